"""Experiment 4, parameter usage under Scenario B (`parameter_usage.csv`,
`parameter_usage.png`): table, figure and reading."""
from __future__ import annotations

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from .data import PARAMETERS, StoreData, fmt, part_text, scene_name, short_scene


def usage_rows(st: StoreData) -> list[dict]:
    u = st.ds["parameter_usage"].transpose("r", "mu", "parameter")
    names = [str(p) for p in u["parameter"].values]
    rows = []
    for ri, mi in st.parts():
        vals = u.values[ri, mi]
        rows.append(dict(r=float(st.r[ri]), mu=float(st.mu[mi]),
                         **{p: float(vals[names.index(p)]) for p in PARAMETERS}))
    return rows


USAGE_COLUMNS = ["r", "mu"] + list(PARAMETERS)


def draw_usage(ax, vals: np.ndarray, none: str):
    """Parameter usage (parts x PARAMETERS, NaN: no positive pose, written `none`) as a
    heatmap with its values printed; returns the image."""
    ax.set_facecolor("#dddddd")
    im = ax.imshow(np.ma.masked_invalid(vals), cmap="viridis", vmin=0.0, vmax=1.0,
                   aspect="auto")
    for i in range(vals.shape[0]):
        for j in range(vals.shape[1]):
            v = vals[i, j]
            ax.text(j, i, none if np.isnan(v) else f"{v:.2f}", ha="center", va="center",
                    fontsize=8, color="black" if np.isnan(v) or v > 0.6 else "white")
    ax.set_xticks(range(len(PARAMETERS)), PARAMETERS)
    return im


def usage_figure(rows: list[dict]) -> Figure:
    vals = np.array([[row[p] for p in PARAMETERS] for row in rows])
    fig = Figure(figsize=(7.5, 0.42 * len(rows) + 2.2), dpi=110, layout="constrained")
    FigureCanvasAgg(fig)
    ax = fig.subplots()
    im = draw_usage(ax, vals, "no positive pose")
    ax.set_yticks(range(len(rows)), [f"r={row['r']:g}, μ={row['mu']:g}" for row in rows],
                  fontsize=8)
    ax.set_xlabel("design parameter")
    ax.set_ylabel("part (radius r, friction μ)")
    cb = fig.colorbar(im, ax=ax, pad=0.02)
    cb.set_label("usage: spread among hull-vertex geometries / search range\n"
                 "(averaged over poses with a positive value; unitless, 0..1)", fontsize=8)
    ax.set_title("Scenario B parameter usage per part", fontsize=11)
    return fig


def reading(st: StoreData, rep) -> list[str]:
    """The reading of experiment 4 (`rep`: the report's tables, `build.Report`)."""
    out = []
    u = np.array([[row[p] for p in PARAMETERS] for row in rep.usage])
    ok = ~np.isnan(u).any(axis=1)
    if ok.any():
        mean = u[ok].mean(axis=0)
        order = np.argsort(-mean, kind="stable")
        out.append(
            f"- Parameter usage (Scenario B), mean over the {int(ok.sum())} parts with a "
            "positive pose: " + ", ".join(f"{PARAMETERS[i]} {fmt(mean[i])}" for i in order)
            + f". Most used: {PARAMETERS[order[0]]}; least used: {PARAMETERS[order[-1]]}. "
            f"w's usage is at least {fmt(u[ok, 0].min())} on every such part.")
    if (~ok).any():
        out.append(f"- {int((~ok).sum())} part(s) have no pose with a positive Scenario B value "
                   "(usage NaN): " + "; ".join(part_text(rep.usage[i])
                                                for i in np.flatnonzero(~ok)) + ".")
    return out


# ---------------------------------------------------------------------------------------------
# Two scenes side by side (`compare.py`)
# ---------------------------------------------------------------------------------------------
def pair_figure(st1: StoreData, st2: StoreData, rows: list[dict]) -> Figure:
    """Scenario B's parameter usage per part, the two scenes side by side, one colour scale."""
    fig = Figure(figsize=(13, 0.42 * len(rows) + 2.4), dpi=100, layout="constrained")
    FigureCanvasAgg(fig)
    axs = fig.subplots(1, 2, sharey=True)
    im = None
    for ax, tag, st in zip(axs, ("1", "2"), (st1, st2)):
        vals = np.array([[row[f"{p}_{tag}"] for p in PARAMETERS] for row in rows])
        im = draw_usage(ax, vals, "none")
        ax.set_title(f"{scene_name(st)} ({short_scene(st)})", fontsize=10)
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
