"""The finger: which configuration it reaches (MODEL 4, 5), in two steps. `closing_contact`
depends on geometry only (l1, l2, r, joint limits): the first contact of the closing sequence.
`settle` adds the stick-slip decisions and the paths (finger_paths), which depend on the pulley
radii and friction. `solve_finger` is both in sequence. With the tip_contact effect (model-notes
D15) a vertex strike is settled too (`settle_vertex`), by the statics.

Parameters come as records (`kernels.records`): `finger` a FingerModel, `solver` the
SolverSettings, `effects` the effect blocks (`finger_effects`: one finger's, springs scaled by
its tendon tension); a finger's configuration is a FingerState. Nothing here raises.
"""
import math
import numpy as np

from ..model import (
    DISTAL_ONLY,
    FREE,
    PROXIMAL_ONLY,
    PROXIMAL_TIP,
    RANGE_TOL,
    SLIPPED,
    TIP_ONLY,
    TWO_PHALANX,
    VERTEX,
)
from .jit import entry, inner
from .records import FingerState, JointSprings, with_joint_springs
from .finger_geometry import (
    clamp,
    distal_tangency,
    distal_tangency_slack,
    EPS,
    in_range,
    joint_strike_angle,
    proximal_tangency,
    rigid_distal_tangency,
    rigid_sweep,
    rigid_tangency_slack,
    tangency_slack,
    tangent_length,
    tangent_length_error,
    vertex_entry,
    vertex_entry_at,
    wrap_angle,
)
from .finger_statics import (
    at_limit,
    BALANCE_NEGATIVE,
    BALANCE_POSITIVE,
    combine_balance,
    joint_torques,
    max_torque_balance,
    sticks_on_lower_stop,
    stop_balance,
    vertex_contact_holds,
)
from .finger_paths import (
    DISTAL_STOP,
    EDGE_PATH,
    event_crossing,
    EXACT_TOL,
    follow_path,
    proximal_link_gap,
    PROXIMAL_STOP,
    SLIP,
    STICK,
    tip_columns,
    tip_event_margin,
    tip_node,
    tip_on_disc,
    TIP_PATH,
    tip_polar,
)


# Internal modes of a first contact that still has to be settled (never stored).
OVERLAP = np.int64(-1)                 # the part overlaps the joint: the point is infeasible
DISTAL_ON_LOWER_STOP = np.int64(16)    # distal-only first contact of the rigid sweep (t2 = th2min)
DISTAL_ON_PROXIMAL_STOP = np.int64(17)  # distal-only contact with the proximal folded at t1 = pi
# Vertex strikes, only with tip_contact (D15; without it they are VERTEX):
JOINT_STRIKE = np.int64(18)            # B strikes the part in the rigid sweep
TIP_ON_LOWER_STOP = np.int64(19)       # T strikes in the rigid sweep (t2 = theta2_min)
TIP_ON_PROXIMAL_STOP = np.int64(20)    # T strikes as the distal closes with t1 = pi
PROXIMAL_THEN_TIP = np.int64(21)       # T strikes as the distal closes after a proximal contact


# ---------------------------------------------------------------------------------------------
# Closing sequence (MODEL 4): geometry only
# ---------------------------------------------------------------------------------------------
@entry
def closing_constants(finger):
    """What the closing sweep of every point of a finger shares (MODEL 3.3, 4): r' and
    l1 cos theta2_min (rigid_sweep), and the tip's polar radius and offset at theta2_min
    (tip_polar). Computed once per finger, not per point: eight of the libm calls of a point's
    rigid sweep, one an arctangent (docs/performance.md)."""
    r_eff, l1_cos_min = rigid_sweep(finger.r, finger.l1, finger.theta2_min)
    rho_t, delta_t = tip_polar(finger.theta2_min, finger.l1, finger.l2)
    return r_eff, l1_cos_min, rho_t, delta_t


@entry
def closing_contact(dx, dy, finger, constants, effects):
    """First contact of the closing sequence, as a FingerState whose mode is FREE,
    PROXIMAL_ONLY, TWO_PHALANX (not yet checked for stick-slip), VERTEX, DISTAL_ON_LOWER_STOP,
    DISTAL_ON_PROXIMAL_STOP, or OVERLAP (part overlaps the joint). `constants`: the finger's
    closing_constants (a field of points computes them once)."""
    r_eff, l1_cos_min, rho_t, delta_t = constants
    l1 = finger.l1
    l2 = finger.l2
    r = finger.r
    theta2_min = finger.theta2_min
    theta2_max = finger.theta2_max
    if tangent_length(dx * dx + dy * dy, r) < 0.0:
        return FingerState(OVERLAP, 0.0, 0.0, 0.0, 0.0, False)
    alpha = math.atan2(dy, dx)  # the polar angle of d, shared by the sweep's events

    # Rigid sweep, proximal tangency first (provably the earliest event when valid).
    t1, k1 = proximal_tangency(alpha, dx, dy, r)
    slack = tangency_slack(k1, dx * dx + dy * dy, r)  # a part touching the joint (stability.md)
    slack_k1 = RANGE_TOL + tangent_length_error(k1, 4.0 * EPS * (dx * dx + dy * dy))
    # a part the feasibility test lets dip below the palm line (y >= r - RANGE_TOL) already
    # touches the open finger: an event's angle lies below 0 by that dip, not by round-off, and
    # means a contact at rest (D30)
    rest = 0.0 if dy >= r else -0.5 * math.pi
    if k1 <= l1 + slack_k1 and rest - slack <= t1 <= math.pi + slack:
        t1 = clamp(t1, 0.0, math.pi)
        k1 = clamp(k1, 0.0, l1)
        return distal_closes_after_proximal(dx, dy, t1, k1, finger, effects.tip_contact)

    # Otherwise the earliest of: distal tangency (3.3), a strike of B, a strike of T.
    best_t1 = math.inf
    mode = FREE
    k1_out = 0.0
    k2_out = 0.0
    t1c, k2c = rigid_distal_tangency(alpha, dx, dy, theta2_min, r_eff, l1_cos_min)
    # validity within the closed form's own round-off (D30): a tangency rejected by round-off
    # let the finger sweep on with its distal link through the part
    slack_k2, slack_t1 = rigid_tangency_slack(dx, dy, l1, r_eff, l1_cos_min, k2c)
    if -slack_k2 <= k2c <= l2 + slack_k2 and rest - slack_t1 <= t1c <= math.pi + slack_t1:
        best_t1 = t1c
        mode = DISTAL_ON_LOWER_STOP
        # within its round-off of B the contact is at B, where it cannot stick (D10, D30):
        # round-off must not decide between sticking and sliding
        k2_out = clamp(k2c, 0.0, l2) if k2c > slack_k2 else 0.0
    # A vertex wins only if strictly earlier: at a tie the tangency covers the link's end.
    t_b = joint_strike_angle(alpha, dx, dy, l1, r)
    if in_range(t_b, rest, math.pi) and t_b < best_t1 - slack_t1:
        best_t1 = t_b
        mode = strike_mode(effects.tip_contact, JOINT_STRIKE)
        k1_out = l1
        k2_out = 0.0
    t_t = vertex_entry_at(alpha, dx, dy, rho_t, delta_t, r)
    tie = slack_t1 if mode == DISTAL_ON_LOWER_STOP else RANGE_TOL
    if in_range(t_t, rest, math.pi) and t_t < best_t1 - tie:
        best_t1 = t_t
        mode = strike_mode(effects.tip_contact, TIP_ON_LOWER_STOP)
        k1_out = 0.0
        k2_out = l2
    if mode != FREE:
        return FingerState(mode, clamp(best_t1, 0.0, math.pi), theta2_min, k1_out, k2_out, False)

    # No event before the proximal stop: the distal closes about B with t1 = pi.
    t1 = math.pi
    t2, k2 = distal_tangency(dx, dy, t1, l1, r)
    slack_k2, slack_t2 = distal_tangency_slack(dx, dy, t1, l1, r, k2)
    if k2 <= l2 + slack_k2 and theta2_min - slack_t2 <= t2 <= theta2_max + slack_t2:
        return FingerState(DISTAL_ON_PROXIMAL_STOP, t1, clamp(t2, theta2_min, theta2_max), 0.0,
                           clamp(k2, 0.0, l2), False)
    t2_tip = tip_entry_about_distal_joint(dx, dy, t1, l1, l2, r)
    if in_range(t2_tip, theta2_min, theta2_max):
        return FingerState(strike_mode(effects.tip_contact, TIP_ON_PROXIMAL_STOP), t1,
                           clamp(t2_tip, theta2_min, theta2_max), 0.0, l2, False)
    return FingerState(FREE, t1, theta2_max, 0.0, 0.0, False)


@inner
def strike_mode(tip_contact, strike):
    """The mode of a vertex strike: VERTEX in the paper's model (tip_contact off), else the
    strike's own internal mode, settled by settle_vertex (D15)."""
    if not tip_contact.on:
        return VERTEX
    return strike


@inner
def tip_entry_about_distal_joint(dx, dy, t1, l1, l2, r):
    """Relative angle t2 at which the tip, turning about B with t1 fixed, enters the disc (inf:
    never)."""
    ex = dx - l1 * math.cos(t1)
    ey = dy - l1 * math.sin(t1)
    phi = vertex_entry(ex, ey, l2, 0.0, r)
    if phi == math.inf:
        return math.inf
    return wrap_angle(phi - t1)


@inner
def distal_closes_after_proximal(dx, dy, t1, k1, finger, tip_contact):
    """MODEL 4.3: after a proximal contact the distal closes about B with t1 fixed. If the tip
    strikes the part on the way, the paper's answer is kept and flagged (tip_contact off) or the tip
    is a contact (tip_contact, D15)."""
    t2, k2 = distal_tangency(dx, dy, t1, finger.l1, finger.r)
    slack_k2, slack_t2 = distal_tangency_slack(dx, dy, t1, finger.l1, finger.r, k2)
    if (k2 <= finger.l2 + slack_k2
            and finger.theta2_min - slack_t2 <= t2 <= finger.theta2_max + slack_t2):
        return FingerState(TWO_PHALANX, t1, clamp(t2, finger.theta2_min, finger.theta2_max), k1,
                           clamp(k2, 0.0, finger.l2), False)
    # The distal reaches its limit; the paper keeps this answer even if the tip passes through
    # the part on the way, which is flagged (MODEL 4.3, model-notes D3).
    t2_tip = tip_entry_about_distal_joint(dx, dy, t1, finger.l1, finger.l2, finger.r)
    strikes = in_range(t2_tip, finger.theta2_min, finger.theta2_max)
    if tip_contact.on and strikes:
        return FingerState(PROXIMAL_THEN_TIP, t1, clamp(t2_tip, finger.theta2_min,
                                                        finger.theta2_max), k1, finger.l2, False)
    return FingerState(PROXIMAL_ONLY, t1, finger.theta2_max, k1, 0.0, strikes)


# ---------------------------------------------------------------------------------------------
# Stick-slip and reconfiguration (MODEL 5)
# ---------------------------------------------------------------------------------------------
@entry
def reconfigure(dx, dy, t1_start, finger, solver, effects):
    """MODEL 5.3: slide the distal contact toward the tip while t1 decreases, until an event
    (the edge path above).

    Returns a FingerState with mode DISTAL_ONLY (stuck, or on a joint stop) or SLIPPED; with
    tip_contact, a contact that passes the tip is taken over by the tip (D15).
    """
    event, t1, _, _ = follow_path(dx, dy, t1_start, 0.0, finger, solver, effects.joint_springs,
                                  EDGE_PATH)
    t2, k2 = distal_tangency(dx, dy, t1, finger.l1, finger.r)
    if event == SLIP:
        return past_the_tip(effects.tip_contact, dx, dy, t1, t2, k2, finger, solver,
                            effects.joint_springs)
    # the bracket end may lie past the distal stop by up to root_tol: report the stop itself;
    # and a contact near B, where 3.2's angle carries round-off, within the lower stop (D30)
    return FingerState(DISTAL_ONLY, t1, clamp(t2, finger.theta2_min, finger.theta2_max), 0.0,
                       k2, False)


@inner
def past_the_tip(tip_contact, dx, dy, t1, t2, k2, finger, solver, springs):
    """The distal contact has slid to the tip: the part is lost (SLIPPED, the paper's ejection)
    or, with tip_contact, the finger follows the tip on the disc (D15)."""
    if not tip_contact.on:
        return FingerState(SLIPPED, t1, t2, 0.0, k2, False)
    return tip_path(dx, dy, t2, finger, solver, springs)


@inner
def tip_path(dx, dy, t2_start, finger, solver, springs):
    """D15: the tip stays on the disc while the distal closes (t2 increases from t2_start, t1
    follows), until it can hold (TIP_ONLY), a joint stop (TIP_ONLY on the stop), the proximal
    link reaches the part (PROXIMAL_TIP, resting on it as on a stop, D21) or the part is lost
    (SLIPPED, where the tip last touched)."""
    event, s, s_touching, s_free = follow_path(dx, dy, -t2_start, -finger.theta2_max, finger,
                                               solver, springs, TIP_PATH)
    if event == SLIP:
        s = s_touching
    elif tip_node(s, dx, dy, finger, springs)[7] > RANGE_TOL:
        # the distal link already cuts into the part at the path's end: it reached the disc at
        # the tip within the last step, unseen at its nodes (the cut rose and fell back within a
        # coarse reconfig_step): the part was lost there, where it is first met (D20, D19)
        _, s = event_crossing(SLIP, s, s_free, dx, dy, finger, springs,
                              min(solver.root_tol, EXACT_TOL), TIP_PATH)
        event = SLIP
    if (event == SLIP and tip_event_margin(STICK, s, dx, dy, finger, springs)[0]
            and not tip_event_margin(STICK, s_free, dx, dy, finger, springs)[0]):
        # the tip could hold where it last touched the part: the tendon stopped driving it along
        # the path (V rose past a minimum) before it pulled the tip off, all within the last
        # step; the path ends where the tip first holds (D15 "Within one step"). Not where the
        # path began (s_free its start): the strike's own hold test, with its stops, decided
        # there, and at a straight finger (t2 = 0) the tip's columns are parallel.
        s, _ = event_crossing(STICK, s, s_free, dx, dy, finger, springs,
                              min(solver.root_tol, EXACT_TOL), TIP_PATH)
        event = STICK
    if event != PROXIMAL_STOP and tip_event_margin(PROXIMAL_STOP, s, dx, dy, finger, springs)[0]:
        # the proximal stop (or the part, D21) was passed within the last step, unseen at its
        # nodes (a coarse reconfig_step): the path ends where it is first met (D19)
        s, _ = event_crossing(PROXIMAL_STOP, s, s_free, dx, dy, finger, springs,
                              min(solver.root_tol, EXACT_TOL), TIP_PATH)
        event = PROXIMAL_STOP
    t2 = min(-s, finger.theta2_max)
    if event == DISTAL_STOP:  # on the stop itself (as the edge path ends on t1 = 0 exactly)
        t2 = finger.theta2_max
    _, _, t1 = tip_on_disc(t2, dx, dy, finger)
    t1 = clamp(t1, 0.0, math.pi)
    if event == SLIP:
        return FingerState(SLIPPED, t1, t2, 0.0, finger.l2, False)
    if event == PROXIMAL_STOP and proximal_link_gap(t1, dx, dy, finger) <= RANGE_TOL:
        # the proximal link reached the part (D21): it rests on it, with the tip
        k1 = clamp(dx * math.cos(t1) + dy * math.sin(t1), 0.0, finger.l1)
        return FingerState(PROXIMAL_TIP, t1, t2, k1, finger.l2, False)
    return FingerState(TIP_ONLY, t1, t2, 0.0, finger.l2, False)


@inner
def tip_contact_holds(state, dx, dy, finger, springs, proximal_contact):
    """MODEL 5.1 for a finger touching the part with its tip (D15), with a proximal edge contact
    or not, and with the stops its joints rest on."""
    cn1, cn2, ct1, ct2 = tip_columns(state.t1, state.t2, dx, dy, finger)
    tau1, tau2 = joint_torques(state.t1, state.t2, finger, springs)
    lower1, upper1 = at_limit(state.t1, 0.0, math.pi)
    lower2, upper2 = at_limit(state.t2, finger.theta2_min, finger.theta2_max)
    # proximal lower stop: closing torque (residual <= 0), upper: opening (>= 0); likewise distal
    proximal = stop_balance(lower1, upper1, BALANCE_NEGATIVE, BALANCE_POSITIVE)
    if proximal_contact and state.k1 > RANGE_TOL:  # a proximal edge contact pushes open
        proximal = combine_balance(proximal, BALANCE_POSITIVE)
    distal = stop_balance(lower2, upper2, BALANCE_NEGATIVE, BALANCE_POSITIVE)
    return vertex_contact_holds(tau1, tau2, cn1, cn2, ct1, ct2, finger.mu_s, proximal, distal)


@inner
def settle_vertex(tip_contact, first, dx, dy, finger, solver, effects):
    """D15: settle a vertex strike (tip_contact only; without it a strike stays VERTEX)."""
    if not tip_contact.on:
        return first
    mode = first.mode
    if mode == JOINT_STRIKE:
        # the distal lies tangent at B, where no force balances the distal tendon: the contact
        # slides from B toward the tip along the edge path
        return reconfigure(dx, dy, first.t1, finger, solver, effects)
    with_proximal = mode == PROXIMAL_THEN_TIP
    if tip_contact_holds(first, dx, dy, finger, effects.joint_springs, with_proximal):
        return FingerState(PROXIMAL_TIP if with_proximal else TIP_ONLY, first.t1, first.t2,
                           first.k1 if with_proximal else 0.0, finger.l2, False)
    return tip_path(dx, dy, first.t2, finger, solver, effects.joint_springs)


@entry
def settle(first, dx, dy, finger, solver, effects):
    """Apply the stick-slip cases to a first contact: the finger's final FingerState."""
    mode = first.mode
    springs = effects.joint_springs
    if mode == TWO_PHALANX:
        if max_torque_balance(first.k2, first.t1, first.t2, finger, springs) >= 0.0:  # 1 and 3
            return first
        return reconfigure(dx, dy, first.t1, finger, solver, effects)
    if mode == DISTAL_ON_LOWER_STOP:
        if sticks_on_lower_stop(first.k2, first.t1, first.t2, finger, springs):
            return FingerState(DISTAL_ONLY, first.t1, first.t2, 0.0, first.k2, False)
        return reconfigure(dx, dy, first.t1, finger, solver, effects)
    if mode == DISTAL_ON_PROXIMAL_STOP:
        if max_torque_balance(first.k2, first.t1, first.t2, finger, springs) >= 0.0:
            return FingerState(DISTAL_ONLY, first.t1, first.t2, 0.0, first.k2, False)
        return reconfigure(dx, dy, first.t1, finger, solver, effects)
    if mode >= JOINT_STRIKE:
        return settle_vertex(effects.tip_contact, first, dx, dy, finger, solver, effects)
    return first


@entry
def solve_finger(dx, dy, finger, solver, effects):
    """The finger's equilibrium configuration (FingerState); mode OVERLAP (-1) means the part
    overlaps the joint (infeasible point). tip_overlap is decided by the closing sequence.
    `effects` is an EffectBlocks record (records.NO_EFFECTS: the paper's model)."""
    return solve_finger_of(dx, dy, finger, closing_constants(finger), solver, effects)


@inner
def solve_finger_of(dx, dy, finger, constants, solver, effects):
    """solve_finger with the finger's closing_constants given (a field of points computes them
    once)."""
    first = closing_contact(dx, dy, finger, constants, effects)
    final = settle(first, dx, dy, finger, solver, effects)
    return FingerState(final.mode, final.t1, final.t2, final.k1, final.k2, first.tip_overlap)


@inner
def solve_finger_branch(dx, dy, finger, constants, solver, effects):
    """(first contact's mode, solve_finger_of's FingerState): the branch of the closing sequence
    a grid point took, which the trajectories compare between the two ends of a step."""
    first = closing_contact(dx, dy, finger, constants, effects)
    final = settle(first, dx, dy, finger, solver, effects)
    return first.mode, FingerState(final.mode, final.t1, final.t2, final.k1, final.k2,
                                   first.tip_overlap)


@inner
def took_tip_path(mode, tip_contact):
    """A settled finger whose final state may lie on the tip path (D15): TIP_ONLY, PROXIMAL_TIP,
    or SLIPPED with tip_contact (the part lost by the tip). Its closing is not the rigid sweep
    then the distal closing that finger_collision rebuilds from the final angles (D14, D29)."""
    return tip_contact.on and (mode == TIP_ONLY or mode == PROXIMAL_TIP or mode == SLIPPED)


@entry
def tip_path_start(dx, dy, mode, t1, t2, finger, solver, effects):
    """(on_tip, t1, t2, k1) where the finger's tip path began (model-notes D29), its closing up to
    there being the rigid sweep then the distal closing, and the proximal contact it had there.
    on_tip False: the finger held where it first struck, so the path D14 rebuilds from its final
    angles is its own. The same calls as solve_finger's (same bits): the first contact, and, when
    the contact first slid along the distal link, that edge path's end (the contact at the tip)."""
    if not took_tip_path(mode, effects.tip_contact):
        return False, t1, t2, 0.0
    first = closing_contact(dx, dy, finger, closing_constants(finger), effects)
    if first.t1 == t1 and first.t2 == t2:  # a strike that held
        return False, t1, t2, 0.0
    if first.mode == TIP_ON_LOWER_STOP or first.mode == TIP_ON_PROXIMAL_STOP:
        return True, first.t1, first.t2, 0.0
    if first.mode == PROXIMAL_THEN_TIP:
        return True, first.t1, first.t2, first.k1
    # the contact slid along the distal link to the tip first (reconfigure, then past_the_tip)
    _, t1e, _, _ = follow_path(dx, dy, first.t1, 0.0, finger, solver, effects.joint_springs,
                               EDGE_PATH)
    t2e, _ = distal_tangency(dx, dy, t1e, finger.l1, finger.r)
    return True, t1e, t2e, 0.0


@entry
def finger_effects(effects, tension):
    """A finger's effect blocks: the springs act per unit of that finger's tendon tension
    (records.JointSprings), as in `maps.compute_map`'s per-side blocks."""
    springs = effects.joint_springs
    if not springs.on:
        return effects
    return with_joint_springs(effects, JointSprings(True, springs.k1, springs.k2, tension))
