"""Compare two sweep stores of the same designs and parts run with different effects (e.g. the
paper sweep without and with finger_collision): totals of the class counts, Lambda, and the
best design (largest Lambda) of every part. Prints Markdown.

    .venv/bin/python scripts/compare_effect_stores.py base.h5 effect.h5
    .venv/bin/python scripts/compare_effect_stores.py base.h5 effect.h5.parts --partial [L1]

With --partial, the second argument is the part-file directory of an unfinished run.
"""
from __future__ import annotations

import sys

import numpy as np

from sweep.storage.store import read_store

COUNTS = ("n_reached", "n_vertex", "n_eject", "n_unreached", "n_infeasible", "n_equilibrium",
          "n_caged", "n_caged_points", "n_caged_crossed")
DESIGN_DIMS = ("l1", "l2", "r1", "r2", "w")


def best_designs(view):
    """{(r, mu): (design tuple, Lambda)} from a store with dims including l1 l2 r1 r2 w r mu."""
    lam = view.variables["Lambda"]
    dims = list(view.dims)
    if "command" in dims:  # one command: drop it
        lam = np.take(lam, 0, axis=dims.index("command"))
        dims.remove("command")
    out = {}
    ir, imu = dims.index("r"), dims.index("mu")
    for a, r in enumerate(view.coords["r"]):
        for b, mu in enumerate(view.coords["mu"]):
            sub = np.take(np.take(lam, a, axis=ir), b, axis=imu - (imu > ir))
            sub_dims = [d for d in dims if d not in ("r", "mu")]
            k = np.unravel_index(int(np.nanargmax(sub)), sub.shape)
            design = tuple(float(view.coords[d][k[sub_dims.index(d)]]) for d in DESIGN_DIMS)
            out[(float(r), float(mu))] = (design, float(sub[k]))
    return out


def main(base_path, effect_path):
    base, eff = read_store(base_path), read_store(effect_path)
    print(f"base: {base_path} (effects {base.attrs.get('effects_on')}); "
          f"effect: {effect_path} (effects {eff.attrs.get('effects_on')})\n")
    print("| count (sum over all maps) | base | with effect | change |")
    print("|---|---|---|---|")
    for name in COUNTS + ("n_collision_changed",):
        a = base.variables.get(name)
        b = eff.variables.get(name)
        sa = int(np.sum(a)) if a is not None else None
        sb = int(np.sum(b)) if b is not None else None
        change = f"{sb - sa:+,}" if sa is not None and sb is not None else ""
        print(f"| {name} | {'' if sa is None else f'{sa:,}'} | "
              f"{'' if sb is None else f'{sb:,}'} | {change} |")
    la, lb = base.variables["Lambda"], eff.variables["Lambda"]
    print(f"\nLambda summed over all maps: base {np.sum(la):,.0f}, with effect {np.sum(lb):,.0f} "
          f"({np.sum(lb) / np.sum(la):.3f} of base); maps whose Lambda changed: "
          f"{int(np.sum(la != lb)):,} of {la.size:,}\n")
    ba, bb = best_designs(base), best_designs(eff)
    print("Best design per part. Configurations depend on the pulley radii only through "
          "R = r2/r1 (MODEL 11), so designs with the same l1, l2, R, w are the same gripper "
          "and tie (to round-off); 'same' compares (l1, l2, R, w).\n")
    print("| part (r, mu) | base best (l1, l2, r1, r2, w) | R | Lambda | with effect | R | Lambda "
          "| same |")
    print("|---|---|---|---|---|---|---|---|")
    for part in ba:
        (da, va), (db, vb) = ba[part], bb[part]
        print(f"| {part[0]:g}, {part[1]:g} | {', '.join(f'{v:g}' for v in da)} | "
              f"{da[3] / da[2]:.3g} | {va:,.0f} | {', '.join(f'{v:g}' for v in db)} | "
              f"{db[3] / db[2]:.3g} | {vb:,.0f} | {'yes' if same_gripper(da, db) else 'no'} |")


def same_gripper(a, b):
    """Same l1, l2, w and R = r2/r1 (the configurations depend on the radii only through R)."""
    return (a[0], a[1], a[4]) == (b[0], b[1], b[4]) and abs(a[3] / a[2] - b[3] / b[2]) < 1e-9




def compare_partial(base_path, parts_dir, l1_best=None):
    """Compare a finished base store with the finished part files of an unfinished run of the
    same designs (another scene), on the maps both have. Best designs per part are taken among
    the designs with l1 == l1_best (a complete slice of the table) when given."""
    from pathlib import Path

    from sweep.schema import SUMMARY_FIELDS
    from sweep.storage.itemfile import read_item_file

    base = read_store(base_path)
    # store dims (l1 l2 r1 r2 w r mu) -> item order (l1 l2 r [command] r1 r2 mu) x w
    order = ("l1", "l2", "r", "r1", "r2", "mu", "w")
    perm = [list(base.dims).index(d) for d in order]
    n_w = len(base.coords["w"])
    full_base = {n: np.transpose(base.variables[n], perm).reshape(-1, n_w) for n in SUMMARY_FIELDS
                 if n in base.variables}
    n_items = next(iter(full_base.values())).shape[0]
    eff = np.full((n_items, n_w, len(SUMMARY_FIELDS)), np.nan)
    covered = np.zeros(n_items, dtype=bool)
    for p in sorted(Path(parts_dir).glob("*.h5")):
        b = read_item_file(p)
        eff[b.start:b.stop] = b.data
        covered[b.start:b.stop] = True
    idx = {n: k for k, n in enumerate(SUMMARY_FIELDS)}
    print(f"maps compared: {covered.sum() * n_w:,} of {n_items * n_w:,} "
          f"(items {np.flatnonzero(covered).min()}..{np.flatnonzero(covered).max()})\n")
    print("| count (sum over the maps compared) | base | with effect | change |")
    print("|---|---|---|---|")
    for name in COUNTS + ("n_collision_changed",):
        sb = int(np.sum(eff[covered, :, idx[name]]))
        if name in full_base:
            sa = int(np.sum(full_base[name][covered]))
            print(f"| {name} | {sa:,} | {sb:,} | {sb - sa:+,} |")
        else:
            print(f"| {name} |  | {sb:,} |  |")
    la, lb = full_base["Lambda"][covered], eff[covered, :, idx["Lambda"]]
    print(f"\nLambda summed over the maps compared: base {la.sum():,.0f}, with effect "
          f"{lb.sum():,.0f} ({lb.sum() / la.sum():.3f} of base); maps whose Lambda changed: "
          f"{int(np.sum(la != lb)):,} of {la.size:,}\n")
    if l1_best is None:
        return
    shape = tuple(len(base.coords[d]) for d in order[:-1])
    items = np.arange(n_items).reshape(shape)
    il1 = int(np.flatnonzero(np.isclose(base.coords["l1"], l1_best))[0])
    print(f"Best design (largest Lambda) per part among the designs with l1 = {l1_best:g}:\n")
    print("| part (r, mu) | base best (l1, l2, r1, r2, w) | Lambda | with effect | Lambda | same |")
    print("|---|---|---|---|---|---|")
    for ir, r in enumerate(base.coords["r"]):
        for imu, mu in enumerate(base.coords["mu"]):
            sel = items[il1, :, ir, :, :, imu].reshape(-1)
            if not covered[sel].all():
                print(f"| {r:g}, {mu:g} | not covered |  |  |  |  |")
                continue
            rows = []
            for vals in (full_base["Lambda"][sel], eff[sel, :, idx["Lambda"]]):
                k, kw = np.unravel_index(int(np.nanargmax(vals)), vals.shape)
                _, il2, _, ir1, ir2, _ = np.unravel_index(sel[k], shape)
                rows.append(((l1_best, float(base.coords["l2"][il2]),
                              float(base.coords["r1"][ir1]), float(base.coords["r2"][ir2]),
                              float(base.coords["w"][kw])), float(vals[k, kw])))
            (da, va), (db, vb) = rows
            print(f"| {r:g}, {mu:g} | {', '.join(f'{v:g}' for v in da)} | {va:,.0f} | "
                  f"{', '.join(f'{v:g}' for v in db)} | {vb:,.0f} | "
                  f"{'yes' if da == db else 'no'} |")


if __name__ == "__main__":
    if "--partial" in sys.argv:
        rest = sys.argv[sys.argv.index("--partial") + 1:]
        compare_partial(sys.argv[1], sys.argv[2], float(rest[0]) if rest else None)
    else:
        main(*sys.argv[1:3])
