"""Chunking is pure: table tests of the cuts, and properties every cut must have."""
import pytest
from hypothesis import given
from hypothesis import strategies as st

from sweep.config.chunks import (
    balanced_boundaries, chunk_ranges, even_ranges, exact_cover, missing_ranges, sub_ranges,
)


@pytest.mark.parametrize("n_items, n_ranges, expected", [
    pytest.param(1, 1, [(0, 1)], id="one-item"),
    pytest.param(5, 5, [(0, 1), (1, 2), (2, 3), (3, 4), (4, 5)], id="chunk-size-1"),
    pytest.param(10, 3, [(0, 4), (4, 7), (7, 10)], id="uneven"),
    pytest.param(12, 4, [(0, 3), (3, 6), (6, 9), (9, 12)], id="even"),
])
def test_even_ranges(n_items, n_ranges, expected):
    assert even_ranges(n_items, n_ranges) == expected


@pytest.mark.parametrize("n_items, n_ranges", [
    pytest.param(3, 4, id="more-ranges-than-items"),
    pytest.param(3, 0, id="zero-ranges"),
])
def test_even_ranges_refuses(n_items, n_ranges):
    with pytest.raises(ValueError):
        even_ranges(n_items, n_ranges)


@pytest.mark.parametrize("n_items, n_chunks, group, costs, expected", [
    pytest.param(1, 1, 1, None, [(0, 1)], id="one-item"),
    pytest.param(12, 3, 4, None, [(0, 4), (4, 8), (8, 12)], id="one-group-per-chunk"),
    pytest.param(20, 3, 4, None, [(0, 8), (8, 16), (16, 20)], id="uneven-last-chunk"),
    pytest.param(8, 8, 4, None, [(k, k + 1) for k in range(8)], id="chunk-size-1-splits-groups"),
    pytest.param(12, 2, 2, [1, 1, 1, 1, 1, 5], [(0, 10), (10, 12)], id="balanced-by-cost"),
    pytest.param(12, 2, 2, [5, 1, 1, 1, 1, 1], [(0, 2), (2, 12)], id="heavy-first-group"),
    pytest.param(6, 3, 2, [0, 0, 0], [(0, 2), (2, 4), (4, 6)], id="zero-costs-fall-back"),
])
def test_chunk_ranges(n_items, n_chunks, group, costs, expected):
    assert chunk_ranges(n_items, n_chunks, group, costs) == expected


def test_chunk_ranges_refuses_more_chunks_than_items():
    with pytest.raises(ValueError, match="at most 4"):
        chunk_ranges(4, 5, 2)


@pytest.mark.parametrize("start, stop, size, group, expected", [
    pytest.param(0, 1, 5, 1, [(0, 1)], id="one-item"),
    pytest.param(0, 3, 1, 3, [(0, 1), (1, 2), (2, 3)], id="size-1"),
    pytest.param(0, 10, 4, 100, [(0, 4), (4, 8), (8, 10)], id="uneven-last"),
    pytest.param(0, 12, 100, 4, [(0, 4), (4, 8), (8, 12)], id="never-across-groups"),
    pytest.param(2, 9, 3, 4, [(2, 4), (4, 7), (7, 8), (8, 9)], id="gap-inside-groups"),
    pytest.param(5, 5, 3, 4, [], id="empty"),
])
def test_sub_ranges(start, stop, size, group, expected):
    assert sub_ranges(start, stop, size, group) == expected


@pytest.mark.parametrize("done, expected", [
    pytest.param([], [(0, 10)], id="nothing-done"),
    pytest.param([(0, 10)], [], id="all-done"),
    pytest.param([(0, 3), (6, 8)], [(3, 6), (8, 10)], id="holes"),
    pytest.param([(6, 8), (0, 3)], [(3, 6), (8, 10)], id="unsorted"),
    pytest.param([(0, 5), (3, 7)], [(7, 10)], id="overlapping"),
    pytest.param([(-5, 2), (9, 20)], [(2, 9)], id="sticking-out"),
])
def test_missing_ranges(done, expected):
    assert missing_ranges(0, 10, done) == expected


@pytest.mark.parametrize("ranges, expected", [
    pytest.param([(0, 4), (4, 10)], [0, 1], id="tiles"),
    pytest.param([(4, 10), (0, 4)], [1, 0], id="unsorted"),
    pytest.param([(0, 4), (5, 10)], None, id="hole"),
    pytest.param([(0, 4), (0, 4), (4, 10)], [0, 2], id="duplicate-ignored"),
    pytest.param([(0, 12)], None, id="too-long"),
])
def test_exact_cover(ranges, expected):
    assert exact_cover(0, 10, ranges) == expected


@given(n_items=st.integers(1, 200), n_chunks=st.integers(1, 40), group=st.integers(1, 9),
       data=st.data())
def test_chunks_tile_the_items(n_items, n_chunks, group, data):
    n_items *= group
    if n_chunks > n_items:
        return
    costs = data.draw(st.one_of(st.none(), st.lists(st.floats(0, 100), min_size=n_items // group,
                                                    max_size=n_items // group)))
    ranges = chunk_ranges(n_items, n_chunks, group, costs)
    assert len(ranges) == n_chunks
    assert ranges[0][0] == 0 and ranges[-1][1] == n_items
    assert all(a < b for a, b in ranges)                       # non-empty
    assert all(ranges[k][1] == ranges[k + 1][0] for k in range(n_chunks - 1))  # contiguous
    if n_chunks <= n_items // group:                             # whole groups only
        assert all(a % group == 0 and b % group == 0 for a, b in ranges)


@given(costs=st.lists(st.floats(0.5, 10), min_size=2, max_size=60), n=st.integers(1, 8))
def test_balanced_split_is_never_worse_than_counting(costs, n):
    if n > len(costs):
        return
    b = balanced_boundaries(costs, n)
    heaviest = max(sum(costs[b[k]:b[k + 1]]) for k in range(n))
    even = [s for s, _ in even_ranges(len(costs), n)] + [len(costs)]
    heaviest_even = max(sum(costs[even[k]:even[k + 1]]) for k in range(n))
    # nearest-to-target cuts: each range exceeds its share by at most one item's cost
    assert heaviest <= sum(costs) / n + 2 * max(costs) + 1e-9
    assert heaviest <= heaviest_even + 2 * max(costs) + 1e-9
