"""Physical invariants over the whole accepted input space (issue P13).

docs/stability.md catalogues the hard cases someone thought of; here Hypothesis draws maps from
everything the validation accepts: designs, parts and tensions over many orders of magnitude,
joint limits anywhere in (-90, 0] x (theta2_min, 180] deg, accuracy settings anywhere in their
accepted ranges, either trajectory method, every combination of effects (springs as strong as
D13 allows) and forces. At every feasible grid point of every map:

- no settled link passes through the part: each link segment's distance from the part centre is
  at least `r (1 - LINK_TOL)` (the paper's distal link kept through the part, MODEL 4.3, is the
  one exception and is flagged `tip_overlap`); with finger_collision the fingers do not cross;
- every finger angle lies within its limits (`0 <= theta1 <= pi`,
  `theta2_min <= theta2 <= theta2_max`, to RANGE_TOL);
- energies, configurations, contact lengths and forces are finite; NaN only at infeasible points;
- MODEL 11: mirror symmetry under equal tensions; configurations that do not depend on the
  tension (without springs) with energies and forces linear in it; more friction never lowering
  the energy at a point (to the resolution of docs/stability.md's `mu = 1e6` row); contacts on
  the disc and `k2 = l1 - k1` in two-phalanx contact.

The edges (model-notes D30): the same draws moved to the edges of the accepted space
(edge_case): joint limits at the extremes the validation accepts, and a grid point put exactly
(or within a few ulps) on a graze of B, a tangency at k = 0 or k = l, the reach's boundary or the
finger's joint; the invariants above hold there too, a limit and the same limit 1e-12 inside it
give the same map, and along a move of a limit by 1e-9 no outcome flips back and forth and the
energy moves continuously where the outcome does not switch (check_limit_moves).

Examples: ACCEPTED_EXAMPLES (default 25, a few seconds with compiled kernels), EDGE_EXAMPLES
(default 8, a few seconds); `make test-long` (SWEEP_LONG_PROPERTIES=1, tests/profiles.py) runs
the long profile (1,000 random examples each). The bounded profile keeps every map within
BOUNDED_ROWS grid rows over the reach (below).
"""
from __future__ import annotations

import dataclasses
import math
import os

import numpy as np
import pytest
from hypothesis import HealthCheck, Phase, given, note, settings
from hypothesis import strategies as st

from profiles import EXPLORE
from sweep.compute.layout import finger_offsets, map_grid
from sweep.compute.maps import compute_map
from sweep.model import (
    FREE,
    INFEASIBLE,
    PROXIMAL_ONLY,
    RANGE_TOL,
    REACHED,
    RECONFIG_STEP_RANGE,
    ROOT_TOL_RANGE,
    TWO_PHALANX,
    VERTEX,
    DISTAL_ONLY,
    Accuracy,
    Command,
    Design,
    Effects,
    Grid,
    Limits,
    ModelInputError,
    Outputs,
    Part,
    validate_inputs,
    validate_scene,
)

LONG = os.environ.get("SWEEP_LONG_PROPERTIES", "") not in ("", "0")
EXAMPLES = 1000 if LONG else int(os.environ.get("ACCEPTED_EXAMPLES", "25"))
#: Smallest reconfig_step drawn: a path of 1e-4 rad steps makes one map's finger field cost
#: seconds, which the long profile pays; the bounded one (make test, CI's 10 minutes) stops at
#: 1e-3, still ten times finer than any config of the project.
STEP_FLOOR = 1e-4 if LONG else 1e-3
#: Examples of the edge draws (edge_case): each runs about ten maps (the limit moves)
EDGE_EXAMPLES = 1000 if LONG else int(os.environ.get("EDGE_EXAMPLES", "8"))
#: Grid rows over the reach in the bounded profile: the palm's half-width is put on the grid
#: only where that keeps the map within them. A palm much narrower than the drawn spacing is on
#: the grid only at h = w / 2, hundreds of rows (one such map of 146 x 469 points cost 6 s, twice,
#: half of make test's time for this module); the long profile draws those.
BOUNDED_ROWS = 30
# The long profile does not shrink a failure (an example costs up to seconds; the failing case
# is printed as drawn, with its note).
PROFILE = settings(max_examples=EXAMPLES, deadline=None, derandomize=not EXPLORE, database=None,
                   suppress_health_check=list(HealthCheck),
                   phases=[Phase.explicit, Phase.generate] if LONG else list(Phase))
#: Relative tolerance of "no link passes through the part": a link may come within
#: r * LINK_TOL of the centre's circle of radius r (round-off of the closed forms, MODEL 5.5).
LINK_TOL = 1e-9


def log_uniform(lo, hi):
    return st.floats(math.log10(lo), math.log10(hi), allow_nan=False).map(lambda e: 10.0 ** e)


@st.composite
def accepted_case(draw):
    """A map anywhere the validation accepts (checked with the validation itself)."""
    scale = draw(st.sampled_from([1.0, 1.0, 1e-3, 1e3]))
    l1 = scale * draw(log_uniform(0.05, 5.0))
    l2 = scale * draw(log_uniform(0.05, 5.0))
    r = scale * draw(log_uniform(0.02, 5.0))
    w = scale * draw(st.sampled_from([0.0, 0.0]) | log_uniform(0.01, 5.0))
    r1 = draw(log_uniform(1e-4, 10.0))
    r2 = r1 * draw(st.sampled_from([1.0]) | log_uniform(1e-3, 10.0))
    mu = draw(st.sampled_from([0.0]) | log_uniform(1e-3, 1e6))
    th2min = draw(st.sampled_from([-5.0, 0.0, -89.999]) | st.floats(-89.999, 0.0))
    th2max = draw(st.sampled_from([90.0, 180.0]) | st.floats(th2min + 1e-6, 180.0))
    th2max = max(th2max, th2min + 1e-6)
    f_left = draw(st.sampled_from([1.0, 0.0]) | log_uniform(1e-9, 1e9))
    f_right = draw(st.sampled_from([1.0]) | log_uniform(1e-9, 1e9))
    step = draw(st.sampled_from([0.01]) | log_uniform(STEP_FLOOR, RECONFIG_STEP_RANGE[1]))
    tol = draw(st.sampled_from([1e-12]) | log_uniform(*ROOT_TOL_RANGE))
    trajectory = draw(st.sampled_from(["sliding", "discrete", "continuous"]))
    on = draw(st.fixed_dictionaries({k: st.booleans() for k in
                                     ("tip_contact", "joint_springs", "finger_collision")}))
    friction = mu > 0 or draw(st.booleans())
    k1 = k2 = 0.0
    if on["joint_springs"]:
        # weaker than the tendon over the joint range (D13): K pi < F r1, K span < F r2
        tension = min(f_left, f_right)
        if tension <= 0:
            on["joint_springs"] = False
        else:
            span2 = math.radians(th2max - th2min)
            k1 = tension * r1 / math.pi * draw(st.floats(0.0, 0.999))
            k2 = tension * r2 / span2 * draw(st.floats(0.0, 0.999))
    forces = (not on["tip_contact"] and not on["joint_springs"]) and draw(st.booleans())
    effects = Effects(friction=friction, spring_k1=k1, spring_k2=k2, **on)
    case = dict(design=Design(l1, l2, r1, r2, w), part=Part(r, mu),
                command=Command(f_left, f_right),
                limits=Limits(theta2_min_deg=th2min, theta2_max_deg=th2max),
                accuracy=Accuracy(step, tol, trajectory), effects=effects,
                outputs=Outputs(forces=forces))
    validate_inputs(case["design"], case["part"], case["command"], case["limits"],
                    case["accuracy"], effects)
    validate_scene(effects, case["outputs"])
    # about 6 to 14 grid rows over the reach; sometimes the palm half-width on the grid
    reach = l1 + l2 + r
    h = reach / draw(st.integers(6, 14))
    if w > 0 and draw(st.booleans()):
        on_palm = w / (2 * max(1, round(w / (2 * h))))
        if LONG or on_palm * BOUNDED_ROWS >= reach:
            h = on_palm
    case["grid"] = Grid(h=h)
    return case


def run(case, **over):
    c = {**case, **over}
    return compute_map(c["design"], c["part"], c["command"], c["grid"], c["limits"],
                       c["accuracy"], c["effects"], outputs=c["outputs"])


# ---------------------------------------------------------------------------------------------
# Geometry of the settled fingers (world frame, MODEL 1-2), independent of the kernels
# ---------------------------------------------------------------------------------------------
def finger_points(design, t1, t2, side):
    """(J, B, T) of each finger as arrays of shape (2, ...); side 0 = left (mirrored)."""
    sign = -1.0 if side == 0 else 1.0
    jx = np.full_like(t1, sign * 0.5 * design.w)
    jy = np.zeros_like(t1)
    bx = jx + sign * design.l1 * np.cos(t1)
    by = design.l1 * np.sin(t1)
    phi = t1 + t2
    tx = bx + sign * design.l2 * np.cos(phi)
    ty = by + design.l2 * np.sin(phi)
    return (jx, jy), (bx, by), (tx, ty)


def segment_distance(px, py, a, b):
    """Distance from points p to the segments a-b (arrays broadcast)."""
    ax, ay = a
    bx, by = b
    vx, vy = bx - ax, by - ay
    length2 = vx * vx + vy * vy
    safe = np.where(length2 > 0, length2, 1.0)
    s = np.clip(((px - ax) * vx + (py - ay) * vy) / safe, 0.0, 1.0)
    s = np.where(length2 > 0, s, 0.0)
    return np.hypot(px - (ax + s * vx), py - (ay + s * vy))


def segments_cross(p1, p2, q1, q2):
    """Proper crossings of segments p1-p2 and q1-q2 (strict: touching does not count)."""
    def orient(a, b, c):
        return (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])
    d1, d2 = orient(q1, q2, p1), orient(q1, q2, p2)
    d3, d4 = orient(p1, p2, q1), orient(p1, p2, q2)
    return (d1 * d2 < 0) & (d3 * d4 < 0)


# ---------------------------------------------------------------------------------------------
# The properties
# ---------------------------------------------------------------------------------------------
def check_map(case, m):
    f = m.fields
    design, part, limits = case["design"], case["part"], case["limits"]
    cls = f["point_class"]
    feasible = cls != INFEASIBLE
    X, Y = np.meshgrid(m.x, m.y)
    # every trajectory from P_j ends in one of the four end states, with a finite score
    a = m.attrs
    assert (a["n_caged"] + a["n_tip_prehension"] + a["n_ejection"] + a["n_stalled"]
            == a["n_reached"] == int((cls == REACHED).sum()))
    assert math.isfinite(a["Lambda"]) and 0.0 <= a["Lambda"] <= a["n_caged"]
    assert math.isfinite(a["caging_area"]) and a["caging_area"] >= 0.0
    assert np.isfinite(f["energy"][feasible]).all()
    assert np.isnan(f["energy"][~feasible]).all()
    for name in ("theta1", "theta2", "k1", "k2"):
        assert np.isfinite(f[name][:, feasible]).all(), name
    for name in ("proximal_normal_force", "distal_normal_force", "distal_friction_multiplier",
                 "resultant_force_x", "resultant_force_y"):
        if name in f:
            assert np.isfinite(f[name][:, feasible]).all(), name
    crossed = np.zeros_like(feasible)
    pts = []
    for side in (0, 1):
        t1, t2 = f["theta1"][side], f["theta2"][side]
        # angles within their limits
        assert np.all((t1[feasible] >= -RANGE_TOL) & (t1[feasible] <= math.pi + RANGE_TOL))
        assert np.all(t2[feasible] >= limits.theta2_min - RANGE_TOL)
        assert np.all(t2[feasible] <= limits.theta2_max + RANGE_TOL)
        j, b, t = finger_points(design, t1, t2, side)
        pts.append((j, b, t))
        # no settled link passes through the part (the flagged paper answer excepted)
        inside = part.r * (1.0 - LINK_TOL)
        proximal = segment_distance(X, Y, j, b)
        distal = segment_distance(X, Y, b, t)
        kept = f["tip_overlap"][side]
        bad_p = feasible & (proximal < inside)
        bad_d = feasible & ~kept & (distal < inside)
        assert not bad_p.any(), _where("proximal link through the part", m, bad_p, side,
                                       proximal)
        assert not bad_d.any(), _where("distal link through the part", m, bad_d, side, distal)
        # contacts on the disc; k2 = l1 - k1 in two-phalanx contact (MODEL 3.4, 11)
        mode = f["finger_mode"][side]
        two = feasible & (mode == TWO_PHALANX)
        assert np.allclose(f["k2"][side][two], design.l1 - f["k1"][side][two],
                           atol=1e-9 * (design.l1 + design.l2))
        touching = feasible & ((mode == TWO_PHALANX) | (mode == PROXIMAL_ONLY))
        off = touching & ~np.isclose(proximal, part.r, rtol=1e-9)
        assert not off.any(), _where("proximal contact off the disc or the link", m, off, side,
                                     proximal)
        touching = feasible & ((mode == TWO_PHALANX) | (mode == DISTAL_ONLY))
        off = touching & ~np.isclose(distal, part.r, rtol=1e-9)
        assert not off.any(), _where("distal contact off the disc or the link", m, off, side,
                                     distal)
    if case["effects"].finger_collision:
        (jl, bl, tl), (jr, br, tr) = pts
        for p1, p2 in ((jl, bl), (bl, tl)):
            for q1, q2 in ((jr, br), (br, tr)):
                crossed |= segments_cross(p1, p2, q1, q2)
        assert not (crossed & feasible).any(), _where("fingers cross", m, crossed & feasible,
                                                      0, None)


def _where(what, m, bad, side, dist):
    iy, ix = np.argwhere(bad)[0]
    extra = f", distance {dist[iy, ix]!r}" if dist is not None else ""
    return (f"{what} at {bad.sum()} points, e.g. (x, y) = ({m.x[ix]!r}, {m.y[iy]!r}), side "
            f"{side}, mode {m.fields['finger_mode'][side][iy, ix]}, theta "
            f"({m.fields['theta1'][side][iy, ix]!r}, {m.fields['theta2'][side][iy, ix]!r}), k "
            f"({m.fields['k1'][side][iy, ix]!r}, {m.fields['k2'][side][iy, ix]!r}){extra}")


def check_model_11(case, m):
    f = m.fields
    cmd = case["command"]
    if cmd.f_left == cmd.f_right and case["grid"].xlim is None:   # a window may be lopsided
        assert np.array_equal(f["point_class"], f["point_class"][:, ::-1])
        assert np.array_equal(f["finger_mode"][0], f["finger_mode"][1][:, ::-1])
        assert np.allclose(f["energy"], f["energy"][:, ::-1], rtol=1e-12, atol=0,
                           equal_nan=True)
    if not case["effects"].joint_springs:
        scaled = run(case, command=Command(3.0 * cmd.f_left, 3.0 * cmd.f_right))
        for name in ("finger_mode", "theta1", "theta2", "point_class"):
            assert np.array_equal(scaled.fields[name], f[name], equal_nan=True), name
        assert np.allclose(scaled.fields["energy"], 3.0 * f["energy"], rtol=1e-12,
                           atol=1e-300, equal_nan=True)


def check_friction_monotone(case, m):
    """More friction never lowers the energy at a point feasible under both (MODEL 11), to the
    energy's resolution (docs/stability.md, the mu = 1e6 row: root_tol * r2 / k2)."""
    design, part, cmd = case["design"], case["part"], case["command"]
    if not case["effects"].friction or case["effects"].finger_collision:
        # with finger_collision a finger's configuration depends on the other's: more friction
        # stops one finger earlier, which can let the other close further (D14), and the sum
        # may fall; MODEL 11's statement is about each finger's own configuration
        return
    more = run(case, part=Part(part.r, 2.0 * part.mu + 0.5))
    f = m.fields
    both = (f["point_class"] != INFEASIBLE) & (more.fields["point_class"] != INFEASIBLE)
    tension = max(cmd.f_left, cmd.f_right)
    k2 = np.minimum(*(np.where(g["k2"] > 0, g["k2"], np.inf).min(axis=0)
                      for g in (f, more.fields)))
    # A stuck contact is located to root_tol in t1 (D4): its energy to root_tol (r1 + r2 |dt2 /
    # dt1|), |dt2 / dt1| = |k2 + l1 cos t2| / k2 <= 1 + l1 / k2 on the path, in either map.
    root_tol = max(case["accuracy"].root_tol, 1e-12)
    resolution = root_tol * (design.r1 + design.r2 * (1.0 + 10.0 * design.l1 / k2))
    tol = tension * (1e-12 * 4.0 * (design.r1 + design.r2) + 2.0 * resolution)
    lower = both & (more.fields["energy"] < f["energy"] - tol)
    assert not lower.any(), _where("more friction lowers the energy", m, lower, 0, None)


# ---------------------------------------------------------------------------------------------
# The edges of the accepted space (model-notes D30)
# ---------------------------------------------------------------------------------------------
#: theta2_min just above -90 deg (the validation refuses -90), at 0, a hair below 0, anywhere
EDGE_THETA2_MIN = st.sampled_from([-90.0 + 10.0 ** -k for k in (1, 3, 5, 7, 9, 11, 13)]
                                  + [0.0, -1e-12, -5.0]) | st.floats(-89.9999, 0.0)
#: what the edge draws put at a grid point of the right finger (EDGE_SNAPS's docstrings)
EDGE_SNAPS = ("b-graze", "tangent-at-b", "tangent-at-tip", "proximal-at-b",
              "two-phalanx-at-tip", "reach", "joint", "distal-at-max", "distal-at-min", "none")
#: how many grid points an edge map may have before it is windowed around the snapped point
EDGE_MAX_POINTS = 1500


def snap(kind, design, part, limits, dx, dy):
    """The design or limits that put the point d = (dx, dy) of the right finger's frame at an
    edge of MODEL 3-4, in closed forms of this test's own (None where the kind does not apply):
    b-graze: B's circle about J touches the disc from outside (|d| = l1 + r); tangent-at-b: the
    rigid sweep's distal tangency (3.3) exactly at B (k2 = 0: |d|^2 = l1^2 + r^2 + 2 r l1 s,
    s = sin(-theta2_min)); tangent-at-tip: the same at the tip (k2 = l2); proximal-at-b: the
    proximal tangency at B (k1 = l1); two-phalanx-at-tip: two-phalanx contact at the tip
    (k2 = l1 - k1 = l2, MODEL 3.4); reach: the tip's circle in the rigid sweep touches the disc
    from outside (the reach's boundary); distal-at-max / -min: the two-phalanx contact's t2
    (pi - 2 atan2(r, l1 - k1)) is the joint limit."""
    l1, r = design.l1, part.r
    dist = math.hypot(dx, dy)
    if dist <= r * (1.0 + 1e-9):
        return None
    s, c = math.sin(-limits.theta2_min), math.cos(limits.theta2_min)
    k1 = math.sqrt(dist * dist - r * r)
    if kind == "b-graze":
        return {"l1": dist - r}
    if kind == "tangent-at-b":
        return {"l1": -r * s + math.sqrt(r * r * s * s + dist * dist - r * r)}
    if kind == "tangent-at-tip":
        r_eff = r + l1 * s
        if dist <= r_eff:
            return None
        k2 = math.sqrt(dist * dist - r_eff * r_eff) - l1 * c
        return {"l2": k2} if k2 > 0 else None
    if kind == "proximal-at-b":
        return {"l1": k1}
    if kind == "two-phalanx-at-tip":
        return {"l2": l1 - k1} if k1 < l1 else None
    if kind == "reach":
        rho = dist - r   # l2^2 + 2 l1 c l2 + l1^2 - rho^2 = 0
        disc = l1 * l1 * c * c - l1 * l1 + rho * rho
        l2_new = -l1 * c + math.sqrt(disc) if disc >= 0 else -1.0
        return {"l2": l2_new} if l2_new > 0 else None
    if kind in ("distal-at-max", "distal-at-min"):
        t1 = math.atan2(dy, dx) - math.atan2(r, k1)
        if not (k1 < l1 and 0.0 <= t1 <= math.pi):
            return None
        t2 = math.degrees(math.pi - 2.0 * math.atan2(r, l1 - k1))
        if kind == "distal-at-max":
            return {"theta2_max_deg": t2} if limits.theta2_min_deg < t2 <= 180.0 else None
        return {"theta2_min_deg": t2} if -90.0 < t2 <= 0.0 and t2 < limits.theta2_max_deg else None
    return None


@st.composite
def edge_case(draw):
    """A map of accepted_case moved to the edges of the accepted space: joint limits at the
    extremes the validation accepts, and one grid point of the right finger put exactly (or
    within a few ulps) at an edge of the closing sequence (snap), or the part touching the
    finger's joint (joint). Falls back to the limits alone where a snap does not apply."""
    case = draw(accepted_case())
    th2min = draw(EDGE_THETA2_MIN)
    th2max = draw(st.sampled_from([180.0, 90.0, 180.0 - 1e-12, "span"])
                  | st.floats(th2min + 1e-9, 180.0))
    if th2max == "span":
        th2max = th2min + draw(st.sampled_from([1e-12, 1e-9, 1e-6, 1e-3]))
    th2max = min(max(th2max, math.nextafter(th2min, math.inf)), 180.0)
    limits = Limits(theta2_min_deg=th2min, theta2_max_deg=th2max)
    design, part, grid = case["design"], case["part"], case["grid"]
    kind = draw(st.sampled_from(EDGE_SNAPS))
    ulps = draw(st.sampled_from([0, 0, 0, 1, -1, 3, -3]))
    what = "limits"
    if kind == "joint":
        g = map_grid(design, part, grid)
        i = draw(st.integers(0, max(0, int(g.i.max()))))
        w = 2.0 * i * grid.h * (1.0 + ulps * 2.0 ** -52)
        if w > 0:
            design = dataclasses.replace(design, w=w)
            what = f"joint: part touching the right finger's joint under column {i}"
    elif kind != "none":
        g = map_grid(design, part, grid)
        ii = draw(st.integers(0, len(g.i) - 1))
        jj = draw(st.integers(0, len(g.y) - 1))
        dx = float(finger_offsets(g.i, design.w, g.h)[1][ii])
        dy = float(g.y[jj])
        change = snap(kind, design, part, limits, dx, dy)
        if change:
            key, value = next(iter(change.items()))
            value *= 1.0 + ulps * 2.0 ** -52
            if key in ("l1", "l2"):
                design = dataclasses.replace(design, **{key: value})
            else:
                limits = dataclasses.replace(limits, **{key: value})
            what = f"{kind} at (x, y) = ({g.x[ii]!r}, {dy!r}): {key} = {value!r}"
            # keep the point on the grid and the map small: a window about it if needed
            x0, y0 = float(g.x[ii]), dy
            full = map_grid(design, part, Grid(h=grid.h))
            inside = full.x[0] <= x0 <= full.x[-1] and y0 <= full.y[-1]
            if not inside or full.x.size * full.y.size > EDGE_MAX_POINTS:
                grid = Grid(h=grid.h, xlim=(x0 - 4 * grid.h, x0 + 4 * grid.h),
                            ylim=(max(part.r, y0 - 4 * grid.h), y0 + 4 * grid.h))
    effects = case["effects"]
    if effects.joint_springs:
        tension = min(case["command"].f_left, case["command"].f_right)
        span2 = limits.theta2_max - limits.theta2_min
        effects = dataclasses.replace(effects, spring_k2=min(
            effects.spring_k2, 0.999 * tension * design.r2 / span2))
    try:
        validate_inputs(design, part, case["command"], limits, case["accuracy"], effects)
    except ModelInputError:
        return case   # a snap the validation refuses (lengths of too many scales): as drawn
    return {**case, "design": design, "limits": limits, "effects": effects, "grid": grid,
            "edge": what}


def moved_limit(case, name, delta):
    """`case` with the joint limit `name` (a Limits field in degrees) moved by `delta` radians,
    or None where the validation refuses it or the move vanishes in round-off."""
    limits = case["limits"]
    new = dataclasses.replace(limits, **{name: getattr(limits, name) + math.degrees(delta)})
    if new == limits:
        return None
    try:
        validate_inputs(case["design"], case["part"], case["command"], new, case["accuracy"],
                        case["effects"])
    except ModelInputError:
        return None
    return {**case, "limits": new}


def outcome_key(m):
    """(class, left mode, right mode, where each VERTEX finger struck) per point: what a move
    of a limit may switch. A vertex strikes in the rigid sweep or with the proximal folded on
    its upper stop (MODEL 4.2), two events the VERTEX code does not tell apart: a graze of T in
    the rigid sweep entering or not switches between them, the energy jumping with the same
    codes (the long profile, 2026-11-28: theta2_min = -89.999999999 deg moved 3e-10 deg)."""
    f = m.fields
    mode = f["finger_mode"]
    folded = (mode == VERTEX) & (f["theta1"] >= math.pi - 1e-9)
    return np.stack([f["point_class"], mode[0], mode[1], folded[0], folded[1]])


def near_b(case, *maps):
    """Points where a finger of any of the maps has a distal contact within 1e-6 of the finger's
    size from B. There the edge path's stick test (MODEL 5.3) reads 3.2 at a tangent length of
    round-off size, whose angle carries up to 1e-8 (D30): whether the contact sticks right at B
    or slides on is decided by that round-off (left as it is, docs/stability.md), and a contact
    a hair from B that sticks on the lower stop against one at B that cannot (D10, D30) is a
    threshold the outcome codes do not show. Their energies are not compared."""
    d = case["design"]
    size = 1e-6 * (d.l1 + d.l2 + case["part"].r)
    out = np.zeros(maps[0].fields["energy"].shape, dtype=bool)
    for m in maps:
        k2 = m.fields["k2"]
        out |= ((k2 > 0) & (k2 < size)).any(axis=0)
    return out


def energy_resolution(case, *maps):
    """How far two maps' energies may differ where their outcomes agree (per unit tension): a
    stuck contact is located to root_tol in t1 (D4), so its energy to root_tol (r1 + r2 (1 +
    10 l1 / k2)), k2 the least contact length of either map (check_friction_monotone)."""
    d = case["design"]
    k2 = np.minimum.reduce([np.where(m.fields["k2"] > 0, m.fields["k2"], np.inf).min(axis=0)
                            for m in maps])
    root_tol = max(case["accuracy"].root_tol, 1e-12)
    return root_tol * (d.r1 + d.r2 * (1.0 + 10.0 * d.l1 / k2))


#: the limit moves: (Limits field, the direction into the accepted range)
LIMIT_MOVES = (("theta2_min_deg", 1.0), ("theta2_max_deg", -1.0))


def check_limit_moves(case, m):
    """A limit and the same limit 1e-12 inside it give the same map (MODEL 5.5's slack: the
    same finger configurations and energies, to the limit's move and the energy's resolution,
    and the same classes and modes except where two of the model's events tie exactly and
    leave the fingers in the same place, e.g. g = 0 exactly at theta2_max = 90 deg with r1 = r2
    and a proximal contact at the joint: two-phalanx, sticking, or distal-only on the proximal
    stop, the same angles); along a move of
    1e-9 into the range (three equal steps) every map keeps its links out of the part, each
    point's outcome switches at most once (a threshold of the model crossed, never back and
    forth: a flip is a decision taken by round-off), and where it does not switch the energy
    moves continuously (both with root_tol <= 1e-10; contacts within a hair of B excepted,
    near_b). "1e-12" is radians at the finger's scale: the length tests of MODEL 3
    are inclusive by an absolute 1e-12, which an angle's move of 1e-12 shifts by 1e-12 times
    the lengths, so the move is 1e-12 / max(1, l1 + l2 + r)."""
    d = case["design"]
    cmd = case["command"]
    if case["effects"].finger_collision and d.w == 0.0:
        # fingers sharing a base touch there, and lie along each other on the palm line, in
        # configurations whose touch test (D5, D14) a limit's move decides: left open
        # (docs/stability.md), no link through the part at stake
        return
    tension = max(cmd.f_left, cmd.f_right)
    inside = 1e-12 / max(1.0, d.l1 + d.l2 + case["part"].r)
    for name, sign in LIMIT_MOVES:
        near = moved_limit(case, name, sign * inside)
        if near is not None:
            mn = run(near)
            tol = tension * ((d.r1 + d.r2) * 1e-9 + 2.0 * energy_resolution(case, m, mn))
            moved = np.zeros(m.fields["energy"].shape, dtype=bool)
            for key in ("theta1", "theta2"):
                moved |= (np.abs(m.fields[key] - mn.fields[key]) > 1e-9).any(axis=0)
            relabelled = (outcome_key(m) != outcome_key(mn)).any(axis=0)
            assert not (relabelled & moved).any(), _where(
                f"{name} moved 1e-12 inside changes the outcome", m, relabelled & moved, 0,
                None)
            jump = ((np.abs(m.fields["energy"] - mn.fields["energy"]) > tol)
                    & ~near_b(case, m, mn))
            assert not jump.any(), _where(f"{name} moved 1e-12 inside moves the energy", m,
                                          jump, 0, None)
        if case["accuracy"].root_tol > 1e-10:
            # a coarse root_tol locates events only to itself: which of two events within it
            # comes first is an accuracy setting's answer (D19), not round-off
            continue
        maps = [m]
        for k in (1, 2, 3):
            c = moved_limit(case, name, sign * k * 1e-9 / 3.0)
            if c is None:
                break
            maps.append(run(c))
            check_map(c, maps[-1])
        if len(maps) < 2:
            continue
        keys = [outcome_key(x) for x in maps]
        switches = sum((a != b).any(axis=0).astype(int) for a, b in zip(keys, keys[1:]))
        assert not (switches > 1).any(), _where(
            f"the outcome flips back and forth along a 1e-9 move of {name}", m, switches > 1,
            0, None)
        if case["effects"].finger_collision:
            # where the fingers meet is a threshold the outcome codes do not show (a finger
            # stopped by the other keeps its mode), so its jumps are not told from continuity
            continue
        same = (keys[0] == keys[-1]).all(axis=0)
        tol = tension * ((d.r1 + d.r2) * 1e-6 + 2.0 * energy_resolution(case, maps[0],
                                                                           maps[-1]))
        jump = (same & ~near_b(case, maps[0], maps[-1])
                & (np.abs(maps[0].fields["energy"] - maps[-1].fields["energy"]) > tol))
        assert not jump.any(), _where(f"the energy jumps along a 1e-9 move of {name}", m, jump,
                                      0, None)


# ---------------------------------------------------------------------------------------------
# Cases the long profile found (docs/stability.md)
# ---------------------------------------------------------------------------------------------
def test_tip_path_ends_where_the_distal_link_reaches_the_disc_at_the_tip():
    """D20: l1 = l2 = 1, r = 0.1, theta2_min = -89.999 deg, tip_contact, no friction; the part
    at d = (-1.55, 0.8875) (over the palm): the rigid sweep folds the proximal to pi, the tip
    strikes, the tip path follows it on the disc while the distal link turns towards the part.
    Where the link becomes tangent at the tip the path must end (beyond, it cuts through the
    part: found at distance 0.022 from the centre): the part is lost there, as the reference
    says."""
    from naive_tip import naive_tip_finger
    from sweep.kernels.finger import solve_finger
    from kernel_calls import solver_settings
    from sweep.kernels.records import NO_EFFECTS, FingerModel, TipContact
    from sweep.model import SLIPPED

    l1 = l2 = 1.0
    r, dx, dy = 0.1, -1.55, 0.8875
    th2min, th2max = math.radians(-89.999), math.radians(90.0)
    got = solve_finger(dx, dy, FingerModel(l1, l2, 1.0, 1.0, r, 0.0, th2min, th2max),
                       solver_settings(0.01, 1e-12),
                       NO_EFFECTS._replace(tip_contact=TipContact(True)))
    ref = naive_tip_finger(dx, dy, l1, l2, 1.0, 1.0, r, 0.0, th2min, th2max)
    assert got.mode == ref["mode"] == SLIPPED
    assert got.t1 == pytest.approx(ref["t1"], abs=1e-9)
    assert got.t2 == pytest.approx(ref["t2"], abs=1e-9)
    (_, b, t) = finger_points(Design(l1, l2, 1.0, 1.0, 0.0), np.array(got.t1),
                              np.array(got.t2), 1)
    assert segment_distance(dx, dy, b, t) >= r * (1 - LINK_TOL)
    assert math.hypot(t[0] - dx, t[1] - dy) == pytest.approx(r, rel=1e-9)   # tangent at T


def test_tip_path_stops_where_the_proximal_link_reaches_the_part():
    """D21: on the tip path t1 turns back up and the proximal link reached the part (found 112
    from the centre, r = 122.2): it must rest on the part, mode proximal_tip, as the
    reference says."""
    from naive_tip import PROXIMAL_TIP, naive_tip_finger
    from sweep.kernels.finger import solve_finger
    from kernel_calls import solver_settings
    from sweep.kernels.records import NO_EFFECTS, FingerModel, TipContact

    l1, l2, r1, r2, r = 500.0, 86.52376598789029, 10**0.05, 1.1220184543019633, 122.1733280394845
    dx, dy = -362.1046561831639, r                       # on the palm row, over the palm
    th2min, th2max, step, tol = 0.0, math.pi, 0.0024350084815844947, 7.047176434405351e-07
    got = solve_finger(dx, dy, FingerModel(l1, l2, r1, r2, r, 0.0, th2min, th2max),
                       solver_settings(step, tol),
                       NO_EFFECTS._replace(tip_contact=TipContact(True)))
    ref = naive_tip_finger(dx, dy, l1, l2, r1, r2, r, 0.0, th2min, th2max, step, tol)
    assert got.mode == ref["mode"] == PROXIMAL_TIP
    assert got.t1 == pytest.approx(ref["t1"], abs=1e-9)
    assert got.t2 == pytest.approx(ref["t2"], abs=1e-9)
    assert got.k1 == pytest.approx(ref["k1"], rel=1e-9)
    j, b, t = finger_points(Design(l1, l2, r1, r2, 0.0), np.array(got.t1), np.array(got.t2), 1)
    assert segment_distance(dx, dy, j, b) == pytest.approx(r, rel=1e-9)   # on the part
    assert segment_distance(dx, dy, b, t) >= r * (1 - LINK_TOL)


def test_tip_path_ends_on_a_proximal_stop_passed_within_one_step():
    """D19: a coarse reconfig_step (0.31 rad) stepped the tip path past its proximal stop; the
    lost tip was reported with t1 clamped to 0 and its distal link 3% of r inside the part. The
    path ends on the stop, as the reference says."""
    from naive_tip import naive_tip_finger
    from sweep.kernels.finger import solve_finger
    from kernel_calls import solver_settings
    from sweep.kernels.records import NO_EFFECTS, FingerModel, TipContact
    from sweep.model import TIP_ONLY

    l1 = l2 = 1e-3
    r1, r2, r = 10.0 ** -0.99999, 0.10000230261160267, 0.00012140319836728114
    dx, dy, step = 0.0011785573324262675, 0.0010642490643082952, 0.3077707726902199
    th2max = math.radians(90.0)
    got = solve_finger(dx, dy, FingerModel(l1, l2, r1, r2, r, 0.0, 0.0, th2max),
                       solver_settings(step, 1e-12),
                       NO_EFFECTS._replace(tip_contact=TipContact(True)))
    ref = naive_tip_finger(dx, dy, l1, l2, r1, r2, r, 0.0, 0.0, th2max, step, 1e-12)
    assert got.mode == ref["mode"] == TIP_ONLY and got.t1 == ref["t1"] == 0.0
    assert got.t2 == pytest.approx(ref["t2"], abs=1e-9)
    j, b, t = finger_points(Design(l1, l2, r1, r2, 0.0), np.array(got.t1), np.array(got.t2), 1)
    assert segment_distance(dx, dy, b, t) >= r * (1 - LINK_TOL)
    assert math.hypot(t[0] - dx, t[1] - dy) == pytest.approx(r, rel=1e-9)


#: Found by the long profile (2026-11-27): a map of l1 = l2 = 1e-3, r = 2e-5 with tip_contact and
#: a coarse reconfig_step (0.318 rad); the part on the palm line beyond the palm.
PALM_LINE_TIP_CASE = dict(
    design=Design(l1=0.001, l2=0.0010046157902783952, r1=0.03249468674022912,
                  r2=0.03249468674022912, w=1.1927364753181519e-05),
    part=Part(r=2.0000000000000015e-05, mu=0.0305472156318628),
    command=Command(f_left=0.0305472156318628, f_right=1.0),
    limits=Limits(theta1_min_deg=0.0, theta1_max_deg=180.0,
                  theta2_min_deg=-6.677145136734467, theta2_max_deg=90.0),
    accuracy=Accuracy(reconfig_step=0.3180722275030504, root_tol=1e-12, trajectory="grid8"),
    effects=Effects(friction=True, tip_contact=True),
    outputs=Outputs(energy=True, equilibrium=True, caging=True, forces=False),
    grid=Grid(h=5.9636823765907595e-06))


def test_tip_path_ends_where_the_link_cut_in_within_one_step():
    """D20 within one step (as D19): the tip struck at t1 = 0.058 and slid down the disc; its
    distal link reached the disc at the tip near t2 = -0.080 and cut in until t1 had passed far
    below its stop, where it came out again: at the nodes of a 0.318 rad step only the proximal
    stop held, and the finger was reported on it (TIP_ONLY, t1 = 0) with its distal link 1.7e-8
    inside the part. The part is lost where the link reaches the disc at the tip, as a fine
    step (0.001 rad) finds in the reference."""
    from naive_tip import naive_tip_finger
    from sweep.kernels.finger import solve_finger
    from kernel_calls import solver_settings
    from sweep.kernels.records import NO_EFFECTS, FingerModel, TipContact
    from sweep.model import SLIPPED

    c = PALM_LINE_TIP_CASE
    d, part, lim = c["design"], c["part"], c["limits"]
    th2min, th2max = math.radians(lim.theta2_min_deg), math.radians(lim.theta2_max_deg)
    dx, dy, step = 0.0020037972785344953, part.r, c["accuracy"].reconfig_step
    got = solve_finger(dx, dy, FingerModel(d.l1, d.l2, d.r1, d.r2, part.r, part.mu, th2min,
                                           th2max),
                       solver_settings(step, 1e-12),
                       NO_EFFECTS._replace(tip_contact=TipContact(True)))
    fine = naive_tip_finger(dx, dy, d.l1, d.l2, d.r1, d.r2, part.r, part.mu, th2min, th2max,
                            0.001, 1e-12)
    coarse = naive_tip_finger(dx, dy, d.l1, d.l2, d.r1, d.r2, part.r, part.mu, th2min, th2max,
                              step, 1e-12)
    assert got.mode == fine["mode"] == coarse["mode"] == SLIPPED
    for ref in (fine, coarse):
        assert got.t1 == pytest.approx(ref["t1"], abs=1e-9)
        assert got.t2 == pytest.approx(ref["t2"], abs=1e-9)
    (_, b, t) = finger_points(dataclasses.replace(d, w=0.0), np.array(got.t1),
                              np.array(got.t2), 1)   # the finger frame
    assert segment_distance(dx, dy, b, t) >= part.r * (1 - LINK_TOL)
    assert math.hypot(t[0] - dx, t[1] - dy) == pytest.approx(part.r, rel=1e-9)   # tangent at T


def test_a_map_whose_tip_path_cut_in_within_one_step_keeps_its_links_out_of_the_part():
    """The long profile's draw itself (the left finger at x = -0.00201 on the palm line)."""
    check_map(PALM_LINE_TIP_CASE, run(PALM_LINE_TIP_CASE))


#: Found by the long profile's fixed draws (2026-11-28): joint springs almost as strong as the
#: right finger's small tension, tip_contact, a 0.01 rad reconfig_step.
SPRING_TIP_CASE = dict(
    design=Design(l1=1.0, l2=1.0, r1=1.0, r2=1.0, w=1.0000002744895709),
    part=Part(r=1.0000002744895709, mu=1.0),
    command=Command(f_left=3.9825897108945525, f_right=0.000684943065318304),
    limits=Limits(theta1_min_deg=0.0, theta1_max_deg=180.0, theta2_min_deg=-5.0,
                  theta2_max_deg=5.308993036854141e-285),
    accuracy=Accuracy(reconfig_step=0.01, root_tol=1e-12, trajectory="sliding"),
    effects=Effects(friction=True, tip_contact=True, joint_springs=True,
                    spring_k1=0.0001737040954804004, spring_k2=0.007474707688161604),
    outputs=Outputs(energy=True, equilibrium=True, caging=True, forces=False),
    grid=Grid(h=0.2500000686223927))


def test_a_tip_path_that_turns_uphill_within_one_step_sticks_where_the_tip_first_holds():
    """D15 within one step (as D19, D20): the right finger's tip struck with its distal on the
    lower stop and slid along the disc (t2 rising from -5 deg); the springs' torque grows with
    t2, so V along the path has a minimum near t2 = -0.0335, where no friction at all is
    needed; beyond it the tendon would pull the tip off (normal force < 0 from t2 = -0.0304).
    The stick window (-0.0354, -0.0305) at mu = 1 lay between two nodes of the 0.01 rad step,
    and the finger was reported lost (SLIPPED) at t2 = -0.0304, uphill of where it stuck: more
    friction (mu = 2.5, sticking at a node) then gave a lower energy. The path ends where the tip
    first holds, as a scan of the path at 1e-5 rad finds from the statics written out here
    (the tip's columns of naive_tip, the springs' torques of model-notes D13)."""
    from naive_tip import tip_columns, tip_strike_t1
    from sweep.kernels.finger import solve_finger
    from kernel_calls import solver_settings
    from sweep.kernels.records import NO_EFFECTS, FingerModel, JointSprings, TipContact
    from sweep.model import TIP_ONLY

    c = SPRING_TIP_CASE
    d, part, lim, eff = c["design"], c["part"], c["limits"], c["effects"]
    tension = c["command"].f_right
    th2min, th2max = math.radians(lim.theta2_min_deg), math.radians(lim.theta2_max_deg)
    dx, dy = 1.75 - 0.5 * d.w, 2.0000005489791417          # the right finger's frame

    def tip_holds(t2):
        t1 = tip_strike_t1(dx, dy, t2, d.l1, d.l2, part.r)
        tau = (d.r1 - eff.spring_k1 / tension * t1,
               d.r2 - eff.spring_k2 / tension * (t2 - th2min))
        c_n, c_t = tip_columns(dx, dy, t1, t2, d.l1, d.l2)
        # tau = F c_n + G c_t: the tip's normal force F and tangential force G
        big_f, big_g = np.linalg.solve(np.array([[c_n[0], c_t[0]], [c_n[1], c_t[1]]]), tau)
        return big_f >= 0.0 and abs(big_g) <= part.mu * big_f

    scan = th2min + 1e-5 * np.arange(1, int((th2max - th2min) / 1e-5))
    first = next(t2 for t2 in scan if tip_holds(t2))
    assert not tip_holds(first + 0.012)       # the window closes within one 0.01 step
    for step in (0.01, 1e-4):
        got = solve_finger(dx, dy, FingerModel(d.l1, d.l2, d.r1, d.r2, part.r, part.mu, th2min,
                                               th2max),
                           solver_settings(step, 1e-12),
                           NO_EFFECTS._replace(tip_contact=TipContact(True),
                                               joint_springs=JointSprings(
                                                   True, eff.spring_k1, eff.spring_k2,
                                                   tension)))
        assert got.mode == TIP_ONLY, step
        assert got.t2 == pytest.approx(first - 0.5e-5, abs=1e-5), step
        assert got.t1 == pytest.approx(tip_strike_t1(dx, dy, got.t2, d.l1, d.l2, part.r),
                                       abs=1e-12)


def test_more_friction_never_lowers_the_energy_where_a_tip_path_turned_uphill_within_a_step():
    """The long profile's draw itself: at (1.75, 2.0) the energy at mu = 1 was 3.6e-8 above
    that at mu = 2.5."""
    check_friction_monotone(SPRING_TIP_CASE, run(SPRING_TIP_CASE))


def test_a_finger_stopped_by_the_other_with_tip_contact_keeps_its_links_out_of_the_part():
    """Found by the long profile (2026-11-25): finger_collision and tip_contact on, a small part
    (r = 0.1225, mu = 0): at one grid point the left finger, reported free (mode 0) at
    theta = (1.1267, 0.8810), had its distal link 0.1117 from the part's centre (r = 0.1225):
    it had slipped along its tip path, and was stopped on the path D14 rebuilds from its final
    angles, which it never took. Fixed by model-notes D29 (stopped on its own path)."""
    case = dict(design=Design(l1=0.9998594712341624, l2=0.08062580376912969, r1=1.0, r2=1.0,
                              w=0.12174083791851716),
                part=Part(r=0.12248872394525123, mu=0.0),
                command=Command(f_left=1.0, f_right=6.0396353060967475e-05),
                limits=Limits(theta2_min_deg=-5.0, theta2_max_deg=160.46620731538695),
                accuracy=Accuracy(reconfig_step=0.003451821595142421,
                                  root_tol=9.349986920991872e-09, trajectory="continuous"),
                effects=Effects(friction=True, tip_contact=True, finger_collision=True),
                outputs=Outputs(), grid=Grid(h=0.12029739989485433))
    check_map(case, run(case))


def test_a_part_touching_the_joint_within_round_off_rests_on_the_open_proximal_link():
    """Found by the long profile (2026-11-25): the part's circle passes through the left
    finger's joint to round-off (d = (2.3e-8, 1), r = 1: the tangent length 2.3e-8 is known
    only to about 20%, so the proximal tangency's angle came out -1.8e-9, beyond RANGE_TOL).
    The tangency was rejected, the rigid sweep went on through the part and the finger
    ended with its proximal link 0.866 from the centre. The link is tangent on its stop:
    it rests on the part there (stability.md)."""
    case = dict(design=Design(l1=1.000000137244776, l2=1.0000000000002303, r1=1.0, r2=1.0,
                              w=1.0),
                part=Part(r=1.0, mu=0.0),
                command=Command(f_left=0.0, f_right=1.0),
                limits=Limits(theta2_min_deg=-5.0, theta2_max_deg=1e-12),
                accuracy=Accuracy(reconfig_step=0.0001, root_tol=1e-12,
                                  trajectory="continuous"),
                effects=Effects(friction=True, tip_contact=True),
                outputs=Outputs(), grid=Grid(h=0.5000000228741678))
    check_map(case, run(case))


# ---------------------------------------------------------------------------------------------
# Graze and tangency decisions at the edges (model-notes D30): each with a case of the scan
# (docs/notes/edge_scan.py) or of the edge draws, against brute-force geometry, the reference or
# the model's own invariance, never against the kernel's earlier output
# ---------------------------------------------------------------------------------------------
#: theta2_min = -89.9999999 deg: B's circle about J touches the disc from outside (|d| = l1 + r)
#: while the distal link, all but perpendicular to the proximal one, comes tangent at B
D30_GRAZE = dict(dx=0.9, dy=1.2, l1=1.0, l2=1.0, r=0.5, theta2_min=math.radians(-89.9999999),
                 theta2_max=math.radians(90.0))


def first_contact_by_brute_force(dx, dy, l1, l2, r, theta2_min):
    """(t1, arc length along J-B-T) of the rigid sweep's first contact, by dense sampling of
    the link-disc distance (tests/test_closing_bruteforce.py; no closed forms)."""
    from test_closing_bruteforce import brute_rigid
    return brute_rigid(dx, dy, l1, l2, r, theta2_min)


def links_clear_of_the_part(dx, dy, l1, l2, r, state):
    j, b, t = finger_points(Design(l1, l2, 1.0, 1.0, 0.0), np.array(state.t1),
                            np.array(state.t2), 1)
    return min(segment_distance(dx, dy, j, b), segment_distance(dx, dy, b, t)) / r - 1.0


@pytest.mark.parametrize("scale", [1e-3, 1.0, 1e3, 1e9])
def test_a_graze_of_b_with_the_distal_link_cutting_in_is_the_first_contact(scale):
    """MODEL 4 (revised 2026-11-27), D30: at D30_GRAZE the rigid sweep's distal tangency (3.3)
    lies at k2 = 0 as B grazes the disc; through asin(r'/|d|) near 1 it came out k2 = -1e-8
    and was rejected, the graze of B was ignored (D3), and the finger swept on until its tip
    struck at t1 = 1.3729 with its distal link 0.29 r inside the part (every scale from 1e-3
    up). Brute force: the first contact is at t1 = atan2(dy, dx), at B. The tangency wins the
    tie (D3) as a contact at B (k2 = 0), which cannot stick and slides (D10, D15); the settled
    finger keeps its links out of the part, as the reference says, at every scale."""
    from kernel_calls import closing, solve
    from naive import naive_finger
    from sweep.kernels.finger import DISTAL_ON_LOWER_STOP

    c = D30_GRAZE
    tb, ub = first_contact_by_brute_force(c["dx"], c["dy"], c["l1"], c["l2"], c["r"],
                                          c["theta2_min"])
    assert tb == pytest.approx(math.atan2(c["dy"], c["dx"]), abs=1e-6) and ub == pytest.approx(
        c["l1"], abs=1e-6)
    dx, dy, l1, l2, r = (scale * c[k] for k in ("dx", "dy", "l1", "l2", "r"))
    first = closing(dx, dy, l1, l2, r, c["theta2_min"], c["theta2_max"])
    assert first.mode == DISTAL_ON_LOWER_STOP and first.k2 == 0.0
    assert first.t1 == pytest.approx(tb, abs=1e-6)
    args = (dx, dy, l1, l2, 0.2, 0.1, r, 0.4, c["theta2_min"], c["theta2_max"])
    final = solve(*args, 0.01, 1e-12)
    assert links_clear_of_the_part(dx, dy, l1, l2, r, final) >= -LINK_TOL
    ref = naive_finger(*args)
    assert final.mode == ref["mode"] and final.t1 == pytest.approx(ref["t1"], abs=1e-9)


def test_a_map_at_the_graze_of_b_has_no_link_through_the_part_and_the_reference_energy():
    """The issue's case on a map (D30): l1 = l2 = 1, r = 0.5, theta2_min = -89.9999999 deg, the
    point (0, 1.5) on both fingers' graze circle (|d| = l1 + r). It was VERTEX with both distal
    links 0.146 (0.29 r) inside the part and an energy 0.089 below the model's; now every
    link is clear and the energy there is the reference's (tests/naive.py)."""
    from naive import naive_point

    case = dict(design=Design(1.0, 1.0, 0.1, 0.05, 0.0), part=Part(0.5, 0.4),
                command=Command(1.0, 1.0),
                limits=Limits(theta2_min_deg=-89.9999999, theta2_max_deg=90.0),
                accuracy=Accuracy(), effects=Effects(), outputs=Outputs(), grid=Grid(h=0.1))
    m = run(case)
    check_map(case, m)
    i = int(np.argmin(np.abs(m.x)))
    j = int(np.argmin(np.abs(m.y - 1.5)))
    assert m.x[i] == 0.0 and m.y[j] == pytest.approx(1.5, abs=1e-15)
    ref = naive_point(0.0, m.y[j], 1.0, 1.0, 0.1, 0.05, 0.0, 0.5, 0.4,
                      theta2_min=case["limits"].theta2_min,
                      theta2_max=case["limits"].theta2_max)
    assert m.fields["point_class"][j, i] == ref["point_class"] == REACHED
    assert m.fields["energy"][j, i] == pytest.approx(ref["energy"], abs=1e-9)


def test_a_distal_link_tangent_at_b_after_a_proximal_contact_at_b_is_a_two_phalanx_contact():
    """D30, MODEL 3.2 within its round-off; case of the scan: theta2_min = 0 (the extreme the
    validation accepts), the proximal link tangent at B (k1 = l1), so the distal closes from its
    lower stop tangent at B (k2 = 0, t2 = 0 by MODEL 3.4). t2 came out below 0 by round-off,
    3.2 was rejected and the distal link closed to theta2_max = 5.2 deg, 0.4% of r into the
    part (PROXIMAL_ONLY, unflagged). Brute force: the distal link meets the disc at t2 = 0,
    at B."""
    from kernel_calls import closing
    from test_closing_bruteforce import brute_close_distal

    dx, dy, l1, l2, r = (0.8023191403825144, 0.10679381955143356, 0.8037489932390243,
                         1.1305086829984365, 0.09543835070658839)
    th2min, th2max = 0.0, 0.09084757333401475
    first = closing(dx, dy, l1, l2, r, th2min, th2max)
    t2b, sb = brute_close_distal(dx, dy, first.t1, l1, l2, r, th2min, th2max)
    assert first.mode == TWO_PHALANX and first.k1 == l1
    assert first.t2 == pytest.approx(t2b, abs=1e-6) and first.k2 == pytest.approx(sb, abs=1e-6)
    assert links_clear_of_the_part(dx, dy, l1, l2, r, first) >= -LINK_TOL


@pytest.mark.parametrize("t1", [0.1, 0.5, 0.7, 1.1])
def test_a_proximal_tangency_at_b_is_decided_alike_at_every_scale(t1):
    """D30, MODEL 3.1's k1 <= l1 within its round-off: the proximal link tangent at B (k1 = l1,
    MODEL 5.5: valid, inclusive), then the distal tangent at B too (3.2: k2 = 0, t2 = 0): a
    two-phalanx contact at every scale. With the absolute RANGE_TOL alone, round-off decided it
    at scales 1e6 and 1e9 (k1 = l1 + 1e-10): a strike of B (VERTEX) instead."""
    from kernel_calls import closing

    for scale in (1.0, 1e6, 1e9):
        l1, l2, r = 2.0 * scale, 1.6 * scale, 0.4 * scale
        dx, dy = l1 * math.cos(t1) - r * math.sin(t1), l1 * math.sin(t1) + r * math.cos(t1)
        first = closing(dx, dy, l1, l2, r, math.radians(-5.0), math.radians(90.0))
        assert first.mode == TWO_PHALANX and first.k1 == l1, scale
        assert first.t1 == pytest.approx(t1, abs=1e-12), scale


@pytest.mark.parametrize("dx", [0.05, 0.2, 0.5])
def test_a_part_dipping_below_the_palm_line_touches_the_open_finger(dx):
    """D30: the feasibility test accepts a part up to RANGE_TOL below the palm row (off the
    grid, where slides go); 9e-13 below, the proximal tangency's angle came out -4.5e-12 (for
    dx = 0.2), beyond RANGE_TOL: rejected, the finger swept on through the part and B struck
    at t1 = 0.927 (VERTEX) with the proximal link inside. Brute force: the open finger
    (t1 = 0) already touches the part, on its proximal link at dx."""
    from kernel_calls import closing

    dy, l1, l2, r, th2min = 0.5 - 9e-13, 1.0, 1.0, 0.5, math.radians(-5.0)
    tb, ub = first_contact_by_brute_force(dx, dy, l1, l2, r, th2min)
    assert tb == 0.0 and ub == pytest.approx(dx, abs=1e-6)
    first = closing(dx, dy, l1, l2, r, th2min, math.radians(90.0))
    assert first.mode in (PROXIMAL_ONLY, TWO_PHALANX)
    assert first.t1 == 0.0 and first.k1 == pytest.approx(dx, abs=1e-9)


def test_a_distal_contact_within_round_off_of_b_does_not_stick_by_round_off():
    """D30; found by the edge draws: theta2_min = -89.9 deg and the same limit 1e-12 rad inside
    it gave the rigid sweep's distal tangency at B as k2 = 6.8e-15 and k2 = -5.5e-14 (clamped
    to 0): the first stuck on its lower stop (D10 needs k2 > 0), the second slid to the tip
    (SLIPPED), an energy 0.028 apart at three points of the map. Within its round-off of B
    the contact is at B (k2 = 0) for both: the same settled finger."""
    from kernel_calls import solve

    l1, l2, r1, r, mu = (2.177854728095023, 0.11692176841063112, 0.015947959508975977,
                         0.09703530199542944, 0.09703530199542944)
    dx, dy = 1.55934056419791, 1.6563758661933394
    th2min, th2max = math.radians(-89.9), math.pi
    states = [solve(dx, dy, l1, l2, r1, r1, r, mu, th2min + move, th2max, 0.01, 1e-12)
              for move in (0.0, 1e-12)]
    assert states[0].mode == states[1].mode
    assert states[0].t1 == pytest.approx(states[1].t1, abs=1e-9)
    assert states[0].t2 == pytest.approx(states[1].t2, abs=1e-9)


def exact_excess(dx, dy, l1, r):
    """|d|^2 - (l1 + r)^2 in exact arithmetic of the given floats: < 0 where B's circle about J
    reaches into the disc (B enters it), > 0 where it misses."""
    from fractions import Fraction as Q
    return Q(dx) ** 2 + Q(dy) ** 2 - (Q(l1) + Q(r)) ** 2


def contact_arc_length(state, l1):
    """Where along J-B-T a first contact of the rigid sweep touches: k1 on the proximal link (a
    strike of B reports k1 = l1), else l1 + k2 on the distal one (a strike of T: l1 + l2)."""
    return state.k1 if state.k1 > 0.0 else l1 + state.k2


def check_stops_at_the_first_contact(dx, dy, l1, l2, r, theta2_min):
    """The rigid sweep's first contact (closing_contact) is brute force's: same angle and place
    along the finger (1e-6: a vertex grazing the disc crosses it only to sqrt(eps)), links out
    of the part there; and the reference (tests/naive.py) agrees."""
    from kernel_calls import closing
    from naive import EV_NONE, rigid_sweep

    tb, ub = first_contact_by_brute_force(dx, dy, l1, l2, r, theta2_min)
    first = closing(dx, dy, l1, l2, r, theta2_min, math.radians(90.0))
    assert first.mode != FREE, (tb, ub)
    assert first.t1 == pytest.approx(tb, abs=1e-6)
    assert contact_arc_length(first, l1) == pytest.approx(ub, abs=1e-6 * l1)
    assert links_clear_of_the_part(dx, dy, l1, l2, r, first) >= -LINK_TOL
    kind, t1_ref, _ = rigid_sweep(dx, dy, l1, l2, r, theta2_min)
    assert kind != EV_NONE and t1_ref == pytest.approx(tb, abs=1e-6)
    return first, tb, ub


@pytest.mark.parametrize("l1, r, depth", [(1.0, 0.5, 1e-13), (1.0, 0.5, 2e-12),
                                          (1.0, 0.01, 1e-13), (1.0, 0.01, 1e-11),
                                          (1.0, 0.05, 3e-12)])
def test_b_entering_the_disc_by_less_than_the_graze_tolerance_stops_the_rigid_sweep(l1, r, depth):
    """MODEL 4 revised, D30 (mutant d30-graze-of-b-ignored). B's circle about J reaches `depth`
    into the disc (|d| = l1 + r - depth), so little that MODEL 4's acos argument for B lies
    within RANGE_TOL of 1 (D3 would call it a graze), with the distal link 1e-5 deg short of
    perpendicular to the proximal one (theta2_min = -89.99999 deg). The distal line then reaches
    over the centre's side of B's circle (r' = r + l1 cos(1e-5 deg) > |d|): 3.3 has no
    tangency, and once B has passed the line from J through the centre the distal link cuts
    into the part. Brute force: the first contact is B, within 1.4e-6 rad of atan2(d); ignoring
    the graze, the finger swept on until its tip struck (l1 = l2 = 1, r = 0.5: t1 = 1.3729,
    the distal link 0.29 r inside) or to the proximal stop with the distal link through the
    whole part (r = 0.01). The reference read the links' directions at B's entry angle, where
    the distal link still pointed out of the disc, and ignored it too (fixed, D30)."""
    l2, th2min = 1.0, math.radians(-89.99999)
    dist = l1 + r - depth
    dx, dy = 0.6 * dist, 0.8 * dist
    assert exact_excess(dx, dy, l1, r) < 0  # B enters the disc
    first, tb, ub = check_stops_at_the_first_contact(dx, dy, l1, l2, r, th2min)
    assert first.mode == VERTEX and first.k1 == l1 and ub == pytest.approx(l1, abs=1e-6)
    assert tb == pytest.approx(math.atan2(dy, dx), abs=2e-6)
    # swept on past B, the distal link cuts into the part (by brute force): B's graze matters
    from test_closing_bruteforce import polyline_contact
    ts = np.linspace(tb, min(tb + 0.5, math.pi), 2001)
    assert polyline_contact(dx, dy, ts, th2min, l1, l2)[0].min() < 0.9 * r


def test_b_grazing_the_disc_with_its_acos_argument_rounded_above_one_stops_the_rigid_sweep():
    """MODEL 4 revised, D30 (mutant d30-graze-round-off-above-one). l1 = 2, l2 = 1, r = 0.01,
    theta2_min = -89.99999 deg, the part at 2.01 (0.6, 0.8) moved down by 1 to 40 ulps of d_y:
    in exact arithmetic B's circle about J reaches into the disc (by up to 7e-15), so the
    distal line, 1e-5 deg short of perpendicular, passes over the centre's side of B's circle
    and the distal link cuts through the part once B has passed the line from J through the
    centre. MODEL 4's acos argument for B comes out exactly 1 for most of these and 1 + 2.2e-16
    for some (its round-off is 4 eps (l1^2 + |d|^2 + r^2) / (2 l1 |d|) = 8.9e-16 here); 3.3's
    tangency lies behind B beyond its round-off (rejected). Reading "above 1" as a miss, the
    finger swept on to its proximal stop (FREE) with the distal link through the whole part.
    Brute force: the first contact is B, at atan2(d) within 1e-8 rad, for every one of them."""
    l1, l2, r, th2min = 2.0, 1.0, 0.01, math.radians(-89.99999)
    dist = l1 + r
    rounded_above = 0
    for k in range(1, 41):
        dx, dy = 0.6 * dist, 0.8 * dist - k * math.ulp(0.8 * dist)
        assert exact_excess(dx, dy, l1, r) < 0, k  # B enters the disc
        d2 = dx * dx + dy * dy
        rounded_above += (l1 * l1 + d2 - r * r) / (2.0 * l1 * math.sqrt(d2)) > 1.0
        first, tb, ub = check_stops_at_the_first_contact(dx, dy, l1, l2, r, th2min)
        assert ub == pytest.approx(l1, abs=1e-6), k
        assert tb == pytest.approx(math.atan2(dy, dx), abs=1e-8), k
    assert rounded_above >= 3


def test_physical_invariants_hold_over_the_accepted_space():
    @PROFILE
    @given(accepted_case())
    def check(case):
        note(repr(case))
        m = run(case)
        check_map(case, m)
        check_model_11(case, m)

    check()


def test_no_link_through_the_part_at_the_edges_of_the_accepted_space():
    """The invariants of test_physical_invariants_hold_over_the_accepted_space on maps drawn at
    the edges (edge_case): joint limits at the extremes the validation accepts, a grid point
    put on a graze of B, a tangency at k = 0 or k = l, the reach's boundary or the finger's
    joint (model-notes D30)."""
    @settings(PROFILE, max_examples=EDGE_EXAMPLES)
    @given(edge_case())
    def check(case):
        note(repr(case))
        m = run(case)
        check_map(case, m)
        check_model_11(case, m)

    check()


def test_limits_at_the_edges_agree_with_the_limit_just_inside_and_move_continuously():
    """check_limit_moves on maps drawn at the edges (edge_case)."""
    @settings(PROFILE, max_examples=EDGE_EXAMPLES)
    @given(edge_case())
    def check(case):
        note(repr(case))
        check_limit_moves(case, run(case))

    check()


def test_a_graze_of_the_tip_switches_a_vertex_strike_once_between_its_two_events():
    """The long profile's edge draw (2026-11-28): the right finger's rigid sweep at the reach
    edge (3.3 at k2 = l2), theta2_min = -89.999999999 deg. There T grazes the disc and is
    passed by (the finger folds to pi and its tip strikes as the distal closes: VERTEX at
    t1 = pi); 3e-10 deg further T enters and strikes in the rigid sweep (VERTEX at
    t1 = 3.0776). One switch at a threshold of the model, the energy jumping by 0.0175 with
    the same codes; where it struck is part of the outcome (outcome_key)."""
    case = dict(design=Design(l1=1.0, l2=0.7859320939764187, r1=0.2332905239554333,
                              r2=0.2332905239554333, w=0.14720110310995038),
                part=Part(r=1.0, mu=1.0), command=Command(f_left=0.0, f_right=1.0),
                limits=Limits(theta1_min_deg=0.0, theta1_max_deg=180.0,
                              theta2_min_deg=-89.999999999, theta2_max_deg=180.0),
                accuracy=Accuracy(reconfig_step=0.00019352841086427302, root_tol=1e-12,
                                  trajectory="grid8"),
                effects=Effects(friction=True), outputs=Outputs(),
                grid=Grid(h=0.07360055155497519, xlim=(-1.913614340429355, -1.3248099279895535),
                          ylim=(1.2208016546649256, 1.8096060671047272)))
    m = run(case)
    moved = run(moved_limit(case, "theta2_min_deg", 1e-9 / 3.0))
    switched = (outcome_key(m) != outcome_key(moved)).any(axis=0)
    x, y = np.meshgrid(m.x, m.y)
    j, i = np.argwhere(np.isclose(x, -1.6192121342094543) & np.isclose(y, 1.5152038608848264))[0]
    assert switched[j, i]
    assert m.fields["finger_mode"][1, j, i] == moved.fields["finger_mode"][1, j, i] == VERTEX
    assert m.fields["theta1"][1, j, i] == pytest.approx(math.pi, abs=1e-9)
    assert moved.fields["theta1"][1, j, i] < math.pi - 0.01
    check_limit_moves(case, m)


def test_more_friction_never_lowers_the_energy_over_the_accepted_space():
    @PROFILE
    @given(accepted_case())
    def check(case):
        note(repr(case))
        check_friction_monotone(case, run(case))

    check()
