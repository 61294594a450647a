"""Many maps at once: per-map summaries of cells (l1, l2, r1, r2, r, mu) x palm widths.

A finger's solution depends only on the part centre relative to its base, so when every palm
half-width is a whole number of grid steps, one right-finger field over integer offsets serves
both fingers of every width: the right finger at world column i reads offset i - s, the left
finger offset -i - s (model-notes D1). The offsets are the same floating-point numbers the
direct computation uses, so the maps are bitwise identical to `compute_map`'s. Each map then goes
through the one map pipeline, `field.map_from_fingers`.
"""
import numpy as np
from numba import njit, prange

from .field import N_SUMMARY, finger_field_serial, map_from_fingers
from .records import (
    EffectBlocks,
    FingerModel,
    Hand,
    new_finger_arrays,
    new_force_arrays,
    new_outcome_arrays,
)


@njit(cache=True)
def shared_field_extent(steps, ncols):
    """(m_lo, number of offsets) of the shared field that serves every width of a cell."""
    m_lo = 0
    m_hi = 0
    for k in range(steps.shape[0]):
        m_lo = min(m_lo, -ncols[k] - steps[k])
        m_hi = max(m_hi, ncols[k] - steps[k])
    return m_lo, m_hi - m_lo + 1


@njit(cache=True)
def shared_finger_field(finger, solver, effects, steps, ncols, ny, h):
    """The right finger's field over every offset any width of the cell needs."""
    m_lo, nm = shared_field_extent(steps, ncols)
    dxs = np.empty(nm)
    for m in range(nm):
        dxs[m] = (m + m_lo) * h
    ys = np.empty(ny)
    for j in range(ny):
        ys[j] = finger.r + j * h
    shared = new_finger_arrays(1, ny, nm)
    finger_field_serial(dxs, ys, finger, solver, effects, shared, 0)
    return shared, m_lo, ys


@njit(cache=True)
def gather_fingers(shared, m_lo, step, ncol, ny, h):
    """Both fingers of the map of palm half-width `step` grid steps, from the shared field:
    (world xs, FingerArrays on (2, ny, 2 ncol + 1))."""
    nx = 2 * ncol + 1
    xs = np.empty(nx)
    fingers = new_finger_arrays(2, ny, nx)
    for c in range(nx):
        i = c - ncol
        xs[c] = i * h
        left = -i - step - m_lo   # mirror
        right = i - step - m_lo   # shift
        for side in range(2):
            src = left if side == 0 else right
            for j in range(ny):
                fingers.mode[side, j, c] = shared.mode[0, j, src]
                fingers.t1[side, j, c] = shared.t1[0, j, src]
                fingers.t2[side, j, c] = shared.t2[0, j, src]
                fingers.k1[side, j, c] = shared.k1[0, j, src]
                fingers.k2[side, j, c] = shared.k2[0, j, src]
                fingers.tip_overlap[side, j, c] = shared.tip_overlap[0, j, src]
    return xs, fingers


@njit(cache=True)
def summarize_cell(finger, solver, effects, ws, steps, ncols, ny, h, f_left, f_right, out):
    """All widths of one cell from one shared finger field. out: (n_w, N_SUMMARY).

    steps[k] is the palm half-width of width k in grid steps; the map of width k has columns
    i = -ncols[k] .. ncols[k] and rows y_j = r + j h, j = 0 .. ny - 1.
    """
    shared, m_lo, ys = shared_finger_field(finger, solver, effects, steps, ncols, ny, h)
    for k in range(ws.shape[0]):
        xs, fingers = gather_fingers(shared, m_lo, steps[k], ncols[k], ny, h)
        outs = new_outcome_arrays(ny, xs.shape[0])
        stack = np.empty(ny * xs.shape[0], dtype=np.int64)
        map_from_fingers(xs, ys, finger, Hand(ws[k], f_left, f_right, h), effects, fingers, outs,
                         None, stack, out[k], False)  # summaries only


@njit(cache=True)
def cell_finger_model(cells, c, theta2_min, theta2_max):
    return FingerModel(cells[c, 0], cells[c, 1], cells[c, 2], cells[c, 3], cells[c, 4],
                       cells[c, 5], theta2_min, theta2_max)


@njit(cache=True, parallel=True)
def summarize_cells_shared(cells, ws, steps, ncols, nys, h, f_left, f_right, theta2_min,
                           theta2_max, solver, effects, out):
    """summarize_cell for every cell, cells in parallel. cells: (n, 6) l1 l2 r1 r2 r mu."""
    # locals: prange cannot capture a record of blocks (read by name: unpacking a record that
    # holds a record fails in parfor lowering)
    tip = effects.tip_contact
    springs = effects.joint_springs
    collision = effects.finger_collision
    trajectory = effects.trajectory
    for c in prange(cells.shape[0]):
        summarize_cell(cell_finger_model(cells, c, theta2_min, theta2_max), solver,
                       EffectBlocks(tip, springs, collision, trajectory), ws, steps, ncols[c], nys[c], h,
                       f_left, f_right, out[c])


@njit(cache=True)
def cell_map(finger, solver, effects, w, step, ncol, ny, h, f_left, f_right, every_point,
             with_forces):
    """The full map of one width of a cell through the shared-field path (per-point outputs of
    the sweep path): (xs, ys, fingers, outcomes, forces, summary row); the force arrays are
    empty unless with_forces."""
    steps = np.array([step])
    ncols = np.array([ncol])
    shared, m_lo, ys = shared_finger_field(finger, solver, effects, steps, ncols, ny, h)
    xs, fingers = gather_fingers(shared, m_lo, step, ncol, ny, h)
    outs = new_outcome_arrays(ny, xs.shape[0])
    stack = np.empty(ny * xs.shape[0], dtype=np.int64)
    summary = np.empty(N_SUMMARY)
    if with_forces:
        forces = new_force_arrays(ny, xs.shape[0])
        map_from_fingers(xs, ys, finger, Hand(w, f_left, f_right, h), effects, fingers, outs,
                         forces, stack, summary, every_point)
    else:
        forces = new_force_arrays(0, 0)  # same return type either way
        map_from_fingers(xs, ys, finger, Hand(w, f_left, f_right, h), effects, fingers, outs,
                         None, stack, summary, every_point)
    return xs, ys, fingers, outs, forces, summary


@njit(cache=True)
def summarize_direct_map(finger, solver, effects, hand, dx_left, dx_right, xs, ys, out):
    """One map with each finger solved at its own offsets (palm half-width off the grid)."""
    ny = ys.shape[0]
    nx = xs.shape[0]
    fingers = new_finger_arrays(2, ny, nx)
    finger_field_serial(dx_left, ys, finger, solver, effects, fingers, 0)
    finger_field_serial(dx_right, ys, finger, solver, effects, fingers, 1)
    outs = new_outcome_arrays(ny, nx)
    stack = np.empty(ny * nx, dtype=np.int64)
    map_from_fingers(xs, ys, finger, hand, effects, fingers, outs, None, stack, out, False)
