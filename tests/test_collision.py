"""The finger_collision effect (MODEL 9, model-notes D14): both fingers advance through their
closing paths with a shared progress p = t1 + (t2 - theta2_min) and stop where they first meet;
a finger whose path ends first is the other's stop.

Cases worked by hand, a plain-Python reference of the rule (own segment geometry), and the
map-level promise: no caged point has crossed fingers.

The plain-Python scan of a tip-path finger's stop (D29) checks a fixed random sample of each
map's points in `make test`, every point in `make test-long` (SWEEP_LONG_PROPERTIES=1,
tests/profiles.py)."""
import math
import os

import naive_tip
import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from sweep.kernels.meeting import meeting_progress, stopped_finger
from sweep.kernels.meeting_search import resolve_collisions
from sweep.kernels.records import (FingerCollision, FingerState, new_finger_arrays,
                                   no_settled_fingers)
from sweep.compute.layout import kernel_records
from sweep.compute.maps import compute_map
from sweep.model import (FREE, PROXIMAL_ONLY, RANGE_TOL, TWO_PHALANX, Accuracy, Design,
                         Effects, Grid, Limits, Part)

TH2MIN, TH2MAX = math.radians(-5.0), math.radians(90.0)
COLLISION = FingerCollision(True, 0.01, 1e-12)
NOT_HANDLED = np.zeros((0, 0), dtype=np.bool_)


def finger_record(l1, l2):
    finger, _, _ = kernel_records(Design(l1, l2, 0.2, 0.14, 0.8), Part(0.4, 0.4), Limits(),
                                  Accuracy(), Effects())
    return finger


# --- plain-Python reference of the rule ------------------------------------------------------
def polyline(side, t1, t2, l1, l2, w):
    s = 1.0 if side == 1 else -1.0
    j = (s * w / 2, 0.0)
    b = (j[0] + s * l1 * math.cos(t1), l1 * math.sin(t1))
    t = (b[0] + s * l2 * math.cos(t1 + t2), b[1] + l2 * math.sin(t1 + t2))
    return [j, b, t]


def segments_meet(p, q, r, s):
    def orient(a, b, c):
        return (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])
    d1, d2, d3, d4 = orient(r, s, p), orient(r, s, q), orient(p, q, r), orient(p, q, s)
    return d1 * d2 <= 0 and d3 * d4 <= 0


def cross(a, b):
    return any(segments_meet(a[i], a[i + 1], b[k], b[k + 1]) for i in range(2) for k in range(2))


def path(p, t1_end, t2_end):
    return (p, TH2MIN) if p <= t1_end else (t1_end, min(TH2MIN + p - t1_end, t2_end))


def reference_meeting(left, right, l1, l2, w, n=200_000):
    """Finest scan of the shared progress for the first crossing (no bracketing tricks)."""
    end = max(left[0] + left[1] - TH2MIN, right[0] + right[1] - TH2MIN)
    for k in range(1, n + 1):
        p = end * k / n
        if cross(polyline(0, *path(p, *left), l1, l2, w), polyline(1, *path(p, *right), l1, l2, w)):
            return p
    return -1.0


# --- case 1: two free fingers, mirror images: tip meets tip on the axis ---------------------
def test_two_free_fingers_meet_tip_to_tip_on_the_axis():
    # l1 = 2, l2 = 1.6, w = 0.8, both fingers sweep rigidly (t2 = -5 deg). By symmetry they
    # first meet on x = 0, at the right finger's leftmost point. B_x = 0.4 + 2 cos p reaches 0
    # only at p = acos(-0.2) = 101.5 deg, and past p = 95 deg the tip lies left of B, so the
    # tips meet first: 0.4 + 2 cos p + 1.6 cos(p - 5 deg) = 0, solved here by bisection.
    lo, hi = math.radians(95), math.radians(101.5)
    for _ in range(100):
        mid = 0.5 * (lo + hi)
        if 0.4 + 2 * math.cos(mid) + 1.6 * math.cos(mid - math.radians(5)) > 0:
            lo = mid
        else:
            hi = mid
    p_star = lo
    assert math.degrees(p_star) == pytest.approx(98.607, abs=0.001)  # 0.4 - 0.2993 - 0.1006
    finger = finger_record(2.0, 1.6)
    p = meeting_progress(math.pi, TH2MAX, math.pi, TH2MAX, finger, 0.8, COLLISION)
    assert p == pytest.approx(p_star, abs=1e-9)
    changed, mode, t1, t2, k1, k2 = stopped_finger(p, FREE, math.pi, TH2MAX, 0.0, 0.0, TH2MIN)
    assert changed and mode == FREE and t1 == pytest.approx(p_star, abs=1e-9) and t2 == TH2MIN


# --- case 2: a finger at rest is the other's stop ----------------------------------------------
def test_a_finger_at_rest_stops_the_other_and_stays():
    # Left finger in two-phalanx contact at t1 = 60 deg, t2 = 30 deg: its path ends at
    # p = 60 + 35 = 95 deg. The right finger is free (path to t1 = pi, t2 = 90 deg). They first
    # meet after p = 95 deg, so the left is at rest and unchanged; the right stops there.
    l1, l2, w = 2.0, 1.6, 0.8
    left = (math.radians(60), math.radians(30))
    right = (math.pi, TH2MAX)
    p_ref = reference_meeting(left, right, l1, l2, w)
    assert p_ref > math.radians(95)
    finger = finger_record(l1, l2)
    p = meeting_progress(*left, *right, finger, w, COLLISION)
    assert p == pytest.approx(p_ref, abs=1e-4)
    assert not stopped_finger(p, TWO_PHALANX, *left, 1.0, 0.3, TH2MIN)[0]
    changed, mode, t1, t2, _, _ = stopped_finger(p, FREE, *right, 0.0, 0.0, TH2MIN)
    assert changed and mode == FREE
    if p <= math.pi:  # still in its rigid sweep
        assert (t1, t2) == pytest.approx((p, TH2MIN), abs=1e-12)


# --- case 3: stopped while the distal closes: the proximal contact stays ----------------------
def test_stopped_while_the_distal_closes_keeps_the_proximal_contact():
    # A finger bound for two-phalanx contact at t1 = 1.0, t2 = 1.2 stopped at p = 1.5 has
    # finished its rigid sweep (its proximal contact is made at p = 1.0) and its distal has
    # turned 0.5 rad from -5 deg: proximal-only, t2 = -5 deg + 0.5 rad, distal contact lost.
    changed, mode, t1, t2, k1, k2 = stopped_finger(1.5, TWO_PHALANX, 1.0, 1.2, 0.7, 0.3, TH2MIN)
    assert changed and mode == PROXIMAL_ONLY
    assert (t1, t2, k1, k2) == pytest.approx((1.0, TH2MIN + 0.5, 0.7, 0.0), abs=1e-15)
    # stopped before its proximal contact: it touches nothing
    changed, mode, t1, t2, k1, k2 = stopped_finger(0.8, TWO_PHALANX, 1.0, 1.2, 0.7, 0.3, TH2MIN)
    assert changed and mode == FREE and (t1, t2, k1, k2) == (0.8, TH2MIN, 0.0, 0.0)


def test_resolve_collisions_matches_the_reference_point_by_point():
    # random final configurations, plain-Python rule vs the kernel
    rng = np.random.default_rng(3)
    l1, l2, w = 1.2, 0.8, 0.4
    finger = finger_record(l1, l2)
    n = 40
    fingers = new_finger_arrays(2, 1, n)
    fingers.mode[:] = FREE
    fingers.k1[:] = 0.0
    fingers.k2[:] = 0.0
    fingers.tip_overlap[:] = False
    fingers.t1[:] = rng.uniform(0.3, math.pi, size=(2, 1, n))
    fingers.t2[:] = rng.uniform(TH2MIN, TH2MAX, size=(2, 1, n))
    before = fingers.t1.copy(), fingers.t2.copy()
    n_changed = resolve_collisions(np.array([1.0]), finger, w, fingers, COLLISION,
                                   no_settled_fingers(), NOT_HANDLED)
    expected_changed = 0
    for i in range(n):
        left = (before[0][0, 0, i], before[1][0, 0, i])
        right = (before[0][1, 0, i], before[1][1, 0, i])
        crossed = cross(polyline(0, *left, l1, l2, w), polyline(1, *right, l1, l2, w))
        new_l = (fingers.t1[0, 0, i], fingers.t2[0, 0, i])
        new_r = (fingers.t1[1, 0, i], fingers.t2[1, 0, i])
        if not crossed:
            assert new_l == left and new_r == right
            continue
        expected_changed += 1
        p = reference_meeting(left, right, l1, l2, w, n=20_000)
        end_l, end_r = path(p, *left), path(p, *right)
        # both at their configuration at the meeting, to the scan's resolution
        assert new_l == pytest.approx(end_l, abs=3e-4) and new_r == pytest.approx(end_r, abs=3e-4)
        assert not cross(polyline(0, *new_l, l1, l2, w), polyline(1, *new_r, l1, l2, w))
    assert n_changed == expected_changed > 0


@pytest.mark.parametrize("mu", [0.4, 0.0])
def test_no_caged_point_has_crossed_fingers(mu):
    design, part = Design(2.0, 1.6, 0.2, 0.14, 0.8), Part(0.4, mu)
    base = compute_map(design, part, grid=Grid(h=0.1), effects=Effects(friction=mu > 0))
    m = compute_map(design, part, grid=Grid(h=0.1),
                    effects=Effects(friction=mu > 0, finger_collision=True))
    assert base.attrs["n_caged_crossed"] > 0 or mu == 0.0
    assert m.attrs["n_caged_crossed"] == 0
    assert "n_collision_changed" not in base.attrs
    changed = (m.fields["theta1"] != base.fields["theta1"]) | \
        (m.fields["theta2"] != base.fields["theta2"])
    changed = changed.any(axis=0) & (base.fields["point_class"] != 0)
    assert m.attrs["n_collision_changed"] == int(changed.sum()) > 0


def test_meeting_progress_skips_only_nodes_where_the_fingers_cannot_meet():
    """meeting_progress skips nodes by a speed bound (no point moves faster than l1 + l2 per
    unit of progress); the answer must be that of testing every node. The every-node search is
    written here from paths_cross_at, on random closing paths of random designs and widths
    (w = 0 included: shared base)."""
    from sweep.kernels.meeting import paths_cross_at

    def every_node(t1l, t2l, t1r, t2r, finger, w):
        th = finger.theta2_min
        p_end = max(t1l + (t2l - th), t1r + (t2r - th))
        if paths_cross_at(0.0, t1l, t2l, t1r, t2r, finger, w):
            return -1.0
        lo, n = 0.0, 1
        while True:
            hi = min(n * COLLISION.progress_step, p_end)
            if paths_cross_at(hi, t1l, t2l, t1r, t2r, finger, w):
                for _ in range(200):
                    if hi - lo <= COLLISION.tol:
                        break
                    mid = 0.5 * (lo + hi)
                    if paths_cross_at(mid, t1l, t2l, t1r, t2r, finger, w):
                        hi = mid
                    else:
                        lo = mid
                return lo
            if hi >= p_end:
                return -1.0
            lo, n = hi, n + 1

    rng = np.random.default_rng(11)
    n_met = 0
    for _ in range(300):
        l1, l2 = rng.uniform(0.4, 2.0), rng.uniform(0.4, 1.6)
        finger = finger_record(l1, l2)
        w = float(rng.choice([0.0, 0.4, 0.8, 2.0]))
        ends = [(rng.uniform(0, math.pi), rng.uniform(TH2MIN, TH2MAX)) for _ in range(2)]
        args = (*ends[0], *ends[1], finger, w)
        expected = every_node(*args)
        assert meeting_progress(*args, COLLISION) == expected, args
        n_met += expected >= 0.0
    assert n_met > 50  # the sample has meetings to find, not only misses


# --- the map's way (resolve_collisions) against the reference search, bit for bit -----------
# resolve_collisions finds the meeting from the symmetric closing and the first contact in
# closed form, and replays the reference's bisection (kernels/meeting_search.py); the reference,
# resolve_collisions_reference, steps and bisects at every crossed point. Same bits asked.
def _settled_fields(design, part, h):
    """The settled (collision-free) finger fields of a map, as the sweep gathers them."""
    from sweep.kernels import many_maps
    from sweep.grid import grid_index_bounds, palm_half_width_steps
    finger, solver, blocks = kernel_records(design, part, Limits(), Accuracy(), Effects())
    _, i1, _, j1 = grid_index_bounds(design, part, Grid(h=h))
    step = palm_half_width_steps(design.w, h)
    shared, m_lo, ys = many_maps.shared_finger_field(finger, solver, blocks, np.array([step]),
                                                 np.array([i1]), j1 + 1, h)
    _, fingers = many_maps.gather_fingers(shared, m_lo, step, i1, j1 + 1, h)
    return finger, ys, fingers


def _copy(fingers):
    return type(fingers)(*(a.copy() for a in fingers))


def _assert_same_fingers(a, b):
    for name, x, y in zip(a._fields, a, b):
        assert np.array_equal(x, y, equal_nan=True), name


@pytest.mark.parametrize("seed", range(4))
def test_map_way_gives_the_reference_search_bits(seed):
    """Random designs and parts of the paper table (w = l1 and w = 0 included: a distal joint
    lands on the other finger's base at t1 = pi, the bases coincide), whole maps at h = 0.1."""
    from sweep.kernels.meeting import resolve_collisions_reference
    rng = np.random.default_rng(seed)
    n_met = 0
    for k in range(3):
        l1 = 0.4 + 0.2 * int(rng.integers(0, 9))
        w = [0.0, round(l1, 1) if l1 <= 2.0 else 2.0, 0.4 * int(rng.integers(0, 6))][k]
        design = Design(l1, 0.4 + 0.4 * int(rng.integers(0, 4)),
                        0.04 + 0.04 * int(rng.integers(0, 5)),
                        0.02 + 0.04 * int(rng.integers(0, 5)), w)
        part = Part(0.4 + 0.4 * int(rng.integers(0, 4)), 0.1 + 0.3 * int(rng.integers(0, 4)))
        finger, ys, settled = _settled_fields(design, part, 0.1)
        fast, reference = _copy(settled), _copy(settled)
        n_fast = resolve_collisions(ys, finger, w, fast, COLLISION, no_settled_fingers(),
                                    NOT_HANDLED)
        n_reference = resolve_collisions_reference(ys, finger, w, reference, COLLISION)
        assert n_fast == n_reference
        _assert_same_fingers(fast, reference)
        n_met += n_fast
    assert n_met > 100  # the sample has meetings to find


@given(st.floats(0.4, 2.0), st.floats(0.4, 1.6), st.sampled_from([0.0, 0.4, 0.8, 1.2, 2.0]),
       st.integers(0, 2**31))
def test_map_way_gives_the_reference_search_bits_on_any_fingers(l1, l2, w, seed):
    """Settled angles drawn at random (not only those a part makes), each point's fingers
    anywhere in their ranges, modes mixed: the meeting and the stopped fingers are the
    reference's bits."""
    from sweep.kernels.meeting import resolve_collisions_reference
    rng = np.random.default_rng(seed)
    finger = finger_record(l1, l2)
    n = 60
    fingers = new_finger_arrays(2, 1, n)
    fingers.mode[:] = rng.choice([FREE, PROXIMAL_ONLY, TWO_PHALANX], size=(2, 1, n))
    fingers.t1[:] = rng.uniform(0.0, math.pi, size=(2, 1, n))
    fingers.t2[:] = rng.uniform(TH2MIN, TH2MAX, size=(2, 1, n))
    fingers.t1[:, :, :10] = math.pi  # free fingers: the paths of the unreached region
    fingers.t2[:, :, :10] = TH2MAX
    fingers.t2[:, :, 10:20] = TH2MIN  # distal on its stop: a strike in the rigid sweep
    fingers.k1[:] = rng.uniform(0.0, l1, size=(2, 1, n))
    fingers.k2[:] = 0.0
    fingers.tip_overlap[:] = False
    fast, reference = _copy(fingers), _copy(fingers)
    ys = np.array([1.0])
    assert resolve_collisions(ys, finger, w, fast, COLLISION, no_settled_fingers(),
                               NOT_HANDLED) == \
        resolve_collisions_reference(ys, finger, w, reference, COLLISION)
    _assert_same_fingers(fast, reference)


def test_sweep_way_gives_the_reference_search_summaries():
    """The sweep (shared fields, link vectors, the per-thread memo across the cells of one
    geometry group) against maps whose fingers the reference resolves: every summary field,
    bit for bit, n_collision_changed included."""
    from sweep.compute.batch import summarize_cells
    from sweep.kernels import many_maps
    from sweep.kernels.meeting import resolve_collisions_reference
    from sweep.kernels.one_map import map_from_fingers, N_SUMMARY, S_COLLISION_CHANGED
    from sweep.kernels.records import (NO_EFFECTS, Hand, new_outcome_arrays, no_force_arrays,
                                       no_settled_fingers)
    from sweep.grid import grid_index_bounds, palm_half_width_steps
    from sweep.model import Command

    h = 0.1
    widths = np.array([0.0, 0.4, 1.2, 2.0])
    rng = np.random.default_rng(5)
    # one geometry group (l1, l2, r) and a cell of another: the memo is reused and cleared
    cells = [(2.0, 1.6, r1, r2, 0.4, mu) for r1, r2, mu in
             zip(rng.choice([0.04, 0.12, 0.2], 5), rng.choice([0.02, 0.1, 0.18], 5),
                 rng.choice([0.1, 0.4, 1.0], 5))] + [(1.2, 0.8, 0.08, 0.1, 0.8, 0.4)]
    cells = np.array(cells)
    # grid8 without step checks: the map pipeline below runs without the effect (the reference
    # resolved the collisions), so evaluations off the grid, which would need it, are kept out
    grid8 = Accuracy(trajectory="grid8", step_resolution=0.0)
    out = summarize_cells(cells, widths, Command(), h, Limits(), grid8,
                          Effects(finger_collision=True))
    for c, cell in enumerate(cells):
        for k, w in enumerate(widths):
            design, part = Design(*cell[:4], w), Part(*cell[4:])
            finger, solver, _ = kernel_records(design, part, Limits(), grid8, Effects())
            _, i1, _, j1 = grid_index_bounds(design, part, Grid(h=h))
            step, ny = palm_half_width_steps(w, h), j1 + 1
            shared, m_lo, ys = many_maps.shared_finger_field(
                finger, solver, NO_EFFECTS, np.array([step]), np.array([i1]), ny, h)
            xs, fingers = many_maps.gather_fingers(shared, m_lo, step, i1, ny, h)
            n_changed = resolve_collisions_reference(ys, finger, w, fingers, COLLISION)
            outs = new_outcome_arrays(ny, xs.size)
            summary = np.empty(N_SUMMARY)
            map_from_fingers(xs, ys, finger, solver,
                             Hand(w, 1.0, 1.0, h, finger.mu_s, finger.mu_s), NO_EFFECTS, fingers,
                             outs, no_force_arrays(), np.empty(xs.size * ny, dtype=np.int64),
                             summary, False, True, True, no_settled_fingers())
            summary[S_COLLISION_CHANGED] = n_changed
            assert np.array_equal(out[c, k], summary, equal_nan=True), (cell, w)


@given(st.integers(1, 600), st.floats(0.0, 1.0), st.sampled_from([0.01, 0.003, 0.05]),
       st.sampled_from([1e-12, 1e-10, 1e-15]))
def test_replayed_bisection_on_mantissas_is_the_floating_point_one(n, where, step, tol):
    """bisect_by_comparison runs the reference's bisection on integer mantissas where both
    ends share a binade; the floating-point steps, written here, must give the same bits."""
    from sweep.kernels.meeting_search import bisect_by_comparison, REPLAY_WINDOW
    lo, hi = (n - 1) * step, n * step
    tau = lo + where * (hi - lo)
    expected = (lo, hi, False)
    a, b = lo, hi
    for _ in range(200):
        if b - a <= tol:
            expected = (a, b, False)
            break
        mid = 0.5 * (a + b)
        if abs(mid - tau) <= REPLAY_WINDOW:
            expected = (a, b, True)
            break
        if mid > tau:
            b = mid
        else:
            a = mid
    assert bisect_by_comparison(lo, hi, tau, tol) == expected


@given(st.floats(0.4, 2.0), st.floats(0.4, 1.6), st.sampled_from([0.0, 0.4, 0.8, 1.2, 2.0]),
       st.integers(0, 2**31))
def test_one_point_anywhere_gets_the_reference_meeting(l1, l2, w, seed):
    """collide (one part position, no map: the trajectories' off-grid points) finds the
    reference's meeting and stops the fingers as resolve_collisions_reference would."""
    from sweep.kernels.meeting import settled_fingers_cross
    from sweep.kernels.meeting_search import collide
    rng = np.random.default_rng(seed)
    finger = finger_record(l1, l2)
    for _ in range(20):
        t1 = [math.pi if rng.random() < 0.2 else rng.uniform(0.0, math.pi) for _ in range(2)]
        t2 = [TH2MIN if rng.random() < 0.3 else rng.uniform(TH2MIN, TH2MAX) for _ in range(2)]
        modes = rng.choice([FREE, PROXIMAL_ONLY, TWO_PHALANX], size=2)
        k1 = rng.uniform(0.0, l1, size=2)
        changed, left, right = collide(finger, w, COLLISION,
                                       FingerState(modes[0], t1[0], t2[0], k1[0], 0.0, False),
                                       FingerState(modes[1], t1[1], t2[1], k1[1], 0.0, False))
        p = -1.0
        if settled_fingers_cross(t1[0], t2[0], t1[1], t2[1], finger, w):
            p = meeting_progress(t1[0], t2[0], t1[1], t2[1], finger, w, COLLISION)
        expected = [stopped_finger(p, modes[s], t1[s], t2[s], k1[s], 0.0, TH2MIN)
                    if p >= 0.0 else (False, modes[s], t1[s], t2[s], k1[s], 0.0)
                    for s in range(2)]
        assert changed == (expected[0][0] or expected[1][0])
        assert tuple(left) == tuple(expected[0][1:]) and tuple(right) == tuple(expected[1][1:])


# --- forces and the manipulation metric with finger_collision (model-notes D17) --------------
def test_forces_are_undetermined_exactly_where_a_finger_rests_on_the_other():
    """A finger stopped on the other touches it: that contact's force is not in the model's
    statics, so neither finger's forces are determined there; everywhere else the fingers
    are the settled ones and so are their forces (compared with the base scene's)."""
    design, part = Design(2.0, 1.6, 0.2, 0.14, 0.8), Part(0.4, 0.4)
    base = compute_map(design, part, grid=Grid(h=0.1), forces=True)
    m = compute_map(design, part, grid=Grid(h=0.1), forces=True,
                    effects=Effects(finger_collision=True))
    changed = ((m.fields["theta1"] != base.fields["theta1"])
               | (m.fields["theta2"] != base.fields["theta2"])).any(axis=0)
    changed &= base.fields["point_class"] != 0
    assert changed.sum() > 100
    determined = m.fields["forces_determined"]
    assert not determined[:, changed].any()
    for name in ("resultant_force_x", "resultant_force_y", "forces_determined"):
        assert np.array_equal(m.fields[name][:, ~changed], base.fields[name][:, ~changed],
                              equal_nan=True), name


def test_manipulation_with_collision_is_the_base_scene_without_crossed_fingers():
    """With finger_collision the counted poses are the base scene's whose fingers do not
    cross: where they would, the effect stops a finger on the other and the pose is dropped
    (D17); nothing else changes. So per part, Scenario B's reduction (every pose's kept
    forces) under the effect is the base scene's 'uncrossed' one, bit for bit, and nothing
    crossed is left."""
    from sweep.compute.batch import manipulation_cells
    from sweep.grid import part_lattice_columns

    widths = np.array([0.0, 0.4, 0.8])
    cells = np.array([(2.0, 1.6, r1, r2, 0.4, 0.4) for r1, r2 in
                      ((0.2, 0.14), (0.12, 0.06), (0.08, 0.1))] + [(1.2, 0.8, 0.16, 0.1, 0.4, 0.4)])
    n_col = part_lattice_columns(widths.max(), 2.0, 1.6, 0.4, 0.1)
    args = (cells, widths, 0.1, Limits(), Accuracy())
    extra = (np.arange(len(cells)), np.zeros((len(cells), 2), dtype=np.int64),
             np.full(len(cells), n_col))
    _, base = manipulation_cells(*args, Effects(), *extra)
    _, coll = manipulation_cells(*args, Effects(finger_collision=True), *extra)
    b_all, b_uncrossed = base.parts[(0, 0)]["all"], base.parts[(0, 0)]["uncrossed"]
    c_all, c_uncrossed = coll.parts[(0, 0)]["all"], coll.parts[(0, 0)]["uncrossed"]
    assert b_all.rows.shape[0] > b_uncrossed.rows.shape[0] > 100  # crossed poses counted
    for c in (c_all, c_uncrossed):
        for name, x in b_uncrossed.to_arrays().items():
            assert np.array_equal(c.to_arrays()[name], x), name


# --- a finger that took the tip path (tip_contact, model-notes D29) ---------------------------
TIP_MODES = (6, 7, 4)  # TIP_ONLY, PROXIMAL_TIP, SLIPPED (sweep.model; with tip_contact)
TIP_SCENE_CASES = [(2.0, 0.4, 1.2, 0.4, 0.0), (2.0, 0.4, 1.2, 0.8, 0.4),
                   (1.2, 1.6, 1.2, 0.4, 0.4)]


def tip_scene_maps(l1, l2, w, r, mu):
    design, part = Design(l1, l2, 0.2, 0.14, w), Part(r, mu)
    tip = compute_map(design, part, grid=Grid(h=0.1),
                      effects=Effects(friction=mu > 0, tip_contact=True))
    both = compute_map(design, part, grid=Grid(h=0.1),
                       effects=Effects(friction=mu > 0, tip_contact=True, finger_collision=True))
    return design, part, tip, both


def tip_on_disc_reference(t2, dx, dy, l1, l2, r):
    """The first t1 in [0, pi] at which the tip, the distal at t2 and the finger turning about
    its joint, reaches the disc (a fine scan, then bisection), independent of the kernels."""
    def outside(t1):
        tx = l1 * math.cos(t1) + l2 * math.cos(t1 + t2)
        ty = l1 * math.sin(t1) + l2 * math.sin(t1 + t2)
        return math.hypot(tx - dx, ty - dy) - r
    grid = np.linspace(0.0, math.pi, 1001)
    vals = np.hypot(l1 * np.cos(grid) + l2 * np.cos(grid + t2) - dx,
                    l1 * np.sin(grid) + l2 * np.sin(grid + t2) - dy) - r
    entries = np.nonzero((vals[:-1] > 0.0) & (vals[1:] <= 0.0))[0]
    if vals[0] <= 0.0 or len(entries) == 0:
        return 0.0 if vals[0] <= 0.0 else math.pi  # the kernel clamps t1 into [0, pi]
    lo, hi = grid[entries[0]], grid[entries[0] + 1]
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if outside(mid) > 0.0 else (lo, mid)
    return hi


def meet(a, b):
    """The fingers cross or touch (within RANGE_TOL, as the kernel's predicate: fingers lying
    on the palm row touch without crossing)."""
    if cross(a, b):
        return True
    return min(segment_distance(a[i], a[i + 1], b[k], b[k + 1])
               for i in range(2) for k in range(2)) <= RANGE_TOL


def segment_distance(p, q, r, s):
    return min(segment_point_distance(p, q, r), segment_point_distance(p, q, s),
               segment_point_distance(r, s, p), segment_point_distance(r, s, q))


@pytest.mark.parametrize("case", TIP_SCENE_CASES, ids=lambda c: "-".join(map(str, c)))
def test_a_finger_that_took_the_tip_path_stops_on_its_own_path(case):
    """Where a finger ended on its tip path (TIP_ONLY, PROXIMAL_TIP, SLIPPED) and the settled
    fingers cross, both fingers stop where their own paths first meet: a plain-Python scan of
    the shared progress (the closing to where the tip path began, then the tip path with the
    tip on the disc, found here by its own scan) gives the same stop; the stopped fingers do
    not cross, no link passes through the part and a finger stopped on its tip path has its
    tip on the disc (D29)."""
    from sweep.kernels.finger import tip_path_start

    l1, l2, w, r, mu = case
    design, part, tip, both = tip_scene_maps(*case)
    finger, solver, blocks = kernel_records(design, part, Limits(), Accuracy(),
                                            Effects(friction=mu > 0, tip_contact=True))
    th = finger.theta2_min
    mode, t1, t2 = (np.asarray(tip.fields[k]) for k in ("finger_mode", "theta1", "theta2"))
    new_mode, n1, n2 = (np.asarray(both.fields[k]) for k in ("finger_mode", "theta1", "theta2"))
    xs, ys = np.asarray(tip.x), np.asarray(tip.y)
    checked = on_tip_stops = 0
    candidates = np.argwhere(np.isin(mode, TIP_MODES).any(axis=0))
    # the plain-Python scan takes about a second a point: a fixed random sample of the map's
    # points, all of them with SWEEP_LONG_PROPERTIES=1 (passed on every point, 2026-11-25)
    long_profile = os.environ.get("SWEEP_LONG_PROPERTIES", "") not in ("", "0")
    for j, i in np.random.default_rng(0).permutation(candidates):
        if not long_profile and checked >= 4 and on_tip_stops >= 2:
            break
        if (mode[:, j, i] < 0).any():
            continue
        x, y = xs[i], ys[j]
        settled = [(t1[s, j, i], t2[s, j, i]) for s in range(2)]
        if not meet(polyline(0, *settled[0], l1, l2, w), polyline(1, *settled[1], l1, l2, w)):
            assert all((n1[s, j, i], n2[s, j, i]) == settled[s] for s in range(2))
            continue
        paths = []
        for s in range(2):
            dx = (-x if s == 0 else x) - 0.5 * w
            # the mode as an int64, as the kernels pass it (their compiled signature)
            on, t1s, t2s, _ = tip_path_start(dx, y, int(mode[s, j, i]), *settled[s], finger,
                                             solver, blocks)
            # where the tip path began, by the independent reference (tests/naive_tip.py)
            start = []
            naive_tip.naive_tip_finger(dx, y, l1, l2, 0.2, 0.14, r, mu, th, finger.theta2_max,
                                       Accuracy().reconfig_step, Accuracy().root_tol,
                                       tip_start=start)
            reference_on = (len(start) == 1 and mode[s, j, i] in TIP_MODES
                            and settled[s] != start[0])
            # A tip path that stuck at its first node is the strike that held: the kernel's
            # settled t1 then comes from the tip's circle (tip_on_disc), an ulp from the
            # strike's, and tip_path_start reports a path of zero length where the reference
            # reports none; both closings are the same to round-off.
            zero_length = on and max(abs(t1s - settled[s][0]), abs(t2s - settled[s][1])) <= 1e-12
            assert on == reference_on or (zero_length and not reference_on)
            on = on and reference_on
            if on:
                assert (t1s, t2s) == pytest.approx(start[0], abs=1e-6)
            paths.append((settled[s], on, start[0] if on else (t1s, t2s), dx))

        ends = [own_path_end_reference(path, th) for path in paths]
        n_scan = 4000
        stop = None
        for k in range(1, n_scan + 1):
            p = max(ends) * k / n_scan
            a, b = (own_path_reference(p, path, y, th, l1, l2, r) for path in paths)
            if meet(polyline(0, *a, l1, l2, w), polyline(1, *b, l1, l2, w)):
                stop = max(ends) * (k - 1) / n_scan
                break
        assert stop is not None
        for s in range(2):
            got = (n1[s, j, i], n2[s, j, i])
            want = own_path_reference(stop, paths[s], y, th, l1, l2, r)
            # to the scan's resolution (the stop lies within one scan step after `stop`)
            assert got == pytest.approx(want, abs=0.05), (j, i, s)
            jj, bb, tt = polyline(s, *got, l1, l2, w)
            for a_, b_ in ((jj, bb), (bb, tt)):
                assert segment_point_distance(a_, b_, (x, y)) >= r * (1 - 1e-6)
            if paths[s][1] and new_mode[s, j, i] == 6 and got != settled[s]:
                assert math.hypot(tt[0] - x, tt[1] - y) == pytest.approx(r, rel=1e-6)
                on_tip_stops += 1
        assert not cross(polyline(0, n1[0, j, i], n2[0, j, i], l1, l2, w),
                         polyline(1, n1[1, j, i], n2[1, j, i], l1, l2, w))
        checked += 1
    assert checked >= 4 and on_tip_stops >= 2


def own_path_end_reference(path, th):
    (a1, a2), on, (t1s, t2s), _ = path
    return a1 + a2 - th if not on else t1s + t2s - th + a2 - t2s


def own_path_reference(p, path, y, th, l1, l2, r):
    """A finger's angles at shared progress p on its own path (D29): without the tip path,
    D14's rebuilt closing; with it, the closing to where the tip path began, then t2 up at
    unit rate with the tip on the disc."""
    (a1, a2), on, (t1s, t2s), dx = path
    if not on:
        return path_angles(p, a1, a2)
    start = t1s + t2s - th
    if p >= own_path_end_reference(path, th):
        return a1, a2
    if p <= start:
        return path_angles(p, t1s, t2s)
    b2 = t2s + p - start
    return tip_on_disc_reference(b2, dx, y, l1, l2, r), b2


def path_angles(p, t1_end, t2_end):
    return (p, TH2MIN) if p <= t1_end else (t1_end, min(TH2MIN + p - t1_end, t2_end))


def segment_point_distance(a, b, q):
    ax, ay = a
    vx, vy = b[0] - ax, b[1] - ay
    u = ((q[0] - ax) * vx + (q[1] - ay) * vy) / (vx * vx + vy * vy)
    u = min(max(u, 0.0), 1.0)
    return math.hypot(ax + u * vx - q[0], ay + u * vy - q[1])


@pytest.mark.parametrize("case", TIP_SCENE_CASES[:2], ids=lambda c: "-".join(map(str, c)))
def test_grid_points_with_a_tip_path_finger_are_the_one_position_answer(case):
    """The map resolves its points with a tip-path finger by meeting.tip_path_collisions, the
    slides' off-grid positions by point_outcome (collide_on_own_paths): at every grid point
    the two give the same fingers (bit for bit), class and energy (the map sums its energy
    from per-finger fields, in another order: to 1e-12, as at every point)."""
    from sweep.kernels.meeting import collide_on_own_paths
    from sweep.kernels.outcome import point_outcome
    from sweep.kernels.records import Hand

    l1, l2, w, r, mu = case
    design, part, tip, both = tip_scene_maps(*case)
    effects = Effects(friction=mu > 0, tip_contact=True, finger_collision=True)
    finger, solver, blocks = kernel_records(design, part, Limits(), Accuracy(), effects)
    hand = Hand(w, 1.0, 1.0, 0.1, finger.mu_s, finger.mu_s)
    mode = np.asarray(tip.fields["finger_mode"])
    pc, energy = np.asarray(both.fields["point_class"]), np.asarray(both.fields["energy"])
    xs, ys = np.asarray(both.x), np.asarray(both.y)
    n = 0
    settled = [np.asarray(tip.fields[k]) for k in ("finger_mode", "theta1", "theta2", "k1",
                                                      "k2")]
    stopped = [np.asarray(both.fields[k]) for k in ("finger_mode", "theta1", "theta2", "k1",
                                                      "k2")]
    for j, i in zip(*np.nonzero(np.isin(mode, TIP_MODES).any(axis=0))):
        c, e = point_outcome(xs[i], ys[j], finger, solver, blocks, hand)
        assert c == pc[j, i]
        if c == 0:
            continue
        _, left, right = collide_on_own_paths(
            xs[i], ys[j], finger, solver, blocks, hand, blocks.finger_collision,
            *[tuple(f[s, j, i].item() for f in settled) for s in range(2)])
        for s, got in enumerate((left, right)):
            assert tuple(np.float64(v).tobytes() for v in got) == \
                tuple(np.float64(f[s, j, i]).tobytes() for f in stopped), (j, i, s)
        assert e == pytest.approx(energy[j, i], rel=1e-12, abs=1e-12)
        n += 1
    assert n > 20


def test_a_cell_never_reads_the_meetings_of_other_links():
    """The per-thread memo of meetings holds the settled fingers of one (l1, l2): a cell that
    follows cells of other links (the same l2, another l1: the fingers settle at the same
    joint stops, and whether and where they meet depends on l1) computes its maps as it would
    alone. Wide palms, where closed fingers of one l1 cross and of another do not."""
    from sweep.compute.batch import summarize_cells
    from sweep.compute.threads import numba_threads
    from sweep.model import Command

    h = 0.1
    widths = np.array([0.0, 1.2, 2.0, 2.8, 3.6])
    effects = Effects(finger_collision=True)
    cases = [[(1.2, 1.2, 0.04, 0.1, 0.8, 0.1), (1.2, 1.2, 0.2, 0.02, 0.8, 0.1),
              (2.0, 1.2, 0.12, 0.1, 0.8, 0.1)],
             [(1.6, 0.8, 0.12, 0.1, 0.4, 1.0), (1.6, 0.8, 0.04, 0.02, 0.4, 1.0),
              (2.0, 0.8, 0.2, 0.02, 0.4, 1.0)]]
    for cells in cases:
        cells = np.array(cells)
        with numba_threads(1):  # one range: the cells in order on one thread, one memo
            together = summarize_cells(cells, widths, Command(), h, Limits(), Accuracy(),
                                       effects)
            alone = [summarize_cells(cells[c:c + 1], widths, Command(), h, Limits(),
                                     Accuracy(), effects)[0] for c in range(len(cells))]
        for c in range(len(cells)):
            assert np.array_equal(together[c], alone[c], equal_nan=True), cells[c]
