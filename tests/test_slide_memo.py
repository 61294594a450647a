"""The slides' shortcuts (model-notes D16, "Cost") change no slide: the memo of outcomes per
map (with mirror images), the bound below which a search needs an energy, and the meeting
found as on the grid.

The reference is D16's rule as tests/naive.py writes it (`ReferenceGrid`: the cascade, the
searches, the rejoin), run on a kernel map's grid values with the model off the grid asked of
the plain `point.point_outcome` (no memo, no bound, `collision.collide`): the slides as they were
before the shortcuts. tests/test_sliding.py compares the base scene with the all-naive
reference; here both scenes, finger_collision above all, where slides are many.
"""
from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from naive import ReferenceGrid
from strategies import paper_table_designs
from sweep.compute.maps import compute_map, kernel_records
from sweep.kernels import finger as fk
from sweep.kernels.meeting_search import collide, collide_near, no_slide_context, slide_context
from sweep.kernels.outcome import point_outcome, point_outcome_below
from sweep.kernels.records import FingerState, Hand
from sweep.kernels.trajectories import (
    EMPTY_KEY,
    memo_for_slide,
    MEMO_MAX_CAPACITY,
    MEMO_MIN_CAPACITY,
    new_memo,
    outcome_at,
)
from sweep.model import (END_NONE, FREE, INFEASIBLE, PROXIMAL_ONLY, REACHED, TWO_PHALANX, VERTEX,
                         Accuracy, Command, Design, Effects, Grid, Limits, Part)

ALONE = no_slide_context()  # a position evaluated on its own (collide, not collide_near)

SCENES = {
    "base": Effects(),
    "collision": Effects(finger_collision=True),
    "collision+tip": Effects(finger_collision=True, tip_contact=True),
    "collision+springs": Effects(finger_collision=True, joint_springs=True),
}


def bits(e):
    """The bits of a float (tells -0.0 from 0.0; NaN never occurs here)."""
    return np.float64(e).tobytes()


#: kernels.finger's first-contact codes by closing stage (model-notes D36)
KERNEL_STAGE = {int(PROXIMAL_ONLY): 0, int(TWO_PHALANX): 0, int(fk.PROXIMAL_THEN_TIP): 0,
                int(fk.DISTAL_ON_LOWER_STOP): 1, int(VERTEX): 2, int(fk.JOINT_STRIKE): 2,
                int(fk.TIP_ON_LOWER_STOP): 2}


class KernelGridReference(ReferenceGrid):
    """D16's reference rules (tests/naive.py) on a kernel map's grid values; off the grid,
    `point.point_outcome` as it is (the slides before the shortcuts)."""

    def __init__(self, m, finger, solver, blocks, hand):  # noqa: D107 (no ReferenceGrid init)
        self.x, self.y = np.asarray(m.x), np.asarray(m.y)
        self.nx, self.ny, self.h = len(self.x), len(self.y), hand.h
        self.trajectory = "sliding"
        f = m.fields
        self.fields = {k: np.asarray(f[k]) for k in ("point_class", "energy", "equilibrium",
                                                     "caging_score")}
        self.model = (finger, solver, blocks, hand)
        self.points, self.slides, self.slide_ends, self.end_point = {}, {}, {}, {}
        self.cascade_moves = [0, 0, 0]
        res = solver.step_resolution
        self.resolution = res if 0.0 < res < hand.h else None
        self.first = np.asarray(f["first_event"])
        self.mode, self.t1, self.t2 = (np.asarray(f[k]) for k in ("finger_mode", "theta1",
                                                                   "theta2"))
        self.collision = bool(blocks.finger_collision.on)
        self.theta2_max = finger.theta2_max

    def stages(self, jj, ii):
        """D36's closing stages from the kernel map's own first events; with finger_collision
        a point where a finger rests on the other matches no other point (its steps are
        sampled): a finger stopped short of its settled configuration, free or proximal-only."""
        if self.collision:
            for side in range(2):
                mode, t1, t2 = (int(self.mode[side, jj, ii]), self.t1[side, jj, ii],
                                self.t2[side, jj, ii])
                if (mode == FREE and (t1 != math.pi or t2 != self.theta2_max)) or (
                        mode == PROXIMAL_ONLY and t2 != self.theta2_max):
                    return ("meeting", jj, ii)
        return tuple(KERNEL_STAGE.get(int(self.first[side, jj, ii]), 3) for side in range(2))

    def point(self, jj, ii):
        f = self.fields
        c = int(f["point_class"][jj, ii])
        stable = c == REACHED and bool(f["equilibrium"][jj, ii])
        return {"point_class": c, "energy": float(f["energy"][jj, ii]), "stable": stable,
                "caged": stable and f["caging_score"][jj, ii] > 0.0}

    def probe(self, cx, cy, rho, u):
        px, py = cx + rho * u[0], cy + rho * u[1]
        c, e = point_outcome(px, py, *self.model)
        return (None if c == INFEASIBLE else e), px, py, c


def map_and_reference(design, part, commands, h, effects):
    m = compute_map(design, part, Command(*commands), Grid(h=h), Limits(), Accuracy(),
                    effects=effects)
    finger, solver, blocks = kernel_records(design, part, Limits(), Accuracy(), effects)
    hand = Hand(float(design.w), float(commands[0]), float(commands[1]), float(h), finger.mu_s,
                finger.mu_s)
    return m, KernelGridReference(m, finger, solver, blocks, hand)


def assert_same_slides(m, ref):
    """Every start's end state and end point: the kernel's against the reference's."""
    state, index = np.asarray(m.fields["end_state"]), np.asarray(m.fields["end_index"])
    pc = np.asarray(m.fields["point_class"])
    bad = []
    for jj, ii in zip(*np.nonzero(pc == REACHED)):
        s, (ej, ei), _ = ref.trajectory_end(int(jj), int(ii))
        if (state[jj, ii], index[jj, ii]) != (s, ej * ref.nx + ei):
            bad.append((jj, ii, state[jj, ii], index[jj, ii], s, ej * ref.nx + ei))
    assert not bad, bad[:5]
    assert np.all(state[pc != REACHED] == END_NONE)
    return len(ref.slides)


# Maps of the 1,200 (l1 = 2, l2 = 1.6) where finger_collision makes many slides (and mirror
# pairs of them), at a coarse h; unequal commands turn the mirror images off.
SLIDING_MAPS = [
    (Design(2.0, 1.6, 0.2, 0.14, 0.8), Part(0.4, 0.4), (1.0, 1.0), 0.1),
    (Design(2.0, 1.6, 0.12, 0.06, 0.0), Part(0.4, 0.1), (1.0, 1.0), 0.1),
    (Design(2.0, 1.6, 0.16, 0.14, 0.4), Part(0.4, 0.4), (1.0, 1.0), 0.1),
    (Design(2.0, 1.6, 0.2, 0.14, 0.8), Part(0.4, 0.4), (1.3, 0.7), 0.1),
]


@pytest.mark.parametrize("scene", ["base", "collision"])
@pytest.mark.parametrize("case", range(len(SLIDING_MAPS)))
def test_slides_are_the_plain_evaluations_slides(case, scene):
    design, part, commands, h = SLIDING_MAPS[case]
    m, ref = map_and_reference(design, part, commands, h, SCENES[scene])
    n_slides = assert_same_slides(m, ref)
    if scene == "collision":
        assert n_slides >= 5  # the shortcuts were exercised (slides there are many)


@settings(max_examples=15, deadline=None)
@given(paper_table_designs(), st.sampled_from(["collision", "collision+tip", "base"]),
       st.sampled_from([(1.0, 1.0), (0.6, 1.4)]))
def test_slides_are_the_plain_evaluations_slides_random_designs(design, scene, commands):
    l1, l2, r1, r2, w, r, mu = design
    m, ref = map_and_reference(Design(l1, l2, r1, r2, w), Part(r, mu), commands, 0.2,
                               SCENES[scene])
    assert_same_slides(m, ref)


@settings(max_examples=60, deadline=None)
@given(paper_table_designs(), st.sampled_from(sorted(SCENES)),
       st.floats(0.0, 3.5), st.floats(0.0, 3.6), st.sampled_from([1.0, 0.5]))
def test_the_model_is_mirror_symmetric_bit_for_bit(design, scene, x, dy, tension):
    """The memo reads a position's mirror image (-x, y) for (x, y) when both tensions are
    equal: the whole evaluation (both finger solves, the meeting, class, energy) must give
    the same bits there, in every scene."""
    l1, l2, r1, r2, w, r, mu = design
    finger, solver, blocks = kernel_records(Design(l1, l2, r1, r2, w), Part(r, mu), Limits(),
                                            Accuracy(), SCENES[scene])
    hand = Hand(w, tension, tension, 0.05, finger.mu_s, finger.mu_s)
    y = r + dy
    for px in (x, -x, 0.5 * w, -0.5 * w) if x else (0.0, -0.0):
        c, e = point_outcome(px, y, finger, solver, blocks, hand)
        cm, em = point_outcome(-px, y, finger, solver, blocks, hand)
        assert (c, bits(e)) == (cm, bits(em))


@settings(max_examples=60, deadline=None)
@given(paper_table_designs(), st.sampled_from(sorted(SCENES)), st.floats(-3.5, 3.5),
       st.floats(0.0, 3.6), st.floats(-2.0, 0.5), st.booleans())
def test_outcome_below_a_bound_is_exact_or_a_lower_bound_above_it(design, scene, x, dy, bound,
                                                                  near):
    """point_outcome_below: exact (the plain evaluation's bits), or, with finger_collision
    only, an energy above the bound and not above the exact one. With the map's context the
    meeting is found as on the grid: the same bits as collide."""
    l1, l2, r1, r2, w, r, mu = design
    finger, solver, blocks = kernel_records(Design(l1, l2, r1, r2, w), Part(r, mu), Limits(),
                                            Accuracy(), SCENES[scene])
    hand = Hand(w, 1.0, 1.0, 0.05, finger.mu_s, finger.mu_s)
    context = slide_context(finger, w, blocks.finger_collision) if near else ALONE
    y = r + dy
    c, e = point_outcome(x, y, finger, solver, blocks, hand)
    for b in (bound, math.inf, e):
        cb, eb, exact = point_outcome_below(x, y, finger, solver, blocks, hand, b, context)
        if exact:
            assert (cb, bits(eb)) == (c, bits(e))
        else:
            assert blocks.finger_collision.on and not blocks.joint_springs.on
            assert b < eb <= e
    assert point_outcome_below(x, y, finger, solver, blocks, hand, math.inf, context)[2]


@given(st.floats(0.4, 2.0), st.floats(0.4, 1.6), st.sampled_from([0.0, 0.4, 0.8, 1.2, 2.0]),
       st.integers(0, 2**31))
def test_meeting_near_is_collides(l1, l2, w, seed):
    """collide_near (one map's context kept from position to position, its hint too) stops the
    fingers exactly as collide does, whatever came before."""
    rng = np.random.default_rng(seed)
    finger, _, blocks = kernel_records(Design(l1, l2, 0.2, 0.14, w), Part(0.4, 0.4), Limits(),
                                       Accuracy(), Effects(finger_collision=True))
    collision = blocks.finger_collision
    context = slide_context(finger, w, collision)
    th2min, th2max = finger.theta2_min, finger.theta2_max
    for _ in range(30):
        t1 = [math.pi if rng.random() < 0.2 else rng.uniform(0.0, math.pi) for _ in range(2)]
        t2 = [th2min if rng.random() < 0.3 else rng.uniform(th2min, th2max) for _ in range(2)]
        modes = rng.choice([FREE, PROXIMAL_ONLY, TWO_PHALANX], size=2)
        k1 = rng.uniform(0.0, l1, size=2)
        args = (FingerState(modes[0], t1[0], t2[0], k1[0], 0.0, False),
                FingerState(modes[1], t1[1], t2[1], k1[1], 0.0, False))
        assert collide_near(finger, w, collision, context, *args) == \
            collide(finger, w, collision, *args)


def test_memo_reads_what_it_stored_and_keeps_it_when_it_grows():
    """A position asked twice is read (the evaluation is not repeated: a poisoned entry
    shows it); the mirror image too when asked for; a lower bound answers only searches whose
    bound is below it; growing keeps every entry."""
    finger, solver, blocks = kernel_records(Design(2.0, 1.6, 0.2, 0.14, 0.8), Part(0.4, 0.4),
                                            Limits(), Accuracy(), Effects(finger_collision=True))
    hand = Hand(0.8, 1.0, 1.0, 0.05, finger.mu_s, finger.mu_s)
    for mirror in (True, False):
        memo = memo_for_slide(new_memo(1, mirror))
        assert memo.keys.shape[0] == MEMO_MIN_CAPACITY and memo.fill[0] == 0
        points = [(0.3 + 0.01 * k, 1.5 + 0.007 * k) for k in range(40)]
        for x, y in points:
            c, e = outcome_at(x, y, math.inf, finger, solver, blocks, hand, memo, ALONE)
            c0, e0 = point_outcome(x, y, finger, solver, blocks, hand)
            assert (c, bits(e)) == (c0, bits(e0))
        assert memo.fill[0] == len(points)
        used = memo.keys[:, 0] != EMPTY_KEY
        memo.values[used, 1] = -123.0  # poison: a read returns it
        memo.values[used, 2] = 1.0
        for x, y in points:
            assert outcome_at(x, y, math.inf, finger, solver, blocks, hand, memo, ALONE)[1] \
                == -123.0
            e_mirror = outcome_at(-x, y, math.inf, finger, solver, blocks, hand, memo, ALONE)[1]
            assert (e_mirror == -123.0) == mirror
        x, y = points[0]  # (x > 0: its key is the bits of (x, y) either way)
        key = (np.float64(x).view(np.int64), np.float64(y).view(np.int64))
        s = [k for k in range(memo.keys.shape[0]) if tuple(memo.keys[k]) == key][0]
        memo.values[s, 2] = 0.0  # a lower bound of -123
        assert outcome_at(x, y, -200.0, finger, solver, blocks, hand, memo, ALONE)[1] == -123.0
        exact = point_outcome(x, y, finger, solver, blocks, hand)
        assert outcome_at(x, y, 0.0, finger, solver, blocks, hand, memo, ALONE)[1] == exact[1]
        assert memo.values[s, 1] == exact[1] and memo.values[s, 2] == 1.0  # now exact
        n = memo.fill[0]
        memo.fill[0] = MEMO_MIN_CAPACITY // 4 + 1  # pretend it is a quarter full: it grows
        bigger = memo_for_slide(memo)
        assert bigger.keys.shape[0] == 4 * MEMO_MIN_CAPACITY and bigger.fill[0] == n
        old = {tuple(memo.keys[k]): tuple(memo.values[k]) for k in np.flatnonzero(
            memo.keys[:, 0] != EMPTY_KEY)}
        new = {tuple(bigger.keys[k]): tuple(bigger.values[k]) for k in np.flatnonzero(
            bigger.keys[:, 0] != EMPTY_KEY)}
        assert old == new
    full = new_memo(MEMO_MAX_CAPACITY, True)
    full.fill[0] = MEMO_MAX_CAPACITY // 2  # the largest memo, half full: kept, and only read
    assert memo_for_slide(full).keys.shape[0] == MEMO_MAX_CAPACITY
    x, y = 0.41, 1.73
    assert outcome_at(x, y, math.inf, finger, solver, blocks, hand, full, ALONE)[1] == \
        point_outcome(x, y, finger, solver, blocks, hand)[1]
    assert full.fill[0] == MEMO_MAX_CAPACITY // 2 and np.all(full.keys[:, 0] == EMPTY_KEY)
