"""One finger's statics in joint-torque space (MODEL 5.1-5.3), its energy (MODEL 6) and
contact forces (MODEL 5.1, 5.6).

Torques are per unit tendon tension. A contact force `F (n + mu t)` at finger point `c` adds
`F (c_n + mu c_t)` to the joints' balance, with `c_n = (c x n, (c - B) x n)` (the second entry
only for a contact on the distal link) and likewise `c_t` for the tangent `t`. The finger holds
iff the tendon's torques `tau` equal such a contact term plus what its other contacts and
engaged stops can supply, each of a fixed sign in one joint: `sticks_on_lower_stop` and the
torque balances for tangent contacts, `vertex_contact_holds` for a vertex contact (tip_contact,
model-notes D15), `finger_statics` for the forces a settled finger exerts.
"""
import math
import numpy as np

from ..model import DISTAL_ONLY, FREE, PROXIMAL_ONLY, RANGE_TOL, TWO_PHALANX
from .jit import entry, inner
from .records import FingerStatics, JointSprings
from .finger_geometry import clamp


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
    """MODEL 5.3: a distal-only contact with the distal on its lower stop
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
            # lines parallel but for round-off (a straight finger's tip columns, t2 = 0) meet
            # anywhere far along them, and there the checks' tolerance, which grows with F,
            # passes; a feasible set has its vertices where other lines meet
            if abs(det) <= 1e-12 * (abs(a1[p] * a2[q]) + abs(a2[p] * a1[q])):
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
