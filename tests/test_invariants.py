"""MODEL 11 invariants, fast-path identities and hard inputs."""
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from sweep.compute.batch import SUMMARY_FIELDS, summarize_cells
from kernel_calls import solve as solve_finger
from sweep.kernels.finger_statics import finger_energy
from sweep.kernels.finger_geometry import distal_tangency
from sweep.compute.maps import compute_map
from sweep.model import (DISTAL_ONLY, END_CAGED, END_TIP_PREHENSION, INFEASIBLE, PROXIMAL_ONLY,
                         REACHED, TWO_PHALANX, Accuracy, Command, Design, Grid, Limits, Part)

TH2MIN = math.radians(-5.0)
TH2MAX = math.radians(90.0)

MAPS = [
    (Design(2.0, 1.6, 0.2, 0.14, 0.8), Part(0.4, 0.4)),
    (Design(0.8, 0.4, 0.04, 0.02, 0.0), Part(1.6, 1.0)),
    (Design(1.4, 1.2, 0.2, 0.18, 2.0), Part(0.8, 0.1)),
]


@pytest.fixture(scope="module", params=range(len(MAPS)), ids=["ref", "small-big-part", "R~1"])
def energy_map(request):
    design, part = MAPS[request.param]
    return compute_map(design, part, grid=Grid(h=0.1))


def test_mirror_symmetry(energy_map):
    f = energy_map.fields
    assert np.array_equal(energy_map.x, -energy_map.x[::-1])
    for name in ("energy", "point_class", "equilibrium", "contained", "l_open", "caging_score"):
        assert np.array_equal(f[name], f[name][:, ::-1], equal_nan=True), name
    for name in ("finger_mode", "theta1", "theta2", "k1", "k2", "tip_overlap"):
        assert np.array_equal(f[name][0], f[name][1][:, ::-1], equal_nan=True), name


def test_nan_only_at_infeasible_points(energy_map):
    f = energy_map.fields
    infeasible = f["point_class"] == INFEASIBLE
    for name in ("energy", "l_open", "caging_score"):
        assert np.array_equal(np.isnan(f[name]), infeasible & np.isnan(f[name]))
        assert not np.isnan(f[name][~infeasible]).any()
    for name in ("theta1", "theta2", "k1", "k2"):
        assert not np.isnan(f[name][:, ~infeasible]).any()
        assert np.isinf(f[name][:, ~infeasible]).sum() == 0


def test_contact_geometry_on_every_reached_point(energy_map):
    """k2 = l1 - k1 in two-phalanx contact; every contact lies on the disc, links tangent."""
    d, p = energy_map.design, energy_map.part
    f = energy_map.fields
    X, Y = np.meshgrid(energy_map.x, energy_map.y)
    checked = 0
    for side, sign in ((0, -1.0), (1, 1.0)):
        mode = f["finger_mode"][side]
        dx = sign * X - 0.5 * d.w
        dy = Y
        t1, t2, k1, k2 = (f[n][side] for n in ("theta1", "theta2", "k1", "k2"))
        two = mode == TWO_PHALANX
        assert np.allclose(k2[two], d.l1 - k1[two], atol=1e-9)
        prox = (mode == TWO_PHALANX) | (mode == PROXIMAL_ONLY)
        cx, cy = k1 * np.cos(t1), k1 * np.sin(t1)
        dist = np.hypot(dx - cx, dy - cy)
        assert np.allclose(dist[prox], p.r, atol=1e-9)
        dist_line = -(dx - cx) * np.sin(t1) + (dy - cy) * np.cos(t1)
        assert np.allclose(dist_line[prox], p.r, atol=1e-9)
        dist_ok = (mode == TWO_PHALANX) | (mode == DISTAL_ONLY)
        phi = t1 + t2
        bx, by = d.l1 * np.cos(t1), d.l1 * np.sin(t1)
        ex, ey = dx - bx - k2 * np.cos(phi), dy - by - k2 * np.sin(phi)
        assert np.allclose(np.hypot(ex, ey)[dist_ok], p.r, atol=1e-9)
        assert np.all((k2[dist_ok] >= -1e-12) & (k2[dist_ok] <= d.l2 + 1e-9))
        checked += prox.sum() + dist_ok.sum()
    assert checked > 0


def test_configurations_do_not_depend_on_tension_and_energy_scales():
    design, part = MAPS[0]
    a = compute_map(design, part, Command(1.0, 1.0), Grid(h=0.1))
    b = compute_map(design, part, Command(2.5, 2.5), Grid(h=0.1))
    for name in ("finger_mode", "theta1", "theta2", "k1", "k2", "point_class", "equilibrium"):
        assert np.array_equal(a.fields[name], b.fields[name], equal_nan=True), name
    assert np.allclose(b.fields["energy"], 2.5 * a.fields["energy"], rtol=1e-12, equal_nan=True)


def test_more_friction_never_lowers_energy_nor_removes_equilibrium():
    design = Design(1.4, 1.2, 0.12, 0.1, 0.8)
    maps = [compute_map(design, Part(0.8, mu), grid=Grid(h=0.1)) for mu in (0.1, 0.4, 1.0)]
    for lo, hi in zip(maps, maps[1:]):
        feasible = lo.fields["point_class"] != INFEASIBLE
        # V at a fixed point never lowered by more friction (MODEL 11)
        assert np.all(hi.fields["energy"][feasible] >= lo.fields["energy"][feasible] - 1e-12)
        same_config = ((lo.fields["finger_mode"] == hi.fields["finger_mode"]).all(axis=0)
                       & np.isclose(lo.fields["theta1"], hi.fields["theta1"], atol=1e-12).all(0)
                       & np.isclose(lo.fields["theta2"], hi.fields["theta2"], atol=1e-12).all(0))
        kept = lo.fields["equilibrium"] & same_config
        assert np.all(hi.fields["equilibrium"][kept])
        assert kept.sum() > 0


def test_frictionless_stops_are_constrained_local_minima_of_energy():
    """With mu = 0 a reconfigured distal-only finger sits at a local minimum of V along its path."""
    l1, l2, r, r1, r2 = 2.0, 1.6, 0.4, 0.2, 0.06
    found = 0
    for dx in np.linspace(-1.0, 3.0, 17):
        for dy in np.linspace(0.5, 3.2, 12):
            mode, t1, t2, k1, k2, _ = solve_finger(dx, dy, l1, l2, r1, r2, r, 0.0, TH2MIN, TH2MAX,
                                                   0.01, 1e-12)
            if mode != DISTAL_ONLY or not (1e-3 < t1 and t2 < TH2MAX - 1e-3
                                           and t2 > TH2MIN + 1e-3):
                continue
            v0 = finger_energy(t1, t2, r1, r2, 1.0, TH2MIN)
            for dt in (-1e-3, 1e-3):
                t2n, k2n = distal_tangency(dx, dy, t1 + dt, l1, r)
                if 0 <= k2n <= l2:
                    assert finger_energy(t1 + dt, t2n, r1, r2, 1.0, TH2MIN) >= v0 - 1e-12
            found += 1
    assert found > 0


@pytest.mark.parametrize("h", [0.1, 0.2])
def test_shared_field_fast_path_equals_direct_maps(h):
    """Mirror + shift by w of one finger field == each map computed directly, bit for bit."""
    widths = np.array([0.0, 0.4, 0.8, 1.2, 1.6, 2.0])
    cells = np.array([[2.0, 1.6, 0.2, 0.14, 0.4, 0.4], [0.6, 0.4, 0.04, 0.18, 1.2, 1.0],
                      [1.0, 0.8, 0.12, 0.12, 0.8, 0.1]])
    fast = summarize_cells(cells, widths, Command(), h, Limits(), Accuracy())
    for c, (l1, l2, r1, r2, r, mu) in enumerate(cells):
        for k, w in enumerate(widths):
            m = compute_map(Design(l1, l2, r1, r2, w), Part(r, mu), grid=Grid(h=h))
            # a field of an effect that is off is absent from the map and 0 in the row
            direct = np.array([m.attrs.get(name, 0) for name in SUMMARY_FIELDS], dtype=float)
            assert np.array_equal(fast[c, k], direct), (c, w)


@pytest.mark.parametrize("widths", [np.array([0.0, 0.4, 0.8, 1.2]), np.array([0.3, 0.5])])
def test_only_the_wanted_maps_are_computed(widths):
    """`want` (the refinement's few widths per cell): the wanted maps equal a whole sweep's bit
    for bit, on the shared-field path and on the direct one; the others stay zero."""
    cells = np.array([[2.0, 1.6, 0.2, 0.14, 0.4, 0.4], [1.0, 0.8, 0.12, 0.12, 0.8, 0.1]])
    whole = summarize_cells(cells, widths, Command(), 0.1, Limits(), Accuracy())
    want = np.zeros((2, widths.size), dtype=bool)
    want[0, 1] = want[1, 0] = want[1, -1] = True
    some = summarize_cells(cells, widths, Command(), 0.1, Limits(), Accuracy(), want=want)
    assert np.array_equal(some[want], whole[want])
    assert not some[~want].any() and whole[~want].any()


def test_off_grid_palm_width_uses_the_direct_path():
    widths = np.array([0.3])  # w/2 = 0.15 is not a whole number of 0.1 steps
    cells = np.array([[1.0, 0.8, 0.12, 0.1, 0.8, 0.4]])
    fast = summarize_cells(cells, widths, Command(), 0.1, Limits(), Accuracy())
    m = compute_map(Design(1.0, 0.8, 0.12, 0.1, 0.3), Part(0.8, 0.4), grid=Grid(h=0.1))
    assert np.array_equal(fast[0, 0], [m.attrs.get(n, 0) for n in SUMMARY_FIELDS])


def test_translating_the_base_translates_the_finger_field():
    """A finger's field for palm width w is the w = 0 field shifted by w/2 (MODEL 11)."""
    design0, part = Design(1.4, 1.2, 0.2, 0.1, 0.0), Part(0.8, 0.4)
    a = compute_map(design0, part, grid=Grid(h=0.1, xlim=(-4.0, 4.0)))
    b = compute_map(Design(1.4, 1.2, 0.2, 0.1, 0.8), part, grid=Grid(h=0.1, xlim=(-4.0, 4.0)))
    shift = 4  # w/2 = 0.4 = 4 steps
    for name in ("finger_mode", "theta1", "theta2", "k1", "k2"):
        right_a = a.fields[name][1][:, :-shift]
        right_b = b.fields[name][1][:, shift:]
        assert np.array_equal(right_a, right_b, equal_nan=True), name


finite = dict(allow_nan=False, allow_infinity=False)


@settings(max_examples=300, deadline=None)
@given(l1=st.floats(0.2, 2.5, **finite), l2=st.floats(0.2, 2.0, **finite),
       r1=st.floats(0.01, 0.3, **finite), R=st.sampled_from([0.1, 0.5, 0.9, 1.0, 1.5]),
       r=st.floats(0.05, 2.0, **finite), mu=st.sampled_from([0.0, 0.1, 1.0, 3.0]),
       u=st.floats(-1.0, 1.0, **finite), v=st.floats(0.0, 1.0, **finite),
       snap=st.sampled_from(["none", "palm", "joint", "B"]))
def test_finger_is_defined_everywhere(l1, l2, r1, R, r, mu, u, v, snap):
    """No NaN, inf or exception for any feasible point, including contacts at joints."""
    reach = l1 + l2 + r
    dx, dy = u * reach, r + v * reach
    if snap == "palm":
        dy = r
    elif snap == "joint":  # part touching the proximal joint
        dx, dy = r * u, r * math.sqrt(max(1 - u * u, 0.0))
        if dy < r:
            dy = r
            dx = 0.0
    elif snap == "B":  # |d|^2 = l1^2 + r^2: contact exactly at the distal joint
        ang = math.pi * v
        dx, dy = l1 * math.cos(ang) - r * math.sin(ang), l1 * math.sin(ang) + r * math.cos(ang)
        if dy < r:
            return
    out = solve_finger(dx, dy, l1, l2, r1, R * r1, r, mu, TH2MIN, TH2MAX, 0.01, 1e-12)
    mode = out[0]
    assert -1 <= mode <= 5
    assert all(math.isfinite(x) for x in out[1:5])
    if mode >= 0:
        assert -1e-12 <= out[1] <= math.pi + 1e-12
        assert TH2MIN - 1e-12 <= out[2] <= math.pi
        assert -1e-12 <= out[3] <= l1 + 1e-12
        assert -1e-12 <= out[4] <= l2 + 1e-6 or mode == 4


def test_counts_add_up(energy_map):
    a = energy_map.attrs
    assert (a["n_infeasible"] + a["n_unreached"] + a["n_eject"] + a["n_vertex"] + a["n_reached"]
            == a["n_points"] == energy_map.fields["energy"].size)
    assert (a["n_caged"] + a["n_tip_prehension"] + a["n_ejection"] + a["n_stalled"]
            == a["n_reached"])
    reached = energy_map.fields["point_class"] == REACHED
    assert a["n_equilibrium"] == int((energy_map.fields["equilibrium"] & reached).sum())
    # the trapezoid across the palm line (model-notes D36): the first row, on y = r, counts half
    f = energy_map.fields
    ends = np.asarray(f["end_index"])[0]
    caged = reached[0] & (np.asarray(f["end_state"])[0] == END_CAGED)
    palm = float(np.asarray(f["caging_score"]).ravel()[ends[caged]].sum())
    assert abs(energy_map.y[0] - energy_map.part.r) < 1e-12
    assert a["caging_area"] == pytest.approx((a["Lambda"] - 0.5 * palm) * 0.1 ** 2, rel=1e-12)
    tips = reached & (np.asarray(f["end_state"]) == END_TIP_PREHENSION)
    assert a["tip_prehension_area"] == pytest.approx(
        (tips.sum() - 0.5 * tips[0].sum()) * 0.1 ** 2, rel=1e-12)
