"""Grids of points: finger fields, per-point outcomes and trajectories of a map (MODEL 8).

Row functions do the work; two thin drivers loop over rows, one with `prange` (one map, all
threads) and one serial (called inside the sweep's own parallel loop over maps, since Numba's
default threading layer does not nest parallel regions).
"""
import math

import numpy as np
from numba import njit, prange

from ..model import (EJECT, END_CAGED, END_EJECTION, END_NONE, END_STALLED, END_TIP_PREHENSION,
                     FREE, INFEASIBLE, RANGE_TOL, REACHED, SLIPPED, UNREACHED, VERTEX,
                     VERTEX_POINT)
from .finger import OVERLAP, finger_energy, solve_finger
from .part import (finger_polyline, fingers_cross, part_contained, part_in_equilibrium,
                   tip_clearance)

# ---------------------------------------------------------------------------------------------
# Working arrays of a map (one place for their shapes and types)
# ---------------------------------------------------------------------------------------------
@njit(cache=True)
def new_finger_arrays(n_fingers, ny, nx):
    """(mode, t1, t2, k1, k2, tip_overlap) on (finger, y, x)."""
    shape = (n_fingers, ny, nx)
    return (np.empty(shape, dtype=np.int8), np.empty(shape), np.empty(shape), np.empty(shape),
            np.empty(shape), np.empty(shape, dtype=np.bool_))


@njit(cache=True)
def new_outcome_arrays(ny, nx):
    """(energy, point_class, equilibrium, contained, l_open, crossed, caged, caging_score)."""
    shape = (ny, nx)
    return (np.empty(shape), np.empty(shape, dtype=np.int8), np.empty(shape, dtype=np.bool_),
            np.empty(shape, dtype=np.bool_), np.empty(shape), np.empty(shape, dtype=np.bool_),
            np.empty(shape, dtype=np.bool_), np.empty(shape))


@njit(cache=True)
def new_trajectory_arrays(ny, nx):
    """(end_state, end_index, stack) for trajectory_ends."""
    return (np.empty((ny, nx), dtype=np.int8), np.empty((ny, nx), dtype=np.int64),
            np.empty(ny * nx, dtype=np.int64))


# ---------------------------------------------------------------------------------------------
# Finger fields
# ---------------------------------------------------------------------------------------------


@njit(cache=True)
def finger_row(j, dxs, dy, l1, l2, r1, r2, r, mu, theta2_min, theta2_max, step, root_tol,
               mode, t1, t2, k1, k2, overlap):
    """Solve one finger at every column offset dxs[i] of row j (part centre at (dxs[i], dy))."""
    for i in range(dxs.shape[0]):
        m, a1, a2, c1, c2, ov = solve_finger(dxs[i], dy, l1, l2, r1, r2, r, mu, theta2_min,
                                             theta2_max, step, root_tol)
        mode[j, i] = m
        t1[j, i] = a1
        t2[j, i] = a2
        k1[j, i] = c1
        k2[j, i] = c2
        overlap[j, i] = ov


@njit(cache=True, parallel=True)
def finger_field(dxs, dys, l1, l2, r1, r2, r, mu, theta2_min, theta2_max, step, root_tol,
                 mode, t1, t2, k1, k2, overlap):
    """One finger over the grid dys x dxs (finger-frame offsets), rows in parallel."""
    for j in prange(dys.shape[0]):
        finger_row(j, dxs, dys[j], l1, l2, r1, r2, r, mu, theta2_min, theta2_max, step,
                   root_tol, mode, t1, t2, k1, k2, overlap)


@njit(cache=True)
def finger_field_serial(dxs, dys, l1, l2, r1, r2, r, mu, theta2_min, theta2_max, step, root_tol,
                        mode, t1, t2, k1, k2, overlap):
    for j in range(dys.shape[0]):
        finger_row(j, dxs, dys[j], l1, l2, r1, r2, r, mu, theta2_min, theta2_max, step,
                   root_tol, mode, t1, t2, k1, k2, overlap)


# ---------------------------------------------------------------------------------------------
# Per-point outcomes of a map
# ---------------------------------------------------------------------------------------------
@njit(cache=True)
def classify_point(y, r, mode_l, mode_r):
    """MODEL 8 classes, first that applies."""
    if y < r - RANGE_TOL or mode_l == OVERLAP or mode_r == OVERLAP:
        return INFEASIBLE
    if mode_l == SLIPPED or mode_r == SLIPPED:
        return EJECT
    if mode_l == VERTEX or mode_r == VERTEX:
        return VERTEX_POINT
    if mode_l == FREE and mode_r == FREE:
        return UNREACHED
    return REACHED


@njit(cache=True)
def outcome_row(j, xs, y, w, l1, l2, r1, r2, r, mu, f_left, f_right, theta2_min,
                mode, t1, t2, k1, k2, energy, point_class, equilibrium, contained, l_open,
                crossed, caged, caging_score, scratch, every_point):
    """Class, energy, equilibrium, containment, opening and point score along row j.

    mode/t1/t2/k1/k2 are (2, ny, nx) finger arrays (0 = left, 1 = right) and are overwritten with
    fill values (-1 / NaN) at infeasible points. With every_point False (summaries only),
    containment, L_open and crossing are computed only where the part is stable, the only points
    whose score or counts depend on them; elsewhere they are left False / NaN.
    """
    for i in range(xs.shape[0]):
        x = xs[i]
        ml = mode[0, j, i]
        mr = mode[1, j, i]
        c = classify_point(y, r, ml, mr)
        point_class[j, i] = c
        equilibrium[j, i] = False
        contained[j, i] = False
        crossed[j, i] = False
        caged[j, i] = False
        caging_score[j, i] = 0.0
        if c == INFEASIBLE:
            energy[j, i] = np.nan
            l_open[j, i] = np.nan
            for side in range(2):
                mode[side, j, i] = -1
                t1[side, j, i] = np.nan
                t2[side, j, i] = np.nan
                k1[side, j, i] = np.nan
                k2[side, j, i] = np.nan
            continue
        a1l = t1[0, j, i]
        a2l = t2[0, j, i]
        a1r = t1[1, j, i]
        a2r = t2[1, j, i]
        energy[j, i] = (finger_energy(a1l, a2l, r1, r2, f_left, theta2_min)
                        + finger_energy(a1r, a2r, r1, r2, f_right, theta2_min))
        eq = False
        if c == REACHED:
            eq = part_in_equilibrium(scratch, x, y, w, r, mu, ml, a1l, a2l, mr, a1r, a2r)
            equilibrium[j, i] = eq
        l_open[j, i] = np.nan
        if not (eq or every_point):
            continue
        left = finger_polyline(0, a1l, a2l, l1, l2, w)
        right = finger_polyline(1, a1r, a2r, l1, l2, w)
        inside = part_contained(x, y, left, right)
        intersect = fingers_cross(left, right)
        opening = 0.0 if intersect else tip_clearance(left, right)  # = mouth_opening
        contained[j, i] = inside
        l_open[j, i] = opening
        crossed[j, i] = intersect
        if eq and inside and opening < 2.0 * r - RANGE_TOL:  # L_open == 2r: not caged
            caged[j, i] = True
            caging_score[j, i] = 1.0 - opening / (2.0 * r)


@njit(cache=True, parallel=True)
def map_outcomes(xs, ys, w, l1, l2, r1, r2, r, mu, f_left, f_right, theta2_min,
                 mode, t1, t2, k1, k2, energy, point_class, equilibrium, contained, l_open,
                 crossed, caged, caging_score):
    for j in prange(ys.shape[0]):
        scratch = np.empty(16)  # per row, not per point
        outcome_row(j, xs, ys[j], w, l1, l2, r1, r2, r, mu, f_left, f_right, theta2_min,
                    mode, t1, t2, k1, k2, energy, point_class, equilibrium, contained, l_open,
                    crossed, caged, caging_score, scratch, True)


@njit(cache=True)
def map_outcomes_serial(xs, ys, w, l1, l2, r1, r2, r, mu, f_left, f_right, theta2_min,
                        mode, t1, t2, k1, k2, energy, point_class, equilibrium, contained,
                        l_open, crossed, caged, caging_score, scratch, every_point):
    for j in range(ys.shape[0]):
        outcome_row(j, xs, ys[j], w, l1, l2, r1, r2, r, mu, f_left, f_right, theta2_min,
                    mode, t1, t2, k1, k2, energy, point_class, equilibrium, contained, l_open,
                    crossed, caged, caging_score, scratch, every_point)


# ---------------------------------------------------------------------------------------------
# Trajectories (MODEL 8): discrete steepest descent, each downhill step computed once
# ---------------------------------------------------------------------------------------------
# Neighbour order E, NE, N, NW, W, SW, S, SE (ties go to the first); j grows with y (north).
NEIGHBOUR_DI = (1, 1, 0, -1, -1, -1, 0, 1)
NEIGHBOUR_DJ = (0, 1, 1, 1, 0, -1, -1, -1)


@njit(cache=True)
def downhill_neighbour(energy, point_class, i, j, h):
    """Flat index of the steepest strictly-lower feasible neighbour of (j, i), or -1."""
    ny, nx = energy.shape
    here = energy[j, i]
    diagonal = h * math.sqrt(2.0)
    best = -1
    best_slope = 0.0
    for n in range(8):
        ii = i + NEIGHBOUR_DI[n]
        jj = j + NEIGHBOUR_DJ[n]
        if ii < 0 or ii >= nx or jj < 0 or jj >= ny:
            continue
        if point_class[jj, ii] == INFEASIBLE:
            continue
        distance = h if (NEIGHBOUR_DI[n] == 0 or NEIGHBOUR_DJ[n] == 0) else diagonal
        slope = (here - energy[jj, ii]) / distance
        if slope > best_slope:
            best_slope = slope
            best = jj * nx + ii
    return best


@njit(cache=True)
def trajectory_ends(energy, point_class, equilibrium, caged, caging_score, h, end_state,
                    end_index, stack):
    """End state and end point of the trajectory from every point of P_j (REACHED points).

    A point's end is its downhill successor's end, so shared paths are walked once. `stack` is
    scratch of size >= number of points. Returns the map score Lambda (MODEL 8).
    """
    ny, nx = energy.shape
    size = ny * nx
    for p in range(size):
        end_state.flat[p] = END_NONE
        end_index.flat[p] = -1
    for p0 in range(size):
        j0 = p0 // nx
        i0 = p0 - j0 * nx
        if point_class[j0, i0] != REACHED or end_state.flat[p0] != END_NONE:
            continue
        depth = 0
        p = p0
        state = END_NONE
        last = -1
        while True:
            j = p // nx
            i = p - j * nx
            if point_class[j, i] != REACHED:
                state = END_EJECTION
                last = p
                break
            if end_state.flat[p] != END_NONE:  # already resolved
                state = end_state.flat[p]
                last = end_index.flat[p]
                break
            stack[depth] = p
            depth += 1
            if equilibrium[j, i]:
                state = END_CAGED if caged[j, i] else END_TIP_PREHENSION
                last = p
                break
            q = downhill_neighbour(energy, point_class, i, j, h)
            if q < 0:
                state = END_STALLED
                last = p
                break
            p = q
        for s in range(depth):
            end_state.flat[stack[s]] = state
            end_index.flat[stack[s]] = last
    score_sum = 0.0
    for p in range(size):
        if end_state.flat[p] == END_CAGED:
            q = end_index.flat[p]
            score_sum += caging_score.flat[q]
    return score_sum


@njit(cache=True)
def count_summary(point_class, end_state, equilibrium, caged, crossed, overlap, score_sum, h,
                  out):
    """The per-map summary row, in the order of model.MAP_SUMMARY_FIELDS."""
    ny, nx = point_class.shape
    for n in range(out.shape[0]):
        out[n] = 0.0
    out[0] = score_sum
    out[1] = score_sum * h * h
    for j in range(ny):
        for i in range(nx):
            c = point_class[j, i]
            if c == REACHED:
                e = end_state[j, i]
                if e == END_CAGED:
                    out[2] += 1
                elif e == END_TIP_PREHENSION:
                    out[3] += 1
                elif e == END_EJECTION:
                    out[4] += 1
                elif e == END_STALLED:
                    out[5] += 1
                out[6] += 1
                if equilibrium[j, i]:
                    out[7] += 1
            elif c == VERTEX_POINT:
                out[8] += 1
            elif c == INFEASIBLE:
                out[12] += 1
            elif c == UNREACHED:
                out[13] += 1
            elif c == EJECT:
                out[14] += 1
            if c != INFEASIBLE and (overlap[0, j, i] or overlap[1, j, i]):
                out[9] += 1
            if caged[j, i]:
                out[15] += 1
                if crossed[j, i]:
                    out[10] += 1
    out[11] = ny * nx
