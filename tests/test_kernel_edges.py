"""Ties and tolerance edges of the kernels that only mutation testing showed untested (issue P13,
scripts/mutants.py): each test pins one rule at the exact edge where a small change of the code
would otherwise go unnoticed."""
import math

import numpy as np
import pytest

from kernel_calls import closing, solve
from naive import naive_finger
from sweep.kernels.many_maps import pose_radius_sum
from incremental_hull import IncrementalHull
from sweep.model import DISTAL_ONLY, SLIPPED, VERTEX

TH2MIN = math.radians(-5.0)
TH2MAX = math.radians(90.0)
DISTAL_ON_LOWER_STOP = 16  # kernels.finger's internal mode of a rigid-sweep distal tangency


# ---------------------------------------------------------------------------------------------
# hull.py: COINCIDE_REL = 1e-12 exactly (MODEL 10: forces coincide "to 1e-12 relative")
# ---------------------------------------------------------------------------------------------
@pytest.mark.parametrize("inside, coincides", [(5e-13, True), (5e-12, False)])
def test_coincidence_with_a_vertex_is_one_part_in_1e12(inside, coincides):
    """A force `inside` (relative) short of the vertex (1, 1) of a square coincides with it
    below 1e-12 and not above: its geometry's parameters enter the usage or not."""
    params = np.array([[0.0, 0.4, 0.4, 0.04, 0.02], [2.0, 2.0, 1.6, 0.2, 0.18]])
    red = IncrementalHull.empty(1)
    red.add([1.0], [1.0], [True], 0, params[0])
    red.add([1.0 - inside], [1.0 - inside], [True], 1, params[1])
    for g, (x, y) in enumerate([(-1.0, 1.0), (-1.0, -1.0), (1.0, -1.0)]):
        red.add([x], [y], [True], 2 + g, params[0])
    expected = np.ones(5) if coincides else np.zeros(5)    # (upper - lower) / range, or none
    np.testing.assert_allclose(red.parameter_usage(), expected, rtol=1e-12, atol=0)


# ---------------------------------------------------------------------------------------------
# finger.py: a strike of B tied with the distal tangency at B (MODEL 4: the tangency covers
# the link's end, a vertex wins only if strictly earlier)
# ---------------------------------------------------------------------------------------------
TIE = dict(dx=1.0136533953236306, dy=0.44970144356784336, l1=1.0, l2=0.4, r=0.4)


def test_distal_tangent_at_b_is_not_a_vertex_strike():
    """The distal link on its stop, tangent to the disc exactly at B at t1 = 0.05 (the strike
    of B comes 2.6e-16 rad earlier by round-off): the first contact is the distal tangency."""
    t = TIE
    # the point is built so: B at t1 = 0.05, the disc tangent to the distal line there
    bx, by = t["l1"] * math.cos(0.05), t["l1"] * math.sin(0.05)
    phi = 0.05 + TH2MIN
    nx, ny = -math.sin(phi), math.cos(phi)                 # the distal link's inner normal
    assert math.hypot(t["dx"] - (bx + t["r"] * nx), t["dy"] - (by + t["r"] * ny)) < 1e-14
    mode, t1, t2, k1, k2, _ = closing(t["dx"], t["dy"], t["l1"], t["l2"], t["r"], TH2MIN,
                                      TH2MAX)
    assert mode == DISTAL_ON_LOWER_STOP and mode != VERTEX
    assert t1 == pytest.approx(0.05, abs=1e-12) and t2 == TH2MIN and k2 == pytest.approx(0.0,
                                                                                         abs=1e-7)
    # settled: a contact at the distal joint cannot stand (MODEL 5.3): it slides, never VERTEX
    final = solve(t["dx"], t["dy"], t["l1"], t["l2"], 0.2, 0.1, t["r"], 0.4, TH2MIN, TH2MAX,
                  0.01, 1e-12)
    assert final[0] != VERTEX


# ---------------------------------------------------------------------------------------------
# finger_paths.py: events tied exactly go to the first in D4's order (stick, distal stop,
# proximal stop, slip); events that start within one step are bracketed to 1e-12 whatever
# root_tol (D19)
# ---------------------------------------------------------------------------------------------
def test_contact_reaching_the_tip_exactly_at_the_proximal_stop_rests_on_the_stop():
    """R = 1, no friction: the distal contact slides to the tip and reaches it (k2 = l2 +
    1.25e-12, within one bracket of 1e-12 of t1 = 0) exactly as the proximal link reaches its
    stop. Both events start at t1 = 0 exactly: the tie goes to the proximal stop (D4), the
    finger rests on it with the contact at the tip (not SLIPPED)."""
    l1, l2, r, phi = 1.0, 0.6, 0.3, math.radians(30.0)
    k2 = l2 + 1.25e-12
    dx = l1 + k2 * math.cos(phi) - r * math.sin(phi)   # distal tangent at k2 with t1 = 0
    dy = k2 * math.sin(phi) + r * math.cos(phi)
    got = solve(dx, dy, l1, l2, 0.1, 0.1, r, 0.0, TH2MIN, TH2MAX, 0.01, 1e-12)
    ref = naive_finger(dx, dy, l1, l2, 0.1, 0.1, r, 0.0, TH2MIN, TH2MAX, 0.01, 1e-12)
    assert got[0] == ref["mode"] == DISTAL_ONLY
    assert got[1] == ref["t1"] == 0.0 and got[2] == pytest.approx(phi, abs=1e-9)
    assert got[4] == pytest.approx(l2, abs=2e-12)


def test_coarse_root_tolerance_keeps_contacts_on_the_link_and_agrees_with_the_reference():
    """root_tol = 0.1 > reconfig_step: no event is bracketed below its step, except joint stops
    and events that start in the same step (D19). Kernel and reference agree point by point;
    every stuck distal contact lies on the link and on its joint range."""
    l1, l2, r1, r2, r, mu = 2.0, 1.0, 0.2, 0.18, 0.4, 0.1
    step, root_tol = 0.05, 0.1
    reconfigured = 0
    for dx in np.linspace(-2.0, 3.0, 26):
        for dy in np.linspace(0.45, 3.0, 18):
            ref = naive_finger(dx, dy, l1, l2, r1, r2, r, mu, TH2MIN, TH2MAX, step, root_tol)
            got = solve(dx, dy, l1, l2, r1, r2, r, mu, TH2MIN, TH2MAX, step, root_tol)
            assert got[0] == ref["mode"], (dx, dy, got, ref)
            if ref["mode"] in (DISTAL_ONLY, SLIPPED):
                # both bracket to the same width by different methods (D4): within it
                assert got[1] == pytest.approx(ref["t1"], abs=2e-12)
                assert got[2] == pytest.approx(ref["t2"], abs=1e-9)
            if got[0] == DISTAL_ONLY:
                reconfigured += got[1] < math.pi
                assert got[4] <= l2 + 1e-9 and got[2] <= TH2MAX
    assert reconfigured > 20


# ---------------------------------------------------------------------------------------------
# many_maps.py: a pose's value needs three forces, not four (MODEL 10: "0 if fewer than 3 forces")
# ---------------------------------------------------------------------------------------------
def test_three_forces_around_the_origin_give_a_positive_value():
    count = np.array([[3]], dtype=np.int64)
    fx = np.array([[[-1.0, 3.0, -1.0]]])
    fy = np.array([[[-1.0, -1.0, 3.0]]])
    values = np.zeros((1, 1, 1))
    total = pose_radius_sum(count, fx, fy, values, 0)
    assert total == pytest.approx(1.0, rel=1e-14) and values[0, 0, 0] == total  # inradius 1
    count[0, 0] = 2
    assert pose_radius_sum(count, fx, fy, values, 0) == 0.0


# ---------------------------------------------------------------------------------------------
# finger.py: a distal contact with the proximal folded on its stop sticks at g = 0 (MODEL 4.2,
# 5.3: the finger holds where g(mu) >= 0 for some admissible multiplier)
# ---------------------------------------------------------------------------------------------
def test_distal_contact_on_the_proximal_stop_sticks_at_zero_torque_balance():
    """t1 = pi, t2 = 0 (sin t2 = 0: friction cannot help), r1 = 3/4, r2 = 1/4, l1 = 1, k2 = 1/2:
    g = r1 k2 - r2 (l1 cos t2 + k2) = 3/8 - 3/8 = 0 exactly in binary. The contact stands (a
    stuck distal-only state, unchanged); 2^-30 less lever for the tendon (k2 smaller) gives
    g < 0 and the finger moves off it."""
    from kernel_calls import finger_model, solver_settings
    from sweep.kernels.finger import DISTAL_ON_PROXIMAL_STOP, settle
    from sweep.kernels.records import NO_EFFECTS, FingerState

    l1, l2, r1, r2, r = 1.0, 0.8, 0.75, 0.25, 0.4
    finger = finger_model(l1, l2, r1, r2, r, 0.4, TH2MIN, TH2MAX)
    solver = solver_settings(0.01, 1e-12)
    for k2, sticks in ((0.5, True), (0.5 - 2.0 ** -30, False)):
        g = r1 * k2 - r2 * (l1 * math.cos(0.0) + k2)
        assert (g == 0.0) if sticks else (g < 0.0)
        dx, dy = -l1 - k2, -r                      # the disc tangent to the distal link at k2
        first = FingerState(DISTAL_ON_PROXIMAL_STOP, math.pi, 0.0, 0.0, k2, False)
        got = settle(first, dx, dy, finger, solver, NO_EFFECTS)
        stuck = (got.mode, got.t1, got.t2, got.k1, got.k2) == (DISTAL_ONLY, math.pi, 0.0, 0.0, k2)
        assert stuck == sticks, (k2, got)


# ---------------------------------------------------------------------------------------------
# finger_statics.py: a joint within RANGE_TOL of a limit rests on it (MODEL 5.5 inclusive ranges)
# ---------------------------------------------------------------------------------------------
@pytest.mark.parametrize("t2, on_stop", [
    (TH2MIN, True), (TH2MIN + 5e-13, True), (TH2MIN + 1e-9, False),
    (TH2MAX, True), (TH2MAX - 5e-13, True), (TH2MAX - 1e-9, False)])
def test_two_phalanx_forces_with_a_distal_stop_within_the_slack_are_undetermined(t2, on_stop):
    """D9: the forces are determined iff contacts + joints resting on a limit <= 2 (one equation
    per joint). A two-phalanx finger has 2 contacts: its distal joint within RANGE_TOL = 1e-12 of
    a stop counts as resting on it (a third unknown, the stop torque), 1e-9 away it does not."""
    from kernel_calls import finger_model
    from sweep.kernels.finger_statics import finger_statics
    from sweep.kernels.records import FingerState
    from sweep.model import TWO_PHALANX

    finger = finger_model(1.2, 0.8, 0.12, 0.1, 0.4, 0.4, TH2MIN, TH2MAX)
    st = finger_statics(FingerState(np.int8(TWO_PHALANX), 1.0, t2, 0.5, 0.7, False), finger)
    assert st.determined == (not on_stop)


# ---------------------------------------------------------------------------------------------
# hand.py: the palm supports a part whose centre is over its end (MODEL 7: y = r, |x| <= w/2)
# ---------------------------------------------------------------------------------------------
@pytest.mark.parametrize("w", [0.8, 1.2, 0.0])
def test_a_part_over_the_palm_end_touches_the_palm(w):
    from sweep.kernels.hand import touches_palm
    r = 0.4
    for sign in (1.0, -1.0):
        assert touches_palm(sign * 0.5 * w, r, w, r)                 # over the end: inclusive
        assert not touches_palm(sign * (0.5 * w + 1e-6), r, w, r)    # beyond it
    assert not touches_palm(0.0, r + 1e-6, w, r)                      # lifted off the palm


# ---------------------------------------------------------------------------------------------
# outcome.py: either finger overlapping the part makes the point infeasible (MODEL 8: |d| >= r for
# each finger), also in the sliver y in [r - RANGE_TOL, r) that the palm test lets through
# ---------------------------------------------------------------------------------------------
def test_a_part_overlapping_either_finger_base_is_infeasible():
    from sweep.kernels.finger import OVERLAP
    from sweep.kernels.outcome import classify_point
    from sweep.model import INFEASIBLE, REACHED, TWO_PHALANX

    w, r = 0.8, 0.4
    y = r - 5e-13                 # within RANGE_TOL below the palm row: the palm test passes it
    # the part over the right finger's base, x = w/2: finger frames d = (x - w/2, y) = (0, y),
    # |d| < r (1 - TOUCH_REL / 2), and d = (-x - w/2, y) = (-w, y) for the left (MODEL 2)
    right = solve(0.0, y, 1.2, 0.8, 0.12, 0.1, r, 0.4, TH2MIN, TH2MAX, 0.01, 1e-12)
    left = solve(-w, y, 1.2, 0.8, 0.12, 0.1, r, 0.4, TH2MIN, TH2MAX, 0.01, 1e-12)
    assert right[0] == OVERLAP and left[0] != OVERLAP
    assert classify_point(y, r, left[0], right[0]) == INFEASIBLE
    assert classify_point(y, r, right[0], left[0]) == INFEASIBLE        # the mirror point
    assert classify_point(r, r, TWO_PHALANX, TWO_PHALANX) == REACHED


# ---------------------------------------------------------------------------------------------
# streamline.py: the node gradient of a linear energy is exact with any of its differences
# (central inside, one-sided at the grid's edge or beside an infeasible point)
# ---------------------------------------------------------------------------------------------
def test_node_gradient_of_a_linear_energy_is_exact_at_every_node():
    """E = 3 i - 2 j (per grid step, in binary exact numbers): every feasible node's gradient is
    (3, -2), whether its neighbours give central or one-sided differences, so a streamline's
    direction does not turn where the kind of difference changes (MODEL 8 continuous)."""
    from sweep.kernels.streamline import node_gradient
    from sweep.model import INFEASIBLE, REACHED

    ny, nx = 5, 6
    jj, ii = np.mgrid[0:ny, 0:nx]
    energy = 3.0 * ii - 2.0 * jj
    point_class = np.full((ny, nx), REACHED, dtype=np.int8)
    point_class[2, 3] = INFEASIBLE            # its neighbours take one-sided differences
    for j in range(ny):
        for i in range(nx):
            if point_class[j, i] != INFEASIBLE:
                assert node_gradient(energy, point_class, i, j) == (3.0, -2.0), (j, i)
