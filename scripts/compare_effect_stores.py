"""Compare two sweep stores of the same designs and parts run with different effects (e.g. the
paper sweep without and with finger_collision): totals of the class counts, Lambda, and the
best design (largest Lambda) of every part. Prints Markdown.

    .venv/bin/python scripts/compare_effect_stores.py base.h5 effect.h5
"""
from __future__ import annotations

import sys

import numpy as np

from sweep.store import read_store

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
    print("| part (r, mu) | base best (l1, l2, r1, r2, w) | Lambda | with effect | Lambda | same |")
    print("|---|---|---|---|---|---|")
    for part in ba:
        (da, va), (db, vb) = ba[part], bb[part]
        print(f"| {part[0]:g}, {part[1]:g} | {', '.join(f'{v:g}' for v in da)} | {va:,.0f} | "
              f"{', '.join(f'{v:g}' for v in db)} | {vb:,.0f} | {'yes' if da == db else 'no'} |")


if __name__ == "__main__":
    main(*sys.argv[1:3])
