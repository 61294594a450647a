"""The kernels' parameters come from one place: a cell row's columns are FingerModel's fields
(records.cell_finger, used by the sweep and by kernel_records), and the friction effect switched
off means frictionless contacts on every path (compute.layout.contact_friction)."""
import dataclasses

import numpy as np
from hypothesis import given, settings, strategies as st

from sweep.compute.batch import summarize_cells
from sweep.compute.layout import cells_as_kernels_read, kernel_records
from sweep.compute.maps import compute_map
from sweep.grid import CELL_COLUMNS
from sweep.model import Accuracy, Command, Design, Effects, Grid, Limits, Part

lengths = st.floats(0.05, 3.0)


@settings(max_examples=25, deadline=None)
@given(l1=lengths, l2=lengths, r1=st.floats(0.01, 0.3), r2=st.floats(0.01, 0.3),
       r=st.floats(0.05, 1.0), mu=st.floats(0.0, 2.0), friction=st.booleans())
def test_the_finger_record_holds_the_named_parameters(l1, l2, r1, r2, r, mu, friction):
    limits = Limits()
    effects = dataclasses.replace(Effects(), friction=friction)
    finger, _, _ = kernel_records(Design(l1, l2, r1, r2, 0.8), Part(r, mu), limits, Accuracy(),
                                  effects)
    assert (finger.l1, finger.l2, finger.r1, finger.r2, finger.r) == (l1, l2, r1, r2, r)
    assert finger.mu_s == (mu if friction else 0.0)
    assert (finger.theta2_min, finger.theta2_max) == (limits.theta2_min, limits.theta2_max)


def test_a_cell_row_reads_as_its_columns():
    row = np.array([[1.2, 0.8, 0.12, 0.1, 0.4, 0.6]])
    assert CELL_COLUMNS == ("l1", "l2", "r1", "r2", "r", "mu")
    off = dataclasses.replace(Effects(), friction=False)
    np.testing.assert_array_equal(cells_as_kernels_read(row, off)[0],
                                  [1.2, 0.8, 0.12, 0.1, 0.4, 0.0])
    np.testing.assert_array_equal(cells_as_kernels_read(row, Effects())[0], row[0])


def test_friction_switched_off_is_a_frictionless_part_on_every_path():
    """The sweep's cells and one map, friction off at mu = 0.6, equal the same at mu = 0."""
    off = dataclasses.replace(Effects(), friction=False)
    h, widths = 0.2, np.array([0.4, 0.8])
    cell = np.array([[1.2, 0.8, 0.12, 0.1, 0.4, 0.6]])
    frictionless = cell.copy()
    frictionless[0, 5] = 0.0
    np.testing.assert_array_equal(
        summarize_cells(cell, widths, Command(), h, Limits(), Accuracy(), off),
        summarize_cells(frictionless, widths, Command(), h, Limits(), Accuracy()))
    design = Design(1.2, 0.8, 0.12, 0.1, 0.8)
    a = compute_map(design, Part(0.4, 0.6), grid=Grid(h=h), effects=off)
    b = compute_map(design, Part(0.4, 0.0), grid=Grid(h=h))
    np.testing.assert_array_equal(a.fields["energy"], b.fields["energy"])
    assert a.attrs["Lambda"] == b.attrs["Lambda"]
