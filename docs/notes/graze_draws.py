"""The graze rule of B (model-notes D30) against its two mutants, on edge draws of one finger's
rigid sweep: where does `joint_strike_angle` decide what the closing sequence reports?

Draws l1, l2, r (r / l1 from 1e-4 to 3), theta2_min 1e-10 to 1e-3 rad above -90 deg and a part
on B's graze circle (|d| = l1 + r, or l1 - r from inside), moved by up to 64 ulps or by 1e-16
to 1e-11 of |d|, and keeps the draws whose MODEL 4 acos argument for B lies in
[1 - 1e-12, 1 + 1e-14]. Each is run through `closing_contact` three times: as is, with the graze
of B ignored (mutant d30-graze-of-b-ignored: `vertex_entry` alone) and with an argument above 1
by round-off read as a miss (d30-graze-round-off-above-one). The kernels run as Python
(NUMBA_DISABLE_JIT, set here) so the mutants can be swapped in. Prints how many draws each
mutant changes and, of those, the ones where the mutant's finger sweeps a link through the part
(FREE, or the tip's strike), with the deepest point of its sweep (brute force, relative to r).

    PYTHONPATH=$PWD .venv/bin/python docs/notes/graze_draws.py --seed 0 --n 4000
"""
from __future__ import annotations

import os

os.environ["NUMBA_DISABLE_JIT"] = "1"

import argparse  # noqa: E402
import math  # noqa: E402

import numpy as np  # noqa: E402

import sweep.kernels.finger as finger  # noqa: E402
import sweep.kernels.finger_geometry as geometry  # noqa: E402
from sweep.kernels.records import NO_EFFECTS, FingerModel  # noqa: E402
from sweep.model import FREE, RANGE_TOL, VERTEX  # noqa: E402

UNMUTATED = finger.joint_strike_angle


def acos_argument(dx, dy, rho, r):
    """MODEL 4's acos argument for a vertex at radius rho (finger_geometry.entry_cosine, an
    inner kernel that only kernels may call: the same formula)."""
    dist2 = dx * dx + dy * dy
    return (rho * rho + dist2 - r * r) / (2.0 * rho * math.sqrt(dist2))


def graze_ignored(dx, dy, l1, r):
    return geometry.vertex_entry(dx, dy, l1, 0.0, r)


def above_one_is_a_miss(dx, dy, l1, r):
    t_b = geometry.vertex_entry(dx, dy, l1, 0.0, r)
    if t_b != geometry.NO_ANGLE:
        return t_b
    c = acos_argument(dx, dy, l1, r)
    if c < 1.0 - RANGE_TOL or c > 1.0:
        return geometry.NO_ANGLE
    return math.atan2(dy, dx) - math.acos(min(c, 1.0))


MUTANTS = {"d30-graze-of-b-ignored": graze_ignored,
           "d30-graze-round-off-above-one": above_one_is_a_miss}


def closing(strike, dx, dy, l1, l2, r, th2min):
    finger.joint_strike_angle = strike
    try:
        model = FingerModel(l1, l2, 1.0, 1.0, r, 0.0, th2min, math.radians(90.0))
        return finger.closing_contact(dx, dy, model, finger.closing_constants(model), NO_EFFECTS)
    finally:
        finger.joint_strike_angle = UNMUTATED


def sweep_depth(dx, dy, l1, l2, r, th2min, t_end):
    """Deepest point of the rigid sweep over [0, t_end] inside the disc, relative to r (> 0:
    a link inside)."""
    t1 = np.linspace(0.0, t_end, 200001)
    bx, by = l1 * np.cos(t1), l1 * np.sin(t1)
    tx, ty = bx + l2 * np.cos(t1 + th2min), by + l2 * np.sin(t1 + th2min)

    def seg(ax, ay, ex, ey):
        vx, vy = ex - ax, ey - ay
        s = np.clip(((dx - ax) * vx + (dy - ay) * vy) / (vx * vx + vy * vy), 0.0, 1.0)
        return np.hypot(dx - ax - s * vx, dy - ay - s * vy)
    dist = np.minimum(seg(0.0 * bx, 0.0 * by, bx, by), seg(bx, by, tx, ty))
    return (r - dist.min()) / r


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--n", type=int, default=4000)
    ap.add_argument("--show", type=int, default=3, help="examples printed per mutant")
    args = ap.parse_args()
    rng = np.random.default_rng(args.seed)
    kept = 0
    changed = {m: [] for m in MUTANTS}
    for _ in range(args.n):
        l1 = 10 ** rng.uniform(-1, 1)
        r = l1 * 10 ** rng.uniform(-4, 0.5)
        l2 = l1 * 10 ** rng.uniform(-1, 1)
        th2min = -math.pi / 2 + 10 ** rng.uniform(-10, -3)
        inside = rng.random() < 0.2 and r < l1 / 2
        dist = (l1 - r) if inside else (l1 + r)
        if rng.random() < 0.5:
            dist *= 1 + int(rng.integers(-64, 65)) * 2.0 ** -53
        else:
            dist -= rng.choice([1, -1]) * 10 ** rng.uniform(-16, -11) * dist
        alpha = rng.uniform(math.asin(min(r / dist, 1.0)), math.pi)
        dx, dy = dist * math.cos(alpha), dist * math.sin(alpha)
        if dy < r or dx * dx + dy * dy < r * r:
            continue
        c = acos_argument(dx, dy, l1, r)
        if not 1.0 - RANGE_TOL <= c <= 1.0 + 1e-14:
            continue
        kept += 1
        first = closing(UNMUTATED, dx, dy, l1, l2, r, th2min)
        for name, strike in MUTANTS.items():
            other = closing(strike, dx, dy, l1, l2, r, th2min)
            if tuple(other) != tuple(first):
                changed[name].append(((dx, dy, l1, l2, r, th2min), first, other))
    print(f"{kept} draws with B's acos argument in [1 - {RANGE_TOL:g}, 1 + 1e-14]")
    for name, rows in changed.items():
        through = []
        for case, first, other in rows:
            tip_strike = other.mode == VERTEX and other.k1 == 0.0
            if other.mode == FREE or tip_strike:
                depth = sweep_depth(*case, min(other.t1, math.pi))
                if depth > 1e-9:
                    through.append((depth, case, first, other))
        print(f"{name}: changes {len(rows)}; sweeps a link through the part in {len(through)}")
        for depth, case, first, other in sorted(through, key=lambda x: -x[0])[:args.show]:
            print(f"  depth {depth:.3g} r  dx, dy, l1, l2, r, theta2_min = {case}")
            print(f"    unmutated {tuple(first)[:5]}  mutant {tuple(other)[:5]}")


if __name__ == "__main__":
    main()
