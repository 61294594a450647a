"""The compute layer's parallel loops: ranges of rows or cells on several threads.

The kernels' drivers (`one_map.finger_rows`, `many_maps.summarize_cells`) release the GIL and
work on a range `first .. last - 1`; `over_ranges` runs consecutive ranges on Numba's thread
count (`numba.get_num_threads()`, set by `numba_threads`), each thread taking the next
range as it finishes one (ranges differ in cost: the part's reach, trajectories). Each range
writes only its own rows, so the results do not depend on the split or the thread count.

Python threads rather than a `prange` loop: a parallel loop compiles its whole call tree twice
more (its body as a separate function, and once with an unsigned index), a third of the cold
compilation of the kernels (docs/performance.md).
"""
from __future__ import annotations

import concurrent.futures
import contextlib
from typing import Callable

import numba
import numpy as np

from ..config.chunks import balanced_boundaries, even_ranges, ranges_between
from ..model import ModelInputError

#: Ranges per thread: enough for the threads to finish together, few enough that a range's
#: set-up (a shared finger field, a memo of meetings) is amortised.
RANGES_PER_THREAD = 4


def check_threads(n: int) -> None:
    """Refuse a thread count this machine cannot run (ModelInputError: a user's --threads or
    SLURM_CPUS_PER_TASK)."""
    if not 1 <= n <= numba.config.NUMBA_NUM_THREADS:
        raise ModelInputError(f"threads must be between 1 and {numba.config.NUMBA_NUM_THREADS} "
                              f"(this machine's cores), got {n}")


@contextlib.contextmanager
def numba_threads(n: int | None):
    """Set Numba's thread count for the block (None: leave Numba's default, every core), restore
    it after. The drivers' ranges run on `numba.get_num_threads()` threads (over_ranges)."""
    old = numba.get_num_threads()
    if n is not None:
        check_threads(n)
        numba.set_num_threads(n)
    try:
        yield numba.get_num_threads()
    finally:
        numba.set_num_threads(old)


def split(n: int, n_ranges: int) -> list[tuple[int, int]]:
    """At most `n_ranges` consecutive non-empty ranges (first, last) covering 0 .. n - 1, as equal
    as they come (`config.chunks.even_ranges`, the one rule)."""
    return even_ranges(n, min(max(n_ranges, 1), n)) if n > 0 else []


def split_by_cost(costs, n_ranges: int) -> list[tuple[int, int]]:
    """At most `n_ranges` consecutive non-empty ranges (first, last) covering 0 .. len(costs) - 1
    whose summed costs are as equal as whole items allow (`config.chunks.balanced_boundaries`,
    the one rule: cut k nearest k / n_ranges of the total)."""
    costs = np.asarray(costs, dtype=np.float64).reshape(-1)
    if costs.size == 0:
        return []
    return ranges_between(balanced_boundaries(costs, min(max(n_ranges, 1), costs.size)))


def over_ranges(n: int, task: Callable[[int, int], None],
                ranges_per_thread: int = RANGES_PER_THREAD, costs=None) -> None:
    """Call `task(first, last)` for consecutive ranges covering 0 .. n - 1, on Numba's thread
    count of threads (in this thread when it is 1); with `costs` (one per item), ranges of
    equal summed cost. An exception in a task is raised here once every task has stopped."""
    threads = numba.get_num_threads()
    n_ranges = threads * ranges_per_thread
    ranges = split(n, n_ranges) if costs is None else split_by_cost(costs, n_ranges)
    if threads == 1 or len(ranges) <= 1:
        for first, last in ranges:
            task(first, last)
        return
    with concurrent.futures.ThreadPoolExecutor(max_workers=threads) as pool:
        futures = [pool.submit(task, first, last) for first, last in ranges]
        try:
            for future in futures:
                future.result()
        except BaseException:
            for future in futures:
                future.cancel()  # (ranges running finish; the others do not start)
            raise
