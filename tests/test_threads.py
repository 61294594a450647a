"""The compute layer's parallel loops (sweep/compute/threads.py): ranges cover every row or cell
once, an error in a thread reaches the caller, and results do not depend on the thread count or
the split (bit for bit)."""
from __future__ import annotations

import threading

import numpy as np
import pytest
from hypothesis import given, strategies as st

from sweep.compute.batch import summarize_cells
from sweep.compute.threads import numba_threads
from sweep.compute.maps import compute_map
from sweep.compute.threads import over_ranges, split, split_by_cost
from sweep.config.chunks import balanced_boundaries, ranges_between
from sweep.model import Accuracy, Command, Design, Effects, Grid, Limits, Part


@given(st.integers(0, 500), st.integers(1, 64))
def test_split_covers_every_index_once_in_order(n, n_ranges):
    ranges = split(n, n_ranges)
    covered = [i for a, b in ranges for i in range(a, b)]
    assert covered == list(range(n))
    assert all(b > a for a, b in ranges) and len(ranges) <= max(n_ranges, 1)
    if n:
        sizes = [b - a for a, b in ranges]
        assert max(sizes) - min(sizes) <= 1


@given(st.lists(st.floats(0.0, 1e6), max_size=300), st.integers(1, 16))
def test_split_by_cost_covers_every_index_once_and_balances(costs, n_ranges):
    ranges = split_by_cost(costs, n_ranges)
    covered = [i for a, b in ranges for i in range(a, b)]
    assert covered == list(range(len(costs)))
    assert all(b > a for a, b in ranges) and len(ranges) <= max(min(n_ranges, len(costs)), 1)
    if costs:
        # each range holds at most its share of the total plus one item
        share = sum(costs) / min(n_ranges, len(costs))
        assert all(sum(costs[a:b]) <= share + max(costs[a:b]) + 1e-6 * share
                   for a, b in ranges)


def test_split_by_cost_cuts_nearest_the_share():
    assert split_by_cost([1, 1, 1, 100, 1, 1], 2) == [(0, 3), (3, 6)]
    assert split_by_cost([100, 1, 1, 1], 2) == [(0, 1), (1, 4)]
    assert split_by_cost([1] * 10, 3) == [(0, 3), (3, 7), (7, 10)]


def test_threads_cut_ranges_by_the_chunks_rule():
    """One rule for cutting items into ranges (sweep/config/chunks.py): on an exact tie the cut
    goes after the item that crosses the share, and equal counts put the larger ranges first,
    as for cluster chunks."""
    assert split_by_cost([1, 2, 1], 2) == [(0, 2), (2, 3)]          # both cuts 1 from the share
    assert split(5, 2) == [(0, 3), (3, 5)]
    for costs, n_ranges in (([3, 1, 4, 1, 5, 9, 2, 6], 3), ([0, 0, 0], 2), ([1, 2, 1], 2)):
        cuts = balanced_boundaries(costs, n_ranges)
        assert split_by_cost(costs, n_ranges) == ranges_between(cuts)


def test_every_range_runs_once_on_several_threads():
    seen, names = [], set()
    lock = threading.Lock()

    def task(first, last):
        with lock:
            seen.extend(range(first, last))
            names.add(threading.current_thread().name)

    with numba_threads(2):
        over_ranges(37, task)
    assert sorted(seen) == list(range(37))


def test_an_error_in_a_thread_reaches_the_caller():
    def task(first, last):
        if first <= 20 < last:
            raise ValueError("cell 20")

    with numba_threads(2), pytest.raises(ValueError, match="cell 20"):
        over_ranges(37, task)


@pytest.mark.parametrize("effects", [Effects(), Effects(finger_collision=True)],
                         ids=["base", "collision"])
def test_sweep_and_map_are_the_same_on_one_thread_and_two(effects):
    cells = np.array([[2.0, 1.6, r1, r2, 0.4, mu] for r1, r2, mu in
                      [(0.2, 0.14, 0.4), (0.12, 0.06, 0.1), (0.04, 0.1, 1.0)]]
                     + [[1.2, 0.8, 0.08, 0.1, 0.8, 0.4]])
    widths = np.array([0.0, 0.8])
    out = {}
    for threads in (1, 2):
        with numba_threads(threads):
            out[threads] = (
                summarize_cells(cells, widths, Command(), 0.2, Limits(), Accuracy(), effects),
                compute_map(Design(2.0, 1.6, 0.2, 0.14, 0.8), Part(0.4, 0.4), grid=Grid(h=0.2),
                            effects=effects).fields)
    assert np.array_equal(out[1][0], out[2][0], equal_nan=True)
    assert out[1][0][:, :, 0].any()   # (the maps were computed: some Lambda is not 0)
    for name, field in out[1][1].items():
        assert np.array_equal(field, out[2][1][name], equal_nan=True), name
