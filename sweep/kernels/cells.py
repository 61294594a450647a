"""Many maps at once: per-map summaries of cells (l1, l2, r1, r2, r, mu) x palm widths.

A finger's solution depends only on the part centre relative to its base, so when every palm
half-width is a whole number of grid steps, one right-finger field over integer offsets serves
both fingers of every width: the right finger at world column i reads offset i - s, the left
finger offset -i - s (model-notes D1). The offsets are the same floating-point numbers the
direct computation uses, so the summaries are bitwise identical to `compute_map`'s.
"""
import numpy as np
from numba import njit, prange

from .field import (count_summary, finger_field_serial, map_outcomes_serial, new_finger_arrays,
                    new_outcome_arrays, new_trajectory_arrays, trajectory_ends)


@njit(cache=True)
def summarize_filled_map(xs, ys, h, w, l1, l2, r1, r2, r, mu, f_left, f_right, theta2_min,
                         mode, t1, t2, k1, k2, overlap, out):
    """Outcomes, trajectories and the summary row `out` of a map whose fingers are solved."""
    ny = ys.shape[0]
    nx = xs.shape[0]
    (energy, point_class, equilibrium, contained, l_open, crossed, caged,
     caging_score) = new_outcome_arrays(ny, nx)
    scratch = np.empty(16)
    map_outcomes_serial(xs, ys, w, l1, l2, r1, r2, r, mu, f_left, f_right, theta2_min, mode,
                        t1, t2, k1, k2, energy, point_class, equilibrium, contained, l_open,
                        crossed, caged, caging_score, scratch, False)  # summaries only
    end_state, end_index, stack = new_trajectory_arrays(ny, nx)
    score_sum = trajectory_ends(energy, point_class, equilibrium, caged, caging_score, h,
                                end_state, end_index, stack)
    count_summary(point_class, end_state, equilibrium, caged, crossed, overlap, score_sum, h,
                  out)


@njit(cache=True, inline="always")
def gather_point(f_mode, f_t1, f_t2, f_k1, f_k2, f_overlap, j, src, mode, t1, t2, k1, k2,
                 overlap, side, c):
    """Copy field column src of row j into finger `side`, world column c of a map."""
    mode[side, j, c] = f_mode[0, j, src]
    t1[side, j, c] = f_t1[0, j, src]
    t2[side, j, c] = f_t2[0, j, src]
    k1[side, j, c] = f_k1[0, j, src]
    k2[side, j, c] = f_k2[0, j, src]
    overlap[side, j, c] = f_overlap[0, j, src]


@njit(cache=True)
def summarize_cell(l1, l2, r1, r2, r, mu, ws, steps, ncols, ny, h, f_left, f_right,
                   theta2_min, theta2_max, step, root_tol, out):
    """All widths of one cell from one shared finger field. out: (n_w, len(MAP_SUMMARY_FIELDS)).

    steps[k] is the palm half-width of width k in grid steps; the map of width k has columns
    i = -ncols[k] .. ncols[k] and rows y_j = r + j h, j = 0 .. ny - 1.
    """
    m_lo = 0
    m_hi = 0
    for k in range(ws.shape[0]):
        m_lo = min(m_lo, -ncols[k] - steps[k])
        m_hi = max(m_hi, ncols[k] - steps[k])
    nm = m_hi - m_lo + 1
    dxs = np.empty(nm)
    for m in range(nm):
        dxs[m] = (m + m_lo) * h
    ys = np.empty(ny)
    for j in range(ny):
        ys[j] = r + j * h
    f_mode, f_t1, f_t2, f_k1, f_k2, f_overlap = new_finger_arrays(1, ny, nm)
    finger_field_serial(dxs, ys, l1, l2, r1, r2, r, mu, theta2_min, theta2_max, step, root_tol,
                        f_mode[0], f_t1[0], f_t2[0], f_k1[0], f_k2[0], f_overlap[0])
    for k in range(ws.shape[0]):
        nx = 2 * ncols[k] + 1
        xs = np.empty(nx)
        mode, t1, t2, k1, k2, overlap = new_finger_arrays(2, ny, nx)
        for c in range(nx):
            i = c - ncols[k]
            xs[c] = i * h
            left = -i - steps[k] - m_lo   # mirror
            right = i - steps[k] - m_lo   # shift
            for j in range(ny):
                gather_point(f_mode, f_t1, f_t2, f_k1, f_k2, f_overlap, j, left, mode, t1, t2,
                             k1, k2, overlap, 0, c)
                gather_point(f_mode, f_t1, f_t2, f_k1, f_k2, f_overlap, j, right, mode, t1, t2,
                             k1, k2, overlap, 1, c)
        summarize_filled_map(xs, ys, h, ws[k], l1, l2, r1, r2, r, mu, f_left, f_right,
                             theta2_min, mode, t1, t2, k1, k2, overlap, out[k])


@njit(cache=True, parallel=True)
def summarize_cells_shared(cells, ws, steps, ncols, nys, h, f_left, f_right, theta2_min,
                           theta2_max, step, root_tol, out):
    """summarize_cell for every cell, cells in parallel. cells: (n, 6) l1 l2 r1 r2 r mu."""
    for c in prange(cells.shape[0]):
        summarize_cell(cells[c, 0], cells[c, 1], cells[c, 2], cells[c, 3], cells[c, 4],
                       cells[c, 5], ws, steps, ncols[c], nys[c], h, f_left, f_right,
                       theta2_min, theta2_max, step, root_tol, out[c])


@njit(cache=True)
def summarize_direct_map(l1, l2, r1, r2, r, mu, w, dx_left, dx_right, xs, ys, h, f_left,
                         f_right, theta2_min, theta2_max, step, root_tol, out):
    """One map with each finger solved at its own offsets (palm half-width off the grid)."""
    ny = ys.shape[0]
    nx = xs.shape[0]
    mode, t1, t2, k1, k2, overlap = new_finger_arrays(2, ny, nx)
    finger_field_serial(dx_left, ys, l1, l2, r1, r2, r, mu, theta2_min, theta2_max, step,
                        root_tol, mode[0], t1[0], t2[0], k1[0], k2[0], overlap[0])
    finger_field_serial(dx_right, ys, l1, l2, r1, r2, r, mu, theta2_min, theta2_max, step,
                        root_tol, mode[1], t1[1], t2[1], k1[1], k2[1], overlap[1])
    summarize_filled_map(xs, ys, h, w, l1, l2, r1, r2, r, mu, f_left, f_right, theta2_min,
                         mode, t1, t2, k1, k2, overlap, out)
