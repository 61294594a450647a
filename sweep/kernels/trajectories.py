"""Trajectories (MODEL 8, `trajectory_ends`): from every point of P_j downhill to where the part
stops, by one of three methods (`SolverSettings.trajectory`, model-notes D16): grid8 (discrete
steepest descent over the 8 neighbours), sliding (the default: slides on the true energy where
every grid neighbour is uphill, with a memo of the model's outcomes off the grid) or continuous
(`streamline.py`).

Grid8 and sliding move the part in straight steps between positions where the model was
evaluated. A step longer than `SolverSettings.step_resolution` whose two ends could lie on
either side of something narrower than the grid (its ends' first contacts made in different
stages of the closing sequence, or any move of a slide) is sampled at that resolution: it is
blocked where the energy rises above both ends (a wall: a band of vertex strikes, say) and it
ends where the part leaves P_j; a slide that met a wall goes on along it with small moves
(WALL_MOVES; model-notes D36).
"""
import math
import numpy as np

from typing import NamedTuple
from ..model import (
    PROXIMAL_ONLY,
    TWO_PHALANX,
    VERTEX,
    END_CAGED,
    END_EJECTION,
    END_NONE,
    END_STALLED,
    END_TIP_PREHENSION,
    INFEASIBLE,
    REACHED,
)
from .jit import entry, inner
from .meeting_search import slide_context
from .outcome import NO_CLASS, point_outcome_below
from .meeting import rests_on_other_finger
from .finger import DISTAL_ON_LOWER_STOP, JOINT_STRIKE, PROXIMAL_THEN_TIP, TIP_ON_LOWER_STOP


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
# After a step of the circle of h was blocked (a wall ahead), the slide goes on along the wall
# with this many moves on the circle of h/4 before it tries the circle of h again.
WALL_MOVES = 4


@entry
def max_slide_points(ny, nx):
    """Positions a slide can visit at most (the length of a `path` array that holds any)."""
    return SLIDE_STEPS_PER_CELL * (nx + ny) + 1

# What a slide ends in (slide_successor's second value).
SLIDE_REJOINS, SLIDE_EJECTS, SLIDE_STALLS = 0, 1, 2


class OutcomeMemo(NamedTuple):
    """The outcomes (`outcome.point_outcome`) the slides of one map have asked for, by position:
    an open-addressing hash table (linear probing) keyed by the bits of (|x|, y) where the hand
    is symmetric (`mirror`: equal tensions; the model is then exactly mirror-symmetric,
    point_outcome(-x, y) = point_outcome(x, y) bit for bit, tests/test_slide_memo.py), else
    of (x, y). A hit returns the bits a new evaluation would, so the slides are the same with
    or without it. An entry may hold a lower bound of the energy
    (`outcome.point_outcome_below`), which answers a later search only if it is above that
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
    if memo_has_room(memo):
        return memo
    capacity = memo.keys.shape[0]
    bigger = new_memo(min(max(MEMO_MIN_CAPACITY, 4 * capacity), MEMO_MAX_CAPACITY), memo.mirror)
    for s in range(capacity):
        if memo.keys[s, 0] != EMPTY_KEY:
            memo_store(bigger, memo.keys[s, 0], memo.keys[s, 1], memo.values[s, 0],
                       memo.values[s, 1], memo.values[s, 2])
    return bigger


@inner(inline="always")
def memo_has_room(memo):
    """Whether the next slide can use the memo as it is (memo_for_slide). A test of two numbers:
    the caller replaces its memo only when this fails, since every replacement of a record of
    arrays costs a reference-count pair per array (docs/performance.md)."""
    capacity = memo.keys.shape[0]
    return capacity >= MEMO_MIN_CAPACITY and (4 * memo.fill[0] <= capacity
                                              or capacity >= MEMO_MAX_CAPACITY)


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
    below `bound` (+inf: the exact outcome): outcome.point_outcome_below, read from the memo
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


# ---------------------------------------------------------------------------------------------
# Steps that cannot cross what the part cannot cross (model-notes D36)
# ---------------------------------------------------------------------------------------------
# What a straight move of the part between two positions meets (step_check's first value).
STEP_CLEAR, STEP_BLOCKED, STEP_LEAVES = 0, 1, 2


@inner
def step_check(x0, y0, e_top, x1, y1, resolution, finger, solver, effects, hand, memo, context):
    """What the part meets moving straight from (x0, y0) to (x1, y1), the model evaluated at
    points at most `resolution` apart (the two ends excluded): (kind, x, y). STEP_BLOCKED at
    the first point whose energy is above `e_top` (a wall: the caller passes the higher of the
    two ends' energies), STEP_LEAVES at the first point outside P_j, else STEP_CLEAR."""
    length = math.hypot(x1 - x0, y1 - y0)
    n = int(math.ceil(length / resolution - 1e-9)) if resolution > 0.0 else 1
    for k in range(1, n):
        t = k / n
        x = x0 + (x1 - x0) * t
        y = y0 + (y1 - y0) * t
        c, e = outcome_at(x, y, e_top, finger, solver, effects, hand, memo, context)
        if e > e_top:
            return STEP_BLOCKED, x, y
        if c != REACHED:
            return STEP_LEAVES, x, y
    return STEP_CLEAR, x1, y1


@inner(inline="always")
def closing_stage(first):
    """Which stage of the closing sequence (MODEL 4) made a finger's first contact, from the
    first contact's mode (kernels.finger codes): 0 the proximal link, 1 the distal link in the
    rigid sweep, 2 a vertex strike in the rigid sweep, 3 the distal closing with the proximal
    folded, or none. A band of vertex strikes lies between regions of different stages."""
    if first == PROXIMAL_ONLY or first == TWO_PHALANX or first == PROXIMAL_THEN_TIP:
        return 0
    if first == DISTAL_ON_LOWER_STOP:
        return 1
    if first == VERTEX or first == JOINT_STRIKE or first == TIP_ON_LOWER_STOP:
        return 2
    return 3


@inner(inline="always")
def same_stages(p, q, nx, first, mode, t1, t2, finger, collision_on):
    """Whether each finger made its first contact in the same stage of the closing sequence at
    the flat grid points p and q (`first`, `mode`, `t1`, `t2`: the map's FingerArrays fields,
    read once by the caller: each read of a record's field is a reference-count pair), and,
    with finger_collision, neither point has a finger stopped on the other (a meeting is a wall
    of its own: the stopped finger is less closed, its energy higher)."""
    jp = p // nx
    ip = p - jp * nx
    jq = q // nx
    iq = q - jq * nx
    for side in range(2):
        if closing_stage(first[side, jp, ip]) != closing_stage(first[side, jq, iq]):
            return False
        if collision_on and (
                rests_on_other_finger(np.int64(mode[side, jp, ip]),
                                      t1[side, jp, ip], t2[side, jp, ip], finger)
                or rests_on_other_finger(np.int64(mode[side, jq, iq]),
                                         t1[side, jq, iq], t2[side, jq, iq], finger)):
            return False
    return True


@inner
def checked_neighbour(energy, point_class, fingers, xs, ys, i, j, h, resolution, finger, solver,
                      effects, hand, memo, context):
    """The grid step from (j, i) with step checks: the steepest strictly lower feasible
    neighbour (downhill_neighbour's rule) whose step is clear, trying the others in order of
    slope where a step is blocked. Returns (kind, flat index): STEP_CLEAR and the neighbour;
    STEP_LEAVES and the grid point nearest to where the part left P_j; (STEP_BLOCKED, -1)
    where no neighbour is lower or every step is blocked.
    A step whose ends' first contacts were made in the same stages is not sampled."""
    ny, nx = energy.shape
    here = energy[j, i]
    diagonal = h * math.sqrt(2.0)
    first, mode, t1, t2 = fingers.first_event, fingers.mode, fingers.t1, fingers.t2
    collision_on = effects.finger_collision.on
    tried = 0
    for _ in range(8):
        best = -1
        best_slope = 0.0
        for n in range(8):
            if tried & (1 << n):
                continue
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
                best = n
        if best < 0:
            break
        tried |= 1 << best
        q = (j + NEIGHBOUR_DJ[best]) * nx + i + NEIGHBOUR_DI[best]
        if same_stages(j * nx + i, q, nx, first, mode, t1, t2, finger, collision_on):
            return STEP_CLEAR, q
        kind, x, y = step_check(xs[i], ys[j], here, xs[q % nx], ys[q // nx], resolution,
                                finger, solver, effects, hand, memo, context)
        if kind == STEP_CLEAR:
            return STEP_CLEAR, q
        if kind == STEP_LEAVES:
            return STEP_LEAVES, nearest_grid_point(x, y, xs, ys, h)
    return STEP_BLOCKED, -1


@entry(inline="always")  # a leaf called at every grid step of trajectories_from
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
    start, or stable), or the grid point nearest to where the part leaves P_j or stops.
    `path`: an array (n, 2) that receives the world positions of the slide (pictures, tests;
    (0, 2): not recorded); `memo`: the map's OutcomeMemo (of no capacity: none); `context`:
    the map's hand.slide_context, or hand.no_slide_context()."""
    ny, nx = energy.shape
    h = hand.h
    resolution = solver.step_resolution
    checks = step_checks_on(solver, h)
    e_start = energy[j0, i0]
    x = xs[i0]
    y = ys[j0]
    e_here = e_start
    stage = 0
    wall = 0   # small moves left before the step's search on the circle of h is tried again
    scratch = np.empty(SLIDE_DIRECTIONS)
    n_path = record(path, np.int64(0), x, y)
    for _ in range(max_slide_points(ny, nx) - 1):
        if stage == 0 and wall > 0:
            stage = 1
        rho = h * SLIDE_CASCADE_RADIUS[stage]
        e, c, ux, uy = lowest_on_circle(x, y, rho, np.bool_(SLIDE_CASCADE_THOROUGH[stage]),
                                        scratch,
                                        finger, solver, effects, hand, memo, context)
        if e < e_here - SLIDE_REL * abs(e_here) and checks:
            kind, gx, gy = step_check(x, y, e_here, x + rho * ux, y + rho * uy, resolution,
                                      finger, solver, effects, hand, memo, context)
            if kind == STEP_BLOCKED:
                e = np.inf
                if stage == 0:
                    wall = WALL_MOVES
            elif kind == STEP_LEAVES:
                n_path = record(path, n_path, gx, gy)
                return nearest_grid_point(gx, gy, xs, ys, h), SLIDE_EJECTS, n_path
        if not (e < e_here - SLIDE_REL * abs(e_here)):
            stage += 1
            if stage == len(SLIDE_CASCADE_RADIUS):
                break
            continue
        x += rho * ux
        y += rho * uy
        e_here = e
        if stage == 1 and wall > 0:
            wall -= 1
        stage = 0
        n_path = record(path, n_path, x, y)
        fi = (x - xs[0]) / h
        fj = (y - ys[0]) / h
        if c != REACHED or not (-0.5 <= fi < nx - 0.5 and -0.5 <= fj < ny - 0.5):
            # the part left P_j, or the grid (a user window's edge)
            return nearest_grid_point(x, y, xs, ys, h), SLIDE_EJECTS, n_path
        # rejoin the grid at the lowest corner of the cell below the start's energy (a stable
        # corner ends the trajectory whatever its energy); with step checks, only a corner the
        # part could move to in a straight line
        ia = int(math.floor(fi))
        ja = int(math.floor(fj))
        best = -1
        e_best = e_start - SLIDE_REL * abs(e_start)
        for corner in range(4):
            qi = ia + (corner & 1)
            qj = ja + (corner >> 1)
            if qi < 0 or qi >= nx or qj < 0 or qj >= ny or point_class[qj, qi] != REACHED:
                continue
            if not equilibrium[qj, qi] and not energy[qj, qi] < e_best:
                continue
            if checks and step_check(x, y, max(e_here, energy[qj, qi]), xs[qi], ys[qj],
                                     resolution, finger, solver, effects, hand, memo,
                                     context)[0] != STEP_CLEAR:
                continue
            if equilibrium[qj, qi]:
                best = qj * nx + qi
                break
            e_best = energy[qj, qi]
            best = qj * nx + qi
        if best >= 0:
            return best, SLIDE_REJOINS, n_path
    return nearest_grid_point(x, y, xs, ys, h), SLIDE_STALLS, n_path


@inner
def step_checks_on(solver, h):
    """Whether a map of spacing h samples its steps: whether its diagonal steps, its longest,
    are longer than the resolution (a step is sampled only where it is)."""
    return solver.step_resolution > 0.0 and h * math.sqrt(2.0) > solver.step_resolution


# What the next step from a grid point gives (`successor`'s first value): the trajectory goes on
# (END_NONE: it does not end there), or it ends, with one of the END_* states.
GOES_ON = END_NONE


@entry
def successor(energy, point_class, equilibrium, fingers, xs, ys, i, j, finger, solver, effects,
              hand, sliding, path, memo, context):
    """Where the trajectory goes from the REACHED, not stable grid point (j, i) (module
    docstring): (GOES_ON, the next grid point, points written to `path` by a slide), or (an
    END_* state, the end point, points written). The one rule of a step, for trajectory_ends
    and for pictures."""
    ny, nx = energy.shape
    h = hand.h
    if step_checks_on(solver, h):
        kind, q = checked_neighbour(energy, point_class, fingers, xs, ys, i, j, h,
                                    solver.step_resolution, finger, solver, effects, hand, memo,
                                    context)
        if kind == STEP_CLEAR:
            return GOES_ON, q, 0
        if kind == STEP_LEAVES:
            return END_EJECTION, q, 0
    else:
        q = downhill_neighbour(energy, point_class, i, j, h)
        if q >= 0:
            return GOES_ON, q, 0
    if not sliding:
        return END_STALLED, j * nx + i, 0
    q, kind, n = slide_successor(energy, point_class, equilibrium, xs, ys, i, j, finger, solver,
                                 effects, hand, path, memo, context)
    if kind == SLIDE_REJOINS:
        return GOES_ON, q, n
    return (END_EJECTION if kind == SLIDE_EJECTS else END_STALLED), q, n


@inner
def record(path, n, x, y):
    """Write position n of a slide into `path` (room for fewer: not recorded); returns n + 1."""
    if n < path.shape[0]:
        path[n, 0] = x
        path[n, 1] = y
    return n + 1


@entry
def trajectory_ends(outs, fingers, xs, ys, finger, solver, effects, hand, stack, sliding):
    """End state and end point (outs.end_state, outs.end_index) of the trajectory from every
    point of P_j (REACHED points): grid8, or with `sliding` the sliding
    method (module docstring). `first`: the map's FingerArrays.first_event (step checks).
    `stack` is scratch of size >= number of points. Returns the map score Lambda (MODEL 8)."""
    ny, nx = outs.energy.shape
    size = ny * nx
    # flat views, made once: `.flat[p]` made an iterator, a reference-count pair, per point
    end_state = outs.end_state.reshape(size)
    end_index = outs.end_index.reshape(size)
    caging_score = outs.caging_score.reshape(size)
    for p in range(size):
        end_state[p] = END_NONE
        end_index[p] = -1
    memo = new_memo(np.int64(1), hand.f_left == hand.f_right)  # grown when first needed
    p0 = np.int64(0)  # (a literal 0 compiled trajectories_from a second time, for Literal[int](0))
    while p0 < size:
        # the trajectories run with one memo until a step needs a larger one; the memo is
        # replaced here, between calls, since replacing a record of arrays inside the loop cost
        # a reference-count pair per array at every point (docs/performance.md)
        p0 = trajectories_from(p0, outs, end_state, end_index, fingers, xs, ys, finger, solver,
                               effects, hand, stack, sliding, memo)
        if p0 < size:
            memo = memo_for_slide(memo)
    score_sum = 0.0
    for p in range(size):
        if end_state[p] == END_CAGED:
            score_sum += caging_score[end_index[p]]
    return score_sum


@inner
def trajectories_from(p_start, outs, end_state, end_index, fingers, xs, ys, finger, solver,
                      effects, hand, stack, sliding, memo):
    """trajectory_ends from flat point p_start on with this memo: fills end_state and end_index
    (flat views of outs') and returns the number of points, or the point whose
    trajectory stopped before a step that evaluates the model because the memo has no room
    (memo_has_room); nothing of that trajectory is written, so the caller gives it a larger
    memo and starts there again (the memo only caches outcomes: the trajectory is the same)."""
    energy = outs.energy
    point_class = outs.point_class
    equilibrium = outs.equilibrium
    caged = outs.caged
    h = hand.h
    checks = step_checks_on(solver, h)
    ny, nx = energy.shape
    size = ny * nx
    no_path = np.empty((0, 2))
    context = slide_context(finger, hand.w, effects.finger_collision)
    first, mode, t1, t2 = fingers.first_event, fingers.mode, fingers.t1, fingers.t2
    collision_on = effects.finger_collision.on
    for p0 in range(p_start, size):
        j0 = p0 // nx
        i0 = p0 - j0 * nx
        if point_class[j0, i0] != REACHED or end_state[p0] != END_NONE:
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
            if end_state[p] != END_NONE:  # already resolved
                state = end_state[p]
                last = end_index[p]
                break
            stack[depth] = p
            depth += 1
            if equilibrium[j, i]:
                state = END_CAGED if caged[j, i] else END_TIP_PREHENSION
                last = p
                break
            # the grid step that needs no evaluation of the model, here rather than in
            # `successor`: the call passes some twenty arrays, a reference-count pair each
            # (docs/architecture.md), at every step; `successor` takes the same first choice
            q = downhill_neighbour(energy, point_class, i, j, h)
            if q >= 0 and (not checks or same_stages(p, q, nx, first, mode, t1, t2, finger,
                                                     collision_on)):
                p = q
                continue
            if not memo_has_room(memo) and (checks or (sliding and q < 0)):
                return p0
            state, q, _ = successor(energy, point_class, equilibrium, fingers, xs, ys, i, j,
                                           finger, solver, effects, hand, sliding, no_path,
                                           memo, context)
            if state != GOES_ON:
                last = q
                break
            p = q
        for s in range(depth):
            end_state[stack[s]] = state
            end_index[stack[s]] = last
    return size
