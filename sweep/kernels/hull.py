"""Exact 2-D convex hulls of contact forces and the per-pose reduction of the manipulation metric
(MODEL 10, "Value of a pose" and "Parameter usage").

Why exact: the metric's hull of a union is the hull of the parts' hulls, and chunks of geometries
are reduced separately and merged later. With a floating-point orientation test, a nearly
collinear point can be a vertex in one chunk order and not in another. The orientation sign here
is exact (Shewchuk's error-free expansions behind a fast filter), so the hull vertex set is a pure
function of the set of input points, and every order or split gives bitwise the same hull.

Per-pose state (one row per pose, fixed capacity `cap`):

    pts[pose, k, :]  columns X, Y (the force), PMIN..PMIN+4 and PMAX..PMAX+4 (min / max of the
                     parameters w, l1, l2, r1, r2 over the geometries whose force is exactly this
                     point)
    first[pose, k]   the smallest geometry index among them
    n_hull[pose]     the first n_hull rows are the hull vertices, CCW, starting at the lowest
                     (then leftmost) vertex
    n_kept[pose]     rows n_hull .. n_kept-1 are "near" points: not vertices, but within reach of
                     the coincidence tolerance of the hull boundary, sorted by (x, y)

Coincidence (decided here, MODEL 10 leaves the scale of "1e-12 relative" open): a force p
coincides with a hull vertex v when |p - v| <= COINCIDE_REL |v|. It is relative to |v| rather
than to the pose's largest force so that it can be decided while streaming: a point that is
farther than that from the current hull's boundary can never coincide with a vertex of any larger
hull (hulls only grow, and distances from inside to the boundary only grow), so it is dropped for
good; near points are kept, generously (NEAR_KEEP_REL plus a round-off allowance), so every path
keeps every point that can coincide with a final vertex. The hull, the values and the parameter
usage are therefore identical whatever the order or split; the list of near points may differ
between paths only by points that coincide with nothing.

Nothing here raises or returns NaN/inf: overflow of a pose's capacity is reported in `status`
(the pose is left unchanged), non-finite forces are skipped and counted in `status` too.
"""
import math

import numpy as np
from numba import prange

from .jit import entry, inner

N_PARAMS = 5                      # w, l1, l2, r1, r2
X, Y = 0, 1
PMIN = 2
PMAX = PMIN + N_PARAMS
N_COLS = PMAX + N_PARAMS          # 12 float columns per kept point

COINCIDE_REL = 1e-12              # MODEL 10: forces that coincide with a hull vertex
INSIDE_REL = 1e-12                # MODEL 10: origin strictly inside, relative to the largest force
NEAR_KEEP_REL = 2.0 * COINCIDE_REL
# Allowance for the round-off of a point-to-segment distance, times the hull's coordinate scale.
ROUNDOFF_ALLOWANCE = 64.0 * 2.0 ** -52

STATUS_OK = 0
STATUS_OVERFLOW = 1               # the pose needs more capacity: grow and redo it
STATUS_NONFINITE = 2              # a counted force was NaN/inf and was skipped

_EPS = 2.0 ** -53                 # unit round-off
_CCW_ERRBOUND = (3.0 + 16.0 * _EPS) * _EPS
_SPLITTER = 134217729.0           # 2^27 + 1, Dekker's split


# ---------------------------------------------------------------------------------------------
# Exact orientation
# ---------------------------------------------------------------------------------------------
@inner
def _two_sum(a, b):
    s = a + b
    bv = s - a
    av = s - bv
    return s, (a - av) + (b - bv)


@inner
def _two_product(a, b):
    p = a * b
    c = _SPLITTER * a
    ahi = c - (c - a)
    alo = a - ahi
    c = _SPLITTER * b
    bhi = c - (c - b)
    blo = b - bhi
    err = alo * blo - (((p - ahi * bhi) - alo * bhi) - ahi * blo)
    return p, err


@inner
def _grow(expansion, length, value):
    """Add `value` to a nonoverlapping expansion in place (Shewchuk's Grow-Expansion)."""
    q = value
    for i in range(length):
        q, low = _two_sum(q, expansion[i])
        expansion[i] = low
    expansion[length] = q
    return length + 1


@inner
def _orient_exact(ax, ay, bx, by, cx, cy, expansion):
    """Sign of (b - a) x (c - a), exactly: the sum of six exact products."""
    n = np.int64(0)  # (not a Python 0: records.LEFT)
    for u, v, s in ((bx, cy, 1.0), (bx, ay, -1.0), (ax, cy, -1.0),
                    (by, cx, -1.0), (by, ax, 1.0), (ay, cx, 1.0)):
        p, e = _two_product(u, v)
        n = _grow(expansion, n, s * e)
        n = _grow(expansion, n, s * p)
    # Components grow in magnitude: the last nonzero one carries the sign of the sum.
    for i in range(n - 1, -1, -1):
        if expansion[i] > 0.0:
            return 1
        if expansion[i] < 0.0:
            return -1
    return 0


@entry
def orient(ax, ay, bx, by, cx, cy, expansion):
    """Exact sign of the turn a -> b -> c: +1 left (CCW), -1 right, 0 collinear.

    `expansion` is a scratch array of at least 12 floats (no allocation here)."""
    left = (ax - cx) * (by - cy)
    right = (ay - cy) * (bx - cx)
    det = left - right
    bound = _CCW_ERRBOUND * (abs(left) + abs(right))
    if det > bound:
        return 1
    if det < -bound:
        return -1
    return _orient_exact(ax, ay, bx, by, cx, cy, expansion)


# ---------------------------------------------------------------------------------------------
# Hull of a point list (rows of a float buffer with X, Y columns)
# ---------------------------------------------------------------------------------------------
@inner
def _lex_less(buf, i, j):
    if buf[i, X] < buf[j, X]:
        return True
    if buf[i, X] > buf[j, X]:
        return False
    return buf[i, Y] < buf[j, Y]


@inner
def _sort_rows(buf, order, n):
    """Indices of the first n rows in (x, y) order, rows of equal (x, y) in index order:
    insertion sort for the usual handful of rows, a bottom-up merge sort (stable) for the
    thousands a merge of many chunks brings. (Not np.argsort: its merge sort compiles for
    seconds, per array layout.)"""
    for i in range(n):
        order[i] = i
    if n <= 32:
        for i in range(1, n):
            k = order[i]
            j = i - 1
            while j >= 0 and _lex_less(buf, k, order[j]):
                order[j + 1] = order[j]
                j -= 1
            order[j + 1] = k
        return
    src = order[:n]
    dst = np.empty(n, dtype=np.int64)
    width = 1
    while width < n:
        for lo in range(0, n, 2 * width):
            mid = min(lo + width, n)
            hi = min(lo + 2 * width, n)
            i, j, k = lo, mid, lo
            while i < mid and j < hi:
                if _lex_less(buf, src[j], src[i]):  # strictly less: ties keep index order
                    dst[k] = src[j]
                    j += 1
                else:
                    dst[k] = src[i]
                    i += 1
                k += 1
            while i < mid:
                dst[k] = src[i]
                i += 1
                k += 1
            while j < hi:
                dst[k] = src[j]
                j += 1
                k += 1
        src, dst = dst, src
        width *= 2
    order[:n] = src


@inner
def _monotone_chain(ux, uy, n, chain, expansion):
    """Andrew's monotone chain on n distinct points sorted by (x, y).

    Writes the hull vertex indices CCW (starting at the first point) into `chain` (size >= 2n+1)
    and returns their number. Collinear points on edges are not vertices."""
    if n <= 2:
        for i in range(n):
            chain[i] = i
        return n
    k = 0
    for i in range(n):
        while k >= 2 and orient(ux[chain[k - 2]], uy[chain[k - 2]], ux[chain[k - 1]],
                                uy[chain[k - 1]], ux[i], uy[i], expansion) <= 0:
            k -= 1
        chain[k] = i
        k += 1
    lower = k + 1
    for i in range(n - 2, -1, -1):
        while k >= lower and orient(ux[chain[k - 2]], uy[chain[k - 2]], ux[chain[k - 1]],
                                    uy[chain[k - 1]], ux[i], uy[i], expansion) <= 0:
            k -= 1
        chain[k] = i
        k += 1
    return k - 1   # the last index repeats the first


@inner
def _canonical_start(ux, uy, chain, nv):
    """Position in the chain of the lowest, then leftmost, vertex."""
    best = 0
    for i in range(1, nv):
        a, b = chain[i], chain[best]
        if uy[a] < uy[b] or (uy[a] == uy[b] and ux[a] < ux[b]):
            best = i
    return best


@entry
def convex_hull(xs, ys):
    """Exact convex hull of n points: vertices CCW from the lowest-then-leftmost one.

    Duplicates and points on edges are not vertices; 1 or 2 vertices for degenerate sets,
    0 for an empty set. Non-finite points are ignored. Returns (hx, hy)."""
    n = xs.shape[0]
    buf = np.empty((n, 2))
    m = np.int64(0)
    for i in range(n):
        if math.isfinite(xs[i]) and math.isfinite(ys[i]):
            buf[m, X] = xs[i] + 0.0   # + 0.0 turns -0.0 into 0.0: one bit pattern per point
            buf[m, Y] = ys[i] + 0.0
            m += 1
    order = np.empty(m, dtype=np.int64)
    _sort_rows(buf, order, m)
    # points and hull as the columns of (n, 2) arrays, as the reductions' rows hold them: the
    # hull's helpers then compile once, for strided columns (one kernel set, no second signature)
    unique = np.empty((m, 2))
    ux = unique[:, X]
    uy = unique[:, Y]
    u = np.int64(0)
    for i in range(m):
        k = order[i]
        if u > 0 and buf[k, X] == ux[u - 1] and buf[k, Y] == uy[u - 1]:
            continue
        ux[u] = buf[k, X]
        uy[u] = buf[k, Y]
        u += 1
    chain = np.empty(2 * u + 1, dtype=np.int64)
    expansion = np.empty(16)
    nv = _monotone_chain(ux, uy, u, chain, expansion)
    start = _canonical_start(ux, uy, chain, nv)
    hull = np.empty((nv, 2))
    hx = hull[:, X]
    hy = hull[:, Y]
    for i in range(nv):
        c = chain[(start + i) % nv]
        hx[i] = ux[c]
        hy[i] = uy[c]
    return hx, hy


@entry
def inscribed_radius(hx, hy, nv):
    """Ferrari-Canny epsilon of a CCW hull: least distance from the origin to an edge if the
    origin is strictly inside (by INSIDE_REL of the largest vertex norm), else 0."""
    if nv < 3:
        return 0.0
    largest = 0.0
    for i in range(nv):
        largest = max(largest, math.hypot(hx[i], hy[i]))
    radius = math.inf
    for i in range(nv):
        ax, ay = hx[i], hy[i]
        bx, by = hx[(i + 1) % nv], hy[(i + 1) % nv]
        # (b - a) x (0 - a) = a x b: positive when the origin is left of the CCW edge.
        dist = (ax * by - ay * bx) / math.hypot(bx - ax, by - ay)
        radius = min(radius, dist)
    if radius > INSIDE_REL * largest:
        return radius
    return 0.0


# ---------------------------------------------------------------------------------------------
# Per-pose reduction
# ---------------------------------------------------------------------------------------------
@inner
def _segment_distance(px, py, ax, ay, bx, by):
    abx, aby = bx - ax, by - ay
    den = abx * abx + aby * aby
    s = 0.0
    if den > 0.0:
        s = min(max(((px - ax) * abx + (py - ay) * aby) / den, 0.0), 1.0)
    return math.hypot(px - (ax + s * abx), py - (ay + s * aby))


@inner
def _is_near(row, nh, px, py):
    """Could the point (not outside the hull) coincide with a vertex of this or any larger hull?"""
    scale = 0.0
    for i in range(nh):
        scale = max(scale, abs(row[i, X]), abs(row[i, Y]))
    scale = max(scale, abs(px), abs(py))
    dist = math.inf
    for i in range(nh):
        j = (i + 1) % nh
        dist = min(dist, _segment_distance(px, py, row[i, X], row[i, Y], row[j, X], row[j, Y]))
    return dist <= NEAR_KEEP_REL * math.hypot(px, py) + ROUNDOFF_ALLOWANCE * scale


@inner
def _merge_aggregate(dst, dst_first, k, src, src_first, s):
    """Combine the parameter ranges of src row s into dst row k (same point)."""
    for c in range(N_PARAMS):
        dst[k, PMIN + c] = min(dst[k, PMIN + c], src[s, PMIN + c])
        dst[k, PMAX + c] = max(dst[k, PMAX + c], src[s, PMAX + c])
    dst_first[k] = min(dst_first[k], src_first[s])


@inner
def _rebuild(cand, cand_first, m, uniq, uniq_first, order, chain, is_vertex, expansion,
             out, out_first, cap):
    """Reduce m candidate rows to the canonical state row: merge exact duplicates, exact hull,
    keep the near points. Writes out/out_first and returns (n_hull, n_kept), or (-1, -1) if the
    result does not fit in cap rows (out untouched)."""
    _sort_rows(cand, order, m)
    u = np.int64(0)
    for i in range(m):
        k = order[i]
        if u > 0 and cand[k, X] == uniq[u - 1, X] and cand[k, Y] == uniq[u - 1, Y]:
            _merge_aggregate(uniq, uniq_first, u - 1, cand, cand_first, k)
            continue
        for c in range(N_COLS):
            uniq[u, c] = cand[k, c]
        uniq_first[u] = cand_first[k]
        u += 1
    nv = _monotone_chain(uniq[:, X], uniq[:, Y], u, chain, expansion)
    start = _canonical_start(uniq[:, X], uniq[:, Y], chain, nv)
    for i in range(u):
        is_vertex[i] = False
    for i in range(nv):
        is_vertex[chain[i]] = True
    # Near points are decided against the new hull, whose rows go to the front of `cand`
    # (cand is free now: everything is in uniq).
    for i in range(nv):
        c = chain[(start + i) % nv]
        cand[i, X] = uniq[c, X]
        cand[i, Y] = uniq[c, Y]
    n = nv
    for i in range(u):
        if not is_vertex[i] and _is_near(cand, nv, uniq[i, X], uniq[i, Y]):
            n += 1
    if n > cap:
        return -1, -1
    for i in range(nv):
        c = chain[(start + i) % nv]
        for col in range(N_COLS):
            out[i, col] = uniq[c, col]
        out_first[i] = uniq_first[c]
    k = nv
    for i in range(u):   # uniq is sorted by (x, y): near points come out sorted
        if not is_vertex[i] and _is_near(cand, nv, uniq[i, X], uniq[i, Y]):
            for col in range(N_COLS):
                out[k, col] = uniq[i, col]
            out_first[k] = uniq_first[i]
            k += 1
    return nv, k


@inner
def _scratch(m):
    """Working arrays of `_rebuild` for up to m candidate rows (one set per block of poses)."""
    return (np.empty((m, N_COLS)), np.empty(m, dtype=np.int64), np.empty((m, N_COLS)),
            np.empty(m, dtype=np.int64), np.empty(m, dtype=np.int64),
            np.empty(2 * m + 1, dtype=np.int64), np.empty(m, dtype=np.bool_), np.empty(16))


@inner
def _blocks(n_items, n_blocks):
    """Contiguous pose blocks for prange (each block allocates its scratch once). n_blocks comes
    from the caller: numba.get_num_threads() inside a kernel would defeat the disk cache."""
    return max(1, min(n_items, n_blocks))


@entry(parallel=True)
def reduction_values(pts, n_hull, values):
    """values[pose] = inscribed radius of the pose's hull (MODEL 10 value of a pose)."""
    for pose in prange(pts.shape[0]):
        values[pose] = inscribed_radius(pts[pose, :, X], pts[pose, :, Y], n_hull[pose])


@entry
def vertex_groups(row, row_first, nh, nk, group_min, group_max, group_first):
    """Per hull vertex: parameter ranges and smallest geometry index over every geometry whose
    force coincides with the vertex (exactly, or another kept point within COINCIDE_REL |v|,
    which may be a near point or, on a hull with vertices closer than that, another vertex)."""
    for i in range(nh):
        for c in range(N_PARAMS):
            group_min[i, c] = row[i, PMIN + c]
            group_max[i, c] = row[i, PMAX + c]
        group_first[i] = row_first[i]
        vx, vy = row[i, X], row[i, Y]
        tol = COINCIDE_REL * math.hypot(vx, vy)
        for k in range(nk):
            if k != i and math.hypot(row[k, X] - vx, row[k, Y] - vy) <= tol:
                for c in range(N_PARAMS):
                    group_min[i, c] = min(group_min[i, c], row[k, PMIN + c])
                    group_max[i, c] = max(group_max[i, c], row[k, PMAX + c])
                group_first[i] = min(group_first[i], row_first[k])


@entry(parallel=True)
def reduction_parameter_ranges(pts, first, n_hull, n_kept, values, ranges, n_blocks):
    """ranges[pose, c] = max - min of parameter c over the geometries of all hull vertices of
    poses with a positive value (MODEL 10 parameter usage, before dividing by the search
    range); 0 elsewhere."""
    n_poses, cap = pts.shape[0], pts.shape[1]
    n_blocks = _blocks(n_poses, n_blocks)
    for b in prange(n_blocks):
        lo = b * n_poses // n_blocks
        hi = (b + 1) * n_poses // n_blocks
        group_min = np.empty((cap, N_PARAMS))
        group_max = np.empty((cap, N_PARAMS))
        group_first = np.empty(cap, dtype=np.int64)
        for pose in range(lo, hi):
            for c in range(N_PARAMS):
                ranges[pose, c] = 0.0
            nh = n_hull[pose]
            if not values[pose] > 0.0:
                continue
            vertex_groups(pts[pose], first[pose], nh, n_kept[pose], group_min, group_max,
                          group_first)
            for c in range(N_PARAMS):
                lowest = group_min[0, c]
                highest = group_max[0, c]
                for i in range(1, nh):
                    lowest = min(lowest, group_min[i, c])
                    highest = max(highest, group_max[i, c])
                ranges[pose, c] = highest - lowest


@entry(parallel=True)
def reduction_rebuild_ragged(seg_start, rows, rows_first, out_rows, out_first, out_hull,
                             out_kept, n_blocks):
    """The canonical state of every pose from all its candidate points at once (one `_rebuild`
    per pose): pose p's candidates are rows seg_start[p] .. seg_start[p+1]-1 (full state rows:
    raw forces, or the kept rows of several reductions being merged); its state goes to the
    same positions of out_rows / out_first (n_kept <= candidates), with out_hull[p],
    out_kept[p]. The state is a function of the candidate set (exact hull, duplicates merged,
    near points kept against the final hull), so adding points one at a time, merging chunks
    pairwise or rebuilding at once all give the same hull, values and usage."""
    n_poses = seg_start.shape[0] - 1
    m = np.int64(1)   # (not a Python 1: records.LEFT)
    for p in range(n_poses):
        m = max(m, seg_start[p + 1] - seg_start[p])
    n_blocks = _blocks(n_poses, n_blocks)
    for b in prange(n_blocks):
        lo = b * n_poses // n_blocks
        hi = (b + 1) * n_poses // n_blocks
        cand, cand_first, uniq, uniq_first, order, chain, is_vertex, expansion = _scratch(m)
        for pose in range(lo, hi):
            a = seg_start[pose]
            n = seg_start[pose + 1] - a
            for k in range(n):
                for col in range(N_COLS):
                    cand[k, col] = rows[a + k, col]
                cand[k, X] += 0.0   # one bit pattern for -0.0 and 0.0
                cand[k, Y] += 0.0
                cand_first[k] = rows_first[a + k]
            if n == 0:
                out_hull[pose] = 0
                out_kept[pose] = 0
                continue
            nh, nk = _rebuild(cand, cand_first, n, uniq, uniq_first, order, chain, is_vertex,
                              expansion, out_rows[a:a + n], out_first[a:a + n], n)
            out_hull[pose] = nh
            out_kept[pose] = nk
