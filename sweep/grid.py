"""Grid geometry and what it costs: the vocabulary that a map, a sweep, a scene and a store share.

Plain Python (no kernels, no arrays): where a map's grid points lie (MODEL 8, model-notes D1),
how a sweep's cells and a part's pose lattice are laid out (MODEL 10), the bytes a map or a cell
holds per point, and the fixed sets of the manipulation metric (Scenario A's commands, the
reductions). `sweep.compute` computes on these grids; `sweep.config.scene` sizes a run with them
before anything is computed; `sweep.storage.store` writes them as coordinates.
"""
from __future__ import annotations

import math
import os

from .model import GRID_TOL, Design, Grid, ModelInputError, Part

# Bytes held per grid point while a map is computed, every array of kernels/records.py:
#: one finger's field (mode, t1, t2, k1, k2, tip_overlap, first_event)
FINGER_BYTES = 1 + 4 * 8 + 1 + 1
#: the outcomes (energy, l_open, caging_score; class and four flags; end state, end index)
OUTCOME_BYTES = 3 * 8 + 5 + 1 + 8
#: both fingers, the outcomes and the trajectory stack (one int64 per point)
BYTES_PER_POINT = 2 * FINGER_BYTES + OUTCOME_BYTES + 8
#: the contact forces (outputs.forces): five floats and a flag per finger, and S_geo
FORCE_BYTES_PER_POINT = 2 * (5 * 8 + 1) + 8
MAX_POINTS_DEFAULT = 200_000_000


def map_bytes_per_point(forces: bool = False, written: bool = False) -> int:
    """Bytes per grid point of one map: its arrays (with the forces when asked for) and, when
    the map is `written`, its file too, which is rendered in memory before it is written
    (sweep.files: about the arrays once more)."""
    arrays = BYTES_PER_POINT + (FORCE_BYTES_PER_POINT if forces else 0)
    return 2 * arrays if written else arrays


def reach(design: Design, part: Part) -> tuple[float, float]:
    """Default window half-width X and height Y: the whole reach (MODEL 8)."""
    return (0.5 * design.w + design.l1 + design.l2 + part.r, part.r + design.l1 + design.l2)


def grid_index_bounds(design: Design, part: Part, grid: Grid) -> tuple[int, int, int, int]:
    """Integer bounds (i0, i1, j0, j1) of a map's grid, x = i h, y = r + j h (MODEL 8, D1).

    Allocates nothing, so it can size a grid before deciding whether it fits in memory.
    """
    h = grid.h
    if not (isinstance(h, (int, float)) and math.isfinite(h) and h > 0):
        raise ModelInputError(f"h must be a positive number, got {h!r}")
    for name, window in (("xlim", grid.xlim), ("ylim", grid.ylim)):
        if window is not None and not all(math.isfinite(v) for v in window):
            raise ModelInputError(f"{name} must be finite, got {window!r}")
    X, Y = reach(design, part)
    extent = max(abs(v) for v in (X, Y, *(grid.xlim or ()), *(grid.ylim or ())))
    if not math.isfinite(extent / h) or extent / h > 1e9:
        raise ModelInputError(f"h = {h!r} is too fine for a window of extent {extent:g} (the "
                              "reach l1 + l2 + w/2 + r, or the window of --xlim/--ylim): that "
                              "grid does not fit in memory")
    if grid.xlim is None:
        n = math.floor(X / h + GRID_TOL)
        i0, i1 = -n, n
    else:
        xmin, xmax = grid.xlim
        if not xmin <= xmax:
            raise ModelInputError(f"xlim must have XMIN <= XMAX, got {grid.xlim!r}")
        i0, i1 = math.ceil(xmin / h - GRID_TOL), math.floor(xmax / h + GRID_TOL)
    if grid.ylim is None:
        j0, j1 = 0, math.floor((Y - part.r) / h + GRID_TOL)
    else:
        ymin, ymax = grid.ylim
        if not ymin <= ymax:
            raise ModelInputError(f"ylim must have YMIN <= YMAX, got {grid.ylim!r}")
        j0 = math.ceil((ymin - part.r) / h - GRID_TOL)
        j1 = math.floor((ymax - part.r) / h + GRID_TOL)
    # Grid points lie at x = i h and y = r + j h: a window narrower than h can fall between them.
    if i1 < i0:
        raise ModelInputError(f"--xlim {grid.xlim[0]:g} {grid.xlim[1]:g} holds no grid column "
                              f"at h = {h:g} (columns at x = i h): widen --xlim or change --h")
    if j1 < j0:
        raise ModelInputError(f"--ylim {grid.ylim[0]:g} {grid.ylim[1]:g} holds no grid row at "
                              f"h = {h:g} (rows at y = r + j h, r = {part.r:g}): widen --ylim or "
                              "change --h")
    return i0, i1, j0, j1


def palm_half_width_steps(w: float, h: float) -> int | None:
    """The palm half-width in whole grid steps, or None if it is not a whole number of steps."""
    s = w / (2.0 * h)
    return int(round(s)) if abs(s - round(s)) <= GRID_TOL else None


def available_memory() -> int:
    """Bytes of memory available to a new computation (MemAvailable on Linux)."""
    try:
        with open("/proc/meminfo") as f:
            for line in f:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except OSError:
        pass
    try:
        return os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
    except (ValueError, OSError, AttributeError):
        return 8 << 30


#: Share of the available memory a computation may plan on (the rest: the system, Python, the
#: other jobs of a node).
MEMORY_SHARE = 0.8


def check_memory_need(need: int, what: str, advice: str) -> None:
    """Refuse (ModelInputError, before anything is computed or written) a computation that would
    need more than MEMORY_SHARE of this machine's available memory: one map, a run, a merge."""
    available = available_memory()
    if need > MEMORY_SHARE * available:
        raise ModelInputError(f"{what} needs about {need / 2**30:.1f} GiB, about "
                              f"{available / 2**30:.1f} GiB free: {advice}")


def check_memory(n_points: int, what: str = "the grid",
                 bytes_per_point: int = BYTES_PER_POINT) -> None:
    """Refuse a grid whose working arrays would not fit in memory."""
    if n_points > MAX_POINTS_DEFAULT:
        raise ModelInputError(f"{what} has {n_points:,} points (about "
                              f"{n_points * bytes_per_point / 2**30:,.0f} GiB), more than "
                              f"{MAX_POINTS_DEFAULT:,}: raise h or narrow it")
    check_memory_need(n_points * bytes_per_point, f"{what} ({n_points:,} points)",
                      "raise h or narrow it")


# ---------------------------------------------------------------------------------------------
# A sweep's cells and a part's pose lattice (MODEL 10)
# ---------------------------------------------------------------------------------------------
#: The columns of a sweep cell, in order (the rows of `compute.batch.summarize_cells`)
CELL_COLUMNS = ("l1", "l2", "r1", "r2", "r", "mu")

#: Scenario A's commands F_left (F_right = 2 - F_left): MODEL 10 lists 0.2, 0.4, ..., 1.8; one
#: geometry's forces F_left f_L + (2 - F_left) f_R lie on a segment, so only its ends can be hull
#: vertices and the metric is that of the two extreme commands, which are the ones computed.
SCENARIO_A_COMMANDS = tuple(round(0.2 * k, 12) for k in range(1, 10))
SCENARIO_A_EXTREMES = (SCENARIO_A_COMMANDS[0], SCENARIO_A_COMMANDS[-1])
ENTRY_CAPACITY = 16384  # counted (pose, width) pairs per cell before the cell is redone bigger


def cell_extent(l1: float, l2: float, r: float, widths, h: float) -> tuple[int, int, int]:
    """(rows, columns of the widest map, offsets of the shared finger field) of a cell's maps
    on the whole-reach grids (as summarize_cells lays them out)."""
    bounds = [grid_index_bounds(Design(l1, l2, 1.0, 1.0, float(w)), Part(r, 0.0), Grid(h=h))
              for w in widths]
    ncols = [b[1] for b in bounds]
    steps = [palm_half_width_steps(float(w), h) or 0 for w in widths]
    m_lo = min(min(-n - s for n, s in zip(ncols, steps)), 0)
    m_hi = max(max(n - s for n, s in zip(ncols, steps)), 0)
    return bounds[0][3] + 1, 2 * max(ncols) + 1, m_hi - m_lo + 1


def cell_bytes(ny: int, nx_max: int, n_shared: int, n_widths: int,
               manipulation: bool = False, scenario_c: bool = False) -> int:
    """Bytes one thread holds while it computes one cell (kernels/many_maps.py summarize_cells): the
    shared finger field, one width's map at a time (both fingers gathered, the outcomes, the
    trajectory stack) and, with the manipulation metric, the shared field's link vectors and
    statics (7 floats a point), Scenario A's per-pose force buffers (a count and two floats per
    width and command) and the cell's Scenario B entries; with Scenario C, a second shared field
    (the low friction) with its links and statics, and C's buffers (four friction pairs)."""
    total = n_shared * ny * FINGER_BYTES + ny * nx_max * BYTES_PER_POINT
    if manipulation:
        slots = n_widths * len(SCENARIO_A_EXTREMES)
        total += (n_shared * ny * 7 * 8 + ny * nx_max * (8 + 2 * 8 * slots)
                  + ENTRY_CAPACITY * (4 * 8 + 1))
        if scenario_c:
            # C's buffers (4 slots a width and command) and the (mu_low, mu_low) pair's (1)
            total += n_shared * ny * (FINGER_BYTES + 7 * 8) + ny * nx_max * (16 + 16 * 5 * slots)
    return total


def part_lattice_columns(max_w: float, max_l1: float, max_l2: float, r: float, h: float) -> int:
    """N of a part's shared pose lattice x = i h, |i| <= N (MODEL 10: the world grid of the
    largest reach, MODEL 8), for every design of a sweep."""
    return int(math.floor((0.5 * max_w + max_l1 + max_l2 + r) / h + GRID_TOL))


#: The reductions kept per part: every counted force, and those where the fingers do not cross
#: (MODEL 10: report how much of the metric comes from crossed fingers).
REDUCTIONS = ("all", "uncrossed")
