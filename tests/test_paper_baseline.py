"""Fast checks of the paper-style baseline (scripts/paper_baseline.py) on analytic cases of
docs/model.md.

The expected values are computed here by hand from MODEL 3 closed forms; the baseline itself only
uses least squares on the vector-loop equations.
"""
import importlib.util
import math
from pathlib import Path

import numpy as np
import pytest

from sweep import model as M

_PATH = Path(__file__).resolve().parents[1] / "scripts" / "paper_baseline.py"
_spec = importlib.util.spec_from_file_location("paper_baseline", _PATH)
pb = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(pb)

TMIN, TMAX = math.radians(-5.0), math.radians(90.0)
L1, L2, R1, R2, R, MU = 2.0, 1.6, 0.2, 0.14, 0.4, 0.4


def test_proximal_only_matches_closed_form():
    # Part near the proximal joint: proximal tangency valid, distal tangency beyond theta2_max.
    dx, dy = 0.5, 0.6
    k1 = math.sqrt(dx * dx + dy * dy - R * R)                 # MODEL 3.1
    t1 = math.atan2(dy, dx) - math.atan2(R, k1)
    mode, bt1, bt2, bk1, bk2 = pb.baseline_finger(dx, dy, L1, L2, R1, R2, R, MU, TMIN, TMAX)
    assert mode == M.PROXIMAL_ONLY
    assert bt1 == pytest.approx(t1, abs=1e-9)
    assert bk1 == pytest.approx(k1, abs=1e-9)
    assert bt2 == TMAX and bk2 == 0.0
    assert pb.finger_energy(bt1, bt2, R1, R2, TMIN) == pytest.approx(
        -(R1 * t1 + R2 * (TMAX - TMIN)), abs=1e-9)


def test_two_phalanx_identity_and_stability():
    # Build a two-phalanx pose by hand: k2 = l1 - k1, t2 = pi - 2 atan2(r, k2) (MODEL 3.4).
    t1, k1 = 0.6, 1.7
    k2 = L1 - k1
    t2 = math.pi - 2 * math.atan2(R, k2)
    assert TMIN < t2 < TMAX
    dx = k1 * math.cos(t1) - R * math.sin(t1)
    dy = k1 * math.sin(t1) + R * math.cos(t1)
    g = R1 * k2 - R2 * (L1 * math.cos(t2) + k2) + MU * R2 * L1 * abs(math.sin(t2))
    assert g > 0  # case 1 or 3: stable
    mode, bt1, bt2, bk1, bk2 = pb.baseline_finger(dx, dy, L1, L2, R1, R2, R, MU, TMIN, TMAX)
    assert mode == M.TWO_PHALANX
    assert (bt1, bk1) == pytest.approx((t1, k1), abs=1e-8)
    assert bk2 == pytest.approx(L1 - bk1, abs=1e-8)
    assert bt2 == pytest.approx(t2, abs=1e-8)


def test_two_phalanx_lift_off_reconfigures_to_a_stop():
    # Same pose without friction: g < 0 (case 2), so the finger reconfigures (MODEL 5.3).
    t1, k1 = 0.6, 1.7
    dx = k1 * math.cos(t1) - R * math.sin(t1)
    dy = k1 * math.sin(t1) + R * math.cos(t1)
    mode, bt1, bt2, bk1, bk2 = pb.baseline_finger(dx, dy, L1, L2, R1, R2, R, 0.0, TMIN, TMAX,
                                                  root_tol=1e-10)
    assert mode in (M.DISTAL_ONLY, M.SLIPPED)
    assert bt1 < t1 and bk1 == 0.0
    # the distal link is still tangent to the part: distance from the centre to its line == r
    bx, by = L1 * math.cos(bt1), L1 * math.sin(bt1)
    phi = bt1 + bt2
    ex, ey = dx - bx, dy - by
    assert -math.sin(phi) * ex + math.cos(phi) * ey == pytest.approx(R, abs=1e-8)
    assert math.cos(phi) * ex + math.sin(phi) * ey == pytest.approx(bk2, abs=1e-8)
    g0 = R1 * bk2 - R2 * (L1 * math.cos(bt2) + bk2)
    if mode == M.DISTAL_ONLY:   # stopped where it can stick (mu = 0: g = 0) or at a joint stop
        assert abs(g0) < 1e-6 or bt2 >= TMAX - 1e-9 or bt1 == 0.0
    else:
        assert bk2 >= L2


def test_distal_only_first_contact_matches_rigid_sweep():
    # Distal link on its lower stop tangent to the part (MODEL 3.3), proximal out of reach.
    r2 = 0.02   # stable on the stop: g(mu*) >= 0
    t1, k2 = 0.5, 0.8
    phi = t1 + TMIN
    dx = L1 * math.cos(t1) + k2 * math.cos(phi) - R * math.sin(phi)
    dy = L1 * math.sin(t1) + k2 * math.sin(phi) + R * math.cos(phi)
    assert math.sqrt(dx * dx + dy * dy - R * R) > L1          # 3.1 invalid: k1 > l1
    mode, bt1, bt2, bk1, bk2 = pb.baseline_finger(dx, dy, L1, L2, R1, r2, R, MU, TMIN, TMAX)
    assert mode == M.DISTAL_ONLY
    assert (bt1, bt2, bk1, bk2) == pytest.approx((t1, TMIN, 0.0, k2), abs=1e-8)


def test_small_map_is_mirror_symmetric_and_classed():
    res = pb.baseline_map(L1, L2, R1, R2, 0.8, R, MU, h=0.4, xlim=(-1.2, 1.2), ylim=(0.4, 1.2))
    pc, e = res["point_class"], res["energy"]
    assert pc.shape == (3, 7) and res["n_points_solved"] == 21
    assert np.allclose(res["x"], 0.4 * np.arange(-3, 4)) and np.allclose(res["y"], [0.4, 0.8, 1.2])
    assert np.array_equal(pc, pc[:, ::-1])
    assert np.array_equal(np.isnan(e), pc == M.INFEASIBLE)
    feas = pc != M.INFEASIBLE
    assert np.array_equal(e[feas], e[:, ::-1][feas])          # exact: integer finger offsets
    assert np.array_equal(res["finger_mode"][0], res["finger_mode"][1][:, ::-1])
    assert set(np.unique(pc)) <= {M.INFEASIBLE, M.UNREACHED, M.EJECT, M.VERTEX_POINT, M.REACHED}
    # part centre on a finger base at the palm row: touching counts as feasible (MODEL 5.5)
    assert pc[0, 4] != M.INFEASIBLE
