"""Which trajectory method converges to the model's trajectory where they disagree ("one
limit"; docs/accuracy.md, "One limit"). MODEL 8: from each start the part follows the energy
downhill (the steepest descent of a non-smooth function, sliding along creases) until it is
stable or leaves P_j. The reference here follows that definition on the true energy, with
none of the methods' discretisations: from the start, the lowest of 128 directions on a circle
of radius RHO (refined around the lowest to 0.35 deg), a move there if lower, until the grid
point nearest to the part is stable (caged or tip prehension, read from the map: the methods
end there too), the part leaves P_j (ejection) or no direction on the circles RHO and RHO / 4
descends: there, where a point within 2 RHO is stable (the part has come to the edge of a
region held by friction, typically across a crease), the end is that point's (caged or tip
prehension), else stalled. Model evaluations off the grid, as the slides make them.

    .venv/bin/python docs/notes/one_limit.py [--h 0.0125] [--starts 25] [--seed 7] [--rho 0.002]
        [--config configs/paper-collision.yaml]

1. Maps: low-friction small parts (r 0.4, 0.8; mu 0.1, 0.4) on designs of the screening
   sample, caging area by sliding, grid8 and continuous at h.
2. The 3 maps where sliding and continuous differ most: per map, a seeded sample of starts
   whose end differs between the methods (caged or not), each followed by the reference.
3. Per method: how many of those starts it ends as the reference does; and, as a check of the
   reference, --controls starts per map where the methods agree.
"""
from __future__ import annotations

import argparse
import math
import time

import numpy as np

from sweep.compute.layout import kernel_records
from sweep.compute.maps import compute_map
from sweep.config.parse import load_scene
from sweep.kernels.outcome import point_outcome
from sweep.kernels.records import Hand
from sweep.model import (END_CAGED, END_EJECTION, END_STALLED, END_TIP_PREHENSION, Accuracy,
                         Design, Effects, Grid, Limits, Part, REACHED)

RHO = 0.002
DIRECTIONS = 128
NAMES = {END_CAGED: "caged", END_TIP_PREHENSION: "tip", END_EJECTION: "ejection",
         END_STALLED: "stalled"}
DESIGNS = [(2.0, 1.6, 0.16, 0.06, 1.2), (2.0, 1.6, 0.2, 0.02, 1.2), (2.0, 1.6, 0.12, 0.02, 1.6),
           (2.0, 1.6, 0.04, 0.02, 0.0), (1.6, 1.6, 0.12, 0.02, 0.8), (2.0, 0.8, 0.08, 0.06, 0.4),
           (1.8, 1.2, 0.08, 0.18, 1.2), (2.0, 1.6, 0.2, 0.06, 0.4)]
PARTS = [(0.4, 0.1), (0.4, 0.4), (0.8, 0.1), (0.8, 0.4)]


def reference_end(x, y, m, evaluate, max_steps=20000):
    """The reference trajectory from world (x, y) on map m (module docstring): end state."""
    h = m.grid.h
    xs, ys = m.x, m.y
    eq = m.fields["equilibrium"]
    caged = m.fields["caged"] if "caged" in m.fields else (m.fields["caging_score"] > 0)
    angles = 2 * math.pi * np.arange(DIRECTIONS) / DIRECTIONS
    c, e = evaluate(x, y)
    for _ in range(max_steps):
        i = int(round((x - xs[0]) / h))
        j = int(round((y - ys[0]) / h))
        if not (0 <= i < xs.size and 0 <= j < ys.size) or c != REACHED:
            return END_EJECTION
        if eq[j, i]:
            return END_CAGED if caged[j, i] else END_TIP_PREHENSION
        moved = False
        for rho in (RHO, RHO / 4):
            vals = [evaluate(x + rho * math.cos(a), y + rho * math.sin(a)) for a in angles]
            k = int(np.argmin([v[1] for v in vals]))
            best, a_best = vals[k], angles[k]
            half = math.pi / DIRECTIONS
            for _ in range(4):   # refine the direction around the lowest
                for s in (-1, 1):
                    a = a_best + s * half
                    v = evaluate(x + rho * math.cos(a), y + rho * math.sin(a))
                    if v[1] < best[1]:
                        best, a_best = v, a
                half /= 2
            if best[1] < e - 1e-12 * abs(e):
                x, y = x + rho * math.cos(a_best), y + rho * math.sin(a_best)
                c, e = best
                moved = True
                break
        if not moved:
            return stop_end(x, y, m)
    return END_STALLED


def stop_end(x, y, m):
    """Where the reference finds no lower point: the part has arrived at the edge of a
    stable region (a crease whose one side is held by friction) when a point within 2 RHO of
    it is stable (caged or tip prehension, by the map's rules at that point), else it stalls."""
    w = compute_map(m.design, m.part, grid=Grid(h=RHO / 2, xlim=(x - 2 * RHO, x + 2 * RHO),
                                                ylim=(y - 2 * RHO, y + 2 * RHO)),
                    effects=m.effects)
    stable = w.fields["equilibrium"] & (w.fields["point_class"] == REACHED)
    if not stable.any():
        return END_STALLED
    return END_CAGED if (w.fields["caging_score"][stable] > 0).any() else END_TIP_PREHENSION


def main(argv=None) -> int:
    global RHO
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--h", type=float, default=0.0125)
    ap.add_argument("--starts", type=int, default=25)
    ap.add_argument("--maps", type=int, default=3)
    ap.add_argument("--seed", type=int, default=7)
    ap.add_argument("--controls", type=int, default=10,
                    help="per map, starts where the methods agree (a check of the reference)")
    ap.add_argument("--rho", type=float, default=RHO, help="the reference's step [0.002]")
    ap.add_argument("--config", help="take the scene's effects from this config "
                    "(e.g. configs/paper-collision.yaml) [the paper's model]")
    args = ap.parse_args(argv)
    RHO = args.rho
    effects = load_scene(args.config).effects if args.config else Effects()
    methods = ("sliding", "grid8", "continuous")
    rows = []
    print(f"## Caging areas at h = {args.h:g}\n\n| design | part | sliding | grid8 | continuous |"
          "\n|---|---|---|---|---|")
    for d in DESIGNS:
        for p in PARTS:
            maps = {t: compute_map(Design(*d), Part(*p), grid=Grid(h=args.h),
                                   accuracy=Accuracy(trajectory=t), effects=effects)
                    for t in methods}
            a = {t: float(maps[t].attrs["caging_area"]) for t in methods}
            rows.append((abs(a["sliding"] - a["continuous"]), d, p, maps))
            print(f"| {d} | {p} | {a['sliding']:.4f} | {a['grid8']:.4f} | "
                  f"{a['continuous']:.4f} |")
    rng = np.random.default_rng(args.seed)
    agree = {t: 0 for t in methods}
    total = 0
    n_control = control_agree = 0
    print("\n## Starts where sliding and continuous end differently, against the reference\n")
    print("| design | part | start (x, y) | sliding | grid8 | continuous | reference |")
    print("|---|---|---|---|---|---|---|")
    t0 = time.perf_counter()
    for _, d, p, maps in sorted(rows, key=lambda r: -r[0])[:args.maps]:
        m = maps["sliding"]
        finger, solver, blocks = kernel_records(Design(*d), Part(*p), Limits(), Accuracy(),
                                                effects)
        hand = Hand(d[4], 1.0, 1.0, args.h, finger.mu_s, finger.mu_s)

        def evaluate(x, y, finger=finger, solver=solver, blocks=blocks, hand=hand):
            c, e = point_outcome(x, y, finger, solver, blocks, hand)
            return int(c), float(e)

        ends = {t: maps[t].fields["end_state"] for t in methods}
        differ = np.argwhere(((ends["sliding"] == END_CAGED) != (ends["continuous"] == END_CAGED))
                             & (m.fields["point_class"] == REACHED))
        pick = differ[rng.choice(len(differ), size=min(args.starts, len(differ)),
                                 replace=False)] if len(differ) else differ
        same = np.argwhere(((ends["sliding"] == END_CAGED) == (ends["continuous"] == END_CAGED))
                           & (m.fields["point_class"] == REACHED))
        controls = same[rng.choice(len(same), size=min(args.controls, len(same)),
                                   replace=False)] if len(same) else same
        for kind, starts in (("disputed", pick), ("control", controls)):
            for j, i in starts:
                ref = reference_end(float(m.x[i]), float(m.y[j]), m, evaluate)
                if kind == "disputed":
                    total += 1
                    for t in methods:
                        agree[t] += (ends[t][j, i] == END_CAGED) == (ref == END_CAGED)
                else:
                    n_control += 1
                    control_agree += (ends["sliding"][j, i] == END_CAGED) == (ref == END_CAGED)
                print(f"| {d} | {p} | ({m.x[i]:.4f}, {m.y[j]:.4f}) {kind} | "
                      + " | ".join(NAMES.get(int(ends[t][j, i]), "?") for t in methods)
                      + f" | {NAMES[ref]} |")
    print(f"\nOf {total} starts, caged or not as the reference: "
          + ", ".join(f"{t} {agree[t]}" for t in methods)
          + f"; of {n_control} control starts (the methods agree), the reference agrees on "
          f"{control_agree} (RHO {RHO:g}; {time.perf_counter() - t0:.0f} s of reference "
          "trajectories).")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
