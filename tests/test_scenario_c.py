"""Scenario C, friction modulation (MODEL 10): A's gripper whose fingers each switch between the
part's mu_s and a low friction mu_low; per pose, the hull over every width, command and friction
pair (mu_left, mu_right) in {mu_low, mu_s}^2, the palm keeping mu_s.

Against the slow reference tests/naive_manipulation.py (naive fingers, LP statics, Qhull) with
per-finger friction; with finger_collision, against the maps of each friction pair
(`compute_map(mu_left=, mu_right=)`, the map pipeline's own collisions) reduced in plain Python;
and by what C must be: A exactly when mu_low = mu_s, at least A always (a superset of forces)."""
from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from naive_manipulation import (SCENARIO_A_COMMANDS, hull_value, naive_metric,
                                scenario_c_frictions, world_lattice)
from strategies import paper_table_designs
from sweep.compute.batch import manipulation_cells
from sweep.compute.maps import compute_map
from sweep.grid import SCENARIO_A_EXTREMES
from sweep.model import (REACHED, Accuracy, Command, Design, Effects, Grid, Limits, Outputs,
                         Part)

H = 0.2


def kernel_metrics(candidate, part, widths, h=H, mu_low=0.0, effects=Effects()):
    """(A, C) of one candidate (l1, l2, r1, r2) and part (r, mu) through the sweep's cell."""
    geometries = [(w, *candidate) for w in widths]
    n_col = world_lattice(geometries, part[0], h)[1][0]
    _, chunk = manipulation_cells(np.array([[*candidate, *part]]), np.array(widths), h,
                                  Limits(), Accuracy(), effects, np.array([0]),
                                  np.array([[0, 0]]), np.array([n_col]), mu_low=mu_low)
    return float(chunk.a_metric[0]), float(chunk.c_metric[0])


@pytest.mark.parametrize("candidate, part, mu_low, widths", [
    ((0.8, 0.8, 0.16, 0.06), (0.8, 1.0), 0.0, (0.0,)),
    ((1.2, 0.4, 0.16, 0.02), (0.8, 0.4), 0.0, (0.0, 0.4)),
    ((1.2, 1.2, 0.04, 0.10), (0.4, 1.0), 0.1, (0.4, 1.2)),
    ((0.8, 0.8, 0.16, 0.06), (0.8, 0.1), 0.7, (0.0,)),       # mu_low above the part's mu
], ids=["short-fingers", "short-distal", "mu_low-0.1", "mu_low-above-mu"])
def test_scenario_c_of_a_candidate_matches_the_reference(candidate, part, mu_low, widths):
    geometries = [(w, *candidate) for w in widths]
    a_ref = naive_metric(geometries, part, H, SCENARIO_A_COMMANDS)
    c_ref = naive_metric(geometries, part, H, SCENARIO_A_COMMANDS,
                         frictions=scenario_c_frictions(mu_low, part[1]))
    a, c = kernel_metrics(candidate, part, widths, mu_low=mu_low)
    assert c_ref["total"] > a_ref["total"]   # the case shows modulation doing something
    assert a == pytest.approx(a_ref["total"], rel=1e-9, abs=1e-12)
    assert c == pytest.approx(c_ref["total"], rel=1e-9, abs=1e-12)


CELLS = st.tuples(paper_table_designs(), st.sets(st.integers(0, 5), min_size=1, max_size=3))


@settings(max_examples=15)
@given(CELLS)
def test_scenario_c_with_mu_low_equal_to_mu_is_scenario_a_exactly(cell):
    (l1, l2, r1, r2, _, r, mu), ws = cell
    widths = tuple(0.4 * k for k in sorted(ws))
    a, c = kernel_metrics((l1, l2, r1, r2), (r, mu), widths, h=H, mu_low=mu)
    assert c == a     # bit for bit


@pytest.mark.parametrize("collision", [False, True], ids=["base", "collision"])
@settings(max_examples=15)
@given(cell=CELLS, mu_low=st.sampled_from([0.0, 0.1, 0.5]))
def test_scenario_c_is_never_below_scenario_a(collision, cell, mu_low):
    (l1, l2, r1, r2, _, r, mu), ws = cell
    widths = tuple(0.4 * k for k in sorted(ws))
    a, c = kernel_metrics((l1, l2, r1, r2), (r, mu), widths, h=H, mu_low=mu_low,
                          effects=Effects(finger_collision=collision))
    assert c >= a


def pair_map_metric(candidate, part, widths, mu_low, effects, h):
    """Scenario C from whole maps: for each width and friction pair the map of
    `compute_map(mu_left=, mu_right=)` with its forces, the count rule of MODEL 10 read from its
    fields (reached, off the palm, not in equilibrium, S_geo > 0, both fingers' forces
    determined), every pose's forces under A's extreme commands hulled by Qhull."""
    forces: dict = {}
    for w in widths:
        for mu_l, mu_r in scenario_c_frictions(mu_low, part[1]):
            m = compute_map(Design(*candidate, w), Part(*part), Command(), Grid(h=h), Limits(),
                            Accuracy(), effects, outputs=Outputs(forces=True), mu_left=mu_l,
                            mu_right=mu_r)
            f = m.fields
            on_palm = ((np.abs(m.y - part[0]) <= 1e-9)[:, None]
                       & (np.abs(m.x) <= 0.5 * w + 1e-9)[None, :])
            counted = ((f["point_class"] == REACHED) & ~f["equilibrium"] & ~on_palm
                       & (f["geometric_cage_score"] > 0) & f["forces_determined"].all(axis=0))
            for j, i in np.argwhere(counted):
                s = f["geometric_cage_score"][j, i]
                left = np.array([f["resultant_force_x"][0, j, i], f["resultant_force_y"][0, j, i]])
                right = np.array([f["resultant_force_x"][1, j, i],
                                  f["resultant_force_y"][1, j, i]])
                pose = (j, int(round(m.x[i] / h)))
                for f_left in SCENARIO_A_EXTREMES:
                    forces.setdefault(pose, []).append(
                        (f_left * left + (2.0 - f_left) * right) * s)
    return sum(hull_value(points)[0] for points in forces.values())


@pytest.mark.parametrize("candidate, part, mu_low", [
    ((2.0, 1.6, 0.16, 0.10), (0.4, 0.7), 0.0),      # with finger_collision: 0 (crossed poses)
    ((2.0, 1.6, 0.20, 0.14), (0.8, 1.0), 0.1),
    ((1.6, 0.8, 0.16, 0.14), (0.4, 0.4), 0.0),
    ((1.6, 1.2, 0.16, 0.14), (0.8, 0.7), 0.0),      # with finger_collision: A 0, C positive
])
@pytest.mark.parametrize("collision", [False, True], ids=["base", "collision"])
def test_scenario_c_matches_the_maps_of_each_friction_pair(candidate, part, mu_low, collision):
    """The cell's pairs are their maps' (finger_collision included: the map pipeline resolves
    the whole map, the cell only the crossed poses it counts, hand.collide)."""
    widths = (0.0, 0.8, 1.6)
    effects = Effects(finger_collision=collision)
    _, c = kernel_metrics(candidate, part, widths, h=0.1, mu_low=mu_low, effects=effects)
    ref = pair_map_metric(candidate, part, widths, mu_low, effects, 0.1)
    assert ref > 0 or (collision and candidate[0] == 2.0 and part[0] == 0.4)
    assert c == pytest.approx(ref, rel=1e-9, abs=1e-12)
