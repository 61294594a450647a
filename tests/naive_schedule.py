"""Slow reference for schedules of settings (MODEL 12; model-notes D35): plain Python, one start
after another, from the maps' own per-point fields, without the lattice, the grouping of starts
or the matrix products of sweep.compute.schedules.

A map here is anything with `x`, `y` (its grid) and per-point fields on (y, x): `end_state`,
`end_index` (flat index into its own grid), `caging_score`, and for `walk_grid8` also `energy`,
`point_class`, `equilibrium`. Two maps meet at a part position by its coordinates: a point of
one map is the point of the other within half a step in x and y (MODEL 8's grids put every map
of one chassis and part on x = i h, y = r + j h), or none.

- `walk_grid8(m, j, i)`: MODEL 8's 8-neighbour steepest descent (trajectory `grid8`) from a grid
  point, on the map's energy, classes and equilibrium: the trajectory run point by point.
- `schedule(maps, walk=...)`: every start of the first map through the settings in order, the
  part carried from one map's end to the next map's grid point at the same place, each map's
  trajectory run there (`walk=True`: by walk_grid8; False: read from its end fields). Returns
  Lambda (the caging scores at the caged final ends, summed start by start), the counts, and
  each start's final end by coordinates.
"""
from __future__ import annotations

import math

from sweep.model import (END_CAGED, END_EJECTION, END_NONE, END_STALLED, END_TIP_PREHENSION,
                         INFEASIBLE, REACHED)

CONTINUING = (END_CAGED, END_TIP_PREHENSION, END_STALLED)
# E, NE, N, NW, W, SW, S, SE: MODEL 8's order for ties
NEIGHBOURS = ((1, 0), (1, 1), (0, 1), (-1, 1), (-1, 0), (-1, -1), (0, -1), (1, -1))


def field(m, name):
    fields = getattr(m, "fields", None)
    return fields[name] if fields is not None else getattr(m, name)


def walk_grid8(m, j: int, i: int) -> tuple[int, int, int]:
    """(end state, end row, end column) of the grid8 trajectory from (j, i) of map m."""
    energy, cls = field(m, "energy"), field(m, "point_class")
    equilibrium, score = field(m, "equilibrium"), field(m, "caging_score")
    ny, nx = len(m.y), len(m.x)
    h = float(m.x[1] - m.x[0])
    for _ in range(ny * nx + 1):
        if cls[j][i] != REACHED:
            return END_EJECTION, j, i
        if equilibrium[j][i]:
            return (END_CAGED if score[j][i] > 0 else END_TIP_PREHENSION), j, i
        best, best_slope = None, 0.0
        for di, dj in NEIGHBOURS:
            jj, ii = j + dj, i + di
            if not (0 <= jj < ny and 0 <= ii < nx) or cls[jj][ii] == INFEASIBLE:
                continue
            slope = (energy[j][i] - energy[jj][ii]) / (h if di == 0 or dj == 0
                                                        else h * math.sqrt(2.0))
            if slope > best_slope:
                best, best_slope = (jj, ii), slope
        if best is None:
            return END_STALLED, j, i
        j, i = best
    raise RuntimeError("a grid8 trajectory did not end")


def trajectory(m, j: int, i: int, walk: bool) -> tuple[int, int, int]:
    """Where map m's trajectory from (j, i) ends: (state, row, column); END_NONE off P_j."""
    if walk:
        if field(m, "point_class")[j][i] != REACHED:
            return END_NONE, -1, -1
        return walk_grid8(m, j, i)
    state = int(field(m, "end_state")[j][i])
    if state == END_NONE:
        return END_NONE, -1, -1
    ej, ei = divmod(int(field(m, "end_index")[j][i]), len(m.x))
    return state, ej, ei


def grid_point(m, x: float, y: float):
    """(row, column) of map m's grid point at (x, y), or None."""
    h = float(m.x[1] - m.x[0])
    cols = [i for i, v in enumerate(m.x) if abs(float(v) - x) < 0.5 * h]
    rows = [j for j, v in enumerate(m.y) if abs(float(v) - y) < 0.5 * h]
    return (rows[0], cols[0]) if cols and rows else None


def schedule(maps: list, walk: bool = False) -> dict:
    """The schedule through `maps` in order (consecutive maps are different settings) from every
    start of the first map: {"lam", "n_caged", "n_tip", "final": {(x, y): (state, x_end,
    y_end)}} (a start lost on the way: state END_NONE, no end). `lam` and `n_tip` count each
    start of the first row, on the palm line, as half (model-notes D36: the trapezoid)."""
    first = maps[0]
    lam, n_caged, n_tip, final = 0.0, 0, 0, {}
    for j in range(len(first.y)):
        for i in range(len(first.x)):
            state, ej, ei = trajectory(first, j, i, walk)
            if state == END_NONE:
                continue
            m = first
            for then in maps[1:]:
                if state not in CONTINUING:
                    break
                at = grid_point(then, float(m.x[ei]), float(m.y[ej]))
                if at is None:
                    state = END_NONE
                    break
                state, ej, ei = trajectory(then, at[0], at[1], walk)
                m = then
                if state == END_NONE:
                    break
            key = (float(first.x[i]), float(first.y[j]))
            if state == END_NONE:
                final[key] = (END_NONE, math.nan, math.nan)
                continue
            final[key] = (state, float(m.x[ei]), float(m.y[ej]))
            weight = 0.5 if j == 0 else 1.0
            if state == END_CAGED:
                lam += weight * float(field(m, "caging_score")[ej][ei])
                n_caged += 1
            elif state == END_TIP_PREHENSION:
                n_tip += weight
    return dict(lam=lam, n_caged=n_caged, n_tip=n_tip, final=final)
