"""The fast implementation (sweep.compute.maps / sweep.kernels.finger) against the slow reference
(tests/naive.py), plus a few self-checks of the reference itself.

Categorical fields must be equal on every point; floats agree to 1e-9 with NaN in the same places.
"""
from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import assume, given
from hypothesis import strategies as st

import naive
from naive import naive_finger, naive_map
from strategies import paper_table_designs

TH2_MIN = math.radians(-5.0)
TH2_MAX = math.radians(90.0)
TOL = 1e-9

CATEGORICAL = ("point_class", "end_state", "equilibrium", "contained", "finger_mode",
               "tip_overlap")
FLOATS = ("energy", "l_open", "caging_score", "theta1", "theta2", "k1", "k2")
# naive key -> fast attribute name
SCALARS = {"Lambda": "Lambda", "n_caged": "n_caged", "n_tip_prehension": "n_tip_prehension",
           "n_ejection": "n_ejection", "n_stalled": "n_stalled",
           "n_crossed_caged": "n_caged_crossed"}


# ---------------------------------------------------------------------------------------------
# Self-checks of the reference (always run)
# ---------------------------------------------------------------------------------------------
def test_reference_grid_follows_D1():
    m = naive_map(2.0, 1.6, 0.2, 0.14, 0.8, 0.4, 0.4, h=0.1)
    n_x = math.floor((0.4 + 2.0 + 1.6 + 0.4) / 0.1 + 1e-9)
    assert np.array_equal(m["x"], np.array([i * 0.1 for i in range(-n_x, n_x + 1)]))
    assert np.array_equal(m["y"], np.array([0.4 + j * 0.1 for j in range(0, 37)]))
    w = naive_map(2.0, 1.6, 0.2, 0.14, 0.8, 0.4, 0.4, h=0.1, xlim=(-0.55, 1.0), ylim=(1.0, 1.5))
    assert np.array_equal(w["x"], np.array([i * 0.1 for i in range(-5, 11)]))
    assert np.array_equal(w["y"], np.array([0.4 + j * 0.1 for j in range(6, 12)]))
    # the window values are the full map's values
    i0 = int(np.flatnonzero(m["x"] == w["x"][0])[0])
    j0 = 6
    sub = (slice(j0, j0 + len(w["y"])), slice(i0, i0 + len(w["x"])))
    for key in ("energy", "point_class", "equilibrium", "contained", "l_open"):
        assert np.array_equal(w[key], m[key][sub], equal_nan=True), key


@pytest.mark.parametrize("w,h", [(0.0, 0.2), (0.8, 0.2), (0.7, 0.15)])
def test_reference_map_mirror_symmetry(w, h):
    """MODEL 11: a symmetric design under equal commands gives a map symmetric in x (exactly,
    thanks to D1's offsets)."""
    m = naive_map(2.0, 1.6, 0.2, 0.14, w, 0.4, 0.4, h=h)
    for key in ("energy", "point_class", "end_state", "equilibrium", "contained", "l_open",
                "caging_score"):
        assert np.array_equal(m[key], m[key][:, ::-1], equal_nan=True), key
    for key in ("finger_mode", "theta1", "theta2", "k1", "k2", "tip_overlap"):
        assert np.array_equal(m[key][0], m[key][1][:, ::-1], equal_nan=True), key


def test_reference_energy_linear_in_tension():
    """MODEL 11: configurations do not depend on F; energies scale linearly."""
    a = naive_map(1.2, 0.8, 0.16, 0.1, 0.4, 0.8, 0.4, f_left=1.0, f_right=1.0, h=0.2)
    b = naive_map(1.2, 0.8, 0.16, 0.1, 0.4, 0.8, 0.4, f_left=2.5, f_right=2.5, h=0.2)
    assert np.array_equal(a["finger_mode"], b["finger_mode"])
    assert np.array_equal(a["theta1"], b["theta1"], equal_nan=True)
    np.testing.assert_allclose(b["energy"], 2.5 * a["energy"], rtol=1e-12, atol=1e-12)


def test_reference_friction_raises_energy():
    """MODEL 11: raising mu never lowers V at a fixed point."""
    lo = naive_map(2.0, 1.6, 0.2, 0.14, 0.8, 0.4, 0.1, h=0.2)
    hi = naive_map(2.0, 1.6, 0.2, 0.14, 0.8, 0.4, 1.0, h=0.2)
    assert np.all(hi["energy"] >= lo["energy"] - 1e-9)


def test_reference_end_states_and_scores_consistent():
    m = naive_map(2.0, 1.6, 0.2, 0.14, 0.8, 0.4, 0.4, h=0.1)
    pj = m["point_class"] == naive.REACHED
    assert np.all((m["end_state"] != naive.END_NONE) == pj)
    assert (m["n_caged"] + m["n_tip_prehension"] + m["n_ejection"] + m["n_stalled"]
            == np.count_nonzero(pj))
    assert np.all(m["caging_score"][~pj] == 0)
    assert np.all((m["caging_score"] > 0) <= (m["equilibrium"] & m["contained"]))
    assert m["Lambda"] <= m["n_caged"] + 1e-12


# ---------------------------------------------------------------------------------------------
# Fast versus reference
# ---------------------------------------------------------------------------------------------
def fast_map(l1, l2, r1, r2, w, r, mu, f_left=1.0, f_right=1.0, h=0.1, xlim=None, ylim=None,
             step=0.01, root_tol=1e-12):
    from sweep.compute.maps import compute_map
    from sweep.model import Accuracy, Command, Design, Grid, Limits, Part
    return compute_map(Design(l1, l2, r1, r2, w), Part(r, mu), Command(f_left, f_right),
                       Grid(h=h, xlim=xlim, ylim=ylim), Limits(),
                       Accuracy(reconfig_step=step, root_tol=root_tol))


def describe(key, idx, fast_value, ref_value, x, y):
    yx = idx[-2:]
    where = f"{key}{tuple(int(i) for i in idx)} at x={x[yx[1]]!r}, y={y[yx[0]]!r}"
    return f"{where}: fast {fast_value!r}, reference {ref_value!r}"


def assert_maps_equal(fast, ref):
    assert np.array_equal(fast.x, ref["x"]) and np.array_equal(fast.y, ref["y"])
    problems = []
    for key in CATEGORICAL:
        a, b = np.asarray(fast.fields[key]), ref[key]
        assert a.shape == b.shape, key
        for idx in np.argwhere(a != b)[:5]:
            problems.append(describe(key, idx, a[tuple(idx)], b[tuple(idx)], ref["x"], ref["y"]))
    for key in FLOATS:
        a, b = np.asarray(fast.fields[key], dtype=float), ref[key]
        assert a.shape == b.shape, key
        bad = (np.isnan(a) != np.isnan(b)) | (np.abs(np.nan_to_num(a) - np.nan_to_num(b)) > TOL)
        for idx in np.argwhere(bad)[:5]:
            problems.append(describe(key, idx, a[tuple(idx)], b[tuple(idx)], ref["x"], ref["y"]))
    for key, fast_key in SCALARS.items():
        if not abs(fast.attrs[fast_key] - ref[key]) <= TOL * max(1.0, abs(ref[key])):
            problems.append(f"{key}: fast {fast.attrs[fast_key]!r}, reference {ref[key]!r}")
    assert not problems, "\n".join(problems)


MAP_CASES = [
    # l1,  l2,  r1,   r2,   w,   r,   mu,  f_left, f_right, h
    (2.0, 1.6, 0.20, 0.14, 0.8, 0.4, 0.4, 1.0, 1.0, 0.1),     # the reference design
    (2.0, 1.6, 0.20, 0.02, 0.0, 0.4, 0.1, 1.0, 1.0, 0.1),     # R small, w = 0, small part
    (2.0, 1.6, 0.20, 0.18, 2.0, 1.6, 1.0, 1.0, 1.0, 0.1),     # R near 1, w = 2, large part
    (1.2, 0.4, 0.20, 0.02, 2.0, 1.6, 0.1, 1.0, 1.0, 0.1),     # short distal, large part
    (0.8, 1.2, 0.20, 0.18, 0.0, 0.4, 1.0, 1.0, 1.0, 0.1),
    (1.6, 0.8, 0.12, 0.12, 0.4, 0.8, 0.4, 1.0, 1.0, 0.1),     # r1 == r2 (MODEL 5.4)
    (1.2, 0.4, 0.20, 0.20, 0.8, 1.6, 1.0, 1.0, 1.0, 0.1),     # r1 == r2, large part
    (0.4, 0.4, 0.04, 0.02, 2.0, 0.4, 1.0, 1.0, 1.0, 0.1),     # smallest links
    (2.0, 0.4, 0.12, 0.10, 0.0, 1.6, 0.4, 1.0, 1.0, 0.1),     # tip overlap region
    (2.0, 1.6, 0.20, 0.14, 0.8, 0.4, 0.4, 0.6, 1.4, 0.1),     # unequal commands
    (2.0, 1.6, 0.20, 0.14, 0.7, 0.4, 0.4, 1.0, 1.0, 0.15),    # w/2 not a multiple of h
    (2.0, 1.6, 0.16, 0.06, 1.2, 1.2, 0.7, 1.0, 1.0, 0.2),
    (2.0, 1.6, 0.20, 0.14, 0.0, 0.4, 0.4, 1.0, 1.0, 0.05),    # fine grid, contact at B exists
]


@pytest.mark.parametrize("case", MAP_CASES, ids=lambda c: "-".join(f"{v:g}" for v in c))
def test_fast_map_matches_reference(case):
    l1, l2, r1, r2, w, r, mu, f_left, f_right, h = case
    ref = naive_map(l1, l2, r1, r2, w, r, mu, f_left, f_right, h=h)
    fast = fast_map(l1, l2, r1, r2, w, r, mu, f_left, f_right, h=h)
    assert_maps_equal(fast, ref)


# Exact geometric ties on grid points, which round-off would decide; model-notes D3-D5 decide them
# with tolerances instead, and both implementations must then agree bit for bit on the classes.
ROUNDOFF_TIES = [
    # w == l1: a FREE finger's joint B lands exactly on the other finger's base J (x=-3.3, y=1.6):
    # the polylines touch, so L_open = 0 in exact arithmetic too.
    pytest.param((1.2, 0.4, 0.20, 0.20, 1.2, 1.6, 1.0, 1.0, 1.0, 0.1),
                 id="w-equals-l1-free-finger-touch"),
    # part centre exactly on the mouth segment T_L-T_R (x=0.8, y=0.4): on the boundary, so not
    # contained.
    pytest.param((0.4, 0.8, 0.04, 0.02, 1.6, 0.4, 0.1, 1.0, 1.0, 0.2),
                 id="centre-on-mouth-segment"),
    # L_open == 2r exactly at x=+-0.4, y=0.4 (|T_L - T_R| = 0.8): not caged.
    pytest.param((1.6, 0.8, 0.16, 0.10, 0.8, 0.4, 1.0, 0.4, 1.6, 0.1), id="l-open-equals-2r"),
    # the right distal link passes exactly through the left joint B_L (x=-1, y=0.4): the fingers
    # meet at a vertex, L_open = 0.
    pytest.param((1.6, 1.6, 0.08, 0.02, 0.4, 0.4, 0.1, 1.0, 1.0, 0.2),
                 id="crossing-through-a-joint"),
    # the same centre-on-mouth tie under unequal commands
    pytest.param((1.6, 0.8, 0.08, 0.02, 1.6, 0.4, 0.4, 0.4, 1.6, 0.1),
                 id="centre-on-mouth-unequal-commands"),
]


@pytest.mark.parametrize("case", ROUNDOFF_TIES)
def test_fast_map_roundoff_ties(case):
    l1, l2, r1, r2, w, r, mu, f_left, f_right, h = case
    ref = naive_map(l1, l2, r1, r2, w, r, mu, f_left, f_right, h=h)
    fast = fast_map(l1, l2, r1, r2, w, r, mu, f_left, f_right, h=h)
    assert_maps_equal(fast, ref)


@pytest.mark.parametrize("xlim,ylim", [((-1.0, 2.5), (0.4, 2.0)), ((0.35, 3.0), (1.25, 3.0)),
                                       ((-4.0, -1.0), None)])
def test_fast_window_matches_reference(xlim, ylim):
    """User windows (D1): the window edge simply has fewer trajectory candidates."""
    args = (2.0, 1.6, 0.2, 0.14, 0.8, 0.4, 0.4)
    ref = naive_map(*args, h=0.1, xlim=xlim, ylim=ylim)
    fast = fast_map(*args, h=0.1, xlim=xlim, ylim=ylim)
    assert_maps_equal(fast, ref)


# Random designs from the paper's table (integer indices, MODEL 1) on coarse grids.
table_designs = paper_table_designs()


@given(table_designs, st.sampled_from([0.2, 0.25]))
def test_fast_map_matches_reference_random_designs(design, h):
    ref = naive_map(*design, h=h)
    fast = fast_map(*design, h=h)
    assert_maps_equal(fast, ref)


@st.composite
def finger_inputs(draw):
    l1 = draw(st.floats(0.4, 2.0))
    l2 = draw(st.floats(0.4, 1.6))
    r1 = draw(st.floats(0.04, 0.2))
    r2 = draw(st.one_of(st.floats(0.02, 0.18), st.just(r1)))
    r = draw(st.floats(0.4, 1.6))
    mu = draw(st.floats(0.0, 1.0))
    th2_min, th2_max = draw(st.one_of(st.just((TH2_MIN, TH2_MAX)),
                                      st.tuples(st.floats(-0.6, 0.0), st.floats(0.6, 2.6))))
    reach = l1 + l2 + r
    rho = draw(st.floats(r, 1.15 * reach))
    ang = draw(st.floats(0.0, math.pi))
    dx, dy = rho * math.cos(ang), rho * math.sin(ang)
    assume(dy >= r)
    return dx, dy, l1, l2, r1, r2, r, mu, th2_min, th2_max


def assert_finger_equal(args, step=0.01, root_tol=1e-12):
    from kernel_calls import solve as solve_finger
    ref = naive_finger(*args, reconfig_step=step, root_tol=root_tol)
    mode, t1, t2, k1, k2, tip = solve_finger(*args, step, root_tol)
    fast = {"mode": int(mode), "t1": float(t1), "t2": float(t2), "k1": float(k1),
            "k2": float(k2), "tip_overlap": bool(tip)}
    assert fast["mode"] == ref["mode"] and fast["tip_overlap"] == ref["tip_overlap"], (
        args, fast, ref)
    for key in ("t1", "t2", "k1", "k2"):
        assert abs(fast[key] - ref[key]) <= TOL, (args, key, fast, ref)


@given(finger_inputs())
def test_fast_finger_matches_reference(args):
    assert_finger_equal(args)


@pytest.mark.parametrize("args", [
    (-2.0, 0.4, 2.0, 1.6, 0.2, 0.14, 0.4, 0.4, TH2_MIN, TH2_MAX),    # contact exactly at B
    (0.0, 0.4, 2.0, 1.6, 0.2, 0.14, 0.4, 0.4, TH2_MIN, TH2_MAX),     # |d| == r
    (1.0, 0.4, 2.0, 1.6, 0.2, 0.14, 0.4, 0.4, TH2_MIN, TH2_MAX),     # y == r
    (2.0, 0.4, 2.0, 1.6, 0.2, 0.14, 0.4, 0.4, TH2_MIN, TH2_MAX),     # y == r, B on the disc
    (2.5, 0.4, 2.0, 1.6, 0.2, 0.14, 0.4, 0.4, TH2_MIN, TH2_MAX),     # y == r, distal first
    (0.11047, 1.88351, 2.0, 0.4, 0.2, 0.14, 1.6, 0.4, TH2_MIN, TH2_MAX),  # tip overlap
    (-9.0, 0.201, 1.0, 12.0, 0.2, 0.1, 0.2, 0.5, TH2_MIN, TH2_MAX),  # distal contact at t1 = pi
    (-1.0, 1.2, 1.6, 0.8, 0.12, 0.12, 0.8, 0.4, TH2_MIN, TH2_MAX),   # r1 == r2
])
def test_fast_finger_hard_cases(args):
    assert_finger_equal(args)
