"""Two scenes of one sweep side by side: the paper's experiments (MODEL 10) as the paper models
them (fingers may cross) and as a gripper works (with `finger_collision`), in one report.

`build_comparison(store_1, store_2, out_dir, top_k=None, log=...)` reads two stores of the same
designs, parts and grid (`check_comparable` refuses others) and writes into `out_dir`:

- `best_designs.png`, `best_designs.csv`: per part, the best caging design of each scene and its
  map, side by side; which parts change gripper;
- `caging_vs_tip.png`, `caging_vs_tip.csv`, `representative_designs.csv`: caged versus
  tip-prehension end points per design, each scene on the same axes;
- `manipulation.png`, `manipulation.csv`, `scenario_a_candidates.csv`: Scenario A's best
  candidate against Scenario B per part under each scene, and Scenario B's per-pose values;
- `parameter_usage.png`, `parameter_usage.csv`: Scenario B's parameter usage of each scene;
- with Scenario C in both stores: `friction.png`, `friction.csv`, `friction_candidates.csv`,
  `caging_modulation.csv`: per part A, C and B under each scene, and each scene's caging under
  modulation;
- when a store has been optimised (`sweep optimize`: its results file beside it):
  `optimization_S.png`, `optimization_S.csv` for that scene S (1 or 2): per part G versus x*,
  the verdict and the box-limited constraints, the two grippers on x*'s map;
- when a store has its schedules (`sweep schedule`: its results file beside it):
  `variable_geometry_S.png`, `variable_geometry_S.csv` for that scene S: per part the best
  fixed setting against the best schedule "draw in, then hold" (MODEL 12);
- `against_paper.csv`: every finding of the paper's discussion and conclusion, each scene's
  number(s) and verdict (`sweep.report.paper`);
- `report.md`: every table, the rules, both scenes' settings, a templated reading and which
  scene a designer should trust for hardware;
- `report.json`: what the report was made from (a rerun on the same stores is a no-op).

Every number comes from the stores (or from maps recomputed with a store's own settings). The
single-store tables are `sweep.report`'s; a scene's best design per part is read through one
function, `best_designs` (a refinement of contenders can later change it there).
"""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from .. import __version__
from . import caging, friction, manipulation, optimized, paper, tip, usage, variable
from .caging import best_caging_rows
from .data import (DESIGN_DIMS, MARKER, PARAMETERS, REPORT_FORMAT, TIE_DIGITS, Comparison,
                   StoreData,
                   crossing, csv_bytes, design_text, fmt, identity, md_table,
                   report_files, scene_label, scene_name, screening_error_text)
from .experiment_error import experiment_error_text
from .manipulation import candidate_rows, manipulation_rows
from .stores import open_pair
from .tip import caging_tip_parts, representative_rows
from .usage import usage_rows
from .style import BackgroundPng, png

FILES = ("best_designs.png", "best_designs.csv", "caging_vs_tip.png", "caging_vs_tip.csv",
         "representative_designs.csv", "manipulation.png", "manipulation.csv",
         "scenario_a_candidates.csv", "parameter_usage.png", "parameter_usage.csv",
         "friction.png", "friction.csv", "friction_candidates.csv", "caging_modulation.csv",
         "optimization_1.png", "optimization_1.csv", "optimization_2.png", "optimization_2.csv",
         "variable_geometry_1.png", "variable_geometry_1.csv", "variable_geometry_2.png",
         "variable_geometry_2.csv", "against_paper.csv", "report.md", MARKER)


# ---------------------------------------------------------------------------------------------
# The report
# ---------------------------------------------------------------------------------------------
# ---------------------------------------------------------------------------------------------
# The tables
# ---------------------------------------------------------------------------------------------
# ---------------------------------------------------------------------------------------------
# Two stores
# ---------------------------------------------------------------------------------------------


# ---------------------------------------------------------------------------------------------
# Tables
# ---------------------------------------------------------------------------------------------
def best_designs(st: StoreData) -> list[dict]:
    """A scene's best caging design per part (the one place the comparison reads it)."""
    return best_caging_rows(st)


def gripper(row: dict) -> tuple:
    """What makes a design a gripper: configurations depend on r1, r2 only through R (MODEL
    11), so designs with the same l1, l2, R, w are the same gripper and tie."""
    return (row["l1"], row["l2"], float(f"{row['R']:.{TIE_DIGITS}g}"), row["w"])


def best_rows(st1: StoreData, st2: StoreData) -> list[dict]:
    """Per part: each scene's best design, whether they are the same gripper, and what each
    scene's best design scores in the other scene."""
    b1, b2 = best_designs(st1), best_designs(st2)
    rows = []
    for (ri, mi), x, y in zip(st1.parts(), b1, b2):
        row = dict(r=x["r"], mu=x["mu"])
        for s, best in (("1", x), ("2", y)):
            row.update({f"{k}_{s}": best[k] for k in DESIGN_DIMS + ("R", "Lambda", "n_tied")})
            row[f"n_caged_crossed_{s}"] = best["n_caged_crossed"]
            row[f"n_caged_points_{s}"] = best["n_caged_points"]
            for k in REFINED_KEYS:  # a refined store: the refined best and what backs it
                if k in best:
                    row[f"{k}_{s}"] = best[k]
            row[f"near_tie_{s}"] = best.get("near_tie", [])
        row["same_gripper"] = gripper(x) == gripper(y)
        row["Lambda_2_of_best_1"] = float(st2.per_design("Lambda", ri, mi)[x["design_index"]])
        row["Lambda_1_of_best_2"] = float(st1.per_design("Lambda", ri, mi)[y["design_index"]])
        rows.append(row)
    return rows


REFINED_KEYS = ("refined_caging_area", "refined_error", "margin", "finest_h", "certification")


def best_columns(st1: StoreData, st2: StoreData) -> list[str]:
    """BEST_COLUMNS, with each refined store's refinement columns after its Lambda."""
    cols = list(BEST_COLUMNS)
    for s, st in (("2", st2), ("1", st1)):
        if st.refined:
            at = cols.index(f"Lambda_{s}") + 1
            cols[at:at] = [f"{k}_{s}" for k in REFINED_KEYS]
    return cols


def caging_tip_rows(st1: StoreData, st2: StoreData) -> list[dict]:
    """Every design's caged and tip-prehension counts in both scenes, for the caging-versus-tip
    parts (MODEL 10)."""
    rows = []
    for ri, mi in caging_tip_parts(st1):
        c = [st.per_design("n_caged", ri, mi) for st in (st1, st2)]
        t = [st.per_design("n_tip_prehension", ri, mi) for st in (st1, st2)]
        for k in range(c[0].size):
            rows.append(dict(r=float(st1.r[ri]), mu=float(st1.mu[mi]), **st1.design(k),
                             n_caged_1=int(c[0][k]), n_tip_prehension_1=int(t[0][k]),
                             n_caged_2=int(c[1][k]), n_tip_prehension_2=int(t[1][k])))
    return rows


def representatives(st1: StoreData, st2: StoreData) -> list[dict]:
    """Each scene's three representative designs of the caging-versus-tip parts (the rules of
    `sweep.report.data.representative_designs`)."""
    rows = []
    for s, st in (("1", st1), ("2", st2)):
        for row in representative_rows(st):
            rows.append(dict(scene=s, **row))
    return rows


def caging_tip_summary(st1: StoreData, st2: StoreData) -> list[dict]:
    rows = []
    for ri, mi in caging_tip_parts(st1):
        for s, st in (("1", st1), ("2", st2)):
            caged = st.per_design("n_caged", ri, mi)
            tip = st.per_design("n_tip_prehension", ri, mi)
            corr = (float(np.corrcoef(caged, tip)[0, 1]) if caged.std() > 0 and tip.std() > 0
                    else float("nan"))
            rows.append(dict(r=float(st.r[ri]), mu=float(st.mu[mi]), scene=s,
                             designs_caging=int(np.count_nonzero(caged > 0)),
                             designs_tip=int(np.count_nonzero(tip > 0)),
                             designs_both=int(np.count_nonzero((caged > 0) & (tip > 0))),
                             caged_sum=int(caged.sum()), tip_sum=int(tip.sum()),
                             correlation=corr))
    return rows


def manip_rows(st1: StoreData, st2: StoreData, best1: dict, best2: dict) -> list[dict]:
    """Per part: Scenario A (each scene's best candidate) and Scenario B under each scene."""
    m1, m2 = manipulation_rows(st1, best1), manipulation_rows(st2, best2)
    rows = []
    for x, y in zip(m1, m2):
        rows.append(dict(r=x["r"], mu=x["mu"], a_1=x["a"], b_1=x["b"],
                         b_uncrossed_1=x["b_uncrossed"], winner_1=x["winner"], a_2=y["a"],
                         b_2=y["b"], b_uncrossed_2=y["b_uncrossed"], winner_2=y["winner"]))
    return rows


def usage_pair_rows(st1: StoreData, st2: StoreData) -> list[dict]:
    rows = []
    for x, y in zip(usage_rows(st1), usage_rows(st2)):
        rows.append(dict(r=x["r"], mu=x["mu"], **{f"{p}_1": x[p] for p in PARAMETERS},
                         **{f"{p}_2": y[p] for p in PARAMETERS}))
    return rows


BEST_COLUMNS = (["r", "mu"] + [f"{k}_1" for k in DESIGN_DIMS + ("R", "Lambda")]
                + [f"{k}_2" for k in DESIGN_DIMS + ("R", "Lambda")]
                + ["same_gripper", "Lambda_2_of_best_1", "Lambda_1_of_best_2", "n_tied_1",
                   "n_tied_2", "n_caged_crossed_1", "n_caged_crossed_2"])
CT_COLUMNS = ["r", "mu"] + list(DESIGN_DIMS) + ["n_caged_1", "n_tip_prehension_1", "n_caged_2",
                                                "n_tip_prehension_2"]
CT_SUMMARY_COLUMNS = ["r", "mu", "scene", "designs_caging", "designs_tip", "designs_both",
                      "caged_sum", "tip_sum", "correlation"]
REP_COLUMNS = ["scene", "r", "mu", "kind", "l1", "l2", "r1", "r2", "w", "R", "n_caged",
               "n_tip_prehension", "Lambda"]
CAND_COLUMNS = ["scene", "l1", "l2", "r1", "r2", "R", "a_sum", "parts_positive", "best"]
MANIP_COLUMNS = ["r", "mu", "a_1", "b_1", "b_uncrossed_1", "winner_1", "a_2", "b_2",
                 "b_uncrossed_2", "winner_2"]
USAGE_COLUMNS = (["r", "mu"] + [f"{p}_1" for p in PARAMETERS] + [f"{p}_2" for p in PARAMETERS])


C_CAND_COLUMNS = ["scene"] + friction.C_CAND_COLUMNS


def make_tables(st1: StoreData, st2: StoreData, top_k: int | None,
                log=lambda s: None) -> Comparison:
    rep = Comparison(best=best_rows(st1, st2), caging_tip=caging_tip_rows(st1, st2),
                     caging_tip_summary=caging_tip_summary(st1, st2),
                     representatives=representatives(st1, st2), top_k=top_k)
    if st1.manipulation:
        c1, c2 = candidate_rows(st1, top_k), candidate_rows(st2, top_k)
        rep.candidates = ([dict(scene="1", **c) for c in c1]
                          + [dict(scene="2", **c) for c in c2])
        best1 = next(c for c in c1 if c["best"])
        best2 = next(c for c in c2 if c["best"])
        rep.best_candidates = (best1, best2)
        rep.manipulation = manip_rows(st1, st2, best1, best2)
        rep.usage = usage_pair_rows(st1, st2)
        if st1.scenario_c and st2.scenario_c:
            scenes, cagings = [], []
            for s, st, a_best in (("1", st1, best1), ("2", st2, best2)):
                cands = friction.c_candidate_rows(st, top_k)
                rep.friction_candidates += [dict(scene=s, **c) for c in cands]
                scenes.append(friction.friction_rows(st, a_best,
                                                     next(c for c in cands if c["best"])))
                cagings.append(friction.modulation_rows(
                    st, a_best, lambda m, s=s: log(f"scene {s}: {m}")))
            rep.friction_scenes, rep.modulation_scenes = tuple(scenes), tuple(cagings)
            rep.friction = friction.pair_rows(*scenes)
            rep.modulation = friction.pair_rows(*cagings)
    for tag, st in (("1", st1), ("2", st2)):
        path = optimized.optimized_file(st)
        if path is not None:
            rep.optimized.append((tag, path, optimized.optimization_rows(path)))
        path = variable.schedule_file(st)
        if path is not None:
            rep.variable.append((tag, path, variable.variable_rows(path)))
    rep.paper = paper.pair_rows(paper.finding_rows(st1, top_k), paper.finding_rows(st2, top_k))
    return rep


# ---------------------------------------------------------------------------------------------
# The files
# ---------------------------------------------------------------------------------------------
def comparison_identity(st1: StoreData, st2: StoreData, top_k: int | None) -> dict:
    """What a two-scene report is made from; equal identities make a rerun a no-op."""
    one, two = identity(st1, top_k), identity(st2, top_k)
    return dict(kind="comparison", store=[one["store"], two["store"]],
                config_hash=[one["config_hash"], two["config_hash"]],
                store_created_utc=[one["store_created_utc"], two["store_created_utc"]],
                store_optimized_utc=[one["store_optimized_utc"], two["store_optimized_utc"]],
                store_schedule_utc=[one["store_schedule_utc"], two["store_schedule_utc"]],
                top_k=top_k, manipulation=st1.manipulation, report_version=__version__,
                report_format=REPORT_FORMAT)


def build_comparison(store_1: Path, store_2: Path, out_dir: Path, top_k: int | None = None,
                     log=lambda s: None, pair=None) -> Comparison:
    """Write every file of the two-scene report into `out_dir` (atomically, one by one;
    `report.json` last, so a complete marker means a complete report)."""
    st1, st2, top_k = pair or open_pair(store_1, store_2, top_k)
    rep = make_tables(st1, st2, top_k, log)
    write, finish = report_files(Path(out_dir), comparison_identity(st1, st2, top_k), rep.files)
    # the largest figure first, rendered by a second process while this one does the rest
    best_png = BackgroundPng(caging.pair_figure(st1, st2, rep.best, log))

    write("best_designs.csv", csv_bytes(rep.best, best_columns(st1, st2)))
    write("caging_vs_tip.csv", csv_bytes(rep.caging_tip, CT_COLUMNS))
    write("representative_designs.csv", csv_bytes(rep.representatives, REP_COLUMNS))
    if st1.manipulation:
        write("scenario_a_candidates.csv", csv_bytes(rep.candidates, CAND_COLUMNS))
        write("manipulation.csv", csv_bytes(rep.manipulation, MANIP_COLUMNS))
        write("parameter_usage.csv", csv_bytes(rep.usage, USAGE_COLUMNS))
        write("parameter_usage.png", png(usage.pair_figure(st1, st2, rep.usage)))
        write("manipulation.png", png(manipulation.pair_figure(st1, st2, rep)))
    if rep.friction:
        write("friction_candidates.csv", csv_bytes(rep.friction_candidates, C_CAND_COLUMNS))
        write("friction.csv", csv_bytes(
            rep.friction, ["r", "mu"] + [f"{k}_{s}" for s in ("1", "2")
                                         for k in friction.FRICTION_COLUMNS[2:]]))
        write("caging_modulation.csv", csv_bytes(
            rep.modulation, ["r", "mu"] + [f"{k}_{s}" for s in ("1", "2")
                                           for k in friction.MODULATION_COLUMNS[2:]]))
        write("friction.png", png(friction.pair_figure(st1, st2, rep)))
    for tag, _, rows in rep.optimized:
        st = st1 if tag == "1" else st2
        write(f"optimization_{tag}.csv", csv_bytes(rows, optimized.OPT_COLUMNS))
        write(f"optimization_{tag}.png", png(optimized.optimization_figure(
            st, rows, lambda m, tag=tag: log(f"scene {tag}: {m}"))))
    for tag, path, rows in rep.variable:
        st = st1 if tag == "1" else st2
        write(f"variable_geometry_{tag}.csv", csv_bytes(rows, variable.columns(rows)))
        write(f"variable_geometry_{tag}.png", png(variable.variable_figure(
            st, rows, path, lambda m, tag=tag: log(f"scene {tag}: {m}"))))
    write("against_paper.csv", csv_bytes(rep.paper, paper.PAIR_COLUMNS))
    write("caging_vs_tip.png", png(tip.pair_figure(st1, st2, rep)))
    write("best_designs.png", best_png.result())
    write("report.md", markdown(st1, st2, rep).encode())
    finish()
    return rep


# ---------------------------------------------------------------------------------------------
# report.md
# ---------------------------------------------------------------------------------------------
def _part(row) -> str:
    return f"r = {fmt(row['r'])}, mu = {fmt(row['mu'])}"


def _errors(st1: StoreData, st2: StoreData, outputs: list[str]) -> list[str]:
    """Each scene's numerical error of the named outputs (experiment_error), as report lines."""
    return ["", *[f"Scene {s}: " + experiment_error_text(st, outputs)
                  for s, st in (("1", st1), ("2", st2))]]


def _pct(x, total) -> str:
    return fmt(100.0 * x / total if total else float("nan")) + " %"


def _settings(st: StoreData, tag: str) -> list[str]:
    a, sc = st.attrs, st.scene
    return [f"- Scene {tag}: `{st.path}` (config `{scene_name(st)}`, hash "
            f"`{str(a.get('config_hash'))[:12]}`, written {a.get('created_utc')} by sweep "
            f"{a.get('sweep_version')}): **{scene_label(st)}**; effects on: "
            f"{a.get('effects_on')}; trajectory {sc.accuracy.trajectory}, reconfig_step "
            f"{fmt(sc.accuracy.reconfig_step)}, root_tol {fmt(sc.accuracy.root_tol)}; "
            f"{int(a.get('n_maps', 0)):,} maps in {fmt(a.get('compute_seconds', math.nan))} s of "
            f"compute ({fmt(a.get('wall_seconds', math.nan))} s wall, {a.get('threads', '?')} "
            "thread(s))"]


def trust(st1: StoreData, st2: StoreData, rep: Comparison) -> list[str]:
    """Which scene a designer should trust for hardware, and why (numbers from the tables)."""
    physical = [t for t, st in (("1", st1), ("2", st2)) if not crossing(st)]
    if len(physical) != 1:
        return ["- Both scenes treat finger collision alike (" + scene_label(st1) + "; "
                + scene_label(st2) + "): the choice between them is not about collision."]
    p = physical[0]
    q = "2" if p == "1" else "1"
    stp, stq = (st1, st2) if p == "1" else (st2, st1)
    best = rep.best
    changed = [row for row in best if not row["same_gripper"]]
    crossed = sum(row[f"n_caged_crossed_{q}"] for row in best)
    out = [f"- **Trust scene {p} ({scene_name(stp)}: {scene_label(stp)}) for hardware.** Real "
           "fingers cannot pass through each other; scene "
           f"{q} ({scene_name(stq)}) lets them, so some of its caged points and manipulation "
           "poses are closed by fingers that overlap, which no gripper can do. Scene "
           f"{p} stops the fingers where they first meet (model-notes D14) and drops the poses "
           "where they press on each other from the manipulation metric (D17)."]
    out.append(f"- It matters: the best gripper (l1, l2, R, w) differs on {len(changed)} of "
               f"{len(best)} parts"
               + (": " + "; ".join(_part(row) for row in changed) if changed else "")
               + ".")
    lost = [(row, row[f"Lambda_{p}_of_best_{q}"], row[f"Lambda_{p}"]) for row in changed]
    if lost:
        worst = min(lost, key=lambda t: t[1] / t[2] if t[2] > 0 else 1.0)
        out.append(f"- Built as scene {q} ranks it, the part {_part(worst[0])}'s gripper "
                   f"would cage with Λ = {fmt(worst[1])} in scene {p} instead of the "
                   f"{fmt(worst[2])} its best design there reaches "
                   f"({_pct(worst[1], worst[2])}).")
    if crossed:
        total = sum(row[f"n_caged_points_{q}"] for row in best)
        out.append(f"- In scene {q}'s best designs, {crossed} of {total} caged points "
                   f"({_pct(crossed, total)}) have crossed fingers.")
    if rep.manipulation:
        b = sum(row[f"b_{q}"] for row in rep.manipulation)
        bu = sum(row[f"b_uncrossed_{q}"] for row in rep.manipulation)
        out.append(f"- Of scene {q}'s Scenario B metric summed over parts ({fmt(b)}), "
                   f"{fmt(b - bu)} ({_pct(b - bu, b)}) comes from poses with crossed fingers.")
    out.append(f"- Scene {q} remains the paper's model: use it to reproduce or discuss the "
               "paper's numbers, not to choose a gripper to build.")
    return out


def reading(st1: StoreData, st2: StoreData, rep: Comparison) -> list[str]:
    out = []
    for tag, st in (("1", st1), ("2", st2)):
        lam = [row[f"Lambda_{tag}"] for row in rep.best]
        rs = sorted({fmt(row[f"R_{tag}"]) for row in rep.best}, key=float)
        ws = sorted({fmt(row[f"w_{tag}"]) for row in rep.best}, key=float)
        out.append(f"- Caging, scene {tag} ({scene_name(st)}): best Λ per part from "
                   f"{fmt(min(lam))} to {fmt(max(lam))}, summed {fmt(sum(lam))}; the best "
                   f"designs use R in {{{', '.join(rs)}}} and w in {{{', '.join(ws)}}}.")
    for row in rep.caging_tip_summary:
        out.append(f"- Caging versus tip prehension, part {_part(row)}, scene {row['scene']}: "
                   f"{row['designs_caging']} designs end some points caged, "
                   f"{row['designs_tip']} some in tip prehension, {row['designs_both']} both; "
                   f"caged end points summed over designs {row['caged_sum']}, tip "
                   f"{row['tip_sum']}; correlation {fmt(row['correlation'])}.")
    if rep.manipulation:
        for tag, st, best in (("1", st1, rep.best_candidates[0]),
                              ("2", st2, rep.best_candidates[1])):
            rows = rep.manipulation
            n_a = sum(r[f"winner_{tag}"] == "A" for r in rows)
            n_b = sum(r[f"winner_{tag}"] == "B" for r in rows)
            out.append(f"- Manipulation, scene {tag} ({scene_name(st)}): best Scenario A "
                       f"candidate l1 = {fmt(best['l1'])}, l2 = {fmt(best['l2'])}, r1 = "
                       f"{fmt(best['r1'])}, r2 = {fmt(best['r2'])} (R = {fmt(best['R'])}), "
                       f"metric summed {fmt(best['a_sum'])}; Scenario B summed "
                       f"{fmt(sum(r[f'b_{tag}'] for r in rows))}; A wins on {n_a} parts, B on "
                       f"{n_b}.")
        flips = [r for r in rep.manipulation if r["winner_1"] != r["winner_2"]]
        out.append(f"- Scenario A versus B changes winner on {len(flips)} of "
                   f"{len(rep.manipulation)} parts"
                   + (": " + "; ".join(_part(r) for r in flips) if flips else "") + ".")
        means = []
        for tag in ("1", "2"):
            u = np.array([[row[f"{p}_{tag}"] for p in PARAMETERS] for row in rep.usage])
            ok = ~np.isnan(u).any(axis=1)
            means.append(u[ok].mean(axis=0) if ok.any() else np.full(len(PARAMETERS), np.nan))
        out.append("- Parameter usage (Scenario B, mean over parts with a positive pose), "
                   "scene 1 against scene 2: "
                   + ", ".join(f"{p} {fmt(means[0][i])} / {fmt(means[1][i])}"
                               for i, p in enumerate(PARAMETERS)) + ".")
    if rep.friction:
        out += friction.pair_reading(st1, st2, rep)
    return out


def markdown(st1: StoreData, st2: StoreData, rep: Comparison) -> str:
    sc = st1.scene
    L = [f"# Report: two scenes of {scene_name(st1)} and {scene_name(st2)}", "",
         f"Scene 1 = {scene_name(st1)}: {scene_label(st1)}. Scene 2 = {scene_name(st2)}: "
         f"{scene_label(st2)}. Report by sweep {__version__}; columns `_1` and `_2` are the "
         "scenes'.", "", "## Which scene to trust for hardware", ""]
    L += trust(st1, st2, rep)
    L += ["", "## Settings", ""]
    L += _settings(st1, "1") + _settings(st2, "2")
    L += ["- Same in both (checked): designs "
          + "; ".join(f"{d} = {', '.join(fmt(v) for v in st1.ds[d].values)}"
                      for d in DESIGN_DIMS)
          + f"; parts r = {', '.join(fmt(v) for v in st1.r)}, mu = "
          f"{', '.join(fmt(v) for v in st1.mu)}; grid h = {fmt(sc.h)} ({sc.bounds}); command "
          f"F_left = {fmt(sc.commands[0].f_left)}, F_right = {fmt(sc.commands[0].f_right)}"
          + (f"; Scenario A top-k = {rep.top_k}" if rep.top_k else ""),
          "- All quantities are unitless (model units)."]
    L += ["", "## Rules", "",
          "- Each scene's tables follow the single-store report's rules (`sweep report "
          "STORE`): best design = largest Λ, first in store order among ties at "
          f"{TIE_DIGITS} significant digits; representative designs and Scenario A candidates "
          "as there.",
          "- Same gripper: the same (l1, l2, R = r2/r1, w); designs that differ only in r1, r2 "
          "at equal R close alike (MODEL 11). `Lambda_2_of_best_1`: scene 2's Λ of scene 1's "
          "best design (and the other way round).",
          "- Maps are recomputed with `compute_map` at each store's own settings."]
    if st1.refined or st2.refined:
        L += ["- Refined stores: the best design of a part is the refined one (`sweep report "
              "STORE` says how the contenders are chosen). **Certification:** a part's best "
              "design is certified when its lead over every other contender exceeds the change "
              "of both between the last two grid spacings, so a finer grid is not expected to "
              "change it; otherwise the designs still in the running form the part's near-tie "
              "set, each with its value and error estimate. *Bound widened (N re-admitted)*: the "
              "part's contender bound check failed, and the N designs that could be the best "
              "were re-admitted and recomputed until it held."]
    L += ["", "## 1. Best caging design per part (`best_designs.png`, `best_designs.csv`)", "",
          md_table(rep.best, best_columns(st1, st2))]
    for s, st in (("1", st1), ("2", st2)):
        if not st.refined:
            continue
        L += ["", f"Scene {s}'s final sets (the certified design, or every member of the "
              "near-tie set with its value and error estimate at its finest h):", ""]
        for row in rep.best:
            members = row[f"near_tie_{s}"]
            if not members:
                L.append(f"- {_part(row)}: {row[f'certification_{s}']}.")
                continue
            L.append(f"- {_part(row)}: {row[f'certification_{s}']} at h = "
                     f"{fmt(row[f'finest_h_{s}'])}: "
                     + "; ".join(f"{design_text(m)} {fmt(m['refined_caging_area'])} ± "
                                 f"{fmt(m['refined_error'])}" for m in members) + ".")
        L += ["", f"Scene {s}'s numerical error. " + screening_error_text(st)]
    L += _errors(st1, st2, ["caging_area"])
    L += ["", "## 2. Caging versus tip prehension (`caging_vs_tip.png`, `caging_vs_tip.csv`, "
          "`representative_designs.csv`)", "",
          md_table(rep.caging_tip_summary, CT_SUMMARY_COLUMNS), "",
          md_table(rep.representatives, REP_COLUMNS)]
    L += _errors(st1, st2, ["caging_area", "tip_prehension_area"])
    if rep.manipulation:
        L += ["", "## 3. Scenario A versus Scenario B per part (`manipulation.png`, "
              "`manipulation.csv`, `scenario_a_candidates.csv`)", "",
              "a: the scene's best Scenario A candidate; b: Scenario B; b_uncrossed: B over "
              "poses whose fingers do not cross (under finger_collision the same as b, "
              "model-notes D17).", "",
              md_table(rep.manipulation, MANIP_COLUMNS), "",
              "Best candidates:", "",
              md_table([c for c in rep.candidates if c["best"]], CAND_COLUMNS),
              *_errors(st1, st2, ["manipulation_a_area", "manipulation_b_area"]),
              "", "## 4. Parameter usage, Scenario B (`parameter_usage.png`, "
              "`parameter_usage.csv`)", "", md_table(rep.usage, USAGE_COLUMNS),
              *_errors(st1, st2, ["parameter_usage"])]
    else:
        L += ["", "## 3, 4. Manipulation and parameter usage", "",
              "Skipped: the stores have no manipulation variables (config option "
              "`outputs: {manipulation: true}`)."]
    L += ["", "## 5. Friction modulation, Scenario C (`friction.png`, `friction.csv`, "
          "`friction_candidates.csv`, `caging_modulation.csv`)", ""]
    if rep.friction:
        L += [f"A's gripper whose fingers each switch between the part's μ and μ_low "
              f"(scene 1: {fmt(st1.mu_low)}, scene 2: {fmt(st2.mu_low)}); the palm keeps μ "
              "(MODEL 10; model-notes D31-D34; each scene's single-store report has every "
              "column). a, c, b: A's best candidate, C's best candidate, B; recovered: (c - a) "
              "/ (b - a) where B gains over A.", "",
              md_table(rep.friction, friction.PAIR_FRICTION_COLUMNS), "",
              "Caging under modulation of each scene's best A candidate (caging areas at the "
              "width where each is largest; s: fingers on μ, low: on μ_low, dh: draw in on "
              "μ_low then hold on μ; best_area: the largest over every geometry at the same h):",
              "",
              md_table(rep.modulation, friction.PAIR_MODULATION_COLUMNS), "",
              "Best C candidates:", "",
              md_table([c for c in rep.friction_candidates if c["best"]], C_CAND_COLUMNS)]
    else:
        L += ["Skipped: Scenario C is not in both stores (config option `outputs: "
              "{manipulation: true, scenario_c: {mu_low: 0.0}}`; `make friction`)."]
    for tag, path, rows in rep.optimized:
        st = st1 if tag == "1" else st2
        L += ["", f"## 6. Beyond the grid, `sweep optimize`, scene {tag} ({scene_name(st)}: "
              f"`optimization_{tag}.png`, `optimization_{tag}.csv`)", ""]
        L += optimized.section(rows, path)
    for tag, path, rows in rep.variable:
        st = st1 if tag == "1" else st2
        L += ["", f"## 7. Variable geometry in the grasp, `sweep schedule`, scene {tag} "
              f"({scene_name(st)}: `variable_geometry_{tag}.png`, "
              f"`variable_geometry_{tag}.csv`)", ""]
        L += variable.section(rows, path)
    L += ["", "## 8. Against the paper (`against_paper.csv`)", ""]
    L += paper.section(rep.paper, (scene_name(st1), scene_name(st2)))
    L += ["", "## Reading", ""] + reading(st1, st2, rep)
    L.append("")
    return "\n".join(L)
