"""The joint_springs effect (MODEL 6, 9; model-notes D13): spring torques K_i (t_i - theta_io)
in the statics and 1/2 K_i (t_i - theta_io)^2 in the energy.

References here are plain Python from the statement of MODEL 5.1 (joint torques balance the
contact moments), not from the kernels."""
import math
import re

import numpy as np
import pytest

from sweep.kernels.finger import solve_finger
from sweep.compute.layout import kernel_records
from sweep.compute.maps import compute_map
from sweep.model import (DISTAL_ONLY, TWO_PHALANX, Accuracy, Command, Design, Effects, Grid,
                         Limits, ModelInputError, Part)

TH2MIN = math.radians(-5.0)
# The worked point of MODEL 3.1, 3.2, 5.2: d = (1.0, 0.8), r = 0.4, l1 = 1.5, r1 = 0.2, r2 = 0.1
D = (1.0, 0.8)
T1 = math.atan2(0.8, 1.0) - math.atan2(0.4, math.sqrt(1.48))   # 0.357078
K1_CONTACT = math.sqrt(1.48)                                    # 1.216553
K2_CONTACT = 1.5 - K1_CONTACT                                   # 0.283447
T2 = math.pi - 2.0 * math.atan2(0.4, K2_CONTACT)                # 1.232974


def solve(mu, k1=0.0, k2=0.0, springs=True, tension=1.0):
    design, part = Design(1.5, 1.0, 0.2, 0.1, 0.0), Part(0.4, mu)
    effects = Effects(joint_springs=springs, spring_k1=k1, spring_k2=k2)
    finger, solver, blocks = kernel_records(design, part, Limits(), Accuracy(), effects, tension)
    return solve_finger(D[0], D[1], finger, solver, blocks)


def proximal_force_times_k1(mu, k1_spring, k2_spring, t1=T1, t2=T2, k2c=K2_CONTACT, F=1.0):
    """k1 F1 from MODEL 5.1 with spring torques: the distal joint gives F2 = T2 / k2, the
    proximal joint T1 = k1 F1 + F2 (l1 cos t2 + k2 - mu l1 sin t2)."""
    T1_net = F * 0.2 - k1_spring * t1
    T2_net = F * 0.1 - k2_spring * (t2 - TH2MIN)
    f2 = T2_net / k2c
    return T1_net - f2 * (1.5 * math.cos(t2) + k2c - mu * 1.5 * math.sin(t2))


def test_hand_worked_point_is_two_phalanx_as_in_model_5_2():
    # the numbers of MODEL 5.2
    assert T1 == pytest.approx(0.357078, abs=1e-6) and T2 == pytest.approx(1.232974, abs=1e-6)
    s = solve(0.3, springs=False)
    assert s.mode == TWO_PHALANX
    assert (s.t1, s.t2) == pytest.approx((T1, T2), abs=1e-9)


def test_distal_spring_holds_a_frictionless_two_phalanx_grasp():
    # Frictionless: k1 F1 = 0.2 - (0.1 / k2) L = -0.0754 < 0 (case 2): the proximal link lifts
    # off. A distal spring K2 = 0.04 lowers the distal torque to 0.1 - 0.04 * 1.3202 = 0.0472,
    # hence the distal force and its moment about J: k1 F1 = +0.0696 > 0, the grasp holds.
    assert proximal_force_times_k1(0.0, 0.0, 0.0) < 0
    assert proximal_force_times_k1(0.0, 0.0, 0.04) > 0
    assert solve(0.0, springs=False).mode != TWO_PHALANX
    s = solve(0.0, k2=0.04)
    assert s.mode == TWO_PHALANX and (s.t1, s.t2) == pytest.approx((T1, T2), abs=1e-9)


def test_proximal_spring_lifts_off_a_grasp_that_friction_held():
    # mu = 0.17: k1 F1 = +0.0094 > 0 with the best multiplier (case 3, sticks); a proximal
    # spring K1 = 0.05 takes 0.05 * t1 = 0.0179 off the proximal torque: k1 F1 < 0, case 2.
    assert proximal_force_times_k1(0.17, 0.0, 0.0) > 0
    assert proximal_force_times_k1(0.17, 0.05, 0.0) < 0
    assert solve(0.17, springs=False).mode == TWO_PHALANX
    s = solve(0.17, k1=0.05)
    assert s.mode != TWO_PHALANX and s.t1 < T1  # reconfigured: the proximal link opened


def test_a_stuck_distal_contact_balances_the_spring_torques():
    # After reconfiguring frictionless with a proximal spring, a distal-only finger stuck
    # between its stops has zero proximal imbalance by 5.1 with the springs at its own angles.
    s = solve(0.0, k1=0.05, k2=0.02)
    assert s.mode == DISTAL_ONLY and 1e-6 < s.t1 < math.pi - 1e-6
    assert TH2MIN + 1e-6 < s.t2 < math.radians(90) - 1e-6
    assert proximal_force_times_k1(0.0, 0.05, 0.02, t1=s.t1, t2=s.t2, k2c=s.k2) == \
        pytest.approx(0.0, abs=1e-9)


def test_spring_torque_scales_with_one_over_tension():
    # statics are homogeneous: (K, F) and (2K, 2F) decide alike
    a = solve(0.17, k1=0.05, tension=1.0)
    b = solve(0.17, k1=0.10, tension=2.0)
    assert a == b


DESIGN, PART = Design(2.0, 1.6, 0.2, 0.14, 0.8), Part(0.4, 0.4)


@pytest.fixture(scope="module")
def base_map():
    return compute_map(DESIGN, PART, grid=Grid(h=0.1))


def test_springs_to_zero_converge_to_the_base_model(base_map):
    changed = []
    for k in (0.02, 2e-3, 2e-4, 2e-6, 0.0):
        m = compute_map(DESIGN, PART, grid=Grid(h=0.1),
                        effects=Effects(joint_springs=True, spring_k1=k, spring_k2=k))
        modes, base_modes = m.fields["finger_mode"], base_map.fields["finger_mode"]
        changed.append(int((modes != base_modes).sum()))
        same = (modes == base_modes).all(axis=0)
        # where nothing changed, the energy differs by the springs' energy alone, O(K)
        diff = np.abs(m.fields["energy"] - base_map.fields["energy"])[same]
        assert np.nanmax(diff) <= 0.5 * k * (math.pi ** 2 + math.radians(95) ** 2) * 2 + 1e-12
    assert changed[0] > 0                       # springs this strong change configurations
    assert changed == sorted(changed, reverse=True)
    assert changed[-1] == 0                     # K = 0 is the base model, field by field
    m0 = compute_map(DESIGN, PART, grid=Grid(h=0.1),
                     effects=Effects(joint_springs=True, spring_k1=0.0, spring_k2=0.0))
    for name in ("finger_mode", "theta1", "theta2", "k1", "k2", "point_class"):
        np.testing.assert_array_equal(m0.fields[name], base_map.fields[name], err_msg=name)


def test_spring_energy_is_the_potential_of_the_spring_torques():
    # Energy with springs minus the base energy of the same configuration = sum of
    # 1/2 K1 t1^2 + 1/2 K2 (t2 - theta2_min)^2 over both fingers, at every feasible point.
    k1, k2 = 0.03, 0.05
    m = compute_map(DESIGN, PART, grid=Grid(h=0.2),
                    effects=Effects(joint_springs=True, spring_k1=k1, spring_k2=k2))
    t1, t2 = m.fields["theta1"], m.fields["theta2"]
    tendon = -(0.2 * t1 + 0.14 * (t2 - TH2MIN)).sum(axis=0)
    springs = (0.5 * k1 * t1 ** 2 + 0.5 * k2 * (t2 - TH2MIN) ** 2).sum(axis=0)
    np.testing.assert_allclose(m.fields["energy"], tendon + springs, rtol=0, atol=1e-12)


@pytest.mark.parametrize("k1, k2, command, message", [
    (0.07, 0.0, Command(), "K1 pi < F r1"),
    (0.0, 0.1, Command(), "K2 (theta2_max - theta2_min) < F r2"),
    (0.01, 0.01, Command(0.0, 1.0), "tensions must be > 0"),
    (-0.01, 0.0, Command(), "K1 (joint_springs) must be >= 0"),
])
def test_springs_stronger_than_the_tendon_are_refused(k1, k2, command, message):
    with pytest.raises(ModelInputError, match=re.escape(message)):
        compute_map(DESIGN, PART, command, grid=Grid(h=0.5),
                    effects=Effects(joint_springs=True, spring_k1=k1, spring_k2=k2))


def test_sweep_path_with_springs_gives_the_maps_summaries():
    # the sweep (one shared finger field per cell, cells in parallel) and compute_map agree
    from sweep.compute.batch import summarize_cells
    from sweep.compute.layout import summary_attrs

    effects = Effects(joint_springs=True, spring_k1=0.03, spring_k2=0.05)
    cells = np.array([[2.0, 1.6, 0.2, 0.14, 0.4, 0.4], [1.0, 0.8, 0.12, 0.1, 0.8, 0.1]])
    widths = np.array([0.0, 0.4])
    out = summarize_cells(cells, widths, Command(), 0.2, Limits(), Accuracy(), effects)
    for c, cell in enumerate(cells):
        for k, w in enumerate(widths):
            m = compute_map(Design(*cell[:4], w), Part(*cell[4:]), grid=Grid(h=0.2),
                            effects=effects)
            expected = summary_attrs(out[c, k], effects=effects)
            assert set(m.attrs) >= set(expected)
            for name in expected:
                assert m.attrs[name] == expected[name], name


@pytest.mark.parametrize("collision", [False, True], ids=["base", "collision"])
def test_springs_and_tensions_scaled_together_leave_every_finger_where_it_was(collision):
    """Each finger's statics see its springs per unit of its own tension (K_i / F): a map with
    springs 2K and command (2 F_left, 2 F_right) has every finger configuration of the map
    with K and (F_left, F_right), bit for bit (the factor 2 is exact), and twice its energy,
    for unequal commands (each finger its own tension)."""
    design, part = Design(2.0, 1.6, 0.2, 0.14, 0.8), Part(0.4, 0.4)
    maps = []
    for scale in (1.0, 2.0):
        effects = Effects(joint_springs=True, spring_k1=0.01 * scale, spring_k2=0.004 * scale,
                          finger_collision=collision)
        maps.append(compute_map(design, part, Command(0.6 * scale, 1.4 * scale),
                                grid=Grid(h=0.1), effects=effects))
    one, two = (m.fields for m in maps)
    for name in ("finger_mode", "theta1", "theta2", "k1", "k2", "point_class"):
        assert np.array_equal(one[name], two[name], equal_nan=True), name
    assert np.array_equal(2.0 * one["energy"], two["energy"], equal_nan=True)
    # the springs do act here: without them some finger ends elsewhere
    plain = compute_map(design, part, Command(0.6, 1.4), grid=Grid(h=0.1),
                        effects=Effects(finger_collision=collision)).fields
    assert not np.array_equal(one["theta1"], plain["theta1"], equal_nan=True)


def test_a_position_off_the_grid_sees_each_finger_s_springs_at_its_own_tension():
    """One position has one class and one energy whichever asks (the slides evaluate the model
    off the grid with outcome.point_outcome): with springs and unequal tendon tensions, the
    class and energy point_outcome gives at each grid point are the map's. Each finger's springs
    act per unit of its own tension (records.JointSprings), on the grid and off it."""
    from sweep.compute.layout import hand_record
    from sweep.kernels.outcome import point_outcome

    design, part = Design(1.4, 1.2, 0.16, 0.1, 0.8), Part(0.4, 0.4)
    command = Command(0.6, 1.4)
    effects = Effects(joint_springs=True, spring_k1=0.01, spring_k2=0.02)
    m = compute_map(design, part, command=command, grid=Grid(h=0.1), effects=effects)
    finger, solver, blocks = kernel_records(design, part, Limits(), Accuracy(), effects)
    hand = hand_record(design.w, command, 0.1, finger)
    pc, energy = np.asarray(m.fields["point_class"]), np.asarray(m.fields["energy"])
    checked = 0
    for j in range(0, pc.shape[0], 3):
        for i in range(0, pc.shape[1], 3):
            c, e = point_outcome(m.x[i], m.y[j], finger, solver, blocks, hand)
            assert c == pc[j, i], (j, i)
            if np.isfinite(energy[j, i]):
                assert e == pytest.approx(energy[j, i], rel=1e-12, abs=1e-12), (j, i)
                checked += 1
    assert checked > 20


def test_springs_with_a_slack_tendon_are_refused_naming_the_tension():
    """joint_springs with a tension of 0: `sweep map` exits 2 with one line naming the tension
    (f_right), not only the effect (found by the long fuzz profile)."""
    from click.testing import CliRunner

    from sweep.cli import main

    res = CliRunner().invoke(main, ["map", "--l1", "1", "--l2", "1", "--r1", "0.25", "--r2",
                                    "0.25", "--w", "0", "--r", "1", "--mu", "0", "--f-right",
                                    "0", "--effects", "friction,joint_springs", "--K1", "0",
                                    "--K2", "0", "--out", "unused.h5"])
    assert res.exit_code == 2
    assert "f_right = 0" in res.output
