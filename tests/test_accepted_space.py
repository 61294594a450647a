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

Examples: ACCEPTED_EXAMPLES (default 25, a few seconds with compiled kernels); `make test-long`
(SWEEP_LONG_PROPERTIES=1, tests/profiles.py) runs the long profile (1,000 random examples). The
bounded profile keeps every map within BOUNDED_ROWS grid rows over the reach (below).
"""
from __future__ import annotations

import math
import os

import numpy as np
import pytest
from hypothesis import HealthCheck, Phase, given, note, settings
from hypothesis import strategies as st

from sweep.compute.maps import compute_map
from sweep.model import (
    INFEASIBLE,
    PROXIMAL_ONLY,
    RANGE_TOL,
    REACHED,
    RECONFIG_STEP_RANGE,
    ROOT_TOL_RANGE,
    TWO_PHALANX,
    DISTAL_ONLY,
    Accuracy,
    Command,
    Design,
    Effects,
    Grid,
    Limits,
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
#: Grid rows over the reach in the bounded profile: the palm's half-width is put on the grid
#: only where that keeps the map within them. A palm much narrower than the drawn spacing is on
#: the grid only at h = w / 2, hundreds of rows (one such map of 146 x 469 points cost 6 s, twice,
#: half of make test's time for this module); the long profile draws those.
BOUNDED_ROWS = 30
# The long profile does not shrink a failure (an example costs up to seconds; the failing case
# is printed as drawn, with its note).
PROFILE = settings(max_examples=EXAMPLES, deadline=None, derandomize=not LONG, database=None,
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
    if cmd.f_left == cmd.f_right:
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


def test_physical_invariants_hold_over_the_accepted_space():
    @PROFILE
    @given(accepted_case())
    def check(case):
        note(repr(case))
        m = run(case)
        check_map(case, m)
        check_model_11(case, m)

    check()


def test_more_friction_never_lowers_the_energy_over_the_accepted_space():
    @PROFILE
    @given(accepted_case())
    def check(case):
        note(repr(case))
        check_friction_monotone(case, run(case))

    check()
