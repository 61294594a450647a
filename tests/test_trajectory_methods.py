"""Trajectory rules (MODEL 7, 8): the discrete tie order, the cone-hull tolerance, and the
continuous method (streamlines), on hand-built outcome arrays and on real maps."""
import math

import numpy as np
import pytest

import naive
from sweep.compute.batch import cell_map_fields, summarize_cells
from sweep.kernels.records import Hand, new_finger_arrays, new_outcome_arrays
from sweep.kernels.trajectories import trajectory_ends
from sweep.kernels.streamline import streamline_ends
from sweep.compute.layout import kernel_records
from sweep.compute.maps import compute_map
from sweep.model import (
    END_CAGED,
    END_EJECTION,
    END_STALLED,
    END_STATE_MEANINGS,
    REACHED,
    UNREACHED,
    Accuracy,
    Command,
    Design,
    Effects,
    Grid,
    Limits,
    Part,
)


def outcomes(energy, point_class=None, stable=(), scores=None):
    """Outcome arrays on energy's grid: every point REACHED unless told; `stable` lists (j, i)
    points in equilibrium and caged, with caging scores `scores` (default 1)."""
    ny, nx = energy.shape
    outs = new_outcome_arrays(ny, nx)
    outs.energy[:] = energy
    outs.point_class[:] = REACHED if point_class is None else point_class
    for name in ("equilibrium", "contained", "crossed", "caged"):
        getattr(outs, name)[:] = False
    outs.caging_score[:] = 0.0
    outs.l_open[:] = np.nan
    for n, (j, i) in enumerate(stable):
        outs.equilibrium[j, i] = outs.caged[j, i] = outs.contained[j, i] = True
        outs.caging_score[j, i] = 1.0 if scores is None else scores[n]
    return outs


def stack_for(outs):
    return np.empty(outs.energy.size, dtype=np.int64)


def grid8_ends(outs, h):
    """The grid8 rule on hand-built outcomes (it reads no model: the records are placeholders)."""
    finger, solver, blocks = kernel_records(Design(1.0, 1.0, 0.1, 0.1, 0.0), Part(0.4, 0.4),
                                            Limits(), Accuracy(trajectory="grid8"), Effects())
    ny, nx = outs.energy.shape
    xs, ys = np.arange(nx) * h, 0.4 + np.arange(ny) * h
    fingers = new_finger_arrays(2, ny, nx)     # one closing stage, no meeting: no step sampled
    fingers.first_event[:] = 0
    fingers.mode[:] = 0
    fingers.t1[:] = np.pi
    fingers.t2[:] = finger.theta2_max
    return trajectory_ends(outs, fingers, xs, ys, finger, solver, blocks,
                           Hand(0.0, 1.0, 1.0, h, finger.mu_s, finger.mu_s), stack_for(outs),
                           False)


# --- discrete method: ties go to the first of E, NE, N, NW, W, SW, S, SE (MODEL 8) -------------
def test_discrete_tie_goes_east_first():
    """Row energies [0, 1, 0]: from the middle, E and W are equally steep; MODEL 8 sends it E,
    so it ends at the east point and scores that point's 0.75 (W would score 0.25)."""
    outs = outcomes(np.array([[0.0, 1.0, 0.0]]), stable=[(0, 0), (0, 2)], scores=[0.25, 0.75])
    lam = grid8_ends(outs, 0.1)
    assert outs.end_index[0, 1] == 2
    assert lam == pytest.approx(0.25 + 0.75 + 0.75)


def test_discrete_tie_north_before_south():
    """Column energies [0, 1, 0] (j grows north): N comes before S in the order."""
    outs = outcomes(np.array([[0.0], [1.0], [0.0]]), stable=[(0, 0), (2, 0)], scores=[0.25, 0.75])
    grid8_ends(outs, 0.1)
    assert outs.end_index[1, 0] == 2  # flat index of (j=2, i=0) on a 1-wide grid


# --- cone-hull tolerance (MODEL 7: gap <= pi + GAP_TOL) ----------------------------------------
def test_cone_hull_tolerance_decides_equilibrium(monkeypatch):
    """w = 0.8000000002: the contact normals are antiparallel up to rounding, so the gap is pi
    plus a few ulps. The reference with the tolerance agrees with the kernels; the reference
    without it finds fewer equilibrium points, so the tolerance is what decides them."""
    args = dict(l1=1.0, l2=0.2, r1=0.12, r2=0.1, w=0.8000000002, r=0.4, mu=0.0)
    m = compute_map(Design(args["l1"], args["l2"], args["r1"], args["r2"], args["w"]),
                    Part(args["r"], args["mu"]), grid=Grid(h=0.05))
    with_tol = naive.naive_map(**args, h=0.05)
    assert np.array_equal(m.fields["equilibrium"], with_tol["equilibrium"])
    assert m.attrs["n_equilibrium"] == int(with_tol["equilibrium"].sum()) == 8
    monkeypatch.setattr(naive, "GAP_TOL", 0.0)
    without_tol = naive.naive_map(**args, h=0.05)
    assert int(without_tol["equilibrium"].sum()) < 8


# --- continuous method: streamlines on the interpolated energy ---------------------------------
def test_streamlines_in_a_bowl_end_at_its_bottom():
    n = 9
    j, i = np.mgrid[0:n, 0:n]
    outs = outcomes(((i - 4.0) ** 2 + (j - 4.0) ** 2) * 0.01, stable=[(4, 4)])
    lam = streamline_ends(outs, 0.1, stack_for(outs), 0.5)
    assert np.all(outs.end_state == END_CAGED)
    assert np.all(outs.end_index == 4 * n + 4)
    assert lam == n * n


def test_streamlines_down_a_tilted_plane_leave_p_j_in_their_row():
    """E = -x (plus a small pull towards the middle row): streamlines run east and leave P_j at
    the UNREACHED east column; the energy's jump there does not matter."""
    ny, nx = 5, 12
    j, i = np.mgrid[0:ny, 0:nx]
    cls = np.full((ny, nx), REACHED, dtype=np.int8)
    cls[:, -1] = UNREACHED
    outs = outcomes(-1.0 * i + 1e-3 * (j - 2.0) ** 2, point_class=cls)
    lam = streamline_ends(outs, 0.05, stack_for(outs), 0.5)
    assert lam == 0.0
    reached = cls == REACHED
    assert np.all(outs.end_state[reached] == END_EJECTION)
    end_i = outs.end_index[reached] % nx
    assert np.all(end_i == nx - 1)


@pytest.mark.parametrize("step", [0.5, 0.1, 0.02])
def test_streamlines_down_a_diagonal_plane_are_not_stalled_on_their_way(step):
    """E = -(x + y): streamlines run north-east, each cell's diagonal (sqrt 2 grid steps of
    travel near one grid point), and leave P_j at the UNREACHED last row or column, whatever
    the integrator's step. Travel near one grid point counts as circling only past STAY_LIMIT
    grid steps (found by mutation testing: a limit of one grid step went unnoticed, though it
    stalls every diagonal streamline whose step is below about 0.7)."""
    n = 8
    j, i = np.mgrid[0:n, 0:n]
    cls = np.full((n, n), REACHED, dtype=np.int8)
    cls[-1, :] = UNREACHED
    cls[:, -1] = UNREACHED
    outs = outcomes(-1.0 * (i + j), point_class=cls)
    lam = streamline_ends(outs, 0.05, stack_for(outs), step)
    reached = cls == REACHED
    assert lam == 0.0
    assert np.all(outs.end_state[reached] == END_EJECTION)
    # each ends on the diagonal it started on, where it meets the last row or column
    start_i, start_j = i[reached], j[reached]
    end_i, end_j = outs.end_index[reached] % n, outs.end_index[reached] // n
    last = np.minimum(n - 1 - start_i, n - 1 - start_j)
    assert np.all(end_i == start_i + last) and np.all(end_j == start_j + last)


def test_streamlines_stall_on_a_flat_energy():
    outs = outcomes(np.zeros((4, 5)))
    streamline_ends(outs, 0.1, stack_for(outs), 0.5)
    assert np.all(outs.end_state == END_STALLED)
    assert np.all(outs.end_index == np.arange(20).reshape(4, 5))


MAP = dict(design=Design(2.0, 1.6, 0.2, 0.14, 0.8), part=Part(0.4, 0.4))


def test_continuous_map_is_consistent_and_matches_the_sweep_path():
    """A real map with streamlines: end states in their set, counts add up, Lambda = sum of end
    scores, and the sweep's shared-field path gives the same summary and fields."""
    acc = Accuracy(trajectory="continuous")
    m = compute_map(MAP["design"], MAP["part"], grid=Grid(h=0.2), accuracy=acc)
    f, a = m.fields, m.attrs
    assert set(np.unique(f["end_state"])) <= set(range(len(END_STATE_MEANINGS)))
    assert a["n_caged"] + a["n_tip_prehension"] + a["n_ejection"] + a["n_stalled"] \
        == a["n_reached"]
    caged = f["end_state"] == END_CAGED
    lam = f["caging_score"].ravel()[f["end_index"][caged]].sum()
    assert a["Lambda"] == pytest.approx(lam)
    # the trapezoid across the palm line (model-notes D36): the first row counts half
    palm = f["caging_score"].ravel()[f["end_index"][0][caged[0]]].sum()
    assert math.isfinite(a["caging_area"])
    assert a["caging_area"] == pytest.approx((lam - 0.5 * palm) * 0.04)
    cell = (2.0, 1.6, 0.2, 0.14, 0.4, 0.4)
    rows = summarize_cells(np.array([cell]), np.array([0.8]), Command(), 0.2, Limits(), acc)
    from sweep.schema import SUMMARY_FIELDS

    # effect-only summary fields are absent from a map's attributes when the effect is off
    assert rows[0, 0].tolist() == pytest.approx([a.get(k, 0) for k in SUMMARY_FIELDS],
                                                nan_ok=True)
    _, _, sweep_fields, _ = cell_map_fields(cell, 0.8, Command(), 0.2, Limits(), acc)
    assert np.array_equal(sweep_fields["end_index"], f["end_index"])


def test_sliding_is_the_default_and_discrete_means_grid8():
    assert Accuracy().trajectory == "sliding"
    assert Accuracy(trajectory="discrete") == Accuracy(trajectory="grid8")
    m1 = compute_map(MAP["design"], MAP["part"], grid=Grid(h=0.2),
                     accuracy=Accuracy(trajectory="grid8"))
    m2 = compute_map(MAP["design"], MAP["part"], grid=Grid(h=0.2),
                     accuracy=Accuracy(trajectory="discrete"))
    assert np.array_equal(m1.fields["end_index"], m2.fields["end_index"])


def test_the_picture_draws_the_streamlines_the_map_ends_with(tmp_path):
    """For a continuous map the plot walks streamlines (not discrete paths), and each ends near
    the grid point the map's end_index names."""
    from sweep.report.plot import plot_map, streamline_points

    m = compute_map(MAP["design"], MAP["part"], grid=Grid(h=0.2),
                    accuracy=Accuracy(trajectory="continuous"))
    f = m.fields
    nx = m.x.size
    h = 0.2
    starts = np.flatnonzero((f["point_class"] == REACHED).ravel())
    for p in starts[::7]:
        pts = streamline_points(int(p), f["energy"], f["point_class"], f["equilibrium"],
                                f["caging_score"] > 0, m.x, m.y)
        end = f["end_index"].ravel()[p]
        j, i = divmod(int(end), nx)
        if f["end_state"].ravel()[p] != END_EJECTION or 0 < i < nx - 1:
            assert abs(pts[-1, 0] - m.x[i]) <= 0.5 * h + 1e-9
            assert abs(pts[-1, 1] - m.y[j]) <= 0.5 * h + 1e-9
    plot_map(m, tmp_path / "map.png")
    assert (tmp_path / "map.png").stat().st_size > 0
