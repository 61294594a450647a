"""Exact hull, Ferrari-Canny radius and the mergeable per-pose reduction (MODEL 10).

References: scipy.spatial.ConvexHull (Qhull; its facet equations give the origin's distance to
each edge), exact rational arithmetic (fractions.Fraction) and hand-built shapes.

The property that random splits merge to the one-pass reduction draws 15 examples in `make
test`, 60 in `make test-long` (SWEEP_LONG_PROPERTIES=1, tests/profiles.py)."""
from fractions import Fraction

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st
from scipy.spatial import ConvexHull, QhullError

from sweep.kernels.hull import convex_hull, inscribed_radius, orient
from sweep.compute.manipulation import PAPER_SEARCH_RANGES
from incremental_hull import IncrementalHull

from profiles import LONG_PROPERTIES

REL = 1e-12   # MODEL 10's tolerances, spelled out here from the text


# ---------------------------------------------------------------------------------------------
# Independent references
# ---------------------------------------------------------------------------------------------
def scipy_hull(points):
    """(vertices CCW from the lowest-then-leftmost, radius) by Qhull; (<= 2 points, 0) if flat."""
    points = np.asarray(points, dtype=float)
    try:
        hull = ConvexHull(points)
    except (QhullError, ValueError):
        return None, 0.0
    verts = points[hull.vertices]               # 2-D: counter-clockwise order
    start = min(range(len(verts)), key=lambda i: (verts[i, 1], verts[i, 0]))
    verts = np.roll(verts, -start, axis=0)
    dist = -hull.equations[:, 2]                # unit outward normals: offset = -distance
    largest = np.hypot(points[:, 0], points[:, 1]).max()
    radius = dist.min() if dist.min() > REL * largest else 0.0
    return verts, radius


def kernel_hull(points):
    points = np.asarray(points, dtype=float).reshape(-1, 2)
    hx, hy = convex_hull(np.ascontiguousarray(points[:, 0]), np.ascontiguousarray(points[:, 1]))
    return np.column_stack([hx, hy]), inscribed_radius(hx, hy, len(hx))


def random_point_set(rng):
    """Random sets of 3..60 points: general position, heavy duplicates, collinear runs."""
    n = int(rng.integers(3, 61))
    kind = rng.integers(4)
    if kind == 0:                                   # general position around the origin
        pts = rng.normal(size=(n, 2)) * rng.uniform(0.1, 10.0) + rng.normal(size=2) * 0.5
    elif kind == 1:                                 # few distinct points, many duplicates
        base = rng.normal(size=(int(rng.integers(1, 6)), 2))
        pts = base[rng.integers(len(base), size=n)]
    elif kind == 2:                                 # small integer lattice: collinear runs
        pts = rng.integers(-3, 4, size=(n, 2)).astype(float)
    else:                                           # points on a few exact lines through lattice
        a = rng.integers(-4, 5, size=(3, 2)).astype(float)
        b = rng.integers(-4, 5, size=(3, 2)).astype(float)
        line = rng.integers(3, size=n)
        t = rng.integers(0, 9, size=n) / 8.0        # dyadic steps: the points lie exactly on it
        pts = a[line] + t[:, None] * (b[line] - a[line])
    return pts


# ---------------------------------------------------------------------------------------------
# Against Qhull
# ---------------------------------------------------------------------------------------------
def test_hull_and_radius_match_qhull_on_random_sets():
    rng = np.random.default_rng(20261123)
    flat = 0
    for _ in range(1200):
        pts = random_point_set(rng)
        ref_verts, ref_radius = scipy_hull(pts)
        verts, radius = kernel_hull(pts)
        if ref_verts is None:                       # Qhull: all points on a line (or one point)
            flat += 1
            assert len(verts) <= 2 and radius == 0.0
            continue
        np.testing.assert_array_equal(verts, ref_verts)
        np.testing.assert_allclose(radius, ref_radius, rtol=1e-10, atol=1e-14)
    assert flat > 10                                # the degenerate branch was exercised


def test_hull_is_ccw_and_starts_at_lowest_then_leftmost():
    rng = np.random.default_rng(3)
    for _ in range(200):
        verts, _ = kernel_hull(random_point_set(rng))
        if len(verts) < 3:
            continue
        x, y = verts[:, 0], verts[:, 1]
        assert 0.5 * np.sum(x * np.roll(y, -1) - np.roll(x, -1) * y) > 0
        lowest = min(map(tuple, verts), key=lambda p: (p[1], p[0]))
        assert tuple(verts[0]) == lowest


# ---------------------------------------------------------------------------------------------
# Hand-built cases
# ---------------------------------------------------------------------------------------------
SQUARE = [(1, 1), (-1, 1), (-1, -1), (1, -1)]


@pytest.mark.parametrize("points, radius, n_vertices", [
    pytest.param(SQUARE, 1.0, 4, id="square-about-origin"),
    pytest.param(SQUARE + [(0, 0), (0.5, 0.5), (1, 0), (0, -1)] + SQUARE, 1.0, 4,
                 id="square-with-duplicates-interior-and-edge-points"),
    pytest.param([(np.cos(a), np.sin(a)) for a in np.arange(6) * np.pi / 3], np.cos(np.pi / 6), 6,
                 id="regular-hexagon"),
    pytest.param([(0, -1), (2, -1), (2, 1), (0, 1)], 0.0, 4, id="origin-on-an-edge"),
    pytest.param([(0, 0), (2, 0), (0, 2)], 0.0, 3, id="origin-is-a-vertex"),
    pytest.param([(1, -1), (3, -1), (3, 1), (1, 1)], 0.0, 4, id="origin-outside"),
    pytest.param([(-1, -1), (0, 0), (1, 1), (2, 2)], 0.0, 2, id="collinear-through-origin"),
    pytest.param([(-2, 1), (3, 1), (0, 1)], 0.0, 2, id="collinear-off-origin"),
    pytest.param([(1, 2), (-1, -2)], 0.0, 2, id="two-forces"),
    pytest.param([(1, 2)], 0.0, 1, id="one-force"),
    pytest.param([(1, 2)] * 5, 0.0, 1, id="one-force-repeated"),
    pytest.param(np.zeros((0, 2)), 0.0, 0, id="no-force"),
    pytest.param([(-1, -1), (3, -1), (-1, 3)], 1.0, 3, id="triangle-inradius-about-origin"),
])
def test_hand_built_hulls(points, radius, n_vertices):
    verts, got = kernel_hull(points)
    assert len(verts) == n_vertices
    assert got == pytest.approx(radius, rel=1e-14, abs=0.0)


def test_strictly_inside_uses_the_relative_tolerance():
    # The origin `offset` inside the left edge of a square x in [-offset, 2 - offset]: 1e-14 is
    # below 1e-12 of the largest force (~2.2), so not strictly inside; 1e-9 is inside.
    for offset, expected in ((1e-14, 0.0), (1e-9, 1e-9)):
        pts = [(x + 1 - offset, y) for x, y in [(-1, -1), (1, -1), (1, 1), (-1, 1)]]
        verts, radius = kernel_hull(pts)
        assert radius == pytest.approx(expected, rel=1e-6, abs=0.0)


def test_duplicates_of_minus_zero_are_one_point():
    verts, _ = kernel_hull([(0.0, 1.0), (-0.0, 1.0), (1.0, 0.0), (0.0, -0.0), (0.0, 0.0)])
    assert len(verts) == 3
    assert not np.signbit(verts).any()


def fraction_orient(a, b, c):
    ax, ay, bx, by, cx, cy = (Fraction(v) for v in (*a, *b, *c))
    det = (bx - ax) * (cy - ay) - (by - ay) * (cx - ax)
    return (det > 0) - (det < 0)


def test_orientation_is_exact_on_nearly_collinear_points():
    # The classic failure of the float formula: points within a few ulps of the line y = x.
    expansion = np.empty(16)
    ulp = 2.0 ** -53
    b, c = (12.0, 12.0), (24.0, 24.0)
    wrong = 0
    for i in range(64):
        for j in range(64):
            a = (0.5 + i * ulp, 0.5 + j * ulp)
            exact = fraction_orient(a, b, c)
            naive = np.sign((b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]))
            wrong += naive != exact
            assert orient(*a, *b, *c, expansion) == exact
    assert wrong > 0                                # the float formula does fail here


def test_orientation_is_exact_on_random_near_degenerate_triples():
    rng = np.random.default_rng(11)
    expansion = np.empty(16)
    for _ in range(3000):
        a, b = rng.normal(size=2), rng.normal(size=2)
        t = rng.uniform(-2, 3)
        c = a + t * (b - a)
        c = c + rng.integers(-3, 4, size=2) * np.spacing(np.abs(c))
        assert orient(*a, *b, *c, expansion) == fraction_orient(a, b, c)


# ---------------------------------------------------------------------------------------------
# Order independence of the hull
# ---------------------------------------------------------------------------------------------
coordinate = st.integers(-6, 6).map(lambda k: k / 4.0) | st.floats(-3, 3, allow_nan=False,
                                                                    width=64)
point_lists = st.lists(st.tuples(coordinate, coordinate), min_size=0, max_size=40)


@given(point_lists, st.randoms(use_true_random=False))
def test_hull_is_invariant_to_permutation(points, rnd):
    shuffled = list(points)
    rnd.shuffle(shuffled)
    a, ra = kernel_hull(np.array(points, dtype=float).reshape(-1, 2))
    b, rb = kernel_hull(np.array(shuffled, dtype=float).reshape(-1, 2))
    assert np.array_equal(a, b) and ra == rb


# ---------------------------------------------------------------------------------------------
# The per-pose reduction
# ---------------------------------------------------------------------------------------------
def random_geometries(rng, n_geometries, n_poses):
    """Forces with exact repeats across geometries, near-coincident copies (within 1e-13
    relative), lattice points with collinear runs, and poses where a geometry does not count."""
    forces = np.empty((n_geometries, n_poses, 2))
    pool = rng.normal(size=(n_poses, 8, 2))
    pool[:, :4] = rng.integers(-3, 4, size=(n_poses, 4, 2))
    for g in range(n_geometries):
        pick = rng.integers(8, size=n_poses)
        forces[g] = pool[np.arange(n_poses), pick]
        jitter = rng.random(n_poses) < 0.3
        forces[g, jitter] *= 1.0 + rng.uniform(-5e-14, 5e-14, size=(jitter.sum(), 1))
    counts = rng.random((n_geometries, n_poses)) < 0.85
    params = rng.uniform(0, 2, size=(n_geometries, 5)).round(1)
    return forces, counts, params


def reduce_all(forces, counts, params, order, capacity=4):
    red = IncrementalHull.empty(forces.shape[1], capacity)
    for g in order:
        red.add(forces[g, :, 0], forces[g, :, 1], counts[g], g, params[g])
    return red


def summary(red):
    """Everything that must not depend on order or split (not the list of near points)."""
    hulls = [red.hull(p) for p in range(red.n_poses)]
    return (red.values(), red.parameter_ranges(), red.n_hull,
            [np.concatenate([h["x"], h["y"], h["param_min"].ravel(), h["param_max"].ravel(),
                             h["first_geometry"]]) for h in hulls])


def assert_same(s1, s2):
    for a, b in zip(s1[:3], s2[:3]):
        np.testing.assert_array_equal(a, b)
    for a, b in zip(s1[3], s2[3]):
        np.testing.assert_array_equal(a, b)


def reference_pose(points, geometries, params, search_ranges):
    """MODEL 10 straight from the text, with Qhull: (value, usage ranges or None)."""
    if len(points) == 0:
        return 0.0, None
    points = np.asarray(points)
    verts, value = scipy_hull(points)
    if value <= 0.0:
        return 0.0, None
    used = set()
    for v in verts:
        near = np.hypot(*(points - v).T) <= REL * np.hypot(*v)
        used.update(np.asarray(geometries)[near])
    chosen = params[sorted(used)]
    return value, (chosen.max(axis=0) - chosen.min(axis=0)) / search_ranges


def test_reduction_matches_a_per_pose_reference():
    rng = np.random.default_rng(5)
    forces, counts, params = random_geometries(rng, 30, 40)
    red = reduce_all(forces, counts, params, range(30))
    ranges = np.asarray(PAPER_SEARCH_RANGES)
    values = red.values()
    usages = []
    for pose in range(40):
        geoms = np.flatnonzero(counts[:, pose])
        value, usage = reference_pose(forces[geoms, pose], geoms, params, ranges)
        assert values[pose] == pytest.approx(value, rel=1e-10, abs=1e-14)
        if usage is not None:
            usages.append(usage)
            np.testing.assert_allclose(red.parameter_ranges()[pose] / ranges, usage, rtol=1e-12)
    assert len(usages) > 5
    np.testing.assert_allclose(red.parameter_usage(), np.mean(usages, axis=0), rtol=1e-12)


def test_near_coincident_geometries_count_for_the_vertex():
    # Geometry 1's force is 1e-13 (relative) inside geometry 0's vertex: both geometries count.
    square = np.array(SQUARE, dtype=float)
    red = IncrementalHull.empty(1)
    params = np.array([[0.0, 0.4, 0.4, 0.04, 0.02], [2.0, 2.0, 1.6, 0.2, 0.18]])
    red.add(square[:, 0][:1], square[:, 1][:1], [True], 0, params[0])
    red.add(square[:1, 0] * (1 - 1e-13), square[:1, 1] * (1 - 1e-13), [True], 1, params[1])
    for i, (x, y) in enumerate(square[1:]):
        red.add([x], [y], [True], 2 + i, params[0])
    np.testing.assert_allclose(red.parameter_usage(), np.ones(5), rtol=1e-12)  # lower..upper
    hull = red.hull(0)
    top_right = np.flatnonzero((hull["x"] == 1.0) & (hull["y"] == 1.0))[0]
    assert hull["first_geometry"][top_right] == 0
    np.testing.assert_array_equal(hull["param_max"][top_right], params[1])
    # ... while a force 1e-9 inside does not coincide.
    far = IncrementalHull.empty(1)
    far.add([1.0], [1.0], [True], 0, params[0])
    far.add([1 - 1e-9], [1 - 1e-9], [True], 1, params[1])
    for i, (x, y) in enumerate(square[1:]):
        far.add([x], [y], [True], 2 + i, params[0])
    np.testing.assert_array_equal(far.parameter_usage(), np.zeros(5))


def test_overflow_grows_and_gives_the_same_result():
    rng = np.random.default_rng(8)
    forces, counts, params = random_geometries(rng, 25, 12)
    small = reduce_all(forces, counts, params, range(25), capacity=1)
    large = reduce_all(forces, counts, params, range(25), capacity=128)
    assert small.capacity > 1
    assert_same(summary(small), summary(large))


def test_arrays_round_trip_and_merge_after_storage():
    rng = np.random.default_rng(9)
    forces, counts, params = random_geometries(rng, 20, 15)
    a = reduce_all(forces, counts, params, range(10))
    b = reduce_all(forces, counts, params, range(10, 20))
    a2 = IncrementalHull.from_arrays(a.to_arrays())
    for key, value in a.to_arrays().items():
        np.testing.assert_array_equal(a2.to_arrays()[key], value)
    whole = reduce_all(forces, counts, params, range(20))
    assert_same(summary(a2.merge(IncrementalHull.from_arrays(b.to_arrays()))), summary(whole))


def test_invalid_input_is_refused():
    red = IncrementalHull.empty(2)
    with pytest.raises(ValueError):
        red.add([1.0, np.nan], [0.0, 0.0], [True, True], 0, np.zeros(5))
    red.add([1.0, np.nan], [0.0, 0.0], [True, False], 0, np.zeros(5))   # not counted: fine
    assert list(red.n_kept) == [1, 0]
    with pytest.raises(ValueError):
        red.add([1.0], [0.0], [True], 0, np.zeros(5))
    with pytest.raises(ValueError):
        red.merge(IncrementalHull.empty(3))


def test_no_positive_pose_gives_undefined_usage():
    red = IncrementalHull.empty(1)
    red.add([1.0], [0.0], [True], 0, np.ones(5))
    assert np.isnan(red.parameter_usage()).all()
    assert red.values()[0] == 0.0


@settings(max_examples=60 if LONG_PROPERTIES else 15)
@given(st.integers(0, 2**32 - 1), st.lists(st.integers(1, 19), max_size=4, unique=True),
       st.randoms(use_true_random=False))
def test_merge_of_random_splits_equals_one_pass_bitwise(seed, cuts, rnd):
    rng = np.random.default_rng(seed)
    forces, counts, params = random_geometries(rng, 20, 10)
    one_pass = summary(reduce_all(forces, counts, params, range(20)))
    order = list(range(20))
    rnd.shuffle(order)
    assert_same(summary(reduce_all(forces, counts, params, order)), one_pass)
    bounds = [0, *sorted(cuts), 20]
    parts = [reduce_all(forces, counts, params, order[lo:hi]) for lo, hi in zip(bounds, bounds[1:])]
    while len(parts) > 1:                           # merge in a random tree
        i = rnd.randrange(len(parts) - 1)
        parts[i:i + 2] = [parts[i].merge(parts[i + 1])]
    assert_same(summary(parts[0]), one_pass)


def test_vertices_closer_than_the_tolerance_share_their_geometries():
    # (1, 1) and (1 + 1e-13, 1 - 1e-13) are both hull vertices, and coincide (MODEL 10).
    red = IncrementalHull.empty(1)
    corners = [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0), (1.0 + 1e-13, 1.0 - 1e-13)]
    for g, (x, y) in enumerate(corners):
        red.add([x], [y], [True], g, np.full(5, float(g)))
    hull = red.hull(0)
    assert len(hull["x"]) == 5
    close_pair = np.flatnonzero((hull["x"] >= 1.0) & (hull["y"] > 0.5))
    assert len(close_pair) == 2
    for k in close_pair:                            # each counts geometries 2 and 4
        assert hull["first_geometry"][k] == 2
        np.testing.assert_array_equal(hull["param_min"][k], np.full(5, 2.0))
        np.testing.assert_array_equal(hull["param_max"][k], np.full(5, 4.0))
