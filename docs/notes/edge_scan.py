"""Links through the part at the edges of the accepted space: a brute-force scan of one finger
(model-notes D30; docs/stability.md).

Draws designs, parts and joint limits at the edges of what the validation accepts (theta2_min
just above -90 deg, at 0 or a hair below it; theta2_max at 180 deg or a hair above theta2_min;
lengths from 1e-6 to 1e9) and puts the part centre where a closed-form test of MODEL 3-4 is
decided at its limit: on MODEL 3.3's tangency at k2 = 0, l2 or a few ulps from it, on a graze
of B or T (MODEL 4's acos argument at 1), on the proximal tangency at k1 = 0 or l1, at the
reach's boundary, on the palm row (to round-off below it, where the feasibility test still
accepts it), on MODEL 3.2's tangency at the joint limits. Each point is solved by
kernels/finger.py: solve_finger, with and without tip_contact, and the settled configuration is
checked by plain geometry: the distance from the part centre to each link segment is at least
r (1 - 1e-9) (less the part's accepted dip below the palm line), the paper's flagged tip overlap
(MODEL 4.3) excepted. Prints the first few violations of each kind and a count by
(kind of point, tip_contact, mode).

    NUMBA_CACHE_DIR=... .venv/bin/python docs/notes/edge_scan.py --seed 1 --n 6000
"""
from __future__ import annotations

import argparse
import math
import random

from sweep.kernels.finger import solve_finger
from sweep.kernels.records import NO_EFFECTS, FingerModel, SolverSettings, TipContact
from sweep.model import DEFAULT_STEP_RESOLUTION, RANGE_TOL, STREAMLINE_STEP, TRAJECTORY_SLIDING

KINDS = ("tangent-3.3", "b-graze", "t-graze", "proximal-3.1", "reach", "palm-row",
         "tangent-3.2", "proximal-at-b", "tip-graze-about-b")


def segment_distance(px, py, ax, ay, bx, by):
    vx, vy = bx - ax, by - ay
    length2 = vx * vx + vy * vy
    s = 0.0 if length2 == 0 else min(max(((px - ax) * vx + (py - ay) * vy) / length2, 0.0), 1.0)
    return math.hypot(px - (ax + s * vx), py - (ay + s * vy))


def link_gaps(dx, dy, l1, l2, t1, t2):
    """Distances from the part centre to the proximal and the distal link."""
    bx, by = l1 * math.cos(t1), l1 * math.sin(t1)
    tx, ty = bx + l2 * math.cos(t1 + t2), by + l2 * math.sin(t1 + t2)
    return segment_distance(dx, dy, 0.0, 0.0, bx, by), segment_distance(dx, dy, bx, by, tx, ty)


def check(dx, dy, l1, l2, r, th2min, th2max, tip, r1=1.0, r2=0.5, mu=0.0, step=0.01, tol=1e-12):
    """(violation, state, proximal gap / r - 1, distal gap / r - 1), or None if infeasible."""
    if dy < r - RANGE_TOL or dx * dx + dy * dy < r * r * (1 - 1e-12):
        return None
    finger = FingerModel(l1, l2, r1, r2, r, mu, th2min, th2max)
    solver = SolverSettings(step, tol, TRAJECTORY_SLIDING, STREAMLINE_STEP,
                            DEFAULT_STEP_RESOLUTION)
    effects = NO_EFFECTS._replace(tip_contact=TipContact(True)) if tip else NO_EFFECTS
    state = solve_finger(dx, dy, finger, solver, effects)
    if state.mode < 0:
        return None
    dp, dd = link_gaps(dx, dy, l1, l2, state.t1, state.t2)
    allowed = max(r * 1e-9, r - dy)   # the part may dip below the palm line by RANGE_TOL
    bad = dp < r - allowed or (dd < r - allowed and not state.tip_overlap)
    return bad, state, dp / r - 1.0, dd / r - 1.0


def edge_theta2_min(rng):
    k = rng.random()
    if k < 0.4:
        return math.radians(-90 + 10 ** rng.uniform(-13, -1))
    if k < 0.5:
        return 0.0
    if k < 0.6:
        return -math.radians(10 ** rng.uniform(-13, -3))
    return math.radians(rng.uniform(-90, 0) + 1e-9)


def draw(rng):
    """(dx, dy, l1, l2, r, theta2_min, theta2_max, kind) of one finger at an edge."""
    scale = 10 ** rng.choice([0, 0, -3, 3, 6, -6, 9])
    l1 = scale * 10 ** rng.uniform(-1.3, 0.7)
    l2 = scale * 10 ** rng.uniform(-1.3, 0.7)
    r = scale * 10 ** rng.uniform(-1.7, 0.7)
    th2min = edge_theta2_min(rng)
    k = rng.random()
    if k < 0.3:
        th2max = math.pi
    elif k < 0.5:
        th2max = th2min + math.radians(10 ** rng.uniform(-6, -1))
    else:
        th2max = math.radians(rng.uniform(math.degrees(th2min), 180))
    th2max = min(max(th2max, th2min + math.radians(1e-6)), math.pi)
    kind = rng.choice(KINDS)
    t = rng.uniform(0, math.pi)
    bx, by = l1 * math.cos(t), l1 * math.sin(t)
    if kind == "tangent-3.3":     # distal (at theta2_min) tangent at k2 = 0, l2, near them, inside
        k = rng.choice([0.0, l2, l2 * 10 ** rng.uniform(-14, -6), rng.uniform(0, l2)])
        phi = t + th2min
        dx = bx + k * math.cos(phi) - r * math.sin(phi)
        dy = by + k * math.sin(phi) + r * math.cos(phi)
    elif kind == "b-graze":       # B's circle about J touching the disc from outside or inside
        rho = l1 + rng.choice([r, -r])
        dx, dy = rho * math.cos(t), rho * math.sin(t)
    elif kind == "t-graze":       # the tip's circle in the rigid sweep touching the disc
        tx, ty = l1 + l2 * math.cos(th2min), l2 * math.sin(th2min)
        rho = math.hypot(tx, ty) + rng.choice([r, -r])
        dx, dy = rho * math.cos(t), rho * math.sin(t)
    elif kind == "proximal-3.1":  # proximal tangent at k1 = 0, l1 or inside
        k = rng.choice([0.0, l1, rng.uniform(0, l1)])
        dx, dy = k * math.cos(t) - r * math.sin(t), k * math.sin(t) + r * math.cos(t)
    elif kind == "reach":         # the reach's boundary, |d| = l1 + l2 + r
        rho = l1 + l2 + r
        dx, dy = rho * math.cos(t), rho * math.sin(t)
    elif kind == "palm-row":
        dx, dy = rng.uniform(-2, 2) * (l1 + l2), r
    elif kind == "proximal-at-b":  # proximal tangent at B; the distal then closes tangent at B
        dx, dy = l1 * math.cos(t) - r * math.sin(t), l1 * math.sin(t) + r * math.cos(t)
    elif kind == "tip-graze-about-b":  # the tip's circle about B touching the disc
        ang = rng.uniform(0, 2 * math.pi)
        rho = l2 + rng.choice([r, -r])
        dx, dy = bx + rho * math.cos(ang), by + rho * math.sin(ang)
    else:                         # 3.2 at a given t1: tangent at k2 = 0, l2, at a joint limit
        t2 = rng.choice([th2min, th2max, rng.uniform(th2min, th2max)])
        k = rng.choice([0.0, l2, rng.uniform(0, l2)])
        phi = t + t2
        dx = bx + k * math.cos(phi) - r * math.sin(phi)
        dy = by + k * math.sin(phi) + r * math.cos(phi)
    # within a few ulps to 1e-8 of the edge, or on it
    dx *= 1 + 10 ** rng.uniform(-16, -8) * rng.choice([-1, 1, 0])
    dy *= 1 + 10 ** rng.uniform(-16, -8) * rng.choice([-1, 1, 0])
    return dx, dy, l1, l2, r, th2min, th2max, kind


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--n", type=int, default=6000, help="points drawn")
    parser.add_argument("--show", type=int, default=3, help="violations printed per kind")
    args = parser.parse_args()
    rng = random.Random(args.seed)
    found = {}
    checked = 0
    for _ in range(args.n):
        dx, dy, l1, l2, r, th2min, th2max, kind = draw(rng)
        for tip in (False, True):
            mu = rng.choice([0.0, 0.4, 1e3])
            res = check(dx, dy, l1, l2, r, th2min, th2max, tip, mu=mu, r2=rng.choice([0.5, 2.0]))
            if res is None:
                continue
            checked += 1
            bad, state, gap_p, gap_d = res
            if bad:
                key = (kind, tip, state.mode)
                found[key] = found.get(key, 0) + 1
                if found[key] <= args.show:
                    print(repr((dx, dy, l1, l2, r, th2min, th2max)), f"tip_contact {tip} mu {mu}",
                          kind, state, f"gaps/r: proximal {gap_p:.3g}, distal {gap_d:.3g}")
    print(f"{checked} solves, {sum(found.values())} with a link through the part")
    for key, n in sorted(found.items()):
        print(f"  {key}: {n}")


if __name__ == "__main__":
    main()
