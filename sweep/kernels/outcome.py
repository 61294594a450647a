"""One part position anywhere (MODEL 4-8): both fingers solved, collided, classified, and the
system energy (`point_outcome`). The grid's outcome rows read the class and the energy from
here, and the sliding trajectories evaluate the model off the grid with the same functions, so
a point has one class and one energy whichever asks.
"""
import numpy as np

from ..model import (
    EJECT,
    FREE,
    INFEASIBLE,
    RANGE_TOL,
    REACHED,
    SLIPPED,
    UNREACHED,
    VERTEX,
    VERTEX_POINT,
)
from .jit import entry, inner
from .records import LEFT, RIGHT, side_finger
from .finger_statics import finger_energy, spring_energy
from .finger import closing_constants, finger_effects, OVERLAP, solve_finger_of, took_tip_path
from .meeting import collide_on_own_paths
from .meeting_search import collide, collide_near, meeting_state, no_slide_context
from .hand import finger_polyline, fingers_cross, mouth_opening, part_contained


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
    meeting found as on the grid) or meeting_search.no_slide_context() (meeting_search.collide)."""
    c, e, exact, _, _ = hand_below(x, y, finger, solver, effects, hand, bound, context)
    return c, e, exact


@inner
def hand_below(x, y, finger, solver, effects, hand, bound, context):
    """Both fingers at world (x, y), collided, classified: (class, energy, exact, left,
    right), each finger (mode, t1, t2, k1, k2); point_outcome_below's lower bound where the
    settled fingers' energy is above `bound` (exact False, the fingers the settled ones)."""
    w = hand.w
    # (solve_finger's own body: the entry point would compile the finger's whole tree again)
    left = side_finger(finger, hand, LEFT)
    right = side_finger(finger, hand, RIGHT)
    sl = solve_finger_of(-x - 0.5 * w, y, left, closing_constants(left), solver,
                         finger_effects(effects, hand.f_left))
    sr = solve_finger_of(x - 0.5 * w, y, right, closing_constants(right), solver,
                         finger_effects(effects, hand.f_right))
    collision = effects.finger_collision
    if collision.on and (took_tip_path(sl.mode, effects.tip_contact)
                                  or took_tip_path(sr.mode, effects.tip_contact)):
        # on the fingers' own paths (D29); no lower bound: on the tip path t1 may grow
        _, fl, fr = collide_on_own_paths(x, y, finger, solver, effects, hand, collision,
                                         meeting_state(sl), meeting_state(sr))
        c, e, exact = outcome_of(y, fl, fr, finger, hand, effects.joint_springs)
        return c, e, exact, fl, fr
    if collision.on and not effects.joint_springs.on and hand.f_left >= 0.0 \
            and hand.f_right >= 0.0:
        c = classify_point(y, finger.r, sl.mode, sr.mode)
        if c != INFEASIBLE:  # (the effect does not change an infeasible point)
            e = point_energy(sl.t1, sl.t2, sr.t1, sr.t2, finger, hand, effects.joint_springs)
            if e > bound:
                return c, e, False, meeting_state(sl), meeting_state(sr)
    if not context[0]:
        _, fl, fr = collide(finger, w, collision, sl, sr)
    else:
        _, fl, fr = collide_near(finger, w, collision, context, sl, sr)
    c, e, exact = outcome_of(y, fl, fr, finger, hand, effects.joint_springs)
    return c, e, exact, fl, fr


@inner
def cage_score(inside, opening, r):
    """S = 1 - L_open / (2r) where the part is contained and L_open < 2r, else 0 (MODEL 8; an
    exact tie L_open == 2r is not caged, model-notes D5). Stability is the caller's business:
    S of a stable point is the caging score, of any reached point S_geo (MODEL 10)."""
    if inside and opening < 2.0 * r - RANGE_TOL:
        return 1.0 - opening / (2.0 * r)
    return 0.0


@inner
def cage_geometry(x, y, t1l, t2l, t1r, t2r, finger, hand):
    """(contained, fingers cross, L_open) of the part at (x, y) between the fingers (MODEL 8)."""
    left = finger_polyline(LEFT, t1l, t2l, finger.l1, finger.l2, hand.w)
    right = finger_polyline(RIGHT, t1r, t2r, finger.l1, finger.l2, hand.w)
    inside = part_contained(x, y, left, right)
    intersect = fingers_cross(left, right)
    opening = mouth_opening(left, right, intersect)
    return inside, intersect, opening


@inner
def outcome_of(y, left, right, finger, hand, springs):
    """(class, energy, exact) of a position from its fingers, each (mode, t1, t2, k1, k2)."""
    c = classify_point(y, finger.r, left[0], right[0])
    if c == INFEASIBLE:
        return c, np.inf, True
    return c, point_energy(left[1], left[2], right[1], right[2], finger, hand, springs), True


NO_CLASS = np.int64(INFEASIBLE)

