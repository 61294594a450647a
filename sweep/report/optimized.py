"""The report's section on `sweep optimize` (docs/optimisation.md), when the store has been
optimised (its results file `STORE` name + `.optimize.h5` beside it): per part G versus x* with
their values and error bars at the finest h both reached, the verdict, the box-limited
constraints; the figure draws the error bars of every part and x*'s map for the parts where x*
gains most, with both grippers on it. The two-scene report (`compare.py`) has the section for
each scene whose store has been optimised.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from ..compute.maps import scene_map
from ..storage.optimized import (CONSTRAINTS, SIDE_MEANINGS, optimization_created,
                                 optimization_path, read_optimization)
from .data import DESIGN_DIMS, StoreData, fmt
from .plot import draw_map_panel
from .style import NOTE_UNITLESS, SCENE_COLOURS

OPT_COLUMNS = ("r", "mu", "x_l1", "x_l2", "x_r1", "x_r2", "x_w", "x_area", "x_error",
               "g_l1", "g_l2", "g_r1", "g_r2", "g_w", "g_area", "g_error", "h", "d", "u",
               "verdict", "box_limited", "spread", "x_tol_min", "g_tol_min", "maps", "seconds")
#: Maps drawn in the figure: the parts where x* gains most over G.
MAPS_DRAWN = 4
#: The two grippers drawn on x*'s map (legend labels; the lines' gids start with them).
X_GRIPPER, G_GRIPPER = "x* (optimum found)", "G (grid's best)"


def optimized_file(st: StoreData) -> Path | None:
    """The store's optimisation results, if it has been optimised (another file under that name
    is none: no section, as the report's identity has none)."""
    p = optimization_path(st.path)
    return p if optimization_created(st.path) is not None else None


def optimization_rows(path: Path) -> list[dict]:
    """One row per part optimised (OPT_COLUMNS), read from the results file."""
    v = read_optimization(path)["vars"]
    rows = []
    for p in range(len(v["r"])):
        k = int(v["finest_level"][p])
        row = dict(r=float(v["r"][p]), mu=float(v["mu"][p]))
        for prefix, name in (("x", "x_star"), ("g", "grid_best")):
            row.update({f"{prefix}_{d}": float(x) for d, x in zip(DESIGN_DIMS, v[name][p])})
            row[f"{prefix}_area"] = float(v[f"{name}_area"][p, k])
            row[f"{prefix}_error"] = float(v[f"{name}_error"][p])
            row[f"{prefix}_tol_min"] = float(v[f"{name}_tolerance_min"][p])
        binds = [c for i, c in enumerate(CONSTRAINTS) if v["binds"][p, i]]
        row.update(h=float(v["h"][k]), d=float(v["difference"][p]), u=float(v["uncertainty"][p]),
                   verdict="x* beats G" if v["beats"][p] else "no design found beats G",
                   box_limited=" ".join(
                       f"{c}:{SIDE_MEANINGS[int(v['constraint_side'][p, i])]}"
                       for i, c in enumerate(CONSTRAINTS) if c in binds),
                   spread=float(v["start_spread"][p]), maps=int(v["maps"][p]),
                   seconds=float(v["seconds"][p]))
        rows.append(row)
    return rows


def optimization_figure(st: StoreData, rows: list[dict], log) -> Figure:
    """Top: per part x* and G with error bars at the finest h; below: x*'s map for the parts
    where x* gains most, with x*'s gripper at a representative caged pose and G's gripper
    (dashed) holding the part at the same place."""
    drawn = sorted(range(len(rows)), key=lambda i: -rows[i]["d"])[:MAPS_DRAWN]
    fig = Figure(figsize=(4.2 * max(len(drawn), 2), 8.0), dpi=100, layout="constrained")
    FigureCanvasAgg(fig)
    grid = fig.add_gridspec(2, max(len(drawn), 1))
    ax = fig.add_subplot(grid[0, :])
    pos = np.arange(len(rows))
    for off, prefix, label, colour in ((-0.15, "g", G_GRIPPER, SCENE_COLOURS[0]),
                                       (0.15, "x", X_GRIPPER, SCENE_COLOURS[1])):
        ax.errorbar(pos + off, [r[f"{prefix}_area"] for r in rows],
                    yerr=[r[f"{prefix}_error"] for r in rows], fmt="o", capsize=3,
                    color=colour, label=label)
    ax.set_xticks(pos, [f"r={r['r']:g}\nμ={r['mu']:g}" + ("\n*" if r["verdict"] == "x* beats G"
                                                             else "") for r in rows],
                  fontsize=7)
    ax.set_ylabel("caging area at the finest h")
    ax.legend(fontsize=8)
    ax.set_title("Caging area of G and x* per part, error bars: change from the level before "
                 "(*: x* beats G beyond the error)", fontsize=9)
    for j, i in enumerate(drawn):
        row = rows[i]
        log(f"optimised maps: {j + 1}/{len(drawn)} (r = {row['r']:g}, mu = {row['mu']:g})")
        m = scene_map(st.scene, {d: row[f"x_{d}"] for d in DESIGN_DIMS}, row["r"], row["mu"])
        g = scene_map(st.scene, {d: row[f"g_{d}"] for d in DESIGN_DIMS}, row["r"], row["mu"])
        title = (f"x* for r={row['r']:g}, μ={row['mu']:g}: "
                 + " ".join(f"{d}={row[f'x_{d}']:.3g}" for d in DESIGN_DIMS)
                 + "\nG: " + " ".join(f"{d}={row[f'g_{d}']:.3g}" for d in DESIGN_DIMS)
                 + f"\nd = {fmt(row['d'])} ± {fmt(row['u'])} at h={fmt(row['h'])}")
        draw_map_panel(fig.add_subplot(grid[1, j]), m, title=title,
                       colorbar_label="energy V (unitless)", label=X_GRIPPER,
                       others=((g, G_GRIPPER),))
    fig.suptitle(f"Beyond the grid: sweep optimize ({NOTE_UNITLESS})", fontsize=11)
    return fig


def section(rows: list[dict], path: Path) -> list[str]:
    """The section of report.md."""
    n = sum(r["verdict"] == "x* beats G" for r in rows)
    limited = [r for r in rows if r["box_limited"]]
    from .data import md_table

    return [f"From `{path.name}` (docs/optimisation.md): per part the best design found in the "
            "continuous box (x*) against the grid's certified best (G), at the finest h both "
            "reached, each value with its error estimate (its change from the level before); "
            "x* beats G when d > u = error(x*) + error(G). box_limited: the constraints x* "
            "sits on whose relaxation by a step gains more than x*'s error.", "",
            f"x* beats G beyond the error on {n} of {len(rows)} parts; box-limited parts: "
            f"{len(limited)}.", "", md_table(rows, OPT_COLUMNS)]
