"""Experiment 1, the best caging design of every part (`best_caging.csv`, `best_caging.png`,
`refinement.csv` for a refined store): table, figure and reading."""
from __future__ import annotations

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from ..compute.maps import scene_map
from .data import (DESIGN_DIMS, StoreData, TIE_DIGITS, best_design, design_text, fmt, part_text,
                   scene_name, short_scene, spread)
from .plot import draw_map_panel
from .style import NOTE_UNITLESS


def best_caging_rows(st: StoreData) -> list[dict]:
    """Per part: its best design (`best_design`)."""
    return [best_design(st, ri, mi) for ri, mi in st.parts()]


BEST_COLUMNS = ["r", "mu", "l1", "l2", "r1", "r2", "w", "R", "Lambda", "caging_area", "n_caged",
                "n_tip_prehension", "n_caged_points", "n_caged_crossed", "n_tied"]


#: Columns added to BEST_COLUMNS in a refined store.
REFINED_COLUMNS = ["refined_caging_area", "refined_error", "margin", "finest_h", "certification"]


#: refinement.csv: every member of each part's final set (the certified best, or the near-tie
#: set), each with its value and error estimate.
REFINEMENT_COLUMNS = ["r", "mu", "status", "l1", "l2", "r1", "r2", "w", "R",
                      "refined_caging_area", "refined_error", "finest_h", "bound_held"]


def best_columns(st: StoreData) -> list[str]:
    return BEST_COLUMNS + (REFINED_COLUMNS if st.refined else [])


def refinement_rows(best: list[dict]) -> list[dict]:
    """refinement.csv's rows: each part's final set, best first."""
    return [m for row in best for m in row["near_tie"]]


def best_caging_figure(st: StoreData, rows: list[dict], log) -> Figure:

    n_r, n_mu = st.r.size, st.mu.size
    fig = Figure(figsize=(5.0 * n_r + 0.5, 3.2 * n_mu + 1.0), dpi=100, layout="constrained")
    FigureCanvasAgg(fig)
    axes = np.atleast_2d(fig.subplots(n_mu, n_r, squeeze=False))
    by_part = {(row["r"], row["mu"]): row for row in rows}
    for k, (ri, mi) in enumerate(st.parts()):
        row = by_part[(float(st.r[ri]), float(st.mu[mi]))]
        log(f"best caging maps: {k + 1}/{len(rows)} (r = {row['r']:g}, mu = {row['mu']:g})")
        m = scene_map(st.scene, {d: row[d] for d in DESIGN_DIMS}, st.r[ri], st.mu[mi])
        title = (f"part r={row['r']:g}, μ={row['mu']:g}\n{design_text(row)}\n"
                 f"Λ={fmt(row['Lambda'])}, caging area={fmt(row['caging_area'])}, "
                 f"{row['n_tied']} tied")
        if "certification" in row:
            title += (f"\nrefined: {fmt(row['refined_caging_area'])} at h={fmt(row['finest_h'])}, "
                      f"{row['certification']}")
        draw_map_panel(axes[mi, ri], m, title=title, colorbar_label="energy V (unitless)")
    fig.suptitle("Best caging design of each part (largest Λ; columns: part radius r, rows: "
                 "friction μ)\nColour: energy V, each panel its own scale; white hatching: part "
                 "in equilibrium; pink outline: caged region; greys and tan: outside P_j "
                 "(not reached); "
                 "gripper and part drawn to scale at a representative caged pose; "
                 f"{NOTE_UNITLESS}", fontsize=11)
    return fig


def reading(st: StoreData, rep) -> list[str]:
    """The reading of experiment 1 (`rep`: the report's tables, `build.Report`); every number
    from the tables."""
    out = []
    best = rep.best
    hi = max(best, key=lambda r: r["Lambda"])
    lo = min(best, key=lambda r: r["Lambda"])
    out.append(f"- Caging: the best Λ over the {len(best)} parts ranges from {fmt(lo['Lambda'])} "
               f"({part_text(lo)}) to {fmt(hi['Lambda'])} ({part_text(hi)}). The best designs use "
               f"transmission ratio R = r2/r1 with {spread(r['R'] for r in best)} and palm "
               f"width w with {spread(r['w'] for r in best)}. Ties for the best Λ (at "
               f"{TIE_DIGITS} "
               "significant digits): "
               f"{sum(r['n_tied'] > 1 for r in best)} of {len(best)} parts have more than one "
               f"best design (at most {max(r['n_tied'] for r in best)}). Caged points with "
               "crossed fingers (the base model lets fingers pass through each other) in the "
               f"best designs: {sum(r['n_caged_crossed'] for r in best)} of "
               f"{sum(r['n_caged_points'] for r in best)} caged points over all parts.")
    zero = [r for r in best if not r["Lambda"] > 0]
    if zero:
        out.append(f"- {len(zero)} part(s) have no design with a positive Λ: "
                   + "; ".join(part_text(r) for r in zero) + ".")
    return out


# ---------------------------------------------------------------------------------------------
# Two scenes side by side (`compare.py`)
# ---------------------------------------------------------------------------------------------
def pair_figure(st1: StoreData, st2: StoreData, rows: list[dict], log) -> Figure:
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
            m = scene_map(st.scene, design, st.r[ri], st.mu[mi])
            ax = axes[mi, 2 * ri + s]
            text = (f"{short_scene(st)}: r={row['r']:g}, μ={row['mu']:g}\n"
                    f"l1={design['l1']:g} l2={design['l2']:g} R={fmt(row[f'R_{tag}'])} "
                    f"w={design['w']:g}\nΛ={fmt(row[f'Lambda_{tag}'])}")
            draw_map_panel(ax, m, title=text, colorbar_label=None, fontsize=7)
            for spine in ax.spines.values():
                spine.set_edgecolor("#999999" if row["same_gripper"] else "#ff0000")
                spine.set_linewidth(1.0 if row["same_gripper"] else 3.0)
    n_changed = sum(not row["same_gripper"] for row in rows)
    fig.suptitle(f"Best caging design of each part in two scenes: left of each pair "
                 f"{scene_name(st1)} ({short_scene(st1)}), right {scene_name(st2)} "
                 f"({short_scene(st2)})\nthick red frames: the best gripper (l1, l2, R, w) changes "
                 f"({n_changed} of {len(rows)} parts); colour: energy V, each panel its own "
                 "scale\nwhite hatching: part in equilibrium; pink outline: caged region; greys "
                 f"and tan: outside P_j; gripper drawn at a representative caged pose; "
                 f"{NOTE_UNITLESS}", fontsize=12)
    return fig
