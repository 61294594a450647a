"""One part position, anywhere: both fingers solved, collided, classified, and the energy
(MODEL 4-8). The grid's outcome rows (`field.outcome_row`) read the class and the energy from
here, and the sliding trajectories (`trajectory.py`) evaluate the model off the grid with
`point_outcome`: the same functions, so a point has one class and one energy whichever asks.
"""
import numpy as np
from numba import njit

from ..model import EJECT, FREE, INFEASIBLE, RANGE_TOL, REACHED, SLIPPED, UNREACHED, VERTEX, \
    VERTEX_POINT
from .finger import OVERLAP, finger_energy, solve_finger, spring_energy
from .collision import collide, collide_near
from .records import JointSprings, with_joint_springs


@njit(cache=True)
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


@njit(cache=True)
def point_energy(a1l, a2l, a1r, a2r, finger, hand, springs):
    """The system energy V_left + V_right of a point (MODEL 6), springs included when on."""
    e = (finger_energy(a1l, a2l, finger.r1, finger.r2, hand.f_left, finger.theta2_min)
         + finger_energy(a1r, a2r, finger.r1, finger.r2, hand.f_right, finger.theta2_min))
    if springs is not None:  # (adding 0.0 would turn a -0.0 energy into +0.0)
        e += (spring_energy(a1l, a2l, springs, finger.theta2_min)
              + spring_energy(a1r, a2r, springs, finger.theta2_min))
    return e


@njit(cache=True)
def finger_effects(effects, tension):
    """A finger's effect blocks: the springs act per unit of that finger's tendon tension
    (records.JointSprings), as in `maps.compute_map`'s per-side blocks."""
    return with_spring_tension(effects, effects.joint_springs, tension)


@njit(cache=True)
def with_spring_tension(effects, springs, tension):
    # the block as an argument: Numba prunes `is None` only on a function's own arguments
    if springs is None:
        return effects
    return with_joint_springs(effects, JointSprings(springs.k1, springs.k2, tension))


@njit(cache=True)
def point_outcome(x, y, finger, solver, effects, hand):
    """(class, energy) of the part centred at world (x, y): both fingers closed on it (finger
    frames d = (-x - w/2, y) and (x - w/2, y), MODEL 2), finger_collision when on; the energy
    is +inf where the point is INFEASIBLE (no energy there, and never lower than another)."""
    c, e, _ = point_outcome_below(x, y, finger, solver, effects, hand, np.inf, None)
    return c, e


@njit(cache=True)
def point_outcome_below(x, y, finger, solver, effects, hand, bound, context):
    """point_outcome for a search that only asks whether the energy is below `bound`:
    (class, energy, exact). Not exact (exact False) only with finger_collision, where the
    settled fingers' energy is already above `bound`: then that energy is returned, a lower
    bound of the true one (a finger stopped on the other has angles no larger than its
    settled ones, and the energy falls as either angle grows: MODEL 6 with tensions >= 0 and
    no springs), and the meeting is not searched. `context`: collision.slide_context (the
    meeting found as on the grid) or None (collision.collide)."""
    w = hand.w
    sl = solve_finger(-x - 0.5 * w, y, finger, solver, finger_effects(effects, hand.f_left))
    sr = solve_finger(x - 0.5 * w, y, finger, solver, finger_effects(effects, hand.f_right))
    collision = effects.finger_collision
    if collision is not None and effects.joint_springs is None and hand.f_left >= 0.0 \
            and hand.f_right >= 0.0:
        c = classify_point(y, finger.r, sl.mode, sr.mode)
        if c != INFEASIBLE:  # (the effect does not change an infeasible point)
            e = point_energy(sl.t1, sl.t2, sr.t1, sr.t2, finger, hand, None)
            if e > bound:
                return c, e, False
    if context is None:
        _, left, right = collide(finger, w, collision, sl.mode, sl.t1, sl.t2, sl.k1, sl.k2,
                                 sr.mode, sr.t1, sr.t2, sr.k1, sr.k2)
    else:
        _, left, right = collide_near(finger, w, collision, context, sl.mode, sl.t1, sl.t2,
                                      sl.k1, sl.k2, sr.mode, sr.t1, sr.t2, sr.k1, sr.k2)
    c = classify_point(y, finger.r, left[0], right[0])
    if c == INFEASIBLE:
        return c, np.inf, True
    return c, point_energy(left[1], left[2], right[1], right[2], finger, hand,
                           effects.joint_springs), True
