"""`sweep schedule`: variable geometry during the grasp, draw in with one setting and hold with
another (`sweep.runs.schedule`; MODEL 12; docs/variable-geometry.md).
"""
from __future__ import annotations

import math
import sys

import click

from .common import (EXIT_INTERRUPTED, PROGRESS, STORE, STORE_OUT, THREADS, SweepCommand,
                     UserError, interrupted_message)


def _numbers(text: str, what: str, count: int | None) -> list:
    bits = [b.strip() for b in text.split(",")]
    out = []
    for b in bits:
        try:
            v = float(b)
        except ValueError:
            raise UserError(f"{what}: {b!r} is not a number") from None
        if not math.isfinite(v) or v <= 0:
            raise UserError(f"{what}: {b!r} must be a positive finite number")
        out.append(v)
    if count is not None and len(out) != count:
        raise UserError(f"{what}: {text!r} needs {count} numbers separated by a comma")
    return out


def parse_chassis(items) -> tuple:
    """--chassis L1,L2 ... -> ((l1, l2), ...), each once, in order."""
    out = []
    for item in items:
        c = tuple(_numbers(item, f"--chassis {item}", 2))
        if c not in out:
            out.append(c)
    return tuple(out)


def parse_ladder(text: str | None) -> tuple:
    """--ladder H0,H1,... -> the spacings, coarse to fine (strictly decreasing)."""
    if text is None:
        return ()
    hs = _numbers(text, "--ladder", None)
    if any(b >= a for a, b in zip(hs, hs[1:])):
        raise UserError(f"--ladder {text}: the spacings must decrease (coarse to fine)")
    return tuple(hs)


def parse_parts(items, view) -> list:
    """--part R,MU ... -> [(r, mu)] values of the store (default: every part)."""
    import numpy as np

    r_vals, mu_vals = (list(map(float, view.coords[k])) for k in ("r", "mu"))
    if not items:
        return [(r, m) for r in r_vals for m in mu_vals]
    out = []
    for item in items:
        bits = item.split(",")
        if len(bits) != 2:
            raise UserError(f"--part: {item!r} is not R,MU (e.g. --part 0.4,0.4)")
        try:
            r, m = (float(b) for b in bits)
        except ValueError:
            raise UserError(f"--part: {item!r} is not R,MU (e.g. --part 0.4,0.4)") from None
        hit_r = [v for v in r_vals if np.isclose(v, r, rtol=1e-9, atol=1e-12)]
        hit_m = [v for v in mu_vals if np.isclose(v, m, rtol=1e-9, atol=1e-12)]
        if not hit_r or not hit_m:
            raise UserError(f"--part {item}: not a part of the store (r: "
                            f"{', '.join(f'{v:g}' for v in r_vals)}; mu: "
                            f"{', '.join(f'{v:g}' for v in mu_vals)})")
        if (hit_r[0], hit_m[0]) not in out:
            out.append((hit_r[0], hit_m[0]))
    return out


@click.command("schedule", cls=SweepCommand,
               short_help="Variable geometry in the grasp: draw in with one setting, hold with "
                          "another.")
@click.argument("store", type=STORE)
@click.option("--part", "part_items", multiple=True, metavar="R,MU",
              help="A part of the store (repeatable) [default: every part].")
@click.option("--chassis", "chassis_items", multiple=True, metavar="L1,L2",
              help="A chassis computed for every part besides the part's own best chassis "
                   "(repeatable) [default: 2.0,1.6].")
@click.option("--ladder", default=None, metavar="H0,H1,...",
              help="Grid spacings, coarse to fine: every setting at the first, the contenders "
                   "at the others; the last two give the error estimates [default: the "
                   "store's h, h/2, h/4].")
@click.option("--contenders", type=click.IntRange(1, 20), default=2, show_default=True,
              help="Best fixed settings and best switches carried to the next spacing, per "
                   "objective (besides the best R switch and w switch).")
@click.option("--third-switch", is_flag=True,
              help="Also measure, at the first spacing, the best schedule of three settings "
                   "(two switches) against the best of two.")
@click.option("--out", type=STORE_OUT, default=None,
              help="Results file [default: STORE's name + .schedule.h5, beside it].")
@THREADS
@PROGRESS
@click.option("--restart", is_flag=True,
              help="Discard the cases of an interrupted run instead of resuming.")
def schedule(store, part_items, chassis_items, ladder, contenders, third_switch, out, threads,
             progress, restart):
    """For a chassis (l1, l2) of a results store and a part, every schedule of two settings
    (R class, palm width w): draw the part in with setting X, then hold it with Y. Per part, on
    its best chassis and on the named ones: the best fixed setting against the best schedule,
    the gain with its error estimate, for caging and for tip prehension.

    \b
    sweep schedule results/paper.h5
    sweep schedule results/paper.h5 --part 0.8,0.4 --chassis 1.2,0.8
    sweep schedule results/paper.h5 --ladder 0.05,0.025 --third-switch

    A schedule reads two maps' trajectory ends on the chassis's shared lattice: from each start
    X's trajectory ends at q (caged, tip prehension or stalled), the setting switches to Y, and
    Y's trajectory from q ends the start (MODEL 12, model-notes D35). Every setting at the
    first spacing; the contenders at the finer ones (--ladder), each value's error estimate
    being its change from the spacing before, as in the refinement. The gain of the best
    schedule over the best fixed setting counts when it exceeds the sum of their errors,
    else it is reported as none.

    Results go into one HDF5 file (xarray opens it), written atomically; a rerun with the same
    store and options prints it again. A killed run resumes from OUT.work/.
    """
    from pathlib import Path

    from ..runs.runner import resolve_threads
    from ..runs.schedule import (DEFAULT_CHASSIS, ScheduleSettings, open_store, schedule_store,
                                 work_path)
    from ..storage.schedule import schedule_path

    chassis = parse_chassis(chassis_items) or DEFAULT_CHASSIS
    hs = parse_ladder(ladder)
    view, _ = open_store(store)
    parts = parse_parts(part_items, view)
    out = Path(out) if out is not None else schedule_path(store)
    if Path(out).resolve() == Path(store).resolve():
        raise UserError(f"--out {out}: that is the store itself")
    threads = resolve_threads(threads)
    settings = ScheduleSettings(hs, contenders, chassis, third_switch)
    try:
        res = schedule_store(store, out, parts, settings, threads=threads, progress=progress,
                             restart=restart)
    except KeyboardInterrupt as exc:
        where = work_path(out)
        hint = (f"the cases computed are kept in {where}; rerun the same command to resume"
                if where.exists() else "")
        click.echo(interrupted_message(exc, hint), err=True)
        sys.exit(EXIT_INTERRUPTED)
    if res.already_done:
        click.echo(f"{out} holds these results already; nothing computed")
    for line in summary_lines(out):
        click.echo(line)


def summary_lines(path) -> list:
    """What `sweep schedule` prints, read from its results file: per case and objective the
    best fixed setting and the best schedule with their errors, the gain and its verdict."""
    from ..storage.schedule import KINDS, OBJECTIVES, SOURCES, VERDICTS, read_schedules

    res = read_schedules(path)
    v, a = res["vars"], res["attrs"]
    h = v["h"]
    R, w = v["setting_R"], v["setting_w"]

    def setting(i) -> str:
        return f"R={R[i]:.4g} w={w[i]:.3g}" if i >= 0 else "none"

    lines = [f"{path}: {len(v['l1'])} cases of {a.get('store')}, ladder h = "
             + ", ".join(f"{x:g}" for x in h)]
    fixed, sched = KINDS.index("fixed"), KINDS.index("schedule")
    for c in range(len(v["l1"])):
        k = int(v["finest_level"][c])
        lines.append(f"r = {v['r'][c]:g}, mu = {v['mu'][c]:g} on l1 = {v['l1'][c]:g}, "
                     f"l2 = {v['l2'][c]:g} ({SOURCES[int(v['chassis_source'][c])]}), "
                     f"finest h = {h[k]:g}:")
        for o, objective in enumerate(OBJECTIVES):
            f_i, s_d, s_h = (int(v["best_draw"][c, o, fixed]), int(v["best_draw"][c, o, sched]),
                             int(v["best_hold"][c, o, sched]))
            fa, fe = v["best_area"][c, o, fixed, k], v["best_error"][c, o, fixed]
            sa, se = v["best_area"][c, o, sched, k], v["best_error"][c, o, sched]
            d, u = v["gain"][c, o], v["gain_error"][c, o]
            verdict = VERDICTS[int(v["verdict"][c, o])]
            lines.append(f"  {objective}: fixed {setting(f_i)} {fa:.4g} +- {fe:.2g}; schedule "
                         f"{setting(s_d)} -> {setting(s_h)} {sa:.4g} +- {se:.2g}; gain "
                         f"{d:.3g} +- {u:.2g}: {verdict}")
            if "third_area" in v:
                t = v["third_settings"][c, o]
                lines.append(f"    three settings {' -> '.join(setting(i) for i in t)}: "
                             + ", ".join(f"{x:.4g}" for x in v["third_area"][c, o]
                                         if math.isfinite(x))
                             + " against two " + ", ".join(
                                 f"{x:.4g}" for x in v["third_best_two"][c, o]
                                 if math.isfinite(x))
                             + f" (h = {h[0]:g}, {h[min(1, len(h) - 1)]:g}); the third switch "
                             + ("adds" if v["third_adds"][c, o] else "adds nothing")
                             + f" ({v['third_gain'][c, o]:.3g} +- {v['third_error'][c, o]:.2g})")
    lines.append(f"{a.get('computed_cases', 0)} cases computed in this run; "
                 f"{a.get('compute_seconds', 0.0):.1f} s of computing in all, "
                 f"{a.get('fraction_of_screening', math.nan):.3f} of the store's screening "
                 f"({a.get('screening_compute_seconds', math.nan):.1f} s)")
    return lines
