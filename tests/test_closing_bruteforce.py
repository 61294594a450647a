"""Validate the closed forms of MODEL 3 and the closing sequence of MODEL 4 against brute-force
geometry that does not use them: sweep the closing motion finely, find the first angle where the
segment-disc distance of a link falls below r, and classify the contact point.

Also MODEL 3.4 (two-phalanx identity), contact points on the disc, no penetration, the statics of
MODEL 5.1 versus the closed forms of 5.2/5.3, and the energy view of 5.3.
"""
from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import assume, given
from hypothesis import strategies as st
from scipy.optimize import brentq, minimize_scalar

import naive
from naive import (CL_NONE, CL_TANGENT, CL_TIP, EV_DISTAL, EV_NONE, EV_PROXIMAL, EV_VERTEX_B,
                   EV_VERTEX_T, close_distal, distal_tangent_state, g_of_mu, naive_finger,
                   rigid_sweep)
from sweep.model import (DISTAL_ONLY, FREE, PROXIMAL_ONLY, SLIPPED, TWO_PHALANX, VERTEX)

TH2_MIN = math.radians(-5.0)
TH2_MAX = math.radians(90.0)
N_SAMPLES = 4000


# ---------------------------------------------------------------------------------------------
# Brute-force geometry (no closed forms)
# ---------------------------------------------------------------------------------------------
def seg_dist(px, py, ax, ay, bx, by):
    """Distance from (px, py) to segments a-b (arrays) and the closest point's fraction along."""
    abx, aby = bx - ax, by - ay
    den = abx * abx + aby * aby
    s = np.clip(((px - ax) * abx + (py - ay) * aby) / np.where(den == 0, 1, den), 0.0, 1.0)
    return np.hypot(px - (ax + s * abx), py - (ay + s * aby)), s


def finger_geometry(t1, t2, l1, l2):
    t1 = np.asarray(t1, dtype=float)
    t2 = np.broadcast_to(np.asarray(t2, dtype=float), t1.shape)
    bx, by = l1 * np.cos(t1), l1 * np.sin(t1)
    tx, ty = bx + l2 * np.cos(t1 + t2), by + l2 * np.sin(t1 + t2)
    return bx, by, tx, ty


def polyline_contact(dx, dy, t1, t2, l1, l2):
    """(distance, arclength u along J-B-T of the closest point) of the finger to the centre."""
    bx, by, tx, ty = finger_geometry(t1, t2, l1, l2)
    dp, sp = seg_dist(dx, dy, 0.0, 0.0, bx, by)
    dd, sd = seg_dist(dx, dy, bx, by, tx, ty)
    u = np.where(dp <= dd, sp * l1, l1 + sd * l2)
    return np.minimum(dp, dd), u


def first_entry(fun, a, b, n=N_SAMPLES):
    """Smallest x in [a, b] where fun(x) < 0 (fun vectorised), found by dense sampling, a local
    minimisation of every sampled dip (so grazing passes are not missed) and brentq. None if
    fun >= 0 on the whole interval."""
    xs = np.linspace(a, b, n)
    f = fun(xs)
    neg = np.flatnonzero(f < 0)
    end = neg[0] if neg.size else n - 1

    def scalar(x):
        return float(fun(np.array([x]))[0])

    for m in range(1, end):
        if f[m] <= f[m - 1] and f[m] <= f[m + 1] and f[m] < 1e-3:
            res = minimize_scalar(scalar, bounds=(xs[m - 1], xs[m + 1]), method="bounded",
                                  options={"xatol": 1e-13})
            if res.fun < 0:
                return brentq(scalar, xs[m - 1], res.x, xtol=1e-15, rtol=4 * np.finfo(float).eps)
    if not neg.size:
        return None
    i = neg[0]
    if i == 0:
        return xs[0]
    return brentq(scalar, xs[i - 1], xs[i], xtol=1e-15, rtol=4 * np.finfo(float).eps)


def grazing(fun, x, h=1e-7, slope_min=1e-5):
    """True when fun crosses zero at x with a tiny slope (a vertex grazing the disc): there the
    crossing is only determined to about sqrt(machine epsilon)."""
    fp, fm = fun(np.array([x + h, x - h]))
    return abs(fp - fm) / (2 * h) < slope_min


def brute_rigid(dx, dy, l1, l2, r, th2_min):
    """First contact of the rigid sweep: (t1, u) or None."""
    t = first_entry(lambda t1: polyline_contact(dx, dy, t1, th2_min, l1, l2)[0] - r, 0.0,
                    math.pi + 1e-7)
    if t is None or t > math.pi + 1e-9:
        return None
    _, u = polyline_contact(dx, dy, np.array([t]), th2_min, l1, l2)
    return t, float(u[0])


def brute_close_distal(dx, dy, t1, l1, l2, r, th2_min, th2_max, skip_b=0.0):
    """First entry of the distal link as it turns about B with t1 fixed: (t2, s along distal).

    skip_b > 0 ignores the first skip_b of the link (used when B itself lies on the disc)."""
    bx, by = l1 * math.cos(t1), l1 * math.sin(t1)

    def f(t2):
        c, s = np.cos(t1 + t2), np.sin(t1 + t2)
        return seg_dist(dx, dy, bx + skip_b * c, by + skip_b * s, bx + l2 * c, by + l2 * s)[0] - r

    # sweep a little past the upper stop so that a contact exactly at the stop is seen
    t2 = first_entry(f, th2_min, th2_max + 1e-7)
    if t2 is None or t2 > th2_max + 1e-9:
        return None
    _, s = seg_dist(dx, dy, bx, by, bx + l2 * math.cos(t1 + t2), by + l2 * math.sin(t1 + t2))
    return t2, float(s) * l2


def naive_event_u(kind, k, l1, l2):
    return {EV_PROXIMAL: lambda: k, EV_DISTAL: lambda: l1 + k, EV_VERTEX_B: lambda: l1,
            EV_VERTEX_T: lambda: l1 + l2}[kind]()


def check_rigid_sweep(dx, dy, l1, l2, r, th2_min, ang_tol=1e-8, u_tol=1e-6):
    kind, t1, k = rigid_sweep(dx, dy, l1, l2, r, th2_min)
    brute = brute_rigid(dx, dy, l1, l2, r, th2_min)
    if brute is None:
        assert kind == EV_NONE, (kind, t1, k)
        return kind, t1, k
    assert kind != EV_NONE, ("brute force finds a contact", brute)
    tb, ub = brute
    if grazing(lambda t: polyline_contact(dx, dy, t, th2_min, l1, l2)[0] - r, tb):
        ang_tol = max(ang_tol, 1e-6)   # a vertex that only grazes the disc: sqrt(eps) crossing
    assert abs(t1 - tb) <= ang_tol, (kind, t1, k, brute)
    un = naive_event_u(kind, k, l1, l2)
    assert abs(un - ub) <= u_tol, (kind, t1, k, brute)
    # Type: away from the vertices the kind is decided by the contact position.
    if abs(ub - l1) > u_tol and abs(ub - l1 - l2) > u_tol:
        assert kind == (EV_PROXIMAL if ub < l1 else EV_DISTAL), (kind, brute)
    elif abs(ub - l1 - l2) <= u_tol:
        assert kind in (EV_VERTEX_T, EV_DISTAL), (kind, brute)
    else:
        assert kind in (EV_VERTEX_B, EV_PROXIMAL, EV_DISTAL), (kind, brute)
    return kind, t1, k


def check_close_distal(dx, dy, t1, l1, l2, r, th2_min, th2_max, ang_tol=1e-8, s_tol=1e-6):
    closing = close_distal(dx, dy, t1, l1, l2, r, th2_min, th2_max)
    ex, ey = dx - l1 * math.cos(t1), dy - l1 * math.sin(t1)
    b_on_disc = ex * ex + ey * ey <= r * r * (1 + 1e-9)
    if b_on_disc:   # B touches the disc: look at the link beyond B (entry known to ~1e-7/r)
        ang_tol = s_tol = max(ang_tol, 2e-6)
    brute = brute_close_distal(dx, dy, t1, l1, l2, r, th2_min, th2_max,
                               skip_b=1e-7 if b_on_disc else 0.0)
    if brute is None:
        assert closing[0] == CL_NONE, (closing, t1)
        return closing
    t2b, sb = brute
    bx, by = l1 * math.cos(t1), l1 * math.sin(t1)
    if grazing(lambda t2: seg_dist(dx, dy, bx, by, bx + l2 * np.cos(t1 + t2),
                                   by + l2 * np.sin(t1 + t2))[0] - r, t2b):
        ang_tol = max(ang_tol, 1e-6)
    assert closing[0] != CL_NONE, ("brute force finds a distal contact", brute)
    assert abs(closing[1] - t2b) <= ang_tol, (closing, brute)
    if closing[0] == CL_TANGENT:
        assert abs(closing[2] - sb) <= s_tol, (closing, brute)
    else:
        assert abs(sb - l2) <= s_tol, (closing, brute)
    return closing


# ---------------------------------------------------------------------------------------------
# Strategies
# ---------------------------------------------------------------------------------------------
designs = st.fixed_dictionaries({
    "l1": st.floats(0.4, 2.0), "l2": st.floats(0.4, 1.6),
    "r1": st.floats(0.04, 0.2), "r2": st.floats(0.02, 0.18),
    "r": st.floats(0.4, 1.6), "mu": st.floats(0.0, 1.0),
})
limits = st.one_of(
    st.just((TH2_MIN, TH2_MAX)),
    st.tuples(st.floats(-0.6, 0.0), st.floats(0.6, 2.6)),
)


@st.composite
def finger_case(draw):
    """A design and a feasible part centre near the finger's reach (polar about J)."""
    dsg = draw(designs)
    th2_min, th2_max = draw(limits)
    reach = dsg["l1"] + dsg["l2"] + dsg["r"]
    rho = draw(st.floats(dsg["r"], 1.15 * reach))
    ang = draw(st.floats(0.0, math.pi))
    dx, dy = rho * math.cos(ang), rho * math.sin(ang)
    assume(dy >= dsg["r"] + 1e-6)
    return dsg, th2_min, th2_max, dx, dy


# ---------------------------------------------------------------------------------------------
# Rigid sweep (MODEL 3.1, 3.3, vertex formula, M4.2)
# ---------------------------------------------------------------------------------------------
@given(finger_case())
def test_rigid_sweep_matches_bruteforce(case):
    dsg, th2_min, th2_max, dx, dy = case
    check_rigid_sweep(dx, dy, dsg["l1"], dsg["l2"], dsg["r"], th2_min)


@given(finger_case())
def test_distal_closing_matches_bruteforce(case):
    """After a proximal contact (M4.3), and at t1 = pi when the rigid sweep meets nothing."""
    dsg, th2_min, th2_max, dx, dy = case
    l1, l2, r = dsg["l1"], dsg["l2"], dsg["r"]
    kind, t1, k = rigid_sweep(dx, dy, l1, l2, r, th2_min)
    assume(kind in (EV_PROXIMAL, EV_NONE))
    check_close_distal(dx, dy, t1, l1, l2, r, th2_min, th2_max)


def _proximal_contact_cases():
    """Proximal contacts built from (t1, k1) with the part above the palm line."""
    cases = []
    for l1, l2, r in [(2.0, 0.4, 1.6), (1.2, 0.4, 1.2), (0.8, 0.4, 0.8), (2.0, 1.6, 0.4)]:
        for t1 in (0.05, 0.3, 0.6, 0.9, 1.2, 1.6, 2.0, 2.4, 2.8):
            for frac in (0.2, 0.5, 0.8, 1.0):
                k1 = frac * l1
                if k1 * math.sin(t1) + r * math.cos(t1) >= r:
                    cases.append((l1, l2, r, t1, frac))
    return cases


@pytest.mark.parametrize("l1,l2,r,t1,frac", _proximal_contact_cases())
def test_proximal_then_distal_grid(l1, l2, r, t1, frac):
    """A grid of proximal contacts built from (t1, k1): includes short distal links and large
    parts, where the tip can pass through the part (D3 tip_overlap)."""
    k1 = frac * l1
    dx = k1 * math.cos(t1) - r * math.sin(t1)
    dy = k1 * math.sin(t1) + r * math.cos(t1)
    kind, t1n, k1n = check_rigid_sweep(dx, dy, l1, l2, r, TH2_MIN)
    assert kind == EV_PROXIMAL and abs(t1n - t1) < 1e-12 and abs(k1n - k1) < 1e-12
    closing = check_close_distal(dx, dy, t1n, l1, l2, r, TH2_MIN, TH2_MAX)
    res = naive_finger(dx, dy, l1, l2, 0.2, 0.1, r, 0.5, TH2_MIN, TH2_MAX)
    if closing[0] == CL_TIP:
        assert res["mode"] == PROXIMAL_ONLY and res["tip_overlap"]
        k2 = l1 - k1   # D3: only when l2 < k2 <= r
        assert l2 < k2 <= r + 1e-12
    else:
        assert not res["tip_overlap"]


def test_tip_overlap_example():
    """Short distal, large part: the distal tangency (k2 = l1 - k1 = 1) lies beyond the tip, the
    tip enters the disc at 82 deg < theta2_max: PROXIMAL_ONLY with tip_overlap."""
    l1, l2, r, t1, k1 = 2.0, 0.4, 1.6, 0.5, 1.0
    dx = k1 * math.cos(t1) - r * math.sin(t1)
    dy = k1 * math.sin(t1) + r * math.cos(t1)
    closing = check_close_distal(dx, dy, t1, l1, l2, r, TH2_MIN, TH2_MAX)
    assert closing[0] == CL_TIP
    res = naive_finger(dx, dy, l1, l2, 0.2, 0.14, r, 0.4, TH2_MIN, TH2_MAX)
    assert res["mode"] == PROXIMAL_ONLY and res["tip_overlap"]
    assert res["t2"] == TH2_MAX and res["k2"] == 0.0 and abs(res["k1"] - k1) < 1e-12


# ---------------------------------------------------------------------------------------------
# Hand-picked hard cases (MODEL 5.5)
# ---------------------------------------------------------------------------------------------
def test_contact_exactly_at_B():
    """d = (-2, 0.4), l1 = 2, r = 0.4: |d|^2 = l1^2 + r^2, the proximal tangency is at B."""
    dx, dy, l1, l2, r = -2.0, 0.4, 2.0, 1.6, 0.4
    kind, t1, k1 = check_rigid_sweep(dx, dy, l1, l2, r, TH2_MIN)
    assert kind == EV_PROXIMAL
    assert k1 == l1                                   # accepted (inclusive) and clamped
    assert abs(t1 - (math.pi - 2 * math.atan(0.2))) < 1e-14
    closing = close_distal(dx, dy, t1, l1, l2, r, TH2_MIN, TH2_MAX)
    # B is on the disc: tangent length 0, t2 = pi - 2 atan2(r, 0) = 0 (MODEL 3.4).
    assert closing[0] == CL_TANGENT
    assert abs(closing[1]) < 1e-7 and abs(closing[2]) < 1e-7
    # k2 ~ 0: g = -r2 l1 cos t2 < 0 for every mu: case 2, the finger reconfigures.
    res = naive_finger(dx, dy, l1, l2, 0.2, 0.14, r, 0.4, TH2_MIN, TH2_MAX)
    assert res["mode"] in (DISTAL_ONLY, SLIPPED) and res["t1"] < t1 and res["k1"] == 0.0
    check_configuration_geometry(dx, dy, l1, l2, r, res)


def test_contact_at_B_map_is_mirror_symmetric():
    """The point where d = (-2, 0.4) for each finger sits on a w = 0 map at x = -+2, y = r."""
    m = naive.naive_map(2.0, 1.6, 0.2, 0.14, 0.0, 0.4, 0.4, h=0.2, xlim=(-2.6, 2.6),
                        ylim=(0.4, 1.4))
    assert np.array_equal(m["energy"], m["energy"][:, ::-1])
    assert np.array_equal(m["point_class"], m["point_class"][:, ::-1])
    for key in ("finger_mode", "theta1", "theta2", "k1", "k2", "tip_overlap"):
        assert np.array_equal(m[key][0], m[key][1][:, ::-1]), key
    i = int(np.flatnonzero(np.isclose(m["x"], -2.0))[0])
    assert m["y"][0] == 0.4 and m["k1"][1, 0, i] == 0.0       # reconfigured away from B


def test_part_touching_the_joint():
    """|d| == r: d = (0, r). Contact at J (k1 = 0) at t1 = 0; the distal tangency is beyond
    theta2_max (pi - 2 atan(r/l1) > pi/2), so PROXIMAL_ONLY."""
    l1, l2, r = 2.0, 1.6, 0.4
    kind, t1, k1 = rigid_sweep(0.0, r, l1, l2, r, TH2_MIN)
    assert (kind, t1, k1) == (EV_PROXIMAL, 0.0, 0.0)
    # brute force: any t1 > 0 pushes the proximal link into the disc
    d, _ = polyline_contact(0.0, r, np.array([1e-6, 1e-3]), TH2_MIN, l1, l2)
    assert np.all(d < r)
    res = naive_finger(0.0, r, l1, l2, 0.2, 0.14, r, 0.4, TH2_MIN, TH2_MAX)
    assert res["mode"] == PROXIMAL_ONLY and res["t1"] == 0.0 and res["t2"] == TH2_MAX
    assert res["k1"] == 0.0 and not res["tip_overlap"]
    check_close_distal(0.0, r, 0.0, l1, l2, r, TH2_MIN, TH2_MAX)


@pytest.mark.parametrize("dx", [-1.0, 0.0, 0.5, 1.0, 1.999, 2.0, 2.3, 2.5, 3.0, 3.5])
def test_part_on_palm_row(dx):
    """y == r: the part rests on the palm line; contacts at t1 = 0 are allowed."""
    l1, l2, r = 2.0, 1.6, 0.4
    check_rigid_sweep(dx, r, l1, l2, r, TH2_MIN)
    kind, t1, k = rigid_sweep(dx, r, l1, l2, r, TH2_MIN)
    if 0.0 <= dx <= l1:
        assert kind == EV_PROXIMAL and t1 == 0.0 and abs(k - dx) < 1e-12
    res = naive_finger(dx, r, l1, l2, 0.2, 0.14, r, 0.4, TH2_MIN, TH2_MAX)
    check_configuration_geometry(dx, r, l1, l2, r, res)


# ---------------------------------------------------------------------------------------------
# Properties of naive_finger's configurations
# ---------------------------------------------------------------------------------------------
def check_configuration_geometry(dx, dy, l1, l2, r, res, tol=1e-9):
    """Contacts lie on the disc, the touching link is at distance r, nothing penetrates (except a
    flagged tip overlap), and the stored k values follow D6."""
    mode, t1, t2, k1, k2 = res["mode"], res["t1"], res["t2"], res["k1"], res["k2"]
    assert all(math.isfinite(v) for v in (t1, t2, k1, k2))
    a = (math.cos(t1), math.sin(t1))
    b = (math.cos(t1 + t2), math.sin(t1 + t2))
    B = (l1 * a[0], l1 * a[1])
    bx, by, tx, ty = finger_geometry(np.array([t1]), t2, l1, l2)
    dp = seg_dist(dx, dy, 0.0, 0.0, bx, by)[0][0]
    dd = seg_dist(dx, dy, bx, by, tx, ty)[0][0]
    if not res["tip_overlap"]:
        assert dp >= r - tol and dd >= r - tol, (res, dp, dd)
    else:
        assert mode == PROXIMAL_ONLY and dd < r
    if mode in (PROXIMAL_ONLY, TWO_PHALANX):
        c = (k1 * a[0], k1 * a[1])
        assert abs(math.hypot(dx - c[0], dy - c[1]) - r) <= tol
        # the centre sits on the inner normal a_y at distance r
        assert abs((dx - c[0]) * -a[1] + (dy - c[1]) * a[0] - r) <= tol
    if mode in (TWO_PHALANX, DISTAL_ONLY, SLIPPED):
        c = (B[0] + k2 * b[0], B[1] + k2 * b[1])
        assert abs(math.hypot(dx - c[0], dy - c[1]) - r) <= tol
        assert abs((dx - c[0]) * -b[1] + (dy - c[1]) * b[0] - r) <= tol
    if mode == TWO_PHALANX:
        # MODEL 3.4: equal tangent lengths from B and the closed-form joint angle
        assert abs(k2 - (l1 - k1)) <= tol
        assert abs(t2 - (math.pi - 2.0 * math.atan2(r, k2))) <= 1e-7
    if mode == FREE:
        assert (t1, k1, k2) == (math.pi, 0.0, 0.0)
        assert dp > r - tol and dd > r - tol
    if mode == VERTEX:
        assert (k1, k2) in ((l1, 0.0), (0.0, l2))
        v = B if k1 == l1 else (tx[0], ty[0])
        assert abs(math.hypot(dx - v[0], dy - v[1]) - r) <= 1e-7
    if mode in (DISTAL_ONLY, SLIPPED, FREE):
        assert k1 == 0.0
    if mode == PROXIMAL_ONLY:
        assert k2 == 0.0
    if mode == SLIPPED:
        assert abs(k2 - l2) <= 1e-9


@given(finger_case())
def test_finger_configuration_geometry(case):
    dsg, th2_min, th2_max, dx, dy = case
    res = naive_finger(dx, dy, dsg["l1"], dsg["l2"], dsg["r1"], dsg["r2"], dsg["r"], dsg["mu"],
                       th2_min, th2_max)
    assert res["mode"] in (FREE, PROXIMAL_ONLY, TWO_PHALANX, DISTAL_ONLY, SLIPPED, VERTEX)
    # a reconfiguration stop is 3.2 at the bisected t1 (D4): within root_tol * |dt2/dt1|
    assert 0.0 <= res["t1"] <= math.pi
    assert th2_min - 1e-12 <= res["t2"] <= th2_max + 1e-9
    check_configuration_geometry(dx, dy, dsg["l1"], dsg["l2"], dsg["r"], res)


@given(finger_case())
def test_finger_follows_the_closing_sequence(case):
    """naive_finger's mode is consistent with the brute-force first events (M4)."""
    dsg, th2_min, th2_max, dx, dy = case
    l1, l2, r, r1, r2, mu = (dsg[k] for k in ("l1", "l2", "r", "r1", "r2", "mu"))
    kind, t1, k = check_rigid_sweep(dx, dy, l1, l2, r, th2_min)
    res = naive_finger(dx, dy, l1, l2, r1, r2, r, mu, th2_min, th2_max)
    mode = res["mode"]
    if kind == EV_PROXIMAL:
        closing = check_close_distal(dx, dy, t1, l1, l2, r, th2_min, th2_max)
        if closing[0] == CL_TANGENT:
            stable = naive.g_max(closing[1], closing[2], l1, r1, r2, mu) >= 0
            assert stable == (mode == TWO_PHALANX)
            if not stable:
                assert mode in (DISTAL_ONLY, SLIPPED) and res["t1"] <= t1
        else:
            assert mode == PROXIMAL_ONLY and res["tip_overlap"] == (closing[0] == CL_TIP)
            assert (res["t1"], res["k1"], res["t2"]) == (t1, k, th2_max)
    elif kind == EV_DISTAL:
        assert mode in (DISTAL_ONLY, SLIPPED) and res["t1"] <= t1
    elif kind in (EV_VERTEX_B, EV_VERTEX_T):
        assert mode == VERTEX and res["t1"] == t1 and res["t2"] == th2_min
    else:
        closing = check_close_distal(dx, dy, math.pi, l1, l2, r, th2_min, th2_max)
        expected = {CL_NONE: (FREE,), CL_TIP: (VERTEX,),
                    CL_TANGENT: (DISTAL_ONLY, SLIPPED)}[closing[0]]
        assert mode in expected


def test_distal_contact_at_t1_pi():
    """M4.2 'no event before t1 = pi' with a valid 3.2 tangency: needs l2 >~ 23 r (the distal
    wedge left unswept near the palm line), never on the paper's table, but reachable."""
    l1, l2, r = 1.0, 12.0, 0.2
    dx, dy = -1.0 - 8.0, 0.2 + 1e-3
    kind, t1, k = check_rigid_sweep(dx, dy, l1, l2, r, TH2_MIN)
    assert kind == EV_NONE
    closing = check_close_distal(dx, dy, math.pi, l1, l2, r, TH2_MIN, TH2_MAX)
    assert closing[0] == CL_TANGENT and TH2_MIN < closing[1] < 0.0
    res = naive_finger(dx, dy, l1, l2, 0.2, 0.1, r, 0.5, TH2_MIN, TH2_MAX)
    assert res["mode"] in (DISTAL_ONLY, SLIPPED)
    check_configuration_geometry(dx, dy, l1, l2, r, res)


# ---------------------------------------------------------------------------------------------
# Statics: MODEL 5.1 (general statement) versus the closed forms of 5.2 / 5.3
# ---------------------------------------------------------------------------------------------
def cross(u, v):
    return u[0] * v[1] - u[1] * v[0]


@given(finger_case(), st.floats(-1.0, 1.0))
def test_two_phalanx_statics_from_general_statement(case, mu_frac):
    dsg, th2_min, th2_max, dx, dy = case
    l1, l2, r, r1, r2, mu_s = (dsg[k] for k in ("l1", "l2", "r", "r1", "r2", "mu"))
    kind, t1, k1 = rigid_sweep(dx, dy, l1, l2, r, th2_min)
    assume(kind == EV_PROXIMAL)
    closing = close_distal(dx, dy, t1, l1, l2, r, th2_min, th2_max)
    assume(closing[0] == CL_TANGENT)
    _, t2, k2 = closing
    assume(k1 > 1e-3 and k2 > 1e-3)
    mu = mu_frac * mu_s
    F = 1.0
    ax, ay = (math.cos(t1), math.sin(t1)), (-math.sin(t1), math.cos(t1))
    bx_, by_ = (math.cos(t1 + t2), math.sin(t1 + t2)), (-math.sin(t1 + t2), math.cos(t1 + t2))
    B = (l1 * ax[0], l1 * ax[1])
    c1 = (k1 * ax[0], k1 * ax[1])
    c2 = (B[0] + k2 * bx_[0], B[1] + k2 * bx_[1])
    t_dir = (-by_[1], by_[0])                          # rot90(n) for the distal contact
    f2_unit = (by_[0] + mu * t_dir[0], by_[1] + mu * t_dir[1])
    f1_unit = ay                                       # proximal friction has no moment about J
    # unknowns (F1, F2): T2 = (c2 - B) x f2 ; T1 = c1 x f1 + c2 x f2
    A = np.array([[0.0, cross((c2[0] - B[0], c2[1] - B[1]), f2_unit)],
                  [cross(c1, f1_unit), cross(c2, f2_unit)]])
    F1, F2 = np.linalg.solve(A, [F * r2, F * r1])
    # MODEL 5.2
    F2_closed = F * r2 / k2
    F1_closed = (F * r1 - (l1 * math.cos(t2) + k2) * F2_closed
                 + l1 * math.sin(t2) * mu * F2_closed) / k1
    assert F2 == pytest.approx(F2_closed, rel=1e-9, abs=1e-12)
    assert F1 == pytest.approx(F1_closed, rel=1e-7, abs=1e-9)
    assert k1 * k2 * F1 / F == pytest.approx(g_of_mu(mu, t2, k2, l1, r1, r2), rel=1e-7, abs=1e-9)
    assert naive.g_max(t2, k2, l1, r1, r2, mu_s) >= g_of_mu(mu, t2, k2, l1, r1, r2) - 1e-12


@given(finger_case(), st.floats(-1.0, 1.0))
def test_distal_only_statics_from_general_statement(case, mu_frac):
    """M5.3: with the proximal off the part and the distal on its lower stop, the stop torque
    needed is >= 0 iff g(mu) >= 0 (given a positive lever)."""
    dsg, th2_min, th2_max, dx, dy = case
    l1, l2, r, r1, r2, mu_s = (dsg[k] for k in ("l1", "l2", "r", "r1", "r2", "mu"))
    kind, t1, k2 = rigid_sweep(dx, dy, l1, l2, r, th2_min)
    assume(kind == EV_DISTAL and k2 > 1e-3)
    mu, t2, F = mu_frac * mu_s, th2_min, 1.0
    ax = (math.cos(t1), math.sin(t1))
    bx_, by_ = (math.cos(t1 + t2), math.sin(t1 + t2)), (-math.sin(t1 + t2), math.cos(t1 + t2))
    B = (l1 * ax[0], l1 * ax[1])
    c2 = (B[0] + k2 * bx_[0], B[1] + k2 * bx_[1])
    f2_unit = (by_[0] - mu * by_[1], by_[1] + mu * by_[0])
    lever = cross(c2, f2_unit)                        # T1 = F2 * lever
    assert lever == pytest.approx(l1 * math.cos(t2) + k2 - mu * l1 * math.sin(t2), abs=1e-12)
    F2 = F * r1 / lever
    stop_torque = k2 * F2 - F * r2                    # closing torque the lower stop must add
    assert lever > 0
    assert stop_torque == pytest.approx(F * g_of_mu(mu, t2, k2, l1, r1, r2) / lever, abs=1e-12)


def test_reconfiguration_energy_view():
    """M5.3: along the 3.2 path dt2/dt1 = -(k2 + l1 cos t2) / k2 and dV/dt1 = -F g(0) / k2."""
    l1, r, r1, r2, theta2_min, F = 2.0, 0.4, 0.2, 0.14, TH2_MIN, 1.0
    dx, dy = -0.5, 1.5
    for t1 in np.linspace(0.4, 1.4, 11):
        h = 1e-6
        t2p, _ = distal_tangent_state(dx, dy, t1 + h, l1, r)
        t2m, _ = distal_tangent_state(dx, dy, t1 - h, l1, r)
        t2, k2 = distal_tangent_state(dx, dy, t1, l1, r)
        assert (t2p - t2m) / (2 * h) == pytest.approx(-(k2 + l1 * math.cos(t2)) / k2, rel=1e-6)

        def V(a):
            b, _ = distal_tangent_state(dx, dy, a, l1, r)
            return -F * (r1 * a + r2 * (b - theta2_min))
        assert (V(t1 + h) - V(t1 - h)) / (2 * h) == pytest.approx(
            -F * g_of_mu(0.0, t2, k2, l1, r1, r2) / k2, rel=1e-6)


@given(finger_case())
def test_reconfiguration_stop_against_dense_path(case):
    """The D4 stop (step 0.01, bisection) against a dense scan of the same path (step 1e-4):
    same winning event and the same t1 unless an event holds only between two coarse nodes."""
    dsg, th2_min, th2_max, dx, dy = case
    l1, l2, r, r1, r2, mu = (dsg[k] for k in ("l1", "l2", "r", "r1", "r2", "mu"))
    res = naive_finger(dx, dy, l1, l2, r1, r2, r, mu, th2_min, th2_max)
    kind, t1_0, _ = rigid_sweep(dx, dy, l1, l2, r, th2_min)
    assume(res["mode"] in (DISTAL_ONLY, SLIPPED) and res["t1"] < t1_0)
    fine = naive.reconfigure(dx, dy, t1_0, l1, l2, r1, r2, r, mu, th2_max, 1e-4, 1e-12)
    if fine[0] != res["mode"] or abs(fine[1] - res["t1"]) > 1e-9:
        # the coarse stepping may only miss an event that holds on a window < 0.01 rad
        assert fine[1] > res["t1"]
        assert fine[1] - res["t1"] > 1e-9
        pytest.fail(f"coarse stepping missed an event: coarse {res}, fine {fine}")
    # the reported state satisfies its stop condition
    t2, k2 = res["t2"], res["k2"]
    if res["mode"] == SLIPPED:
        assert k2 > l2
    else:
        assert (naive.g_max(t2, k2, l1, r1, r2, mu) >= 0 or t2 >= th2_max - 1e-12
                or res["t1"] == 0.0)


# ---------------------------------------------------------------------------------------------
# Where the reconfiguration path stops (MODEL 5.3, D4, D19): the kernel against the reference
# ---------------------------------------------------------------------------------------------
@st.composite
def path_case(draw):
    """A reconfiguration path (the distal contact sliding toward the tip as t1 falls): a design,
    a part centre and the path's start, random or at the edges: R = 1, no or huge friction,
    theta2_max at 180 deg or a hair above theta2_min, starts on the proximal upper stop, coarse
    steps and tolerances up to what the validation accepts (0.5 rad, 0.1 rad)."""
    dsg, th2_min, th2_max, dx, dy = draw(finger_case())
    l1, l2, r = dsg["l1"], dsg["l2"], dsg["r"]
    r1 = dsg["r1"]
    r2 = draw(st.sampled_from([dsg["r2"], dsg["r2"], r1]))
    mu = draw(st.sampled_from([dsg["mu"], dsg["mu"], 0.0, 1e6]))
    th2_max = draw(st.sampled_from([th2_max, th2_max, math.pi, th2_min + 1e-9]))
    step = draw(st.sampled_from([0.01, 0.5, 1e-3]) | st.floats(1e-3, 0.5))
    root_tol = draw(st.sampled_from([1e-12, 1e-15, 1e-3, 0.1]) | st.floats(1e-15, 0.1))
    kind, t1, _ = rigid_sweep(dx, dy, l1, l2, r, th2_min)
    start = draw(st.sampled_from(["first contact", "pi", "anywhere"]))
    if start == "pi":
        t1 = math.pi
    elif start == "anywhere" or kind == EV_NONE:
        t1 = draw(st.floats(0.0, math.pi))
    return dict(dx=dx, dy=dy, l1=l1, l2=l2, r1=r1, r2=r2, r=r, mu=mu, th2_min=th2_min,
                th2_max=th2_max, t1=t1, step=step, root_tol=root_tol)


@given(path_case())
def test_reconfiguration_stops_where_the_reference_stops(c):
    """The kernel's path (finger.reconfigure, finger_paths.follow_path) against the reference's
    (naive.reconfigure, plain bisection): the same kind of stop (stuck or on a stop, or slipped
    off the tip), at the same t1 to the bracket's width (both report the bracket end where the
    event holds, D4), and the reported state is 3.2 at that t1 and satisfies its stop. A
    change that moves a stop while the maps' end states (or grid values to 1e-9) still agree
    cannot pass."""
    from kernel_calls import reconfig

    ref_mode, ref_t1, _, _ = naive.reconfigure(c["dx"], c["dy"], c["t1"], c["l1"], c["l2"],
                                               c["r1"], c["r2"], c["r"], c["mu"], c["th2_max"],
                                               c["step"], c["root_tol"])
    got = reconfig(c["dx"], c["dy"], c["t1"], c["l1"], c["l2"], c["r1"], c["r2"], c["r"],
                   c["mu"], c["th2_min"], c["th2_max"], c["step"], c["root_tol"])
    assert got.mode == ref_mode, (got, ref_mode, ref_t1)
    # both brackets end where the event holds and are at most root_tol wide (D4, D19)
    assert abs(got.t1 - ref_t1) <= c["root_tol"] + 4e-16, (got, ref_t1)
    t2, k2 = distal_tangent_state(c["dx"], c["dy"], got.t1, c["l1"], c["r"])
    expected_t2 = min(t2, c["th2_max"])
    if got.mode == DISTAL_ONLY:   # 3.2 near B carries round-off: within the lower stop (D30)
        expected_t2 = max(expected_t2, c["th2_min"])
    assert got.t2 == pytest.approx(expected_t2, abs=1e-12)
    assert got.k2 == pytest.approx(k2, abs=1e-12 * (c["l1"] + c["r"]))
    assert got.k1 == 0.0
    # the reported state satisfies its stop (D4: the bracket end where the event holds)
    if got.mode == SLIPPED:
        assert k2 > c["l2"] + naive.RANGE_TOL
    else:
        assert (naive.g_max(t2, k2, c["l1"], c["r1"], c["r2"], c["mu"]) >= 0.0
                or t2 >= c["th2_max"] - naive.RANGE_TOL or got.t1 == 0.0), got
