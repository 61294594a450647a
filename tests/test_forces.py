"""Contact forces (MODEL 5.1, 5.6) as an output: statics at every point, tension, symmetry,
the sweep path, and the decided rule for undetermined forces (model-notes D9)."""
from __future__ import annotations

import math

import numpy as np
import pytest
from kernel_calls import closing, solve

from sweep.compute.batch import cell_map_fields
from sweep.compute.maps import compute_map
from sweep.model import (
    DISTAL_ONLY,
    FREE,
    PROXIMAL_ONLY,
    TWO_PHALANX,
    Accuracy,
    Command,
    Design,
    Grid,
    Limits,
    Part,
)
from sweep.schema import FORCE_FIELDS

TH2MIN, TH2MAX = math.radians(-5.0), math.radians(90.0)
LIM = 1e-12
MAPS = [  # (design, part, h): the reference design, R > 1 with low friction, a large part
    (Design(2.0, 1.6, 0.2, 0.14, 0.8), Part(0.4, 0.4), 0.1),
    (Design(1.0, 0.8, 0.04, 0.18, 1.2), Part(0.8, 0.1), 0.1),
    (Design(0.6, 0.4, 0.12, 0.1, 0.4), Part(1.2, 1.0), 0.1),
    (Design(1.6, 1.2, 0.08, 0.06, 0.0), Part(0.4, 0.0), 0.1),
]


def cross(a, b):
    return a[0] * b[1] - a[1] * b[0]


def check_finger_statics(mode, t1, t2, k1, k2, f1, f2, mu2, fx, fy, design, part, tension):
    """MODEL 5.1 from scratch, right-finger frame: contact forces f_i = F_i (n_i + mu_i t_i),
    t_i = rot90(n_i); torques about J (all contacts) and B (distal contacts) against the tendon
    torques F r1, F r2, any difference taken by a joint resting on a limit with the sign that
    limit can supply (closing at a lower limit, opening at an upper one)."""
    l1 = design.l1
    ax = np.array([math.cos(t1), math.sin(t1)])
    ay = np.array([-math.sin(t1), math.cos(t1)])
    bx = np.array([math.cos(t1 + t2), math.sin(t1 + t2)])
    by = np.array([-math.sin(t1 + t2), math.cos(t1 + t2)])
    B = l1 * ax
    forces, points, distal = [], [], []
    if mode in (PROXIMAL_ONLY, TWO_PHALANX):
        forces.append(tension * f1 * ay)
        points.append(k1 * ax)
        distal.append(False)
    if mode in (TWO_PHALANX, DISTAL_ONLY):
        forces.append(tension * f2 * (by + mu2 * np.array([-by[1], by[0]])))
        points.append(B + k2 * bx)
        distal.append(True)
    assert f1 >= 0 and f2 >= 0 and abs(mu2) <= part.mu + 1e-15
    total = sum(forces, np.zeros(2))
    assert total / tension == pytest.approx([fx, fy], abs=1e-12)
    tau_proximal = sum(cross(c, f) for c, f in zip(points, forces)) - tension * design.r1
    tau_distal = sum(cross(c - B, f) for c, f, d in zip(points, forces, distal) if d) \
        - tension * design.r2
    scale = tension * max(design.r1, design.r2) * 1e-9
    for tau, angle, lo, hi in ((tau_proximal, t1, 0.0, math.pi),
                               (tau_distal, t2, TH2MIN, TH2MAX)):
        if angle <= lo + LIM:
            assert tau >= -scale        # a lower stop can only push the joint closed
        elif angle >= hi - LIM:
            assert tau <= scale         # an upper stop can only push it open
        else:
            assert abs(tau) <= scale    # free joint: exact balance
    return tau_proximal, tau_distal


@pytest.mark.parametrize("design,part,h", MAPS, ids=[f"map{k}" for k in range(len(MAPS))])
def test_forces_satisfy_the_finger_statics_at_every_point(design, part, h):
    tension = 1.7
    m = compute_map(design, part, Command(tension, tension), Grid(h=h), forces=True)
    f = m.fields
    n_checked = n_least = 0
    for side in range(2):
        det = f["forces_determined"][side]
        for j, i in zip(*np.nonzero(det)):
            mode = f["finger_mode"][side, j, i]
            fx = f["resultant_force_x"][side, j, i] * (1.0 if side == 1 else -1.0)  # own frame
            args = [f[k][side, j, i] for k in ("theta1", "theta2", "k1", "k2",
                                               "proximal_normal_force", "distal_normal_force",
                                               "distal_friction_multiplier")]
            if mode == FREE:
                assert fx == 0.0 and f["resultant_force_y"][side, j, i] == 0.0
                continue
            tau_p, tau_d = check_finger_statics(mode, *args, fx, f["resultant_force_y"][side, j, i],
                                                design, part, tension)
            n_checked += 1
            mu2 = args[6]
            # least |mu| (MODEL 5.6): a non-zero multiplier is needed only where mu = 0 would
            # leave a force or a stop torque of the wrong sign, so at the chosen multiplier that
            # quantity is exactly at its bound: F1 = 0 (two-phalanx) or no stop torque (distal)
            if mu2 != 0.0 and abs(mu2) < part.mu:
                n_least += 1
                if mode == TWO_PHALANX:
                    assert args[4] == pytest.approx(0.0, abs=1e-9)
                else:
                    assert min(abs(tau_p), abs(tau_d)) <= 1e-9 * tension
    assert n_checked >= 10


def test_forces_are_per_unit_tension_and_configurations_do_not_depend_on_it():
    design, part, h = MAPS[0]
    one = compute_map(design, part, Command(1.0, 1.0), Grid(h=h), forces=True).fields
    big = compute_map(design, part, Command(1e6, 1e6), Grid(h=h), forces=True).fields
    for name in FORCE_FIELDS + ("finger_mode", "theta1", "theta2", "k1", "k2"):
        np.testing.assert_array_equal(one[name], big[name], err_msg=name)
    np.testing.assert_allclose(big["energy"], 1e6 * one["energy"], rtol=1e-15)


@pytest.mark.parametrize("design,part,h", MAPS[:2], ids=["map0", "map1"])
def test_forces_are_mirror_symmetric(design, part, h):
    f = compute_map(design, part, Command(), Grid(h=h), forces=True).fields
    s_geo = f["geometric_cage_score"]
    np.testing.assert_array_equal(s_geo, s_geo[:, ::-1])
    for name in FORCE_FIELDS:
        if f[name].ndim == 2:
            continue
        left, right = f[name][0], f[name][1][:, ::-1]
        if name == "resultant_force_x":
            right = -right
        np.testing.assert_array_equal(left, right, err_msg=name)


@pytest.mark.parametrize("design,part,h", MAPS[:3], ids=["map0", "map1", "map2"])
def test_geometric_cage_score_is_the_caging_score_without_stability(design, part, h):
    """MODEL 10: S_geo = 1 - L_open/(2r) at reached, contained points with L_open < 2r, computed
    without the stability requirement; where the part is stable it is the caging score."""
    f = compute_map(design, part, Command(), Grid(h=h), forces=True).fields
    s_geo = f["geometric_cage_score"]
    reached = f["point_class"] == 4
    expect = np.where(reached & f["contained"] & (f["l_open"] < 2 * part.r - 1e-12),
                      1.0 - f["l_open"] / (2 * part.r), 0.0)
    np.testing.assert_array_equal(np.where(np.isnan(s_geo), 0.0, s_geo), expect)
    stable = reached & f["equilibrium"]
    np.testing.assert_array_equal(np.where(stable, s_geo, 0.0), f["caging_score"])
    if design == MAPS[0][0]:  # the reference map has poses the manipulation metric can count
        assert (s_geo[reached & ~f["equilibrium"]] > 0).any()


def test_forces_off_cost_no_output_and_leave_the_rest_unchanged():
    design, part, h = MAPS[1]
    off = compute_map(design, part, Command(0.4, 1.6), Grid(h=h))
    on = compute_map(design, part, Command(0.4, 1.6), Grid(h=h), forces=True)
    assert not set(FORCE_FIELDS) & set(off.fields)
    for name, value in off.fields.items():
        np.testing.assert_array_equal(value, on.fields[name], err_msg=name)
    for name in ("Lambda", "n_caged", "n_reached"):
        assert off.attrs[name] == on.attrs[name]


@pytest.mark.parametrize("design,part,h", MAPS, ids=[f"map{k}" for k in range(len(MAPS))])
def test_sweep_path_gives_the_same_forces_as_one_map(design, part, h):
    cell = (design.l1, design.l2, design.r1, design.r2, part.r, part.mu)
    x, y, fields, attrs = cell_map_fields(cell, design.w, Command(), h, Limits(), Accuracy(),
                                          forces=True)
    m = compute_map(design, part, Command(), Grid(h=h), forces=True)
    np.testing.assert_array_equal(x, m.x)
    np.testing.assert_array_equal(y, m.y)
    assert set(fields) == set(m.fields)
    for name in fields:
        np.testing.assert_array_equal(fields[name], m.fields[name], err_msg=name)
    assert attrs == {k: m.attrs[k] for k in attrs}


def test_a_link_pressed_on_the_part_while_on_its_stop_has_undetermined_forces():
    """MODEL 10: the proximal link lying flat on the palm row outside the palm (t1 = 0 on its
    stop) can share any load with the stop: its force is not determined (model-notes D9)."""
    l1, l2, r = 2.0, 1.6, 0.4
    # part centre on the palm row, k1 = 1.0 along the flat proximal link
    state = solve(1.0, r, l1, l2, 0.2, 0.14, r, 0.4, TH2MIN, TH2MAX, 0.01, 1e-12)
    assert state.t1 == 0.0 and state.mode in (PROXIMAL_ONLY, TWO_PHALANX)
    design = Design(l1, l2, 0.2, 0.14, 0.8)
    m = compute_map(design, Part(r, 0.4), Command(), Grid(h=0.1), forces=True)
    i = int(np.flatnonzero(np.isclose(m.x, 0.4 + 1.0))[0])  # right finger base at w/2 = 0.4
    assert m.fields["theta1"][1, 0, i] == 0.0
    assert not m.fields["forces_determined"][1, 0, i]
    # one row up the proximal link is off its stop and the same kind of contact is determined
    assert m.fields["theta1"][1, 1, i] > 0.0 and m.fields["forces_determined"][1, 1, i]


def test_more_friction_never_unsticks_a_distal_contact_on_its_lower_stop():
    """MODEL 5.3 revised: stable iff SOME |mu| <= mu_s gives g >= 0 and a positive lever.
    Testing only the multiplier that maximises g (-mu_s at t2 = -5 deg) makes the lever negative
    for mu_s > cot 5 deg ~ 11.4 and would let more friction lower the energy."""
    l1, l2, r, t1, k2 = 2.0, 1.6, 0.4, 0.8, 0.2
    phi = t1 + TH2MIN
    dx = l1 * math.cos(t1) + k2 * math.cos(phi) - r * math.sin(phi)
    dy = l1 * math.sin(t1) + k2 * math.sin(phi) + r * math.cos(phi)
    from sweep.kernels.finger import DISTAL_ON_LOWER_STOP
    assert closing(dx, dy, l1, l2, r, TH2MIN, TH2MAX)[0] == DISTAL_ON_LOWER_STOP
    r1, r2 = 0.2, 0.12
    g0 = r1 * k2 - r2 * (l1 * math.cos(TH2MIN) + k2)
    assert g0 < 0  # friction is needed to stick
    slope = r2 * l1 * math.sin(TH2MIN)           # g(mu) = g0 + mu slope
    lever = lambda mu: l1 * math.cos(TH2MIN) + k2 - mu * l1 * math.sin(TH2MIN)  # noqa: E731
    mu_needed = g0 / slope                          # g >= 0 needs mu <= -mu_needed
    mu_old_limit = (l1 * math.cos(TH2MIN) + k2) / (l1 * abs(math.sin(TH2MIN)))
    assert 10 < mu_needed < 11 and 12 < mu_old_limit < 13
    energies = []
    for mu_s in (1.0, 11.0, 12.0, 50.0, 1e3):
        state = solve(dx, dy, l1, l2, r1, r2, r, mu_s, TH2MIN, TH2MAX, 0.01, 1e-12)
        energies.append(-(r1 * state.t1 + r2 * (state.t2 - TH2MIN)))
        if mu_s < mu_needed:   # no admissible multiplier gives g >= 0: it reconfigures
            assert state.t1 < t1
            continue
        # sticks where it first touched, including where the multiplier that maximises g
        # (-mu_s) has a negative lever (mu_s = 50, 1000) and a smaller |mu| holds it
        assert state.mode == DISTAL_ONLY
        assert state.t1 == pytest.approx(t1, abs=1e-12)
        assert state.t2 == pytest.approx(TH2MIN, abs=1e-12)
        assert (lever(-mu_s) > 0) == (mu_s < mu_old_limit)
    assert energies == sorted(energies)  # more friction never lowers V (MODEL 11)


def test_sweep_map_writes_forces_when_asked(tmp_path):
    import xarray as xr
    from click.testing import CliRunner

    from sweep.cli import main

    base = ["map", "--l1", "2.0", "--l2", "1.6", "--r1", "0.2", "--r2", "0.14", "--w", "0.8",
            "--r", "0.4", "--mu", "0.4", "--h", "0.2"]
    runner = CliRunner()
    res = runner.invoke(main, base + ["--out", str(tmp_path / "f.h5"), "--forces"])
    assert res.exit_code == 0, res.output
    res = runner.invoke(main, base + ["--out", str(tmp_path / "n.h5")])
    assert res.exit_code == 0, res.output
    with xr.open_dataset(tmp_path / "f.h5", engine="h5netcdf") as ds:
        assert set(FORCE_FIELDS) <= set(ds.data_vars)
        assert ds["resultant_force_x"].dims == ("finger", "y", "x")
        assert "forces" in ds.attrs["outputs_on"]
        determined = ds["forces_determined"].values.astype(bool)
        assert determined.any()
        assert np.isfinite(ds["resultant_force_y"].values[determined]).all()
    with xr.open_dataset(tmp_path / "n.h5", engine="h5netcdf") as ds:
        assert not set(FORCE_FIELDS) & set(ds.data_vars)


from hypothesis import given  # noqa: E402
from hypothesis import strategies as st  # noqa: E402


@given(t2=st.floats(-1.5, 0.0), k2=st.one_of(st.just(0.0), st.floats(0.0, 2.0)),
       l1=st.floats(0.2, 2.0), r1=st.floats(0.01, 0.3), r2=st.floats(0.01, 0.3),
       mu_s=st.one_of(st.just(0.0), st.floats(0.0, 2.0), st.floats(0.0, 1e3)))
def test_lower_stop_rule_matches_the_interval_reference(t2, k2, l1, r1, r2, mu_s):
    """The kernel's closed form of MODEL 5.3 (revised) against the explicit interval
    intersection of tests/naive.py, friction up to 1000."""
    from kernel_calls import finger_model
    from naive import lower_stop_admissible

    from sweep.kernels.finger_statics import sticks_on_lower_stop
    from sweep.kernels.records import NO_EFFECTS

    finger = finger_model(l1, 1.0, r1, r2, 0.4, mu_s, -1.5, 1.5)
    assert sticks_on_lower_stop(k2, 0.0, t2, finger, NO_EFFECTS.joint_springs) == \
        lower_stop_admissible(t2, k2, l1, r1, r2, mu_s)


def test_forces_match_the_linear_programme_of_the_slow_reference():
    """Per finger and point, the kernel's resultant equals the independent LP statics of
    tests/naive_manipulation.py (least total tangential force, stop torques of admissible sign)
    given the same configuration, and both decide `determined` alike (model-notes D9)."""
    from naive_manipulation import finger_forces

    design, part, h = MAPS[0]
    f = compute_map(design, part, Command(), Grid(h=h), forces=True).fields
    rng = np.random.default_rng(7)
    feasible = np.argwhere(f["point_class"] >= 1)
    picks = feasible[rng.choice(len(feasible), size=150, replace=False)]
    compared = 0
    for j, i in picks:
        for side in range(2):
            mode = int(f["finger_mode"][side, j, i])
            if mode not in (FREE, PROXIMAL_ONLY, TWO_PHALANX, DISTAL_ONLY):
                continue
            res = {k: float(f[name][side, j, i]) for k, name in
                   (("t1", "theta1"), ("t2", "theta2"), ("k1", "k1"), ("k2", "k2"))}
            res["mode"] = mode
            ref = finger_forces(res, design.l1, design.r1, design.r2, part.mu)
            assert bool(f["forces_determined"][side, j, i]) == ref["determined"], (j, i, side)
            if not (ref["determined"] and ref["admissible"] and ref["unique"]):
                continue
            fx = f["resultant_force_x"][side, j, i] * (1.0 if side == 1 else -1.0)
            np.testing.assert_allclose([fx, f["resultant_force_y"][side, j, i]], ref["force"],
                                       rtol=1e-7, atol=1e-9)
            compared += 1
    assert compared > 50
