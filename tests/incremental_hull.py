"""The incremental hull reduction: one geometry's forces added at a time to every pose, and two
reductions merged pose by pose. The sweep does not reduce this way (it rebuilds each pose from
all its points at once: compute.manipulation.PartReduction and hull.reduction_rebuild_ragged);
this second way, through the same exact hull kernels (hull._rebuild, orient), is what
tests/test_hull.py holds against Qhull and exact arithmetic, and against which the sweep's
answer must not depend on order or split."""
import math

import numba
import numpy as np
from numba import prange

from sweep.compute.manipulation import PARAMETER_NAMES, HullReduction, _pose_ranges
from sweep.kernels import hull
from sweep.kernels.hull import (
    N_COLS, N_PARAMS, PMAX, PMIN, STATUS_NONFINITE, STATUS_OK, STATUS_OVERFLOW,
    X, Y, _blocks, _is_near, _merge_aggregate, _rebuild, _scratch, orient,
)


@numba.njit(cache=True)
def _strictly_outside(row, nh, px, py, expansion):
    """True if the point is outside the hull (or the hull has fewer than 3 vertices)."""
    if nh < 3:
        return True
    for i in range(nh):
        j = (i + 1) % nh
        if orient(row[i, X], row[i, Y], row[j, X], row[j, Y], px, py, expansion) < 0:
            return True
    return False


@numba.njit(cache=True)
def _add_point(row, row_first, nh, nk, point, point_first, cand, cand_first, uniq, uniq_first,
               order, chain, is_vertex, expansion):
    """Add one point (a 1-row buffer with its parameters) to a pose's state row.

    Returns the new (n_hull, n_kept), or (-1, -1) on overflow (row unchanged)."""
    cap = row.shape[0]
    px, py = point[0, X], point[0, Y]
    for k in range(nk):                            # the same force again: widen its ranges
        if row[k, X] == px and row[k, Y] == py:
            _merge_aggregate(row, row_first, k, point, point_first, 0)
            return nh, nk
    if not _strictly_outside(row, nh, px, py, expansion):
        if not _is_near(row, nh, px, py):
            return nh, nk                          # deep inside: can never matter again
        if nk + 1 > cap:
            return -1, -1
        pos = nk                                   # insert among the near points by (x, y)
        while pos > nh and (px < row[pos - 1, X]
                            or (px == row[pos - 1, X] and py < row[pos - 1, Y])):
            for col in range(N_COLS):
                row[pos, col] = row[pos - 1, col]
            row_first[pos] = row_first[pos - 1]
            pos -= 1
        for col in range(N_COLS):
            row[pos, col] = point[0, col]
        row_first[pos] = point_first[0]
        return nh, nk + 1
    for k in range(nk):
        for col in range(N_COLS):
            cand[k, col] = row[k, col]
        cand_first[k] = row_first[k]
    for col in range(N_COLS):
        cand[nk, col] = point[0, col]
    cand_first[nk] = point_first[0]
    return _rebuild(cand, cand_first, nk + 1, uniq, uniq_first, order, chain, is_vertex,
                    expansion, row, row_first, cap)


@numba.njit(cache=True, parallel=True)
def reduction_add(pts, first, n_hull, n_kept, fx, fy, counts, geometry_index, params, status,
                  n_blocks):
    """Add one geometry's forces (fx[pose], fy[pose], where counts[pose]) to every pose.

    params: the geometry's (w, l1, l2, r1, r2). status[pose] is set to STATUS_OVERFLOW where the
    pose's capacity is exceeded (that pose is left unchanged; grow and redo it), to
    STATUS_NONFINITE where a counted force is not finite (skipped), else STATUS_OK."""
    n_poses, cap = pts.shape[0], pts.shape[1]
    n_blocks = _blocks(n_poses, n_blocks)
    for b in prange(n_blocks):
        lo = b * n_poses // n_blocks
        hi = (b + 1) * n_poses // n_blocks
        m = cap + 1
        cand, cand_first, uniq, uniq_first, order, chain, is_vertex, expansion = _scratch(m)
        point = np.empty((1, N_COLS))
        point_first = np.empty(1, dtype=np.int64)
        for c in range(N_PARAMS):
            point[0, PMIN + c] = params[c]
            point[0, PMAX + c] = params[c]
        point_first[0] = geometry_index
        for pose in range(lo, hi):
            status[pose] = STATUS_OK
            if not counts[pose]:
                continue
            if not (math.isfinite(fx[pose]) and math.isfinite(fy[pose])):
                status[pose] = STATUS_NONFINITE
                continue
            point[0, X] = fx[pose] + 0.0
            point[0, Y] = fy[pose] + 0.0
            nh, nk = _add_point(pts[pose], first[pose], n_hull[pose], n_kept[pose], point,
                                point_first, cand, cand_first, uniq, uniq_first, order, chain,
                                is_vertex, expansion)
            if nh < 0:
                status[pose] = STATUS_OVERFLOW
            else:
                n_hull[pose] = nh
                n_kept[pose] = nk


@numba.njit(cache=True, parallel=True)
def reduction_merge(pts_a, first_a, n_kept_a, pts_b, first_b, n_kept_b,
                    out, out_first, out_hull, out_kept, status, n_blocks):
    """out = merge of reductions a and b, pose by pose (the hull of the union of their points).

    status[pose] = STATUS_OVERFLOW where out's capacity is too small (that pose is not written)."""
    n_poses, cap = out.shape[0], out.shape[1]
    m = pts_a.shape[1] + pts_b.shape[1]
    n_blocks = _blocks(n_poses, n_blocks)
    for b in prange(n_blocks):
        lo = b * n_poses // n_blocks
        hi = (b + 1) * n_poses // n_blocks
        cand, cand_first, uniq, uniq_first, order, chain, is_vertex, expansion = _scratch(m)
        for pose in range(lo, hi):
            status[pose] = STATUS_OK
            n = 0
            for k in range(n_kept_a[pose]):
                for col in range(N_COLS):
                    cand[n, col] = pts_a[pose, k, col]
                cand_first[n] = first_a[pose, k]
                n += 1
            for k in range(n_kept_b[pose]):
                for col in range(N_COLS):
                    cand[n, col] = pts_b[pose, k, col]
                cand_first[n] = first_b[pose, k]
                n += 1
            if n == 0:
                out_hull[pose] = 0
                out_kept[pose] = 0
                continue
            nh, nk = _rebuild(cand, cand_first, n, uniq, uniq_first, order, chain, is_vertex,
                              expansion, out[pose], out_first[pose], cap)
            if nh < 0:
                status[pose] = STATUS_OVERFLOW
            else:
                out_hull[pose] = nh
                out_kept[pose] = nk


class IncrementalHull(HullReduction):
    """A HullReduction grown one geometry at a time (`add`) or by merging (`merge`)."""

    def _grow(self, capacity: int) -> None:
        points = np.zeros((self.n_poses, capacity, hull.N_COLS))
        first = np.zeros((self.n_poses, capacity), dtype=np.int64)
        points[:, :self.capacity] = self.points
        first[:, :self.capacity] = self.first
        self.points, self.first = points, first

    def add(self, fx, fy, counts, geometry_index: int, params) -> None:
        """Add one geometry's forces at every pose: fx[pose], fy[pose] where counts[pose].

        params: the geometry's (w, l1, l2, r1, r2). A counted force that is not finite is an
        error of the caller (ValueError, nothing added)."""
        fx = np.ascontiguousarray(fx, dtype=np.float64)
        fy = np.ascontiguousarray(fy, dtype=np.float64)
        counts = np.ascontiguousarray(counts, dtype=np.bool_)
        params = np.ascontiguousarray(params, dtype=np.float64)
        if not (fx.shape == fy.shape == counts.shape == (self.n_poses,)):
            raise ValueError(f"fx, fy, counts must have shape ({self.n_poses},)")
        if params.shape != (hull.N_PARAMS,):
            raise ValueError(f"params must be the {hull.N_PARAMS} values {PARAMETER_NAMES}")
        if not (np.isfinite(fx[counts]).all() and np.isfinite(fy[counts]).all()):
            raise ValueError("a counted force is not finite")
        status = np.zeros(self.n_poses, dtype=np.int64)
        todo = counts
        while True:
            reduction_add(self.points, self.first, self.n_hull, self.n_kept, fx, fy, todo,
                                np.int64(geometry_index), params, status, _pose_ranges())
            overflow = status == hull.STATUS_OVERFLOW
            if not overflow.any():
                return
            # Overflowed poses were left unchanged: grow and redo exactly those.
            self._grow(2 * self.capacity)
            todo = overflow

    def add_geometry(self, f_left, f_right, counts, commands, geometry_index: int,
                     params) -> None:
        """Add one geometry under every command (MODEL 10): at each counted pose the force
        F_left f_left + F_right f_right for each (F_left, F_right) in commands.

        f_left, f_right: (n_poses, 2) per-unit-tension resultants of each finger on the part,
        world frame, already multiplied by the pose's S_geo."""
        f_left = np.asarray(f_left, dtype=np.float64)
        f_right = np.asarray(f_right, dtype=np.float64)
        if f_left.shape != (self.n_poses, 2) or f_right.shape != (self.n_poses, 2):
            raise ValueError(f"f_left and f_right must have shape ({self.n_poses}, 2)")
        for f_l, f_r in commands:
            force = f_l * f_left + f_r * f_right
            self.add(force[:, 0], force[:, 1], counts, geometry_index, params)

    def merge(self, other: "IncrementalHull") -> "IncrementalHull":
        """A new reduction holding the union of both (the hull of the union of their forces)."""
        if other.n_poses != self.n_poses:
            raise ValueError("reductions of different pose lattices cannot be merged")
        capacity = max(self.capacity, other.capacity)
        status = np.zeros(self.n_poses, dtype=np.int64)
        while True:
            out = IncrementalHull.empty(self.n_poses, capacity)
            reduction_merge(self.points, self.first, self.n_kept, other.points,
                                  other.first, other.n_kept, out.points, out.first, out.n_hull,
                                  out.n_kept, status, _pose_ranges())
            if not (status == hull.STATUS_OVERFLOW).any():
                return out
            capacity *= 2

    def hull(self, pose: int) -> dict:
        """The hull at one pose: vertices (CCW from the lowest-then-leftmost), and per vertex the
        parameter ranges and smallest index of the geometries whose forces coincide with it."""
        nh, nk = int(self.n_hull[pose]), int(self.n_kept[pose])
        row = self.points[pose]
        group_min = np.zeros((max(nh, 1), hull.N_PARAMS))
        group_max = np.zeros((max(nh, 1), hull.N_PARAMS))
        group_first = np.zeros(max(nh, 1), dtype=np.int64)
        hull.vertex_groups(row, self.first[pose], nh, nk, group_min, group_max, group_first)
        return {"x": row[:nh, hull.X].copy(), "y": row[:nh, hull.Y].copy(),
                "param_min": group_min[:nh], "param_max": group_max[:nh],
                "first_geometry": group_first[:nh]}

    def to_arrays(self) -> dict:
        """Flat arrays (ragged rows as offsets + concatenation), for HDF5 shards."""
        offsets = np.zeros(self.n_poses + 1, dtype=np.int64)
        np.cumsum(self.n_kept, out=offsets[1:])
        keep = np.arange(self.capacity)[None, :] < self.n_kept[:, None]
        rows = self.points[keep]
        return {
            "offsets": offsets,
            "n_hull": self.n_hull.copy(),
            "force": rows[:, :2].copy(),
            "param_min": rows[:, hull.PMIN:hull.PMIN + hull.N_PARAMS].copy(),
            "param_max": rows[:, hull.PMAX:hull.PMAX + hull.N_PARAMS].copy(),
            "first_geometry": self.first[keep].copy(),
        }

