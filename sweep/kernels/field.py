"""Grids of points (MODEL 4-8): one part position anywhere, a map's finger fields, outcomes and
trajectories, and many maps at once from shared finger fields. In the order of this file:

- *One position* (`point_outcome`): both fingers solved, collided, classified, and the energy.
  The grid's outcome rows read the class and the energy from here, and the sliding trajectories
  evaluate the model off the grid with the same functions, so a point has one class and one
  energy whichever asks.
- *Trajectories* (MODEL 8, `trajectory_ends`): from every point of P_j downhill to where the
  part stops, by one of three methods (`SolverSettings.trajectory`, model-notes D16): grid8,
  sliding (the default; slides on the true energy where every grid neighbour is uphill) or
  continuous (`streamline.py`).
- *One map* (`map_from_fingers`): outcomes -> trajectories -> summary, from finger fields that
  the caller fills (`finger_rows`, or by gathering a shared field). The sweep and
  `sweep.compute.maps.compute_map` both go through it.
- *Many maps* (`summarize_cells`): per-map summaries of cells (l1, l2, r1, r2, r, mu) x palm
  widths. A finger's solution depends only on the part centre relative to its base, so when
  every palm half-width is a whole number of grid steps, one right-finger field over integer
  offsets serves both fingers of every width: the right finger at world column i reads offset
  i - s, the left finger offset -i - s (model-notes D1). The offsets are the same floating-point
  numbers the direct computation uses, so the maps are bitwise identical to `compute_map`'s.

The drivers (`finger_rows`, `map_from_fingers`, `summarize_cells`) release the GIL and work on a
range of rows or cells: the compute layer runs ranges on several threads
(`sweep.compute.threads`). No `prange`: a parallel loop compiles its whole call tree twice
more (docs/performance.md, cold compilation).
"""
import math
import numpy as np

from typing import NamedTuple

from .jit import entry, inner
from ..model import (
    EJECT,
    END_CAGED,
    END_EJECTION,
    END_NONE,
    END_STALLED,
    END_TIP_PREHENSION,
    FREE,
    INFEASIBLE,
    RANGE_TOL,
    REACHED,
    PROXIMAL_ONLY,
    SLIPPED,
    TIP_ONLY,
    TRAJECTORY_GRID8,
    TRAJECTORY_SLIDING,
    UNREACHED,
    VERTEX,
    VERTEX_POINT,
)
from ..schema import SUMMARY_FIELDS, SUMMARY_INDEX
from .hand import (
    MAX_PROGRESS_STEPS,
    closing_path_angles,
    collide,
    collide_near,
    no_slide_context,
    resolve_collisions,
    rests_on_other_finger,
    settled_fingers_cross,
    slide_context,
    stopped_finger,
)
from .finger import (
    OVERLAP,
    finger_energy,
    finger_statics,
    solve_finger,
    spring_energy,
    tip_on_disc,
    tip_path_start,
    took_tip_path,
)
from .hull import convex_hull, inscribed_radius
from .hand import (
    finger_polyline,
    fingers_cross,
    friction_cones,
    link_vectors,
    part_contained,
    part_in_equilibrium,
    polyline_from_links,
    tip_clearance,
    touches_palm,
)
from .records import (
    FingerModel,
    FingerState,
    Hand,
    JointSprings,
    new_finger_arrays,
    new_outcome_arrays,
    no_force_arrays,
    no_settled_fingers,
    LEFT,
    RIGHT,
    SettledFingers,
    side_finger,
    wants_manipulation,
    wants_scenario_c,
    with_forces,
    with_joint_springs,
)
from .streamline import streamline_ends


# ---------------------------------------------------------------------------------------------
# finger_collision for a finger that took the tip path (tip_contact; model-notes D29)
# ---------------------------------------------------------------------------------------------
# A finger's own path (path tuples): (t1, t2) its final angles; on_tip, (t1s, t2s) where its
# tip path began (finger.tip_path_start); (dx, dy) the part in its frame. Without the tip path
# it is the closing D14 rebuilds from the final angles; with it, that closing up to (t1s, t2s),
# then the tip path (the tip on the disc, t1 following, t2 up to the final t2), progress
# counting t2's travel there. Here, not in hand.py: it needs the finger's paths (finger.py),
# and the kernels' import chain stays within its length (tests/test_layers.py).
@inner
def own_path_end(path, theta2_min):
    t1, t2, on_tip, t1s, t2s, _, _ = path
    if not on_tip:
        return t1 + (t2 - theta2_min)
    return t1s + (t2s - theta2_min) + (t2 - t2s)


@inner
def own_path_angles(progress, path, finger):
    """(t1, t2) of a finger at shared progress p along its own path (the final angles from
    its end on)."""
    t1, t2, on_tip, t1s, t2s, dx, dy = path
    th = finger.theta2_min
    if not on_tip:
        return closing_path_angles(progress, t1, t2, th)
    if progress >= own_path_end(path, th):
        return t1, t2
    start = t1s + (t2s - th)
    if progress <= start:
        return closing_path_angles(progress, t1s, t2s, th)
    a2 = t2s + (progress - start)
    _, _, a1 = tip_on_disc(a2, dx, dy, finger)
    return min(max(a1, 0.0), math.pi), a2


@inner
def own_paths_cross_at(progress, left, right, finger, w):
    a1l, a2l = own_path_angles(progress, left, finger)
    a1r, a2r = own_path_angles(progress, right, finger)
    return fingers_cross(finger_polyline(LEFT, a1l, a2l, finger.l1, finger.l2, w),
                         finger_polyline(RIGHT, a1r, a2r, finger.l1, finger.l2, w))


@inner
def own_paths_meeting(left, right, finger, w, collision):
    """hand.meeting_progress on the fingers' own paths: the first node (every
    collision.progress_step) where they cross, that step bisected to collision.tol; -1 if they
    cross from the start (as the reference) or never. Every node is tried: on the tip path no
    speed bound lets nodes be skipped, and these points are few."""
    if own_paths_cross_at(0.0, left, right, finger, w):
        return -1.0
    th = finger.theta2_min
    p_end = max(own_path_end(left, th), own_path_end(right, th))
    step = collision.progress_step
    n_max = int(min(math.ceil(p_end / step), MAX_PROGRESS_STEPS)) + 1
    for n in range(1, n_max + 1):
        hi = min(n * step, p_end)
        if own_paths_cross_at(hi, left, right, finger, w):
            lo = min((n - 1) * step, p_end)
            for _ in range(200):
                if hi - lo <= collision.tol:
                    break
                mid = 0.5 * (lo + hi)
                if own_paths_cross_at(mid, left, right, finger, w):
                    hi = mid
                else:
                    lo = mid
            return lo
        if hi >= p_end:
            break
    return -1.0


@inner
def stopped_on_own_path(progress, state, path, k1_start, finger):
    """hand.stopped_finger on the finger's own path: (changed, mode, t1, t2, k1, k2). In its
    closing to where the tip path began, D14's rule (FREE, or PROXIMAL_ONLY with that closing's
    proximal contact); on the tip path, held by the other finger with its tip on the part
    (TIP_ONLY)."""
    mode, t1, t2, k1, k2 = state
    _, _, on_tip, t1s, t2s, _, _ = path
    th = finger.theta2_min
    if not on_tip:
        return stopped_finger(progress, mode, t1, t2, k1, k2, th)
    if progress >= own_path_end(path, th):
        return False, mode, t1, t2, k1, k2
    if progress < t1s + (t2s - th):
        return stopped_finger(progress, PROXIMAL_ONLY if k1_start > 0.0 else FREE, t1s, t2s,
                              k1_start, 0.0, th)
    a1, a2 = own_path_angles(progress, path, finger)
    return True, TIP_ONLY, a1, a2, 0.0, finger.l2


@entry
def collide_on_own_paths(x, y, finger, solver, effects, hand, collision, left, right):
    """finger_collision at a part position where a finger took the tip path (D29): (changed,
    left, right), each (mode, t1, t2, k1, k2), both fingers stopped on their own paths at the
    first meeting, if their final configurations cross (D14)."""
    w = hand.w
    if left[0] < 0 or right[0] < 0 or not collision.on:
        return False, left, right
    if not settled_fingers_cross(left[1], left[2], right[1], right[2], finger, w):
        return False, left, right
    dxl = -x - 0.5 * w
    dxr = x - 0.5 * w
    on_l, t1sl, t2sl, k1sl = tip_path_start(dxl, y, left[0], left[1], left[2],
                                            side_finger(finger, hand, LEFT), solver,
                                            finger_effects(effects, hand.f_left))
    on_r, t1sr, t2sr, k1sr = tip_path_start(dxr, y, right[0], right[1], right[2],
                                            side_finger(finger, hand, RIGHT), solver,
                                            finger_effects(effects, hand.f_right))
    path_l = (left[1], left[2], on_l, t1sl, t2sl, dxl, y)
    path_r = (right[1], right[2], on_r, t1sr, t2sr, dxr, y)
    p = own_paths_meeting(path_l, path_r, finger, w, collision)
    if p < 0.0:
        return False, left, right
    cl, ml, a1l, a2l, b1l, b2l = stopped_on_own_path(p, left, path_l, k1sl, finger)
    cr, mr, a1r, a2r, b1r, b2r = stopped_on_own_path(p, right, path_r, k1sr, finger)
    return cl or cr, (ml, a1l, a2l, b1l, b2l), (mr, a1r, a2r, b1r, b2r)


@inner
def tip_path_collisions(xs, ys, finger, solver, effects, hand, fingers, collision, tip):
    """The grid's points where a finger took the tip path, by collide_on_own_paths (in place):
    (points changed, handled), `handled` marking them for hand.resolve_collisions to leave
    alone. Without tip_contact no finger took it: nothing is handled."""
    handled = np.zeros((fingers.mode.shape[1], fingers.mode.shape[2]), dtype=np.bool_)
    n_changed = 0
    for j in range(ys.shape[0]):
        for i in range(xs.shape[0]):
            if not (took_tip_path(np.int64(fingers.mode[0, j, i]), tip)
                    or took_tip_path(np.int64(fingers.mode[1, j, i]), tip)):
                continue
            handled[j, i] = True
            left = (np.int64(fingers.mode[0, j, i]), fingers.t1[0, j, i], fingers.t2[0, j, i],
                    fingers.k1[0, j, i], fingers.k2[0, j, i])
            right = (np.int64(fingers.mode[1, j, i]), fingers.t1[1, j, i], fingers.t2[1, j, i],
                     fingers.k1[1, j, i], fingers.k2[1, j, i])
            changed, new_l, new_r = collide_on_own_paths(xs[i], ys[j], finger, solver, effects,
                                                         hand, collision, left, right)
            if changed:
                n_changed += 1
                set_finger(fingers, LEFT, j, i, new_l)
                set_finger(fingers, RIGHT, j, i, new_r)
    return n_changed, handled


@inner
def set_finger(fingers, side, j, i, state):
    fingers.mode[side, j, i] = state[0]
    fingers.t1[side, j, i] = state[1]
    fingers.t2[side, j, i] = state[2]
    fingers.k1[side, j, i] = state[3]
    fingers.k2[side, j, i] = state[4]


@inner
def collisions_of_map(xs, ys, finger, solver, effects, hand, fingers, settled):
    """finger_collision on a map's solved fingers (in place): the points where a finger took
    the tip path on their own paths (D29), the rest by hand.resolve_collisions (D14). Returns
    the number of points changed. `settled`: records.SettledFingers."""
    collision = effects.finger_collision
    if not collision.on:
        return 0
    if not effects.tip_contact.on:
        return resolve_collisions(ys, finger, hand.w, fingers, collision, settled,
                                  np.empty((0, 0), dtype=np.bool_))
    n_tip, handled = tip_path_collisions(xs, ys, finger, solver, effects, hand, fingers,
                                         collision, effects.tip_contact)
    return n_tip + resolve_collisions(ys, finger, hand.w, fingers, collision, settled, handled)


# ---------------------------------------------------------------------------------------------
# One position
# ---------------------------------------------------------------------------------------------
@entry
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


@inner
def point_energy(a1l, a2l, a1r, a2r, finger, hand, springs):
    """The system energy V_left + V_right of a point (MODEL 6), springs included when on."""
    e = (finger_energy(a1l, a2l, finger.r1, finger.r2, hand.f_left, finger.theta2_min)
         + finger_energy(a1r, a2r, finger.r1, finger.r2, hand.f_right, finger.theta2_min))
    if springs.on:  # (adding 0.0 would turn a -0.0 energy into +0.0)
        e += (spring_energy(a1l, a2l, springs, finger.theta2_min)
              + spring_energy(a1r, a2r, springs, finger.theta2_min))
    return e


@entry
def finger_effects(effects, tension):
    """A finger's effect blocks: the springs act per unit of that finger's tendon tension
    (records.JointSprings), as in `maps.compute_map`'s per-side blocks."""
    springs = effects.joint_springs
    if not springs.on:
        return effects
    return with_joint_springs(effects, JointSprings(True, springs.k1, springs.k2, tension))


@entry
def point_outcome(x, y, finger, solver, effects, hand):
    """(class, energy) of the part centred at world (x, y): both fingers closed on it (finger
    frames d = (-x - w/2, y) and (x - w/2, y), MODEL 2), finger_collision when on; the energy
    is +inf where the point is INFEASIBLE (no energy there, and never lower than another)."""
    c, e, _ = point_outcome_below(x, y, finger, solver, effects, hand, np.inf,
                                  no_slide_context())
    return c, e


@entry
def point_outcome_below(x, y, finger, solver, effects, hand, bound, context):
    """point_outcome for a search that only asks whether the energy is below `bound`:
    (class, energy, exact). Not exact (exact False) only with finger_collision, where the
    settled fingers' energy is already above `bound`: then that energy is returned, a lower
    bound of the true one (a finger stopped on the other has angles no larger than its
    settled ones, and the energy falls as either angle grows: MODEL 6 with tensions >= 0 and
    no springs), and the meeting is not searched. `context`: hand.slide_context (the
    meeting found as on the grid) or hand.no_slide_context() (hand.collide)."""
    w = hand.w
    sl = solve_finger(-x - 0.5 * w, y, side_finger(finger, hand, LEFT), solver,
                      finger_effects(effects, hand.f_left))
    sr = solve_finger(x - 0.5 * w, y, side_finger(finger, hand, RIGHT), solver,
                      finger_effects(effects, hand.f_right))
    collision = effects.finger_collision
    if collision.on and (took_tip_path(sl.mode, effects.tip_contact)
                                  or took_tip_path(sr.mode, effects.tip_contact)):
        # on the fingers' own paths (D29); no lower bound: on the tip path t1 may grow
        _, left, right = collide_on_own_paths(
            x, y, finger, solver, effects, hand, collision,
            (sl.mode, sl.t1, sl.t2, sl.k1, sl.k2), (sr.mode, sr.t1, sr.t2, sr.k1, sr.k2))
        return outcome_of(y, left, right, finger, hand, effects.joint_springs)
    if collision.on and not effects.joint_springs.on and hand.f_left >= 0.0 \
            and hand.f_right >= 0.0:
        c = classify_point(y, finger.r, sl.mode, sr.mode)
        if c != INFEASIBLE:  # (the effect does not change an infeasible point)
            e = point_energy(sl.t1, sl.t2, sr.t1, sr.t2, finger, hand, effects.joint_springs)
            if e > bound:
                return c, e, False
    if not context[0]:
        _, left, right = collide(finger, w, collision, sl.mode, sl.t1, sl.t2, sl.k1, sl.k2,
                                 sr.mode, sr.t1, sr.t2, sr.k1, sr.k2)
    else:
        _, left, right = collide_near(finger, w, collision, context, sl.mode, sl.t1, sl.t2,
                                      sl.k1, sl.k2, sr.mode, sr.t1, sr.t2, sr.k1, sr.k2)
    return outcome_of(y, left, right, finger, hand, effects.joint_springs)


@inner
def outcome_of(y, left, right, finger, hand, springs):
    """(class, energy, exact) of a position from its fingers, each (mode, t1, t2, k1, k2)."""
    c = classify_point(y, finger.r, left[0], right[0])
    if c == INFEASIBLE:
        return c, np.inf, True
    return c, point_energy(left[1], left[2], right[1], right[2], finger, hand, springs), True


# ---------------------------------------------------------------------------------------------
# Trajectories
# ---------------------------------------------------------------------------------------------
# The 8 neighbours in the order that breaks ties (MODEL 8): E, NE, N, NW, W, SW, S, SE.
NEIGHBOUR_DI = (1, 1, 0, -1, -1, -1, 0, 1)
NEIGHBOUR_DJ = (0, 1, 1, 1, 0, -1, -1, -1)

# The slide's circle. Directions: 32, every 11.25 deg counter-clockwise from E, built from the
# first quadrant by sign flips so that each is the exact mirror image in x of another (a
# symmetric map slides symmetrically). The *step's search* uses every 4th (E, NE, N, ... as the
# grid's neighbours) and SLIDE_REFINE halvings of the angle around the lowest (2 points each:
# 45 deg -> 5.6 deg). The *thorough search* uses all 32, refined around each local minimum of
# the circle (a narrow descending wedge between two walls is missed by 8 directions:
# model-notes D16). From a position, the searches of SLIDE_CASCADE are tried in turn (radius
# in grid steps, thorough or not) until one finds a lower point; where none does, the part
# stalls. Each search costs 14 (step) or about 45 (thorough) evaluations of the model, and a
# stall the whole cascade: the order puts the cheap searches first (model-notes D16, measured
# in docs/performance.md).
SLIDE_DIRECTIONS = 32
SLIDE_CASCADE_RADIUS = (1.0, 0.25, 1.0)
SLIDE_CASCADE_THOROUGH = (False, False, True)


def _circle_directions(n):
    quarter = [(math.cos(2.0 * math.pi * k / n), math.sin(2.0 * math.pi * k / n))
               for k in range(n // 4 + 1)]
    quarter[0] = (1.0, 0.0)
    quarter[-1] = (0.0, 1.0)
    upper = quarter + [(-c, s) for c, s in reversed(quarter[:-1])]   # 0 .. 180 deg
    full = upper + [(c, -s) for c, s in reversed(upper[1:-1])]         # 180 .. 360 deg
    return tuple(c for c, _ in full), tuple(s for _, s in full)


SLIDE_DX, SLIDE_DY = _circle_directions(SLIDE_DIRECTIONS)
SLIDE_STEP_STRIDE = SLIDE_DIRECTIONS // 8
SLIDE_REFINE = 3
# A slide step must lower the energy by more than this relative amount (round-off of the
# energy, about 1e-16 relative, must not count as descent).
SLIDE_REL = 1e-12
# Defence in depth: a slide is at most this many circles per grid step of the map's size.
SLIDE_STEPS_PER_CELL = 64


@entry
def max_slide_points(ny, nx):
    """Positions a slide can visit at most (the length of a `path` array that holds any)."""
    return SLIDE_STEPS_PER_CELL * (nx + ny) + 1

# What a slide ends in (slide_successor's second value).
SLIDE_REJOINS, SLIDE_EJECTS, SLIDE_STALLS = 0, 1, 2


class OutcomeMemo(NamedTuple):
    """The outcomes (`field.point_outcome`) the slides of one map have asked for, by position:
    an open-addressing hash table (linear probing) keyed by the bits of (|x|, y) where the hand
    is symmetric (`mirror`: equal tensions; the model is then exactly mirror-symmetric,
    point_outcome(-x, y) = point_outcome(x, y) bit for bit, tests/test_slide_memo.py), else
    of (x, y). A hit returns the bits a new evaluation would, so the slides are the same with
    or without it. An entry may hold a lower bound of the energy
    (`field.point_outcome_below`), which answers a later search only if it is above that
    search's bound. Where slides come in mirror pairs (a symmetric map) the second of a pair
    is all hits, and the cascade's thorough search at radius h reads the step search's 8
    directions at the same centre."""

    keys: np.ndarray      # (capacity, 2) int64: key bits, EMPTY_KEY where free
    values: np.ndarray    # (capacity, 3) float64: class, energy, 1 if exact (0: a lower bound)
    bits: np.ndarray      # 2 float64 scratch: the key being looked up ...
    key: np.ndarray       # ... and the same memory as int64
    fill: np.ndarray      # 1 int64: entries in use
    mirror: bool


EMPTY_KEY = -1       # no position has these bits (a NaN)
MEMO_MIN_CAPACITY = 4096  # entries (40 bytes each), allocated at a map's first slide
# Bound on a map's memo: 10.5 MB per map being computed (a thread's), about 130,000 positions
# (a map of the 1,200 at h = 0.05 asks for 1,000-6,000); a full memo is still read.
MEMO_MAX_CAPACITY = 1 << 18


@entry
def new_memo(capacity, mirror):
    """An empty OutcomeMemo of `capacity` entries (a power of two)."""
    bits = np.empty(2)
    return OutcomeMemo(np.full((capacity, 2), EMPTY_KEY, dtype=np.int64),
                       np.empty((capacity, 3)), bits, bits.view(np.int64),
                       np.zeros(1, dtype=np.int64), mirror)


@entry
def memo_for_slide(memo):
    """The memo to give the next slide: the same, or (before the first slide of the map, and
    once it is a quarter full, so that a slide finds room) a larger copy of it. Allocation
    happens here, between slides, and the capacity grows fourfold, up to MEMO_MAX_CAPACITY:
    amortised over the evaluations, which cost microseconds each."""
    capacity = memo.keys.shape[0]
    if capacity >= MEMO_MIN_CAPACITY and (4 * memo.fill[0] <= capacity
                                          or capacity >= MEMO_MAX_CAPACITY):
        return memo
    bigger = new_memo(min(max(MEMO_MIN_CAPACITY, 4 * capacity), MEMO_MAX_CAPACITY), memo.mirror)
    for s in range(capacity):
        if memo.keys[s, 0] != EMPTY_KEY:
            memo_store(bigger, memo.keys[s, 0], memo.keys[s, 1], memo.values[s, 0],
                       memo.values[s, 1], memo.values[s, 2])
    return bigger


@inner
def memo_slot(memo, k0, k1):
    """The slot of key (k0, k1) in the memo, or of the free slot where it would go."""
    mask = memo.keys.shape[0] - 1
    mix = k0 ^ (k1 >> 3)
    mix ^= mix >> 23
    mix ^= mix >> 11
    s = mix & mask
    while memo.keys[s, 0] != EMPTY_KEY and (memo.keys[s, 0] != k0 or memo.keys[s, 1] != k1):
        s = (s + 1) & mask  # the memo is at most half full: a free slot comes
    return s


@inner
def memo_store(memo, k0, k1, c, e, exact):
    """Enter an outcome, or replace a lower bound by the exact one (no new entry where the
    memo is half full: it is then only read)."""
    s = memo_slot(memo, k0, k1)
    if memo.keys[s, 0] == EMPTY_KEY:
        if 2 * (memo.fill[0] + 1) > memo.keys.shape[0]:
            return
        memo.keys[s, 0] = k0
        memo.keys[s, 1] = k1
        memo.fill[0] += 1
    memo.values[s, 0] = c
    memo.values[s, 1] = e
    memo.values[s, 2] = exact


@entry
def outcome_at(x, y, bound, finger, solver, effects, hand, memo, context):
    """(class, energy) at world (x, y) for a search that only asks whether the energy is
    below `bound` (+inf: the exact outcome): field.point_outcome_below, read from the memo
    where it holds the position (or its mirror image, for a symmetric hand) well enough.
    The energy is exact, or a lower bound above `bound`; the search compares it with `bound`
    only (`e < best`), so its decisions are those of the exact energies. A memo of no capacity
    (`new_memo(0, ...)`): always evaluated; `context`: as point_outcome_below's."""
    if memo.keys.shape[0] == 0:
        c, e, _ = point_outcome_below(x, y, finger, solver, effects, hand, bound, context)
        return c, e
    memo.bits[0] = abs(x) if memo.mirror else x
    memo.bits[1] = y
    k0 = memo.key[0]
    k1 = memo.key[1]
    s = memo_slot(memo, k0, k1)
    if memo.keys[s, 0] != EMPTY_KEY and (memo.values[s, 2] != 0.0 or memo.values[s, 1] > bound):
        return int(memo.values[s, 0]), memo.values[s, 1]
    c, e, exact = point_outcome_below(x, y, finger, solver, effects, hand, bound, context)
    memo_store(memo, k0, k1, float(c), e, 1.0 if exact else 0.0)
    return c, e


@entry
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


@entry
def lowest_on_circle(x, y, rho, thorough, scratch, finger, solver, effects, hand, memo,
                     context):
    """(energy, class, unit direction ux, uy) of the lowest point found on the circle of radius
    rho around world (x, y) (the search of the module's SLIDE_* constants; `thorough` for the
    stall decision). Ties go to the first evaluated: directions counter-clockwise from E, then
    each refinement's counter-clockwise side first. `scratch`: SLIDE_DIRECTIONS floats."""
    stride = 1 if thorough else SLIDE_STEP_STRIDE
    best = np.inf
    best_class = NO_CLASS
    ux = 0.0
    uy = 0.0
    for n in range(0, SLIDE_DIRECTIONS, stride):
        # the thorough search keeps every direction's energy (its local minima): exact
        c, e = outcome_at(x + rho * SLIDE_DX[n], y + rho * SLIDE_DY[n],
                          np.inf if thorough else best, finger, solver, effects, hand, memo,
                          context)
        scratch[n] = e
        if e < best:
            best, best_class, ux, uy = e, c, SLIDE_DX[n], SLIDE_DY[n]
    half = math.pi * stride / SLIDE_DIRECTIONS
    if not thorough:
        return refine_on_circle(x, y, rho, best, best_class, ux, uy, half, finger, solver,
                                effects, hand, memo, context)
    for n in range(SLIDE_DIRECTIONS):  # refine around every local minimum of the circle
        e = scratch[n]
        if not (e <= scratch[n - 1] and e <= scratch[(n + 1) % SLIDE_DIRECTIONS]) \
                or not math.isfinite(e):
            continue
        e, c, vx, vy = refine_on_circle(x, y, rho, e, NO_CLASS, SLIDE_DX[n], SLIDE_DY[n],
                                        half, finger, solver, effects, hand, memo, context)
        if e < best:
            best, best_class, ux, uy = e, c, vx, vy
    return best, best_class, ux, uy


@inner
def refine_on_circle(x, y, rho, best, best_class, ux, uy, half, finger, solver, effects, hand,
                     memo, context):
    """SLIDE_REFINE times: the directions `half` either side of (ux, uy) (counter-clockwise
    first), the lower replacing it; `half` halves each time."""
    for _ in range(SLIDE_REFINE):
        cd = math.cos(half)
        sd = math.sin(half)
        cx, cy = ux, uy
        for side in range(2):
            s = sd if side == 0 else -sd
            vx = cx * cd - cy * s
            vy = cy * cd + cx * s
            c, e = outcome_at(x + rho * vx, y + rho * vy, best, finger, solver, effects, hand,
                              memo, context)
            if e < best:
                best, best_class, ux, uy = e, c, vx, vy
        half *= 0.5
    return best, best_class, ux, uy


@inner
def nearest_grid_point(x, y, xs, ys, h):
    """Flat index of the grid point nearest to world (x, y), clipped into the grid."""
    nx = xs.shape[0]
    i = min(max(int(math.floor((x - xs[0]) / h + 0.5)), 0), nx - 1)
    j = min(max(int(math.floor((y - ys[0]) / h + 0.5)), 0), ys.shape[0] - 1)
    return j * nx + i


@entry
def slide_successor(energy, point_class, equilibrium, xs, ys, i0, j0, finger, solver, effects,
                    hand, path, memo, context):
    """Slide the part from grid point (j0, i0), where every neighbour is uphill, on the true
    energy (module docstring). Returns (flat index, SLIDE_REJOINS | SLIDE_EJECTS | SLIDE_STALLS,
    points written to `path`): the grid point where the slide rejoins the grid (lower than the
    start, or stable), or the grid point nearest to where the part leaves P_j or stops. `path`:
    an array (n, 2) that receives the world positions of the slide (pictures, tests; (0, 2):
    not recorded); `memo`: the map's OutcomeMemo (of no capacity: none); `context`: the map's
    hand.slide_context, or hand.no_slide_context()."""
    ny, nx = energy.shape
    h = hand.h
    e_start = energy[j0, i0]
    x = xs[i0]
    y = ys[j0]
    e_here = e_start
    stage = 0
    scratch = np.empty(SLIDE_DIRECTIONS)
    n_path = record(path, np.int64(0), x, y)
    for _ in range(max_slide_points(ny, nx) - 1):
        rho = h * SLIDE_CASCADE_RADIUS[stage]
        e, c, ux, uy = lowest_on_circle(x, y, rho, np.bool_(SLIDE_CASCADE_THOROUGH[stage]),
                                        scratch,
                                        finger, solver, effects, hand, memo, context)
        if not (e < e_here - SLIDE_REL * abs(e_here)):
            stage += 1
            if stage == len(SLIDE_CASCADE_RADIUS):
                break
            continue
        x += rho * ux
        y += rho * uy
        e_here = e
        stage = 0
        n_path = record(path, n_path, x, y)
        fi = (x - xs[0]) / h
        fj = (y - ys[0]) / h
        if c != REACHED or not (-0.5 <= fi < nx - 0.5 and -0.5 <= fj < ny - 0.5):
            # the part left P_j, or the grid (a user window's edge)
            return nearest_grid_point(x, y, xs, ys, h), SLIDE_EJECTS, n_path
        # rejoin the grid at the lowest corner of the cell below the start's energy (a stable
        # corner ends the trajectory whatever its energy)
        ia = int(math.floor(fi))
        ja = int(math.floor(fj))
        best = -1
        e_best = e_start - SLIDE_REL * abs(e_start)
        for corner in range(4):
            qi = ia + (corner & 1)
            qj = ja + (corner >> 1)
            if qi < 0 or qi >= nx or qj < 0 or qj >= ny or point_class[qj, qi] != REACHED:
                continue
            if equilibrium[qj, qi]:
                best = qj * nx + qi
                break
            if energy[qj, qi] < e_best:
                e_best = energy[qj, qi]
                best = qj * nx + qi
        if best >= 0:
            return best, SLIDE_REJOINS, n_path
    return nearest_grid_point(x, y, xs, ys, h), SLIDE_STALLS, n_path


@inner
def record(path, n, x, y):
    """Write position n of a slide into `path` (room for fewer: not recorded); returns n + 1."""
    if n < path.shape[0]:
        path[n, 0] = x
        path[n, 1] = y
    return n + 1


@entry
def trajectory_ends(outs, xs, ys, finger, solver, effects, hand, stack, sliding):
    """End state and end point (outs.end_state, outs.end_index) of the trajectory from every
    point of P_j (REACHED points): grid8, or with `sliding` the sliding method (module
    docstring). `stack` is scratch of size >= number of points. Returns the map score Lambda
    (MODEL 8)."""
    energy = outs.energy
    point_class = outs.point_class
    end_state = outs.end_state
    end_index = outs.end_index
    equilibrium = outs.equilibrium
    caged = outs.caged
    caging_score = outs.caging_score
    h = hand.h
    ny, nx = energy.shape
    size = ny * nx
    for p in range(size):
        end_state.flat[p] = END_NONE
        end_index.flat[p] = -1
    memo = new_memo(np.int64(1), hand.f_left == hand.f_right)  # grown at the first slide
    no_path = np.empty((0, 2))
    context = slide_context(finger, hand.w, effects.finger_collision)
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
                if not sliding:
                    state = END_STALLED
                    last = p
                    break
                memo = memo_for_slide(memo)
                q, kind, _ = slide_successor(energy, point_class, equilibrium, xs, ys, i, j,
                                             finger, solver, effects, hand, no_path, memo,
                                             context)
                if kind != SLIDE_REJOINS:
                    state = END_EJECTION if kind == SLIDE_EJECTS else END_STALLED
                    last = q
                    break
            p = q
        for s in range(depth):
            end_state.flat[stack[s]] = state
            end_index.flat[stack[s]] = last
    score_sum = 0.0
    for p in range(size):
        if end_state.flat[p] == END_CAGED:
            score_sum += caging_score.flat[end_index.flat[p]]
    return score_sum


# ---------------------------------------------------------------------------------------------
# One map
# ---------------------------------------------------------------------------------------------
# Positions in the summary row (sweep.schema), frozen into the kernels as constants.
N_SUMMARY = len(SUMMARY_FIELDS)
S_LAMBDA = SUMMARY_INDEX["Lambda"]
S_CAGING_AREA = SUMMARY_INDEX["caging_area"]
S_CAGED = SUMMARY_INDEX["n_caged"]
S_TIP_PREHENSION = SUMMARY_INDEX["n_tip_prehension"]
S_EJECTION = SUMMARY_INDEX["n_ejection"]
S_STALLED = SUMMARY_INDEX["n_stalled"]
S_REACHED = SUMMARY_INDEX["n_reached"]
S_EQUILIBRIUM = SUMMARY_INDEX["n_equilibrium"]
S_VERTEX = SUMMARY_INDEX["n_vertex"]
S_TIP_OVERLAP = SUMMARY_INDEX["n_tip_overlap"]
S_CAGED_CROSSED = SUMMARY_INDEX["n_caged_crossed"]
S_POINTS = SUMMARY_INDEX["n_points"]
S_INFEASIBLE = SUMMARY_INDEX["n_infeasible"]
S_UNREACHED = SUMMARY_INDEX["n_unreached"]
S_EJECT = SUMMARY_INDEX["n_eject"]
S_CAGED_POINTS = SUMMARY_INDEX["n_caged_points"]
S_COLLISION_CHANGED = SUMMARY_INDEX["n_collision_changed"]
SCRATCH_ANGLES = 16  # cone-edge scratch of the equilibrium test (at most 10 edges)
# Constant arguments of kernel calls (NumPy scalars: records.LEFT): a map's per-point outputs
# everywhere or only where the part is stable (summaries: `every_point`), its equilibrium and
# caging outputs on, the only finger of a shared field, a part taken as contained.
EVERY_POINT, STABLE_POINTS = np.bool_(True), np.bool_(False)
ALL_OUTPUTS = np.bool_(True)
MIRRORED = np.bool_(True)
WHOLE_ROWS = np.bool_(False)
HALF_ROWS = np.bool_(True)
SHARED = np.int64(0)
CONTAINED = np.bool_(True)
NO_CLASS = np.int64(INFEASIBLE)


# ---------------------------------------------------------------------------------------------
# Finger fields
# ---------------------------------------------------------------------------------------------
@entry(nogil=True)
def finger_rows(first, last, dxs, dys, finger, solver, effects, fingers, side):
    """Solve one finger at every column offset dxs[i] of rows first .. last - 1 of the grid
    dys x dxs (finger-frame offsets: part centre at (dxs[i], dys[j])) into fingers[side].
    Without the GIL: `sweep.compute.threads` runs blocks of rows on several threads."""
    for j in range(first, last):
        dy = dys[j]
        for i in range(dxs.shape[0]):
            s = solve_finger(dxs[i], dy, finger, solver, effects)
            fingers.mode[side, j, i] = s.mode
            fingers.t1[side, j, i] = s.t1
            fingers.t2[side, j, i] = s.t2
            fingers.k1[side, j, i] = s.k1
            fingers.k2[side, j, i] = s.k2
            fingers.tip_overlap[side, j, i] = s.tip_overlap


# ---------------------------------------------------------------------------------------------
# Per-point outcomes of a map
# ---------------------------------------------------------------------------------------------
@inner
def fill_infeasible(j, i, fingers, outs, forces, forces_on):
    """Fill values where the point does not exist (model-notes D6)."""
    outs.energy[j, i] = np.nan
    outs.l_open[j, i] = np.nan
    for side in range(2):
        fingers.mode[side, j, i] = -1
        fingers.t1[side, j, i] = np.nan
        fingers.t2[side, j, i] = np.nan
        fingers.k1[side, j, i] = np.nan
        fingers.k2[side, j, i] = np.nan
        fingers.tip_overlap[side, j, i] = False
        if forces_on:
            forces.proximal_normal[side, j, i] = np.nan
            forces.distal_normal[side, j, i] = np.nan
            forces.distal_multiplier[side, j, i] = np.nan
            forces.resultant_x[side, j, i] = np.nan
            forces.resultant_y[side, j, i] = np.nan
            forces.determined[side, j, i] = False
    if forces_on:
        forces.geometric_cage_score[j, i] = np.nan


@inner
def point_forces(j, i, finger_l, finger_r, fingers, forces):
    """Contact forces of both fingers at a feasible point (per unit tension, world frame), each
    finger with its own friction (records.side_finger). Where finger_collision stopped a finger
    on the other, neither finger's forces are determined (the finger-finger contact,
    model-notes D17)."""
    touching = fingers_touch(fingers, j, i, finger_l)
    for side in range(2):
        st = finger_statics_at(fingers, side, j, i, finger_l if side == 0 else finger_r)
        forces.proximal_normal[side, j, i] = st.proximal_normal
        forces.distal_normal[side, j, i] = st.distal_normal
        forces.distal_multiplier[side, j, i] = st.distal_multiplier
        # the left finger's frame is the right one's mirror image in x
        forces.resultant_x[side, j, i] = st.resultant_x if side == 1 else -st.resultant_x
        forces.resultant_y[side, j, i] = st.resultant_y
        forces.determined[side, j, i] = st.determined and not touching


@inner
def fingers_touch(fingers, j, i, finger):
    """finger_collision stopped one of the point's fingers on the other (model-notes D17)."""
    return (rests_on_other_finger(np.int64(fingers.mode[0, j, i]), fingers.t1[0, j, i],
                                  fingers.t2[0, j, i], finger)
            or rests_on_other_finger(np.int64(fingers.mode[1, j, i]), fingers.t1[1, j, i],
                                     fingers.t2[1, j, i], finger))


@inner
def finger_statics_at(fingers, side, j, i, finger):
    return finger_statics(FingerState(fingers.mode[side, j, i], fingers.t1[side, j, i],
                                      fingers.t2[side, j, i], fingers.k1[side, j, i],
                                      fingers.k2[side, j, i], fingers.tip_overlap[side, j, i]),
                          finger)


@inner
def outcome_row(j, xs, y, finger, hand, springs, tip, fingers, outs, forces, scratch,
                every_point, equilibrium, caging):
    """Class, energy, equilibrium, containment, opening, point score (and contact forces when
    `forces` has room for them: records.with_forces) along row j.

    `equilibrium` False skips the part-equilibrium test and `caging` False the cage geometry
    (containment, L_open, crossing) at every point: those fields are left False / NaN / 0.

    The finger arrays are overwritten with fill values (-1 / NaN / False) at infeasible points.
    With every_point False (summaries only), containment, L_open and crossing are computed only
    where the part is stable, the only points whose score or counts depend on them; elsewhere
    they are left False / NaN.
    """
    r = finger.r
    # the record's arrays read once: a record field read inside the loop cost a reference-count
    # pair on the points that `continue` (docs/performance.md)
    mode, t1, t2 = fingers.mode, fingers.t1, fingers.t2
    point_class, energy, l_open = outs.point_class, outs.energy, outs.l_open
    equilibrium_out, contained, crossed = outs.equilibrium, outs.contained, outs.crossed
    caged, caging_score = outs.caged, outs.caging_score
    forces_on = with_forces(forces)
    finger_l = side_finger(finger, hand, LEFT)
    finger_r = side_finger(finger, hand, RIGHT)
    cones = friction_cones(finger.mu_s, hand.mu_left, hand.mu_right)
    for i in range(xs.shape[0]):
        x = xs[i]
        ml = np.int64(mode[0, j, i])
        mr = np.int64(mode[1, j, i])
        c = classify_point(y, r, ml, mr)
        point_class[j, i] = c
        equilibrium_out[j, i] = False
        contained[j, i] = False
        crossed[j, i] = False
        caged[j, i] = False
        caging_score[j, i] = 0.0
        if c == INFEASIBLE:
            fill_infeasible(j, i, fingers, outs, forces, forces_on)
            continue
        if forces_on:
            point_forces(j, i, finger_l, finger_r, fingers, forces)
        a1l = t1[0, j, i]
        a2l = t2[0, j, i]
        a1r = t1[1, j, i]
        a2r = t2[1, j, i]
        energy[j, i] = point_energy(a1l, a2l, a1r, a2r, finger, hand, springs)
        eq = False
        if c == REACHED and equilibrium:
            eq = part_in_equilibrium(scratch, x, y, hand.w, r, cones, ml, a1l, a2l, mr, a1r,
                                     a2r, finger.l1, finger.l2, tip)
            equilibrium_out[j, i] = eq
        l_open[j, i] = np.nan
        # the manipulation metric needs S_geo wherever the part is reached (MODEL 10)
        wants_geometry = caging and (eq or every_point or (forces_on and c == REACHED))
        if forces_on:
            forces.geometric_cage_score[j, i] = 0.0
        if not wants_geometry:
            continue
        inside, intersect, opening = cage_geometry(x, y, a1l, a2l, a1r, a2r, finger, hand)
        contained[j, i] = inside
        l_open[j, i] = opening
        crossed[j, i] = intersect
        score = cage_score(inside, opening, r)
        if forces_on and c == REACHED:
            forces.geometric_cage_score[j, i] = score
        if eq and score > 0.0:
            caged[j, i] = True
            caging_score[j, i] = score


@inner
def cage_score(inside, opening, r):
    """S = 1 - L_open / (2r) where the part is contained and L_open < 2r, else 0 (MODEL 8; an
    exact tie L_open == 2r is not caged, model-notes D5). Stability is the caller's business:
    S of a stable point is the caging score, of any reached point S_geo (MODEL 10)."""
    if inside and opening < 2.0 * r - RANGE_TOL:
        return 1.0 - opening / (2.0 * r)
    return 0.0


@inner
def cage_geometry(x, y, a1l, a2l, a1r, a2r, finger, hand):
    """(contained, fingers cross, L_open) of the part at (x, y) between the fingers (MODEL 8)."""
    left = finger_polyline(LEFT, a1l, a2l, finger.l1, finger.l2, hand.w)
    right = finger_polyline(RIGHT, a1r, a2r, finger.l1, finger.l2, hand.w)
    inside = part_contained(x, y, left, right)
    intersect = fingers_cross(left, right)
    opening = 0.0 if intersect else tip_clearance(left, right)  # = mouth_opening
    return inside, intersect, opening


# ---------------------------------------------------------------------------------------------
# Trajectories (MODEL 8): discrete steepest descent, each downhill step computed once
# ---------------------------------------------------------------------------------------------
# Neighbour order E, NE, N, NW, W, SW, S, SE (ties go to the first); j grows with y (north).
@inner
def count_summary(outs, tip_overlap, score_sum, h, out):
    """The per-map summary row, in the order of sweep.schema.SUMMARY."""
    point_class = outs.point_class
    end_state = outs.end_state
    equilibrium = outs.equilibrium
    caged = outs.caged
    crossed = outs.crossed
    ny, nx = point_class.shape
    for n in range(out.shape[0]):
        out[n] = 0.0
    out[S_LAMBDA] = score_sum
    out[S_CAGING_AREA] = score_sum * h * h
    for j in range(ny):
        for i in range(nx):
            c = point_class[j, i]
            if c == REACHED:
                e = end_state[j, i]
                if e == END_CAGED:
                    out[S_CAGED] += 1
                elif e == END_TIP_PREHENSION:
                    out[S_TIP_PREHENSION] += 1
                elif e == END_EJECTION:
                    out[S_EJECTION] += 1
                elif e == END_STALLED:
                    out[S_STALLED] += 1
                out[S_REACHED] += 1
                if equilibrium[j, i]:
                    out[S_EQUILIBRIUM] += 1
            elif c == VERTEX_POINT:
                out[S_VERTEX] += 1
            elif c == INFEASIBLE:
                out[S_INFEASIBLE] += 1
            elif c == UNREACHED:
                out[S_UNREACHED] += 1
            elif c == EJECT:
                out[S_EJECT] += 1
            if c != INFEASIBLE and (tip_overlap[0, j, i] or tip_overlap[1, j, i]):
                out[S_TIP_OVERLAP] += 1
            if caged[j, i]:
                out[S_CAGED_POINTS] += 1
                if crossed[j, i]:
                    out[S_CAGED_CROSSED] += 1
    out[S_POINTS] = ny * nx


# ---------------------------------------------------------------------------------------------
# The map pipeline
# ---------------------------------------------------------------------------------------------
@entry(nogil=True)
def map_from_fingers(xs, ys, finger, solver, hand, effects, fingers, outs, forces, stack,
                     summary, every_point, equilibrium, caging, settled):
    """From solved finger fields to a scored map: finger_collision, outcomes (and forces),
    trajectories (the method of SolverSettings.trajectory), summary row. The sweep and
    `sweep.compute.maps.compute_map` both come here.

    Only the outputs asked for are computed (MODEL 9): `equilibrium` False skips the part
    equilibrium test, `caging` False the cage geometry and the trajectories (end states none,
    Lambda NaN). Plain run-time flags: they are loop-invariant, and the work they skip is per
    point, so a branch costs nothing measurable (docs/effects.md). `settled`: what the sweep
    knows of the settled fingers for finger_collision (records.SettledFingers). `forces`: the
    ForceArrays to fill, or empty ones (records.with_forces)."""
    n_collision_changed = collisions_of_map(xs, ys, finger, solver, effects, hand, fingers,
                                            settled)
    scratch = np.empty(SCRATCH_ANGLES)
    for j in range(ys.shape[0]):
        outcome_row(j, xs, ys[j], finger, hand, effects.joint_springs, effects.tip_contact,
                    fingers, outs, forces, scratch, every_point, equilibrium, caging)
    if not caging:
        outs.end_state[:, :] = END_NONE
        outs.end_index[:, :] = -1
        score_sum = np.nan  # no trajectories: Lambda does not exist
    elif solver.trajectory == TRAJECTORY_GRID8 or solver.trajectory == TRAJECTORY_SLIDING:
        score_sum = trajectory_ends(outs, xs, ys, finger, solver, effects, hand, stack,
                                    solver.trajectory == TRAJECTORY_SLIDING)
    else:
        score_sum = streamline_ends(outs, hand.h, stack, solver.streamline_step)
    count_summary(outs, fingers.tip_overlap, score_sum, hand.h, summary)
    summary[S_COLLISION_CHANGED] = n_collision_changed


# ---------------------------------------------------------------------------------------------
# Many maps
# ---------------------------------------------------------------------------------------------
@inner
def shared_field_extent(steps, ncols):
    """(m_lo, number of offsets) of the shared field that serves every width of a cell."""
    m_lo = 0
    m_hi = 0
    for k in range(steps.shape[0]):
        m_lo = min(m_lo, -ncols[k] - steps[k])
        m_hi = max(m_hi, ncols[k] - steps[k])
    return m_lo, m_hi - m_lo + 1


@entry
def shared_finger_field(finger, solver, effects, steps, ncols, ny, h):
    """The right finger's field over every offset any width of the cell needs."""
    m_lo, nm = shared_field_extent(steps, ncols)
    dxs = np.empty(nm)
    for m in range(nm):
        dxs[m] = (m + m_lo) * h
    ys = np.empty(ny)
    for j in range(ny):
        ys[j] = finger.r + j * h
    shared = new_finger_arrays(np.int64(1), ny, nm)
    finger_rows(np.int64(0), ny, dxs, ys, finger, solver, effects, shared, SHARED)
    return shared, m_lo, ys


@entry
def gather_fingers(shared, m_lo, step, ncol, ny, h):
    """Both fingers of the map of palm half-width `step` grid steps, from the shared field:
    (world xs, FingerArrays on (2, ny, 2 ncol + 1)). Copied row by row, one finger's field at a
    time: reads and writes run along rows (column by column it took over a third of the
    per-map work after the finger field)."""
    nx = 2 * ncol + 1
    xs = np.empty(nx)
    for c in range(nx):
        xs[c] = (c - ncol) * h
    fingers = new_finger_arrays(np.int64(2), ny, nx)
    for side in range(2):
        for j in range(ny):
            gather_row(shared.mode[0, j], fingers.mode[side, j], side, m_lo, step, ncol)
            gather_row(shared.t1[0, j], fingers.t1[side, j], side, m_lo, step, ncol)
            gather_row(shared.t2[0, j], fingers.t2[side, j], side, m_lo, step, ncol)
            gather_row(shared.k1[0, j], fingers.k1[side, j], side, m_lo, step, ncol)
            gather_row(shared.k2[0, j], fingers.k2[side, j], side, m_lo, step, ncol)
            gather_row(shared.tip_overlap[0, j], fingers.tip_overlap[side, j], side, m_lo, step,
                       ncol)
    return xs, fingers


@inner
def gather_row(src, dst, side, m_lo, step, ncol):
    """One row of one finger field: world column c (i = c - ncol) of the right finger reads
    offset i - step (a shift), of the left finger offset -i - step (a mirror)."""
    if side == 1:
        base = -ncol - step - m_lo
        for c in range(dst.shape[0]):
            dst[c] = src[base + c]
    else:
        base = ncol - step - m_lo
        for c in range(dst.shape[0]):
            dst[c] = src[base - c]


@inner
def shared_finger_links(shared, finger):
    """Per point of a cell's shared finger field, the link vectors l1 (cos t1, sin t1) and
    l2 (cos phi, sin phi) in the finger's frame: (4, y, offset)."""
    ny, nm = shared.mode.shape[1], shared.mode.shape[2]
    links = np.empty((4, ny, nm))
    for j in range(ny):
        for m in range(nm):
            # what finger_polyline forms, so world coordinates match it bit for bit
            l1c, l1s, l2c, l2s = link_vectors(shared.t1[0, j, m], shared.t2[0, j, m],
                                              finger.l1, finger.l2)
            links[0, j, m] = l1c
            links[1, j, m] = l1s
            links[2, j, m] = l2c
            links[3, j, m] = l2s
    return links


@inner
def shared_finger_links_and_statics(shared, finger):
    """Per point of a cell's shared finger field, what every width's map reads from it for the
    manipulation metric: the link vectors (`shared_finger_links`) and the finger's statics per
    unit tension (determined, resultant x, y)."""
    ny, nm = shared.mode.shape[1], shared.mode.shape[2]
    links = shared_finger_links(shared, finger)
    statics = np.empty((3, ny, nm))
    for j in range(ny):
        for m in range(nm):
            st = finger_statics_at(shared, SHARED, j, m, finger)
            statics[0, j, m] = 1.0 if st.determined else 0.0
            statics[1, j, m] = st.resultant_x
            statics[2, j, m] = st.resultant_y
    return links, statics


@inner
def collect_counted_forces(xs, ys, finger, hand, outs, fingers, links, statics, m_lo, step, ncol,
                           ncol_max, k, manip, c, a_count, a_fx, a_fy):
    """The counted poses of one map (MODEL 10): reached, not touching the palm, not in
    equilibrium, S_geo > 0, both fingers' forces determined by statics (model-notes D9; not
    where finger_collision stopped a finger on the other, D17: `fingers` are the map's, after
    the effect). Elsewhere the fingers are the shared field's, whose links and statics are
    precomputed. Scenario B entries (command 1/1) go into row c of `manip`; Scenario A forces
    (each command F_left of manip.a_commands, F_right = 2 - F_left) into the cell's per-pose
    buffers. Forces are the fingers' per-unit-tension resultants (world frame) times S_geo."""
    capacity = manip.pose.shape[1]
    n_lattice = 2 * manip.lattice_ncol[c] + 1
    for j in range(ys.shape[0]):
        y = ys[j]
        for col in range(xs.shape[0]):
            if outs.point_class[j, col] != REACHED or outs.equilibrium[j, col]:
                continue
            x = xs[col]
            if touches_palm(x, y, hand.w, finger.r) or fingers_touch(fingers, j, col, finger):
                continue
            i = col - ncol                    # world column: x = i h
            src_l = -i - step - m_lo          # the shared field's columns (gather_fingers)
            src_r = i - step - m_lo
            # cheapest first: statics (precomputed), containment, then the opening
            if statics[0, j, src_l] == 0.0 or statics[0, j, src_r] == 0.0:
                continue
            left = polyline_from_links(LEFT, hand.w, links[0, j, src_l], links[1, j, src_l],
                                       links[2, j, src_l], links[3, j, src_l])
            right = polyline_from_links(RIGHT, hand.w, links[0, j, src_r], links[1, j, src_r],
                                        links[2, j, src_r], links[3, j, src_r])
            if not part_contained(x, y, left, right):
                continue
            crossed = fingers_cross(left, right)
            s_geo = cage_score(CONTAINED, 0.0 if crossed else tip_clearance(left, right),
                               finger.r)
            if s_geo <= 0.0:
                continue
            lx = -statics[1, j, src_l]         # the left finger's frame is mirrored in x
            ly = statics[2, j, src_l]
            rx = statics[1, j, src_r]
            ry = statics[2, j, src_r]
            e = manip.n_entries[c]
            if e < capacity:
                manip.pose[c, e] = j * n_lattice + i + manip.lattice_ncol[c]
                manip.fx[c, e] = (lx + rx) * s_geo
                manip.fy[c, e] = (ly + ry) * s_geo
                manip.width[c, e] = k
                manip.crossed[c, e] = crossed
            manip.n_entries[c] = e + 1
            a = col - ncol + ncol_max
            for f_left in manip.a_commands:
                n = a_count[j, a]
                a_fx[j, a, n] = (f_left * lx + (2.0 - f_left) * rx) * s_geo
                a_fy[j, a, n] = (f_left * ly + (2.0 - f_left) * ry) * s_geo
                a_count[j, a] = n + 1


@inner
def collect_pair_forces(xs, ys, finger, hand, effects, left, right, links_l, statics_l, links_r,
                        statics_r, m_lo, step, ncol, ncol_max, commands, scratch, count, fx, fy,
                        mirror, half):
    """Scenario C (MODEL 10): the counted poses of one map whose left finger touches the part
    with friction hand.mu_left and the right with hand.mu_right (the palm: finger.mu_s), the
    left finger read from the shared field `left` (solved at that friction, with its links and
    statics), the right from `right`; every command's force (F_left of `commands`, F_right = 2 -
    F_left) into the per-pose buffers.

    The count rule of collect_counted_forces, pose by pose, with the same functions, so that a
    pair's poses are those of its map (`compute_map(mu_left=, mu_right=)`): settled fingers
    first (class, palm, statics, containment, S_geo), then finger_collision where the settled
    fingers cross (hand.collide: a finger stopped on the other leaves the pose undetermined,
    D17), then the part's equilibrium with each contact's own cone.

    `mirror`: each counted pose x = i h also gives the pose -x of the swapped pair (left with
    hand.mu_right, right with hand.mu_left), its mirror image (the model is mirror-symmetric,
    MODEL 11; the fields, links and statics are the same numbers, and its forces are formed as
    the swapped pair's own would be, bit for bit); with `half` (a pair that is its own swap),
    only the poses x <= 0 are visited."""
    r = finger.r
    w = hand.w
    collision = effects.finger_collision
    cones = friction_cones(finger.mu_s, hand.mu_left, hand.mu_right)
    mode_l, t1_l, t2_l, k1_l, k2_l = left.mode, left.t1, left.t2, left.k1, left.k2
    mode_r, t1_r, t2_r, k1_r, k2_r = right.mode, right.t1, right.t2, right.k1, right.k2
    n_cols = ncol + 1 if half else xs.shape[0]
    for j in range(ys.shape[0]):
        y = ys[j]
        for col in range(n_cols):
            i = col - ncol                    # world column: x = i h
            src_l = -i - step - m_lo          # the shared fields' columns (gather_fingers)
            src_r = i - step - m_lo
            ml = np.int64(mode_l[0, j, src_l])
            mr = np.int64(mode_r[0, j, src_r])
            if classify_point(y, r, ml, mr) != REACHED:
                continue
            x = xs[col]
            if touches_palm(x, y, w, r):
                continue
            if statics_l[0, j, src_l] == 0.0 or statics_r[0, j, src_r] == 0.0:
                continue
            left_line = polyline_from_links(LEFT, w, links_l[0, j, src_l], links_l[1, j, src_l],
                                            links_l[2, j, src_l], links_l[3, j, src_l])
            right_line = polyline_from_links(RIGHT, w, links_r[0, j, src_r],
                                             links_r[1, j, src_r], links_r[2, j, src_r],
                                             links_r[3, j, src_r])
            if not part_contained(x, y, left_line, right_line):
                continue
            crossed = fingers_cross(left_line, right_line)
            s_geo = cage_score(CONTAINED, 0.0 if crossed else tip_clearance(left_line,
                                                                               right_line), r)
            if s_geo <= 0.0:
                continue
            a1l, a2l = t1_l[0, j, src_l], t2_l[0, j, src_l]
            a1r, a2r = t1_r[0, j, src_r], t2_r[0, j, src_r]
            if crossed and collision.on:  # (fingers that do not cross are left as settled)
                changed, new_l, new_r = collide(finger, w, collision, ml, a1l, a2l,
                                                k1_l[0, j, src_l], k2_l[0, j, src_l], mr, a1r,
                                                a2r, k1_r[0, j, src_r], k2_r[0, j, src_r])
                if changed:
                    if (rests_on_other_finger(new_l[0], new_l[1], new_l[2], finger)
                            or rests_on_other_finger(new_r[0], new_r[1], new_r[2], finger)):
                        continue
                    ml, a1l, a2l = new_l[0], new_l[1], new_l[2]
                    mr, a1r, a2r = new_r[0], new_r[1], new_r[2]
                    if classify_point(y, r, ml, mr) != REACHED:
                        continue
            if part_in_equilibrium(scratch, x, y, w, r, cones, ml, a1l, a2l, mr, a1r, a2r,
                                   finger.l1, finger.l2, effects.tip_contact):
                continue
            lx = -statics_l[1, j, src_l]         # the left finger's frame is mirrored in x
            ly = statics_l[2, j, src_l]
            rx = statics_r[1, j, src_r]
            ry = statics_r[2, j, src_r]
            a = col - ncol + ncol_max
            for f_left in commands:
                n = count[j, a]
                fx[j, a, n] = (f_left * lx + (2.0 - f_left) * rx) * s_geo
                fy[j, a, n] = (f_left * ly + (2.0 - f_left) * ry) * s_geo
                count[j, a] = n + 1
            if mirror and not (half and i == 0):
                # the swapped pair at -x: its left finger is this right one mirrored (x force
                # -rx), its right finger this left one (x force -lx)
                a = -i + ncol_max
                for f_left in commands:
                    n = count[j, a]
                    fx[j, a, n] = (f_left * -rx + (2.0 - f_left) * -lx) * s_geo
                    fy[j, a, n] = (f_left * ry + (2.0 - f_left) * ly) * s_geo
                    count[j, a] = n + 1


@inner
def append_forces(count, fx, fy, more_count, more_fx, more_fy):
    """Each pose's forces in the `more` buffers appended to its own."""
    for j in range(count.shape[0]):
        for a in range(count.shape[1]):
            n = count[j, a]
            for q in range(more_count[j, a]):
                fx[j, a, n + q] = more_fx[j, a, q]
                fy[j, a, n + q] = more_fy[j, a, q]
            count[j, a] = n + more_count[j, a]


@inner
def friction_field(finger, mu, solver, effects, steps, ncols, ny, h):
    """The shared finger field of a cell with the finger's contacts at friction `mu`, and its
    links and statics (Scenario C's low-friction surface)."""
    switched = FingerModel(finger.l1, finger.l2, finger.r1, finger.r2, finger.r, mu,
                           finger.theta2_min, finger.theta2_max)
    field, _, _ = shared_finger_field(switched, solver, effects, steps, ncols, ny, h)
    links, statics = shared_finger_links_and_statics(field, switched)
    return field, links, statics


@inner
def surrounds_origin(fx, fy):
    """Forces on both sides of the origin in x and in y: without that, the origin is not
    strictly inside their hull and the pose's value is 0 (hull.inscribed_radius returns 0 for
    such a hull, so this only spares the hull)."""
    left = right = below = above = False
    for q in range(fx.shape[0]):
        left |= fx[q] < 0.0
        right |= fx[q] > 0.0
        below |= fy[q] < 0.0
        above |= fy[q] > 0.0
    return left and right and below and above


@entry
def pose_radius_sum(count, fx, fy, pose_value, c):
    """Sum over poses of the inscribed radius of the hull of each pose's forces (MODEL 10);
    each pose's value also into pose_value[c] when that array has rows."""
    keep = pose_value.shape[0] > 0
    total = 0.0
    for j in range(count.shape[0]):
        for a in range(count.shape[1]):
            n = count[j, a]
            value = 0.0
            if n >= 3 and surrounds_origin(fx[j, a, :n], fy[j, a, :n]):
                hx, hy = convex_hull(fx[j, a, :n], fy[j, a, :n])
                value = inscribed_radius(hx, hy, hx.shape[0])
            total += value
            if keep:
                pose_value[c, j, a] = value
    return total


@inner
def cell_finger_model(cells, c, theta2_min, theta2_max):
    return FingerModel(cells[c, 0], cells[c, 1], cells[c, 2], cells[c, 3], cells[c, 4],
                       cells[c, 5], theta2_min, theta2_max)


@entry(nogil=True)
def summarize_cells(cells, first, last, ws, steps, ncols, nys, h, f_left, f_right, theta2_min,
                    theta2_max, solver, effects, out, want, manip):
    """The maps of cells first .. last - 1 at every width, each cell's from one shared finger
    field, in order on the calling thread, without the GIL (`sweep.compute.threads` runs
    ranges of cells on several threads). One function, not one per cell: each level of the
    call tree above the model compiles the whole tree below it again (docs/performance.md).

    cells: (n, 6) l1 l2 r1 r2 r mu; out: (n, n_w, N_SUMMARY); want: bool (n, n_w), the maps to
    compute (out[c, k] of another stays as it was: the refinement asks for a few widths of a
    cell, and a width's map costs far more than its share of the field). steps[k] is the palm
    half-width of width k in grid steps; the map of cell c at width k has columns
    i = -ncols[c, k] .. ncols[c, k] and rows y_j = r + j h, j = 0 .. nys[c] - 1. With `manip`
    (a ManipulationOut with a row per cell; without: records.no_manipulation()) the contact
    forces are computed too and row c of `manip` receives the cell's manipulation metric data
    (MODEL 10), Scenario C's too when `manip` has its low friction (a second shared field at
    that friction, the pairs with a switched finger: collect_pair_forces). With
    finger_collision, this call's memo of meetings (records.SettledFingers: (n_w, y, x, 5), one
    map per width, and the l1, l2 of the cell that filled it) is filled while the next cell
    has the same links and cleared when the links change."""
    manipulation = wants_manipulation(manip)
    scenario_c = manipulation and wants_scenario_c(manip)
    collision = effects.finger_collision.on
    no_forces = no_force_arrays()
    memo = np.empty((0, 0, 0, 5))
    if collision and last > first:   # as large as the largest map of these cells
        memo = np.empty((ws.shape[0], nys[first:last].max(), 2 * ncols[first:last].max() + 1, 5))
    memo_key = np.full(2, np.nan)
    scratch = np.empty(SCRATCH_ANGLES)
    # Scenario C's low-friction field depends on the cell without its mu (the cells of one
    # (l1, l2, r1, r2, r) are neighbours in the work order): kept while they follow each other
    low_key = np.full(5, np.nan)
    low = new_finger_arrays(np.int64(1), np.int64(0), np.int64(0))
    low_links = np.empty((4, 0, 0))
    low_statics = np.empty((3, 0, 0))
    # the pair (mu_low, mu_low) does not depend on the part's mu either (palm poses never
    # count): its forces, kept with the field (the manipulation metric wants every width)
    low_count = np.zeros((0, 0), dtype=np.int64)
    low_fx = np.empty((0, 0, 0))
    low_fy = np.empty((0, 0, 0))
    for c in range(first, last):
        finger = cell_finger_model(cells, c, theta2_min, theta2_max)
        ny = nys[c]
        cell_ncols = ncols[c]
        memo_next = (c + 1 < last and cells[c + 1, 0] == cells[c, 0]
                     and cells[c + 1, 1] == cells[c, 1])
        shared, m_lo, ys = shared_finger_field(finger, solver, effects, steps, cell_ncols, ny, h)
        ncol_max = np.int64(0)
        slots = 0
        a_count = np.zeros((0, 0), dtype=np.int64)
        a_fx = np.empty((0, 0, 0))
        a_fy = np.empty((0, 0, 0))
        links = np.empty((4, 0, 0))
        statics = np.empty((3, 0, 0))
        if manipulation:
            for k in range(ws.shape[0]):
                ncol_max = max(ncol_max, cell_ncols[k])
            slots = ws.shape[0] * manip.a_commands.shape[0]
            a_count = np.zeros((ny, 2 * ncol_max + 1), dtype=np.int64)
            a_fx = np.empty((ny, 2 * ncol_max + 1, slots))
            a_fy = np.empty((ny, 2 * ncol_max + 1, slots))
            manip.n_entries[c] = 0
            links, statics = shared_finger_links_and_statics(shared, finger)
        elif collision:
            links = shared_finger_links(shared, finger)
        # Scenario C: the pairs with a finger on the low friction, unless it is the part's own
        # (then the four pairs are A's one, and C is A)
        mu_low = manip.c_mu_low[0] if scenario_c else finger.mu_s
        switching = mu_low != finger.mu_s
        c_count = np.zeros((0, 0), dtype=np.int64)
        c_fx = np.empty((0, 0, 0))
        c_fy = np.empty((0, 0, 0))
        fresh_low = False
        if switching:
            c_count = np.zeros((ny, 2 * ncol_max + 1), dtype=np.int64)
            c_fx = np.empty((ny, 2 * ncol_max + 1, 4 * slots))
            c_fy = np.empty((ny, 2 * ncol_max + 1, 4 * slots))
            key = (finger.l1, finger.l2, finger.r1, finger.r2, finger.r)
            fresh_low = not (low_key[0] == key[0] and low_key[1] == key[1]
                             and low_key[2] == key[2] and low_key[3] == key[3]
                             and low_key[4] == key[4])
            if fresh_low:
                low, low_links, low_statics = friction_field(finger, mu_low, solver, effects,
                                                             steps, cell_ncols, ny, h)
                for q in range(5):
                    low_key[q] = key[q]
                low_count = np.zeros((ny, 2 * ncol_max + 1), dtype=np.int64)
                low_fx = np.empty((ny, 2 * ncol_max + 1, slots))
                low_fy = np.empty((ny, 2 * ncol_max + 1, slots))
        memo_read = False
        if collision:
            memo_read = memo_key[0] == finger.l1 and memo_key[1] == finger.l2
            if memo_next and not memo_read:
                memo[:] = np.nan  # meetings depend on the links (and the widths, one memo each)
                memo_key[0] = finger.l1
                memo_key[1] = finger.l2
        for k in range(ws.shape[0]):
            if not want[c, k]:
                continue
            xs, fingers = gather_fingers(shared, m_lo, steps[k], cell_ncols[k], ny, h)
            outs = new_outcome_arrays(ny, xs.shape[0])
            stack = np.empty(ny * xs.shape[0], dtype=np.int64)
            hand = Hand(ws[k], f_left, f_right, h, finger.mu_s, finger.mu_s)
            settled = no_settled_fingers()
            if collision:  # the settled fingers' links, as gather_fingers reads the shared field
                settled = SettledFingers(True, links, cell_ncols[k] - steps[k] - m_lo, -1,
                                         -cell_ncols[k] - steps[k] - m_lo, 1, memo[k],
                                         memo_read, memo_next)
            map_from_fingers(xs, ys, finger, solver, hand, effects, fingers, outs, no_forces,
                             stack, out[c, k], STABLE_POINTS, ALL_OUTPUTS, ALL_OUTPUTS, settled)
            if manipulation:
                collect_counted_forces(xs, ys, finger, hand, outs, fingers, links, statics, m_lo,
                                       steps[k], cell_ncols[k], ncol_max, k, manip, c, a_count,
                                       a_fx, a_fy)
            if switching:
                # (mu_low, mu_s), and its mirror image (mu_s, mu_low)
                collect_pair_forces(
                    xs, ys, finger, Hand(ws[k], f_left, f_right, h, mu_low, finger.mu_s),
                    effects, low, shared, low_links, low_statics, links, statics, m_lo,
                    steps[k], cell_ncols[k], ncol_max, manip.a_commands, scratch, c_count,
                    c_fx, c_fy, MIRRORED, WHOLE_ROWS)
            if fresh_low:  # (mu_low, mu_low), its own mirror image: half the poses
                collect_pair_forces(
                    xs, ys, finger, Hand(ws[k], f_left, f_right, h, mu_low, mu_low), effects,
                    low, low, low_links, low_statics, low_links, low_statics, m_lo, steps[k],
                    cell_ncols[k], ncol_max, manip.a_commands, scratch, low_count, low_fx,
                    low_fy, MIRRORED, HALF_ROWS)
        if manipulation:
            manip.a_metric[c] = pose_radius_sum(a_count, a_fx, a_fy, manip.a_pose_value, c)
        if switching:
            append_forces(c_count, c_fx, c_fy, low_count, low_fx, low_fy)
            append_forces(c_count, c_fx, c_fy, a_count, a_fx, a_fy)
            manip.c_metric[c] = pose_radius_sum(c_count, c_fx, c_fy, manip.c_pose_value, c)
        elif scenario_c:  # mu_low is the part's own: the same forces as A
            manip.c_metric[c] = pose_radius_sum(a_count, a_fx, a_fy, manip.c_pose_value, c)
