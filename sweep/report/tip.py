"""Experiment 2, caging versus tip prehension (`caging_vs_tip.csv`, `caging_vs_tip.png`,
`representative_designs.csv`): table, figure and reading."""
from __future__ import annotations

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from ..compute.maps import scene_map
from .data import (Comparison, DESIGN_DIMS, StoreData, design_text, fmt,
                   representative_designs, scene_name, short_scene)
from .plot import draw_map_panel
from .style import NOTE_UNITLESS, REPRESENTATIVE_COLOURS, SCENE_COLOURS


def caging_tip_parts(st: StoreData) -> list[tuple[int, int]]:
    """The smallest and the largest part at the highest friction (one part if they coincide)."""
    mi = int(np.argmax(st.mu))
    small, large = int(np.argmin(st.r)), int(np.argmax(st.r))
    return [(small, mi)] if small == large else [(small, mi), (large, mi)]


def caging_tip_rows(st: StoreData) -> list[dict]:
    """Every design's caged and tip-prehension counts for the caging-versus-tip parts."""
    rows = []
    for ri, mi in caging_tip_parts(st):
        caged = st.per_design("n_caged", ri, mi)
        tip = st.per_design("n_tip_prehension", ri, mi)
        lam = st.per_design("Lambda", ri, mi)
        for k in range(caged.size):
            rows.append(dict(r=float(st.r[ri]), mu=float(st.mu[mi]), **st.design(k),
                             n_caged=int(caged[k]), n_tip_prehension=int(tip[k]),
                             Lambda=float(lam[k])))
    return rows


def representative_rows(st: StoreData) -> list[dict]:
    rows = []
    for ri, mi in caging_tip_parts(st):
        caged = st.per_design("n_caged", ri, mi)
        tip = st.per_design("n_tip_prehension", ri, mi)
        lam = st.per_design("Lambda", ri, mi)
        for kind, k in representative_designs(caged, tip).items():
            d = st.design(k)
            rows.append(dict(r=float(st.r[ri]), mu=float(st.mu[mi]), kind=kind, **d,
                             R=d["r2"] / d["r1"], n_caged=int(caged[k]),
                             n_tip_prehension=int(tip[k]), Lambda=float(lam[k]),
                             design_index=k))
    return rows


CT_COLUMNS = ["r", "mu", "l1", "l2", "r1", "r2", "w", "n_caged", "n_tip_prehension", "Lambda"]


REP_COLUMNS = ["r", "mu", "kind", "l1", "l2", "r1", "r2", "w", "R", "n_caged",
               "n_tip_prehension", "Lambda"]


def caging_tip_figure(st: StoreData, rep_rows: list[dict], log) -> Figure:

    parts = caging_tip_parts(st)
    fig = Figure(figsize=(20, 4.8 * len(parts) + 1.0), dpi=100, layout="constrained")
    FigureCanvasAgg(fig)
    axes = fig.subplots(len(parts), 4, squeeze=False,
                        gridspec_kw=dict(width_ratios=[1.25, 1, 1, 1]))
    markers = {"caging focused": "o", "tip focused": "D", "compromise": "s"}
    for p, (ri, mi) in enumerate(parts):
        r, mu = float(st.r[ri]), float(st.mu[mi])
        caged = st.per_design("n_caged", ri, mi)
        tip = st.per_design("n_tip_prehension", ri, mi)
        ax = axes[p, 0]
        # How many designs share each (caged, tip) point: colour, since many coincide.
        pts, counts = np.unique(np.column_stack([caged, tip]), axis=0, return_counts=True)
        sc = ax.scatter(pts[:, 0], pts[:, 1], c=counts, cmap="viridis", norm="log", s=10,
                        linewidths=0, vmin=1, vmax=max(counts.max(), 2))
        cb = fig.colorbar(sc, ax=ax, pad=0.01, aspect=30)
        cb.set_label("designs at this point", fontsize=8)
        mine = [row for row in rep_rows if row["r"] == r and row["mu"] == mu]
        for row in mine:
            ax.scatter([row["n_caged"]], [row["n_tip_prehension"]], s=110,
                       marker=markers[row["kind"]], facecolors="none",
                       edgecolors=REPRESENTATIVE_COLOURS[row["kind"]], linewidths=2.2,
                       label=f"{row['kind']}: caged {row['n_caged']}, tip "
                             f"{row['n_tip_prehension']}", zorder=5)
        ax.set_xlabel("grid points whose trajectory ends caged (n_caged)")
        ax.set_ylabel("grid points ending in tip prehension (n_tip_prehension)")
        ax.set_title(f"part r={r:g}, μ={mu:g}: {caged.size} designs, one point each",
                     fontsize=10)
        ax.legend(fontsize=8, loc="best")
        ax.grid(alpha=0.3)
        for q, row in enumerate(mine):
            log(f"caging versus tip maps: part r = {r:g}, {row['kind']}")
            m = scene_map(st.scene, {d: row[d] for d in DESIGN_DIMS}, st.r[ri], st.mu[mi])
            a = axes[p, q + 1]
            draw_map_panel(a, m, title=f"{row['kind']} (r={r:g}, μ={mu:g})\n"
                                       f"{design_text(row)}\ncaged {row['n_caged']}, tip "
                                       f"{row['n_tip_prehension']}, Λ={fmt(row['Lambda'])}",
                           fontsize=8)
            for spine in a.spines.values():
                spine.set_edgecolor(REPRESENTATIVE_COLOURS[row["kind"]])
                spine.set_linewidth(2.5)
    fig.suptitle("Caging versus tip prehension per design, smallest and largest part at the "
                 "highest friction; three representative designs (rules in report.md) marked "
                 f"and drawn\n(energy V; hatching: equilibrium; pink: caged region; greys and tan: "
                 "outside P_j); "
                 f"{NOTE_UNITLESS}", fontsize=11)
    return fig


def reading(st: StoreData, rep) -> list[str]:
    """The reading of experiment 2 (`rep`: the report's tables, `build.Report`)."""
    out = []
    for (ri, mi) in caging_tip_parts(st):
        r, mu = float(st.r[ri]), float(st.mu[mi])
        caged = st.per_design("n_caged", ri, mi)
        tip = st.per_design("n_tip_prehension", ri, mi)
        reps = {row["kind"]: row for row in rep.representatives
                if row["r"] == r and row["mu"] == mu}
        both = int(np.count_nonzero((caged > 0) & (tip > 0)))
        corr = (float(np.corrcoef(caged, tip)[0, 1]) if caged.std() > 0 and tip.std() > 0
                else float("nan"))
        out.append(
            f"- Caging versus tip prehension, part r = {fmt(r)}, mu = {fmt(mu)}: "
            f"{int(np.count_nonzero(caged > 0))} of {caged.size} designs end some points "
            f"caged, {int(np.count_nonzero(tip > 0))} end some in tip prehension, {both} do "
            f"both; the correlation of the two counts over designs is {fmt(corr)}. The "
            f"caging-focused design has R = {fmt(reps['caging focused']['R'])} (caged "
            f"{reps['caging focused']['n_caged']}, tip "
            f"{reps['caging focused']['n_tip_prehension']}), the tip-focused one R = "
            f"{fmt(reps['tip focused']['R'])} (caged {reps['tip focused']['n_caged']}, tip "
            f"{reps['tip focused']['n_tip_prehension']}).")
    return out


# ---------------------------------------------------------------------------------------------
# Two scenes side by side (`compare.py`)
# ---------------------------------------------------------------------------------------------
def pair_figure(st1: StoreData, st2: StoreData, rep: Comparison) -> Figure:
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
                           label=f"{scene_name(other)} ({short_scene(other)}): {caged.size} designs"
                           + ("" if s2 == s else " (faint)"))
            for row in rep.representatives:
                if row["scene"] == str(s + 1) and row["r"] == r and row["mu"] == mu:
                    ax.scatter([row["n_caged"]], [row["n_tip_prehension"]], s=120,
                               marker=markers[row["kind"]], facecolors="none",
                               edgecolors=REPRESENTATIVE_COLOURS[row["kind"]], linewidths=2.2,
                               zorder=5, label=f"{row['kind']}: l1={row['l1']:g} "
                               f"l2={row['l2']:g} R={fmt(row['R'])} w={row['w']:g}")
            ax.set_title(f"part r={r:g}, μ={mu:g}: {scene_name(st)} ({short_scene(st)})",
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
