"""One finger: which configuration it reaches and what it exerts (MODEL 4, 5, 6).

Split in two: `closing_contact` depends on geometry only (l1, l2, r, joint limits); `settle`
adds the stick-slip decisions and the paths of `kernels.path`, which depend on the pulley radii and
friction. `solve_finger` is both in sequence. With the tip_contact effect (model-notes D15) a
vertex strike is settled too (`settle_vertex`), by the statics of `kernels.statics`.

Right-finger frame throughout (`d = p - J`); the left finger calls the same code with `d` mirrored.
Parameters come as records (`kernels.records`): `finger` is a FingerModel, `solver` the
SolverSettings; a finger's configuration is a FingerState. Nothing here raises.
"""
import math

from numba import njit

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
from .geometry import (
    clamp,
    distal_tangency,
    in_range,
    proximal_tangency,
    rigid_distal_tangency,
    tangent_length,
    vertex_entry,
    wrap_angle,
)
from .path import (DISTAL_STOP, EXACT_TOL, PROXIMAL_STOP, SLIP, event_crossing, follow_path,
                   proximal_link_gap, tip_columns, tip_event_margin, tip_on_disc, tip_polar)
from .records import FingerState, FingerStatics
from .statics import (
    BALANCE_NEGATIVE,
    BALANCE_POSITIVE,
    at_limit,
    combine_balance,
    distal_lever,
    joint_torques,
    max_torque_balance,
    proximal_torque_balance,
    sticks_on_lower_stop,
    stop_balance,
    vertex_contact_holds,
)

# Internal modes of a first contact that still has to be settled (never stored).
OVERLAP = -1                   # the part overlaps the joint: the point is infeasible
DISTAL_ON_LOWER_STOP = 16      # distal-only first contact of the rigid sweep (t2 = theta2_min)
DISTAL_ON_PROXIMAL_STOP = 17   # distal-only contact with the proximal folded at t1 = pi
# Vertex strikes, only with tip_contact (D15; without it they are VERTEX):
JOINT_STRIKE = 18              # B strikes the part in the rigid sweep
TIP_ON_LOWER_STOP = 19         # T strikes in the rigid sweep (t2 = theta2_min)
TIP_ON_PROXIMAL_STOP = 20      # T strikes as the distal closes with t1 = pi
PROXIMAL_THEN_TIP = 21         # T strikes as the distal closes after a proximal contact


# ---------------------------------------------------------------------------------------------
# Closing sequence (MODEL 4): geometry only
# ---------------------------------------------------------------------------------------------
@njit(cache=True)
def closing_contact(dx, dy, finger, effects):
    """First contact of the closing sequence, as a FingerState whose mode is FREE,
    PROXIMAL_ONLY, TWO_PHALANX (not yet checked for stick-slip), VERTEX, DISTAL_ON_LOWER_STOP,
    DISTAL_ON_PROXIMAL_STOP, or OVERLAP (part overlaps the joint)."""
    l1 = finger.l1
    l2 = finger.l2
    r = finger.r
    theta2_min = finger.theta2_min
    theta2_max = finger.theta2_max
    if tangent_length(dx * dx + dy * dy, r) < 0.0:
        return FingerState(OVERLAP, 0.0, 0.0, 0.0, 0.0, False)

    # Rigid sweep, proximal tangency first (provably the earliest event when valid).
    t1, k1 = proximal_tangency(dx, dy, r)
    if k1 <= l1 + RANGE_TOL and in_range(t1, 0.0, math.pi):
        t1 = clamp(t1, 0.0, math.pi)
        k1 = clamp(k1, 0.0, l1)
        return distal_closes_after_proximal(dx, dy, t1, k1, finger, effects.tip_contact)

    # Otherwise the earliest of: distal tangency (3.3), a strike of B, a strike of T.
    best_t1 = math.inf
    mode = FREE
    k1_out = 0.0
    k2_out = 0.0
    t1c, k2c = rigid_distal_tangency(dx, dy, l1, r, theta2_min)
    if k2c >= -RANGE_TOL and k2c <= l2 + RANGE_TOL and in_range(t1c, 0.0, math.pi):
        best_t1 = t1c
        mode = DISTAL_ON_LOWER_STOP
        k2_out = clamp(k2c, 0.0, l2)
    # A vertex wins only if strictly earlier: at a tie the tangency covers the link's end.
    t_b = vertex_entry(dx, dy, l1, 0.0, r)
    if in_range(t_b, 0.0, math.pi) and t_b < best_t1 - RANGE_TOL:
        best_t1 = t_b
        mode = strike_mode(effects.tip_contact, JOINT_STRIKE)
        k1_out = l1
        k2_out = 0.0
    rho_t, delta_t = tip_polar(theta2_min, l1, l2)
    t_t = vertex_entry(dx, dy, rho_t, delta_t, r)
    if in_range(t_t, 0.0, math.pi) and t_t < best_t1 - RANGE_TOL:
        best_t1 = t_t
        mode = strike_mode(effects.tip_contact, TIP_ON_LOWER_STOP)
        k1_out = 0.0
        k2_out = l2
    if mode != FREE:
        return FingerState(mode, clamp(best_t1, 0.0, math.pi), theta2_min, k1_out, k2_out, False)

    # No event before the proximal stop: the distal closes about B with t1 = pi.
    t1 = math.pi
    t2, k2 = distal_tangency(dx, dy, t1, l1, r)
    if k2 <= l2 + RANGE_TOL and in_range(t2, theta2_min, theta2_max):
        return FingerState(DISTAL_ON_PROXIMAL_STOP, t1, clamp(t2, theta2_min, theta2_max), 0.0,
                           clamp(k2, 0.0, l2), False)
    t2_tip = tip_entry_about_distal_joint(dx, dy, t1, l1, l2, r)
    if in_range(t2_tip, theta2_min, theta2_max):
        return FingerState(strike_mode(effects.tip_contact, TIP_ON_PROXIMAL_STOP), t1,
                           clamp(t2_tip, theta2_min, theta2_max), 0.0, l2, False)
    return FingerState(FREE, t1, theta2_max, 0.0, 0.0, False)


@njit(cache=True)
def strike_mode(tip, strike):
    """The mode of a vertex strike: VERTEX in the paper's model (tip None), else the strike's
    own internal mode, settled by settle_vertex (D15)."""
    if tip is None:
        return VERTEX
    return strike


@njit(cache=True)
def tip_entry_about_distal_joint(dx, dy, t1, l1, l2, r):
    """Relative angle t2 at which the tip, turning about B with t1 fixed, enters the disc (inf:
    never)."""
    ex = dx - l1 * math.cos(t1)
    ey = dy - l1 * math.sin(t1)
    phi = vertex_entry(ex, ey, l2, 0.0, r)
    if phi == math.inf:
        return math.inf
    return wrap_angle(phi - t1)


@njit(cache=True)
def distal_closes_after_proximal(dx, dy, t1, k1, finger, tip):
    """MODEL 4.3: after a proximal contact the distal closes about B with t1 fixed. If the tip
    strikes the part on the way, the paper's answer is kept and flagged (tip None) or the tip
    is a contact (tip_contact, D15)."""
    t2, k2 = distal_tangency(dx, dy, t1, finger.l1, finger.r)
    if k2 <= finger.l2 + RANGE_TOL and in_range(t2, finger.theta2_min, finger.theta2_max):
        return FingerState(TWO_PHALANX, t1, clamp(t2, finger.theta2_min, finger.theta2_max), k1,
                           clamp(k2, 0.0, finger.l2), False)
    # The distal reaches its limit; the paper keeps this answer even if the tip passes through
    # the part on the way, which is flagged (MODEL 4.3, model-notes D3).
    t2_tip = tip_entry_about_distal_joint(dx, dy, t1, finger.l1, finger.l2, finger.r)
    strikes = in_range(t2_tip, finger.theta2_min, finger.theta2_max)
    if tip is not None and strikes:
        return FingerState(PROXIMAL_THEN_TIP, t1, clamp(t2_tip, finger.theta2_min,
                                                        finger.theta2_max), k1, finger.l2, False)
    return FingerState(PROXIMAL_ONLY, t1, finger.theta2_max, k1, 0.0, strikes)


# ---------------------------------------------------------------------------------------------
# Stick-slip and reconfiguration (MODEL 5)
# ---------------------------------------------------------------------------------------------
@njit(cache=True)
def reconfigure(dx, dy, t1_start, finger, solver, effects):
    """MODEL 5.3: slide the distal contact toward the tip while t1 decreases, until an event
    (the edge path of kernels.path).

    Returns a FingerState with mode DISTAL_ONLY (stuck, or on a joint stop) or SLIPPED; with
    tip_contact, a contact that passes the tip is taken over by the tip (D15).
    """
    event, t1, _, _ = follow_path(dx, dy, t1_start, 0.0, finger, solver, effects.joint_springs,
                               None)
    t2, k2 = distal_tangency(dx, dy, t1, finger.l1, finger.r)
    if event == SLIP:
        return past_the_tip(effects.tip_contact, dx, dy, t1, t2, k2, finger, solver,
                            effects.joint_springs)
    # the bracket end may lie past the distal stop by up to root_tol: report the stop itself
    return FingerState(DISTAL_ONLY, t1, min(t2, finger.theta2_max), 0.0, k2, False)


@njit(cache=True)
def past_the_tip(tip, dx, dy, t1, t2, k2, finger, solver, springs):
    """The distal contact has slid to the tip: the part is lost (SLIPPED, the paper's ejection)
    or, with tip_contact, the finger follows the tip on the disc (D15)."""
    if tip is None:
        return FingerState(SLIPPED, t1, t2, 0.0, k2, False)
    return tip_path(dx, dy, t2, finger, solver, springs, tip)


@njit(cache=True)
def tip_path(dx, dy, t2_start, finger, solver, springs, tip):
    """D15: the tip stays on the disc while the distal closes (t2 increases from t2_start, t1
    follows), until it can hold (TIP_ONLY), a joint stop (TIP_ONLY on the stop), the proximal
    link reaches the part (PROXIMAL_TIP, resting on it as on a stop, D21) or the part is lost
    (SLIPPED, where the tip last touched)."""
    event, s, s_touching, s_free = follow_path(dx, dy, -t2_start, -finger.theta2_max, finger,
                                               solver, springs, tip)
    if event == SLIP:
        s = s_touching
    if event != PROXIMAL_STOP and tip_event_margin(PROXIMAL_STOP, s, dx, dy, finger, springs)[0]:
        # the proximal stop (or the part, D21) was passed within the last step, unseen at its
        # nodes (a coarse reconfig_step): the path ends where it is first met (D19)
        s, _ = event_crossing(PROXIMAL_STOP, s, s_free, dx, dy, finger, springs,
                              min(solver.root_tol, EXACT_TOL), tip)
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


@njit(cache=True)
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


@njit(cache=True)
def settle_vertex(tip, first, dx, dy, finger, solver, effects):
    """D15: settle a vertex strike (tip_contact only; without it a strike stays VERTEX)."""
    if tip is None:
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
    return tip_path(dx, dy, first.t2, finger, solver, effects.joint_springs, tip)


@njit(cache=True)
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


@njit(cache=True)
def solve_finger(dx, dy, finger, solver, effects):
    """The finger's equilibrium configuration (FingerState); mode OVERLAP (-1) means the part
    overlaps the joint (infeasible point). tip_overlap is decided by the closing sequence.
    `effects` is an EffectBlocks record (records.NO_EFFECTS: the paper's model)."""
    first = closing_contact(dx, dy, finger, effects)
    final = settle(first, dx, dy, finger, solver, effects)
    return FingerState(final.mode, final.t1, final.t2, final.k1, final.k2, first.tip_overlap)


# ---------------------------------------------------------------------------------------------
# Energy (MODEL 6) and contact forces (MODEL 5.1, 5.6)
# ---------------------------------------------------------------------------------------------
@njit(cache=True)
def finger_energy(t1, t2, r1, r2, tension, theta2_min):
    """V = -F [r1 (t1 - theta1_o) + r2 (t2 - theta2_o)] with theta1_o = 0, theta2_o = theta2_min."""
    return -tension * (r1 * t1 + r2 * (t2 - theta2_min))


@njit(cache=True)
def spring_energy(t1, t2, springs, theta2_min):
    """Energy stored in the joint springs, 1/2 K1 t1^2 + 1/2 K2 (t2 - theta2_min)^2: the
    potential of the torques K_i (t_i - theta_io) (MODEL 6, 9; model-notes D13); 0 when off."""
    if springs is None:
        return 0.0
    return 0.5 * springs.k1 * t1 * t1 + 0.5 * springs.k2 * (t2 - theta2_min) ** 2


@njit(cache=True)
def contact_count(mode):
    """Tangent contacts a finger's final mode has with the part (MODEL 7)."""
    if mode == TWO_PHALANX:
        return 2
    if mode == PROXIMAL_ONLY or mode == DISTAL_ONLY:
        return 1
    return 0


@njit(cache=True)
def joints_on_limits(state, finger):
    """How many of the finger's joints rest on a limit (each may carry a stop torque)."""
    lower1, upper1 = at_limit(state.t1, 0.0, math.pi)
    lower2, upper2 = at_limit(state.t2, finger.theta2_min, finger.theta2_max)
    return int(lower1 or upper1) + int(lower2 or upper2)


@njit(cache=True)
def normal_forces(state, finger):
    """(F1, F2, mu2) per unit tension (MODEL 5.6): normal forces and the distal multiplier.

    mu2 is the least |multiplier| for which the finger's statics hold with every joint-stop torque
    of an admissible sign; the proximal contact's friction exerts no torque and is reported as 0.
    A contact exactly at a joint (k -> 0) carries no determinate force and is reported as 0.
    """
    mode = state.mode
    t1 = state.t1
    t2 = state.t2
    k1 = state.k1
    k2 = state.k2
    l1 = finger.l1
    r1 = finger.r1
    r2 = finger.r2
    mu_s = finger.mu_s
    if mode == PROXIMAL_ONLY:
        if k1 <= RANGE_TOL:
            return 0.0, 0.0, 0.0
        return r1 / k1, 0.0, 0.0
    if mode == TWO_PHALANX:
        if k2 <= RANGE_TOL:
            return 0.0, 0.0, 0.0
        g0 = proximal_torque_balance(k2, t1, t2, finger, None, 0.0)
        mu2 = 0.0
        if g0 < 0.0 and math.sin(t2) != 0.0:
            mu2 = clamp(-g0 / (r2 * l1 * math.sin(t2)), -mu_s, mu_s)
        f2 = r2 / k2
        f1 = 0.0
        if k1 > RANGE_TOL:
            f1 = max(proximal_torque_balance(k2, t1, t2, finger, None, mu2) / (k1 * k2), 0.0)
        return f1, f2, mu2
    if mode == DISTAL_ONLY:
        if k2 <= RANGE_TOL:
            return 0.0, 0.0, 0.0
        g0 = proximal_torque_balance(k2, t1, t2, finger, None, 0.0)
        s = math.sin(t2)
        if t2 <= finger.theta2_min + RANGE_TOL:
            # On the distal lower stop: stop torque >= 0 needs g(mu) >= 0; the proximal balance
            # gives F2.
            mu2 = 0.0
            if g0 < 0.0 and s != 0.0:
                mu2 = clamp(-g0 / (r2 * l1 * s), -mu_s, mu_s)
            return 0.0, r1 / distal_lever(k2, t2, l1, mu2), mu2
        if t2 >= finger.theta2_max - RANGE_TOL:
            # On the distal upper stop: stop torque <= 0 needs g(mu) <= 0, true for mu = 0 here.
            return 0.0, r1 / distal_lever(k2, t2, l1, 0.0), 0.0
        if t1 <= RANGE_TOL or t1 >= math.pi - RANGE_TOL:
            # On a proximal stop, which takes the imbalance -g(mu)/k2 per unit tension: the lower
            # stop (t1 = 0) only pushes closed, needing g(mu) <= 0; the upper (t1 = pi) only
            # opens, needing g(mu) >= 0. Least |mu| with the right sign of g.
            mu2 = 0.0
            if s != 0.0 and ((t1 <= RANGE_TOL and g0 > 0.0) or (t1 > RANGE_TOL and g0 < 0.0)):
                mu2 = clamp(-g0 / (r2 * l1 * s), -mu_s, mu_s)
            return 0.0, r2 / k2, mu2
        # Stuck between stops: g(mu) = 0 fixes the multiplier.
        mu2 = 0.0
        if s != 0.0:
            mu2 = clamp(-g0 / (r2 * l1 * s), -mu_s, mu_s)
        return 0.0, r2 / k2, mu2
    return 0.0, 0.0, 0.0


@njit(cache=True)
def finger_statics(state, finger):
    """Contact forces of a settled finger on the part per unit tension (MODEL 5.1, 5.6), with
    the resultant in the finger's own frame.

    Determined (model-notes D9) iff the finger is in a static mode (free, proximal-only,
    two-phalanx, distal-only), no contact sits exactly at a joint, and its contacts plus the joints
    resting on a limit are at most two: each joint gives one equation (MODEL 5.1), each contact
    one unknown normal force and each engaged stop one unknown torque.
    """
    mode = state.mode
    f1, f2, mu2 = normal_forces(state, finger)
    n_contacts = contact_count(mode)
    proximal = mode == PROXIMAL_ONLY or mode == TWO_PHALANX
    distal = mode == TWO_PHALANX or mode == DISTAL_ONLY
    at_joint = (proximal and state.k1 <= RANGE_TOL) or (distal and state.k2 <= RANGE_TOL)
    determined = mode == FREE or (
        n_contacts > 0 and not at_joint and n_contacts + joints_on_limits(state, finger) <= 2)
    # a_y = (-sin t1, cos t1); b_y = (-sin phi, cos phi); the distal tangent rot90(b_y) = -b_x
    phi = state.t1 + state.t2
    fx = -f1 * math.sin(state.t1) + f2 * (-math.sin(phi) - mu2 * math.cos(phi))
    fy = f1 * math.cos(state.t1) + f2 * (math.cos(phi) - mu2 * math.sin(phi))
    return FingerStatics(f1, f2, mu2, fx, fy, determined)
