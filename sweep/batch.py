"""A sweep of maps: per-map summaries for many designs and parts (MODEL 8, 10).

The unit of work is a *cell* ``(l1, l2, r1, r2, r, mu)`` evaluated for every palm width of the
sweep: the maps of one cell share finger geometry (a finger's field depends on the part centre
relative to its base, so all widths and both fingers are shifts/mirrors of one field).
"""
from __future__ import annotations

import math

import numpy as np

from .kernels.cells import summarize_cells_shared, summarize_direct_map
from .maps import finger_offsets, grid_index_bounds, map_grid, palm_half_width_steps
from .model import (MAP_SUMMARY_FIELDS, Accuracy, Command, Design, Effects, Grid, Limits,
                    ModelInputError, Part, validate_inputs)

# Per-map summary variables, in storage order.
SUMMARY_FIELDS = MAP_SUMMARY_FIELDS
CELL_COLUMNS = ("l1", "l2", "r1", "r2", "r", "mu")


def summarize_cells(cells: np.ndarray, widths: np.ndarray, command: Command, h: float,
                    limits: Limits, accuracy: Accuracy,
                    effects: Effects = Effects()) -> np.ndarray:
    """Summaries of the maps of every cell at every width: float64 array (n_cells, n_w, n_fields).

    `cells` is float64 (n_cells, 6) with columns CELL_COLUMNS; `widths` float64 (n_w,).
    Each map uses the default whole-reach grid of MODEL 8 at spacing `h`. Results are bitwise
    identical to `compute_map(...).attrs` for the same map.
    """
    cells = np.ascontiguousarray(cells, dtype=np.float64).reshape(-1, len(CELL_COLUMNS))
    widths = np.ascontiguousarray(widths, dtype=np.float64).reshape(-1)
    if not effects.friction:
        cells = cells.copy()
        cells[:, 5] = 0.0
    out = np.zeros((cells.shape[0], widths.size, len(SUMMARY_FIELDS)))
    if cells.shape[0] == 0 or widths.size == 0:
        return out
    steps = [palm_half_width_steps(w, h) for w in widths]
    th2min, th2max = limits.theta2_min, limits.theta2_max
    if all(s is not None for s in steps):
        # whole-reach grids: columns -N..N, rows 0..M (sized without allocating them)
        bounds = [[grid_index_bounds(Design(c[0], c[1], c[2], c[3], w), Part(c[4], c[5]),
                                     Grid(h=h)) for w in widths] for c in cells]
        ncols = np.array([[b[1] for b in row] for row in bounds], dtype=np.int64)
        nys = np.array([row[0][3] + 1 for row in bounds], dtype=np.int64)
        summarize_cells_shared(cells, widths, np.array(steps, dtype=np.int64), ncols, nys, h,
                               command.f_left, command.f_right, th2min, th2max,
                               accuracy.reconfig_step, accuracy.root_tol, out)
        return out
    for c in range(cells.shape[0]):  # palm half-width off the grid: each map on its own
        l1, l2, r1, r2, r, mu = cells[c]
        for k, w in enumerate(widths):
            g = map_grid(Design(l1, l2, r1, r2, w), Part(r, mu), Grid(h=h))
            dx_left, dx_right = finger_offsets(g.i, w, h)
            summarize_direct_map(l1, l2, r1, r2, r, mu, w, dx_left, dx_right, g.x, g.y, h,
                                 command.f_left, command.f_right, th2min, th2max,
                                 accuracy.reconfig_step, accuracy.root_tol, out[c, k])
    return out


def validate_cells(cells: np.ndarray, widths: np.ndarray, command: Command, limits: Limits,
                   accuracy: Accuracy, effects: Effects) -> None:
    """Validate every design/part of a sweep once, up front (raises ModelInputError)."""
    for c in np.asarray(cells).reshape(-1, len(CELL_COLUMNS)):
        for w in np.asarray(widths).reshape(-1):
            validate_inputs(Design(*map(float, c[:4]), float(w)), Part(float(c[4]), float(c[5])),
                            command, limits, accuracy, effects)
    if not all(math.isfinite(w) for w in np.asarray(widths).reshape(-1)):
        raise ModelInputError("widths must be finite")
