"""The two-scene report's figures (`compare.py` writes them): each draws the two scenes on one
canvas, the same scale where they share one."""
from __future__ import annotations

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from .compare_tables import Comparison, crossing, scene_name
from .data import DESIGN_DIMS, PARAMETERS, StoreData, compute_best_map, fmt
from .plot import draw_map_panel
from .manipulation import lattice_edges
from .style import NOTE_UNITLESS, REPRESENTATIVE_COLOURS, SCENE_COLOURS
from .tip import caging_tip_parts
from .usage import draw_usage


# ---------------------------------------------------------------------------------------------
# Figures: each draws the two scenes on one canvas, the same scale where they share one
# ---------------------------------------------------------------------------------------------
def _short(st: StoreData) -> str:
    return "fingers may cross" if crossing(st) else "fingers cannot cross"


def best_designs_figure(st1: StoreData, st2: StoreData, rows: list[dict], log) -> Figure:
    """Per part two panels, scene 1 then scene 2: each scene's best design and its map; the
    pair framed red where the best gripper changes."""
    n_r, n_mu = st1.r.size, st1.mu.size
    fig = Figure(figsize=(8.6 * n_r + 0.5, 3.4 * n_mu + 1.4), dpi=90, layout="constrained")
    FigureCanvasAgg(fig)
    axes = np.atleast_2d(fig.subplots(n_mu, 2 * n_r, squeeze=False))
    for k, ((ri, mi), row) in enumerate(zip(st1.parts(), rows)):
        log(f"best designs of both scenes: {k + 1}/{len(rows)} (r = {row['r']:g}, "
            f"mu = {row['mu']:g})")
        for s, st in ((0, st1), (1, st2)):
            tag = str(s + 1)
            design = {d: row[f"{d}_{tag}"] for d in DESIGN_DIMS}
            m = compute_best_map(st, design, ri, mi)
            ax = axes[mi, 2 * ri + s]
            text = (f"{_short(st)}: r={row['r']:g}, μ={row['mu']:g}\n"
                    f"l1={design['l1']:g} l2={design['l2']:g} R={fmt(row[f'R_{tag}'])} "
                    f"w={design['w']:g}\nΛ={fmt(row[f'Lambda_{tag}'])}")
            draw_map_panel(ax, m, title=text, colorbar_label=None, fontsize=7)
            for spine in ax.spines.values():
                spine.set_edgecolor("#999999" if row["same_gripper"] else "#ff0000")
                spine.set_linewidth(1.0 if row["same_gripper"] else 3.0)
    n_changed = sum(not row["same_gripper"] for row in rows)
    fig.suptitle(f"Best caging design of each part in two scenes: left of each pair "
                 f"{scene_name(st1)} ({_short(st1)}), right {scene_name(st2)} "
                 f"({_short(st2)})\nthick red frames: the best gripper (l1, l2, R, w) changes "
                 f"({n_changed} of {len(rows)} parts); colour: energy V, each panel its own "
                 "scale\nwhite hatching: part in equilibrium; pink outline: caged region; greys "
                 f"and tan: outside P_j; gripper drawn at a representative caged pose; "
                 f"{NOTE_UNITLESS}", fontsize=12)
    return fig


def caging_tip_figure(st1: StoreData, st2: StoreData, rep: Comparison) -> Figure:
    """Per caging-versus-tip part, both scenes' designs on the same axes (caged versus
    tip-prehension end points), with each scene's representative designs."""
    parts = caging_tip_parts(st1)
    fig = Figure(figsize=(16, 6.2 * len(parts) + 0.8), dpi=90, layout="constrained")
    FigureCanvasAgg(fig)
    axes = fig.subplots(len(parts), 2, squeeze=False, sharex="row", sharey="row")
    markers = {"caging focused": "o", "tip focused": "D", "compromise": "s"}
    for p, (ri, mi) in enumerate(parts):
        r, mu = float(st1.r[ri]), float(st1.mu[mi])
        for s, st in ((0, st1), (1, st2)):
            ax = axes[p, s]
            for s2, other in ((1 - s, (st2, st1)[s]), (s, st)):  # the other scene faint
                caged = other.per_design("n_caged", ri, mi)
                tip = other.per_design("n_tip_prehension", ri, mi)
                ax.scatter(caged, tip, s=6 if s2 == s else 4, linewidths=0,
                           color=SCENE_COLOURS[s2], alpha=0.7 if s2 == s else 0.12,
                           label=f"{scene_name(other)} ({_short(other)}): {caged.size} designs"
                           + ("" if s2 == s else " (faint)"))
            for row in rep.representatives:
                if row["scene"] == str(s + 1) and row["r"] == r and row["mu"] == mu:
                    ax.scatter([row["n_caged"]], [row["n_tip_prehension"]], s=120,
                               marker=markers[row["kind"]], facecolors="none",
                               edgecolors=REPRESENTATIVE_COLOURS[row["kind"]], linewidths=2.2,
                               zorder=5, label=f"{row['kind']}: l1={row['l1']:g} "
                               f"l2={row['l2']:g} R={fmt(row['R'])} w={row['w']:g}")
            ax.set_title(f"part r={r:g}, μ={mu:g}: {scene_name(st)} ({_short(st)})",
                         fontsize=11)
            ax.set_xlabel("grid points whose trajectory ends caged (n_caged)")
            ax.set_ylabel("grid points ending in tip prehension (n_tip_prehension)")
            ax.grid(alpha=0.3)
            ax.legend(fontsize=8, loc="best")
    fig.suptitle("Caging versus tip prehension per design, smallest and largest part at the "
                 "highest friction: each scene in its colour, the other scene faint behind it;\n"
                 f"representative designs (rules in report.md) marked; {NOTE_UNITLESS}",
                 fontsize=11)
    return fig


def manipulation_figure(st1: StoreData, st2: StoreData, rep: Comparison) -> Figure:
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
        axp.set_title(f"{scene_name(st)} ({_short(st)}): Scenario B metric {fmt(total)}, "
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


def usage_figure(st1: StoreData, st2: StoreData, rows: list[dict]) -> Figure:
    """Scenario B's parameter usage per part, the two scenes side by side, one colour scale."""
    fig = Figure(figsize=(13, 0.42 * len(rows) + 2.4), dpi=100, layout="constrained")
    FigureCanvasAgg(fig)
    axs = fig.subplots(1, 2, sharey=True)
    im = None
    for ax, tag, st in zip(axs, ("1", "2"), (st1, st2)):
        vals = np.array([[row[f"{p}_{tag}"] for p in PARAMETERS] for row in rows])
        im = draw_usage(ax, vals, "none")
        ax.set_title(f"{scene_name(st)} ({_short(st)})", fontsize=10)
        ax.set_xlabel("design parameter")
    axs[0].set_yticks(range(len(rows)), [f"r={row['r']:g}, μ={row['mu']:g}" for row in rows],
                      fontsize=8)
    axs[0].set_ylabel("part (radius r, friction μ)")
    cb = fig.colorbar(im, ax=list(axs), pad=0.02)
    cb.set_label("usage: spread among hull-vertex geometries / search range (unitless, 0..1)",
                 fontsize=8)
    fig.suptitle("Scenario B parameter usage per part in both scenes ('none': no pose with a "
                 "positive value)", fontsize=11)
    return fig
