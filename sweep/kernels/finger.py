"""One finger's mechanics (MODEL 3-6): contact geometry, statics, the paths of a finger that
cannot hold, and the closing sequence that settles it. One module, four parts in reading order:

1. Geometry. Closed-form contact geometry of one finger (MODEL 3) and vertex strikes (MODEL 4).
   Functions return `math.inf` / a negative length for "no such contact" instead of raising, so
   they can run inside parallel loops on any input.
2. Statics. A finger's statics in joint-torque space (MODEL 5.1): what the joints must carry, and
   whether a vertex contact with the finger's other contacts and stops can carry it (model-notes
   D15). Torques are per unit tendon tension. A contact force `F (n + mu t)` at finger point `c`
   adds `F (c_n + mu c_t)` to the joints' balance, with `c_n = (c x n, (c - B) x n)` (the second
   entry only for a contact on the distal link) and likewise `c_t` for the tangent `t`. The finger
   holds iff the tendon's torques `tau` equal such a contact term plus what its other contacts and
   engaged stops can supply, each of a fixed sign in one joint.
3. Paths. The paths a finger follows when its first contact cannot hold (MODEL 5.3, model-notes
   D4, D15). Two paths, one stepping-and-bracketing routine: along each, t1 decreases from its
   start and the first event met wins.
   - The *edge path* (MODEL 5.3): the distal link stays tangent to the part (3.2 at each t1) and
     its contact slides toward the tip. Events: stick (gmax >= 0), distal stop, proximal stop,
     slip (the contact passes the tip).
   - The *tip path* (tip_contact, D15): the tip stays on the part; at each t1 the distal closes
     about B until the tip meets the disc. Events: stick (gtip >= 0), distal stop, proximal stop,
     lost (the tip no longer meets the disc, or the tendon pulls it off).
   `on_tip_path` says which: False for the edge path, True for the tip path.
4. The finger: which configuration it reaches and what it exerts (MODEL 4, 5, 6), in two steps:
   `closing_contact` depends on geometry only (l1, l2, r, joint limits); `settle` adds the
   stick-slip decisions and the paths, which depend on the pulley radii and friction.
   `solve_finger` is both in sequence. With the tip_contact effect (model-notes D15) a vertex
   strike is settled too (`settle_vertex`), by the statics.

Right-finger frame throughout: origin at its proximal joint J, `d = p - J`; the left finger calls
the same code with `d` mirrored. Parameters come as records (`kernels.records`): `finger` is a
FingerModel, `solver` the SolverSettings; a finger's configuration is a FingerState. Nothing here
raises.
"""
import math

import numpy as np

from .jit import entry, inner
from ..model import (
    DISTAL_ONLY,
    FREE,
    PROXIMAL_ONLY,
    PROXIMAL_TIP,
    RANGE_TOL,
    SLIPPED,
    TIP_ONLY,
    TOUCH_REL,
    TWO_PHALANX,
    VERTEX,
)
from .records import FingerState, FingerStatics, JointSprings


# =================================================================================================
# Geometry (MODEL 3, 4)
# =================================================================================================

NO_ANGLE = math.inf
EPS = 2.0 ** -52  # float64 machine epsilon (the round-off of tangencies, tangency_slack)


@inner
def wrap_angle(a):
    """Wrap into (-pi, pi]."""
    if -math.pi < a <= math.pi:
        return a
    return a - 2.0 * math.pi * math.ceil((a - math.pi) / (2.0 * math.pi))


@inner
def tangent_length(dist2, r):
    """Length of the tangent from a point at squared distance dist2 to a disc of radius r.

    Returns -1.0 if the point is inside the disc; points within the MODEL 5.5 tolerance of the
    circle count as touching (length 0).
    """
    r2 = r * r
    if dist2 < r2 * (1.0 - TOUCH_REL):
        return -1.0
    return math.sqrt(max(dist2 - r2, 0.0))


@inner
def in_range(value, lower, upper):
    """Inclusive range check with the MODEL 5.5 slack."""
    return lower - RANGE_TOL <= value <= upper + RANGE_TOL


@inner
def clamp(value, lower, upper):
    return min(max(value, lower), upper)


@inner
def tangency_slack(k, dist2, r):
    """How far round-off can move the angle atan2(r, k) of a tangency (MODEL 5.5), plus
    RANGE_TOL. k = sqrt(dist2 - r^2) carries an absolute error of about eps dist2 / k (sqrt of
    eps dist2 once k^2 is below that): as the point nears the circle the tangent's angle is
    known only to about 1e-8 (a part touching the joint to round-off). Far from it this is
    RANGE_TOL to 1e-15."""
    delta = 4.0 * EPS * dist2
    dk = delta / (2.0 * k) if k * k > delta else math.sqrt(delta)
    return RANGE_TOL + dk * r / (r * r + k * k)


@inner
def rigid_sweep_offset(r, l1, theta2_min):
    """r' = r + l1 sin(-theta2_min): during the rigid sweep the distal link's line keeps this
    distance from the joint J, so its tangency to the part reads d . b_y = r' (MODEL 3.3)."""
    return r + l1 * math.sin(-theta2_min)


@inner
def tangent_length_error(k, delta):
    """Round-off of a tangent length k = sqrt(D - r^2) whose D carries an absolute error
    delta: delta / (2 k), and sqrt(delta) once k^2 is below delta."""
    return delta / (2.0 * k) if k * k > delta else math.sqrt(delta)


@inner
def rigid_tangency_slack(dx, dy, l1, r, theta2_min, k2):
    """(slack of k2, slack of t1) of MODEL 3.3's tangency: RANGE_TOL plus their round-off.
    K = k2 + l1 cos(theta2_min) = sqrt(|d|^2 - r'^2) comes through asin(r'/|d|), which near 1
    leaves K known only to about sqrt(eps) |d| and the angle to about K's error / r'. With
    theta2_min near -90 deg a tangency at k2 = 0 (the distal link tangent at B as B grazes
    the disc) is exactly there, and RANGE_TOL alone let round-off reject it (model-notes
    D30)."""
    dist2 = dx * dx + dy * dy
    r_eff = rigid_sweep_offset(r, l1, theta2_min)
    big = max(dist2, r_eff * r_eff)
    dk = (tangent_length_error(max(k2 + l1 * math.cos(theta2_min), 0.0), 8.0 * EPS * big)
          + 4.0 * EPS * (math.sqrt(dist2) + l1))
    return RANGE_TOL + dk, RANGE_TOL + dk / r_eff + 8.0 * EPS


@inner
def distal_tangency_slack(dx, dy, t1, l1, r, k2):
    """(slack of k2, slack of t2) of MODEL 3.2's tangency at a given t1: RANGE_TOL plus their
    round-off. e = d - B cancels, so its components carry about eps (|d| + l1) and |e|^2 about
    4 eps |e| (|d| + l1 + |e|); k2 and t2 then carry what tangency_slack says of such a
    tangent (model-notes D30)."""
    dist = math.sqrt(dx * dx + dy * dy)
    ex = dx - l1 * math.cos(t1)
    ey = dy - l1 * math.sin(t1)
    e = math.sqrt(ex * ex + ey * ey)
    err_e = 2.0 * EPS * (dist + l1)
    dk = tangent_length_error(k2, 2.0 * e * err_e + 4.0 * EPS * e * e)
    dt = err_e / max(e, r) + dk * r / (r * r + k2 * k2) + 8.0 * EPS * math.pi
    return RANGE_TOL + dk, RANGE_TOL + dt


@inner
def proximal_tangency(dx, dy, r):
    """MODEL 3.1: (t1, k1) of the proximal link tangent to the part; k1 < 0 if d is inside the
    disc."""
    k1 = tangent_length(dx * dx + dy * dy, r)
    if k1 < 0.0:
        return NO_ANGLE, -1.0
    return math.atan2(dy, dx) - math.atan2(r, k1), k1


@entry
def distal_tangency(dx, dy, t1, l1, r):
    """MODEL 3.2: (t2, k2) of the distal link tangent to the part, proximal fixed at t1.

    The first tangency met as the distal link turns about B from its lower limit upward. No range
    checks here (the caller decides validity). If the disc covers B, the tangent length is 0.
    """
    ex = dx - l1 * math.cos(t1)
    ey = dy - l1 * math.sin(t1)
    k2 = max(tangent_length(ex * ex + ey * ey, r), 0.0)
    t2 = wrap_angle(math.atan2(ey, ex) - math.atan2(r, k2) - t1)
    return t2, k2


@inner
def rigid_distal_tangency(dx, dy, l1, r, theta2_min):
    """MODEL 3.3: (t1, k2) of the distal link (held at theta2_min) tangent during the rigid sweep.

    Returns (inf, -1) if the distal line never reaches the part.
    """
    r_eff = rigid_sweep_offset(r, l1, theta2_min)
    dist2 = dx * dx + dy * dy
    if dist2 < r_eff * r_eff * (1.0 - TOUCH_REL):
        return NO_ANGLE, -1.0
    dist = math.sqrt(dist2)
    alpha = math.atan2(dy, dx)
    offset = math.asin(min(r_eff / dist, 1.0))  # alpha - phi
    phi = alpha - offset
    k2 = dist * math.cos(offset) - l1 * math.cos(theta2_min)
    return phi - theta2_min, k2


@entry
def vertex_entry(dx, dy, rho, delta, r):
    """MODEL 4: turning angle at which a vertex at radius rho, polar offset delta, enters the disc.

    The vertex turns counter-clockwise about the origin of (dx, dy). Returns inf if it never does,
    or only grazes the disc (model-notes D3).
    """
    c = entry_cosine(dx, dy, rho, r)
    if c >= 1.0 - RANGE_TOL or c < -1.0:  # a graze (c = 1) touches without entering
        return NO_ANGLE
    return math.atan2(dy, dx) - math.acos(c) - delta


@inner
def entry_cosine(dx, dy, rho, r):
    """MODEL 4's acos argument (rho^2 + |d|^2 - r^2) / (2 rho |d|) for a vertex at radius rho
    about the origin of (dx, dy); 2 (no entry) where it is undefined."""
    dist2 = dx * dx + dy * dy
    if dist2 <= 0.0 or rho <= 0.0:
        return 2.0
    dist = math.sqrt(dist2)
    return (rho * rho + dist2 - r * r) / (2.0 * rho * dist)


@inner
def joint_strike_angle(dx, dy, l1, r):
    """MODEL 4 (revised): the rigid sweep's angle at which B, turning about J, strikes the
    part. A graze of B counts (vertex_entry ignores it): a link attached to B enters the disc
    just after, the distal link when the disc is outside B's circle (it leaves B at
    theta2_min > -90 deg from the proximal, towards the centre) and the proximal link when it
    is inside. A graze is the acos argument within RANGE_TOL below 1 or within its own
    round-off above it (model-notes D30)."""
    t_b = vertex_entry(dx, dy, l1, 0.0, r)
    if t_b != NO_ANGLE:
        return t_b
    c = entry_cosine(dx, dy, l1, r)
    dist2 = dx * dx + dy * dy
    err_c = 4.0 * EPS * (l1 * l1 + dist2 + r * r) / (2.0 * l1 * math.sqrt(dist2))
    if c < 1.0 - RANGE_TOL or c > 1.0 + err_c:
        return NO_ANGLE
    return math.atan2(dy, dx) - math.acos(min(c, 1.0))

# =================================================================================================
# Statics (MODEL 5.1, model-notes D15)
# =================================================================================================

# What the rest of the finger can add to a joint's balance (the residual tau_i - contact_i):
# (NumPy integers: a kernel passing a Python int constant compiles its callee once per value:
# docs/architecture.md, "One compilation for every scene".)
BALANCE_EXACT = np.int64(0)      # nothing: the contact alone balances the joint
BALANCE_POSITIVE = np.int64(1)   # >= 0: a proximal edge contact, the proximal or distal upper stop
BALANCE_NEGATIVE = np.int64(-1)  # <= 0: the proximal or distal lower stop
BALANCE_FREE = np.int64(2)       # either sign (stops or contacts of both signs)


# ---------------------------------------------------------------------------------------------
# Tangent contacts (MODEL 5.2, 5.3): everything is decided with g = k1 k2 F1 / F, finite at k -> 0.
# `multiplier` is a tangential multiplier mu (|mu| <= mu_s); mu_s is the friction coefficient.
# ---------------------------------------------------------------------------------------------
@inner
def joint_torques(t1, t2, finger, springs):
    """Net closing torques of the joints per unit tendon tension (MODEL 5.1, 6): (r1, r2) in the
    paper's model; with the joint_springs effect the springs' K_i (t_i - theta_io) / F are
    taken off (theta1_o = 0, theta2_o = theta2_min). `springs` is a JointSprings record;
    the edge keeps both positive over the joint ranges (the tendon still closes the finger)."""
    if not springs.on:
        return finger.r1, finger.r2
    return (finger.r1 - springs.k1 / springs.tension * t1,
            finger.r2 - springs.k2 / springs.tension * (t2 - finger.theta2_min))


@inner
def proximal_torque_balance(k2, t1, t2, finger, springs, multiplier):
    """g(mu) = tau1 k2 - tau2 (l1 cos t2 + k2) + mu tau2 l1 sin t2 (MODEL 5.3), for a given
    multiplier; tau = joint_torques (r1, r2 without springs)."""
    tau1, tau2 = joint_torques(t1, t2, finger, springs)
    return (tau1 * k2 - tau2 * (finger.l1 * math.cos(t2) + k2)
            + multiplier * tau2 * finger.l1 * math.sin(t2))


@inner
def friction_for_sticking(t2, mu_s):
    """The multiplier in [-mu_s, mu_s] that maximises g: friction opposing the slip."""
    s = math.sin(t2)
    if s > 0.0:
        return mu_s
    if s < 0.0:
        return -mu_s
    return 0.0


@inner
def max_torque_balance(k2, t1, t2, finger, springs):
    """max over |mu| <= mu_s of g(mu): >= 0 means the finger can stick (tau2 > 0, so the
    maximising multiplier has the sign of sin t2 with or without springs)."""
    return proximal_torque_balance(k2, t1, t2, finger, springs,
                                   friction_for_sticking(t2, finger.mu_s))


@inner
def distal_lever(k2, t2, l1, multiplier):
    """Moment arm (per unit normal force) of a distal contact about the proximal joint."""
    return l1 * math.cos(t2) + k2 - multiplier * l1 * math.sin(t2)


@entry
def sticks_on_lower_stop(k2, t1, t2, finger, springs):
    """MODEL 5.3 (revised): a distal-only contact with the distal on its lower stop
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
# A vertex contact (tip_contact, model-notes D15): MODEL 5.1 as a small linear feasibility test
# ---------------------------------------------------------------------------------------------
@inner
def combine_balance(a, b):
    """The balance kind of a joint that has two suppliers of kinds a and b."""
    if a == BALANCE_EXACT:
        return b
    if b == BALANCE_EXACT or a == b:
        return a
    return BALANCE_FREE


@inner
def stop_balance(at_lower, at_upper, lower_kind, upper_kind):
    """The balance kind a joint's engaged stops supply."""
    kind = BALANCE_EXACT
    if at_lower:
        kind = combine_balance(kind, lower_kind)
    if at_upper:
        kind = combine_balance(kind, upper_kind)
    return kind


@inner
def _satisfies(f, g, tau1, tau2, cn1, cn2, ct1, ct2, mu_s, kind1, kind2):
    """Whether the contact term (F, G = F mu) satisfies every constraint, to round-off."""
    scale = abs(tau1) + abs(tau2) + (abs(f) + abs(g)) * (abs(cn1) + abs(cn2) + abs(ct1)
                                                         + abs(ct2)) + 1e-300
    tol = 1e-12 * scale
    if f < -tol or g - mu_s * f > tol * (1.0 + mu_s) or -g - mu_s * f > tol * (1.0 + mu_s):
        return False
    res1 = tau1 - f * cn1 - g * ct1
    res2 = tau2 - f * cn2 - g * ct2
    return _residual_ok(res1, kind1, tol) and _residual_ok(res2, kind2, tol)


@inner
def _residual_ok(res, kind, tol):
    if kind == BALANCE_FREE:
        return True
    if kind == BALANCE_POSITIVE:
        return res >= -tol
    if kind == BALANCE_NEGATIVE:
        return res <= tol
    return abs(res) <= tol


@inner
def vertex_contact_holds(tau1, tau2, cn1, cn2, ct1, ct2, mu_s, kind1, kind2):
    """MODEL 5.1 for a finger with one vertex contact (columns c_n, c_t) and, per joint, what the
    rest of the finger can supply (a BALANCE_* kind): is there F >= 0, |mu| <= mu_s with the
    residual tau - F (c_n + mu c_t) of the admissible sign in each joint?

    A linear feasibility problem in (F, G = F mu) inside the pointed cone |G| <= mu_s F: when
    feasible it has a vertex, the meeting point of two of its constraint lines, so testing those
    (at most 10) decides it exactly up to round-off.
    """
    # Constraint lines a1 F + a2 G = b: F = 0, G = mu_s F, G = -mu_s F, and one per joint whose
    # residual is bounded (tau_i - F cn_i - G ct_i = 0).
    a1 = (1.0, -mu_s, -mu_s, cn1, cn2)
    a2 = (0.0, 1.0, -1.0, ct1, ct2)
    b = (0.0, 0.0, 0.0, tau1, tau2)
    used1 = kind1 != BALANCE_FREE
    used2 = kind2 != BALANCE_FREE
    for p in range(5):
        if p >= 3 and ((p == 3 and not used1) or (p == 4 and not used2)):
            continue
        for q in range(p + 1, 5):
            if q >= 3 and ((q == 3 and not used1) or (q == 4 and not used2)):
                continue
            det = a1[p] * a2[q] - a2[p] * a1[q]
            if det == 0.0:
                continue
            f = (b[p] * a2[q] - a2[p] * b[q]) / det
            g = (a1[p] * b[q] - b[p] * a1[q]) / det
            if _satisfies(f, g, tau1, tau2, cn1, cn2, ct1, ct2, mu_s, kind1, kind2):
                return True
    return False


@inner
def vertex_columns(cx, cy, bx, by, nx, ny, on_distal):
    """(c_n, c_t) of a contact at finger point c with unit normal n (tangent rot90(n)): its
    moments about J and, on the distal link, about B (else 0)."""
    tx = -ny
    ty = nx
    cn1 = cx * ny - cy * nx
    ct1 = cx * ty - cy * tx
    cn2 = 0.0
    ct2 = 0.0
    if on_distal:
        cn2 = (cx - bx) * ny - (cy - by) * nx
        ct2 = (cx - bx) * ty - (cy - by) * tx
    return cn1, cn2, ct1, ct2


@inner
def unit_normal_to(dx, dy, cx, cy):
    """Unit vector from finger point c to the part centre d (a vertex contact's normal)."""
    ux = dx - cx
    uy = dy - cy
    norm = math.hypot(ux, uy)
    if norm <= 0.0:
        return 0.0, 0.0
    return ux / norm, uy / norm


@inner
def at_limit(value, lower, upper):
    """(at the lower limit, at the upper limit), inclusive with the MODEL 5.5 slack."""
    return value <= lower + RANGE_TOL, value >= upper - RANGE_TOL

# =================================================================================================
# Paths (MODEL 5.3, model-notes D4, D15)
# =================================================================================================

# Events along a path (bit mask), in tie-break priority order (model-notes D4). On the tip path
# SLIP is "lost": the tip no longer holds the part.
STICK, DISTAL_STOP, PROXIMAL_STOP, SLIP = np.int64(1), np.int64(2), np.int64(4), np.int64(8)
JOINT_STOPS = DISTAL_STOP | PROXIMAL_STOP
# Which path follow_path steps (its `on_tip_path`).
EDGE_PATH, TIP_PATH = np.bool_(False), np.bool_(True)
MAX_PATH_STEPS = 10_000_000  # defence in depth: the edge refuses steps below 1e-6 rad
# Bracket width of a path that ends on a joint stop, and of events that start within the same
# step, whatever root_tol (model-notes D4, D19): the state on a stop must satisfy the stop (a
# coarse bracket clamped onto it left a contact off the disc or a tip inside the part), and
# the order of two events is decided by where they start, not by the bracket's resolution (a
# stick and a slip tied at a coarse node reported a stuck contact past the tip).
EXACT_TOL = 1e-12


# ---------------------------------------------------------------------------------------------
# The edge path (MODEL 5.3)
# ---------------------------------------------------------------------------------------------
@inner
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


@inner
def edge_event_margin(event, t1, dx, dy, finger, springs):
    """(holds, margin) of one edge-path event at t1; the margin is continuous in t1 and >= 0
    where the event holds, so a bracketing root finder can interpolate it."""
    t2, k2 = distal_tangency(dx, dy, t1, finger.l1, finger.r)
    holds = (path_events(t1, t2, k2, finger, springs) & event) != 0
    if event == STICK:
        margin = max_torque_balance(k2, t1, t2, finger, springs)
    elif event == DISTAL_STOP:
        margin = t2 - (finger.theta2_max - RANGE_TOL)
    else:  # SLIP
        margin = k2 - (finger.l2 + RANGE_TOL)
    return holds, margin


# ---------------------------------------------------------------------------------------------
# The tip path (tip_contact, model-notes D15)
# ---------------------------------------------------------------------------------------------
@inner
def tip_on_disc(t2, dx, dy, finger):
    """The finger with its distal at t2 turns about J until the tip meets the disc (D15):
    (meets, c, t1), c being MODEL 4's acos argument for the tip (it meets the disc iff
    -1 <= c < 1 - RANGE_TOL, D3) and t1 the tip's entry angle (computed with c clamped into
    [-1, 1] where it does not meet). The rigid sweep's tip strike is this at t2 = theta2_min."""
    rho, delta = tip_polar(t2, finger.l1, finger.l2)
    c = entry_cosine(dx, dy, rho, finger.r)
    meets = -1.0 <= c < 1.0 - RANGE_TOL
    t1 = math.atan2(dy, dx) - math.acos(min(max(c, -1.0), 1.0)) - delta
    return meets, c, t1


@inner
def tip_polar(t2, l1, l2):
    """Radius and polar offset of the tip about J, relative to the proximal link (MODEL 4)."""
    rho = math.sqrt(l1 * l1 + l2 * l2 + 2.0 * l1 * l2 * math.cos(t2))
    return rho, math.atan2(l2 * math.sin(t2), l1 + l2 * math.cos(t2))


@inner
def tip_columns(t1, t2, dx, dy, finger):
    """(c_n, c_t) of a tip contact (D15): the moments about J and B of the contact's normal
    (from the tip to the part centre) and tangent."""
    bx = finger.l1 * math.cos(t1)
    by = finger.l1 * math.sin(t1)
    phi = t1 + t2
    tx = bx + finger.l2 * math.cos(phi)
    ty = by + finger.l2 * math.sin(phi)
    nx, ny = unit_normal_to(dx, dy, tx, ty)
    return vertex_columns(tx, ty, bx, by, nx, ny, True)


@inner
def tip_stick_margin(tau1, tau2, cn1, cn2, ct1, ct2, mu_s):
    """gtip = tau x c_n + mu_s |tau x c_t| (D15): >= 0 where the tip can hold the finger or the
    tendon no longer drives it along the path (the analogue of gmax)."""
    return tau1 * cn2 - tau2 * cn1 + mu_s * abs(tau1 * ct2 - tau2 * ct1)


@inner
def tip_node(s, dx, dy, finger, springs):
    """The tip path at s = -t2 (D15): (meets, c, t1, t2, gtip, pull, pushes, cut). pull =
    -tau . c_n > 0 where the tendon pulls the tip off the disc; pushes: where some multiplier
    balances the tendon (gtip >= 0), whether the normal force F of tau = F (c_n + mu c_t) is
    >= 0, from tau x c_t = F (c_n x c_t) (its sign, without dividing); cut = u . (T - d) / r,
    u the distal link's direction: > 0 where the link reaches the tip from inside the disc (it
    cuts through the part), 0 where it is tangent there (D20); gap: the proximal link's
    clearance from the part (proximal_link_gap, D21). 0 / True where it does not meet."""
    t2 = -s
    meets, c, t1 = tip_on_disc(t2, dx, dy, finger)
    gtip = 0.0
    pull = 0.0
    pushes = True
    cut = -1.0
    gap = proximal_link_gap(t1, dx, dy, finger)
    if meets:
        cn1, cn2, ct1, ct2 = tip_columns(t1, t2, dx, dy, finger)
        tau1, tau2 = joint_torques(t1, t2, finger, springs)
        gtip = tip_stick_margin(tau1, tau2, cn1, cn2, ct1, ct2, finger.mu_s)
        pull = -(tau1 * cn1 + tau2 * cn2)
        pushes = (tau1 * ct2 - tau2 * ct1) * (cn1 * ct2 - cn2 * ct1) >= 0.0
        cut = link_cut_at_tip(t1, t2, dx, dy, finger)
    return meets, c, t1, t2, gtip, pull, pushes, cut, gap


@inner
def proximal_link_gap(t1, dx, dy, finger):
    """|d - J B| / r - 1 for the proximal link at t1 (D21): < 0 where the link is inside the
    part, 0 where it touches it."""
    bx = finger.l1 * math.cos(t1)
    by = finger.l1 * math.sin(t1)
    s = min(max((dx * bx + dy * by) / (finger.l1 * finger.l1), 0.0), 1.0)
    return math.hypot(dx - s * bx, dy - s * by) / finger.r - 1.0


@inner
def link_cut_at_tip(t1, t2, dx, dy, finger):
    """u . (T - d) / r for the distal link's direction u (D20): the link near its tip T lies
    inside the disc iff this is > 0 (|T - e u - d|^2 = r^2 - 2 e u . (T - d) + e^2)."""
    phi = t1 + t2
    ux = math.cos(phi)
    uy = math.sin(phi)
    tx = finger.l1 * math.cos(t1) + finger.l2 * ux
    ty = finger.l1 * math.sin(t1) + finger.l2 * uy
    return (ux * (tx - dx) + uy * (ty - dy)) / finger.r


@inner
def tip_event_margin(event, s, dx, dy, finger, springs):
    """(holds, margin) of one tip-path event at s = -t2 (D15), as edge_event_margin."""
    meets, c, t1, t2, gtip, pull, pushes, cut, gap = tip_node(s, dx, dy, finger, springs)
    return tip_event_holds(event, meets, c, t1, t2, gtip, pull, pushes, cut, gap, finger)


@inner
def tip_event_holds(event, meets, c, t1, t2, gtip, pull, pushes, cut, gap, finger):
    """(holds, margin) of a tip-path event at a node: stick (gtip >= 0 with a pushing tip: the
    finger is in equilibrium, MODEL 5.1), distal stop (t2 >= theta2_max), proximal stop (t1 out
    of [0, pi] by more than the range slack, or the proximal link reaching the part, which stops
    it as its joint stop would, D21), lost (SLIP: the tip's circle about J misses the disc, the
    tendon pulls the tip off, only a pulling tip would balance the tendon, or the distal link
    reaches the tip from inside the disc, D20)."""
    if event == DISTAL_STOP:  # with or without contact: the path ends at theta2_max
        margin = t2 - (finger.theta2_max - RANGE_TOL)
        return margin >= 0.0, margin
    if not meets:
        if event == SLIP:
            return True, max(c - (1.0 - RANGE_TOL), -1.0 - c)
        return False, -1.0
    if event == PROXIMAL_STOP:
        margin = max(-RANGE_TOL - t1, t1 - (math.pi + RANGE_TOL), -gap - RANGE_TOL)
        return margin > 0.0, margin
    if event == STICK:
        return gtip >= 0.0 and pushes, gtip
    if gtip >= 0.0 and not pushes:
        return True, max(pull, gtip, cut - RANGE_TOL)
    margin = max(pull, cut - RANGE_TOL)
    return margin > 0.0, margin


@inner
def tip_path_events(s, dx, dy, finger, springs):
    """Bit mask of the tip-path events that hold at s = -t2 (D15)."""
    meets, c, t1, t2, gtip, pull, pushes, cut, gap = tip_node(s, dx, dy, finger, springs)
    events = 0
    for event in (STICK, DISTAL_STOP, PROXIMAL_STOP, SLIP):
        holds, _ = tip_event_holds(event, meets, c, t1, t2, gtip, pull, pushes, cut, gap,
                                   finger)
        if holds:
            events |= event
    return events


# ---------------------------------------------------------------------------------------------
# Either path: step t1 down to the first event, then bracket it
# ---------------------------------------------------------------------------------------------
@inner
def event_margin(event, t1, dx, dy, finger, springs, on_tip_path):
    if not on_tip_path:
        return edge_event_margin(event, t1, dx, dy, finger, springs)
    return tip_event_margin(event, t1, dx, dy, finger, springs)


@inner
def event_mask_at(t1, dx, dy, finger, springs, on_tip_path):
    if not on_tip_path:
        t2, k2 = distal_tangency(dx, dy, t1, finger.l1, finger.r)
        return path_events(t1, t2, k2, finger, springs)
    return tip_path_events(t1, dx, dy, finger, springs)


@inner
def event_crossing(event, lo, hi, dx, dy, finger, springs, root_tol, on_tip_path):
    """Where an event starts along the path: it holds at lo, not at hi (lo < hi). Returns the
    final bracket (lo, hi): the event holds at lo, and hi - lo <= root_tol.

    Safeguarded Illinois regula falsi on the event margin: every probe lies at least root_tol/2
    inside the bracket and every fourth is a bisection, so the bracket shrinks to root_tol in a
    handful of evaluations (model-notes D4).
    """
    if event == PROXIMAL_STOP and not on_tip_path:  # the edge path's last node, t1 = 0
        return 0.0, hi
    _, f_lo = event_margin(event, lo, dx, dy, finger, springs, on_tip_path)
    _, f_hi = event_margin(event, hi, dx, dy, finger, springs, on_tip_path)
    kept = 0  # +1: lo kept moving, -1: hi kept moving (Illinois halves the stale end)
    for it in range(400):  # bounded: at worst every fourth probe halves the bracket
        width = hi - lo
        if width <= root_tol:
            break
        x = 0.5 * (lo + hi)
        if it % 4 != 3 and f_lo != f_hi:
            x = hi - f_hi * width / (f_hi - f_lo)
            x = min(max(x, lo + 0.5 * root_tol), hi - 0.5 * root_tol)
        holds, f_x = event_margin(event, x, dx, dy, finger, springs, on_tip_path)
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
    return lo, hi


@inner
def follow_path(dx, dy, s_start, s_end, finger, solver, springs, on_tip_path):
    """Step the path's parameter s down from s_start to the first event, bracket each event that
    holds there, and return (event, s, s_after, s_free): the first event met (largest s; exact
    ties in the order stick, distal stop, proximal stop, slip), where it starts, the bracket's
    other end (where it did not hold yet) and the last node where no event held. The edge
    path's s is t1 (down to s_end = 0, where the proximal stop holds), the tip path's -t2 (down
    to -theta2_max, where the distal stop holds): the last node always ends the path on an
    event."""
    step = solver.reconfig_step
    hi = s_start
    lo = s_start
    events = 0
    # Bounded in floating point before converting (no int overflow for any step: Numba's
    # math.ceil returns int64, which overflowed for t1 / step > 9.2e18 and skipped the path; found
    # by running the tests under NUMBA_DISABLE_JIT=1). The last node is s_end.
    n_max = int(math.ceil(min((s_start - s_end) / step, float(MAX_PATH_STEPS)))) + 1
    for n in range(1, n_max + 1):
        lo = s_start - n * step
        if lo <= s_end or n == n_max:
            lo = s_end
        events = event_mask_at(lo, dx, dy, finger, springs, on_tip_path)
        if events != 0:
            break
        hi = lo
    best_t1 = -math.inf
    best_after = hi
    best_event = PROXIMAL_STOP
    several = (events & (events - 1)) != 0
    for event in (STICK, DISTAL_STOP, PROXIMAL_STOP, SLIP):  # priority order for exact ties
        if events & event:
            tol = solver.root_tol
            if several or (event & JOINT_STOPS) != 0:
                tol = min(tol, EXACT_TOL)
            t_cross, t_after = event_crossing(event, lo, hi, dx, dy, finger, springs, tol,
                                              on_tip_path)
            if t_cross > best_t1:
                best_t1 = t_cross
                best_after = t_after
                best_event = event
    if best_t1 < s_end:  # unreachable (the last node is always an event); keep a defined answer
        best_t1 = s_end
    return best_event, best_t1, best_after, hi

# =================================================================================================
# The finger (MODEL 4-6)
# =================================================================================================

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
    t1c, k2c = rigid_distal_tangency(dx, dy, l1, r, theta2_min)
    # validity within the closed form's own round-off (D30): a tangency rejected by round-off
    # let the finger sweep on with its distal link through the part
    slack_k2, slack_t1 = rigid_tangency_slack(dx, dy, l1, r, theta2_min, k2c)
    if -slack_k2 <= k2c <= l2 + slack_k2 and rest - slack_t1 <= t1c <= math.pi + slack_t1:
        best_t1 = t1c
        mode = DISTAL_ON_LOWER_STOP
        # within its round-off of B the contact is at B, where it cannot stick (D10, D30):
        # round-off must not decide between sticking and sliding
        k2_out = clamp(k2c, 0.0, l2) if k2c > slack_k2 else 0.0
    # A vertex wins only if strictly earlier: at a tie the tangency covers the link's end.
    t_b = joint_strike_angle(dx, dy, l1, r)
    if in_range(t_b, rest, math.pi) and t_b < best_t1 - slack_t1:
        best_t1 = t_b
        mode = strike_mode(effects.tip_contact, JOINT_STRIKE)
        k1_out = l1
        k2_out = 0.0
    rho_t, delta_t = tip_polar(theta2_min, l1, l2)
    t_t = vertex_entry(dx, dy, rho_t, delta_t, r)
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
def strike_mode(tip, strike):
    """The mode of a vertex strike: VERTEX in the paper's model (tip_contact off), else the
    strike's own internal mode, settled by settle_vertex (D15)."""
    if not tip.on:
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
def distal_closes_after_proximal(dx, dy, t1, k1, finger, tip):
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
    if tip.on and strikes:
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
def past_the_tip(tip, dx, dy, t1, t2, k2, finger, solver, springs):
    """The distal contact has slid to the tip: the part is lost (SLIPPED, the paper's ejection)
    or, with tip_contact, the finger follows the tip on the disc (D15)."""
    if not tip.on:
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
def settle_vertex(tip, first, dx, dy, finger, solver, effects):
    """D15: settle a vertex strike (tip_contact only; without it a strike stays VERTEX)."""
    if not tip.on:
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
    first = closing_contact(dx, dy, finger, effects)
    final = settle(first, dx, dy, finger, solver, effects)
    return FingerState(final.mode, final.t1, final.t2, final.k1, final.k2, first.tip_overlap)


@inner
def took_tip_path(mode, tip):
    """A settled finger whose final state may lie on the tip path (D15): TIP_ONLY, PROXIMAL_TIP,
    or SLIPPED with tip_contact (the part lost by the tip). Its closing is not the rigid sweep
    then the distal closing that finger_collision rebuilds from the final angles (D14, D29)."""
    return tip.on and (mode == TIP_ONLY or mode == PROXIMAL_TIP or mode == SLIPPED)


@entry
def tip_path_start(dx, dy, mode, t1, t2, finger, solver, effects):
    """(on_tip, t1, t2, k1) where the finger's tip path began (model-notes D29), its closing up to
    there being the rigid sweep then the distal closing, and the proximal contact it had there.
    on_tip False: the finger held where it first struck, so the path D14 rebuilds from its final
    angles is its own. The same calls as solve_finger's (same bits): the first contact, and, when
    the contact first slid along the distal link, that edge path's end (the contact at the tip)."""
    if not took_tip_path(mode, effects.tip_contact):
        return False, t1, t2, 0.0
    first = closing_contact(dx, dy, finger, effects)
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


# ---------------------------------------------------------------------------------------------
# Energy (MODEL 6) and contact forces (MODEL 5.1, 5.6)
# ---------------------------------------------------------------------------------------------
@entry
def finger_energy(t1, t2, r1, r2, tension, theta2_min):
    """V = -F [r1 (t1 - theta1_o) + r2 (t2 - theta2_o)] with theta1_o = 0, theta2_o = theta2_min."""
    return -tension * (r1 * t1 + r2 * (t2 - theta2_min))


@inner
def spring_energy(t1, t2, springs, theta2_min):
    """Energy stored in the joint springs, 1/2 K1 t1^2 + 1/2 K2 (t2 - theta2_min)^2: the
    potential of the torques K_i (t_i - theta_io) (MODEL 6, 9; model-notes D13); 0 when off."""
    if not springs.on:
        return 0.0
    return 0.5 * springs.k1 * t1 * t1 + 0.5 * springs.k2 * (t2 - theta2_min) ** 2


@inner
def contact_count(mode):
    """Tangent contacts a finger's final mode has with the part (MODEL 7)."""
    if mode == TWO_PHALANX:
        return 2
    if mode == PROXIMAL_ONLY or mode == DISTAL_ONLY:
        return 1
    return 0


@inner
def joints_on_limits(state, finger):
    """How many of the finger's joints rest on a limit (each may carry a stop torque)."""
    lower1, upper1 = at_limit(state.t1, 0.0, math.pi)
    lower2, upper2 = at_limit(state.t2, finger.theta2_min, finger.theta2_max)
    return int(lower1 or upper1) + int(lower2 or upper2)


@inner
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
    # the paper's model: forces with joint_springs are refused (model-notes D13)
    no_springs = JointSprings(False, 0.0, 0.0, 1.0)
    if mode == PROXIMAL_ONLY:
        if k1 <= RANGE_TOL:
            return 0.0, 0.0, 0.0
        return r1 / k1, 0.0, 0.0
    if mode == TWO_PHALANX:
        if k2 <= RANGE_TOL:
            return 0.0, 0.0, 0.0
        g0 = proximal_torque_balance(k2, t1, t2, finger, no_springs, 0.0)
        mu2 = 0.0
        if g0 < 0.0 and math.sin(t2) != 0.0:
            mu2 = clamp(-g0 / (r2 * l1 * math.sin(t2)), -mu_s, mu_s)
        f2 = r2 / k2
        f1 = 0.0
        if k1 > RANGE_TOL:
            f1 = max(proximal_torque_balance(k2, t1, t2, finger, no_springs, mu2) / (k1 * k2), 0.0)
        return f1, f2, mu2
    if mode == DISTAL_ONLY:
        if k2 <= RANGE_TOL:
            return 0.0, 0.0, 0.0
        g0 = proximal_torque_balance(k2, t1, t2, finger, no_springs, 0.0)
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


@entry
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
