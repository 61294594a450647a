"""The kernels compiled once, before the first computation needs them.

Numba compiles a kernel the first time it is called and caches it on disk (kernels/__init__.py:
the cache is keyed by the kernel sources). One compilation serves every scene: effects and
optional outputs are run-time switches of one kernel set. On a machine where that set is not in
the cache yet, `ensure_compiled` says so in one line and compiles every kernel a command calls,
through the same public functions and with the same argument types as a real run (a kernel
compiles once per argument types), in two processes at the same time: here one map and the
manipulation sweep (`compile_maps`), and in a second process finger_collision's search, the
summaries sweep and the manipulation metric's hull reductions (`compile_summaries`). Both
compile the finger's kernels (in a process of its own a kernel compiles with all it calls), so
the split balances the two: 56 s in this one against 17 s in the second, before the summaries
sweep moved there, 39 s and 39 s after (docs/performance.md). No kernel compiles with different
argument types in the two (two processes writing different signatures of one kernel could spoil
the cache's index: tests/test_compile_cold.py). It then leaves a marker in the cache, so the
next start only loads (about a second).

    python -m sweep.compute.warm [maps|summaries]     # what `ensure_compiled` runs
"""
from __future__ import annotations

import os
import subprocess
import sys
import time

import numpy as np

from .. import kernels
from ..model import Accuracy, Command, Design, Effects, Grid, Limits, Part

#: Cold compilation of every kernel, on the reference machine (docs/performance-log.md, "Cold
#: compilation"): what the one line says to expect.
COLD_SECONDS = 40
MARKER = "compiled"


def is_compiled() -> bool:
    """Whether this kernel set is in the cache (ensure_compiled ran to its end)."""
    return (kernels.cache_directory() / MARKER).exists()


def compile_maps() -> None:
    """One map (with and without forces), the sweep's cells with the manipulation metric, one
    map the sweep's way, the pictures' trajectories."""
    from ..kernels.trajectories import (
        downhill_neighbour,
        max_slide_points,
        new_memo,
        successor,
    )
    from ..kernels.meeting_search import no_slide_context
    from ..kernels.records import Hand
    from ..kernels.streamline import max_streamline_steps, streamline_walk
    from .batch import cell_map_fields, manipulation_cells
    from .layout import finger_arrays_of, kernel_records
    from .maps import compute_map

    design, part, h = Design(1.2, 0.8, 0.12, 0.1, 0.8), Part(0.4, 0.4), 0.4
    cell = np.array([[1.2, 0.8, 0.12, 0.1, 0.4, 0.4]])
    widths = np.array([0.0, 0.8])
    for forces in (False, True):
        m = compute_map(design, part, grid=Grid(h=h), forces=forces)
    manipulation_cells(cell, widths, h, Limits(), Accuracy(), Effects(), np.array([0]),
                       np.array([[0, 0]]), np.array([8]))
    cell_map_fields(cell[0], 0.8, Command(), h, Limits(), Accuracy(), forces=True)
    # the pictures' kernels (sweep/report/plot.py), with its argument types
    energy = np.asarray(m.fields["energy"], dtype=np.float64)
    point_class = np.asarray(m.fields["point_class"])
    equilibrium = np.asarray(m.fields["equilibrium"], dtype=bool)
    caged = np.asarray(m.fields["caging_score"]) > 0.0
    ny, nx = energy.shape
    downhill_neighbour(energy, point_class, 0, 0, h)
    finger, solver, blocks = kernel_records(design, part, Limits(), Accuracy(), Effects())
    successor(energy, point_class, equilibrium, finger_arrays_of(m.fields), m.x, m.y,
              0, 0, finger, solver, blocks, Hand(0.8, 1.0, 1.0, h, finger.mu_s, finger.mu_s),
              True, np.empty((max_slide_points(ny, nx), 2)), new_memo(0, False),
              no_slide_context())
    steps = max_streamline_steps(ny, nx, 0.5)
    streamline_walk(energy, point_class, equilibrium, caged, 0, 0, 0.5, steps,
                    np.full(energy.size, -1, dtype=np.int64), np.empty((steps + 1, 2)))


def compile_collision_search() -> None:
    """finger_collision's search over a map (`meeting_search.resolve_collisions` and all below
    it), with the argument types the maps' pipeline passes."""
    from ..kernels.meeting_search import resolve_collisions
    from ..kernels.records import new_finger_arrays, no_settled_fingers
    from .layout import kernel_records

    design, part = Design(1.2, 0.8, 0.12, 0.1, 0.8), Part(0.4, 0.4)
    finger, _, blocks = kernel_records(design, part, Limits(), Accuracy(), Effects())
    resolve_collisions(np.linspace(0.4, 2.0, 5), finger, 0.8, new_finger_arrays(2, 5, 7),
                       blocks.finger_collision, no_settled_fingers(),
                       np.empty((0, 0), dtype=np.bool_))


def compile_summaries() -> None:
    """The second process's set: finger_collision's search (compile_collision_search), the
    manipulation metric's hull reductions (the sweep's chunks and the merge) and the sweep's
    cells with summaries only."""
    from .batch import summarize_cells
    from .manipulation import PartReduction

    compile_collision_search()
    rng = np.random.default_rng(0)
    n = 40
    red = PartReduction.from_entries(rng.integers(0, 3, n), rng.normal(size=n),
                                     rng.normal(size=n), np.arange(n), rng.uniform(size=(n, 5)))
    red.merge(red).values_and_ranges()
    # last: by then the first process has cached most of the one-map kernels it shares
    summarize_cells(np.array([[1.2, 0.8, 0.12, 0.1, 0.4, 0.4]]), np.array([0.0, 0.8]), Command(),
                    0.4, Limits(), Accuracy())


#: The kernel caches this process found compiled or compiled: looked up once, so that a later
#: command of the same process (the tests run commands as another user, who may not read the
#: cache folder) does not look again; the kernels are in memory by then.
_FOUND_HERE: set = set()


def ensure_compiled(say=None) -> None:
    """Compile every kernel unless this kernel set is in the cache already (module docstring);
    `say` gets the one line (default: standard error)."""
    directory = kernels.cache_directory()
    if directory in _FOUND_HERE:
        return
    if is_compiled():
        _FOUND_HERE.add(directory)
        return
    message = f"compiling kernels (first run only, about {COLD_SECONDS} s)"
    if say is None:
        print(message, file=sys.stderr, flush=True)
    else:
        say(message)
    started = time.perf_counter()
    second = subprocess.Popen([sys.executable, "-m", __name__, "summaries"], env=os.environ,
                              stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        compile_maps()
    finally:
        failed = second.wait() != 0
    if failed:  # (compiled here instead; what the other process cached stays valid)
        compile_summaries()
    kernels.cache_directory().mkdir(parents=True, exist_ok=True)
    (kernels.cache_directory() / MARKER).write_text(f"{time.perf_counter() - started:.1f} s\n")
    _FOUND_HERE.add(directory)


def main(argv: list[str]) -> int:
    for name in argv or ["maps", "summaries"]:
        {"maps": compile_maps, "summaries": compile_summaries}[name]()
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
