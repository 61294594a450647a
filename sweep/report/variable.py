"""The report's section on variable geometry during the grasp (`sweep schedule`; MODEL 12,
model-notes D35, docs/variable-geometry.md), when the store has its schedules (`STORE` name +
`.schedule.h5` beside it): per case (a chassis and a part) and objective (caging, tip
prehension) the best fixed setting against the best schedule "draw in with X, then hold with
Y", each with its error estimate, the gain and its verdict; the figure draws the bars per part,
the schedules' settings (R and w before and after the switch) and, for two parts, both maps
with one start's path across the switch; the reading answers the paper's claim part by part.
The two-scene report (`compare.py`) has the section for each scene whose store has them.
"""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from matplotlib.lines import Line2D

from ..compute.maps import compute_map
from ..compute.schedules import chained, lattice_of, on_lattice, tie_key
from ..model import END_CAGED, REACHED, Design, Grid, Part
from ..storage.schedule import (KINDS, OBJECTIVES, SOURCES, STATUSES, VERDICTS, read_schedules,
                                schedule_path)
from .data import StoreData, fmt, md_table
from .plot import draw_map_panel, sliding_points, streamline_points
from .style import NOTE_UNITLESS, SCENE_COLOURS

VARIABLE_COLUMNS = ("r", "mu", "l1", "l2", "chassis", "objective", "h", "fixed_R", "fixed_w",
                    "fixed_area", "fixed_error", "draw_R", "draw_w", "hold_R", "hold_w",
                    "schedule_area", "schedule_error", "gain", "gain_error", "verdict",
                    "r_switch_area", "r_switch_error", "w_switch_area", "w_switch_error")
THIRD_COLUMNS = ("third_gain", "third_error", "third_adds")
#: Parts whose maps the figure draws across the switch.
MAPS_DRAWN = 2
PATH_COLOURS = ("white", "#ffd23f")      # the draw map's path, the hold map's


def schedule_file(st: StoreData) -> Path | None:
    """The store's schedules, if `sweep schedule` has been run on it (a file beside it made
    from another config is not this store's)."""
    p = schedule_path(st.path)
    if not p.is_file():
        return None
    try:
        made_from = read_schedules(p)["attrs"].get("config_hash")
    except (OSError, ValueError, KeyError):
        return None
    return p if made_from == st.attrs.get("config_hash") else None


# ---------------------------------------------------------------------------------------------
# The table
# ---------------------------------------------------------------------------------------------
def variable_rows(path: Path) -> list[dict]:
    """One row per case and objective (VARIABLE_COLUMNS, and THIRD_COLUMNS when the third
    switch was measured), read from the results file; `case` indexes the file's cases."""
    v = read_schedules(path)["vars"]
    R, w = v["setting_R"], v["setting_w"]
    fixed, sched = KINDS.index("fixed"), KINDS.index("schedule")
    rows = []
    for c in range(len(v["l1"])):
        k = int(v["finest_level"][c])
        source = SOURCES[int(v["chassis_source"][c])]
        status = STATUSES[int(v["part_status"][c])]
        chassis = ("part's best, " + status.replace("_", "-") if source == "part_best"
                   else "named")
        for o, objective in enumerate(OBJECTIVES):
            f_i = int(v["best_draw"][c, o, fixed])
            d_i, h_i = int(v["best_draw"][c, o, sched]), int(v["best_hold"][c, o, sched])
            fa, fe = float(v["best_area"][c, o, fixed, k]), float(v["best_error"][c, o, fixed])
            row = dict(case=c, r=float(v["r"][c]), mu=float(v["mu"][c]),
                       l1=float(v["l1"][c]), l2=float(v["l2"][c]), chassis=chassis,
                       source=source, objective=objective, h=float(v["h"][k]),
                       fixed_R=_at(R, f_i), fixed_w=_at(w, f_i), fixed_area=fa, fixed_error=fe,
                       draw=d_i, hold=h_i, draw_R=_at(R, d_i), draw_w=_at(w, d_i),
                       hold_R=_at(R, h_i), hold_w=_at(w, h_i),
                       schedule_area=float(v["best_area"][c, o, sched, k]),
                       schedule_error=float(v["best_error"][c, o, sched]),
                       gain=float(v["gain"][c, o]), gain_error=float(v["gain_error"][c, o]),
                       verdict=VERDICTS[int(v["verdict"][c, o])])
            for kind in ("r_switch", "w_switch"):
                i = KINDS.index(kind)
                row[f"{kind}_area"] = float(v["best_area"][c, o, i, k])
                row[f"{kind}_error"] = float(v["best_error"][c, o, i])
            if "third_gain" in v:
                row.update(third_gain=float(v["third_gain"][c, o]),
                           third_error=float(v["third_error"][c, o]),
                           third_adds=bool(v["third_adds"][c, o]))
            rows.append(row)
    return rows


def _at(values, i: int) -> float:
    return float(values[i]) if i >= 0 else math.nan


def columns(rows: list[dict]) -> tuple:
    return VARIABLE_COLUMNS + (THIRD_COLUMNS if rows and "third_gain" in rows[0] else ())


def _switch(row: dict) -> str:
    """How the best schedule changes the setting, in words."""
    if row["draw"] == row["hold"]:
        return "no switch"
    out = []
    if row["draw_R"] != row["hold_R"]:
        out.append(f"R {'down' if row['hold_R'] < row['draw_R'] else 'up'} "
                   f"{_g(row['draw_R'])} -> {_g(row['hold_R'])}")
    if row["draw_w"] != row["hold_w"]:
        out.append(f"w {'narrower' if row['hold_w'] < row['draw_w'] else 'wider'} "
                   f"{_g(row['draw_w'])} -> {_g(row['hold_w'])}")
    return ", ".join(out)


# ---------------------------------------------------------------------------------------------
# The figure
# ---------------------------------------------------------------------------------------------
def _part_best(rows: list[dict], objective: str) -> list[dict]:
    return [r for r in rows if r["source"] == "part_best" and r["objective"] == objective]


def _bars(ax, rows: list[dict], title: str) -> None:
    xs = np.arange(len(rows))
    for off, key, label, colour in ((-0.2, "fixed", "best fixed setting", SCENE_COLOURS[0]),
                                    (0.2, "schedule", "best schedule (draw in, then hold)",
                                     SCENE_COLOURS[1])):
        ax.bar(xs + off, [r[f"{key}_area"] for r in rows], width=0.4, color=colour,
               label=label, yerr=[r[f"{key}_error"] for r in rows], capsize=3,
               error_kw=dict(lw=1.0))
    ax.set_xticks(xs, [f"r={r['r']:g}\nμ={r['mu']:g}" + ("\n*" if r["verdict"] == "gain"
                                                         else "") for r in rows], fontsize=7)
    ax.set_xlim(-0.7, max(len(rows), 1) - 0.3)
    ax.grid(axis="y", alpha=0.3)
    ax.legend(fontsize=7.5, loc="upper right")
    ax.set_title(title, fontsize=9)


def _settings(ax_r, ax_w, rows_c: list[dict], rows_t: list[dict]) -> None:
    """Each part's best schedule as arrows from the draw setting to the hold setting: R on
    top, w below; caging left of the part's tick, tip prehension right."""
    for off, rows, colour in ((-0.15, rows_c, SCENE_COLOURS[1]), (0.15, rows_t, "#ff9f1c")):
        for x, r in enumerate(rows):
            for ax, key in ((ax_r, "R"), (ax_w, "w")):
                a, b = r[f"draw_{key}"], r[f"hold_{key}"]
                if not (math.isfinite(a) and math.isfinite(b)):
                    continue
                ax.plot([x + off], [a], "o", color=colour, ms=4, mfc="white")
                if a != b:
                    ax.annotate("", (x + off, b), (x + off, a),
                                arrowprops=dict(arrowstyle="-|>", color=colour, lw=1.4))
                else:
                    ax.plot([x + off], [b], "o", color=colour, ms=4)
    handles = [Line2D([], [], color=SCENE_COLOURS[1], marker="o", mfc="white",
                      label="caging: draw setting (open) -> hold setting"),
               Line2D([], [], color="#ff9f1c", marker="o", mfc="white",
                      label="tip prehension: draw -> hold"),
               Line2D([], [], ls="none", color="0.3", marker="o",
                      label="filled dot: no switch (the best is fixed)")]
    ax_r.legend(handles=handles, fontsize=7, loc="upper right")
    ax_r.set_yscale("log")
    ax_r.set_ylabel("R = r2/r1", fontsize=8)
    ax_w.set_ylabel("palm width w", fontsize=8)
    ticks = [f"r={r['r']:g}\nμ={r['mu']:g}" for r in rows_c]
    for ax in (ax_r, ax_w):
        ax.set_xticks(np.arange(len(ticks)), ticks, fontsize=7)
        ax.set_xlim(-0.7, max(len(ticks), 1) - 0.3)
        ax.grid(alpha=0.3)
    ax_r.set_title("the best schedules' settings, before and after the switch", fontsize=9)


def _map(st: StoreData, row: dict, setting: int, settings: dict, h: float):
    design = Design(row["l1"], row["l2"], settings["r1"][setting], settings["r2"][setting],
                    settings["w"][setting])
    sc = st.scene
    return compute_map(design, Part(row["r"], row["mu"]), sc.commands[0], Grid(h=h), sc.limits,
                       sc.accuracy, sc.effects)


def path_points(m, start: int) -> np.ndarray:
    """World points (n, 2) of map m's trajectory from its grid point `start` (flat index), by
    the map's own trajectory method, as the map pictures draw them."""
    f = m.fields
    point_class, equilibrium = np.asarray(f["point_class"]), np.asarray(f["equilibrium"], bool)
    stable = (point_class == REACHED) & equilibrium
    method = m.accuracy.trajectory
    if method == "continuous":
        energy = np.asarray(f["energy"], dtype=np.float64)
        return streamline_points(start, energy, point_class, equilibrium,
                                 np.asarray(f["caging_score"]) > 0, m.x, m.y)
    return sliding_points(start, m, stable, sliding=method == "sliding")[0]


def switch_start(draw, hold) -> tuple | None:
    """A start that the switch cages: its final end is caged, the draw map's own end is not;
    the one farthest from where it is finally held (first in flat order among ties). Returns
    (start, q, end) as flat indices of the draw map's grid (start, q) and the hold map's (end),
    or None."""
    h = float(draw.x[1] - draw.x[0])
    lat = lattice_of([draw, hold], h, draw.part.r)
    ex, ey = on_lattice(draw, lat), on_lattice(hold, lat)
    state, end = chained([ex, ey])
    pick = np.flatnonzero((state == END_CAGED) & (ex.state != END_CAGED))
    if not pick.size:
        return None
    xs = np.tile(lat.x, lat.ny)
    ys = np.repeat(lat.y, lat.nx)
    far = np.hypot(xs[pick] - xs[end[pick]], ys[pick] - ys[end[pick]])
    s = int(pick[int(np.argmax(far))])
    q = int(ex.end[s])

    def own(m, p):      # a lattice index as the flat index of map m's grid
        j, i = divmod(p, lat.nx)
        col = int(np.flatnonzero(lat.columns(m.x) == i)[0])
        return j * m.x.size + col

    return own(draw, s), own(draw, q), own(hold, q), own(hold, int(end[s]))


def variable_figure(st: StoreData, rows: list[dict], path: Path, log) -> Figure:
    """Top: per part (on its best chassis) the best fixed setting and the best schedule with
    their error bars, caging and tip prehension; middle: the best schedules' settings drawn;
    bottom: for the two parts where the caging schedule gains most, the draw map with one
    start's path to the switch and the hold map with its path from there."""
    data = read_schedules(path)["vars"]
    settings = {"r1": data["setting_r1"], "r2": data["setting_r2"], "w": data["setting_w"]}
    h0 = float(data["h"][0])
    rows_c, rows_t = _part_best(rows, "caging"), _part_best(rows, "tip_prehension")
    drawn = sorted([r for r in rows_c if r["draw"] != r["hold"] and r["draw"] >= 0],
                   key=lambda r: (r["verdict"] != "gain", -r["gain"]))[:MAPS_DRAWN]
    fig = Figure(figsize=(17, 24), dpi=80, layout="constrained")
    FigureCanvasAgg(fig)
    top, middle, bottom = fig.subfigures(3, 1, height_ratios=[1.0, 0.9, 2.2])
    ax_c, ax_t = top.subplots(1, 2)
    _bars(ax_c, rows_c, "caging area at the finest h (Λ h²), error bars: change from the h "
                        "before (*: gain beyond the error)")
    _bars(ax_t, rows_t, "tip-prehension area at the finest h (starts ending in tip prehension "
                        "x h²)")
    top.suptitle("Variable geometry in the grasp (MODEL 12): best fixed setting against the "
                 "best schedule, each part on its best chassis", fontsize=11)
    ax_r, ax_w = middle.subplots(2, 1, sharex=True)
    _settings(ax_r, ax_w, rows_c, rows_t)
    panels = bottom.subplots(max(len(drawn), 1), 2, squeeze=False).ravel()
    for j, row in enumerate(drawn):
        log(f"variable geometry maps: {j + 1}/{len(drawn)} (r = {row['r']:g}, "
            f"mu = {row['mu']:g})")
        draw = _map(st, row, row["draw"], settings, h0)
        hold = _map(st, row, row["hold"], settings, h0)
        picked = switch_start(draw, hold)
        for k, (m, which) in enumerate(((draw, "draw in"), (hold, "hold"))):
            ax = panels[2 * j + k]
            side = "draw" if k == 0 else "hold"
            title = (f"r={row['r']:g}, μ={row['mu']:g}, l1={row['l1']:g} l2={row['l2']:g}: "
                     f"{which} with R={row[side + '_R']:.4g}, w={row[side + '_w']:.3g} (map at "
                     f"h = {h0:g})\ncaging: best fixed {row['fixed_area']:.4g}, this schedule "
                     f"{row['schedule_area']:.4g}, gain {row['gain']:.3g} ± "
                     f"{row['gain_error']:.2g} at h = {row['h']:g}")
            at = None if picked is None else (picked[1] if k == 0 else picked[3])
            draw_map_panel(ax, m, title=title, at=at, colorbar_label=None, fontsize=8.0)
            if picked is None:
                continue
            start = picked[0] if k == 0 else picked[2]
            pts = path_points(m, start)
            ax.plot(pts[:, 0], pts[:, 1], color=PATH_COLOURS[k], lw=2.0, zorder=8,
                    label="from the start to the switch" if k == 0
                    else "after the switch, to where it is held")
            ax.plot(pts[:1, 0], pts[:1, 1], "o", color=PATH_COLOURS[k], ms=6, zorder=9,
                    mec="black")
            ax.legend(fontsize=7, loc="lower right")
    if not drawn:
        panels[0].set_axis_off()
        panels[0].text(0.5, 0.5, "no part's best caging schedule switches", ha="center")
    bottom.suptitle("One start across the switch: its path on the draw map to where the "
                    f"setting switches, then on the hold map ({NOTE_UNITLESS})", fontsize=11)
    return fig


# ---------------------------------------------------------------------------------------------
# The section and the reading
# ---------------------------------------------------------------------------------------------
def _claim(row: dict, objective: str) -> str:
    """What the part's best schedule of an objective says about "large R draws in, small R
    holds tip prehension"."""
    if row["verdict"] != "gain":
        return "no schedule beats the best fixed setting beyond the error"
    if row["draw_R"] == row["hold_R"]:
        return "the gain keeps R (a palm-width switch)"
    down = row["hold_R"] < row["draw_R"]
    if objective == "caging":
        return ("draws in with the larger R, as the claim says" if down else
                "draws in with the smaller R and holds with the larger (raising R pulls the "
                "part in), not the claim's order")
    return ("holds tip prehension with the smaller R, as the claim says" if down else
            "holds tip prehension with the larger R, against the claim")


def _g(v: float) -> str:
    """A number of the reading: three significant digits."""
    return "NaN" if not math.isfinite(v) else f"{v:.3g}"


def _kind_gain(row: dict, kind: str) -> tuple[float, float]:
    """(gain over the best fixed setting, its error) of the best switch of a kind; 0 where the
    two tie at TIE_DIGITS (the same starts in another order)."""
    a, e = row[f"{kind}_area"], row[f"{kind}_error"]
    d = a - row["fixed_area"]
    if math.isfinite(a) and tie_key(a) == tie_key(row["fixed_area"]):
        d = 0.0
    return d, e + row["fixed_error"]


def _palm_or_r(row: dict) -> tuple[str, str]:
    """Which single switch matters more for the part: ("w" | "R" | "", the words). A switch
    kind matters when it gains beyond its error; the palm matters more when its gain exceeds
    the R switch's by more than both switches' own errors (and the other way round)."""
    (w, uw), (r, ur) = _kind_gain(row, "w_switch"), _kind_gain(row, "r_switch")
    if not (math.isfinite(w) and math.isfinite(r)):
        return "", "a single switch could not be compared"
    text = (f"a palm-width switch alone {_g(w)} ± {_g(uw)}, an R switch alone {_g(r)} ± "
            f"{_g(ur)}")
    if not (w > uw or r > ur):
        return "", f"neither switch alone gains beyond the error ({text})"
    apart = row["w_switch_error"] + row["r_switch_error"]
    if w - r > apart and w > uw:
        return "w", f"the palm width matters more ({text})"
    if r - w > apart and r > ur:
        return "R", f"R matters more ({text})"
    return "", f"the palm width and R are not separated ({text})"


def _one(row: dict) -> str:
    fixed = (f"fixed R {_g(row['fixed_R'])}, w {_g(row['fixed_w'])}: "
             f"{_g(row['fixed_area'])} ± {_g(row['fixed_error'])}")
    if row["draw"] == row["hold"]:
        return f"{fixed}; no schedule does better"
    return (f"{fixed}; best schedule {_switch(row)}: {_g(row['schedule_area'])} ± "
            f"{_g(row['schedule_error'])}, gain {_g(row['gain'])} ± {_g(row['gain_error'])}")


def reading(rows: list[dict]) -> list[str]:
    """The paper's claim, part by part ("a variable transmission ratio is needed to either draw
    a part into a cage (large R) or maintain a tip prehension grasp (small R)"), and where a
    palm-width switch matters more; every number from the table."""
    out = []
    pairs = list(zip(_part_best(rows, "caging"), _part_best(rows, "tip_prehension")))
    for c, t in pairs:
        out.append(f"- r = {fmt(c['r'])}, mu = {fmt(c['mu'])} (l1 = {fmt(c['l1'])}, l2 = "
                   f"{fmt(c['l2'])}, h = {fmt(c['h'])}). Caging: {_one(c)}: "
                   f"{_claim(c, 'caging')}; {_palm_or_r(c)[1]}. Tip prehension: {_one(t)}: "
                   f"{_claim(t, 'tip_prehension')}.")
    gains = [c for c, _ in pairs if c["verdict"] == "gain"]
    down = [c for c in gains if c["hold_R"] < c["draw_R"]]
    up = [c for c in gains if c["hold_R"] > c["draw_R"]]
    same = [c for c in gains if c["hold_R"] == c["draw_R"]]
    tips = [t for _, t in pairs if t["verdict"] == "gain"]
    tip_down = [t for t in tips if t["hold_R"] < t["draw_R"]]
    tip_up = [t for t in tips if t["hold_R"] > t["draw_R"]]
    static = [c for c, t in pairs if c["fixed_R"] > t["fixed_R"]]
    palm = [c for c, _ in pairs if _palm_or_r(c)[0] == "w"]
    rmore = [c for c, _ in pairs if _palm_or_r(c)[0] == "R"]

    def names(rs):
        return "; ".join(f"r = {fmt(r['r'])}, mu = {fmt(r['mu'])}" for r in rs) or "none"

    n = len(pairs)
    out.append(f"- Over the {n} parts, each on its best chassis: a caging schedule beats the "
               f"best fixed setting beyond the error on {len(gains)} ({names(gains)}). Of "
               f"those it lowers R (large R draws in, as the claim says) on {len(down)} "
               f"({names(down)}), raises R (draws in with the smaller R, holds with the "
               f"larger) on {len(up)} ({names(up)}) and keeps R, switching the palm width "
               f"only, on {len(same)} ({names(same)}).")
    out.append(f"- Tip prehension: a schedule beats the best fixed setting beyond the error on "
               f"{len(tips)} parts ({names(tips)}); it holds with the smaller R, as the claim "
               f"says, on {len(tip_down)} ({names(tip_down)}) and with the larger on "
               f"{len(tip_up)} ({names(tip_up)}).")
    out.append(f"- Without a switch, the best fixed setting for caging has a larger R than the "
               f"best fixed setting for tip prehension on {len(static)} of {n} parts: the "
               "claim's \"large R cages, small R holds tip prehension\" holds between fixed "
               f"designs there. For caging, the palm width matters more than R (each switched "
               f"alone) on {len(palm)} parts ({names(palm)}) and R more on {len(rmore)} "
               f"({names(rmore)}).")
    if rows and "third_gain" in rows[0]:
        adds = [r for r in rows if r["third_adds"]]
        out.append(f"- A third switch (three settings) adds beyond the error on {len(adds)} of "
                   f"{len(rows)} case-objectives"
                   + (": " + "; ".join(f"r = {fmt(r['r'])}, mu = {fmt(r['mu'])}, l1 = "
                                       f"{fmt(r['l1'])}, l2 = {fmt(r['l2'])}, "
                                       f"{r['objective']}: {_g(r['third_gain'])} ± "
                                       f"{_g(r['third_error'])}" for r in adds) if adds else "")
                   + ".")
    return out


def section(rows: list[dict], path: Path) -> list[str]:
    """The section of report.md: the rules, the table, the reading."""
    a = read_schedules(path)["attrs"]
    n_gain = sum(r["verdict"] == "gain" and r["objective"] == "caging" for r in rows)
    n_cases = sum(r["objective"] == "caging" for r in rows)
    return [f"From `{path.name}` (`sweep schedule`, docs/variable-geometry.md): per chassis "
            "and part, every schedule of two settings (R class, palm width w) of the config: "
            "draw the part in with one setting, then hold it with another (MODEL 12, "
            "model-notes D35). h-ladder " + ", ".join(fmt(h) for h in a.get("ladder", []))
            + f"; the best fixed setting and the best schedule at the finest h, each with its "
            "error estimate (its change from the h before); the gain counts when it exceeds "
            "the sum of the two errors (verdict gain), else none. Computing: "
            f"{_g(float(a.get('compute_seconds', math.nan)))} s, "
            f"{_g(float(a.get('fraction_of_screening', math.nan)))} of the store's screening "
            "compute (not side by side: docs/performance.md has the measured ratio).",
            "", f"A caging schedule gains beyond the error in {n_gain} of {n_cases} cases.", "",
            md_table(rows, list(columns(rows))), "", "Reading, part by part:", ""] \
        + reading(rows)
