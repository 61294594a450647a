"""Experiment 5, friction modulation (MODEL 10, Scenario C), the paper's future work beside
variable geometry (`friction.csv`, `friction_candidates.csv`, `caging_modulation.csv`,
`friction.png`): per part Scenario A (one gripper: palm width and tendons), C (A's gripper whose
fingers each switch between the part's mu and a low friction) and B (every geometry) side by
side; and caging under modulation for A's best candidate: Lambda with both fingers on the low
friction and on the part's, and "draw in, then hold" (model-notes D32-D34)."""
from __future__ import annotations

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from ..compute.maps import draw_in_then_hold, scene_map
from .data import (CANDIDATE_DIMS, StoreData, candidate_metric_rows, crossing, fmt, part_text,
                   scene_name, tie_key)
from .style import NOTE_UNITLESS, SCENE_COLOURS

#: A, C and B in every figure of this experiment
SCENARIO_COLOURS = {"A": "#1f77b4", "C": "#2ca02c", "B": "#d62728"}
#: the three ways to cage of the caging-under-modulation table, in its figure
CAGING_COLOURS = {"s": "#1f77b4", "low": "#bcbd22", "dh": "#9467bd"}


def _same(x: float, y: float) -> bool:
    """Equal at the report's TIE_DIGITS (sums of the same hulls in another order differ in the
    last bits)."""
    return bool(tie_key([x])[0] == tie_key([y])[0])


# ---------------------------------------------------------------------------------------------
# Scenario C per part, against A and B
# ---------------------------------------------------------------------------------------------
def c_candidate_rows(st: StoreData, top_k: int) -> list[dict]:
    """Scenario C's candidates (Scenario A's: the top-k caging designs of every part, merged)
    with C's and A's metrics summed over all parts; the best by C (largest sum, first in store
    order among ties) is flagged."""
    a = st.ds["manipulation_a"].transpose(*CANDIDATE_DIMS, "r", "mu").values
    rows = candidate_metric_rows(st, top_k, "c")
    for row in rows:
        row["a_sum"] = float(np.nansum(a[row["index"]]))
    return rows


#: What friction modulation does for a part where variable geometry gains over A ...
WHERE_B_GAINS = ("C matches B", "C beats B", "C recovers part", "C adds nothing")
#: ... and where it does not
WHERE_B_DOES_NOT = ("C gains, B not", "neither gains")


def b_gains(a: float, b: float) -> bool:
    """Variable geometry (B) gains over one gripper (A) on the part."""
    return b > a and not _same(a, b)


def verdict(a: float, c: float, b: float) -> str:
    """What friction modulation does for one part, against variable geometry (D34). C's best
    candidate may be another gripper than A's, below A on a part: that adds nothing either."""
    c_gains = c > a and not _same(c, a)
    if b_gains(a, b):
        if _same(c, b):
            return "C matches B"
        if c > b:
            return "C beats B"
        return "C recovers part" if c_gains else "C adds nothing"
    return "C gains, B not" if c_gains else "neither gains"


def friction_rows(st: StoreData, a_best: dict, c_best: dict) -> list[dict]:
    """Per part: A (A's best candidate), C (C's best candidate; also C of A's best candidate)
    and B; B's gain over A and the share of it that C recovers, (C - A) / (B - A) where B
    gains (D34)."""
    a = st.ds["manipulation_a"].transpose(*CANDIDATE_DIMS, "r", "mu").values[a_best["index"]]
    c = st.ds["manipulation_c"].transpose(*CANDIDATE_DIMS, "r", "mu").values
    c_of_a = c[a_best["index"]]
    c = c[c_best["index"]]
    rows = []
    for ri, mi in st.parts():
        va, vc, vb = float(a[ri, mi]), float(c[ri, mi]), float(st.ds["manipulation_b"]
                                                              .values[ri, mi])
        rows.append(dict(r=float(st.r[ri]), mu=float(st.mu[mi]), a=va, c=vc, b=vb,
                         c_of_a_best=float(c_of_a[ri, mi]), c_gain=vc - va, b_gain=vb - va,
                         recovered=((vc - va) / (vb - va) if b_gains(va, vb)
                                    else float("nan")),
                         verdict=verdict(va, vc, vb)))
    return rows


def share_text(rows: list[dict]) -> str:
    """How much of B's gain over A C recovers, in words."""
    share = recovered_share(rows)
    if share != share:
        return "B gains over A on no part (nothing to recover)"
    return f"C recovers {fmt(100 * share)} % of B's gain over A"


def recovered_share(rows: list[dict]) -> float:
    """The share of B's gain over A, summed over the parts where B gains, that C recovers: each
    part's recovery capped at its own gain (a part where C beats B does not cover another)."""
    gaining = [r for r in rows if r["verdict"] in WHERE_B_GAINS]
    gain = sum(r["b_gain"] for r in gaining)
    got = sum(min(max(r["c_gain"], 0.0), r["b_gain"]) for r in gaining)
    return got / gain if gain > 0 else float("nan")


C_CAND_COLUMNS = ["l1", "l2", "r1", "r2", "R", "c_sum", "c_area_sum", "a_sum", "parts_positive",
                  "best"]
FRICTION_COLUMNS = ["r", "mu", "a", "c", "b", "c_of_a_best", "c_gain", "b_gain", "recovered",
                    "verdict"]


# ---------------------------------------------------------------------------------------------
# Caging under modulation, A's best candidate
# ---------------------------------------------------------------------------------------------
def _argmax(values) -> int:
    """The first of the largest (at TIE_DIGITS)."""
    return int(np.argmax(tie_key(values)))


def modulation_rows(st: StoreData, a_best: dict, log=lambda s: None) -> list[dict]:
    """Per part, A's best candidate at every palm width of the sweep, the fingers on the low
    friction (palm on the part's) and on the part's friction: Lambda of each, and of "draw in,
    then hold" (`compute.maps.draw_in_then_hold`); each reported at the width where it is
    largest (first width among ties), with its caging area (times h^2) (D33). `best_area`: the
    part's largest caging area over every geometry at the same spacing (the screening's), for
    comparison."""
    sc = st.scene
    mu_low = st.mu_low
    h2 = sc.h * sc.h
    rows = []
    for ri, mi in st.parts():
        r, mu = float(st.r[ri]), float(st.mu[mi])
        log(f"caging under modulation: part r = {r:g}, mu = {mu:g}")
        lam = {"s": [], "low": [], "dh": []}
        n_dh = []
        for w in sc.widths:
            design = dict(**{d: a_best[d] for d in CANDIDATE_DIMS}, w=float(w))
            hold = scene_map(sc, design, r, mu)
            draw = scene_map(sc, design, r, mu, mu_left=mu_low, mu_right=mu_low)
            dh, n = draw_in_then_hold(draw, hold)
            lam["s"].append(float(hold.attrs["Lambda"]))
            lam["low"].append(float(draw.attrs["Lambda"]))
            lam["dh"].append(dh)
            n_dh.append(n)
        row = dict(r=r, mu=mu, mu_low=mu_low)
        for key, values in lam.items():
            k = _argmax(values)
            row.update({f"w_{key}": float(sc.widths[k]), f"lambda_{key}": values[k],
                        f"area_{key}": values[k] * h2})
        row["n_dh"] = n_dh[_argmax(lam["dh"])]
        # the screening's largest, on the grid of these maps (a refined store's best design is
        # ranked on finer grids, where its screened value need not be the largest)
        row["best_area"] = float(np.nanmax(st.per_design("caging_area", ri, mi)))
        rows.append(row)
    return rows


MODULATION_COLUMNS = ["r", "mu", "mu_low", "w_s", "lambda_s", "area_s", "w_low", "lambda_low",
                      "area_low", "w_dh", "lambda_dh", "area_dh", "n_dh", "best_area"]


# ---------------------------------------------------------------------------------------------
# Figure and reading
# ---------------------------------------------------------------------------------------------
def _bars(ax, rows, series, width, log_scale=True, labels=True):
    """Grouped bars per part: `series` = (key, colour, hatch, label) each; values printed."""
    xs = np.arange(len(rows))
    allv = np.array([row[k] for row in rows for k, *_ in series], dtype=float)
    positive = allv[allv > 0]
    floor = positive.min() / 3 if positive.size else 1e-3
    n = len(series)
    for s, (key, colour, hatch, label) in enumerate(series):
        off = (s - (n - 1) / 2) * width
        vals = np.array([row[key] for row in rows], dtype=float)
        ax.bar(xs + off, np.where(vals > 0, vals, np.nan), width=width, color=colour,
               hatch=hatch, edgecolor="white", label=label)
        if labels:
            for x, v in zip(xs + off, vals):
                ax.text(x, max(v, floor), fmt(v), rotation=90, ha="center", va="bottom",
                        fontsize=6.5)
    if log_scale:
        ax.set_yscale("log")
        ax.set_ylim(floor, (positive.max() if positive.size else 1.0) * 30)
    ax.set_xlim(-0.7, len(rows) - 0.3)
    ax.grid(axis="y", alpha=0.3)
    return xs


def friction_figure(st: StoreData, rows: list[dict], caging: list[dict], a_best: dict,
                    c_best: dict) -> Figure:
    """Top: per part A, C and B (log scale, values printed); bottom: caging under modulation of
    A's best candidate: caging area on the part's friction, on the low one, and draw in, then
    hold; with the part's best caging area over every geometry as a line."""
    fig = Figure(figsize=(17, 12.5), dpi=90, layout="constrained")
    FigureCanvasAgg(fig)
    top, bottom = fig.subfigures(2, 1, height_ratios=[1.15, 1])
    ax = top.subplots()
    cand = lambda c: f"l1={c['l1']:g} l2={c['l2']:g} R={fmt(c['R'])}"  # noqa: E731
    xs = _bars(ax, rows, [("a", SCENARIO_COLOURS["A"], "", f"A, best candidate ({cand(a_best)}):"
                           " w and tendons varied"),
                          ("c", SCENARIO_COLOURS["C"], "", f"C, best candidate ({cand(c_best)}):"
                           f" A's and each finger on μ or μ_low = {fmt(st.mu_low)}"),
                          ("b", SCENARIO_COLOURS["B"], "", "B: every geometry, F_left = "
                           "F_right = 1")], 0.27)
    ax.set_xticks(xs, [f"r={row['r']:g}\nμ={row['mu']:g}\n{row['verdict']}" for row in rows],
                  fontsize=7.5)
    ax.set_ylabel("manipulation metric (sum over poses of the inscribed radius;\nunitless, "
                  "log scale, 0 not drawn)")
    ax.set_xlabel("part (radius r, friction μ); what friction modulation does against variable "
                  "geometry (D34)")
    ax.legend(fontsize=9, loc="upper right")
    top.suptitle(f"{scene_name(st)}: friction modulation (Scenario C) beside variable geometry "
                 f"(B) and one gripper (A): {share_text(rows)}", fontsize=11)
    ax2 = bottom.subplots()
    xs = _bars(ax2, caging, [("area_s", CAGING_COLOURS["s"], "", "fingers on the part's μ"),
                             ("area_low", CAGING_COLOURS["low"], "",
                              f"fingers on μ_low = {fmt(st.mu_low)} (palm μ)"),
                             ("area_dh", CAGING_COLOURS["dh"], "//",
                              "draw in on μ_low, then hold on μ")], 0.27, log_scale=False,
               labels=False)
    ax2.plot(xs, [row["best_area"] for row in caging], "k_", markersize=22, mew=2,
             label="the part's largest over every geometry (μ)")
    ax2.set_xticks(xs, [f"r={row['r']:g}\nμ={row['mu']:g}" for row in caging], fontsize=7.5)
    ax2.set_ylabel("caging area Λ h² (unitless), each at its best palm width")
    ax2.set_xlabel("part (radius r, friction μ)")
    ax2.legend(fontsize=9, loc="upper right")
    bottom.suptitle(f"Caging under modulation, A's best candidate ({cand(a_best)}), best palm "
                    f"width for each bar; {NOTE_UNITLESS}", fontsize=11)
    return fig


def _parts(rows) -> str:
    return "; ".join(part_text(r) for r in rows) if rows else "none"


def reading(st: StoreData, rep) -> list[str]:
    """The reading of experiment 5: whether switching friction is an alternative to variable
    geometry in this model, for which parts, and where not (every number from the tables)."""
    rows, caging = rep.friction, rep.modulation
    c_best = next(c for c in rep.friction_candidates if c["best"])
    a_best = next(c for c in rep.candidates if c["best"])
    by = {v: [r for r in rows if r["verdict"] == v] for v in WHERE_B_GAINS + WHERE_B_DOES_NOT}
    gaining = [r for r in rows if r["verdict"] in WHERE_B_GAINS]
    sums = {k: sum(r[k] for r in rows) for k in ("a", "c", "b")}
    out = [
        f"- Friction modulation (Scenario C, μ_low = {fmt(st.mu_low)}): the best C candidate is "
        f"l1 = {fmt(c_best['l1'])}, l2 = {fmt(c_best['l2'])}, r1 = {fmt(c_best['r1'])}, r2 = "
        f"{fmt(c_best['r2'])} (R = {fmt(c_best['R'])})"
        + (", the best A candidate too" if c_best["index"] == a_best["index"] else
           f"; A's best is l1 = {fmt(a_best['l1'])}, l2 = {fmt(a_best['l2'])}, R = "
           f"{fmt(a_best['R'])}")
        + f". Summed over the {len(rows)} parts: A = {fmt(sums['a'])}, C = {fmt(sums['c'])}, "
        f"B = {fmt(sums['b'])}. Variable geometry (B) gains over one gripper (A) on "
        f"{len(gaining)} parts"
        + (f"; switching friction recovers {fmt(100 * recovered_share(rows))} % of that gain "
           "(each part's share capped at its own gain)." if gaining else ".")]
    if gaining:
        out.append(
            f"- Switching friction is an alternative to variable geometry for "
            f"{len(by['C matches B']) + len(by['C beats B'])} of those {len(gaining)} parts, "
            f"where C reaches or passes B: {_parts(by['C matches B'] + by['C beats B'])}. It is "
            f"a partial one for {len(by['C recovers part'])}: "
            + ("; ".join(f"{part_text(r)} ({fmt(100 * r['recovered'])} %)"
                         for r in by["C recovers part"]) or "none")
            + f". It is no alternative for {len(by['C adds nothing'])}, where it adds nothing "
            f"to A: {_parts(by['C adds nothing'])}.")
    if crossing(st):
        out.append("- In this scene the fingers may pass through each other (the paper's "
                   "model): poses with crossed fingers count with S_geo = 1 (MODEL 10), and a "
                   "finger on μ_low slides further round the part, so C here includes such "
                   "poses; a scene with finger_collision says what a real gripper gets.")
    if rows and len(gaining) < len(rows):
        out.append(f"- Where B does not gain over A ({len(rows) - len(gaining)} parts), "
                   f"switching friction adds on {len(by['C gains, B not'])}"
                   + (f": {_parts(by['C gains, B not'])}" if by["C gains, B not"] else "")
                   + ".")
    better = [r for r in caging if r["area_dh"] > r["area_s"] and not _same(r["area_dh"],
                                                                             r["area_s"])]
    worse = [r for r in caging if r["area_dh"] < r["area_s"] and not _same(r["area_dh"],
                                                                            r["area_s"])]
    reach = [r for r in caging if r["area_dh"] >= r["best_area"]
             or _same(r["area_dh"], r["best_area"])]
    out.append(
        f"- Caging under modulation (A's best candidate, each at its best palm width): "
        f"\"draw in on μ_low, then hold on μ\" cages more than holding on μ throughout on "
        f"{len(better)} of {len(caging)} parts ({_parts(better)}), less on {len(worse)}"
        + (f" ({_parts(worse)})" if worse else "")
        + f"; it reaches the largest caging area of any geometry on {len(reach)} parts"
        + (f" ({_parts(reach)})" if reach else "") + ". Caging areas summed over parts: on μ "
        f"{fmt(sum(r['area_s'] for r in caging))}, on μ_low "
        f"{fmt(sum(r['area_low'] for r in caging))}, draw in then hold "
        f"{fmt(sum(r['area_dh'] for r in caging))}, the largest of any geometry per part "
        f"{fmt(sum(r['best_area'] for r in caging))}.")
    return out


# ---------------------------------------------------------------------------------------------
# Two scenes side by side (`compare.py`)
# ---------------------------------------------------------------------------------------------
def pair_rows(rows_1: list[dict], rows_2: list[dict]) -> list[dict]:
    """The per-part rows of two scenes side by side (columns `_1`, `_2`)."""
    return [dict(r=x["r"], mu=x["mu"], **{f"{k}_1": x[k] for k in x if k not in ("r", "mu")},
                 **{f"{k}_2": y[k] for k in y if k not in ("r", "mu")})
            for x, y in zip(rows_1, rows_2)]


PAIR_FRICTION_COLUMNS = ["r", "mu"] + [f"{k}_{s}" for s in ("1", "2")
                                       for k in ("a", "c", "b", "recovered", "verdict")]
PAIR_MODULATION_COLUMNS = ["r", "mu"] + [f"{k}_{s}" for s in ("1", "2")
                                         for k in ("area_s", "area_low", "area_dh", "w_dh",
                                                   "best_area")]


def pair_figure(st1: StoreData, st2: StoreData, rep) -> Figure:
    """Top: per part A, C and B under each scene (log scale); bottom: caging under modulation
    of each scene's A candidate (on μ, draw in then hold)."""
    fig = Figure(figsize=(18, 12.5), dpi=90, layout="constrained")
    FigureCanvasAgg(fig)
    top, bottom = fig.subfigures(2, 1, height_ratios=[1.1, 1])
    ax = top.subplots()
    rows = rep.friction
    series = []
    for s, st in (("1", st1), ("2", st2)):
        colour = SCENE_COLOURS[int(s) - 1]
        series += [(f"a_{s}", colour, "..", f"A, {scene_name(st)}"),
                   (f"c_{s}", colour, "//", f"C, {scene_name(st)}"),
                   (f"b_{s}", colour, "", f"B, {scene_name(st)}")]
    xs = _bars(ax, rows, series, 0.13, labels=False)
    ax.set_xticks(xs, [f"r={row['r']:g}\nμ={row['mu']:g}" for row in rows], fontsize=8)
    ax.set_ylabel("manipulation metric (unitless, log scale, 0 not drawn)")
    ax.set_xlabel("part (radius r, friction μ)")
    ax.legend(fontsize=8, ncol=2)
    top.suptitle("Friction modulation (C, hatched //) beside one gripper (A, dotted) and "
                 "variable geometry (B, solid), each scene in its colour\n"
                 + "; ".join(f"{scene_name(st)}: {share_text(x)}"
                             for x, st in ((rep.friction_scenes[0], st1),
                                           (rep.friction_scenes[1], st2))), fontsize=11)
    ax2 = bottom.subplots()
    caging = rep.modulation
    series = []
    for s, st in (("1", st1), ("2", st2)):
        colour = SCENE_COLOURS[int(s) - 1]
        series += [(f"area_s_{s}", colour, "", f"on μ, {scene_name(st)}"),
                   (f"area_dh_{s}", colour, "//", f"draw in then hold, {scene_name(st)}")]
    xs = _bars(ax2, caging, series, 0.2, log_scale=False, labels=False)
    ax2.set_xticks(xs, [f"r={row['r']:g}\nμ={row['mu']:g}" for row in caging], fontsize=8)
    ax2.set_ylabel("caging area Λ h² (unitless), at its best palm width")
    ax2.set_xlabel("part (radius r, friction μ)")
    ax2.legend(fontsize=8, ncol=2)
    bottom.suptitle(f"Caging under modulation of each scene's best A candidate (μ_low = "
                    f"{fmt(st1.mu_low)}); {NOTE_UNITLESS}", fontsize=11)
    return fig


def pair_reading(st1: StoreData, st2: StoreData, rep) -> list[str]:
    """Both scenes' answers in one line each, and where they differ."""
    out = []
    for (s, st), rows, caging in zip((("1", st1), ("2", st2)), rep.friction_scenes,
                                     rep.modulation_scenes):
        full = [r for r in rows if r["verdict"] in ("C matches B", "C beats B")]
        part = [r for r in rows if r["verdict"] == "C recovers part"]
        none = [r for r in rows if r["verdict"] == "C adds nothing"]
        out.append(f"- Friction modulation, scene {s} ({scene_name(st)}): {share_text(rows)}; "
                   f"an alternative to variable geometry on {len(full)} parts ({_parts(full)}), "
                   f"partly on {len(part)} ({_parts(part)}), not at all on {len(none)} "
                   f"({_parts(none)}); draw in "
                   f"then hold cages {fmt(sum(r['area_dh'] for r in caging))} against "
                   f"{fmt(sum(r['area_s'] for r in caging))} on μ (summed caging areas).")
    differ = [r for r in rep.friction if r["verdict_1"] != r["verdict_2"]]
    out.append(f"- The verdict differs between the scenes on {len(differ)} of "
               f"{len(rep.friction)} parts" + (f": {_parts(differ)}" if differ else "") + ".")
    return out

