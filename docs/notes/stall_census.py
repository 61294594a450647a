"""Where sliding trajectories stall, and why (model-notes D16; docs/accuracy.md).

For each map, every distinct place where a stalled trajectory stops (one start per stalled end
point is followed to the off-grid stop with the picture's walker, `plot.sliding_points`) is
probed with the true energy on circles of radii h/4, h/2 and h (the resolution of the slide's
cascade), PROBE_DIRECTIONS directions each: a stop is *certified* when no probe is lower than
it (by more than PROBE_TOL, relative). Each
stop is then counted by kind, from the points around it (the probes and the stop):

  - vertex corner: some probe is a VERTEX point (an unresolved vertex contact: its energy is
    the strike's, a wall the part cannot climb);
  - mode boundary: the finger modes differ among the probes, no VERTEX point;
  - smooth minimum: the same finger modes all round;
  - plateau: every probe has the stop's energy.

    .venv/bin/python docs/notes/stall_census.py --h 0.0125 [--maps crease|1200] [--stride 1]
"""
from __future__ import annotations

import argparse
import itertools
import math
import sys
from collections import Counter

import numpy as np

from sweep.kernels.finger import solve_finger
from sweep.kernels.finger import finger_effects
from sweep.kernels.outcome import point_outcome
from sweep.kernels.records import Hand
from sweep.compute.layout import kernel_records
from sweep.compute.maps import compute_map
from sweep.model import (END_STALLED, REACHED, VERTEX_POINT, Accuracy, Command, Design, Effects,
                         Grid, Limits, Part)
from sweep.report.plot import sliding_points

PROBE_DIRECTIONS = 720
PROBE_RADII = (1 / 4, 1 / 2, 1.0)  # times h: the resolution of the slide's cascade (D16)
PROBE_TOL = 1e-12


def probe(x, y, h, finger, solver, blocks, hand):
    """(lowest probe energy - stop energy, classes of the probes, finger modes of the probes)."""
    _, e0 = point_outcome(x, y, finger, solver, blocks, hand)
    worst = 0.0
    classes, modes = set(), set()
    for rho in PROBE_RADII:
        for k in range(PROBE_DIRECTIONS):
            t = 2.0 * math.pi * k / PROBE_DIRECTIONS
            px, py = x + rho * h * math.cos(t), y + rho * h * math.sin(t)
            c, e = point_outcome(px, py, finger, solver, blocks, hand)
            classes.add(int(c))
            w = hand.w
            ml = solve_finger(-px - 0.5 * w, py, finger, solver,
                              finger_effects(blocks, hand.f_left)).mode
            mr = solve_finger(px - 0.5 * w, py, finger, solver,
                              finger_effects(blocks, hand.f_right)).mode
            modes.add((int(ml), int(mr)))
            if math.isfinite(e):
                worst = min(worst, e - e0)
    return worst, e0, classes, modes


def kind(worst, e0, classes, modes):
    if VERTEX_POINT in classes:
        return "vertex corner"
    if len(modes) > 1:
        return "mode boundary"
    return "plateau" if worst == 0.0 else "smooth minimum"


def census(design, part, h, accuracy=Accuracy()):
    m = compute_map(design, part, Command(), Grid(h=h), accuracy=accuracy)
    f = m.fields
    es, ei = f["end_state"].ravel(), f["end_index"].ravel()
    stable = (f["point_class"] == REACHED) & f["equilibrium"]
    finger, solver, blocks = kernel_records(design, part, Limits(), accuracy, Effects())
    hand = Hand(design.w, 1.0, 1.0, h, finger.mu_s, finger.mu_s)
    rows = []
    for q in np.unique(ei[es == END_STALLED]):
        starts = np.flatnonzero((es == END_STALLED) & (ei == q))
        pts, _ = sliding_points(int(starts[0]), m, stable)
        x, y = pts[-1]
        worst, e0, classes, modes = probe(x, y, h, finger, solver, blocks, hand)
        certified = worst >= -PROBE_TOL * max(1.0, abs(e0))
        rows.append(dict(x=x, y=y, starts=len(starts), worst=worst, certified=certified,
                         kind=kind(worst, e0, classes, modes)))
    return m, rows


def issue_maps(stride):
    k = 0
    for r, mu in itertools.product((0.4, 0.8), (0.1, 0.4, 0.7, 1.0)):
        for r1, r2, w in itertools.product((0.04, 0.08, 0.12, 0.16, 0.2),
                                           (0.02, 0.06, 0.1, 0.14, 0.18),
                                           (0.0, 0.4, 0.8, 1.2, 1.6, 2.0)):
            k += 1
            if k % stride == 0:
                yield Design(2.0, 1.6, r1, r2, w), Part(r, mu)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--h", type=float, default=0.0125)
    ap.add_argument("--maps", choices=("crease", "1200"), default="crease")
    ap.add_argument("--stride", type=int, default=1, help="every n-th of the 1,200 maps")
    args = ap.parse_args(argv)
    maps = ([(Design(2.0, 1.6, 0.16, 0.06, 1.2), Part(0.4, 0.1))] if args.maps == "crease"
            else list(issue_maps(args.stride)))
    stops, starts, reached, stalled = Counter(), Counter(), 0, 0
    uncertified = []
    for design, part in maps:
        m, rows = census(design, part, args.h)
        reached += m.attrs["n_reached"]
        stalled += m.attrs["n_stalled"]
        for r in rows:
            stops[r["kind"]] += 1
            starts[r["kind"]] += r["starts"]
            if not r["certified"]:
                uncertified.append((design, part, r))
    print(f"h = {args.h}, {len(maps)} maps: {stalled} of {reached} reached starts stalled "
          f"({stalled / max(reached, 1):.4f}), at {sum(stops.values())} stops")
    for k in ("vertex corner", "mode boundary", "smooth minimum", "plateau"):
        print(f"  {k:15s} stops {stops[k]:5d}  starts {starts[k]:8d}")
    print(f"  stops with a lower probe (not certified): {len(uncertified)}")
    for design, part, r in uncertified[:10]:
        print(f"    {design} {part} at ({r['x']:.5f}, {r['y']:.5f}): {r['worst']:.3e}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
