"""`sweep top`, `sweep show`: what a results store holds, as tables.
"""
from __future__ import annotations

from pathlib import Path

import click

from .common import STORE, SWEEP_FILE, SweepCommand, UserError


TOP_COLUMNS = ("Lambda", "caging_area", "n_caged", "n_tip_prehension", "n_ejection", "n_stalled",
               "n_reached")


@click.command("top", cls=SweepCommand, short_help="Best designs of each part, as tables.")
@click.argument("results", type=STORE)
@click.option("--r", "r", type=float, default=None,
              help="Part radius (a value of the store); default: every radius.")
@click.option("--mu", type=float, default=None,
              help="Part friction (a value of the store); default: every value.")
@click.option("-n", "n", type=int, default=None,
              help="How many designs per part [default: 10 for one part, else 1].")
@click.option("--by", default=None,
              help="Summary variable to rank by (e.g. Lambda, caging_area, n_caged) "
                   "[default: the refined ranking when the store is refined, else Lambda].")
@click.option("--ascending", is_flag=True, help="Smallest first.")
@click.option("--command", "command", type=int, default=0, show_default=True,
              help="Command index, for stores with several commands.")
def top(results, r, mu, n, by, ascending, command):
    """Print the best designs of each part (r, mu) of a results store, as tables.

    In a refined store (`refine:`, `sweep refine`) the designs are ranked by the refinement:
    the designs still in the running at the finest grid first (the best, then its near-tie
    set), then the other contenders, then the rest, each group by refined caging area (the
    screened one for designs not refined); each part's table is headed by its best design, its
    lead over the runner-up, the finest h reached and "certified" or the near-tie set. Otherwise,
    and with --by, designs are ranked by that screened summary variable (default Lambda, the
    paper's caging metric), largest first unless --ascending; ties keep the store's order.
    Without --r / --mu every part of the store is listed (by default its best design only).
    Examples: sweep top paper.h5 --r 0.4 --mu 0.1 -n 10; sweep top paper.h5 --by n_caged
    """
    import numpy as np

    from ..schema import SUMMARY_FIELDS
    from ..storage.store import read_store

    if by is not None and by not in SUMMARY_FIELDS:
        raise UserError(f"--by: unknown field {by!r} (valid: {', '.join(SUMMARY_FIELDS)})")
    if n is None:
        n = 10 if (r is not None and mu is not None) else 1
    if n < 1:
        raise UserError(f"-n: must be >= 1, got {n}")
    view = read_store(results)
    if by is None and not view.refine:
        by = "Lambda"
    chosen = {}
    for name, value in (("r", r), ("mu", mu)):
        coord = view.coords[name]
        if value is None:
            chosen[name] = list(range(coord.size))
            continue
        hits = np.flatnonzero(np.isclose(coord, value, rtol=1e-9, atol=1e-12))
        if hits.size != 1:
            raise UserError(f"--{name}: {value:g} is not in the store (values: "
                                  f"{', '.join(f'{v:g}' for v in coord)})")
        chosen[name] = [int(hits[0])]
    ncmd = view.coords["command"].size if "command" in view.dims else 1
    if not 0 <= command < ncmd:
        raise UserError(f"--command: must be an index 0..{ncmd - 1}, got {command}")
    for k, (ri, mui) in enumerate((a, b) for a in chosen["r"] for b in chosen["mu"]):
        if k:
            click.echo("")
        _print_top(view, ri, mui, n, by, ascending, command)


def _design_text(designs, d) -> str:
    l1, l2, r1, r2, w = designs[d]
    return f"l1={l1:g} l2={l2:g} r1={r1:g} r2={r2:g} w={w:g}"


def _refined_header(view, designs, pick, pick_part):
    """Lines describing one part's refinement, the refined ranking and the outcome."""
    import numpy as np

    from ..storage.refined import equal_r_classes, part_outcome, ranking

    ref = view.refine
    role, value, error = (pick(ref[k]) for k in ("refine_role", "refined_caging_area",
                                                  "refined_error"))
    widened = "refine_widenings" in ref
    out = part_outcome(equal_r_classes(designs), role, value, error,
                       pick_part(ref["refine_status"]), pick_part(ref["refine_finest_h"]),
                       pick_part(ref["refine_margin"]), pick_part(ref["refine_bound_held"]),
                       pick_part(ref["refine_widenings"]) if widened else None,
                       pick_part(ref["refine_n_readmitted"]) if widened else 0,
                       tuple(pick_part(ref[k]) for k in ("refine_audit_designs",
                                                         "refine_audit_rise", "refine_audit_h"))
                       if "refine_audit_designs" in ref else None)
    order = ranking(role, value, pick(view.variables["caging_area"]).astype(np.float64))
    if out.status == "not_refined":
        return ["  refinement: not refined (no design cages at the screening spacing)"], \
            order, out
    twins = f" (+{out.n_best - 1} equal-R)" if out.n_best > 1 else ""
    b = out.best
    rel = out.margin / value[b] if value[b] > 0 else float("nan")
    lines = [f"  refinement: {out.status.replace('_', '-')} at h = {out.finest_h:g}; best "
             f"{_design_text(designs, b)}{twins}, refined caging area {value[b]:.6g} "
             f"(error {error[b]:.2g}), lead over the runner-up {out.margin:.3g} ({rel:.2%})"
             + (f"; {out.bound_note()}" if out.bound_note() else ""),
             f"  designs left out: {out.audit_note()}"]
    if not out.certified:
        lines.append(f"  near-tie set ({len(out.members)}): " + "; ".join(
            f"{_design_text(designs, d)}: {value[d]:.6g} +- {error[d]:.2g}"
            for d in out.members))
    return lines, order, out


def _print_top(view, ri, mui, n, by, ascending, command):
    import numpy as np

    from ..storage.refined import designs_of_coords

    sel = {"r": ri, "mu": mui}
    if "command" in view.dims:
        sel["command"] = command
    design_dims = ("l1", "l2", "r1", "r2", "w")

    def pick(arr):
        index = tuple(sel.get(d, slice(None)) for d in view.dims)
        return arr[index].reshape(-1)       # remaining dims are design_dims, in order

    def pick_part(arr):
        return arr[(ri, mui) + ((command,) if "command" in view.dims else ())]

    values = {f: pick(view.variables[f]) for f in view.variables}
    designs = designs_of_coords(view.coords)
    header = []
    refined = by is None
    if refined:
        header, order, _ = _refined_header(view, designs, pick, pick_part)
        order = order[:n]
        values["refined_caging_area"] = pick(view.refine["refined_caging_area"])
        values["refined_error"] = pick(view.refine["refined_error"])
        level = pick(view.refine["refined_level"]).astype(np.float64)
        values["refined_h"] = np.where(level > 0, view.attrs["grid_h"] / 2.0 ** level, np.nan)
        cols = ["refined_caging_area", "refined_error", "refined_h"] + list(TOP_COLUMNS)
        what = "the refined ranking"
    else:
        key = values[by].astype(np.float64)
        key = np.where(np.isnan(key), -np.inf if not ascending else np.inf, key)
        order = np.argsort(key if ascending else -key, kind="stable")[:n]
        cols = list(TOP_COLUMNS) if by in TOP_COLUMNS else [by] + list(TOP_COLUMNS)
        what = f"{by}{' (ascending)' if ascending else ''}"
    head = ["rank"] + list(design_dims) + cols
    rows = []
    for rank, i in enumerate(order, 1):
        row = [str(rank)] + [f"{designs[i][k]:g}" for k in range(len(design_dims))]
        for c in cols:
            v = values[c][i]
            row.append(("-" if np.isnan(v) else f"{v:.6g}")
                       if np.issubdtype(values[c].dtype, np.floating) else f"{v:d}")
        rows.append(row)
    widths = [max(len(h), *(len(r_[k]) for r_ in rows)) for k, h in enumerate(head)]
    cmd = ""
    if "command" in view.dims:
        cmd = f", command {command}"
    elif "f_left" in view.attrs:
        cmd = f", F_left {view.attrs['f_left']:g}, F_right {view.attrs['f_right']:g}"
    click.echo(f"part r = {view.coords['r'][sel['r']]:g}, mu = {view.coords['mu'][sel['mu']]:g}"
               f"{cmd}: top {len(rows)} of {designs.shape[0]:,} designs by {what}; screened at "
               f"h = {view.attrs.get('grid_h', '?')}")
    for line in header:
        click.echo(line)
    click.echo("  ".join(h.rjust(w) for h, w in zip(head, widths)))
    for row in rows:
        click.echo("  ".join(v.rjust(w) for v, w in zip(row, widths)))


@click.command("show", cls=SweepCommand,
               short_help="What a results store (or any sweep file) holds.")
@click.argument("results", type=SWEEP_FILE)
def show(results):
    """Print what a results store holds: dimensions, variables, config, effects, grid,
    provenance and timings. Shard and part files, and single maps (`sweep map`,
    outputs.save_maps), get a short description."""
    import numpy as np

    from ..storage.itemfile import read_item_file
    from ..storage.store import CorruptFile, StoreError, read_store

    try:
        view = read_store(results)
    except StoreError as store_exc:
        try:
            b = read_item_file(results, with_data=False)
        except CorruptFile:
            lines = _describe_map_file(results)
            if lines is None:
                raise UserError(str(store_exc)) from None
            click.echo("\n".join(lines))
            return
        click.echo(f"{results}: {b.kind} of sweep {b.frozen.get('name')!r}, items "
                   f"{b.start}-{b.stop} of {b.frozen and _n_items(b)}"
                   + (f", chunk {b.chunk} of {b.n_chunks}" if b.chunk is not None else ""))
        click.echo(f"  config {b.config_hash[:12]}, sweep {b.version}, compute "
                   f"{b.compute_seconds:.1f} s")
        return
    a = view.attrs
    click.echo(f"{results}: results store of sweep {a.get('name')!r} ({a.get('created_by')}, "
               f"{a.get('created_utc')})")
    shape = " x ".join(f"{d} {view.coords[d].size}" for d in view.dims)
    click.echo(f"  {int(a.get('n_maps', 0)):,} maps on {shape}")
    for d in view.dims:
        v = view.coords[d]
        click.echo(f"    {d:<8} {', '.join(f'{x:g}' for x in v)}")
    click.echo("  variables (" + ", ".join(view.dims) + "):")
    for name, arr in view.variables.items():
        ln = view.var_attrs[name].get("long_name", "")
        click.echo(f"    {name:<17} {str(arr.dtype):<8} {ln}")
    click.echo(f"  grid: h = {a.get('grid_h')}, bounds {a.get('grid_bounds')}; limits theta2 "
               f"[{a.get('theta2_min_deg')}, {a.get('theta2_max_deg')}] deg; accuracy: "
               f"reconfig_step {a.get('reconfig_step')}, root_tol {a.get('root_tol')}, "
               f"trajectory {a.get('trajectory')}")
    if "f_left" in a:
        click.echo(f"  command: F_left {a['f_left']:g}, F_right {a['f_right']:g}")
    click.echo(f"  effects on: {a.get('effects_on')}")
    click.echo(f"  config {str(a.get('config_hash'))[:12]}, sweep {a.get('sweep_version')}, "
               f"numba {a.get('numba_version')}, numpy {a.get('numpy_version')}, "
               f"HDF5 {a.get('hdf5_version')}")
    timing = [f"compute {a['compute_seconds']:.1f} s" if "compute_seconds" in a else "",
              f"wall {a['wall_seconds']:.1f} s" if "wall_seconds" in a else "",
              f"{a['maps_per_second']:,.0f} maps/s" if "maps_per_second" in a else ""]
    click.echo("  timings: " + ", ".join(t for t in timing if t))
    if view.refine:
        click.echo(f"  refinement: {a.get('refine_counts')}; levels h = "
                   f"{', '.join(f'{x:g}' for x in np.atleast_1d(a.get('refine_level_h', [])))}; "
                   f"cap bound {a.get('refine_bound')}, at least {a.get('refine_min_contenders')} "
                   f"contenders; {a.get('refine_compute_seconds', float('nan')):.1f} s of compute "
                   f"(variables: {', '.join(view.refine)})")
        if "refine_widenings" in view.refine:
            widened = int(np.count_nonzero(view.refine["refine_widenings"]))
            click.echo(f"  bound check: {widened} part{'s' if widened != 1 else ''} widened, "
                       f"{int(np.sum(view.refine['refine_n_readmitted'])):,} designs re-admitted, "
                       f"{int(a.get('refine_widen_maps', 0)):,} maps")
        else:
            click.echo("  bound check: refined by an earlier version that did not re-admit "
                       "designs (`sweep refine` refines it again)")
    if "saved_maps" in a:
        import json

        names = json.loads(a["saved_maps"])
        click.echo(f"  {len(names)} full maps saved in {a.get('saved_maps_dir')}:")
        for name in names:
            click.echo(f"    {name}")


def _describe_map_file(path: Path) -> list[str] | None:
    """A few lines about a single-map file, or None if `path` is not one."""
    import json

    import h5py

    try:
        with h5py.File(path, "r") as f:
            if "energy" not in f or "design" not in f.attrs:
                return None
            a = {k: (v.decode() if isinstance(v, bytes) else v) for k, v in f.attrs.items()}
            ny, nx = f["energy"].shape
    except (OSError, KeyError, ValueError):
        return None

    def fmt(key):
        try:
            return ", ".join(f"{k} {v:g}" for k, v in json.loads(a[key]).items()
                             if isinstance(v, (int, float)))
        except (KeyError, TypeError, ValueError):
            return "?"

    return [f"{path}: one energy map (written by `sweep map` or a sweep's outputs.save_maps; "
            "`sweep show` describes results stores in full, open this one with xarray)",
            f"  design: {fmt('design')}; part: {fmt('part')}; command: {fmt('command')}",
            f"  grid: {ny} x {nx} points at h = {a.get('h')}; Lambda {a.get('Lambda')}, "
            f"caging_area {a.get('caging_area')}, caged {a.get('n_caged')}, "
            f"reached {a.get('n_reached')}",
            f"  sweep {a.get('sweep_version')}, written {a.get('created_utc')}"]


def _n_items(b) -> str:
    try:
        from ..config.parse import scene_from_frozen

        return f"{scene_from_frozen(b.frozen).n_items:,}"
    except Exception:  # noqa: BLE001 - display only
        return "?"
