"""One finger: which configuration it reaches and what it exerts (MODEL 4, 5, 6).

Split in two so the sweep can reuse work: `closing_contact` depends on geometry only
(l1, l2, r, joint limits); `settle` adds the stick-slip decisions and the reconfiguration path,
which depend on the pulley radii and friction. `solve_finger` is both in sequence.

Right-finger frame throughout (`d = p - J`); the left finger calls the same code with `d` mirrored.
Parameters come as records (`kernels.records`): `finger` is a FingerModel, `solver` the
SolverSettings; a finger's configuration is a FingerState. Nothing here raises.
"""
import math

from numba import njit

from ..model import DISTAL_ONLY, FREE, PROXIMAL_ONLY, RANGE_TOL, SLIPPED, TWO_PHALANX, VERTEX
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
from .records import FingerState, FingerStatics

# Internal modes of a first contact that still has to be settled (never stored).
OVERLAP = -1                   # the part overlaps the joint: the point is infeasible
DISTAL_ON_LOWER_STOP = 6       # distal-only first contact of the rigid sweep (t2 = theta2_min)
DISTAL_ON_PROXIMAL_STOP = 7    # distal-only contact with the proximal folded at t1 = pi

# Events along the reconfiguration path (bit mask), in tie-break priority order (model-notes D4).
STICK, DISTAL_STOP, PROXIMAL_STOP, SLIP = 1, 2, 4, 8
MAX_PATH_STEPS = 10_000_000  # defence in depth: the edge refuses steps below 1e-6 rad


# ---------------------------------------------------------------------------------------------
# Statics (MODEL 5.2, 5.3): everything is decided with g = k1 k2 F1 / F, finite at k -> 0.
# `multiplier` is a tangential multiplier mu (|mu| <= mu_s); mu_s is the friction coefficient.
# ---------------------------------------------------------------------------------------------
@njit(cache=True)
def joint_torques(t1, t2, finger, springs):
    """Net closing torques of the joints per unit tendon tension (MODEL 5.1, 6): (r1, r2) in the
    paper's model; with the joint_springs effect the springs' K_i (t_i - theta_io) / F are
    taken off (theta1_o = 0, theta2_o = theta2_min). `springs` is None or a JointSprings record;
    the edge keeps both positive over the joint ranges (the tendon still closes the finger)."""
    if springs is None:
        return finger.r1, finger.r2
    return (finger.r1 - springs.k1 / springs.tension * t1,
            finger.r2 - springs.k2 / springs.tension * (t2 - finger.theta2_min))


@njit(cache=True)
def proximal_torque_balance(k2, t1, t2, finger, springs, multiplier):
    """g(mu) = tau1 k2 - tau2 (l1 cos t2 + k2) + mu tau2 l1 sin t2 (MODEL 5.3), for a given
    multiplier; tau = joint_torques (r1, r2 without springs)."""
    tau1, tau2 = joint_torques(t1, t2, finger, springs)
    return (tau1 * k2 - tau2 * (finger.l1 * math.cos(t2) + k2)
            + multiplier * tau2 * finger.l1 * math.sin(t2))


@njit(cache=True)
def friction_for_sticking(t2, mu_s):
    """The multiplier in [-mu_s, mu_s] that maximises g: friction opposing the slip."""
    s = math.sin(t2)
    if s > 0.0:
        return mu_s
    if s < 0.0:
        return -mu_s
    return 0.0


@njit(cache=True)
def max_torque_balance(k2, t1, t2, finger, springs):
    """max over |mu| <= mu_s of g(mu): >= 0 means the finger can stick (tau2 > 0, so the
    maximising multiplier has the sign of sin t2 with or without springs)."""
    return proximal_torque_balance(k2, t1, t2, finger, springs,
                                   friction_for_sticking(t2, finger.mu_s))


@njit(cache=True)
def distal_lever(k2, t2, l1, multiplier):
    """Moment arm (per unit normal force) of a distal contact about the proximal joint."""
    return l1 * math.cos(t2) + k2 - multiplier * l1 * math.sin(t2)


@njit(cache=True)
def sticks_on_lower_stop(k2, t1, t2, finger, springs):
    """MODEL 5.3 (revised 2026-11-22): a distal-only contact with the distal on its lower stop
    holds iff SOME |mu| <= mu_s gives both g(mu) >= 0 (the stop supplies closing torque) and a
    positive lever L(mu). Since g(mu) = r1 k2 - r2 L(mu), that asks for L(mu) in (0, r1 k2 / r2];
    L(0) = l1 cos t2 + k2 > 0 on the lower stop, so the set is not empty iff k2 > 0 and the
    multiplier that maximises g (minimises L) gives g >= 0. Testing L > 0 at that multiplier
    alone (the first rule) fails for mu_s > cot|t2|, about 11.4 at -5 deg (model-notes D10)."""
    mu_best = friction_for_sticking(t2, finger.mu_s)
    if proximal_torque_balance(k2, t1, t2, finger, springs, mu_best) < 0.0:
        return False  # no multiplier gives g >= 0
    return k2 > 0.0


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
        return distal_closes_after_proximal(dx, dy, t1, k1, finger)

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
        mode = VERTEX
        k1_out = l1
        k2_out = 0.0
    rho_t = math.sqrt(l1 * l1 + l2 * l2 + 2.0 * l1 * l2 * math.cos(theta2_min))
    delta_t = math.atan2(l2 * math.sin(theta2_min), l1 + l2 * math.cos(theta2_min))
    t_t = vertex_entry(dx, dy, rho_t, delta_t, r)
    if in_range(t_t, 0.0, math.pi) and t_t < best_t1 - RANGE_TOL:
        best_t1 = t_t
        mode = VERTEX
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
        return FingerState(VERTEX, t1, clamp(t2_tip, theta2_min, theta2_max), 0.0, l2, False)
    return FingerState(FREE, t1, theta2_max, 0.0, 0.0, False)


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
def distal_closes_after_proximal(dx, dy, t1, k1, finger):
    """MODEL 4.3: after a proximal contact the distal closes about B with t1 fixed."""
    t2, k2 = distal_tangency(dx, dy, t1, finger.l1, finger.r)
    if k2 <= finger.l2 + RANGE_TOL and in_range(t2, finger.theta2_min, finger.theta2_max):
        return FingerState(TWO_PHALANX, t1, clamp(t2, finger.theta2_min, finger.theta2_max), k1,
                           clamp(k2, 0.0, finger.l2), False)
    # The distal reaches its limit; the paper keeps this answer even if the tip passes through
    # the part on the way, which is flagged (MODEL 4.3, model-notes D3).
    t2_tip = tip_entry_about_distal_joint(dx, dy, t1, finger.l1, finger.l2, finger.r)
    return FingerState(PROXIMAL_ONLY, t1, finger.theta2_max, k1, 0.0,
                       in_range(t2_tip, finger.theta2_min, finger.theta2_max))


# ---------------------------------------------------------------------------------------------
# Stick-slip and reconfiguration (MODEL 5)
# ---------------------------------------------------------------------------------------------
@njit(cache=True)
def path_events(t1, t2, k2, finger, springs):
    """Bit mask of the reconfiguration events that hold at a state of the path (model-notes D4)."""
    events = 0
    if max_torque_balance(k2, t1, t2, finger, springs) >= 0.0:
        events |= STICK
    if t2 >= finger.theta2_max - RANGE_TOL:
        events |= DISTAL_STOP
    if t1 <= 0.0:
        events |= PROXIMAL_STOP
    if k2 > finger.l2 + RANGE_TOL:
        events |= SLIP
    return events


@njit(cache=True)
def path_event_mask_at(t1, dx, dy, finger, springs):
    t2, k2 = distal_tangency(dx, dy, t1, finger.l1, finger.r)
    return path_events(t1, t2, k2, finger, springs)


@njit(cache=True)
def event_margin(event, t1, dx, dy, finger, springs):
    """(holds, margin) of one path event at t1; the margin is continuous in t1 and >= 0 where
    the event holds, so a bracketing root finder can interpolate it."""
    t2, k2 = distal_tangency(dx, dy, t1, finger.l1, finger.r)
    holds = (path_events(t1, t2, k2, finger, springs) & event) != 0
    if event == STICK:
        margin = max_torque_balance(k2, t1, t2, finger, springs)
    elif event == DISTAL_STOP:
        margin = t2 - (finger.theta2_max - RANGE_TOL)
    else:  # SLIP
        margin = k2 - (finger.l2 + RANGE_TOL)
    return holds, margin


@njit(cache=True)
def event_crossing(event, lo, hi, dx, dy, finger, springs, root_tol):
    """Where an event starts along the path: it holds at lo, not at hi (lo < hi).

    Safeguarded Illinois regula falsi on the event margin: every probe lies at least root_tol/2
    inside the bracket and every fourth is a bisection, so the bracket shrinks to root_tol in a
    handful of evaluations. Returns the lo end, where the event holds (model-notes D4).
    """
    if event == PROXIMAL_STOP:
        return 0.0
    _, f_lo = event_margin(event, lo, dx, dy, finger, springs)
    _, f_hi = event_margin(event, hi, dx, dy, finger, springs)
    kept = 0  # +1: lo kept moving, -1: hi kept moving (Illinois halves the stale end)
    for it in range(400):  # bounded: at worst every fourth probe halves the bracket
        width = hi - lo
        if width <= root_tol:
            break
        x = 0.5 * (lo + hi)
        if it % 4 != 3 and f_lo != f_hi:
            x = hi - f_hi * width / (f_hi - f_lo)
            x = min(max(x, lo + 0.5 * root_tol), hi - 0.5 * root_tol)
        holds, f_x = event_margin(event, x, dx, dy, finger, springs)
        if holds:
            lo = x
            f_lo = f_x
            if kept == 1:
                f_hi *= 0.5
            kept = 1
        else:
            hi = x
            f_hi = f_x
            if kept == -1:
                f_lo *= 0.5
            kept = -1
    return lo


@njit(cache=True)
def reconfigure(dx, dy, t1_start, finger, solver, effects):
    """MODEL 5.3: slide the distal contact toward the tip while t1 decreases, until an event.

    Returns a FingerState with mode DISTAL_ONLY (stuck, or on a joint stop) or SLIPPED.
    """
    step = solver.reconfig_step
    hi = t1_start
    lo = t1_start
    events = 0
    # Bounded in floating point before converting (no int overflow for any step: Numba's
    # math.ceil returns int64, which overflowed for t1 / step > 9.2e18 and skipped the path; found
    # by running the tests under NUMBA_DISABLE_JIT=1). The last node is t1 = 0, where the proximal
    # stop always holds, so the loop always ends on an event.
    n_max = int(math.ceil(min(t1_start / step, float(MAX_PATH_STEPS)))) + 1
    for n in range(1, n_max + 1):
        lo = t1_start - n * step
        if lo <= 0.0 or n == n_max:
            lo = 0.0
        events = path_event_mask_at(lo, dx, dy, finger, effects.joint_springs)
        if events != 0:
            break
        hi = lo
    best_t1 = -1.0
    best_event = PROXIMAL_STOP
    for event in (STICK, DISTAL_STOP, PROXIMAL_STOP, SLIP):  # priority order for exact ties
        if events & event:
            t_cross = event_crossing(event, lo, hi, dx, dy, finger, effects.joint_springs,
                                     solver.root_tol)
            if t_cross > best_t1:
                best_t1 = t_cross
                best_event = event
    if best_t1 < 0.0:  # unreachable (t1 = 0 is always an event); keep a defined answer
        best_t1 = 0.0
    t2, k2 = distal_tangency(dx, dy, best_t1, finger.l1, finger.r)
    if best_event == SLIP:
        return FingerState(SLIPPED, best_t1, t2, 0.0, k2, False)
    # the bracket end may lie past the distal stop by up to root_tol: report the stop itself
    return FingerState(DISTAL_ONLY, best_t1, min(t2, finger.theta2_max), 0.0, k2, False)


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
    n = 0
    if state.t1 <= RANGE_TOL or state.t1 >= math.pi - RANGE_TOL:
        n += 1
    if state.t2 <= finger.theta2_min + RANGE_TOL or state.t2 >= finger.theta2_max - RANGE_TOL:
        n += 1
    return n


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
