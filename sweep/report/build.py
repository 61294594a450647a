"""The report of one results store: the paper's four experiments (MODEL 10) put together.

`build_report(store, out_dir, top_k=None, log=...)` reads a store written by `sweep run` and
writes into `out_dir`:

- `best_caging.png`, `best_caging.csv`: the best caging design of every part, its map (in a
  refined store the refined best, with its margin, finest h and certification, and
  `refinement.csv`: each part's certified design or near-tie set);
- `caging_vs_tip.png`, `caging_vs_tip.csv`, `representative_designs.csv`: caged versus
  tip-prehension end points per design for the smallest and the largest part at the highest
  friction, with three representative designs;
- `manipulation.png`, `manipulation.csv`, `scenario_a_candidates.csv`: Scenario A's best
  candidate against Scenario B for every part, and the per-pose values of one part;
- `parameter_usage.png`, `parameter_usage.csv`: Scenario B's parameter usage;
- with Scenario C (friction modulation, `outputs.scenario_c`): `friction.png`, `friction.csv`,
  `friction_candidates.csv`, `caging_modulation.csv`: per part A, C and B side by side, C's
  candidates, and caging under modulation of A's best candidate;
- with the store's schedules beside it (`sweep schedule`): `variable_geometry.png`,
  `variable_geometry.csv`: per part the best fixed setting against the best schedule "draw in,
  then hold" (MODEL 12);
- `against_paper.csv`: every finding of the paper's discussion and conclusion, the store's
  number(s) and a verdict (`sweep.report.paper`);
- `report.md`: every table, the rules used, the settings, the run time and a templated reading;
- `report.json`: what the report was made from (a rerun on the same store is a no-op).

A store without the manipulation variables (`outputs: {manipulation: true}` not set) gets the
caging parts only, with a note. Every number comes from the store (or from maps recomputed with
the store's own settings); nothing is typed in. Physics is the library's: `compute_map`,
`scenario_a_pose_values`; this module only selects, tabulates and draws.
"""
from __future__ import annotations

import json
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .. import __version__
from ..files import text_bytes
from .caging import (REFINEMENT_COLUMNS, best_caging_figure, best_caging_rows, best_columns,
                     refinement_rows)
from . import caging, friction, manipulation, optimized, paper, tip, usage, variable
from .data import (DESIGN_DIMS, MARKER, PARAMETERS, TIE_DIGITS, StoreData, csv_bytes, design_text,
                   fmt, identity, md_table, part_text, report_files, resolve_top_k,
                   screening_error_text)
from .experiment_error import experiment_error_text
from .manipulation import (CAND_COLUMNS, MANIP_COLUMNS, candidate_rows, manipulation_figure,
                           manipulation_rows, pose_map_part)
from .stores import open_store
from .style import png
from .tip import (CT_COLUMNS, REP_COLUMNS, caging_tip_figure, caging_tip_rows,
                  representative_rows)
from .usage import USAGE_COLUMNS, usage_figure, usage_rows


CAGING_FILES = ("best_caging.png", "best_caging.csv", "caging_vs_tip.png", "caging_vs_tip.csv",
                "representative_designs.csv", "refinement.csv")


MANIPULATION_FILES = ("manipulation.png", "manipulation.csv", "scenario_a_candidates.csv",
                      "parameter_usage.png", "parameter_usage.csv")


FRICTION_FILES = ("friction.png", "friction.csv", "friction_candidates.csv",
                  "caging_modulation.csv")


OPTIMIZATION_FILES = ("optimization.png", "optimization.csv")


VARIABLE_FILES = ("variable_geometry.png", "variable_geometry.csv")


ALL_FILES = (CAGING_FILES + MANIPULATION_FILES + FRICTION_FILES + OPTIMIZATION_FILES
             + VARIABLE_FILES + ("against_paper.csv", "report.md", MARKER))


@dataclass
class Report:
    """Tables of a report (rows of plain values), as written."""

    best: list[dict]
    caging_tip: list[dict]
    representatives: list[dict]
    top_k: int | None = None
    candidates: list[dict] = field(default_factory=list)
    manipulation: list[dict] = field(default_factory=list)
    usage: list[dict] = field(default_factory=list)
    pose_part: dict | None = None
    friction_candidates: list[dict] = field(default_factory=list)
    friction: list[dict] = field(default_factory=list)
    modulation: list[dict] = field(default_factory=list)
    files: list[str] = field(default_factory=list)
    optimized: list[dict] = field(default_factory=list)
    optimized_path: Path | None = None
    variable: list[dict] = field(default_factory=list)
    variable_path: Path | None = None
    paper: list[dict] = field(default_factory=list)


def make_tables(st: StoreData, top_k: int | None, log=lambda s: None) -> Report:
    rep = Report(best=best_caging_rows(st), caging_tip=caging_tip_rows(st),
                 representatives=representative_rows(st), top_k=top_k)
    if st.manipulation:
        rep.candidates = candidate_rows(st, top_k)
        best = next(c for c in rep.candidates if c["best"])
        rep.manipulation = manipulation_rows(st, best)
        rep.usage = usage_rows(st)
        rep.pose_part = rep.manipulation[pose_map_part(rep.manipulation)]
        if st.scenario_c:
            rep.friction_candidates = friction.c_candidate_rows(st, top_k)
            c_best = next(c for c in rep.friction_candidates if c["best"])
            rep.friction = friction.friction_rows(st, best, c_best)
            rep.modulation = friction.modulation_rows(st, best, log)
    rep.optimized_path = optimized.optimized_file(st)
    if rep.optimized_path is not None:
        rep.optimized = optimized.optimization_rows(rep.optimized_path)
    rep.variable_path = variable.schedule_file(st)
    if rep.variable_path is not None:
        rep.variable = variable.variable_rows(rep.variable_path)
    rep.paper = paper.finding_rows(st, top_k)
    return rep


def build_report(store: Path, out_dir: Path, top_k: int | None = None, log=lambda s: None,
                 st: StoreData | None = None) -> Report:
    """Write every file of the report into `out_dir` (atomically, one by one; `report.json`
    last, so a complete marker means a complete report)."""
    st = st or open_store(Path(store))
    top_k = resolve_top_k(st, top_k)
    rep = make_tables(st, top_k, log)
    write, finish = report_files(Path(out_dir), identity(st, top_k), rep.files)

    write("best_caging.csv", csv_bytes(rep.best, best_columns(st)))
    if st.refined:
        write("refinement.csv", csv_bytes(refinement_rows(rep.best), REFINEMENT_COLUMNS))
    write("caging_vs_tip.csv", csv_bytes(rep.caging_tip, CT_COLUMNS))
    write("representative_designs.csv", csv_bytes(rep.representatives, REP_COLUMNS))
    if st.manipulation:
        write("scenario_a_candidates.csv", csv_bytes(rep.candidates, CAND_COLUMNS))
        write("manipulation.csv", csv_bytes(rep.manipulation, MANIP_COLUMNS))
        write("parameter_usage.csv", csv_bytes(rep.usage, USAGE_COLUMNS))
        write("parameter_usage.png", png(usage_figure(rep.usage)))
        best = next(c for c in rep.candidates if c["best"])
        write("manipulation.png", png(manipulation_figure(
            st, rep.manipulation, best, rep.manipulation.index(rep.pose_part), log)))
    if rep.friction:
        write("friction_candidates.csv", csv_bytes(rep.friction_candidates,
                                                   friction.C_CAND_COLUMNS))
        write("friction.csv", csv_bytes(rep.friction, friction.FRICTION_COLUMNS))
        write("caging_modulation.csv", csv_bytes(rep.modulation, friction.MODULATION_COLUMNS))
        write("friction.png", png(friction.friction_figure(
            st, rep.friction, rep.modulation, next(c for c in rep.candidates if c["best"]),
            next(c for c in rep.friction_candidates if c["best"]))))
    if rep.optimized:
        write("optimization.csv", csv_bytes(rep.optimized, optimized.OPT_COLUMNS))
        write("optimization.png", png(optimized.optimization_figure(st, rep.optimized, log)))
    if rep.variable:
        write("variable_geometry.csv", csv_bytes(rep.variable, variable.columns(rep.variable)))
        write("variable_geometry.png", png(variable.variable_figure(st, rep.variable,
                                                                    rep.variable_path, log)))
    write("against_paper.csv", csv_bytes(rep.paper, paper.COLUMNS))
    write("best_caging.png", png(best_caging_figure(st, rep.best, log)))
    write("caging_vs_tip.png", png(caging_tip_figure(st, rep.representatives, log)))
    write("report.md", text_bytes(markdown(st, rep)))
    finish()
    return rep


def reading(st: StoreData, rep: Report) -> list[str]:
    """The templated reading, experiment by experiment: every number from the tables."""
    out = caging.reading(st, rep) + tip.reading(st, rep)
    if st.manipulation:
        out += manipulation.reading(st, rep) + usage.reading(st, rep)
    if rep.friction:
        out += friction.reading(st, rep)
    return out


def comparison(st: StoreData, rep: Report) -> list[str]:
    """Where the numbers meet or differ from what the paper says (its methods file states its
    claims in the abstract; it has no tables of results to compare with)."""
    a = st.attrs
    out = [f"- Run time: the paper computed its 86,400 maps in about 10 hours on 256 cores; this "
           f"store's {int(a.get('n_maps', 0)):,} maps took "
           f"{fmt(a.get('compute_seconds', math.nan))}"
           f" s of compute ({fmt(a.get('wall_seconds', math.nan))} s wall) on "
           f"{a.get('threads', '?')} thread(s)."]
    best = rep.best
    n_r = len(set(fmt(r["R"]) for r in best))
    out.append(
        "- The paper (abstract): \"a variable transmission ratio ... is needed to draw parts "
        "into a cage or to maintain a tip prehension grasp\". Here the best caging designs "
        f"use {n_r} different R over {len(best)} parts"
        + (", so no single R is best for every part, in line with the claim."
           if n_r > 1 else ", so one R is best for every part: this does not support the claim "
           "for caging alone.")
        + " Caging-focused versus tip-focused R per part: "
        + "; ".join(
            f"r = {fmt(r)}: {fmt(c['R'])} versus {fmt(t['R'])}"
            for r, c, t in (
                (row["r"], row,
                 next(x for x in rep.representatives if x["r"] == row["r"]
                      and x["mu"] == row["mu"] and x["kind"] == "tip focused"))
                for row in rep.representatives if row["kind"] == "caging focused"))
        + ".")
    if st.manipulation:
        u = np.array([[row[p] for p in PARAMETERS] for row in rep.usage])
        ok = ~np.isnan(u).any(axis=1)
        if ok.any():
            mean = u[ok].mean(axis=0)
            rank = int(np.flatnonzero(np.argsort(-mean, kind="stable") == 0)[0]) + 1
            out.append(
                "- The paper (abstract): \"a variable palm width is needed to manipulate parts "
                f"of varying scales\". Here w's mean usage is {fmt(mean[0])}, rank {rank} of 5 "
                "parameters" + (" (the most used), in line with the claim."
                                if rank == 1 else "; used more: " + ", ".join(
                                    f"{PARAMETERS[i]} ({fmt(mean[i])})"
                                    for i in np.argsort(-mean, kind="stable")[:rank - 1])
                                + "."))
        rows = rep.manipulation
        n_b = sum(r["winner"] == "B" for r in rows)
        out.append(
            "- The paper compares Scenario A's best design with Scenario B for all sixteen "
            "parts but its methods file states no outcome. Here B (variable geometry, fixed "
            f"tension) wins on {n_b} of {len(rows)} parts. The paper's metric scales each force "
            "by the caging score; this model uses S_geo (the score without the stability "
            "requirement, MODEL 10), since S vanishes out of equilibrium: the two are not the "
            "same number.")
    return out


def friction_section(st: StoreData, rep: Report) -> list[str]:
    """Section 5 of report.md: Scenario C's tables, or why there are none."""
    if not rep.friction:
        return ["Skipped: this store has no Scenario C. Rerun the sweep with `outputs: "
                "{manipulation: true, scenario_c: {mu_low: 0.0}}` in its config (`make "
                "friction` runs the paper's two scenes so)."]
    c_best = next(c for c in rep.friction_candidates if c["best"])
    return [
        f"A's gripper whose fingers each switch between the part's μ and μ_low = "
        f"{fmt(st.mu_low)} (the palm keeps μ): per pose the hull over every palm width, command "
        "and friction pair (μ_left, μ_right) in {μ_low, μ}² (MODEL 10; model-notes D31-D34). "
        f"C's candidates are A's ({len(rep.friction_candidates)}); the best by C's metric "
        f"summed over parts is l1 = {fmt(c_best['l1'])}, l2 = {fmt(c_best['l2'])}, r1 = "
        f"{fmt(c_best['r1'])}, r2 = {fmt(c_best['r2'])} ({fmt(c_best['c_sum'])}).", "",
        "Per part (a: A's best candidate; c: C's best candidate; c_of_a_best: C of A's best "
        "candidate; b: B; recovered: (c - a) / (b - a) where B gains over A; verdict: what "
        "switching friction does against variable geometry, D34):", "",
        md_table(rep.friction, friction.FRICTION_COLUMNS), "",
        "Caging under modulation, A's best candidate (every quantity at the palm width where "
        "it is largest, w_*; Λ and caging area Λ h²; s: both fingers on the part's μ, low: "
        "both on μ_low with the palm on μ, dh: draw in on μ_low, then hold on μ; n_dh: the "
        "starts that count; best_area: the part's largest caging area over every geometry at "
        "the same h, D33):", "",
        md_table(rep.modulation, friction.MODULATION_COLUMNS), "",
        "C's candidates, largest summed metric first (at most 20 here; all in the CSV):", "",
        md_table(sorted(rep.friction_candidates, key=lambda c: -c["c_sum"])[:20],
                 friction.C_CAND_COLUMNS)]


def markdown(st: StoreData, rep: Report) -> str:
    a = st.attrs
    sc = st.scene
    L = [f"# Report: {a.get('name')} ({st.path.name})", ""]
    L.append(f"Store `{st.path}`, config `{str(a.get('config_hash'))[:12]}`, written "
             f"{a.get('created_utc')} by sweep {a.get('sweep_version')}; report by sweep "
             f"{__version__}.")
    L.append("")
    L.append("## Settings")
    L.append("")
    L += ["- Designs: " + "; ".join(f"{d} = {', '.join(fmt(v) for v in st.ds[d].values)}"
                                     for d in DESIGN_DIMS),
          f"- Parts: r = {', '.join(fmt(v) for v in st.r)}; mu = "
          f"{', '.join(fmt(v) for v in st.mu)}",
          f"- Command: F_left = {fmt(sc.commands[0].f_left)}, F_right = "
          f"{fmt(sc.commands[0].f_right)}; grid h = {fmt(sc.h)} ({sc.bounds}); theta2 limits "
          f"[{fmt(sc.limits.theta2_min_deg)}, {fmt(sc.limits.theta2_max_deg)}] deg; "
          f"reconfig_step {fmt(sc.accuracy.reconfig_step)}, root_tol "
          f"{fmt(sc.accuracy.root_tol)}, trajectory {sc.accuracy.trajectory}",
          f"- Effects on: {a.get('effects_on')}",
          f"- Maps: {int(a.get('n_maps', 0)):,}; run time: compute "
          f"{fmt(a.get('compute_seconds', math.nan))} s, wall "
          f"{fmt(a.get('wall_seconds', math.nan))}"
          f" s, {a.get('threads', '?')} thread(s)",
          "- Manipulation metric: "
          + (f"yes; Scenario A top-k = {rep.top_k} (store attribute "
             f"manipulation_scenario_a_top_k = {a.get('manipulation_scenario_a_top_k')})"
             + (f"; Scenario C (friction modulation) with μ_low = {fmt(st.mu_low)}"
                if st.scenario_c else "; no Scenario C")
             if st.manipulation else
             "**not in this store** (config option `outputs: {manipulation: true}` was not set):"
             " the manipulation and parameter-usage parts are skipped"),
          "- All quantities are unitless (model units: lengths, tensions and forces per unit "
          "tendon tension)."]
    if st.refined:
        counts = json.loads(a["refine_counts"]) if isinstance(a.get("refine_counts"), str) \
            else a.get("refine_counts", {})
        L.append(f"- Refinement: up to {a.get('refine_levels')} levels (h down to "
                 f"{fmt(sc.h / 2 ** int(a.get('refine_levels', 0)))}), contender bound per "
                 f"part at most {fmt(a.get('refine_bound'))} of the best screened caging area, "
                 f"at least {a.get('refine_min_contenders')} contenders; "
                 f"{counts.get('certified', 0)} "
                 f"parts certified, {counts.get('near_tie', 0)} near-tie sets, "
                 f"{counts.get('not_refined', 0)} not refined; compute "
                 f"{fmt(a.get('refine_compute_seconds', math.nan))} s "
                 f"({fmt(100 * a.get('refine_fraction_of_screening', math.nan))} % of the "
                 "screening's)")
    L += ["", "## Rules", ""]
    if st.refined:
        L += ["- Best caging design of a part (refined store): the screening ranks every design "
              "by its caging area at h; the contenders (the min_contenders best, and every "
              "design the change of those from h to h/2 says could still be the best, at most "
              "those within the bound of the part's best; equal-R designs, same l1, l2, w and "
              "R, give the same map and count once, `tied`) are "
              "recomputed at h/2, h/4, ..., and a contender leaves the running once its value "
              "plus its error estimate (its change from the level before) falls below the best's "
              "value minus the best's error estimate. **Certification:** a part is certified "
              "when the best design's lead over every other contender exceeds the change "
              "between the last two levels of both, so that a finer grid is not expected to "
              "change it; at the level cap the designs still in the running are the part's "
              "near-tie set, each reported with its value and error estimate.",
              "- *Bound widened*: the contender bound is checked per part; it holds when the "
              "best's refined value minus its error exceeds every non-contender's screened value "
              "plus the largest change any contender showed from screening to its finest level, "
              "and every eliminated contender's value plus error at its last level. Where it "
              "does not, the designs that could be the best are re-admitted, recomputed at the "
              "levels the part reached and separated again (the levels go on if several are "
              "left below the cap), until it holds; the certification column says how many "
              "designs were re-admitted. (*Bound not confirmed* appears only for a store refined "
              "by an earlier version: `sweep refine STORE` repairs it.)"]
    L += ["- Best caging design of a part" + (" that is not refined" if st.refined else "")
          + ": largest Λ over (l1, l2, r1, r2, w); ties are "
          "expected (configurations depend on the radii only through R = r2/r1), broken by the "
          "first design in store order (l1, l2, r1, r2, w, last fastest); `tied` counts the "
          f"designs with that Λ. Λ is compared at {TIE_DIGITS} significant digits: equal-R "
          "designs sum the same scores in another order, which changes the last bits.",
          "- Caging versus tip prehension: the smallest and the largest part radius at the "
          "highest friction. Representative designs: *caging focused* = most caged end points "
          "(n_caged), fewer tip-prehension end points breaking ties; *tip focused* = most "
          "tip-prehension end points, fewer caged breaking ties; *compromise* = largest "
          "min(n_caged / the part's largest n_caged, n_tip / the part's largest n_tip), then "
          "the largest sum of the two fractions; remaining ties by store order.",
          "- The maps drawn are recomputed with `compute_map` at the store's settings; the "
          "gripper is drawn at the caged end point that contributes most to Λ (else the "
          "stable point of lowest energy, else the centre of P_j)."]
    if st.manipulation:
        L += ["- Scenario A candidates: the (l1, l2, r1, r2) of the top-k caging designs (by Λ, "
              "store order among ties; in a refined store by the refined ranking: the final set, "
              "then the other contenders, then the rest, each by caging area at the finest h "
              "reached) of every part, duplicates merged. Best candidate: the "
              "largest Scenario A metric summed over all parts (first in store order among "
              f"ties; both compared at {TIE_DIGITS} significant digits). Per part, the "
              "scenario with the larger metric wins; equal metrics are a "
              "tie.",
              "- Per-pose maps: the part with the largest min(A, B) of the best candidate's A "
              "and B, so that both maps show something (first in table order among ties)."]
    L += ["", "## 1. Best caging design per part (`best_caging.png`, `best_caging.csv`)", "",
          md_table(rep.best, best_columns(st),
                   [{"n_tied": "tied"}.get(c, c) for c in best_columns(st)])]
    if st.refined:
        L += ["", "Columns Lambda to tied are the screening's (grid h above); refined_caging_area "
              "and refined_error are at finest_h; margin is the best's lead over the runner-up "
              "there. Each part's final set (`refinement.csv`: the certified design, or every "
              "member of the near-tie set with its value and error estimate):", ""]
        for row in rep.best:
            if row["certification"] == "not refined":
                L.append(f"- {part_text(row)}: not refined (no design cages at the screening "
                         "spacing).")
                continue
            L.append(f"- {part_text(row)}: {row['certification']} at h = {fmt(row['finest_h'])}: "
                     + "; ".join(f"{design_text(m)} {fmt(m['refined_caging_area'])} ± "
                                 f"{fmt(m['refined_error'])}" for m in row["near_tie"]) + ".")
        L += ["", "Numerical error. " + screening_error_text(st)]
    L += ["", experiment_error_text(st, ["caging_area"])]
    L += ["", "## 2. Caging versus tip prehension (`caging_vs_tip.png`, "
          "`representative_designs.csv`; every design's counts in `caging_vs_tip.csv`)", "",
          md_table(rep.representatives, REP_COLUMNS), "",
          experiment_error_text(st, ["caging_area", "tip_prehension_area"])]
    if st.manipulation:
        best_c = next(c for c in rep.candidates if c["best"])
        L += ["", "## 3. In-hand manipulation (`manipulation.png`, `manipulation.csv`, "
              "`scenario_a_candidates.csv`)", "",
              f"Best Scenario A candidate of {len(rep.candidates)}: l1 = {fmt(best_c['l1'])}, "
              f"l2 = {fmt(best_c['l2'])}, r1 = {fmt(best_c['r1'])}, r2 = {fmt(best_c['r2'])}; "
              f"metric summed over parts {fmt(best_c['a_sum'])} (times h^2: "
              f"{fmt(best_c['a_area_sum'])}).", "",
              "A and B per part (a, b: metric; *_area: times h^2; b_uncrossed: B without "
              "crossed-finger poses; b_poses: poses with a positive B value):", "",
              md_table(rep.manipulation, MANIP_COLUMNS), "",
              f"Per-pose maps drawn for part {part_text(rep.pose_part)}.", "",
              "Candidates, largest summed metric first (at most 20 here; all in the CSV):", "",
              md_table(sorted(rep.candidates, key=lambda c: -c["a_sum"])[:20], CAND_COLUMNS),
              "", experiment_error_text(st, ["manipulation_a_area", "manipulation_b_area"]),
              "", "## 4. Parameter usage, Scenario B (`parameter_usage.png`, "
              "`parameter_usage.csv`)", "",
              md_table(rep.usage, USAGE_COLUMNS), "",
              experiment_error_text(st, ["parameter_usage"])]
    else:
        L += ["", "## 3, 4. Manipulation and parameter usage", "",
              "Skipped: this store has no manipulation variables. Rerun the sweep with "
              "`outputs: {manipulation: true}` in its config."]
    L += ["", "## 5. Friction modulation, Scenario C (`friction.png`, `friction.csv`, "
          "`friction_candidates.csv`, `caging_modulation.csv`)", ""]
    L += friction_section(st, rep)
    if rep.optimized:
        L += ["", "## 6. Beyond the grid, `sweep optimize` (`optimization.png`, "
              "`optimization.csv`)", ""]
        L += optimized.section(rep.optimized, rep.optimized_path)
    if rep.variable:
        L += ["", "## 7. Variable geometry in the grasp, `sweep schedule` "
              "(`variable_geometry.png`, `variable_geometry.csv`)", ""]
        L += variable.section(rep.variable, rep.variable_path)
    L += ["", "## 8. Against the paper (`against_paper.csv`)", ""] + paper.section(rep.paper)
    L += ["", "## Reading", ""] + reading(st, rep)
    L += ["", "## Compared with the paper", ""] + comparison(st, rep)
    L.append("")
    return "\n".join(L)
