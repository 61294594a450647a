"""Continuous trajectories (MODEL 8, the accuracy option): streamlines on the interpolated energy.

From every point of P_j a streamline follows -grad E with a fixed-step Heun (RK2) integrator in
grid units. The gradient at a grid point is a central difference over its feasible neighbours
(one-sided where one neighbour is infeasible or off the grid, 0 where both are); between grid
points it is interpolated bilinearly from the feasible corners of the cell (weights renormalised).
The direction is normalised, so a jump of the energy at a mode boundary (a steep finite
difference) turns the streamline down the jump but never lengthens its step.

A streamline ends by the discrete method's rules, read at the grid point nearest to it: STABLE
(CAGED or TIP PREHENSION, end point that grid point), not in P_j or off the grid (EJECTION), or
stalled: the nearest grid point has no strictly lower feasible neighbour, the interpolated
gradient vanishes, the streamline stays near one grid point for STAY_LIMIT grid steps of travel
(a minimum of the interpolated energy that is no grid minimum), comes back near grid points it
had left more than MAX_REVISITS times (circling), or the step budget is spent.
"""
import math

import numpy as np


from .jit import entry, inner
from ..model import (
    END_CAGED,
    END_EJECTION,
    END_NONE,
    END_STALLED,
    END_TIP_PREHENSION,
    INFEASIBLE,
    REACHED,
)

# Step budget: a streamline longer than this many traversals of the grid (nx + ny grid steps)
# circles a flat region and counts as stalled.
TRAVERSALS = 4.0
# A streamline that travels this many grid steps without leaving one grid point's cell circles a
# minimum of the interpolated energy that is no grid minimum (typically next to an energy jump at
# a mode boundary): stalled.
STAY_LIMIT = 4.0
# A streamline that comes back near grid points it had left more than this many times circles
# a region with no grid minimum in it: stalled.
MAX_REVISITS = 2

# Neighbour order of the discrete method (its stall test is reused here).
_DI = (1, 1, 0, -1, -1, -1, 0, 1)
_DJ = (0, 1, 1, 1, 0, -1, -1, -1)


@entry
def node_gradient(energy, point_class, i, j):
    """dE/di, dE/dj (per grid step) at a feasible grid point from its feasible neighbours."""
    ny, nx = energy.shape
    e = energy[j, i]
    gi = 0.0
    gj = 0.0
    for axis in range(2):
        lo = 0.0
        hi = 0.0
        lo_ok = False
        hi_ok = False
        if axis == 0:
            if i > 0 and point_class[j, i - 1] != INFEASIBLE:
                lo_ok = True
                lo = energy[j, i - 1]
            if i < nx - 1 and point_class[j, i + 1] != INFEASIBLE:
                hi_ok = True
                hi = energy[j, i + 1]
        else:
            if j > 0 and point_class[j - 1, i] != INFEASIBLE:
                lo_ok = True
                lo = energy[j - 1, i]
            if j < ny - 1 and point_class[j + 1, i] != INFEASIBLE:
                hi_ok = True
                hi = energy[j + 1, i]
        if lo_ok and hi_ok:
            g = 0.5 * (hi - lo)
        elif hi_ok:
            g = hi - e
        elif lo_ok:
            g = e - lo
        else:
            g = 0.0
        if axis == 0:
            gi = g
        else:
            gj = g
    return gi, gj


@inner
def interpolated_gradient(energy, point_class, fi, fj):
    """Bilinear interpolation of the node gradients at (fi, fj) in grid units; (0, 0, False)
    when no corner of the cell is feasible."""
    ny, nx = energy.shape
    i0 = int(math.floor(fi))
    j0 = int(math.floor(fj))
    ti = fi - i0
    tj = fj - j0
    gi = 0.0
    gj = 0.0
    wsum = 0.0
    for c in range(4):
        di = c & 1
        dj = c >> 1
        i = i0 + di
        j = j0 + dj
        if i < 0 or i >= nx or j < 0 or j >= ny or point_class[j, i] == INFEASIBLE:
            continue
        wgt = (ti if di == 1 else 1.0 - ti) * (tj if dj == 1 else 1.0 - tj)
        if wgt <= 0.0:
            continue
        a, b = node_gradient(energy, point_class, i, j)
        gi += wgt * a
        gj += wgt * b
        wsum += wgt
    if wsum <= 0.0:
        return 0.0, 0.0, False
    return gi / wsum, gj / wsum, True


@inner
def has_lower_neighbour(energy, point_class, i, j):
    ny, nx = energy.shape
    here = energy[j, i]
    for n in range(8):
        ii = i + _DI[n]
        jj = j + _DJ[n]
        if ii < 0 or ii >= nx or jj < 0 or jj >= ny or point_class[jj, ii] == INFEASIBLE:
            continue
        if energy[jj, ii] < here:
            return True
    return False


@inner
def descent_direction(energy, point_class, fi, fj):
    """Unit vector along -grad E at (fi, fj), or (0, 0, False) where the gradient vanishes."""
    gi, gj, ok = interpolated_gradient(energy, point_class, fi, fj)
    norm = math.sqrt(gi * gi + gj * gj)
    if not ok or not (norm > 0.0) or not math.isfinite(norm):
        return 0.0, 0.0, False
    return -gi / norm, -gj / norm, True


@entry
def streamline_walk(energy, point_class, equilibrium, caged, i0, j0, step, max_steps, visited,
                    path):
    """(end_state, flat end index, points in `path`) of the streamline started at grid point
    (j0, i0). `visited[p]` holds the start's flat index once the streamline has been near grid
    point p. `path`: an array (max_steps + 1, 2) that receives the positions (i, j) in grid
    units (the picture draws them), or (0, 2): not recorded."""
    ny, nx = energy.shape
    fi = float(i0)
    fj = float(j0)
    last = j0 * nx + i0
    start = last
    visited[start] = start
    revisits = 0
    stay = 0
    n = 0
    recorded = path.shape[0] > 0
    for _ in range(max_steps):
        if recorded:
            path[n, 0] = fi
            path[n, 1] = fj
        n += 1
        i = int(math.floor(fi + 0.5))
        j = int(math.floor(fj + 0.5))
        if i < 0 or i >= nx or j < 0 or j >= ny:
            return END_EJECTION, last, n
        here = j * nx + i
        stay = stay + 1 if here == last else 0
        if step * stay > STAY_LIMIT:  # circling a minimum of the interpolated energy
            return END_STALLED, last, n
        if here != last:
            if visited[here] == start:  # back near a grid point it had left: circling
                revisits += 1
                if revisits > MAX_REVISITS:
                    return END_STALLED, here, n
            visited[here] = start
        last = here
        if point_class[j, i] != REACHED:
            return END_EJECTION, last, n
        if equilibrium[j, i]:
            return (END_CAGED if caged[j, i] else END_TIP_PREHENSION), last, n
        if not has_lower_neighbour(energy, point_class, i, j):
            return END_STALLED, last, n
        ui, uj, ok = descent_direction(energy, point_class, fi, fj)
        if not ok:
            return END_STALLED, last, n
        vi, vj, ok2 = descent_direction(energy, point_class, fi + step * ui, fj + step * uj)
        if ok2:  # Heun: average of the directions at both ends of the Euler step
            si = ui + vi
            sj = uj + vj
            norm = math.sqrt(si * si + sj * sj)
            if norm > 1e-12:
                ui = si / norm
                uj = sj / norm
        fi += step * ui
        fj += step * uj
    return END_STALLED, last, n


@inner
def streamline_end(outs, i0, j0, step, max_steps, visited):
    """(end_state, flat end index) of the streamline started at grid point (j0, i0)."""
    state, last, _ = streamline_walk(outs.energy, outs.point_class, outs.equilibrium, outs.caged,
                                     i0, j0, step, max_steps, visited, np.empty((0, 2)))
    return state, last


@entry
def max_streamline_steps(ny, nx, step):
    return int(TRAVERSALS * (nx + ny) / step) + 1


@entry
def streamline_ends(outs, h, stack, step):
    """end_state and end_index of the streamline from every point of P_j (integrator step
    `step` in grid steps); returns Lambda. `h` is unused (same signature as
    field.trajectory_ends; `stack` holds which start last visited each point)."""
    point_class = outs.point_class
    ny, nx = point_class.shape
    size = ny * nx
    max_steps = max_streamline_steps(ny, nx, step)
    for p in range(size):
        outs.end_state.flat[p] = END_NONE
        outs.end_index.flat[p] = -1
    for p in range(size):
        stack[p] = -1
    score_sum = 0.0
    for p in range(size):
        j = p // nx
        i = p - j * nx
        if point_class[j, i] != REACHED:
            continue
        state, last = streamline_end(outs, i, j, step, max_steps, stack)
        outs.end_state.flat[p] = state
        outs.end_index.flat[p] = last
        if state == END_CAGED:
            score_sum += outs.caging_score.flat[last]
    return score_sum

