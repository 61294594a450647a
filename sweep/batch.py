"""A sweep of maps: per-map summaries for many designs and parts (MODEL 8, 10).

The unit of work is a *cell* ``(l1, l2, r1, r2, r, mu)`` evaluated for every palm width of the
sweep: the maps of one cell share finger geometry (a finger's field depends on the part centre
relative to its base, so all widths and both fingers are shifts/mirrors of one field).
"""
from __future__ import annotations

import numpy as np

from .kernels.cells import cell_map, summarize_cells_shared, summarize_direct_map
from .kernels.records import Hand
from .maps import (
    finger_offsets,
    grid_index_bounds,
    kernel_records,
    map_fields,
    map_grid,
    palm_half_width_steps,
    summary_attrs,
)
from .model import Accuracy, Command, Design, Effects, Grid, Limits, ModelInputError, Part
from .schema import SUMMARY_FIELDS

CELL_COLUMNS = ("l1", "l2", "r1", "r2", "r", "mu")


def _cell_design_part(cell, w: float) -> tuple[Design, Part]:
    l1, l2, r1, r2, r, mu = (float(v) for v in cell)
    return Design(l1, l2, r1, r2, float(w)), Part(r, mu)


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
    _, solver, blocks = kernel_records(*_cell_design_part(cells[0], widths[0]), limits, accuracy,
                                       effects)
    th2min, th2max = limits.theta2_min, limits.theta2_max
    if all(s is not None for s in steps):
        # whole-reach grids: columns -N..N, rows 0..M (sized without allocating them)
        bounds = [[grid_index_bounds(*_cell_design_part(c, w), Grid(h=h)) for w in widths]
                  for c in cells]
        ncols = np.array([[b[1] for b in row] for row in bounds], dtype=np.int64)
        nys = np.array([row[0][3] + 1 for row in bounds], dtype=np.int64)
        summarize_cells_shared(cells, widths, np.array(steps, dtype=np.int64), ncols, nys, h,
                               command.f_left, command.f_right, th2min, th2max, solver, blocks,
                               out)
        return out
    for c in range(cells.shape[0]):  # palm half-width off the grid: each map on its own
        for k, w in enumerate(widths):
            design, part = _cell_design_part(cells[c], w)
            finger, _, _ = kernel_records(design, part, limits, accuracy, effects)
            g = map_grid(design, part, Grid(h=h))
            dx_left, dx_right = finger_offsets(g.i, w, h)
            hand = Hand(float(w), command.f_left, command.f_right, float(h))
            summarize_direct_map(finger, solver, blocks, hand, dx_left, dx_right, g.x, g.y,
                                 out[c, k])
    return out


def cell_map_fields(cell, w: float, command: Command, h: float, limits: Limits,
                    accuracy: Accuracy, effects: Effects = Effects(),
                    forces: bool = False) -> tuple[np.ndarray, np.ndarray, dict, dict]:
    """The per-point fields of one map computed the way the sweep computes it (shared finger
    field, mirrored and shifted): (x, y, fields, summary attrs), fields named as in
    sweep.schema. The palm half-width must be a whole number of grid steps."""
    design, part = _cell_design_part(cell, w)
    step = palm_half_width_steps(float(w), h)
    if step is None:
        raise ModelInputError(f"w = {w} is not a whole number of grid steps 2h = {2 * h}")
    finger, solver, blocks = kernel_records(design, part, limits, accuracy, effects)
    _, i1, _, j1 = grid_index_bounds(design, part, Grid(h=h))
    xs, ys, fingers, outs, force_arrays, summary = cell_map(
        finger, solver, blocks, float(w), step, i1, j1 + 1, float(h), float(command.f_left),
        float(command.f_right), True, forces)
    return xs, ys, map_fields(fingers, outs, force_arrays if forces else None), \
        summary_attrs(summary)
