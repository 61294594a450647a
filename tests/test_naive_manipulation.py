"""The slow reference of the manipulation metric, checked on itself where answers are analytic,
and the hull reduction fed with its forces (MODEL 10, 5.1, 5.6)."""
import math
from functools import lru_cache

import numpy as np
import pytest

from naive import naive_finger
from naive_manipulation import (SCENARIO_A_COMMANDS, SCENARIO_B_COMMANDS, THETA2_MAX, THETA2_MIN,
                                finger_forces, naive_metric, on_limit, pose_forces, rot90,
                                world_lattice)
from sweep.compute.manipulation import PAPER_SEARCH_RANGES
from incremental_hull import IncrementalHull
from sweep.model import DISTAL_ONLY, PROXIMAL_ONLY, TWO_PHALANX

# Three geometries of the paper's grid, (w, l1, l2, r1, r2), and a part (r, mu_s): chosen because
# their metric is positive in both scenarios at h = 0.2 (found by a search over random triples).
GEOMETRIES = [(0.0, 1.4, 0.8, 0.12, 0.10), (1.2, 0.4, 0.8, 0.16, 0.14), (0.8, 0.4, 1.2, 0.12, 0.14)]
PART = (0.4, 0.4)
H = 0.2


@pytest.fixture(scope="module")
def scenario_a():
    return naive_metric(GEOMETRIES, PART, H, SCENARIO_A_COMMANDS)


@pytest.fixture(scope="module")
def scenario_b():
    return naive_metric(GEOMETRIES, PART, H, SCENARIO_B_COMMANDS)


def sample_fingers():
    """Configurations the reference finger solver reaches, over a coarse grid of part centres."""
    cases = []
    for l1, l2, r1, r2, mu in ((1.4, 0.8, 0.12, 0.10, 0.4), (0.4, 1.2, 0.12, 0.14, 0.1),
                               (2.0, 1.6, 0.20, 0.02, 1.0)):
        for dx in np.arange(-2.0, 2.01, 0.25):
            for dy in np.arange(0.4, 3.0, 0.25):
                res = naive_finger(dx, dy, l1, l2, r1, r2, 0.4, mu, THETA2_MIN, THETA2_MAX)
                if res["mode"] in (PROXIMAL_ONLY, TWO_PHALANX, DISTAL_ONLY):
                    cases.append((res, l1, r1, r2, mu))
    return cases


SAMPLE = sample_fingers()


@lru_cache(maxsize=None)
def sample_forces():
    """finger_forces of every SAMPLE finger at unit tension (an LP each), solved once for the
    tests that read them."""
    return [finger_forces(res, l1, r1, r2, mu) for res, l1, r1, r2, mu in SAMPLE]


def test_sample_covers_every_contact_mode():
    modes = {res["mode"] for res, *_ in SAMPLE}
    assert modes == {PROXIMAL_ONLY, TWO_PHALANX, DISTAL_ONLY}


def test_finger_forces_satisfy_the_joint_equations_and_the_cones():
    checked = 0
    for (res, l1, r1, r2, mu), out in zip(SAMPLE, sample_forces()):
        if not out["determined"]:
            continue
        if res["mode"] == DISTAL_ONLY and res["k2"] == 0.0:
            # Contact exactly at the distal joint: no moment about B can balance r2, so no
            # statics exist (seen at t1 = 0 on the palm row); the reference drops such poses.
            assert not out["admissible"]
            continue
        assert out["admissible"]
        checked += 1
        b_pt = l1 * np.array([math.cos(res["t1"]), math.sin(res["t1"])])
        torque_j = sum(c[0] * f[1] - c[1] * f[0] for c, f in out["contacts"])
        # Contacts are listed proximal first; the distal one (if any) is last.
        distal = out["contacts"][-1:] if res["mode"] in (TWO_PHALANX, DISTAL_ONLY) else []
        torque_b = sum((c - b_pt)[0] * f[1] - (c - b_pt)[1] * f[0] for c, f in distal)
        assert torque_j == pytest.approx(r1 + out["stops"].get(1, 0.0), abs=1e-12)
        assert torque_b == pytest.approx(r2 + out["stops"].get(2, 0.0), abs=1e-12)
        np.testing.assert_allclose(sum(f for _, f in out["contacts"]), out["force"], atol=1e-15)
        for (_c, _f), m in zip(out["contacts"], out["mu"]):
            assert abs(m) <= mu * (1 + 1e-9)
        # A lower stop pushes closing, an upper stop opening: never the other way.
        if on_limit(res["t2"], THETA2_MAX):
            assert out["stops"][2] <= 1e-12
        if on_limit(res["t2"], THETA2_MIN):
            assert out["stops"][2] >= -1e-12
    assert checked > 50


def test_forces_scale_linearly_with_tension():
    for (res, l1, r1, r2, mu), one in zip(SAMPLE[::5], sample_forces()[::5]):   # tension 1
        if not one["determined"]:
            continue
        three = finger_forces(res, l1, r1, r2, mu, tension=3.0)
        np.testing.assert_allclose(three["force"], 3.0 * one["force"], rtol=1e-9, atol=1e-14)


def test_analytic_forces_of_tangent_contacts():
    """MODEL 5.2 from first principles: the distal normal force balances the distal joint alone,
    F2 = r2 / k2; a proximal-only finger has F1 = r1 / k1 and needs no friction."""
    seen = set()
    for (res, _l1, r1, r2, _mu), out in zip(SAMPLE, sample_forces()):
        if not out["determined"]:
            continue
        normals = [f @ (rot90(np.array([math.cos(a), math.sin(a)])))
                   for (c, f), a in zip(out["contacts"], link_angles(res))]
        if res["mode"] == PROXIMAL_ONLY:
            assert normals[0] == pytest.approx(r1 / res["k1"], rel=1e-9)
            assert out["mu"] == [0.0]
        elif res["mode"] == TWO_PHALANX:
            assert normals[1] == pytest.approx(r2 / res["k2"], rel=1e-9)
            assert out["mu"][0] == 0.0          # no moment: least |mu| is 0
        seen.add(res["mode"])
    assert {PROXIMAL_ONLY, TWO_PHALANX} <= seen


def link_angles(res):
    angles = []
    if res["mode"] in (PROXIMAL_ONLY, TWO_PHALANX):
        angles.append(res["t1"])
    if res["mode"] in (TWO_PHALANX, DISTAL_ONLY):
        angles.append(res["t1"] + res["t2"])
    return angles


def test_undetermined_rule_counts_contacts_and_stops():
    # Proximal link flat on the palm row (t1 = 0) with the distal on its upper stop: 1 + 2 > 2.
    res = {"mode": PROXIMAL_ONLY, "t1": 0.0, "t2": THETA2_MAX, "k1": 0.5, "k2": 0.0}
    assert not finger_forces(res, 1.0, 0.1, 0.05, 0.4)["determined"]
    res = {"mode": PROXIMAL_ONLY, "t1": 0.3, "t2": THETA2_MAX, "k1": 0.5, "k2": 0.0}
    out = finger_forces(res, 1.0, 0.1, 0.05, 0.4)
    assert out["determined"] and out["stops"][2] == pytest.approx(-0.05)


def test_value_maps_are_mirror_symmetric(scenario_a, scenario_b):
    # Symmetric designs; command sets closed under swapping the fingers.
    for res in (scenario_a, scenario_b):
        np.testing.assert_array_equal(res["n_forces"], res["n_forces"][:, ::-1])
        np.testing.assert_allclose(res["values"], res["values"][:, ::-1], rtol=1e-9, atol=1e-13)
        assert res["total"] > 0 and res["inadmissible"] == []
        assert res["total_h2"] == pytest.approx(res["total"] * H * H)


def test_scenario_a_equals_its_two_extreme_commands(scenario_a):
    """MODEL 10: each geometry's forces lie on a segment; only 0.2 and 1.8 can be vertices."""
    extremes = naive_metric(GEOMETRIES, PART, H, [SCENARIO_A_COMMANDS[0], SCENARIO_A_COMMANDS[-1]])
    np.testing.assert_allclose(extremes["values"], scenario_a["values"], rtol=1e-9, atol=1e-13)
    np.testing.assert_allclose(extremes["usage"], scenario_a["usage"])


def test_explicit_poses_give_the_same_values(scenario_a):
    poses, (n, _) = world_lattice(GEOMETRIES, PART[0], H)
    pick = [p for k, p in enumerate(poses) if scenario_a["values"].ravel()[k] > 0][:3]
    pick.append((0, 0))
    res = naive_metric(GEOMETRIES, PART, H, SCENARIO_A_COMMANDS, poses=pick)
    for (i, j), value in zip(pick, res["values"]):
        assert value == scenario_a["values"][j, i + n]


@pytest.mark.parametrize("scenario", ["scenario_a", "scenario_b"])
def test_hull_reduction_on_reference_forces(scenario, request):
    """The reduction kernel, fed the reference's counted forces geometry by geometry (each
    geometry's commands as separate adds), gives the reference's values and usage."""
    ref = request.getfixturevalue(scenario)
    n_poses = len(ref["poses"])
    red = IncrementalHull.empty(n_poses)
    per_geometry = {}
    for k, (owners, forces) in enumerate(ref["forces"]):
        for g in np.unique(owners):
            per_geometry.setdefault(g, []).append((k, forces[owners == g]))
    for g in sorted(per_geometry):
        n_cmd = max(len(f) for _, f in per_geometry[g])
        for c in range(n_cmd):
            fx, fy, counts = np.zeros(n_poses), np.zeros(n_poses), np.zeros(n_poses, dtype=bool)
            for k, forces in per_geometry[g]:
                fx[k], fy[k], counts[k] = forces[c, 0], forces[c, 1], True
            red.add(fx, fy, counts, int(g), np.array(GEOMETRIES[g]))
    np.testing.assert_allclose(red.values(), ref["values"].ravel(), rtol=1e-9, atol=1e-13)
    np.testing.assert_allclose(red.parameter_usage(PAPER_SEARCH_RANGES), ref["usage"],
                               rtol=1e-12)


@pytest.mark.parametrize("scenario, commands", [("scenario_a", SCENARIO_A_COMMANDS),
                                                ("scenario_b", SCENARIO_B_COMMANDS)])
def test_add_geometry_combines_the_commands(scenario, commands, request):
    """add_geometry with the per-finger resultants of every pose = the reference metric."""
    ref = request.getfixturevalue(scenario)
    n_poses = len(ref["poses"])
    red = IncrementalHull.empty(n_poses)
    for g, geometry in enumerate(GEOMETRIES):
        f_left, f_right = np.zeros((n_poses, 2)), np.zeros((n_poses, 2))
        counts = np.zeros(n_poses, dtype=bool)
        for k, (i, j) in enumerate(ref["poses"]):
            pf = pose_forces(geometry, PART, i, j, H)
            f_left[k], f_right[k], counts[k] = pf["f_left"], pf["f_right"], pf["counts"]
        red.add_geometry(f_left, f_right, counts, commands, g, geometry)
    np.testing.assert_allclose(red.values(), ref["values"].ravel(), rtol=1e-9, atol=1e-13)
    np.testing.assert_allclose(red.parameter_usage(), ref["usage"], rtol=1e-12)
