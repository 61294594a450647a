"""Cases worked by hand from the formulas of docs/model.md, checked against the kernels."""
import math

import numpy as np
import pytest

from kernel_calls import closing as closing_contact
from kernel_calls import finger_model
from kernel_calls import solve as solve_finger
from sweep.kernels.finger_statics import finger_energy, finger_statics
from sweep.kernels.finger import DISTAL_ON_LOWER_STOP
from sweep.kernels.records import FingerState
from sweep.model import DISTAL_ONLY, FREE, PROXIMAL_ONLY, SLIPPED, TWO_PHALANX, VERTEX

TH2MIN = math.radians(-5.0)
TH2MAX = math.radians(90.0)
STEP, TOL = 0.01, 1e-12


def on_proximal(t1, k1, r):
    """Part centre tangent to the proximal link at distance k1 (MODEL 3.1 read backwards)."""
    return k1 * math.cos(t1) - r * math.sin(t1), k1 * math.sin(t1) + r * math.cos(t1)


def on_distal(t1, t2, k2, l1, r):
    """Part centre tangent to the distal link at distance k2 from B."""
    phi = t1 + t2
    return (l1 * math.cos(t1) + k2 * math.cos(phi) - r * math.sin(phi),
            l1 * math.sin(t1) + k2 * math.sin(phi) + r * math.cos(phi))


def g_max(k2, t2, l1, r1, r2, mu):
    return r1 * k2 - r2 * (l1 * math.cos(t2) + k2) + mu * r2 * l1 * abs(math.sin(t2))


def test_two_phalanx_contact_has_equal_tangents():
    l1, l2, r, t1, k1 = 2.0, 1.6, 0.4, 1.0, 1.7
    dx, dy = on_proximal(t1, k1, r)
    mode, a1, a2, c1, c2, overlap = closing_contact(dx, dy, l1, l2, r, TH2MIN, TH2MAX)
    k2 = l1 - k1  # MODEL 3.4: equal tangent lengths from B
    assert mode == TWO_PHALANX and not overlap
    assert a1 == pytest.approx(t1, abs=1e-12)
    assert c1 == pytest.approx(k1, abs=1e-12)
    assert c2 == pytest.approx(k2, abs=1e-12)
    assert a2 == pytest.approx(math.pi - 2 * math.atan2(r, k2), abs=1e-12)
    # with a strong proximal pulley case 1 holds: the finger stays in two-phalanx contact
    r1, r2, mu = 0.2, 0.02, 0.4
    assert g_max(k2, a2, l1, r1, r2, mu) > 0
    final = solve_finger(dx, dy, l1, l2, r1, r2, r, mu, TH2MIN, TH2MAX, STEP, TOL)
    assert final[0] == TWO_PHALANX
    assert final[1:5] == pytest.approx((a1, a2, c1, c2), abs=1e-15)


def test_two_phalanx_case_2_lifts_off_and_reconfigures():
    l1, l2, r, t1, k1 = 2.0, 1.6, 0.4, 1.0, 1.7
    dx, dy = on_proximal(t1, k1, r)
    r1, r2, mu = 0.04, 0.18, 0.1
    k2 = l1 - k1
    t2 = math.pi - 2 * math.atan2(r, k2)
    assert g_max(k2, t2, l1, r1, r2, mu) < 0  # case 2: F1 < 0 for every admissible mu
    mode, a1, a2, c1, c2, _ = solve_finger(dx, dy, l1, l2, r1, r2, r, mu, TH2MIN, TH2MAX,
                                           STEP, TOL)
    assert mode in (DISTAL_ONLY, SLIPPED)
    assert a1 < t1  # the proximal opened
    assert c1 == 0.0


def test_proximal_only_when_distal_tangency_is_past_its_limit():
    l1, l2, r, t1, k1 = 2.0, 1.6, 0.4, 0.7, 1.0
    dx, dy = on_proximal(t1, k1, r)
    # l1 - k1 = 1.0 > r: the distal tangency would need t2 > 90 deg
    assert math.pi - 2 * math.atan2(r, l1 - k1) > TH2MAX
    mode, a1, a2, c1, c2, overlap = solve_finger(dx, dy, l1, l2, 0.2, 0.1, r, 0.4, TH2MIN,
                                                 TH2MAX, STEP, TOL)
    assert mode == PROXIMAL_ONLY and not overlap
    assert (a1, a2, c1) == pytest.approx((t1, TH2MAX, k1), abs=1e-12)


def test_tip_overlap_flag_for_short_distal_and_large_part():
    # l2 < l1 - k1 <= r: the distal tangency lies beyond the tip, within the limit; the tip
    # enters the part on the way to theta2_max (model-notes D3).
    l1, l2, r, t1, k1 = 2.0, 0.4, 1.6, 0.9, 1.2
    dx, dy = on_proximal(t1, k1, r)
    mode, a1, a2, c1, c2, overlap = solve_finger(dx, dy, l1, l2, 0.2, 0.1, r, 0.4, TH2MIN,
                                                 TH2MAX, STEP, TOL)
    assert mode == PROXIMAL_ONLY and overlap
    assert a2 == TH2MAX


def test_distal_only_contact_that_sticks_on_the_lower_stop():
    l1, l2, r, t1, k2 = 2.0, 1.6, 0.4, 0.8, 0.5
    dx, dy = on_distal(t1, TH2MIN, k2, l1, r)
    assert dx * dx + dy * dy > l1 * l1 + r * r  # no proximal tangency on the link (MODEL 3.1)
    first = closing_contact(dx, dy, l1, l2, r, TH2MIN, TH2MAX)
    assert first[0] == DISTAL_ON_LOWER_STOP
    r1, r2, mu = 0.2, 0.02, 0.4
    assert g_max(k2, TH2MIN, l1, r1, r2, mu) >= 0
    mode, a1, a2, c1, c2, _ = solve_finger(dx, dy, l1, l2, r1, r2, r, mu, TH2MIN, TH2MAX,
                                           STEP, TOL)
    assert mode == DISTAL_ONLY
    assert (a1, a2, c2) == pytest.approx((t1, TH2MIN, k2), abs=1e-12)


@pytest.mark.parametrize("R_num", [0.02, 0.06, 0.1])
def test_frictionless_distal_only_reconfigures_to_the_equilibrium_point(R_num):
    # MODEL 5.3 with mu = 0: the stop is where k2 = R/(1-R) l1 cos t2 (the distal equilibrium
    # position), unless a joint stop or the tip comes first.
    l1, l2, r, t1, k2 = 2.0, 1.6, 0.4, 1.2, 0.1
    r1, r2 = 0.2, R_num
    R = r2 / r1
    dx, dy = on_distal(t1, TH2MIN, k2, l1, r)
    assert g_max(k2, TH2MIN, l1, r1, r2, 0.0) < 0
    mode, a1, a2, c1, c2, _ = solve_finger(dx, dy, l1, l2, r1, r2, r, 0.0, TH2MIN, TH2MAX,
                                           STEP, TOL)
    assert mode == DISTAL_ONLY
    assert 0 < a1 < t1 and TH2MIN < a2 < TH2MAX
    assert c2 == pytest.approx(R / (1 - R) * l1 * math.cos(a2), abs=1e-9)
    # still tangent: the part centre is at distance r from the distal line, contact on the link
    phi = a1 + a2
    bx, by = l1 * math.cos(a1), l1 * math.sin(a1)
    assert (dx - bx) * -math.sin(phi) + (dy - by) * math.cos(phi) == pytest.approx(r, abs=1e-9)
    assert (dx - bx) * math.cos(phi) + (dy - by) * math.sin(phi) == pytest.approx(c2, abs=1e-9)
    # the motion lowered the energy (MODEL 5.3 energy view)
    assert finger_energy(a1, a2, r1, r2, 1.0, TH2MIN) < finger_energy(t1, TH2MIN, r1, r2, 1.0,
                                                                      TH2MIN)


def test_equal_pulley_radii_slide_to_the_tip():
    # MODEL 5.4: with R = 1 the equilibrium point is at infinity: the contact reaches the tip.
    l1, l2, r, t1, k2 = 2.0, 1.6, 0.4, 1.2, 0.3
    dx, dy = on_distal(t1, TH2MIN, k2, l1, r)
    mode, a1, a2, c1, c2, _ = solve_finger(dx, dy, l1, l2, 0.1, 0.1, r, 0.0, TH2MIN, TH2MAX,
                                           STEP, TOL)
    assert mode == SLIPPED
    assert c2 == pytest.approx(l2, abs=1e-9)
    assert all(math.isfinite(v) for v in (a1, a2, c1, c2))


def test_vertex_strike_of_the_distal_joint():
    # B strikes first only if, seen from B, the centre is ahead of the proximal link (angle
    # <= 90 deg from a_x, so the proximal segment misses it) and behind the distal link, which is
    # bent 5 deg outward (angle >= 85 deg from a_x): a narrow wedge. Take 87.5 deg.
    l1, l2, r, t1 = 1.0, 0.4, 0.4, 0.9
    bx, by = l1 * math.cos(t1), l1 * math.sin(t1)
    ang = t1 + math.radians(87.5)
    dx, dy = bx + r * math.cos(ang), by + r * math.sin(ang)
    mode, a1, a2, c1, c2, _ = closing_contact(dx, dy, l1, l2, r, TH2MIN, TH2MAX)
    assert mode == VERTEX
    # B is on the circle at the strike
    assert math.hypot(l1 * math.cos(a1) - dx, l1 * math.sin(a1) - dy) == pytest.approx(r, abs=1e-9)
    assert c1 == l1


def test_free_finger_out_of_reach():
    mode, a1, a2, *_ = solve_finger(10.0, 5.0, 1.0, 1.0, 0.2, 0.1, 0.4, 0.4, TH2MIN, TH2MAX,
                                    STEP, TOL)
    assert mode == FREE and a1 == math.pi and a2 == TH2MAX


def test_contact_at_the_distal_joint_is_decided_by_tolerance_not_round_off():
    # MODEL 5.5: d = (-2.0, 0.4), l1 = 2, r = 0.4: |d|^2 = l1^2 + r^2, contact exactly at B.
    l1, l2, r = 2.0, 1.6, 0.4
    first = closing_contact(-2.0, 0.4, l1, l2, r, TH2MIN, TH2MAX)
    assert first[0] == TWO_PHALANX
    assert first[3] == pytest.approx(l1, abs=1e-12) and first[4] == pytest.approx(0, abs=1e-6)


@pytest.mark.parametrize("mode_args", [
    # (mode, t1, t2, k1, k2)
    (TWO_PHALANX, 1.0, math.pi - 2 * math.atan2(0.4, 0.3), 1.7, 0.3),
    (PROXIMAL_ONLY, 0.7, TH2MAX, 1.0, 0.0),
    (DISTAL_ONLY, 0.8, TH2MIN, 0.0, 0.5),
])
def test_contact_forces_balance_the_joint_torques(mode_args):
    """MODEL 5.1: T2 = sum over distal contacts (c - B) x f, T1 = sum over contacts (c - J) x f."""
    mode, t1, t2, k1, k2 = mode_args
    l1, r1, r2, mu, F = 2.0, 0.2, 0.02, 0.4, 1.3
    # the mode as the kernels hold it (int8): the production path's compiled signature
    st = finger_statics(FingerState(np.int8(mode), t1, t2, k1, k2, False),
                        finger_model(l1, 0.0, r1, r2, 0.4, mu, TH2MIN, TH2MAX))
    assert st.determined
    f1, f2, mu2 = F * st.proximal_normal, F * st.distal_normal, st.distal_multiplier  # linear in F
    assert f1 >= 0 and f2 >= 0 and abs(mu2) <= mu
    ax = np.array([math.cos(t1), math.sin(t1)])
    ay = np.array([-math.sin(t1), math.cos(t1)])
    bxv = np.array([math.cos(t1 + t2), math.sin(t1 + t2)])
    byv = np.array([-math.sin(t1 + t2), math.cos(t1 + t2)])

    def cross(a, b):
        return a[0] * b[1] - a[1] * b[0]

    force_distal = f2 * (byv + mu2 * np.array([-byv[1], byv[0]]))  # n + mu rot90(n)
    force_proximal = f1 * ay
    c1 = k1 * ax
    c2 = l1 * ax + k2 * bxv
    torque_distal = cross(c2 - l1 * ax, force_distal)
    torque_proximal = cross(c1, force_proximal) + cross(c2, force_distal)
    if mode == TWO_PHALANX:  # no joint on a stop: both balances exact
        assert torque_distal == pytest.approx(F * r2, rel=1e-12)
        assert torque_proximal == pytest.approx(F * r1, rel=1e-12)
    elif mode == PROXIMAL_ONLY:  # the distal stop takes T2
        assert torque_proximal == pytest.approx(F * r1, rel=1e-12)
    else:  # distal on its lower stop: the stop adds closing torque (>= 0), proximal exact
        assert torque_proximal == pytest.approx(F * r1, rel=1e-12)
        assert torque_distal >= F * r2 * (1 - 1e-12)


# --- tie rules of model-notes D3, D5 ---------------------------------------------------------
from sweep.kernels.finger_geometry import vertex_entry  # noqa: E402
from sweep.kernels.hand import fingers_cross, mouth_opening, part_contained  # noqa: E402


def test_shared_base_at_zero_palm_width_is_not_a_crossing():
    # w = 0, both fingers upright and apart: the polylines share only the base point.
    left = (0.0, 0.0, -0.5, 1.0, -0.5, 2.0)
    right = (0.0, 0.0, 0.5, 1.0, 0.5, 2.0)
    assert not fingers_cross(left, right)
    assert mouth_opening(left, right, fingers_cross(left, right)) == pytest.approx(1.0)
    # ... but overlapping proximal links are (B_L on the right proximal link)
    right_overlap = (0.0, 0.0, -1.0, 2.0, 0.0, 3.0)
    assert fingers_cross((0.0, 0.0, -0.5, 1.0, -0.5, 2.0), right_overlap)


def test_fingers_meeting_at_a_vertex_intersect():
    # the right distal link passes exactly through the left distal joint B_L = (-1.8, 0)
    left = (-0.2, 0.0, -1.8, 0.0, -1.8, 1.6)
    right = (0.2, 0.0, -1.0, 1.0, -2.6, -1.0)  # B_R=(-1,1), T_R=(-2.6,-1): through (-1.8, 0)
    assert fingers_cross(left, right)
    assert mouth_opening(left, right, fingers_cross(left, right)) == 0.0


def test_centre_on_the_mouth_is_not_contained():
    left = (-0.4, 0.0, -0.4, 1.0, 0.0, 1.0)   # tips meet the mouth line y = 1 ...
    right = (0.4, 0.0, 0.4, 1.0, 0.2, 1.0)
    assert not part_contained(0.1, 1.0, left, right)  # ... centre exactly on T_L-T_R
    assert part_contained(0.1, 0.9, left, right)


def test_a_grazing_vertex_does_not_strike():
    # vertex circle of radius 1 about the origin, disc of radius 0.5 centred at distance 1.5:
    # the vertex touches the disc at one angle only (c = 1)
    assert vertex_entry(1.5, 0.0, 1.0, 0.0, 0.5) == math.inf
    assert vertex_entry(1.4, 0.0, 1.0, 0.0, 0.5) < math.inf


def test_reconfiguration_terminates_for_any_step():
    """The path loop is bounded in floating point and always ends on an event (the last node is
    t1 = 0), even for a step the edge would refuse."""
    from kernel_calls import reconfig
    l1, l2, r, t1, k2 = 2.0, 1.6, 0.4, 1.2, 0.1
    dx, dy = on_distal(t1, TH2MIN, k2, l1, r)
    coarse = reconfig(dx, dy, t1, l1, l2, 0.2, 0.06, r, 0.0, TH2MIN, TH2MAX, 0.01, 1e-12)
    tiny_step = reconfig(dx, dy, t1, l1, l2, 0.2, 0.06, r, 0.0, TH2MIN, TH2MAX, 1e-300, 1e-12)
    assert all(math.isfinite(v) for v in tiny_step[1:])
    assert coarse[0] == DISTAL_ONLY and 0 < coarse[1] < t1
    # a step below float resolution collapses the path to one bracket [0, t1] (the nodes all
    # equal t1 until the last, t1 = 0); the stick region of this path reaches t1 = 0, so the
    # bracket's root finder lands on the same stick boundary as the stepped path. (The first
    # version computed the node count as int64 math.ceil(t1 / 1e-300), which overflowed, skipped
    # the path and reported the proximal stop; NUMBA_DISABLE_JIT=1 showed the difference.)
    assert tiny_step[0] == DISTAL_ONLY
    assert tiny_step[1] == pytest.approx(coarse[1], abs=1e-9)
