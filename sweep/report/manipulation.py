"""Experiment 3, in-hand manipulation, Scenario A against Scenario B (`manipulation.csv`,
`manipulation.png`, `scenario_a_candidates.csv`): tables, figure and reading."""
from __future__ import annotations

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from ..compute.batch import scenario_a_pose_values
from .data import (CANDIDATE_DIMS, Comparison, StoreData, candidate_metric_rows, fmt, part_text,
                   scene_name, short_scene)
from .style import NOTE_UNITLESS, SCENE_COLOURS


def candidate_rows(st: StoreData, top_k: int) -> list[dict]:
    """Every Scenario A candidate with its metric summed over all parts; the best one (largest
    sum, first in store order among ties) is flagged."""
    return candidate_metric_rows(st, top_k, "a")


def manipulation_rows(st: StoreData, best: dict) -> list[dict]:
    """Per part: the best candidate's Scenario A metric next to Scenario B's, and which wins."""
    a = st.ds["manipulation_a"].transpose(*CANDIDATE_DIMS, "r", "mu").values[best["index"]]
    a_area = st.ds["manipulation_a_area"].transpose(*CANDIDATE_DIMS, "r", "mu").values[
        best["index"]]
    rows = []
    for ri, mi in st.parts():
        va, vb = float(a[ri, mi]), float(st.ds["manipulation_b"].values[ri, mi])
        winner = "A" if va > vb else "B" if vb > va else "tie"
        rows.append(dict(r=float(st.r[ri]), mu=float(st.mu[mi]), a=va,
                         a_area=float(a_area[ri, mi]), b=vb,
                         b_area=float(st.ds["manipulation_b_area"].values[ri, mi]),
                         b_uncrossed=float(st.ds["manipulation_b_uncrossed"].values[ri, mi]),
                         b_poses=int(st.ds["manipulation_b_poses"].values[ri, mi]),
                         winner=winner))
    return rows


def pose_map_part(rows: list[dict]) -> int:
    """Row index of the part whose per-pose maps are drawn: the largest min(A, B), so that both
    maps show something; first in table order among ties."""
    return int(np.argmax([min(r["a"], r["b"]) for r in rows]))


CAND_COLUMNS = ["l1", "l2", "r1", "r2", "R", "a_sum", "a_area_sum", "parts_positive", "best"]


MANIP_COLUMNS = ["r", "mu", "a", "a_area", "b", "b_area", "b_uncrossed", "b_poses", "winner"]


def lattice_edges(v: np.ndarray, h: float) -> np.ndarray:
    return np.concatenate([v - 0.5 * h, [v[-1] + 0.5 * h]])


def manipulation_figure(st: StoreData, rows: list[dict], best: dict, part_row: int,
                        log) -> Figure:

    fig = Figure(figsize=(16, 13), dpi=100, layout="constrained")
    FigureCanvasAgg(fig)
    top, bottom = fig.subfigures(2, 1, height_ratios=[1, 1.15])
    ax = top.subplots()
    n = len(rows)
    xs = np.arange(n)
    a = np.array([row["a"] for row in rows])
    b = np.array([row["b"] for row in rows])
    positive = np.concatenate([a[a > 0], b[b > 0]])
    floor = positive.min() / 3 if positive.size else 1e-3
    cand = (f"l1={best['l1']:g} l2={best['l2']:g} r1={best['r1']:g} r2={best['r2']:g}")
    for off, vals, colour, label in ((-0.2, a, "#1f77b4", f"Scenario A, best candidate ({cand}"
                                      "; w and F_left/F_right varied)"),
                                     (0.2, b, "#d62728", "Scenario B (every geometry, "
                                      "F_left = F_right = 1)")):
        ax.bar(xs + off, np.where(vals > 0, vals, np.nan), width=0.4, color=colour,
               label=label)
        for x, v in zip(xs + off, vals):
            ax.text(x, max(v, floor), fmt(v), rotation=90, ha="center", va="bottom",
                    fontsize=7.5)
    ax.set_yscale("log")
    ax.set_ylim(floor, (positive.max() if positive.size else 1.0) * 30)
    ax.set_xticks(xs, [f"r={row['r']:g}\nμ={row['mu']:g}\n{row['winner']} wins"
                       if row["winner"] != "tie" else f"r={row['r']:g}\nμ={row['mu']:g}\ntie"
                       for row in rows], fontsize=8)
    ax.set_ylabel("manipulation metric: sum over poses of the inscribed-circle radius\n"
                  "(unitless, forces per unit tension × S_geo; log scale; 0 not drawn)")
    ax.set_xlabel("part (radius r, friction μ); which scenario has the larger metric")
    ax.legend(fontsize=9, loc="upper right")
    ax.grid(axis="y", alpha=0.3)
    top.suptitle("In-hand manipulation metric per part: Scenario A's best candidate versus "
                 "Scenario B (values printed)", fontsize=12)

    row = rows[part_row]
    ri = int(np.flatnonzero(st.r == row["r"])[0])
    mi = int(np.flatnonzero(st.mu == row["mu"])[0])
    log(f"Scenario A per-pose values: part r = {row['r']:g}, mu = {row['mu']:g}")
    sc = st.scene
    cand = tuple(best[d] for d in CANDIDATE_DIMS)
    xa, ya, va, metric = scenario_a_pose_values(cand, (row["r"], row["mu"]), sc.widths, sc.h,
                                                sc.limits, sc.accuracy, sc.effects)
    h = sc.h
    pv = st.ds["manipulation_b_pose_value"].isel(r=ri, mu=mi)
    vb = pv.values
    xb = pv["pose_column"].values * h
    yb = row["r"] + pv["pose_row"].values * h
    vmax = max(float(va.max()), float(vb.max()), 1e-12)
    axs = bottom.subplots(1, 2, sharex=True, sharey=True)
    mesh = None
    for axp, (x, y, v, name, total) in zip(axs, (
            (xa, ya, va, "Scenario A, best candidate", metric),
            (xb, yb, vb, "Scenario B", row["b"]))):
        shown = np.ma.masked_where(v <= 0, v)
        mesh = axp.pcolormesh(lattice_edges(x, h), lattice_edges(y, h), shown,
                              cmap="magma_r", vmin=0.0, vmax=vmax, shading="flat")
        axp.set_aspect("equal")
        axp.set_facecolor("#eeeeee")
        axp.set_xlabel("part centre x")
        axp.set_title(f"{name}: metric {fmt(total)}, {int((v > 0).sum())} poses with a "
                      "positive value", fontsize=10)
    axs[0].set_ylabel("part centre y")
    ext = [np.r_[xa[(va > 0).any(0)], xb[(vb > 0).any(0)]],
           np.r_[ya[(va > 0).any(1)], yb[(vb > 0).any(1)]]]
    if ext[0].size:
        axs[0].set_xlim(ext[0].min() - 4 * h, ext[0].max() + 4 * h)
        axs[0].set_ylim(min(0.0, ext[1].min() - 4 * h), ext[1].max() + 4 * h)
    cb = bottom.colorbar(mesh, ax=list(axs), shrink=0.8, pad=0.01)
    cb.set_label("pose value: radius of the largest origin-centred circle in the force hull "
                 "(unitless)", fontsize=9)
    bottom.suptitle(f"Per-pose values for part r={row['r']:g}, μ={row['mu']:g} (the part with "
                    "the largest min(A, B)); grey: value 0 (origin not strictly inside the "
                    f"hull) or no pose; {NOTE_UNITLESS}", fontsize=11)
    return fig


def reading(st: StoreData, rep) -> list[str]:
    """The reading of experiment 3 (`rep`: the report's tables, `build.Report`)."""
    out = []
    best_c = next(c for c in rep.candidates if c["best"])
    rows = rep.manipulation
    n_b = sum(r["winner"] == "B" for r in rows)
    n_a = sum(r["winner"] == "A" for r in rows)
    n_t = sum(r["winner"] == "tie" for r in rows)
    sum_a, sum_b = sum(r["a"] for r in rows), sum(r["b"] for r in rows)
    crossed = sum(r["b"] - r["b_uncrossed"] for r in rows)
    out.append(
        f"- Manipulation: the best Scenario A candidate of {len(rep.candidates)} (top "
        f"{rep.top_k} caging designs of every part, merged) is l1 = {fmt(best_c['l1'])}, "
        f"l2 = {fmt(best_c['l2'])}, r1 = {fmt(best_c['r1'])}, r2 = {fmt(best_c['r2'])} "
        f"(R = {fmt(best_c['R'])}) with metric {fmt(best_c['a_sum'])} summed over parts, "
        f"positive on {best_c['parts_positive']} of {len(rows)} parts. Scenario B has the "
        f"larger metric on {n_b} parts, Scenario A on {n_a}, ties on {n_t}; summed over parts "
        f"A = {fmt(sum_a)} and B = {fmt(sum_b)}. Of B's total, {fmt(crossed)} "
        f"({fmt(100 * crossed / sum_b if sum_b > 0 else float('nan'))} %) comes from poses "
        "with crossed fingers (the base model lets fingers pass through each other).")
    for who in ("A", "B"):
        won = [r for r in rows if r["winner"] == who]
        if won:
            rs = ", ".join(sorted(set(fmt(r["r"]) for r in won), key=float))
            mus = ", ".join(sorted(set(fmt(r["mu"]) for r in won), key=float))
            out.append(f"- {who} wins on {len(won)} parts, with r in {{{rs}}} and mu in "
                       f"{{{mus}}}: " + "; ".join(part_text(r) for r in won) + ".")
    b_by_r = {}
    for r in rows:
        b_by_r.setdefault(r["r"], []).append(r["b"])
    out.append("- Scenario B's metric summed over friction values, by part radius: "
               + ", ".join(f"r = {fmt(k)}: {fmt(sum(v))}" for k, v in sorted(b_by_r.items()))
               + ".")
    return out


# ---------------------------------------------------------------------------------------------
# Two scenes side by side (`compare.py`)
# ---------------------------------------------------------------------------------------------
def pair_figure(st1: StoreData, st2: StoreData, rep: Comparison) -> Figure:
    """Top: per part the four metrics (A and B under each scene, log scale); bottom: Scenario
    B's per-pose values of one part under both scenes (one colour scale)."""
    rows = rep.manipulation
    fig = Figure(figsize=(17, 13), dpi=90, layout="constrained")
    FigureCanvasAgg(fig)
    top, bottom = fig.subfigures(2, 1, height_ratios=[1, 1.1])
    ax = top.subplots()
    xs = np.arange(len(rows))
    series = [("a_1", -0.3, SCENE_COLOURS[0], "//", f"A, {scene_name(st1)}"),
              ("b_1", -0.1, SCENE_COLOURS[0], "", f"B, {scene_name(st1)}"),
              ("a_2", 0.1, SCENE_COLOURS[1], "//", f"A, {scene_name(st2)}"),
              ("b_2", 0.3, SCENE_COLOURS[1], "", f"B, {scene_name(st2)}")]
    allv = np.array([row[k] for row in rows for k, *_ in series])
    positive = allv[allv > 0]
    floor = positive.min() / 3 if positive.size else 1e-3
    for key, off, colour, hatch, label in series:
        vals = np.array([row[key] for row in rows])
        ax.bar(xs + off, np.where(vals > 0, vals, np.nan), width=0.2, color=colour,
               hatch=hatch, edgecolor="white", label=label)
    ax.set_yscale("log")
    ax.set_ylim(floor, (positive.max() if positive.size else 1.0) * 5)
    ax.set_xlim(-0.7, len(rows) - 0.3)
    ax.set_xticks(xs, [f"r={row['r']:g}\nμ={row['mu']:g}\n{row['winner_1']} / "
                       f"{row['winner_2']}" for row in rows], fontsize=8)
    ax.set_xlabel("part (radius r, friction μ); the scenario with the larger metric under "
                  f"{scene_name(st1)} / under {scene_name(st2)}")
    ax.set_ylabel("manipulation metric (sum over poses of the inscribed radius;\nunitless, "
                  "log scale, 0 not drawn)")
    ax.legend(fontsize=9, ncol=2)
    ax.grid(axis="y", alpha=0.3)
    b1, b2 = rep.best_candidates
    top.suptitle(f"In-hand manipulation per part, Scenario A (hatched; best candidate "
                 f"{scene_name(st1)}: l1={b1['l1']:g} l2={b1['l2']:g} R={fmt(b1['R'])}; "
                 f"{scene_name(st2)}: l1={b2['l1']:g} l2={b2['l2']:g} R={fmt(b2['R'])}) and "
                 "Scenario B (solid), each scene in its colour", fontsize=11)
    k = int(np.argmax([min(row["b_1"], row["b_2"]) for row in rows]))
    row = rows[k]
    ri = int(np.flatnonzero(st1.r == row["r"])[0])
    mi = int(np.flatnonzero(st1.mu == row["mu"])[0])
    h = st1.scene.h
    maps = []
    for st in (st1, st2):
        pv = st.ds["manipulation_b_pose_value"].isel(r=ri, mu=mi)
        maps.append((pv["pose_column"].values * h, row["r"] + pv["pose_row"].values * h,
                     pv.values))
    vmax = max(max(float(v.max()) for _, _, v in maps), 1e-12)
    axs = bottom.subplots(1, 2, sharex=True, sharey=True)
    mesh = None
    for axp, st, (x, y, v), total in zip(axs, (st1, st2), maps, (row["b_1"], row["b_2"])):
        mesh = axp.pcolormesh(lattice_edges(x, h), lattice_edges(y, h),
                              np.ma.masked_where(v <= 0, v), cmap="magma_r", vmin=0.0,
                              vmax=vmax, shading="flat")
        axp.set_aspect("equal")
        axp.set_facecolor("#eeeeee")
        axp.set_xlabel("part centre x")
        axp.set_title(f"{scene_name(st)} ({short_scene(st)}): Scenario B metric {fmt(total)}, "
                      f"{int((v > 0).sum())} poses with a positive value", fontsize=10)
    axs[0].set_ylabel("part centre y")
    on = [(x[(v > 0).any(0)], y[(v > 0).any(1)]) for x, y, v in maps]
    xs_on = np.concatenate([a for a, _ in on])
    ys_on = np.concatenate([b for _, b in on])
    if xs_on.size:
        axs[0].set_xlim(xs_on.min() - 4 * h, xs_on.max() + 4 * h)
        axs[0].set_ylim(min(0.0, ys_on.min() - 4 * h), ys_on.max() + 4 * h)
    cb = bottom.colorbar(mesh, ax=list(axs), shrink=0.8, pad=0.01)
    cb.set_label("pose value (inscribed radius of the force hull, unitless)", fontsize=9)
    bottom.suptitle(f"Scenario B per pose for part r={row['r']:g}, μ={row['mu']:g} (the "
                    "largest min over the two scenes), one colour scale; grey: value 0 or no "
                    f"pose; {NOTE_UNITLESS}", fontsize=11)
    return fig
