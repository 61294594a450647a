"""Cutting an ordered list of items into contiguous index ranges: the one rule. Pure functions.

A range is a half-open ``(start, stop)`` pair. The rule, here only: cut `n` items into ranges
of equal count (`even_ranges`: sizes differ by at most one, the larger ones first) or of equal
summed cost (`balanced_boundaries`: each cut nearest its share of the total, on an exact tie
after the item that crosses it, so that here too the earlier range is the larger one).
Cluster chunks and sub-chunks of work items use it (this module), and so do the ranges of rows
or cells the compute layer runs on threads (`sweep.compute.threads`).

Work items are numbered so that those sharing finger geometry form contiguous *groups* of equal
size (`sweep.config.scene.ITEM_ORDER`). Cluster chunks are runs of whole groups whenever there are
at least as many groups as chunks, balanced by an estimated cost per group; sub-chunks (the unit
a run writes to disk) never straddle a group boundary.
"""
from __future__ import annotations

from collections.abc import Sequence

import numpy as np

Range = tuple[int, int]


def even_ranges(n_items: int, n_ranges: int) -> list[Range]:
    """`n_ranges` contiguous non-empty ranges covering 0..n_items, sizes differing by at most one
    (the larger ones first)."""
    if n_ranges < 1:
        raise ValueError(f"number of ranges must be >= 1, got {n_ranges}")
    if n_ranges > n_items:
        raise ValueError(f"cannot cut {n_items} items into {n_ranges} non-empty ranges")
    q, rem = divmod(n_items, n_ranges)
    out, start = [], 0
    for k in range(n_ranges):
        stop = start + q + (1 if k < rem else 0)
        out.append((start, stop))
        start = stop
    return out


def balanced_boundaries(costs: Sequence[float], n_ranges: int) -> list[int]:
    """Cut points 0 = b0 < b1 < ... < bn = len(costs) that split `costs` into `n_ranges`
    contiguous non-empty runs whose sums are close to equal: b_k is where the running sum is
    nearest to k/n of the total, after the item that crosses it when both are as near (kept
    strictly increasing, leaving one item for every later run); `even_ranges`' cuts when every
    cost is 0."""
    n = len(costs)
    if n_ranges < 1:
        raise ValueError(f"number of ranges must be >= 1, got {n_ranges}")
    if n_ranges > n:
        raise ValueError(f"cannot cut {n} items into {n_ranges} non-empty ranges")
    c = np.asarray(costs, dtype=np.float64)
    if c.size and (not np.all(np.isfinite(c)) or np.any(c < 0)):
        raise ValueError("costs must be finite and >= 0")
    cum = np.concatenate([[0.0], np.cumsum(c)])
    total = cum[-1]
    if total <= 0:
        return [b for b, _ in even_ranges(n, n_ranges)] + [n]
    bounds = [0]
    for k in range(1, n_ranges):
        target = total * k / n_ranges
        j = int(np.searchsorted(cum, target))          # cum[j-1] < target <= cum[j]
        if j > 0 and target - cum[j - 1] < cum[j] - target:   # nearer to the previous cut
            j -= 1
        j = max(j, bounds[-1] + 1)
        j = min(j, n - (n_ranges - k))
        bounds.append(j)
    bounds.append(n)
    return bounds


def ranges_between(bounds: Sequence[int]) -> list[Range]:
    """The ranges between consecutive cut points."""
    return [(int(a), int(b)) for a, b in zip(bounds[:-1], bounds[1:])]


def chunk_ranges(n_items: int, n_chunks: int, group_size: int = 1,
                 group_costs: Sequence[float] | None = None) -> list[Range]:
    """Item ranges of `n_chunks` cluster chunks.

    With at least `n_chunks` groups, every chunk is a run of whole groups (balanced by
    `group_costs` when given, else by group count). With fewer groups than chunks the items are
    cut evenly, splitting groups.
    """
    if group_size < 1 or n_items % group_size:
        raise ValueError(f"group size {group_size} does not divide {n_items} items")
    n_groups = n_items // group_size
    if n_chunks > n_items:
        raise ValueError(f"{n_chunks} chunks for {n_items} work items: at most {n_items} chunks")
    if n_chunks > n_groups:
        return even_ranges(n_items, n_chunks)
    if group_costs is None:
        gb = [b for b, _ in even_ranges(n_groups, n_chunks)] + [n_groups]
    else:
        if len(group_costs) != n_groups:
            raise ValueError(f"{len(group_costs)} group costs for {n_groups} groups")
        gb = balanced_boundaries(group_costs, n_chunks)
    return [(gb[k] * group_size, gb[k + 1] * group_size) for k in range(n_chunks)]


def sub_ranges(start: int, stop: int, size: int, group_size: int = 1) -> list[Range]:
    """Cut [start, stop) into runs of at most `size` items that never cross a multiple of
    `group_size` (a geometry-group boundary). Cuts depend on absolute item indices only."""
    if size < 1:
        raise ValueError(f"sub-chunk size must be >= 1, got {size}")
    if group_size < 1:
        raise ValueError(f"group size must be >= 1, got {group_size}")
    out = []
    s = start
    while s < stop:
        group_end = (s // group_size + 1) * group_size
        e = min(s + size, group_end, stop)
        out.append((s, e))
        s = e
    return out


def missing_ranges(start: int, stop: int, done: Sequence[Range]) -> list[Range]:
    """The parts of [start, stop) not covered by any range in `done` (which may overlap or stick
    out of [start, stop))."""
    out = []
    s = start
    for a, b in sorted(done):
        if b <= s or a >= stop:
            continue
        if a > s:
            out.append((s, a))
        s = max(s, b)
        if s >= stop:
            break
    if s < stop:
        out.append((s, stop))
    return out


def exact_cover(start: int, stop: int, ranges: Sequence[Range]) -> list[int] | None:
    """Indices (into `ranges`) of non-overlapping ranges that tile [start, stop) exactly, chosen
    in start order (first found wins on a tie); None when no such tiling exists greedily."""
    order = sorted(range(len(ranges)), key=lambda i: (ranges[i][0], -ranges[i][1]))
    chosen, s = [], start
    for i in order:
        a, b = ranges[i]
        if a == s and b > a and b <= stop:
            chosen.append(i)
            s = b
    return chosen if s == stop else None
