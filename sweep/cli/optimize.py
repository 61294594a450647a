"""`sweep optimize`: the best design between the grid's points, against the grid's best
(`sweep.runs.optimize`; docs/optimisation.md).
"""
from __future__ import annotations

import math
import sys

import click

from ..interrupts import EXIT_INTERRUPTED, interrupted_message
from .common import (PROGRESS, STORE, STORE_OUT, THREADS, SweepCommand, UserError)

PARAMS = ("l1", "l2", "r1", "r2", "w")


def _number(text: str, what: str) -> float:
    try:
        v = float(text)
    except ValueError:
        raise UserError(f"{what}: {text!r} is not a number") from None
    if not math.isfinite(v):
        raise UserError(f"{what}: {text!r} is not a finite number")
    return v


def _finite(ctx, param, value):
    """A number option's value must be finite (click's FloatRange lets nan through)."""
    if value is not None and not math.isfinite(value):
        raise click.BadParameter(f"{value!r} is not a finite number")
    return value


def _name(text: str, what: str) -> str:
    name = text.strip()
    if name not in PARAMS:
        raise UserError(f"{what}: unknown parameter {name!r} (one of {', '.join(PARAMS)})")
    return name


def _valid_value(name: str, v: float, what: str) -> None:
    if name == "w" and v < 0:
        raise UserError(f"{what}: w must be >= 0, got {v:g}")
    if name != "w" and v <= 0:
        raise UserError(f"{what}: {name} must be > 0, got {v:g}")


def parse_fixed(items) -> dict:
    """--fix l1=2.0 ... -> {name: value}."""
    out = {}
    for item in items:
        if "=" not in item:
            raise UserError(f"--fix: {item!r} is not NAME=VALUE (e.g. --fix l1=2.0)")
        k, v = item.split("=", 1)
        k = _name(k, "--fix")
        if k in out:
            raise UserError(f"--fix: {k} given twice")
        out[k] = _number(v, f"--fix {k}")
        _valid_value(k, out[k], f"--fix {k}")
    return out


def parse_bounds(items) -> dict:
    """--bounds l1=0.4:2.4 ... -> {name: (lower, upper)}."""
    out = {}
    for item in items:
        if "=" not in item or ":" not in item.split("=", 1)[1]:
            raise UserError(f"--bounds: {item!r} is not NAME=LOWER:UPPER (e.g. l1=0.4:2.4)")
        k, v = item.split("=", 1)
        k = _name(k, "--bounds")
        a, b = (_number(t, f"--bounds {k}") for t in v.split(":", 1))
        for x in (a, b):
            _valid_value(k, x, f"--bounds {k}")
        if not a < b:
            raise UserError(f"--bounds {k}: lower {a:g} must be below upper {b:g}")
        out[k] = (a, b)
    return out


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
        r, m = (_number(b, "--part") for b in bits)
        hit_r = [v for v in r_vals if np.isclose(v, r, rtol=1e-9, atol=1e-12)]
        hit_m = [v for v in mu_vals if np.isclose(v, m, rtol=1e-9, atol=1e-12)]
        if not hit_r or not hit_m:
            raise UserError(f"--part {item}: not a part of the store (r: "
                            f"{', '.join(f'{v:g}' for v in r_vals)}; mu: "
                            f"{', '.join(f'{v:g}' for v in mu_vals)})")
        if (hit_r[0], hit_m[0]) not in out:
            out.append((hit_r[0], hit_m[0]))
    return out


@click.command("optimize", cls=SweepCommand,
               short_help="The best design between the grid's points, against the grid's best.")
@click.argument("store", type=STORE)
@click.option("--part", "part_items", multiple=True, metavar="R,MU",
              help="A part of the store to optimise (repeatable) [default: every part].")
@click.option("--parts", type=click.Choice(["all"]), default=None,
              help="Every part of the store (the default; with --objective, one gripper for "
                   "them all).")
@click.option("--evaluations", type=click.IntRange(min=20), default=1500, show_default=True,
              help="Maps per part the search may compute at the store's spacing h (designs of "
                   "one equal-R class count once).")
@click.option("--seed", type=click.IntRange(min=0), default=0, show_default=True,
              help="Seed of the search: the same seed gives the same results.")
@click.option("--fix", "fix_items", multiple=True, metavar="NAME=VALUE",
              help="Hold a parameter at a value (repeatable), e.g. --fix l1=2.0.")
@click.option("--bounds", "bound_items", multiple=True, metavar="NAME=LOWER:UPPER",
              help="Search a parameter between these values instead of the store's smallest "
                   "and largest grid values (repeatable), e.g. --bounds l1=0.4:2.4.")
@click.option("--length-budget", type=float, default=None, metavar="L",
              help="Finger-length budget: only designs with l1 + l2 <= L.")
@click.option("--objective", type=click.Choice(["worst", "mean"]), default=None,
              help="Also one gripper for all the parts: maximise the worst (or mean) part's "
                   "caging area relative to that part's own optimum.")
@click.option("--joint-evaluations", type=click.IntRange(min=10), default=300,
              show_default=True,
              help="Designs the one-gripper search may score (each: one map per part).")
@click.option("--levels", type=click.IntRange(1, 4), default=2, show_default=True,
              help="Fidelity ladder: finalists recomputed at h/2 ... h/2^LEVELS.")
@click.option("--starts", type=click.IntRange(1, 20), default=4, show_default=True,
              help="Compass searches after the evolution (multi-start).")
@click.option("--seeds", "n_seeds", type=click.IntRange(1, 100), default=8, show_default=True,
              help="Grid designs seeded: the store's best, then the next distinct ones.")
@click.option("--tolerance", type=click.FloatRange(min=0.0), default=0.01, show_default=True,
              callback=_finite,
              help="Manufacturing tolerance of each parameter (model units), for robustness.")
@click.option("--friction-change", type=click.FloatRange(min=0.0), default=0.1,
              show_default=True, callback=_finite,
              help="Robustness in friction: the part's mu +- this.")
@click.option("--out", type=STORE_OUT, default=None,
              help="Results file [default: STORE's name + .optimize.h5, beside it].")
@THREADS
@PROGRESS
@click.option("--restart", is_flag=True,
              help="Discard the maps of an interrupted run instead of resuming.")
def optimize(store, part_items, parts, evaluations, seed, fix_items, bound_items,
             length_budget, objective, joint_evaluations, levels, starts, n_seeds, tolerance,
             friction_change, out, threads, progress, restart):
    """Search the continuous design box of a results store for each part's best design (caging
    area), and say honestly whether it beats the grid's certified best G.

    \b
    sweep optimize results/paper-collision.h5 --part 0.4,0.4
    sweep optimize results/paper-collision.h5 --parts all --objective worst
    sweep optimize paper.h5 --part 0.4,0.4 --bounds l1=0.4:2.4 --length-budget 3.6

    Per part: differential evolution seeded with G and the next distinct grid designs, then
    compass searches whose steps stay above the grid's noise, at the store's spacing h (every
    design class computed once); the finalists and G are recomputed at h/2, h/4 (--levels)
    as the refinement does, each value's error estimate being its change from the level
    before. Printed per part: x* and G with value +- error at the finest h both reached; "x*
    beats G by d +- u" when d exceeds u = error(x*) + error(G), else "no design found beats G
    beyond the error"; the constraints x* sits on with the change of a step inwards and
    outwards ("box-limited": relaxing it gains more than the error); the multi-start spread;
    maps and seconds; robustness over the tolerance box and mu +- --friction-change.

    Results (every map computed, seeds, finalists, verdicts, versions) go into one HDF5 file,
    written atomically; a rerun with the same store and options prints it again. A killed run
    resumes from OUT.work/ with identical results.
    """
    from pathlib import Path

    from ..runs.optimize import OptimizeSettings, default_box, optimize_store, work_path
    from ..runs.runner import resolve_threads
    from ..storage.optimized import optimization_path, read_identity
    from ..storage.store import read_store

    fixed = parse_fixed(fix_items)
    bounds = parse_bounds(bound_items)
    for k in fixed:
        if k in bounds:
            raise UserError(f"--fix {k} and --bounds {k}: give one")
    view = read_store(store)
    if "caging_area" not in view.variables:
        raise UserError(f"{store}: no caging_area variable (a store with the caging output)")
    chosen = parse_parts(part_items, view)
    if parts == "all" and part_items:
        raise UserError("--parts all and --part: give one")
    if objective and len(chosen) < 2:
        raise UserError("--objective: one gripper for several parts needs at least two parts")
    from ..config.parse import scene_from_frozen

    scene = scene_from_frozen(view.frozen)
    box = default_box(scene, bounds, fixed, length_budget)
    if length_budget is not None:
        lo = box.lo
        if not length_budget >= lo[0] + lo[1]:
            raise UserError(f"--length-budget: {length_budget:g} is below the shortest fingers "
                            f"the box allows (l1 + l2 = {lo[0] + lo[1]:g})")
    if not box.free:
        raise UserError("nothing to search: every parameter is fixed")
    # a tolerance as large as a whole link or pulley is no manufacturing tolerance, and its
    # corners' maps may not fit in memory (the long fuzz profile's --tolerance 1e300)
    smallest = min(float(v) for v in box.upper[:4])
    if not tolerance <= smallest:
        raise UserError(f"--tolerance: {tolerance:g} is larger than the box's smallest length "
                        f"or radius ({smallest:g}; l1, l2, r1, r2 at their upper bounds)")
    out = Path(out) if out is not None else optimization_path(store)
    # results of another identity are made again; anything else under that name (a store, the
    # input itself) is the user's and stays
    if out.exists() and read_identity(out) is None:
        raise UserError(f"--out: {out} exists and is not a results file of `sweep optimize`; "
                        "it is left alone (give another --out)")
    threads = resolve_threads(threads)
    settings = OptimizeSettings(evaluations=evaluations, seed=seed, n_seeds=n_seeds,
                                starts=starts, levels=levels, tolerance=tolerance,
                                friction_change=friction_change, objective=objective,
                                joint_evaluations=joint_evaluations)
    try:
        res = optimize_store(store, out, chosen, box, settings, threads=threads,
                             progress=progress, restart=restart)
    except KeyboardInterrupt as exc:
        where = work_path(out)
        hint = (f"the maps computed are kept in {where}; rerun the same command to resume"
                if where.exists() else "")
        click.echo(interrupted_message(exc, hint), err=True)
        sys.exit(EXIT_INTERRUPTED)
    if res.already_done:
        click.echo(f"{out} holds these results already; nothing computed")
    for line in summary_lines(out):
        click.echo(line)


def _design(d) -> str:
    return " ".join(f"{k}={v:.4g}" for k, v in zip(PARAMS, d))


def summary_lines(path) -> list:
    """What `sweep optimize` prints, read from its results file."""
    import numpy as np

    from ..storage.optimized import CONSTRAINTS, SIDE_MEANINGS, read_optimization

    res = read_optimization(path)
    v, a = res["vars"], res["attrs"]
    h = v["h"]
    lines = [f"{path}: {len(v['r'])} parts of {a['store']}, searched at h = {h[0]:g}"]
    for p in range(len(v["r"])):
        k = int(v["finest_level"][p])
        x, g = v["x_star_area"][p, k], v["grid_best_area"][p, k]
        d, u = v["difference"][p], v["uncertainty"][p]
        lines.append(f"part r = {v['r'][p]:g}, mu = {v['mu'][p]:g}:")
        lines.append(f"  x* {_design(v['x_star'][p])}: {x:.4g} +- {v['x_star_error'][p]:.2g}")
        lines.append(f"  G  {_design(v['grid_best'][p])}: {g:.4g} +- "
                     f"{v['grid_best_error'][p]:.2g}   (at h = {h[k]:g})")
        if v["beats"][p]:
            lines.append(f"  verdict: x* beats G by {d:.3g} +- {u:.2g} ({d / g:+.1%})"
                         if g > 0 else f"  verdict: x* beats G by {d:.3g} +- {u:.2g}")
        else:
            lines.append(f"  verdict: no design found beats G beyond the error "
                         f"(d = {d:.3g} +- {u:.2g})")
        on = []
        for c, name in enumerate(CONSTRAINTS):
            side = SIDE_MEANINGS[int(v["constraint_side"][p, c])]
            if side == "free":
                continue
            tag = "binds" if v["binds"][p, c] else "does not bind"
            on.append(f"{name} {side} ({tag}: a step in {v['inward_change'][p, c]:+.3g}, "
                      f"out {v['outward_change'][p, c]:+.3g})")
        lines.append("  on constraints: " + ("; ".join(on) if on else "none"))
        lim = [CONSTRAINTS[c] for c in range(len(CONSTRAINTS)) if v["binds"][p, c]]
        if lim:
            lines.append(f"  box-limited by {', '.join(lim)}: the stated bounds, not the "
                         "physics, limit this part")
        ends = v["start_end_area"][p]
        ends = ends[np.isfinite(ends)]
        lines.append(f"  multi-start: {ends.size} searches ended at "
                     f"{', '.join(f'{e:.4g}' for e in ends)} (spread {v['start_spread'][p]:.3g}); "
                     f"{int(v['search_maps'][p])} designs searched, {int(v['maps'][p])} maps, "
                     f"{v['seconds'][p]:.1f} s")
        fx, fg = v["x_star_friction_area"][p], v["grid_best_friction_area"][p]
        lines.append(f"  robustness at h = {h[min(1, len(h) - 1)]:g}: tolerance box min/median "
                     f"x* {v['x_star_tolerance_min'][p]:.4g}/{v['x_star_tolerance_median'][p]:.4g},"
                     f" G {v['grid_best_tolerance_min'][p]:.4g}/"
                     f"{v['grid_best_tolerance_median'][p]:.4g}; mu -/+: x* {fx[0]:.4g}/"
                     f"{fx[1]:.4g}, G {fg[0]:.4g}/{fg[1]:.4g}")
    joint = res.get("one_gripper")
    if joint:
        ja, jv = joint["attrs"], joint["vars"]
        obj = ja["objective"]
        obj = obj.decode() if isinstance(obj, bytes) else obj
        cons = ja["constraints"]
        cons = cons.decode() if isinstance(cons, bytes) else cons
        lines.append(f"one gripper ({obj} part): {_design(jv['design'])}; score {ja['score']:.3f}"
                     f" at h, {ja['score_half_h']:.3f} at h/2; on constraints: {cons}")
        lines.append("  loss against each part's own optimum at h/2: " + ", ".join(
            f"r={r:g} mu={m:g} {loss:.1%}" for r, m, loss in zip(v["r"], v["mu"], jv["loss"])))
    lines.append(f"{a.get('computed_maps', 0)} maps computed in this run, "
                 f"{a.get('compute_seconds', 0.0):.1f} s of computing in all")
    return lines
