"""The paths a finger follows when its first contact cannot hold (MODEL 5.3, model-notes D4,
D15). Two paths, one stepping-and-bracketing routine (`follow_path`): along each, t1 decreases
from its start and the first event met wins.

- The *edge path* (MODEL 5.3, EDGE_PATH): the distal link stays tangent to the part (MODEL 3.2
  at each t1) and its contact slides toward the tip. Events: stick (gmax >= 0), distal stop,
  proximal stop, slip (the contact passes the tip).
- The *tip path* (tip_contact, D15, TIP_PATH): the tip stays on the part; at each t1 the distal
  closes about B until the tip meets the disc. Events: stick (gtip >= 0), distal stop,
  proximal stop, lost (the tip no longer meets the disc, or the tendon pulls it off).
"""
import math
import numpy as np

from ..model import RANGE_TOL
from .jit import inner
from .finger_geometry import distal_tangency, enters_disc, entry_cosine
from .finger_statics import joint_torques, max_torque_balance, unit_normal_to, vertex_columns


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
    return edge_margin(event, t1, t2, k2, finger, springs)


@inner
def edge_margin(event, t1, t2, k2, finger, springs):
    """edge_event_margin at a state (t1, t2, k2) of the edge path. Each test is path_events' own
    (the same expression and comparison), for this event only: the bracket evaluates one event
    many times, and the others' trigonometry would be wasted."""
    if event == STICK:
        margin = max_torque_balance(k2, t1, t2, finger, springs)
        return margin >= 0.0, margin
    if event == DISTAL_STOP:
        return t2 >= finger.theta2_max - RANGE_TOL, t2 - (finger.theta2_max - RANGE_TOL)
    return k2 > finger.l2 + RANGE_TOL, k2 - (finger.l2 + RANGE_TOL)  # SLIP


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
    meets = enters_disc(c)
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
def event_crossing(event, lo, hi, dx, dy, finger, springs, root_tol, on_tip_path):
    """Where an event starts along the path: it holds at lo, not at hi (lo < hi). Returns the
    final bracket (lo, hi): the event holds at lo, and hi - lo <= root_tol."""
    if event == PROXIMAL_STOP and not on_tip_path:  # the edge path's last node, t1 = 0
        return 0.0, hi
    _, f_lo = event_margin(event, lo, dx, dy, finger, springs, on_tip_path)
    _, f_hi = event_margin(event, hi, dx, dy, finger, springs, on_tip_path)
    return bracket_event(event, lo, hi, f_lo, f_hi, dx, dy, finger, springs, root_tol,
                         on_tip_path)


@inner
def bracket_event(event, lo, hi, f_lo, f_hi, dx, dy, finger, springs, root_tol, on_tip_path):
    """event_crossing from the event's margins at the bracket's ends (f_lo, f_hi).

    Safeguarded Illinois regula falsi on the event margin: every probe lies at least root_tol/2
    inside the bracket and every fourth is a bisection, so the bracket shrinks to root_tol in a
    handful of evaluations (model-notes D4).
    """
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
    # the edge path's tangency at the last two nodes (lo, hi): the brackets start from their
    # margins without solving the tangency again (hi_known: hi is a node, not s_start)
    t2_lo = k2_lo = t2_hi = k2_hi = 0.0
    hi_known = False
    # Bounded in floating point before converting (no int overflow for any step: Numba's
    # math.ceil returns int64, which overflowed for t1 / step > 9.2e18 and skipped the path; found
    # by running the tests under NUMBA_DISABLE_JIT=1). The last node is s_end.
    n_max = int(math.ceil(min((s_start - s_end) / step, float(MAX_PATH_STEPS)))) + 1
    for n in range(1, n_max + 1):
        lo = s_start - n * step
        if lo <= s_end or n == n_max:
            lo = s_end
        if on_tip_path:
            events = tip_path_events(lo, dx, dy, finger, springs)
        else:
            t2_lo, k2_lo = distal_tangency(dx, dy, lo, finger.l1, finger.r)
            events = path_events(lo, t2_lo, k2_lo, finger, springs)
        if events != 0:
            break
        hi = lo
        t2_hi = t2_lo
        k2_hi = k2_lo
        hi_known = True
    best_t1 = -math.inf
    best_after = hi
    best_event = PROXIMAL_STOP
    several = (events & (events - 1)) != 0
    for event in (STICK, DISTAL_STOP, PROXIMAL_STOP, SLIP):  # priority order for exact ties
        if events & event:
            tol = solver.root_tol
            if several or (event & JOINT_STOPS) != 0:
                tol = min(tol, EXACT_TOL)
            if on_tip_path or event == PROXIMAL_STOP:
                t_cross, t_after = event_crossing(event, lo, hi, dx, dy, finger, springs, tol,
                                                  on_tip_path)
            else:
                if not hi_known:
                    t2_hi, k2_hi = distal_tangency(dx, dy, hi, finger.l1, finger.r)
                    hi_known = True
                _, f_lo = edge_margin(event, lo, t2_lo, k2_lo, finger, springs)
                _, f_hi = edge_margin(event, hi, t2_hi, k2_hi, finger, springs)
                t_cross, t_after = bracket_event(event, lo, hi, f_lo, f_hi, dx, dy, finger,
                                                 springs, tol, on_tip_path)
            if t_cross > best_t1:
                best_t1 = t_cross
                best_after = t_after
                best_event = event
    if best_t1 < s_end:  # unreachable (the last node is always an event); keep a defined answer
        best_t1 = s_end
    return best_event, best_t1, best_after, hi
