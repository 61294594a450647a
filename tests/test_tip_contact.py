"""The `tip_contact` effect (docs/model-notes.md D15): the reference (tests/naive_tip.py) checked
on statics and cases worked by hand, the fast kernel compared with it point by point on whole
maps, and the effect's invariants.

Tolerances (as tests/test_reference.py): categorical fields equal everywhere, floats to 1e-9.
One D15 outcome would not be determined to 1e-9: where the tip path loses the part because the
tip's circle about J stops meeting the disc (MODEL 4's acos argument reaching 1), t1 = angle(d)
- acos(c) - delta at the bracket end with contact has c within ~root_tol of 1, so t1 moves by up
to sqrt(2 root_tol) ~ 1e-6 with where the root finder stops in its last bracket (bisection here,
regula falsi in the kernel). That event never ended a tip path on the 120 table designs sampled
(the pull-off test tau . c_n < 0 always comes first), so the comparison stays at 1e-9; a
mismatch of ~1e-7 in theta1 of a SLIPPED finger would be that, not a bug.

Three issues this comparison found in the first version of D15 and of the kernel are tests here:
`test_every_final_tip_state_is_in_equilibrium` (the stick event accepted a balancing tip force
that pulls; D15 now calls that "lost") and the two grid-point ties
`test_tip_path_meeting_both_stops_at_once_is_decided_by_tolerance`,
`test_frictionless_tip_pinch_centre_on_the_mouth_is_not_contained`.

Random table designs compared on whole maps: 6 in `make test`, 12 in `make test-long`
(SWEEP_LONG_PROPERTIES=1, tests/profiles.py).
"""
from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

import naive
import naive_tip
from profiles import LONG_PROPERTIES
from naive_tip import PROXIMAL_TIP, TIP_ONLY, finger_holds, naive_tip_finger, naive_tip_map
from strategies import paper_table_designs
from sweep.model import (DISTAL_ONLY, END_TIP_PREHENSION, PROXIMAL_ONLY, REACHED, SLIPPED,
                         VERTEX, VERTEX_POINT)

TH2_MIN = math.radians(-5.0)
TH2_MAX = math.radians(90.0)
TOL = 1e-9

CATEGORICAL = ("point_class", "end_state", "equilibrium", "contained", "finger_mode",
               "tip_overlap")
POINT_FLOATS = ("energy", "l_open", "caging_score")
FINGER_FLOATS = ("theta1", "theta2", "k1", "k2")
SCALARS = {"Lambda": "Lambda", "n_caged": "n_caged", "n_tip_prehension": "n_tip_prehension",
           "n_ejection": "n_ejection", "n_stalled": "n_stalled",
           "n_crossed_caged": "n_caged_crossed"}

# the reference design
L1, L2, R1, R2, W = 2.0, 1.6, 0.2, 0.14, 0.8


def _kernel_ready() -> bool:
    from sweep import model
    return "tip_contact" in model.IMPLEMENTED_EFFECTS


needs_kernel = pytest.mark.skipif(not _kernel_ready(),
                                  reason="tip_contact kernel not implemented yet")
IMPLS = ["reference", pytest.param("kernel", marks=needs_kernel)]


# ---------------------------------------------------------------------------------------------
# Calling the kernel and the reference the same way
# ---------------------------------------------------------------------------------------------
def kernel_finger(dx, dy, l1, l2, r1, r2, r, mu, step=0.01, root_tol=1e-12):
    from sweep.kernels.finger import solve_finger
    from sweep.compute.layout import kernel_records
    from sweep.model import Accuracy, Design, Effects, Limits, Part
    finger, solver, effects = kernel_records(
        Design(l1, l2, r1, r2, 0.0), Part(r, mu), Limits(),
        Accuracy(reconfig_step=step, root_tol=root_tol), Effects(tip_contact=True))
    mode, t1, t2, k1, k2, tip = solve_finger(float(dx), float(dy), finger, solver, effects)
    return {"mode": int(mode), "t1": float(t1), "t2": float(t2), "k1": float(k1),
            "k2": float(k2), "tip_overlap": bool(tip)}


def solve(impl, dx, dy, l1, l2, r1, r2, r, mu):
    if impl == "kernel":
        return kernel_finger(dx, dy, l1, l2, r1, r2, r, mu)
    return naive_tip_finger(dx, dy, l1, l2, r1, r2, r, mu, TH2_MIN, TH2_MAX)


def kernel_map(l1, l2, r1, r2, w, r, mu, f_left=1.0, f_right=1.0, h=0.1, xlim=None, ylim=None,
               tip_contact=True):
    from sweep.compute.maps import compute_map
    from sweep.model import Accuracy, Command, Design, Effects, Grid, Limits, Part
    return compute_map(Design(l1, l2, r1, r2, w), Part(r, mu), Command(f_left, f_right),
                       Grid(h=h, xlim=xlim, ylim=ylim), Limits(), Accuracy(),
                       effects=Effects(tip_contact=tip_contact))


def as_ref(fast):
    """compute_map's EnergyMap as the reference's dict (fields, x, y, summaries)."""
    out = {k: np.asarray(v) for k, v in fast.fields.items()}
    out.update(x=fast.x, y=fast.y)
    for key, fast_key in SCALARS.items():
        out[key] = fast.attrs[fast_key]
    return out


#: The reference's maps by their arguments: several tests read the same map (none changes it).
_REFERENCE_MAPS: dict = {}


def reference_map(*args, **kwargs):
    """naive_tip_map, each map computed once per session."""
    key = (args, tuple(sorted(kwargs.items())))
    if key not in _REFERENCE_MAPS:
        _REFERENCE_MAPS[key] = naive_tip_map(*args, **kwargs)
    return _REFERENCE_MAPS[key]


def get_map(impl, *args, **kwargs):
    if impl == "kernel":
        return as_ref(kernel_map(*args, **kwargs))
    return reference_map(*args, **kwargs)


# ---------------------------------------------------------------------------------------------
# Geometry used by the hand-worked cases (written out again here, not taken from naive_tip)
# ---------------------------------------------------------------------------------------------
def joints(t1, t2, l1, l2):
    B = np.array([l1 * math.cos(t1), l1 * math.sin(t1)])
    T = B + l2 * np.array([math.cos(t1 + t2), math.sin(t1 + t2)])
    return B, T


def cross2(u, v) -> float:
    return float(u[0] * v[1] - u[1] * v[0])


def seg_distance(p, a, b):
    ab, ap = b - a, p - a
    s = min(max(float(ap @ ab) / float(ab @ ab), 0.0), 1.0)
    return float(np.hypot(*(ap - s * ab)))


def energy(res, r1, r2):
    """MODEL 6 at unit tension."""
    return -(r1 * res["t1"] + r2 * (res["t2"] - TH2_MIN))


def tip_normal(d, res, l1, l2):
    _, T = joints(res["t1"], res["t2"], l1, l2)
    v = np.asarray(d, dtype=float) - T
    return v / np.hypot(*v)


STOP_TOL = 1e-9   # a reported state within this of a joint limit rests on that stop (a path's
                  # bracket end may lie up to root_tol = 1e-12 inside the range, D4)


def stops_of(res):
    t1, t2 = res["t1"], res["t2"]
    return [name for name, on in (("proximal_lower", abs(t1) <= STOP_TOL),
                                  ("proximal_upper", abs(t1 - math.pi) <= STOP_TOL),
                                  ("distal_lower", abs(t2 - TH2_MIN) <= STOP_TOL),
                                  ("distal_upper", abs(t2 - TH2_MAX) <= STOP_TOL)) if on]


def tip_holds(d, res, l1, l2, r1, r2, mu, extra=()):
    """MODEL 5.1 at a final state with a tip contact (and `extra` contacts), by the LP."""
    B, T = joints(res["t1"], res["t2"], l1, l2)
    contacts = list(extra) + [(tuple(T), tuple(tip_normal(d, res, l1, l2)), True)]
    return finger_holds((r1, r2), contacts, stops_of(res), mu, B=tuple(B))


def tip_gap(d, res, l1, l2, r):
    _, T = joints(res["t1"], res["t2"], l1, l2)
    return abs(float(np.hypot(*(np.asarray(d, dtype=float) - T))) - r)


def entry_angle_about_B(d, t1, l1, l2, r):
    """MODEL 4's vertex formula about B (rho = l2, delta = 0), as t2."""
    B = np.array([l1 * math.cos(t1), l1 * math.sin(t1)])
    e = np.asarray(d, dtype=float) - B
    dist = float(np.hypot(*e))
    c = (l2 * l2 + dist * dist - r * r) / (2.0 * l2 * dist)
    return math.atan2(e[1], e[0]) - math.acos(c) - t1


# ---------------------------------------------------------------------------------------------
# 1. finger_holds on statics worked by hand
# ---------------------------------------------------------------------------------------------
# A distal contact at T = (1, 1) with B = (1, 0) (the distal link vertical, l2 = 1). Its column
# for a force direction e is (T x e, (T - B) x e) = (e_y - e_x, -e_x): a linear map M e. The
# normal n0 = (-r2, r1 - r2)/|.| gives M n0 = (r1, r2)/|.|, exactly proportional to tau.
TAU = (0.2, 0.14)
B_HAND = (1.0, 0.0)
T_HAND = (1.0, 1.0)
N0_ANGLE = math.atan2(TAU[0] - TAU[1], -TAU[1])


def hand_contact(delta):
    a = N0_ANGLE + delta
    return (T_HAND, (math.cos(a), math.sin(a)), True)


def test_holds_single_frictionless_contact_along_tau():
    n0 = hand_contact(0.0)[1]
    col = naive_tip.contact_column(T_HAND, n0, True, B_HAND)
    assert abs(col[0] * TAU[1] - col[1] * TAU[0]) < 1e-15 and col[0] > 0
    assert finger_holds(TAU, [hand_contact(0.0)], [], 0.0, B=B_HAND)
    # rotated slightly either way, a frictionless contact no longer balances both joints
    assert not finger_holds(TAU, [hand_contact(0.01)], [], 0.0, B=B_HAND)
    assert not finger_holds(TAU, [hand_contact(-0.01)], [], 0.0, B=B_HAND)
    # the opposite normal pulls: never
    assert not finger_holds(TAU, [hand_contact(math.pi)], [], 0.5, B=B_HAND)


@pytest.mark.parametrize("mu", [0.1, 0.4, 1.0])
@pytest.mark.parametrize("sign", [1.0, -1.0])
def test_holds_with_friction_up_to_the_cone_angle(mu, sign):
    """M is linear and invertible, so tau = M (sum of cone edges) iff n0 lies in the cone: a
    normal rotated by delta from n0 holds iff |delta| <= atan(mu)."""
    cone = math.atan(mu)
    assert finger_holds(TAU, [hand_contact(sign * (cone - 1e-6))], [], mu, B=B_HAND)
    assert not finger_holds(TAU, [hand_contact(sign * (cone + 1e-6))], [], mu, B=B_HAND)


def test_stops_supply_only_their_sign():
    # stops alone: the closing stops cannot hold a closing tendon, the opening ones can
    assert not finger_holds(TAU, [], ["proximal_lower", "distal_lower"], 0.0)
    assert finger_holds(TAU, [], ["proximal_upper", "distal_upper"], 0.0)
    assert not finger_holds(TAU, [], ["proximal_upper"], 0.0)
    # a contact rotated off tau, plus a stop: the distal lower stop (closing, (0, -1)) helps only
    # when the contact's column leans towards the distal joint (second/first > r2/r1)
    # (M e = (e_y - e_x, -e_x); turning n0 by +0.2 raises the second entry's share)
    lean_distal, lean_proximal = hand_contact(0.2), hand_contact(-0.2)
    for contact, above in ((lean_distal, True), (lean_proximal, False)):
        col = naive_tip.contact_column(contact[0], contact[1], True, B_HAND)
        assert col[0] > 0 and (col[1] / col[0] > TAU[1] / TAU[0]) == above
    assert finger_holds(TAU, [lean_distal], ["distal_lower"], 0.0, B=B_HAND)
    assert not finger_holds(TAU, [lean_proximal], ["distal_lower"], 0.0, B=B_HAND)
    assert not finger_holds(TAU, [lean_distal], ["proximal_lower"], 0.0, B=B_HAND)
    assert finger_holds(TAU, [lean_proximal], ["proximal_lower"], 0.0, B=B_HAND)
    # and the opening stops the other way round
    assert finger_holds(TAU, [lean_proximal], ["distal_upper"], 0.0, B=B_HAND)
    assert finger_holds(TAU, [lean_distal], ["proximal_upper"], 0.0, B=B_HAND)


def test_holds_proximal_contact_column():
    """A proximal edge contact at k1 has the column (k1, 0) for any friction (no moment about
    J from its friction); alone it cannot balance tau2 > 0, with the distal upper stop it can."""
    t1, k1 = 0.7, 0.9
    ax = (math.cos(t1), math.sin(t1))
    prox = ((k1 * ax[0], k1 * ax[1]), (-ax[1], ax[0]), False)
    for mu in (0.0, 0.5):
        cols = naive_tip.holds_columns([prox], [], mu)
        assert all(abs(c[0] - k1) < 1e-15 and c[1] == 0.0 for c in cols)
    assert not finger_holds(TAU, [prox], [], 0.5)
    assert finger_holds(TAU, [prox], ["distal_upper"], 0.0)


@st.composite
def edge_states(draw):
    l1 = draw(st.floats(0.4, 2.0))
    r1 = draw(st.floats(0.04, 0.2))
    r2 = draw(st.floats(0.02, 0.18))
    t1 = draw(st.floats(0.05, 3.0))
    t2 = draw(st.floats(-0.087, 1.57))
    k1 = draw(st.floats(0.01, l1))
    k2 = draw(st.floats(0.0, 1.6))
    mu = draw(st.sampled_from([0.0, 0.1, 0.4, 1.0]))
    return l1, r1, r2, t1, t2, k1, k2, mu


def edge_contacts(l1, t1, t2, k1, k2):
    ax = (math.cos(t1), math.sin(t1))
    bx = (math.cos(t1 + t2), math.sin(t1 + t2))
    B = (l1 * ax[0], l1 * ax[1])
    prox = ((k1 * ax[0], k1 * ax[1]), (-ax[1], ax[0]), False)
    dist = ((B[0] + k2 * bx[0], B[1] + k2 * bx[1]), (-bx[1], bx[0]), True)
    return B, prox, dist


@given(edge_states())
def test_holds_reproduces_the_base_models_closed_forms(state):
    """MODEL 5.2 (two-phalanx: stable iff max g >= 0) and 5.3 revised (distal-only on the lower
    stop: some mu gives g >= 0 and L > 0) are finger_holds with edge contacts."""
    l1, r1, r2, t1, t2, k1, k2, mu = state
    B, prox, dist = edge_contacts(l1, t1, t2, k1, k2)
    gm = naive.g_max(t2, k2, l1, r1, r2, mu)
    assume(abs(gm) > 1e-7 and k2 > 1e-7)
    assert finger_holds((r1, r2), [prox, dist], [], mu, B=B) == (gm >= 0.0)
    lower = naive.lower_stop_admissible(t2, k2, l1, r1, r2, mu)
    assert finger_holds((r1, r2), [dist], ["distal_lower"], mu, B=B) == lower


# ---------------------------------------------------------------------------------------------
# 2. Self-checks of the reference's tip path
# ---------------------------------------------------------------------------------------------
def test_tip_column_at_the_slip_crossing_is_the_edge_column():
    """Where the distal edge contact reaches the tip, n = b_y and D15's tip columns are the
    edge's: c_n = (l1 cos t2 + l2, l2), c_t = (-l1 sin t2, 0), so gtip = gmax at k2 = l2."""
    l1, l2, r, t1, t2 = 2.0, 1.6, 0.4, 1.1, 0.7
    B, T = joints(t1, t2, l1, l2)
    by = np.array([-math.sin(t1 + t2), math.cos(t1 + t2)])
    d = T + r * by                                    # disc tangent to the link at its tip
    c_n, c_t = naive_tip.tip_columns(d[0], d[1], t1, t2, l1, l2)
    assert np.allclose(c_n, (l1 * math.cos(t2) + l2, l2), atol=1e-14)
    assert np.allclose(c_t, (-l1 * math.sin(t2), 0.0), atol=1e-14)
    mu = 0.3
    gtip = naive_tip.cross(TAU, c_n) + mu * abs(naive_tip.cross(TAU, c_t))
    assert gtip == pytest.approx(naive.g_max(t2, l2, l1, TAU[0], TAU[1], mu), abs=1e-14)
    # and the tip path's t2(t1) there is this t2 (the tip is on the disc, entering it)
    assert naive_tip.tip_entry_t2(d[0], d[1], t1, l1, l2, r) == pytest.approx(t2, abs=1e-7)


def test_reference_tip_path_stays_on_the_disc_and_lowers_the_energy():
    """Along the tip path of a case-5 point (t2 rising from the slip, t1(t2) the tip's strike
    about J) the tip stays on the disc, t1(t2) starts at the slip's t1, and V falls while the
    tendon drives the finger along the path (gtip < 0)."""
    dx, dy, r, mu = -1.7 - W / 2, 2.0, 1.6, 0.4
    end = naive_tip_finger(dx, dy, L1, L2, R1, R2, r, mu, TH2_MIN, TH2_MAX)
    slip = naive.naive_finger(dx, dy, L1, L2, R1, R2, r, mu, TH2_MIN, TH2_MAX)
    assert naive_tip.tip_strike_t1(dx, dy, slip["t2"], L1, L2, r) == pytest.approx(slip["t1"],
                                                                                 abs=1e-9)
    v_prev = None
    for t2 in np.linspace(slip["t2"], end["t2"], 12):
        res = {"t1": naive_tip.tip_strike_t1(dx, dy, t2, L1, L2, r), "t2": t2}
        assert tip_gap((dx, dy), res, L1, L2, r) < 1e-12
        v = energy(res, R1, R2)
        assert v_prev is None or v <= v_prev + 1e-15
        v_prev = v


# ---------------------------------------------------------------------------------------------
# 3. Cases worked by hand: switching the effect on changes the answer as the physics says
# ---------------------------------------------------------------------------------------------
def strike_angle_of_rigid_tip(d, l1, l2, r):
    """t1 at which the rigid finger's tip (t2 = theta2_min) first reaches the disc: the tip
    turns about J at rho = |l1 + l2 e^(i theta2_min)|, offset delta from the proximal link;
    law of cosines in the triangle J, T, d: |d - T|^2 = rho^2 + |d|^2 - 2 rho |d| cos(angle)."""
    tip = np.array([l1 + l2 * math.cos(TH2_MIN), l2 * math.sin(TH2_MIN)])
    rho, delta = float(np.hypot(*tip)), math.atan2(tip[1], tip[0])
    dist = float(np.hypot(*d))
    c = (rho * rho + dist * dist - r * r) / (2 * rho * dist)
    return math.atan2(d[1], d[0]) - math.acos(c) - delta


@pytest.mark.parametrize("impl", IMPLS)
def test_hand_a1_vertex_point_where_the_tip_holds_at_the_strike(impl):
    """(a) Reference design, part r = 0.8, mu = 0.4, grid point (x, y) = (-3.9, 0.8): right
    finger d = (-4.3, 0.8). No proximal tangency (k1 = sqrt(19.13 - 0.64) = 4.30 > l1) and no
    valid rigid distal tangency: the rigid tip strikes first (MODEL 4), at
        rho = |2 + 1.6 e^(-5 deg i)| = 3.596616, delta = -0.038782, c = 0.998856,
        t1_T = atan2(0.8, -4.3) - acos(c) - delta = 2.957649 - 0.047848 + 0.038782 = 2.948584.
    Base model: VERTEX. With tip_contact (D15 case 2) the tip is a contact: n = (d - T)/|d - T|
    = (-0.999463, -0.032774), t = rot90(n), and its columns
        c_n = (T x n, (T - B) x n) = (0.940497, 0.492747),
        c_t = (T x t, (T - B) x t) = (3.471471, 1.522235).
    Frictionless, c_n leans to the proximal joint (0.4927/0.9405 = 0.524 < r2/r1 = 0.7) and the
    lower stop can only add closing torque: no hold. With friction the tendon is balanced by
    F (c_n + m c_t) with tau x (c_n + m c_t) = 0:
        m = -(tau x c_n)/(tau x c_t) = -(-0.033117)/(-0.181544) = -0.182421, |m| < 0.4,
    and F > 0 (c_n1 + m c_t1 = 0.307226 > 0): the finger holds at the strike, mode tip,
    t2 = theta2_min, energy that of the strike configuration."""
    r, mu = 0.8, 0.4
    d = (-3.9 - W / 2, 0.8)
    t1_T = strike_angle_of_rigid_tip(d, L1, L2, r)
    assert t1_T == pytest.approx(2.948584, abs=1e-6)
    base = naive.naive_finger(*d, L1, L2, R1, R2, r, mu, TH2_MIN, TH2_MAX)
    assert base["mode"] == VERTEX and base["t1"] == pytest.approx(t1_T, abs=1e-12)

    strike = {"t1": t1_T, "t2": TH2_MIN}
    B, T = joints(t1_T, TH2_MIN, L1, L2)
    n = tip_normal(d, strike, L1, L2)
    t = np.array([-n[1], n[0]])
    c_n = np.array([cross2(T, n), cross2(T - B, n)])
    c_t = np.array([cross2(T, t), cross2(T - B, t)])
    assert np.allclose(c_n, (0.940497, 0.492747), atol=1e-6)
    assert np.allclose(c_t, (3.471471, 1.522235), atol=1e-6)
    m = -cross2(TAU, c_n) / cross2(TAU, c_t)
    assert m == pytest.approx(-0.182421, abs=1e-6) and c_n[0] + m * c_t[0] > 0
    assert tip_holds(d, strike, L1, L2, R1, R2, mu)
    assert not tip_holds(d, strike, L1, L2, R1, R2, 0.0)
    assert not tip_holds(d, strike, L1, L2, R1, R2, 0.18)      # just below |m|
    assert tip_holds(d, strike, L1, L2, R1, R2, 0.183)         # just above

    res = solve(impl, *d, L1, L2, R1, R2, r, mu)
    assert res["mode"] == TIP_ONLY and not res["tip_overlap"]
    assert res["t1"] == pytest.approx(t1_T, abs=1e-9)
    assert res["t2"] == pytest.approx(TH2_MIN, abs=1e-12)
    assert res["k1"] == 0.0 and res["k2"] == pytest.approx(L2, abs=1e-12)
    assert tip_gap(d, res, L1, L2, r) < 1e-9
    assert stops_of(res) == ["distal_lower"] and tip_holds(d, res, L1, L2, R1, R2, mu)
    assert energy(res, R1, R2) == pytest.approx(energy(base, R1, R2), abs=1e-9)

    # frictionless, the same strike does not hold: the tip path takes the finger on, lower
    frictionless = solve(impl, *d, L1, L2, R1, R2, r, 0.0)
    assert frictionless["mode"] != VERTEX
    assert energy(frictionless, R1, R2) < energy(res, R1, R2)


@pytest.mark.parametrize("impl", IMPLS)
def test_hand_a2_vertex_point_resolved_by_the_tip_path(impl):
    """(a) Reference design, r = 0.8, mu = 0.4, grid point (4.4, 0.8): d = (4.0, 0.8). The rigid
    tip strikes at t1_T = 0.069408 (formula above): base VERTEX. With tip_contact the tip at
    the strike cannot hold (its normal leans towards the proximal joint, the lower stop can only
    add closing torque), so the finger follows the tip path: the distal closes (t2 rises) and the
    proximal opens (t1 falls) to keep the tip on the disc, the tendon driving it along the path
    (gtip < 0, tau . c_n > 0) until t1 reaches the proximal lower stop, t1 = 0. There B = (2, 0),
    e = d - B = (2.0, 0.8), |e|^2 = 4.64, and t2 is the tip's entry angle about B:
        t2 = atan2(0.8, 2.0) - acos((1.6^2 + 4.64 - 0.8^2) / (2 * 1.6 * sqrt(4.64)))
           = 0.380506 - 0.312107 = 0.068399.
    The energy falls from V(strike) = -0.2 * 0.069408 = -0.013882 to
    V = -0.14 * (0.068399 + 0.087266) = -0.021793."""
    r, mu = 0.8, 0.4
    d = (4.0, 0.8)
    t1_T = strike_angle_of_rigid_tip(d, L1, L2, r)
    assert t1_T == pytest.approx(0.069408, abs=1e-6)
    base = naive.naive_finger(*d, L1, L2, R1, R2, r, mu, TH2_MIN, TH2_MAX)
    assert base["mode"] == VERTEX and base["t1"] == pytest.approx(t1_T, abs=1e-12)
    strike = {"t1": t1_T, "t2": TH2_MIN}
    assert not tip_holds(d, strike, L1, L2, R1, R2, mu)

    t2_hand = math.atan2(0.8, 2.0) - math.acos((1.6 ** 2 + 4.64 - 0.8 ** 2)
                                               / (2 * 1.6 * math.sqrt(4.64)))
    assert t2_hand == pytest.approx(0.068399, abs=1e-6)
    res = solve(impl, *d, L1, L2, R1, R2, r, mu)
    assert res["mode"] == TIP_ONLY and not res["tip_overlap"]
    assert res["t1"] == pytest.approx(0.0, abs=1e-12)
    assert res["t2"] == pytest.approx(t2_hand, abs=1e-9)
    assert tip_gap(d, res, L1, L2, r) < 1e-9
    assert stops_of(res) == ["proximal_lower"] and tip_holds(d, res, L1, L2, R1, R2, mu)
    assert energy(res, R1, R2) == pytest.approx(-0.021793, abs=1e-6)
    assert energy(res, R1, R2) < energy(strike, R1, R2) == pytest.approx(-0.013882, abs=1e-6)


@pytest.mark.parametrize("impl", IMPLS)
def test_hand_b_tip_overlap_point_stops_where_the_tip_meets_the_disc(impl):
    """(b) Design l1 = 1.2, l2 = 0.4, r1 = 0.2, r2 = 0.02, w = 0; part r = 1.2, mu = 0.4; grid
    point (0, 1.3) (h = 0.1): d = (0, 1.3) for both fingers.
    Proximal tangency (3.1): k1 = sqrt(1.69 - 1.44) = 0.5, t1 = pi/2 - atan2(1.2, 0.5)
    = 0.394791, cos t1 = 12/13, sin t1 = 5/13, B = (1.107692, 0.461538). Closing the distal
    about B: the tangent length from B is sqrt(|e|^2 - r^2) = 0.7 > l2 = 0.4 (= l1 - k1, 3.4), so
    no distal tangency on the link: base PROXIMAL_ONLY with t2 = theta2_max and the distal link
    through the disc (tip_overlap). With tip_contact (case 4) the tip meets the disc at
        e = d - B = (-1.107692, 0.838462), |e| = sqrt(1.93) = 1.389244,
        t2 = atan2(e) - acos((0.16 + 1.93 - 1.44) / (2 * 0.4 * 1.389244)) - t1
           = 2.493188 - 0.945627 - 0.394791 = 1.152770 < theta2_max,
    and the finger holds there (proximal contact (k1, 0) + the tip; tau = (0.2, 0.02)): mode
    proximal_tip, and the distal link no longer enters the disc."""
    l1, l2, r1, r2, r, mu = 1.2, 0.4, 0.2, 0.02, 1.2, 0.4
    d = (0.0, 1.3)
    t1_hand = math.pi / 2 - math.atan2(1.2, 0.5)
    assert math.cos(t1_hand) == pytest.approx(12 / 13, abs=1e-15)
    t2_hand = entry_angle_about_B(d, t1_hand, l1, l2, r)
    e = np.array(d) - np.array([1.2 * 12 / 13, 1.2 * 5 / 13])
    assert float(e @ e) == pytest.approx(1.93, abs=1e-12)
    assert t2_hand == pytest.approx(1.152770, abs=1e-6) and t2_hand < TH2_MAX

    base = naive.naive_finger(*d, l1, l2, r1, r2, r, mu, TH2_MIN, TH2_MAX)
    assert base["mode"] == PROXIMAL_ONLY and base["tip_overlap"]
    Bb, Tb = joints(base["t1"], base["t2"], l1, l2)
    assert seg_distance(np.array(d), Bb, Tb) < r - 0.1           # the base distal is inside

    res = solve(impl, *d, l1, l2, r1, r2, r, mu)
    assert res["mode"] == PROXIMAL_TIP and not res["tip_overlap"]
    assert res["t1"] == pytest.approx(t1_hand, abs=1e-12)
    assert res["k1"] == pytest.approx(0.5, abs=1e-12) and res["k2"] == pytest.approx(l2)
    assert res["t2"] == pytest.approx(t2_hand, abs=1e-9)
    assert tip_gap(d, res, l1, l2, r) < 1e-9
    B, T = joints(res["t1"], res["t2"], l1, l2)
    assert seg_distance(np.array(d), B, T) >= r - 1e-9           # no longer through the disc
    ax = (math.cos(res["t1"]), math.sin(res["t1"]))
    prox = ((0.5 * ax[0], 0.5 * ax[1]), (-ax[1], ax[0]), False)
    assert tip_holds(d, res, l1, l2, r1, r2, mu, extra=[prox])
    assert energy(res, r1, r2) > energy(base, r1, r2)             # the distal closes less

    # on the map: the point is REACHED, nobody flags tip_overlap
    m = get_map(impl, l1, l2, r1, r2, 0.0, r, mu, h=0.1, xlim=(0.0, 0.0), ylim=(1.3, 1.3))
    assert m["point_class"][0, 0] == REACHED
    assert list(m["finger_mode"][:, 0, 0]) == [PROXIMAL_TIP, PROXIMAL_TIP]
    assert not m["tip_overlap"].any()


@pytest.mark.parametrize("impl", IMPLS)
def test_hand_c_slipped_point_becomes_a_tip_contact(impl):
    """(c) Reference design, part r = 1.6, mu = 0.4, grid point (-1.7, 2.0): d = (-2.1, 2.0).
    Base: the rigid sweep's first contact is distal-only, it cannot stand, and the
    reconfiguration slides the contact to the tip: SLIPPED where k2 = l2, i.e.
    |e|^2 = l2^2 + r^2 = 5.12:  |d|^2 + l1^2 - 2 l1 |d| cos(alpha - t1) = 5.12,
        t1_s = alpha - acos((8.41 + 4 - 5.12) / (2 * 2 * 2.9)) = 2.380863 - 0.891523 = 1.489340.
    With tip_contact (case 5) the tip takes over there and the tip path runs on to smaller t1;
    the contact sticks where the tendon's torque is on the edge of the tip's friction cone
    (gtip = 0: the multiplier needed is exactly -mu_s or +mu_s), at t1 = 1.480673 < t1_s."""
    r, mu = 1.6, 0.4
    d = (-1.7 - W / 2, 2.0)
    dist = math.hypot(*d)
    t1_s = math.atan2(d[1], d[0]) - math.acos((dist ** 2 + L1 ** 2 - L2 ** 2 - r ** 2)
                                              / (2 * L1 * dist))
    assert t1_s == pytest.approx(1.489340, abs=1e-6)
    base = naive.naive_finger(*d, L1, L2, R1, R2, r, mu, TH2_MIN, TH2_MAX)
    assert base["mode"] == SLIPPED and base["t1"] == pytest.approx(t1_s, abs=1e-9)

    res = solve(impl, *d, L1, L2, R1, R2, r, mu)
    assert res["mode"] == TIP_ONLY and not res["tip_overlap"]
    assert res["k1"] == 0.0 and res["k2"] == pytest.approx(L2)
    assert res["t1"] == pytest.approx(1.480673, abs=1e-6) and res["t1"] < t1_s
    assert res["t2"] == pytest.approx(entry_angle_about_B(d, res["t1"], L1, L2, r), abs=1e-9)
    assert tip_gap(d, res, L1, L2, r) < 1e-9
    assert stops_of(res) == [] and tip_holds(d, res, L1, L2, R1, R2, mu)
    # the multiplier that balances the tendon: tau x (c_n + m c_t) = 0
    B, T = joints(res["t1"], res["t2"], L1, L2)
    n = tip_normal(d, res, L1, L2)
    t = np.array([-n[1], n[0]])
    c_n = np.array([cross2(T, n), cross2(T - B, n)])
    c_t = np.array([cross2(T, t), cross2(T - B, t)])
    m = -cross2(TAU, c_n) / cross2(TAU, c_t)
    assert abs(m) == pytest.approx(mu, abs=1e-9)
    assert energy(res, R1, R2) < energy(base, R1, R2)

    m_tip = get_map(impl, L1, L2, R1, R2, W, r, mu, h=0.1, xlim=(-1.7, -1.7), ylim=(2.0, 2.0))
    assert m_tip["point_class"][0, 0] == REACHED and m_tip["finger_mode"][1, 0, 0] == TIP_ONLY


# ---------------------------------------------------------------------------------------------
# 4. Kernel versus reference on whole maps
# ---------------------------------------------------------------------------------------------
def _describe(key, idx, a, b, x, y):
    yx = idx[-2:]
    return (f"{key}{tuple(int(i) for i in idx)} at x={x[yx[1]]!r}, y={y[yx[0]]!r}: "
            f"kernel {a!r}, reference {b!r}")


def map_problems(fast, ref, max_each=5):
    """Differences between two maps given as the reference's dicts."""
    problems = []
    assert np.array_equal(fast["x"], ref["x"]) and np.array_equal(fast["y"], ref["y"])
    for key in CATEGORICAL:
        a, b = np.asarray(fast[key]), ref[key]
        assert a.shape == b.shape, key
        for idx in np.argwhere(a != b)[:max_each]:
            problems.append(_describe(key, idx, a[tuple(idx)], b[tuple(idx)], ref["x"],
                                      ref["y"]))
    for key in POINT_FLOATS + FINGER_FLOATS:
        a, b = np.asarray(fast[key], dtype=float), ref[key]
        bad = (np.isnan(a) != np.isnan(b)) | (np.abs(np.nan_to_num(a) - np.nan_to_num(b)) > TOL)
        for idx in np.argwhere(bad)[:max_each]:
            problems.append(_describe(key, idx, a[tuple(idx)], b[tuple(idx)], ref["x"],
                                      ref["y"]))
    for key in SCALARS:
        if not abs(fast[key] - ref[key]) <= TOL * max(1.0, abs(ref[key])):
            problems.append(f"{key}: kernel {fast[key]!r}, reference {ref[key]!r}")
    return problems


MAP_CASES = [
    # l1,  l2,  r1,   r2,   w,   r,   mu,  h
    (2.0, 1.6, 0.20, 0.14, 0.8, 1.6, 0.4, 0.2),    # reference design, large part: all 5 cases
    (2.0, 1.6, 0.20, 0.14, 0.8, 0.4, 0.1, 0.1),    # small part, long fingers
    (2.0, 0.4, 0.12, 0.10, 0.0, 1.6, 1.0, 0.2),    # short distal, large part: tip_overlap (case 4)
    (1.2, 0.4, 0.20, 0.02, 2.0, 1.2, 1.0, 0.2),    # proximal_tip holds
    (0.6, 1.6, 0.08, 0.06, 0.8, 0.8, 0.0, 0.2),    # frictionless: tip path stops between stops
    (1.0, 0.8, 0.16, 0.10, 0.4, 0.8, 1.0, 0.2),    # high friction: tip path sticks
    (1.6, 0.8, 0.12, 0.12, 0.4, 1.2, 0.1, 0.2),    # r1 == r2: every reconfiguration reaches the tip
]


@needs_kernel
@pytest.mark.parametrize("case", MAP_CASES, ids=lambda c: "-".join(f"{v:g}" for v in c))
def test_kernel_map_matches_reference(case):
    *args, h = case
    ref = reference_map(*args, h=h)
    fast = as_ref(kernel_map(*args, h=h))
    problems = map_problems(fast, ref)
    assert not problems, "\n".join(problems)
    # the maps do exercise the effect
    modes = ref["finger_mode"]
    assert np.count_nonzero((modes == TIP_ONLY) | (modes == PROXIMAL_TIP)) > 0


@needs_kernel
def test_kernel_map_unequal_commands_and_odd_palm_matches_reference():
    args = (2.0, 1.6, 0.16, 0.06, 0.7, 1.2, 0.7)
    ref = naive_tip_map(*args, f_left=0.6, f_right=1.4, h=0.15)
    fast = as_ref(kernel_map(*args, f_left=0.6, f_right=1.4, h=0.15))
    problems = map_problems(fast, ref)
    assert not problems, "\n".join(problems)


# Random designs from the paper's table (integer indices, MODEL 1) on coarse grids.
table_designs = paper_table_designs(mu=st.sampled_from([0.0, 0.1, 0.4, 1.0]))


@needs_kernel
@settings(max_examples=12 if LONG_PROPERTIES else 6)
@given(table_designs)
def test_kernel_map_matches_reference_random_designs(design):
    ref = naive_tip_map(*design, h=0.25)
    fast = as_ref(kernel_map(*design, h=0.25))
    problems = map_problems(fast, ref)
    assert not problems, "\n".join(problems)


@pytest.mark.parametrize("impl", IMPLS)
@pytest.mark.parametrize("design", [(2.0, 0.4, 0.12, 0.10, 1.6, 1.0),
                                    (2.0, 1.6, 0.20, 0.14, 1.6, 0.4),
                                    (0.8, 0.8, 0.04, 0.14, 0.8, 0.0),
                                    (1.2, 0.8, 0.20, 0.10, 0.8, 0.1)])
def test_tip_path_meeting_both_stops_at_once_is_decided_by_tolerance(impl, design):
    """A grid-point tie (right finger at x = w/2 + l1, y = l2 + r): d = (l1, l2 + r), so the
    finger flat on the palm (t1 = 0) with the distal upright (t2 = 90 deg) has its tip at the
    disc's lowest point. The reconfiguration slides the distal contact to the tip and the tip
    path (t2 rising) ends exactly at that corner: near it t1(t2) = O((theta2_max - t2)^2) >= 0,
    touching the proximal stop only at theta2_max. So in exact arithmetic the path never leaves
    [0, pi] before theta2_max and ends on the distal stop at (0, theta2_max); a proximal-stop test
    t1 < 0 without the model's slack (D2: ranges inclusive by 1e-12) lets round-off
    (t1 ~ -1e-16) end it a few 1e-8 earlier in t2."""
    l1, l2, r1, r2, r, mu = design
    d = (l1, l2 + r)
    t2 = TH2_MAX - 1e-4
    assert 0 < naive_tip.tip_strike_t1(*d, t2, l1, l2, r) < 1e-7
    res = solve(impl, *d, l1, l2, r1, r2, r, mu)
    assert res["mode"] == TIP_ONLY
    assert res["t1"] == pytest.approx(0.0, abs=1e-12)
    assert res["t2"] == pytest.approx(TH2_MAX, abs=1e-11)


#: Straight fingers (theta2_min = 0) whose tip strikes the part with the distal on its lower stop
#: (D15 case 2), from random draws (l1, l2, r1, r2, r, mu, d and reconfig_step as
#: `tip_finger_inputs`): (dx, dy, l1, l2, r1, r2, r, mu, reconfig_step).
STRAIGHT_STRIKES = {
    # the kernel's hold test at the strike said the tip holds (parallel columns, below)
    "strike-a": (1.6002579966516164, 1.9063592126734437, 0.4978565528211391, 1.2596923108936773,
                 0.15556381091133728, 0.16324860454782192, 0.8231072870562676, 1.0, 0.05),
    "strike-b": (-0.00599271113066258, 2.0372122268871595, 0.5914118033916532,
                 0.4555998440364209, 0.17114771955114058, 0.13202349162426677,
                 1.0990261989392918, 1.0, 0.2),
    # the strike does not hold in the kernel either: the tip path starts and is lost at once,
    # where the stick-within-the-last-step rule's guard decides (D15 "Within one step")
    "path-start": (-3.652883100107087, 1.420132766065952, 1.5155793130765929,
                   1.1743090067299191, 0.14171837718005634, 0.06577910645505673,
                   1.3878556396308885, 1.0, 0.01),
}


@needs_kernel
@pytest.mark.parametrize("case", list(STRAIGHT_STRIKES.values()), ids=list(STRAIGHT_STRIKES))
def test_a_straight_fingers_tip_that_cannot_hold_at_its_strike_is_lost_there(case):
    """A straight finger's tip on the disc with the distal on its lower stop t2 = 0: the tip's
    columns (T x e, (T - B) x e) of both friction-cone edges e = n +- mu t are multiples of D =
    (l1 + l2, l2) (T = (l1 + l2) u, T - B = l2 u); here of opposite signs, so the tip supplies
    any multiple of D, and the lower stop only a closing torque lambda >= 0 in the distal joint
    (a stop pushes). tau = (r1, r2) balances iff tau1 D2 - tau2 D1 >= 0 (lambda = that / D1):
    worked out here, < 0, so the tip does not hold at the strike (MODEL 5.1), and on the tip
    path just beyond it (t2 = 1e-6, 1e-3) the tendon is balanced only by a pulling tip (gtip >=
    0, normal force < 0, the statics of naive_tip): lost at once, SLIPPED where it struck
    (t2 = 0). Checked: the kernel's hold test accepting the meeting point of two constraint
    lines parallel but for round-off (it held the tip, TIP_ONLY, in "strike-a" and "strike-b":
    32 of 3,945 random straight-finger draws disagreed with the reference so) and the stick rule
    without its guard at the path's start (TIP_ONLY at t2 = 0 in "path-start") each fail
    here."""
    dx, dy, l1, l2, r1, r2, r, mu, step = case
    t1 = naive_tip.tip_strike_t1(dx, dy, 0.0, l1, l2, r)
    (tip, n, _), joint = naive_tip.tip_contact(dx, dy, t1, 0.0, l1, l2)
    u, t = (math.cos(t1), math.sin(t1)), naive_tip.rot90(n)
    edges = [(n[0] + s * mu * t[0], n[1] + s * mu * t[1]) for s in (1.0, -1.0)]
    moments = [naive_tip.cross(u, e) for e in edges]
    assert moments[0] * moments[1] < 0
    for e, moment in zip(edges, moments):
        column = naive_tip.contact_column(tip, e, True, joint)
        assert column == pytest.approx((moment * (l1 + l2), moment * l2), abs=1e-12)
    assert r1 * l2 - r2 * (l1 + l2) < 0
    for t2 in (1e-6, 1e-3):
        a = naive_tip.tip_strike_t1(dx, dy, t2, l1, l2, r)
        c_n, c_t = naive_tip.tip_columns(dx, dy, a, t2, l1, l2)
        gtip = naive_tip.cross((r1, r2), c_n) + mu * abs(naive_tip.cross((r1, r2), c_t))
        assert gtip >= 0.0 and naive_tip.normal_force((r1, r2), c_n, c_t) < 0.0, t2
    from sweep.kernels.finger import solve_finger
    from sweep.kernels.records import NO_EFFECTS, TipContact
    from kernel_calls import finger_model, solver_settings

    got = solve_finger(dx, dy, finger_model(l1, l2, r1, r2, r, mu, 0.0, TH2_MAX),
                       solver_settings(step, 1e-12),
                       NO_EFFECTS._replace(tip_contact=TipContact(True)))
    assert (got.mode, got.t2) == (SLIPPED, 0.0)
    assert got.t1 == pytest.approx(t1, abs=1e-12)
    ref = naive_tip_finger(dx, dy, l1, l2, r1, r2, r, mu, 0.0, TH2_MAX, step, 1e-12)
    assert (ref["mode"], ref["t2"]) == (SLIPPED, 0.0)


@pytest.mark.parametrize("impl", IMPLS)
def test_frictionless_tip_pinch_centre_on_the_mouth_is_not_contained(impl):
    """A grid-point tie worked by hand: design l1 = 1.8, l2 = 1.2, r1 = 0.08, r2 = 0.18, w = 0;
    part r = 1.2, mu = 0; grid point (0, 1.8), d = (0, 1.8) for both fingers. Each finger ends
    on its tip path's distal stop, t2 = 90 deg, where the tip's strike about J gives
        rho = |1.8 + 1.2 i| = 2.163331, delta = atan2(1.2, 1.8) = 0.588003,
        c = (rho^2 + 1.8^2 - 1.2^2) / (2 rho 1.8) = 0.832050 = cos(delta),
        t1 = pi/2 - acos(c) - delta = pi/2 - 2 delta = 0.394791   (cos t1 = 12/13),
    so B = (1.661538, 0.692308), T = B + 1.2 (-5/13, 12/13) = (1.2, 1.8): the tips are the disc's
    left and right extremes and press horizontally. Two antipodal frictionless contacts: the
    part is in equilibrium (cone-edge gap exactly pi). The centre lies on the mouth segment
    T_L T_R, so it is not contained (D5: within 1e-12 of the boundary): TIP PREHENSION, score
    0. (Reporting the distal stop 1e-12 before theta2_max lifts the tips by 1.2e-12 and turns
    the tie into `contained`, i.e. CAGED, by the last bits.)"""
    l1, l2, r1, r2, w, r, mu = 1.8, 1.2, 0.08, 0.18, 0.0, 1.2, 0.0
    t1_hand = math.pi / 2 - 2 * math.atan2(1.2, 1.8)
    assert math.cos(t1_hand) == pytest.approx(12 / 13, abs=1e-15)
    _, T = joints(t1_hand, TH2_MAX, l1, l2)
    assert np.allclose(T, (1.2, 1.8), atol=1e-15)
    m = get_map(impl, l1, l2, r1, r2, w, r, mu, h=0.2, xlim=(0.0, 0.0), ylim=(1.8, 1.8))
    assert list(m["finger_mode"][:, 0, 0]) == [TIP_ONLY, TIP_ONLY]
    assert np.allclose(m["theta1"][:, 0, 0], t1_hand, atol=1e-9)
    assert np.allclose(m["theta2"][:, 0, 0], TH2_MAX, atol=1e-9)
    assert m["point_class"][0, 0] == REACHED and m["equilibrium"][0, 0]
    assert not m["contained"][0, 0]
    assert m["end_state"][0, 0] == END_TIP_PREHENSION and m["caging_score"][0, 0] == 0.0


@st.composite
def tip_finger_inputs(draw):
    l1 = draw(st.floats(0.4, 2.0))
    l2 = draw(st.floats(0.4, 1.6))
    r1 = draw(st.floats(0.04, 0.2))
    r2 = draw(st.one_of(st.floats(0.02, 0.18), st.just(r1)))
    r = draw(st.floats(0.4, 1.6))
    mu = draw(st.sampled_from([0.0, 0.1, 0.4, 1.0]))
    reach = l1 + l2 + r
    rho = draw(st.floats(r, 1.05 * reach))
    ang = draw(st.floats(0.0, math.pi))
    dx, dy = rho * math.cos(ang), rho * math.sin(ang)
    assume(dy >= r)
    return dx, dy, l1, l2, r1, r2, r, mu


@needs_kernel
@given(tip_finger_inputs())
def test_kernel_finger_matches_reference(args):
    ref = naive_tip_finger(*args, TH2_MIN, TH2_MAX)
    fast = kernel_finger(*args)
    assert fast["mode"] == ref["mode"] and fast["tip_overlap"] == ref["tip_overlap"], (
        args, fast, ref)
    for key in ("t1", "t2", "k1", "k2"):
        assert abs(fast[key] - ref[key]) <= TOL, (args, key, fast, ref)


# ---------------------------------------------------------------------------------------------
# 5. Invariants under tip_contact (on the kernel's maps; on the reference's without the kernel)
# ---------------------------------------------------------------------------------------------
def finger_d(m, fi, jj, ii, w):
    """d of finger fi at grid point (jj, ii) in its own frame (general offsets, MODEL 2)."""
    x, y = m["x"][ii], m["y"][jj]
    return (x - w / 2.0, y) if fi == 1 else (-x - w / 2.0, y)


def tip_balance(d, res, l1, l2, r1, r2):
    """tau = a c_n + b c_t for the tip at a final state: (a, b, gtip_without_mu). a is the
    tip's normal force per unit tension that would balance the tendon (MODEL 5.1 needs a >= 0
    and |b| <= mu_s a between stops); a = (tau x c_t) / (c_n x c_t)."""
    B, T = joints(res["t1"], res["t2"], l1, l2)
    n = tip_normal(d, res, l1, l2)
    t = np.array([-n[1], n[0]])
    c_n = np.array([cross2(T, n), cross2(T - B, n)])
    c_t = np.array([cross2(T, t), cross2(T - B, t)])
    det = cross2(c_n, c_t)
    tau = (r1, r2)
    return cross2(tau, c_t) / det, cross2(c_n, tau) / det, c_n, c_t


def tip_states_checked(m, l1, l2, r1, r2, w, r, mu):
    """Every final tip / proximal_tip state of a map: the tip on the disc, and MODEL 5.1:
    states on a stop (and proximal_tip) hold with their stops. Between stops a tip state ends
    D15's stick event (gtip = tau x c_n + mu_s |tau x c_t| >= 0); returns those that do not hold
    by MODEL 5.1 with the balancing normal force a, for the caller to judge."""
    not_holding = []
    n_tip = 0
    for fi, jj, ii in np.argwhere((m["finger_mode"] == TIP_ONLY)
                                  | (m["finger_mode"] == PROXIMAL_TIP)):
        res = {k: float(m[f][fi, jj, ii]) for k, f in (("t1", "theta1"), ("t2", "theta2"),
                                                      ("k1", "k1"))}
        d = finger_d(m, fi, jj, ii, w)
        where = (fi, jj, ii, d, res)
        assert tip_gap(d, res, l1, l2, r) < 1e-9, where
        n_tip += 1
        extra = []
        if m["finger_mode"][fi, jj, ii] == PROXIMAL_TIP:
            ax = (math.cos(res["t1"]), math.sin(res["t1"]))
            extra = [((res["k1"] * ax[0], res["k1"] * ax[1]), (-ax[1], ax[0]), False)]
        if tip_holds(d, res, l1, l2, r1, r2, mu, extra=extra):
            continue
        assert not extra and not stops_of(res), where          # only the stick event remains
        a, b, c_n, c_t = tip_balance(d, res, l1, l2, r1, r2)
        gtip = cross2((r1, r2), c_n) + mu * abs(cross2((r1, r2), c_t))
        assert gtip >= -1e-9, where
        not_holding.append((where, a, b))
    return n_tip, not_holding


# The first D15 stick event tested gtip = tau x c_n + mu_s |tau x c_t| >= 0 only. At its crossing
# tau is parallel to a cone edge c_n +- mu_s c_t, but nothing asked that it points the same way:
# on many tip paths the crossing has tau = a c_n + b c_t with a < 0 (the tip would have to pull
# on the part; the pull-off test tau . c_n < 0 had not fired, the joint-space friction cone being
# wide), so the final `tip` state was not in equilibrium by MODEL 5.1 (95% of the stick endings
# of 100 random table designs). Worked point: design 2.0/0.4/0.12/0.10, r = 1.6, mu = 0.4,
# d = (3.4, 1.6) (left finger of grid point (-3.4, 1.6), w = 0): case 2, tip path, crossing at
# t1 = 0.194495, t2 = 1.218462 with a = -0.2441, b = +0.0976 = -mu a. D15 now: stick needs a
# >= 0; where only a pulling tip balances the tendon, the part is lost.


@pytest.mark.parametrize("impl", IMPLS)
def test_no_vertex_no_overlap_and_every_tip_state_is_on_the_disc(impl):
    """D15: VERTEX and tip_overlap never occur; every final tip / proximal_tip state has the tip
    on the disc and holds by MODEL 5.1 (with its stops)."""
    l1, l2, r1, r2, w, r, mu = 2.0, 0.4, 0.12, 0.10, 0.0, 1.6, 0.4
    m = get_map(impl, l1, l2, r1, r2, w, r, mu, h=0.2)
    assert not (m["point_class"] == VERTEX_POINT).any()
    assert not (m["finger_mode"] == VERTEX).any() and not m["tip_overlap"].any()
    n_tip, not_holding = tip_states_checked(m, l1, l2, r1, r2, w, r, mu)
    assert n_tip > 100
    assert not not_holding


STICK_PULLS_POINT = ((2.0, 0.4, 0.12, 0.10, 1.6, 0.4), (3.4, 1.6))


@pytest.mark.parametrize("impl", IMPLS)
def test_a_tip_that_would_have_to_pull_loses_the_part(impl):
    """The worked point of the first D15's stick issue: case 2 (the rigid tip strike does not
    hold), tip path, where gtip reaches 0 with tau = a c_n + b c_t, a < 0, b = -mu a: tau is
    antiparallel to the cone edge c_n - mu c_t, not inside the cone, so no pushing tip holds the
    finger and the part is lost there (SLIPPED, where the tip last touched)."""
    (l1, l2, r1, r2, r, mu), d = STICK_PULLS_POINT
    res = solve(impl, *d, l1, l2, r1, r2, r, mu)
    assert res["mode"] == SLIPPED and not stops_of(res)
    assert (res["t1"], res["t2"]) == (pytest.approx(0.194495, abs=1e-6),
                                      pytest.approx(1.218462, abs=1e-6))
    a, b, c_n, c_t = tip_balance(d, res, l1, l2, r1, r2)
    assert a == pytest.approx(-0.244074, abs=1e-6) and b == pytest.approx(-mu * a, abs=1e-9)
    tau = (r1, r2)
    assert cross2(tau, c_n) + mu * abs(cross2(tau, c_t)) == pytest.approx(0.0, abs=1e-9)
    assert tau[0] * c_n[0] + tau[1] * c_n[1] > 0.01          # D15's pull-off test has not fired


@pytest.mark.parametrize("impl", IMPLS)
def test_every_final_tip_state_is_in_equilibrium(impl):
    """No `tip` state claims an equilibrium MODEL 5.1 does not give (the first D15 did, at
    STICK_PULLS_POINT): every tip state of a random sample of fingers holds."""
    (l1, l2, r1, r2, r, mu), _ = STICK_PULLS_POINT
    rng = np.random.default_rng(7)
    n_tip = 0
    for _ in range(400):
        d = (rng.uniform(-4.0, 4.0), rng.uniform(r, 4.0))
        if math.hypot(*d) < r:
            continue
        res = solve(impl, *d, l1, l2, r1, r2, r, mu)
        if res["mode"] == TIP_ONLY:
            n_tip += 1
            assert tip_holds(d, res, l1, l2, r1, r2, mu), (d, res)
    assert n_tip > 20


@pytest.mark.parametrize("impl", IMPLS)
def test_tip_contact_map_mirror_symmetry(impl):
    m = get_map(impl, 2.0, 1.6, 0.2, 0.14, 0.8, 1.2, 0.4, h=0.2)
    for key in ("energy", "point_class", "end_state", "equilibrium", "contained", "l_open",
                "caging_score"):
        assert np.array_equal(m[key], m[key][:, ::-1], equal_nan=True), key
    for key in ("finger_mode", "theta1", "theta2", "k1", "k2", "tip_overlap"):
        assert np.array_equal(m[key][0], m[key][1][:, ::-1], equal_nan=True), key


@pytest.mark.parametrize("impl", IMPLS)
def test_more_friction_never_lowers_the_energy_with_tip_contact(impl):
    """MODEL 11: with the tip's cone wider, every hold decision and the stick event of the tip
    path come no later, and V only falls along the paths."""
    args = (0.6, 1.6, 0.08, 0.06, 0.8, 0.8)
    maps = [get_map(impl, *args, mu, h=0.2) for mu in (0.0, 0.1, 0.4, 1.0)]
    for lo, hi in zip(maps, maps[1:]):
        assert np.array_equal(np.isnan(lo["energy"]), np.isnan(hi["energy"]))
        ok = np.isnan(lo["energy"]) | (hi["energy"] >= lo["energy"] - 1e-9)
        assert ok.all(), np.argwhere(~ok)[:5]


@pytest.mark.parametrize("impl", IMPLS)
def test_frictionless_tip_states_between_stops_are_stationary_on_the_tip_path(impl):
    """mu_s = 0: a final tip state that rests on no stop is where the tendon's generalised force
    is along the constraint normal (tau x c_n = 0), i.e. a constrained stationary point (here a
    minimum) of V along the tip path (checked by differences along t2(t1))."""
    l1, l2, r1, r2, w, r = 0.6, 1.6, 0.08, 0.06, 0.8, 0.8
    m = get_map(impl, l1, l2, r1, r2, w, r, 0.0, h=0.2)
    checked = 0
    for fi, jj, ii in np.argwhere(m["finger_mode"] == TIP_ONLY):
        res = {"t1": float(m["theta1"][fi, jj, ii]), "t2": float(m["theta2"][fi, jj, ii])}
        if stops_of(res) or res["t1"] < 1e-9 or res["t2"] > TH2_MAX - 1e-9:
            continue
        d = finger_d(m, fi, jj, ii, w)
        B, T = joints(res["t1"], res["t2"], l1, l2)
        n = tip_normal(d, res, l1, l2)
        c_n = np.array([cross2(T, n), cross2(T - B, n)])
        assert abs(cross2((r1, r2), c_n)) <= 1e-9, (fi, jj, ii)

        def v_along(t2, d=d):
            return energy({"t1": naive_tip.tip_strike_t1(*d, t2, l1, l2, r), "t2": t2}, r1, r2)

        dt = 1e-5
        v0, vp, vm = v_along(res["t2"]), v_along(res["t2"] + dt), v_along(res["t2"] - dt)
        assert abs(vp - vm) / (2 * dt) <= 1e-6
        assert vp >= v0 - 1e-13 and vm >= v0 - 1e-13
        checked += 1
    assert checked >= 8


@needs_kernel
def test_kernel_mode_codes():
    from sweep import model
    assert (model.TIP_ONLY, model.PROXIMAL_TIP) == (TIP_ONLY, PROXIMAL_TIP)


@needs_kernel
def test_effect_off_equals_the_base_reference():
    args = (2.0, 1.6, 0.20, 0.14, 0.8, 1.6, 0.4)
    ref = naive.naive_map(*args, h=0.2)
    fast = as_ref(kernel_map(*args, h=0.2, tip_contact=False))
    # the base model is compared to 1e-9 everywhere (its SLIPPED state is well conditioned)
    problems = []
    for key in CATEGORICAL:
        if not np.array_equal(fast[key], ref[key]):
            problems.append(key)
    for key in POINT_FLOATS + FINGER_FLOATS:
        a, b = np.asarray(fast[key], dtype=float), ref[key]
        if not (np.array_equal(np.isnan(a), np.isnan(b))
                and np.nanmax(np.abs(a - b)) <= TOL):
            problems.append(key)
    assert not problems, problems
    assert (ref["point_class"] == VERTEX_POINT).any()
    assert abs(fast["Lambda"] - ref["Lambda"]) <= TOL * max(1.0, ref["Lambda"])


def test_switching_the_effect_on_only_changes_vertex_overlap_and_slipped_fingers():
    """The reference with the effect on differs from the base reference only where the base
    finger is VERTEX, flagged tip_overlap or SLIPPED (D15: only what follows a vertex event
    changes)."""
    args = (2.0, 0.4, 0.12, 0.10, 0.0, 1.6, 0.4)
    base = naive.naive_map(*args, h=0.2)
    tip = reference_map(*args, h=0.2)
    touched = ((base["finger_mode"] == VERTEX) | base["tip_overlap"]
               | (base["finger_mode"] == SLIPPED))
    assert touched.any()
    for key in ("finger_mode", "theta1", "theta2", "k1", "k2"):
        same = np.isclose(base[key], tip[key], rtol=0, atol=0, equal_nan=True)
        assert same[~touched].all(), key
    assert set(np.unique(tip["finger_mode"][touched])) <= {DISTAL_ONLY, SLIPPED, TIP_ONLY,
                                                          PROXIMAL_TIP}
