"""Slow, independent reference implementation of the model, for the tests.

Written straight from the model (``docs/model.md``, which keeps the section numbers of the
project's authoritative MODEL.md) and ``docs/model-notes.md`` (D1-D10, D16) without looking at the
fast kernels. Plain Python + math + NumPy; readability over speed: this file is the specification
in executable form. Section numbers below refer to docs/model.md ("M3.1") and to the model notes
("D4").

Frames (M2): a finger is solved in the RIGHT finger's frame, ``d = p - J_R``; the left finger uses
the mirrored offset and its angles/contact lengths are reported in its own mirrored frame.
"""
from __future__ import annotations

import math
from functools import lru_cache

import numpy as np

from sweep.model import (
    DISTAL_ONLY, EJECT, END_CAGED, END_EJECTION, END_NONE, END_STALLED, END_TIP_PREHENSION,
    FREE, INFEASIBLE, PROXIMAL_ONLY, REACHED, SLIPPED, TWO_PHALANX, UNREACHED, VERTEX,
    VERTEX_POINT,
)

# Tolerances of the model (M5.5, M7, M8, D2), spelled out here from the text on purpose.
TOUCH_REL = 1e-12   # |d|^2 >= r^2 (1 - 1e-12): touching, tangent length 0
RANGE_TOL = 1e-12   # inclusive slack of validity ranges; also the D3 tie window
GAP_TOL = 1e-9      # cone hull: equilibrium iff no angular gap exceeds pi + 1e-9
PALM_TOL = 1e-9     # palm contact: |y - r| <= 1e-9 and |x| <= w/2 + 1e-9
GRID_TOL = 1e-9     # grid index rounding

PI = math.pi

# Rigid-sweep event kinds (M4.2)
EV_PROXIMAL, EV_DISTAL, EV_VERTEX_B, EV_VERTEX_T, EV_NONE = (
    "proximal", "distal", "vertex_B", "vertex_T", "none")
# Distal-closing outcomes about B (M4.3 / M4.2 last bullet)
CL_TANGENT, CL_TIP, CL_NONE = "tangent", "tip", "none"


# ---------------------------------------------------------------------------------------------
# Small helpers
# ---------------------------------------------------------------------------------------------
def wrap(a: float) -> float:
    """Wrap an angle into (-pi, pi]; values already inside are returned unchanged."""
    return a - 2.0 * PI * math.ceil((a - PI) / (2.0 * PI))


def tangent_length(dist2: float, r: float):
    """Tangent length from a point at squared distance dist2 to a circle of radius r (M5.5, D2).

    None when the point is inside the disc (beyond the touching tolerance)."""
    if dist2 < r * r * (1.0 - TOUCH_REL):
        return None
    return math.sqrt(max(dist2 - r * r, 0.0))


def in_range(v: float, lo: float, hi: float) -> bool:
    """Inclusive range check with the model's slack (D2)."""
    return lo - RANGE_TOL <= v <= hi + RANGE_TOL


def clamp(v: float, lo: float, hi: float) -> float:
    return min(max(v, lo), hi)


def g_of_mu(mu: float, t2: float, k2: float, l1: float, r1: float, r2: float) -> float:
    """g(mu) = r1 k2 - r2 (l1 cos t2 + k2) + mu r2 l1 sin t2 (M5.3; = k1 k2 F1 / F of M5.2)."""
    return r1 * k2 - r2 * (l1 * math.cos(t2) + k2) + mu * r2 * l1 * math.sin(t2)


def g_max(t2: float, k2: float, l1: float, r1: float, r2: float, mu_s: float) -> float:
    """max over |mu| <= mu_s of g(mu) (D4 'stick')."""
    return r1 * k2 - r2 * (l1 * math.cos(t2) + k2) + mu_s * r2 * l1 * abs(math.sin(t2))


# ---------------------------------------------------------------------------------------------
# Closed forms (M3) and the vertex entry angle (M4)
# ---------------------------------------------------------------------------------------------
def lower_stop_admissible(t2, k2, l1, r1, r2, mu_s):
    """M5.3 (revised): some |mu| <= mu_s gives g(mu) >= 0 and lever(mu) > 0. Each condition is a
    half-line of mu (or everything / nothing); intersect the intervals explicitly. At k2 = 0,
    g = -r2 lever, so the two conditions exclude each other."""
    if k2 <= 0.0:
        return False
    lo, lo_open, hi, hi_open = -mu_s, False, mu_s, False
    # g(mu) = g0 + a mu >= 0 (closed half-line)
    g0 = g_of_mu(0.0, t2, k2, l1, r1, r2)
    a = r2 * l1 * math.sin(t2)
    if a > 0 and -g0 / a > lo:
        lo, lo_open = -g0 / a, False
    elif a < 0 and -g0 / a < hi:
        hi, hi_open = -g0 / a, False
    elif a == 0 and g0 < 0:
        return False
    # lever(mu) = L0 - b mu > 0 (open half-line)
    L0 = l1 * math.cos(t2) + k2
    b = l1 * math.sin(t2)
    if b > 0 and L0 / b <= hi:
        hi, hi_open = L0 / b, True
    elif b < 0 and L0 / b >= lo:
        lo, lo_open = L0 / b, True
    elif b == 0 and L0 <= 0:
        return False
    return lo < hi or (lo == hi and not lo_open and not hi_open)


# D30: a closed form's validity test accepts its value within RANGE_TOL plus the value's own
# round-off. A tangent length k = sqrt(D - r^2) whose D carries an absolute error delta carries
# delta / (2 k), or sqrt(delta) once k^2 is below delta; the tangent's angle atan2(r, k) then
# carries that times r / (r^2 + k^2).
EPS = 2.0 ** -52


def tangent_roundoff(k, delta, r):
    """D30: (error of the tangent length k, error of its angle) for D known to delta."""
    dk = delta / (2.0 * k) if k * k > delta else math.sqrt(delta)
    return dk, dk * r / (r * r + k * k)


def within(v, lo, hi, slack):
    """D30: lo <= v <= hi, inclusive by RANGE_TOL plus the value's round-off."""
    return lo - RANGE_TOL - slack <= v <= hi + RANGE_TOL + slack


def proximal_tangency(dx, dy, l1, r):
    """M3.1 with its validity checks (D30). Returns (t1, k1) clamped into range, or None.

    |d|^2 carries 4 eps |d|^2. A part dipping below the palm line within the feasibility test's
    slack (dy < r) touches the link at rest: any angle below 0 is that contact (D30)."""
    dist2 = dx * dx + dy * dy
    k1 = tangent_length(dist2, r)
    if k1 is None:
        return None
    t1 = math.atan2(dy, dx) - math.atan2(r, k1)
    dk, dt = tangent_roundoff(k1, 4.0 * EPS * dist2, r)
    low = 0.0 if dy >= r else -PI / 2.0
    if within(k1, 0.0, l1, dk) and within(t1, low, PI, dt):
        return clamp(t1, 0.0, PI), clamp(k1, 0.0, l1)
    return None


def distal_tangent_state(dx, dy, t1, l1, r):
    """M3.2 WITHOUT range checks (the reconfiguration path of D4): (t2, k2) for a given t1.

    The tangent length is taken as sqrt(max(|e|^2 - r^2, 0)) even if B is slightly inside."""
    ex = dx - l1 * math.cos(t1)
    ey = dy - l1 * math.sin(t1)
    k2 = math.sqrt(max(ex * ex + ey * ey - r * r, 0.0))
    t2 = wrap(math.atan2(ey, ex) - math.atan2(r, k2) - t1)
    return t2, k2


def distal_tangency(dx, dy, t1, l1, l2, r, th2_min, th2_max):
    """M3.2 with its validity checks (D30). Returns (t2, k2) clamped into range, or None.

    e = d - B cancels: its components carry 2 eps (|d| + l1), so |e|^2 carries 2 |e| that plus
    4 eps |e|^2, and the direction of e that over |e|."""
    ex = dx - l1 * math.cos(t1)
    ey = dy - l1 * math.sin(t1)
    e2 = ex * ex + ey * ey
    k2 = tangent_length(e2, r)
    if k2 is None:
        return None
    t2 = wrap(math.atan2(ey, ex) - math.atan2(r, k2) - t1)
    e = math.sqrt(e2)
    err_e = 2.0 * EPS * (math.hypot(dx, dy) + l1)
    dk, dt = tangent_roundoff(k2, 2.0 * e * err_e + 4.0 * EPS * e2, r)
    dt += err_e / max(e, r) + 8.0 * EPS * PI
    if within(k2, 0.0, l2, dk) and within(t2, th2_min, th2_max, dt):
        return clamp(t2, th2_min, th2_max), clamp(k2, 0.0, l2)
    return None


def rigid_distal_tangency(dx, dy, l1, l2, r, th2_min, rest=0.0):
    """M3.3: distal tangency during the rigid sweep (t2 = theta2_min). Returns (t1, k2, t1 before
    clamping, its slack) or None. Validity within the round-off of D30: K = k2 +
    l1 cos(theta2_min) = sqrt(|d|^2 - r'^2) through asin(r'/|d|) carries what a tangent
    length with delta = 8 eps max(|d|^2, r'^2) does, plus 4 eps (|d| + l1); the angle K's
    error over r'. `rest`: the lowest angle that is still a contact (below 0 for a part
    dipping below the palm line)."""
    r_prime = r + l1 * math.sin(-th2_min)
    dist2 = dx * dx + dy * dy
    if dist2 < r_prime * r_prime * (1.0 - TOUCH_REL):
        return None
    dist = math.sqrt(dist2)
    alpha = math.atan2(dy, dx)
    phi = alpha - math.asin(min(r_prime / dist, 1.0))
    t1 = phi - th2_min
    k2 = dist * math.cos(alpha - phi) - l1 * math.cos(th2_min)
    big = max(dist2, r_prime * r_prime)
    dk, _ = tangent_roundoff(max(k2 + l1 * math.cos(th2_min), 0.0), 8.0 * EPS * big, r)
    dk += 4.0 * EPS * (dist + l1)
    dt = dk / r_prime + 8.0 * EPS
    if within(k2, 0.0, l2, dk) and within(t1, rest, PI, dt):
        # within its round-off of B the contact is at B (k2 = 0), where it cannot stick (D30)
        k2 = clamp(k2, 0.0, l2) if k2 > RANGE_TOL + dk else 0.0
        return clamp(t1, 0.0, PI), k2, t1, RANGE_TOL + dt
    return None


def b_graze_strike(dx, dy, l1, r, th2_min):
    """D30 (MODEL 4 revised): the angle at which B, only grazing the disc in the rigid sweep
    (acos argument within RANGE_TOL below 1, or within its round-off above), strikes it because
    a link attached to B points into the disc there; None otherwise. At the graze B lies on the
    line from J to the centre; the distal link leaves B at theta2_min from the proximal one."""
    dist = math.hypot(dx, dy)
    c = (l1 * l1 + dist * dist - r * r) / (2.0 * l1 * dist)
    err_c = 4.0 * EPS * (l1 * l1 + dist * dist + r * r) / (2.0 * l1 * dist)
    if not (1.0 - RANGE_TOL <= c <= 1.0 + err_c):
        return None
    t = math.atan2(dy, dx) - math.acos(min(c, 1.0))
    # the links' directions are read where B is nearest the centre (t1 = atan2(dy, dx)), not at
    # the entry angle t: t lies up to acos(1 - RANGE_TOL) = 1.4e-6 before it, which turns the
    # distal link's direction by (1 + l1 / r) that much, and with theta2_min within that of
    # -90 deg it pointed out of the disc at t while the link cut in just after (D30)
    a = math.atan2(dy, dx)
    bx, by = l1 * math.cos(a), l1 * math.sin(a)
    to_centre = (dx - bx, dy - by)
    distal = (math.cos(a + th2_min), math.sin(a + th2_min))
    proximal_back = (-math.cos(a), -math.sin(a))
    enters = any(to_centre[0] * u[0] + to_centre[1] * u[1] > 0.0 for u in (distal, proximal_back))
    return t if enters else None


def vertex_entry(ex, ey, rho, r, delta):
    """M4: turning angle at which a vertex at radius rho (polar offset delta from the moving link)
    enters the disc whose centre is at e relative to the pivot. None if it never meets it."""
    dist = math.hypot(ex, ey)
    if dist == 0.0 or rho == 0.0:
        return None
    c = (rho * rho + dist * dist - r * r) / (2.0 * rho * dist)
    if c < -1.0 or c >= 1.0 - RANGE_TOL:   # D3: a graze (c = 1) touches the disc without entering
        return None
    return math.atan2(ey, ex) - math.acos(c) - delta


# ---------------------------------------------------------------------------------------------
# Closing sequence (M4)
# ---------------------------------------------------------------------------------------------
def rigid_sweep(dx, dy, l1, l2, r, th2_min):
    """M4.2: first event as t1 goes from 0 to pi with the distal on its lower stop.

    Returns (kind, t1, k) with kind one of EV_*; k is k1 (proximal), k2 (distal) or None."""
    prox = proximal_tangency(dx, dy, l1, r)
    if prox is not None:
        t1, k1 = prox
        return EV_PROXIMAL, t1, k1

    # Vertex strikes, turning about J: B at (rho=l1, delta=0), T at the rigid tip position.
    # A part dipping below the palm line (dy < r, D30) touches the finger at rest: an event's
    # angle below 0 is that contact.
    rest = 0.0 if dy >= r else -PI / 2.0
    strikes = []
    tb = vertex_entry(dx, dy, l1, r, 0.0)
    if tb is None:
        tb = b_graze_strike(dx, dy, l1, r, th2_min)    # D30: a graze of B strikes
    if tb is not None and in_range(tb, rest, PI):
        strikes.append((clamp(tb, 0.0, PI), 0, EV_VERTEX_B, tb))
    tip_x = l1 + l2 * math.cos(th2_min)
    tip_y = l2 * math.sin(th2_min)
    tt = vertex_entry(dx, dy, math.hypot(tip_x, tip_y), r, math.atan2(tip_y, tip_x))
    if tt is not None and in_range(tt, rest, PI):
        strikes.append((clamp(tt, 0.0, PI), 1, EV_VERTEX_T, tt))
    first_strike = min(strikes) if strikes else None   # B before T on an exact tie (D3)

    tan = rigid_distal_tangency(dx, dy, l1, l2, r, th2_min, rest)
    # tangency wins ties within its angle's slack (D3, D30); the unclamped angles are compared
    if tan is not None and (first_strike is None or tan[2] <= first_strike[3] + tan[3]):
        return EV_DISTAL, tan[0], tan[1]
    if first_strike is not None:
        return first_strike[2], first_strike[0], None
    return EV_NONE, PI, None


def close_distal(dx, dy, t1, l1, l2, r, th2_min, th2_max):
    """Distal closing about B with t1 fixed, t2 from theta2_min up (M4.2 last bullet, M4.3, D3).

    Returns (CL_TANGENT, t2, k2) if 3.2 is valid, else (CL_TIP, t2_entry) if the tip enters the
    disc within the joint range, else (CL_NONE,)."""
    tan = distal_tangency(dx, dy, t1, l1, l2, r, th2_min, th2_max)
    if tan is not None:
        return CL_TANGENT, tan[0], tan[1]
    ex = dx - l1 * math.cos(t1)
    ey = dy - l1 * math.sin(t1)
    phi = vertex_entry(ex, ey, l2, r, 0.0)   # absolute direction of the distal link at entry
    if phi is not None:
        t2 = wrap(phi - t1)
        if in_range(t2, th2_min, th2_max):
            return CL_TIP, clamp(t2, th2_min, th2_max)
    return (CL_NONE,)


def reconfigure(dx, dy, t1_0, l1, l2, r1, r2, r, mu, th2_max, step, root_tol):
    """D4 / M5.3: distal kept tangent while t1 decreases from t1_0; first event wins.

    Returns (mode, t1, t2, k2) with mode DISTAL_ONLY or SLIPPED."""

    def state(t1):
        return distal_tangent_state(dx, dy, t1, l1, r)

    def holds(event, t1):
        t2, k2 = state(t1)
        if event == "stick":
            return g_max(t2, k2, l1, r1, r2, mu) >= 0.0
        if event == "distal_stop":
            return t2 >= th2_max - RANGE_TOL
        if event == "proximal_stop":
            return t1 <= 0.0
        if event == "slip":
            return k2 > l2 + RANGE_TOL
        raise ValueError(event)

    events = ("stick", "distal_stop", "proximal_stop", "slip")   # also the tie order

    # Step: nodes t1_n = t1_0 - n*step, the last one clamped to 0.
    n = 1
    prev = t1_0
    while True:
        node = max(t1_0 - n * step, 0.0)
        holding = [ev for ev in events if holds(ev, node)]
        if holding:
            break
        prev = node
        n += 1

    # Bisect each event that holds at the node: lo holds, hi does not; return lo. A joint stop,
    # and events that start in the same step, are bisected to 1e-12 whatever root_tol (D19).
    crossings = []
    for priority, ev in enumerate(events):
        if ev not in holding:
            continue
        tol = root_tol
        if len(holding) > 1 or ev in ("distal_stop", "proximal_stop"):
            tol = min(root_tol, 1e-12)
        if ev == "proximal_stop":
            crossing = 0.0
        else:
            lo, hi = node, prev
            while hi - lo > tol:
                mid = 0.5 * (lo + hi)
                if mid <= lo or mid >= hi:
                    break
                if holds(ev, mid):
                    lo = mid
                else:
                    hi = mid
            crossing = lo
        crossings.append((-crossing, priority, ev))   # largest t1 first, then tie order
    neg_t1, _, winner = min(crossings)
    t1 = -neg_t1
    t2, k2 = state(t1)
    if winner == "slip":
        return SLIPPED, t1, t2, k2
    return DISTAL_ONLY, t1, min(t2, th2_max), k2   # D4: a stop on the distal limit reports it


def _result(mode, t1, t2, k1, k2, tip_overlap=False):
    return {"mode": int(mode), "t1": float(t1), "t2": float(t2), "k1": float(k1),
            "k2": float(k2), "tip_overlap": bool(tip_overlap)}


def finger_feasible(dx, dy, r):
    """D2 per finger: the disc neither overlaps the palm line nor the finger's joint."""
    return not (dy < r - RANGE_TOL or dx * dx + dy * dy < r * r * (1.0 - TOUCH_REL))


def naive_finger(dx, dy, l1, l2, r1, r2, r, mu, theta2_min, theta2_max,
                 reconfig_step=0.01, root_tol=1e-12):
    """Configuration one finger reaches for a part centred at d = (dx, dy) in its frame (M3-M5).

    Returns a dict: mode (FREE..VERTEX), t1, t2, k1, k2 (radians / lengths), tip_overlap.
    For an infeasible input (disc over the palm line or the joint) mode is -1 and values NaN."""
    if not finger_feasible(dx, dy, r):
        nan = float("nan")
        return _result(-1, nan, nan, nan, nan)

    def reconfigured(t1_0):
        mode, t1, t2, k2 = reconfigure(dx, dy, t1_0, l1, l2, r1, r2, r, mu, theta2_max,
                                       reconfig_step, root_tol)
        if mode == DISTAL_ONLY:   # 3.2 near B carries round-off: within the lower stop (D30)
            t2 = max(t2, theta2_min)
        return _result(mode, t1, t2, 0.0, k2)

    kind, t1, k = rigid_sweep(dx, dy, l1, l2, r, theta2_min)

    if kind == EV_PROXIMAL:                                   # M4.3
        k1 = k
        closing = close_distal(dx, dy, t1, l1, l2, r, theta2_min, theta2_max)
        if closing[0] == CL_TANGENT:
            _, t2, k2 = closing
            if g_max(t2, k2, l1, r1, r2, mu) >= 0.0:          # M5.2 cases 1 and 3
                return _result(TWO_PHALANX, t1, t2, k1, k2)
            return reconfigured(t1)                           # case 2: proximal lifts off
        return _result(PROXIMAL_ONLY, t1, theta2_max, k1, 0.0,
                       tip_overlap=(closing[0] == CL_TIP))

    if kind == EV_DISTAL:                                     # M4.4 / M5.3 first bullet
        k2 = k
        t2 = theta2_min
        if lower_stop_admissible(t2, k2, l1, r1, r2, mu):
            return _result(DISTAL_ONLY, t1, t2, 0.0, k2)
        return reconfigured(t1)

    if kind == EV_VERTEX_B:
        return _result(VERTEX, t1, theta2_min, l1, 0.0)
    if kind == EV_VERTEX_T:
        return _result(VERTEX, t1, theta2_min, 0.0, l2)

    # No event in the rigid sweep: the distal closes with the proximal on its upper stop.
    closing = close_distal(dx, dy, PI, l1, l2, r, theta2_min, theta2_max)
    if closing[0] == CL_TANGENT:
        _, t2, k2 = closing
        if g_max(t2, k2, l1, r1, r2, mu) >= 0.0:
            return _result(DISTAL_ONLY, PI, t2, 0.0, k2)
        return reconfigured(PI)
    if closing[0] == CL_TIP:
        return _result(VERTEX, PI, closing[1], 0.0, l2)
    return _result(FREE, PI, theta2_max, 0.0, 0.0)


# ---------------------------------------------------------------------------------------------
# Maps (M6, M7, M8, D1, D5-D7)
# ---------------------------------------------------------------------------------------------
def grid_indices(lo_hi, h, offset):
    lo, hi = lo_hi
    return (math.ceil((lo - offset) / h - GRID_TOL), math.floor((hi - offset) / h + GRID_TOL))


def finger_points(t1, t2, l1, l2):
    """J, B, T in a finger's own frame."""
    bx, by = l1 * math.cos(t1), l1 * math.sin(t1)
    tx, ty = bx + l2 * math.cos(t1 + t2), by + l2 * math.sin(t1 + t2)
    return (0.0, 0.0), (bx, by), (tx, ty)


def to_world(pt, finger, w):
    """Finger frame -> world: right x' = x + w/2; left is mirrored, x' = -x - w/2."""
    if finger == 1:
        return (pt[0] + w / 2.0, pt[1])
    return (-pt[0] - w / 2.0, pt[1])


def contact_normals(res, finger):
    """Unit normals (finger on part, world frame) of a finger's tangent contacts (D5)."""
    t1, t2, mode = res["t1"], res["t2"], res["mode"]
    normals = []
    if mode in (PROXIMAL_ONLY, TWO_PHALANX):
        normals.append((-math.sin(t1), math.cos(t1)))
    if mode in (TWO_PHALANX, DISTAL_ONLY):
        normals.append((-math.sin(t1 + t2), math.cos(t1 + t2)))
    if finger == 0:
        normals = [(-nx, ny) for nx, ny in normals]
    return normals


def in_equilibrium(normals, mu):
    """M7: origin in the convex hull of the friction-cone edges <=> no angular gap > pi + 1e-9.

    `mu`: one friction coefficient for every contact, or one per normal (MODEL 10, Scenario C:
    each contact its own cone)."""
    if len(normals) < 2:
        return False
    mus = list(mu) if isinstance(mu, (list, tuple)) else [mu] * len(normals)
    assert len(mus) == len(normals)
    angles = []
    for (nx, ny), mu_i in zip(normals, mus):
        tx, ty = -ny, nx                       # t = rot90(n)
        for s in (1.0, -1.0):
            angles.append(math.atan2(ny + s * mu_i * ty, nx + s * mu_i * tx))
    angles.sort()
    gaps = [b - a for a, b in zip(angles, angles[1:])]
    gaps.append(2.0 * PI - (angles[-1] - angles[0]))
    return max(gaps) <= PI + GAP_TOL


def pnpoly(poly, px, py):
    """Crossing-number test exactly as PNPOLY writes it (D5)."""
    inside = False
    n = len(poly)
    j = n - 1
    for i in range(n):
        xi, yi = poly[i]
        xj, yj = poly[j]
        if ((yi > py) != (yj > py)) and (px < (xj - xi) * (py - yi) / (yj - yi) + xi):
            inside = not inside
        j = i
    return inside


def point_segment_distance(p, a, b):
    abx, aby = b[0] - a[0], b[1] - a[1]
    apx, apy = p[0] - a[0], p[1] - a[1]
    den = abx * abx + aby * aby
    s = 0.0 if den == 0.0 else clamp((apx * abx + apy * aby) / den, 0.0, 1.0)
    return math.hypot(p[0] - (a[0] + s * abx), p[1] - (a[1] + s * aby))


def cross3(o, a, b):
    return (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])


def segments_intersect(p1, p2, q1, q2):
    """D5: the segments cross, or come within RANGE_TOL of each other (touching counts)."""
    if (cross3(q1, q2, p1) * cross3(q1, q2, p2) < 0.0
            and cross3(p1, p2, q1) * cross3(p1, p2, q2) < 0.0):
        return True
    return min(point_segment_distance(p1, q1, q2), point_segment_distance(p2, q1, q2),
               point_segment_distance(q1, p1, p2), point_segment_distance(q2, p1, p2)) <= RANGE_TOL


def fingers_intersect(left_pts, right_pts):
    """D5: the two polylines meet anywhere except at a base they share (w = 0), where the
    proximal links meet elsewhere only if a distal joint lies on the other proximal link."""
    jl, bl, tl = left_pts
    jr, br, tr = right_pts
    for a1, a2 in ((jl, bl), (bl, tl)):
        for b1, b2 in ((jr, br), (br, tr)):
            if a1 is jl and b1 is jr and math.hypot(jl[0] - jr[0], jl[1] - jr[1]) <= RANGE_TOL:
                if (point_segment_distance(bl, jr, br) <= RANGE_TOL
                        or point_segment_distance(br, jl, bl) <= RANGE_TOL):
                    return True
            elif segments_intersect(a1, a2, b1, b2):
                return True
    return False


def opening(left_pts, right_pts):
    """L_open (M8, D5) and whether the fingers intersect."""
    jl, bl, tl = left_pts
    jr, br, tr = right_pts
    if fingers_intersect(left_pts, right_pts):
        return 0.0, True
    dists = [math.hypot(tl[0] - tr[0], tl[1] - tr[1]),
             point_segment_distance(tl, jr, br), point_segment_distance(tl, br, tr),
             point_segment_distance(tr, jl, bl), point_segment_distance(tr, bl, tl)]
    return min(dists), False


def contained(poly, px, py):
    """D5: PNPOLY, and a centre within RANGE_TOL of the polygon's boundary is not contained."""
    if not pnpoly(poly, px, py):
        return False
    edges = zip(poly, poly[1:] + poly[:1])
    return min(point_segment_distance((px, py), a, b) for a, b in edges) > RANGE_TOL


def finger_energy(res, force, r1, r2, theta2_min):
    """M6: V = -F [r1 (t1 - 0) + r2 (t2 - theta2_min)]."""
    return -force * (r1 * res["t1"] + r2 * (res["t2"] - theta2_min))


def position_feasible(dx_left, dx_right, py, r):
    """D2, as the map decides it: the disc clear of the palm line and of both fingers' joints."""
    return (py >= r - RANGE_TOL and finger_feasible(dx_left, py, r)
            and finger_feasible(dx_right, py, r))


def class_of_modes(modes):
    """M8: the class of a feasible point from its two fingers' modes, first that applies."""
    if SLIPPED in modes:
        return EJECT
    if VERTEX in modes:
        return VERTEX_POINT
    if modes[0] == FREE and modes[1] == FREE:
        return UNREACHED
    return REACHED


def hand_state(dx_left, dx_right, py, r, solve, f_left, f_right, r1, r2, theta2_min):
    """Both fingers at one part centre given by its finger-frame offsets (M4-M6, M8).

    `solve(dx, dy)` is naive_finger with the design bound, or a pair (left, right) of them when
    the fingers' frictions differ (MODEL 10, Scenario C). Returns (class, energy, fingers);
    an infeasible position is (INFEASIBLE, None, None): it has no energy."""
    if not position_feasible(dx_left, dx_right, py, r):
        return INFEASIBLE, None, None
    solve_left, solve_right = solve if isinstance(solve, tuple) else (solve, solve)
    fingers = (solve_left(dx_left, py), solve_right(dx_right, py))
    energy = (finger_energy(fingers[0], f_left, r1, r2, theta2_min)
              + finger_energy(fingers[1], f_right, r1, r2, theta2_min))
    return class_of_modes([f["mode"] for f in fingers]), energy, fingers


def finger_solver(l1, l2, r1, r2, r, mu, theta2_min, theta2_max, reconfig_step, root_tol):
    """naive_finger with the design bound, memoised on (dx, dy)."""

    @lru_cache(maxsize=None)
    def solve(dx, dy):
        return naive_finger(dx, dy, l1, l2, r1, r2, r, mu, theta2_min, theta2_max,
                            reconfig_step, root_tol)

    return solve


def world_offsets(px, w):
    """(dx_left, dx_right) of a part centre at any x (M2): d = p - J_R, the left one mirrored."""
    return -px - w / 2.0, px - w / 2.0


def naive_point(px, py, l1, l2, r1, r2, w, r, mu, f_left=1.0, f_right=1.0,
                theta2_min=math.radians(-5.0), theta2_max=math.radians(90.0),
                reconfig_step=0.01, root_tol=1e-12, solve=None, mu_left=None, mu_right=None):
    """The model at any part centre (x, y), on or off the grid (D16 step 2): both fingers by
    naive_finger, the class by M8 (INFEASIBLE as naive_map decides it), the energy by M6.
    mu_left, mu_right: each finger's own friction (None: mu).

    Returns a dict: point_class, energy (None where infeasible), fingers (None where infeasible).
    Off the grid the offsets are x -+ w/2 (on the grid naive_map uses D1's exact offsets)."""
    if solve is None:
        solve = tuple(finger_solver(l1, l2, r1, r2, r, mu if m is None else m, theta2_min,
                                    theta2_max, reconfig_step, root_tol)
                      for m in (mu_left, mu_right))
    dx_left, dx_right = world_offsets(px, w)
    cls, energy, fingers = hand_state(dx_left, dx_right, py, r, solve, f_left, f_right, r1, r2,
                                      theta2_min)
    return {"point_class": cls, "energy": energy, "fingers": fingers}


# Neighbour order of the discrete steepest descent: E, NE, N, NW, W, SW, S, SE as (di, dj).
NEIGHBOURS = ((1, 0), (1, 1), (0, 1), (-1, 1), (-1, 0), (-1, -1), (0, -1), (1, -1))
TRAJECTORY_METHODS = ("sliding", "grid8")


def _slide_directions():
    """D16 "Directions": 32 unit vectors, direction k at k 11.25 deg counter-clockwise from E.

    k = 0 .. 8 from cos/sin, with E = (1, 0) and N = (0, 1) exact; the other quadrants by flipping
    signs, so that direction 16 - k (mod 32) is the exact mirror image in x of direction k."""
    quarter = ([(1.0, 0.0)]
               + [(math.cos(k * PI / 16.0), math.sin(k * PI / 16.0)) for k in range(1, 8)]
               + [(0.0, 1.0)])
    directions = []
    for k in range(32):
        if k <= 8:                      # first quadrant
            c, s = quarter[k]
        elif k <= 16:                   # second: mirror of 16 - k
            c, s = quarter[16 - k]
            c = -c
        elif k < 24:                    # third: point reflection of k - 16
            c, s = quarter[k - 16]
            c, s = -c, -s
        else:                           # fourth: mirror in y of 32 - k
            c, s = quarter[32 - k]
            s = -s
        directions.append((c, s))
    return tuple(directions)


SLIDE_DIRECTIONS = _slide_directions()
SLIDE_STEP_DIRECTIONS = tuple(range(0, 32, 4))       # the step's 8: E, NE, N, NW, W, SW, S, SE
SLIDE_REFINEMENTS = 3                                # rotations by +a then -a, a halving
SLIDE_STEP_ROTATION = PI / 8.0                       # a = 22.5, 11.25, 5.6 deg
SLIDE_THOROUGH_ROTATION = PI / 32.0                  # a = 5.6, 2.8, 1.4 deg
# D16 "The cascade": (search, radius as a fraction of h), tried in this order from every position
SLIDE_CASCADE = (("step", 1.0),                      # (a) the step's search on the circle of h
                 ("step", 0.25),                     # (b) the step's search on the circle of h/4
                 ("thorough", 1.0))                  # (c) the thorough search on the circle of h
SLIDE_REL = 1e-12                                    # "lower": E < E_ref - 1e-12 |E_ref|
STEP_RESOLUTION = 0.025                              # D36: Accuracy.step_resolution's default
# D36: the stage of the closing sequence that made a finger's first contact (M4)
CLOSING_STAGE = {EV_PROXIMAL: 0, EV_DISTAL: 1, EV_VERTEX_B: 2, EV_VERTEX_T: 2, EV_NONE: 3}
WALL_MOVES = 4                                       # D36: moves along a wall on h/4's circle
SLIDE_SEARCHES_PER_CELL = 64                         # at most 64 (nx + ny) searches per slide


def strictly_below(e, e_ref):
    """D16's comparison: e < e_ref - 1e-12 |e_ref|."""
    return e < e_ref - SLIDE_REL * abs(e_ref)


class ReferenceGrid:
    """One map's grid (M8, D1) with the model at its points, each computed when first asked for,
    and the trajectory rules (D7 grid8, D16 sliding). naive_map runs it over every point;
    naive_trajectory follows a single start without computing the rest of the map."""

    def __init__(self, l1, l2, r1, r2, w, r, mu, f_left=1.0, f_right=1.0, h=0.05, xlim=None,
                 ylim=None, theta2_min=math.radians(-5.0), theta2_max=math.radians(90.0),
                 reconfig_step=0.01, root_tol=1e-12, trajectory="sliding", mu_left=None,
                 mu_right=None, step_resolution=STEP_RESOLUTION):
        if trajectory not in TRAJECTORY_METHODS:
            raise ValueError(f"trajectory must be one of {TRAJECTORY_METHODS}, "
                             f"not {trajectory!r}")
        self.l1, self.l2, self.r1, self.r2, self.w, self.r, self.mu = l1, l2, r1, r2, w, r, mu
        self.f_left, self.f_right, self.h, self.theta2_min = f_left, f_right, h, theta2_min
        self.trajectory = trajectory
        # D36: steps are sampled only where longer than the resolution (0: never); a grid
        # whose diagonal is not longer samples nothing
        self.resolution = (step_resolution if 0.0 < step_resolution < h * math.sqrt(2.0)
                           else None)

        # --- Grid (M8, D1) -------------------------------------------------------------------
        if xlim is None:
            x_reach = w / 2.0 + l1 + l2 + r
            n_x = math.floor(x_reach / h + GRID_TOL)
            i_lo, i_hi = -n_x, n_x
        else:
            i_lo, i_hi = grid_indices(xlim, h, 0.0)
        if ylim is None:
            y_reach = r + l1 + l2
            j_lo, j_hi = 0, math.floor((y_reach - r) / h + GRID_TOL)
        else:
            j_lo, j_hi = grid_indices(ylim, h, r)
        self.i_range = list(range(i_lo, i_hi + 1))
        self.j_range = list(range(j_lo, j_hi + 1))
        self.x = np.array([i * h for i in self.i_range])
        self.y = np.array([r + j * h for j in self.j_range])
        self.nx, self.ny = len(self.x), len(self.y)
        half = w / (2.0 * h)
        self.s = round(half)
        self.integer_offsets = abs(half - self.s) <= GRID_TOL

        # each finger with its own friction (MODEL 10, Scenario C); the palm keeps mu
        self.mu_left = mu if mu_left is None else mu_left
        self.mu_right = mu if mu_right is None else mu_right
        self.solve = tuple(finger_solver(l1, l2, r1, r2, r, m, theta2_min, theta2_max,
                                         reconfig_step, root_tol)
                           for m in (self.mu_left, self.mu_right))
        self.points = {}          # (j, i) -> the model at that grid point (see point())
        self.slides = {}          # (j, i) -> "rejoined" | "ejection" | "stalled"
        self.slide_ends = {}      # (j, i) -> (x, y, energy) where that slide left off
        self.end_point = {}       # (j, i) -> trajectory result (see trajectory_end())
        self.cascade_moves = [0] * len(SLIDE_CASCADE)   # moves given by each search of D16

    # --- The model at grid points (M4-M8, D1, D5, D6) ------------------------------------------
    def offsets(self, ii):
        """(dx_left, dx_right) of D1 at column ii."""
        i, h = self.i_range[ii], self.h
        if self.integer_offsets:
            return (-i - self.s) * h, (i - self.s) * h
        return -(i * h) - self.w / 2.0, i * h - self.w / 2.0

    def point(self, jj, ii):
        """Everything the map stores at grid point (jj, ii), computed once."""
        rec = self.points.get((jj, ii))
        if rec is None:
            rec = self._compute_point(jj, ii)
            self.points[(jj, ii)] = rec
        return rec

    def _compute_point(self, jj, ii):
        px, py, r, w = self.x[ii], self.y[jj], self.r, self.w
        dx_left, dx_right = self.offsets(ii)
        cls, energy, fingers = hand_state(dx_left, dx_right, py, r, self.solve, self.f_left,
                                          self.f_right, self.r1, self.r2, self.theta2_min)
        rec = {"point_class": cls, "energy": energy, "fingers": fingers, "contained": False,
               "l_open": float("nan"), "crossed": False, "equilibrium": False,
               "stable": False, "caged": False, "caging_score": 0.0}
        if cls == INFEASIBLE:
            return rec                                       # class 0, NaN values (D6)
        pts = [[to_world(p, fi, w) for p in finger_points(res["t1"], res["t2"], self.l1,
                                                          self.l2)]
               for fi, res in enumerate(fingers)]
        (jl, bl, tl), (jr, br, tr) = pts
        rec["contained"] = contained([jl, bl, tl, tr, br, jr], px, py)
        rec["l_open"], rec["crossed"] = opening(pts[0], pts[1])
        if cls == REACHED:
            left, right = contact_normals(fingers[0], 0), contact_normals(fingers[1], 1)
            normals = left + right
            mus = [self.mu_left] * len(left) + [self.mu_right] * len(right)
            if abs(py - r) <= PALM_TOL and abs(px) <= w / 2.0 + PALM_TOL:
                normals.append((0.0, 1.0))
                mus.append(self.mu)
            rec["equilibrium"] = in_equilibrium(normals, mus)
        rec["stable"] = cls == REACHED and rec["equilibrium"]
        rec["caged"] = (rec["stable"] and rec["contained"]
                        and rec["l_open"] < 2.0 * r - RANGE_TOL)
        if rec["caged"]:
            rec["caging_score"] = 1.0 - rec["l_open"] / (2.0 * r)
        return rec

    # --- The model off the grid (D16 step 2) ---------------------------------------------------
    def probe(self, cx, cy, rho, u):
        """(energy, x, y, class) at rho u from (cx, cy); energy None where infeasible."""
        px, py = cx + rho * u[0], cy + rho * u[1]
        dx_left, dx_right = world_offsets(px, self.w)
        cls, energy, _ = hand_state(dx_left, dx_right, py, self.r, self.solve, self.f_left,
                                    self.f_right, self.r1, self.r2, self.theta2_min)
        return energy, px, py, cls

    def refine(self, cx, cy, rho, best, u, a):
        """D16's 3 refinements from `best`, found in direction u: the directions +a (counter-
        clockwise), then -a, from the direction this refinement started from, each replacing
        the best only if strictly lower; a halves each time."""
        for _ in range(SLIDE_REFINEMENTS):
            ux, uy = u                                       # this refinement's centre
            for sign in (1.0, -1.0):
                ca, sa = math.cos(a), sign * math.sin(a)
                v = (ca * ux - sa * uy, sa * ux + ca * uy)   # mirror-exact for mirrored u, -a
                p = self.probe(cx, cy, rho, v)
                if p[0] is not None and p[0] < best[0]:
                    best, u = p, v
            a /= 2.0
        return best

    def step_search(self, cx, cy, rho):
        """D16 "A step's search": the 8 directions (first strictly lowest kept), refined 3 times
        with a = 22.5 deg. None when all 8 points are infeasible."""
        best = u_best = None
        for k in SLIDE_STEP_DIRECTIONS:
            u = SLIDE_DIRECTIONS[k]
            p = self.probe(cx, cy, rho, u)
            if p[0] is not None and (best is None or p[0] < best[0]):
                best, u_best = p, u
        if best is None:
            return None
        return self.refine(cx, cy, rho, best, u_best, SLIDE_STEP_ROTATION)

    def thorough_search(self, cx, cy, rho):
        """D16 "thorough search" on one circle: the 32 directions (first strictly lowest kept),
        then around every direction k with a finite energy <= both its cyclic neighbours, in
        order of k, the 3 refinements with a = 5.625 deg, each refinement's result replacing the
        best so far only if strictly lower. None when all 32 points are infeasible."""
        probes = [self.probe(cx, cy, rho, u) for u in SLIDE_DIRECTIONS]
        best = None
        for p in probes:
            if p[0] is not None and (best is None or p[0] < best[0]):
                best = p
        if best is None:
            return None
        e = [math.inf if p[0] is None else p[0] for p in probes]
        n = len(probes)
        for k in range(n):
            if math.isfinite(e[k]) and e[k] <= e[k - 1] and e[k] <= e[(k + 1) % n]:
                result = self.refine(cx, cy, rho, probes[k], SLIDE_DIRECTIONS[k],
                                     SLIDE_THOROUGH_ROTATION)
                if result[0] < best[0]:
                    best = result
        return best

    # --- Trajectories (M8, D7, D16, D36) -------------------------------------------------------
    def lower_neighbours(self, jj, ii):
        """The strictly lower feasible neighbours, steepest first (ties: D7's order)."""
        e = self.point(jj, ii)["energy"]
        found = []
        for order, (di, dj) in enumerate(NEIGHBOURS):
            ni, nj = ii + di, jj + dj
            if not (0 <= ni < self.nx and 0 <= nj < self.ny):
                continue
            other = self.point(nj, ni)
            if other["point_class"] == INFEASIBLE:
                continue
            dist = self.h if (di == 0 or dj == 0) else self.h * math.sqrt(2.0)
            slope = (e - other["energy"]) / dist
            if slope > 0.0:
                found.append((-slope, order, (nj, ni)))
        return [c for _, _, c in sorted(found)]

    def successor(self, jj, ii):
        """D7 / D16 step 1: the steepest strictly lower feasible neighbour, or None. With step
        checks (D36): the steepest whose step is clear, or ("leaves", grid point) where a step
        leaves P_j first."""
        lower = self.lower_neighbours(jj, ii)
        if self.resolution is None:
            return lower[0] if lower else None
        for nj, ni in lower:
            if self.stages(jj, ii) == self.stages(nj, ni):
                return (nj, ni)
            kind, px, py = self.step_check(self.x[ii], self.y[jj], self.point(jj, ii)["energy"],
                                           self.x[ni], self.y[nj])
            if kind == "clear":
                return (nj, ni)
            if kind == "leaves":
                return ("leaves", self.nearest_grid_point(px, py))
        return None

    def stages(self, jj, ii):
        """D36: each finger's closing stage (CLOSING_STAGE) at a grid point, from M4.2's rigid
        sweep at the point's finger-frame offsets."""
        dy = self.y[jj]
        return tuple(CLOSING_STAGE[rigid_sweep(dx, dy, self.l1, self.l2, self.r,
                                               self.theta2_min)[0]]
                     for dx in self.offsets(ii))

    def step_check(self, x0, y0, e_top, x1, y1):
        """D36: the model at n - 1 evenly spaced points strictly between the two ends, n the
        least whole number with length / n <= the resolution: ("blocked", x, y) at the first
        point whose energy is above e_top (or infeasible), ("leaves", x, y) at the first point
        outside P_j, else ("clear", x1, y1)."""
        length = math.hypot(x1 - x0, y1 - y0)
        n = math.ceil(length / self.resolution - 1e-9)
        for k in range(1, n):
            t = k / n
            px, py = x0 + (x1 - x0) * t, y0 + (y1 - y0) * t
            energy, _, _, cls = self.probe(px, py, 0.0, (0.0, 0.0))
            if energy is None or energy > e_top:
                return "blocked", px, py
            if cls != REACHED:
                return "leaves", px, py
        return "clear", x1, y1

    def nearest_grid_point(self, px, py):
        """The grid point nearest to a position (clamped into the grid)."""
        ii = min(max(math.floor((px - self.x[0]) / self.h + 0.5), 0), self.nx - 1)
        jj = min(max(math.floor((py - self.y[0]) / self.h + 0.5), 0), self.ny - 1)
        return (jj, ii)

    def slide_move(self, px, py, e_here, searches_left, along_wall=False):
        """One move of a slide from (px, py), D16 "The cascade": (a) the step's search on the
        circle of h, (b) the step's search on the circle of h/4, (c) the thorough search on the
        circle of h; the first that finds a point strictly below e_here gives the move. Each
        search counts one against the budget; stops early (no move) when it runs out.

        With step checks (D36) a search's point counts only if the straight move to it is clear;
        a move that leaves P_j on the way is ("leaves", x, y).

        `along_wall` (D36): a step of (a) was blocked within the last WALL_MOVES moves; (a) is
        skipped.

        Returns (move or None, searches used, stage, whether (a)'s point was blocked); a move is
        (energy, x, y, class), stage the index in SLIDE_CASCADE of the search that gave it (None
        without a move)."""
        searches = {"step": self.step_search, "thorough": self.thorough_search}
        used = 0
        blocked = False
        for stage, (kind, fraction) in enumerate(SLIDE_CASCADE):
            if stage == 0 and along_wall:
                continue
            if used == searches_left:
                break
            used += 1
            best = searches[kind](px, py, fraction * self.h)
            if best is not None and strictly_below(best[0], e_here):
                if self.resolution is not None:
                    check, gx, gy = self.step_check(px, py, e_here, best[1], best[2])
                    if check == "blocked":
                        blocked = blocked or stage == 0
                        continue
                    if check == "leaves":
                        return ("leaves", gx, gy), used, stage, blocked
                return best, used, stage, blocked
        return None, used, None, blocked

    def slide(self, jj, ii):
        """D16 step 2 from the grid point (jj, ii), where no neighbour is lower.

        Returns ("corner", (j, i)): the trajectory rejoins the grid there; or
        ("end", end_state, (j, i), (x, y, energy)): it ends EJECTION or stalled with that end
        point, the part having stopped at (x, y)."""
        e_start = self.point(jj, ii)["energy"]
        px, py, e_here = self.x[ii], self.y[jj], e_start
        x0, y0, h, nx, ny = self.x[0], self.y[0], self.h, self.nx, self.ny
        searches_left = SLIDE_SEARCHES_PER_CELL * (nx + ny)  # defence in depth (D16)
        wall = 0                            # D36: moves of (b) left before (a) is tried again
        while True:
            move, used, stage, blocked = self.slide_move(px, py, e_here, searches_left,
                                                         along_wall=wall > 0)
            searches_left -= used
            if blocked:
                wall = WALL_MOVES
            if stage == 1 and wall > 0:
                wall -= 1
            if stage is not None:
                self.cascade_moves[stage] += 1
            if move is None:                                 # nothing lower, or no budget
                self.slides[(jj, ii)] = "stalled"
                self.slide_ends[(jj, ii)] = (px, py, e_here)
                return "end", END_STALLED, self.nearest_grid_point(px, py), (px, py, e_here)
            if move[0] == "leaves":                          # D36: the move left P_j
                _, gx, gy = move
                self.slides[(jj, ii)] = "ejection"
                self.slide_ends[(jj, ii)] = (gx, gy, e_here)
                return "end", END_EJECTION, self.nearest_grid_point(gx, gy), (gx, gy, e_here)
            e_here, px, py, cls_here = move
            inside = (-h / 2.0 <= px - x0 < (nx - 0.5) * h
                      and -h / 2.0 <= py - y0 < (ny - 0.5) * h)
            if cls_here != REACHED or not inside:
                self.slides[(jj, ii)] = "ejection"
                self.slide_ends[(jj, ii)] = (px, py, e_here)
                return "end", END_EJECTION, self.nearest_grid_point(px, py), (px, py, e_here)
            ci, cj = math.floor((px - x0) / h), math.floor((py - y0) / h)
            corners = [(kj, ki) for ki, kj in ((ci, cj), (ci + 1, cj), (ci, cj + 1),
                                               (ci + 1, cj + 1))
                       if 0 <= ki < nx and 0 <= kj < ny
                       and self.point(kj, ki)["point_class"] == REACHED]
            if self.resolution is not None:              # D36: corners in reach in a line
                corners = [c for c in corners
                           if (self.point(*c)["stable"]
                               or strictly_below(self.point(*c)["energy"], e_start))
                           and self.step_check(px, py, max(e_here, self.point(*c)["energy"]),
                                               self.x[c[1]], self.y[c[0]])[0] == "clear"]
            chosen = next((c for c in corners if self.point(*c)["stable"]), None)
            if chosen is None:
                for c in corners:
                    e_c = self.point(*c)["energy"]
                    if strictly_below(e_c, e_start) and (
                            chosen is None or e_c < self.point(*chosen)["energy"]):
                        chosen = c
            if chosen is not None:
                self.slides[(jj, ii)] = "rejoined"
                self.slide_ends[(jj, ii)] = (px, py, e_here)
                return "corner", chosen

    def trajectory_end(self, jj, ii):
        """(end_state, end point (j, i), (x, y, energy) where the part stopped) of the
        trajectory from a grid point."""
        path = []
        cur = (jj, ii)
        while True:
            if cur in self.end_point:
                result = self.end_point[cur]
                break
            cj, ci = cur
            rec = self.point(cj, ci)
            here = (self.x[ci], self.y[cj], rec["energy"])
            if rec["point_class"] != REACHED:
                result = (END_EJECTION, cur, here)
                break
            if rec["stable"]:             # also a STABLE corner above the slide's start (D16 3)
                result = (END_CAGED if rec["caged"] else END_TIP_PREHENSION, cur, here)
                break
            nxt = self.successor(cj, ci)
            if nxt is not None and nxt[0] == "leaves":       # D36: the step left P_j
                path.append(cur)
                result = (END_EJECTION, nxt[1], here)
                break
            if nxt is None and self.trajectory == "sliding":
                outcome = self.slide(cj, ci)
                if outcome[0] == "corner":
                    nxt = outcome[1]
                else:
                    path.append(cur)
                    result = outcome[1:]
                    break
            if nxt is None:
                result = (END_STALLED, cur, here)
                break
            path.append(cur)
            cur = nxt
        for p in path:
            self.end_point[p] = result
        self.end_point[cur] = result
        return result


def naive_map(l1, l2, r1, r2, w, r, mu, f_left=1.0, f_right=1.0, h=0.05, xlim=None, ylim=None,
              theta2_min=math.radians(-5.0), theta2_max=math.radians(90.0),
              reconfig_step=0.01, root_tol=1e-12, trajectory="sliding", mu_left=None,
              mu_right=None, step_resolution=STEP_RESOLUTION):
    """One energy map, point by point (M8). Arrays on (y, x) and (finger, y, x).

    trajectory: "sliding" (D16, the kernels' default) or "grid8" (D7, the paper-like descent).
    Besides the fields, "end_index" (flat (y, x) index of each start's end point, -1 off P_j),
    "slides" ({(j, i): "rejoined" | "ejection" | "stalled"}, one entry per grid stall that slid;
    empty for grid8) and "slide_ends" ({(j, i): (x, y, energy)}: where each slide left off, for a
    stalled one where the part stopped) and "cascade_moves" (moves of all slides given by each
    search of D16's cascade, in the order of SLIDE_CASCADE). mu_left, mu_right: each finger's
    own contact friction (MODEL 10, Scenario C; None: mu); the palm keeps mu."""
    grid = ReferenceGrid(l1, l2, r1, r2, w, r, mu, f_left, f_right, h, xlim, ylim, theta2_min,
                         theta2_max, reconfig_step, root_tol, trajectory, mu_left, mu_right,
                         step_resolution)
    x, y, nx, ny = grid.x, grid.y, grid.nx, grid.ny

    nan = float("nan")
    shape = (ny, nx)
    out = {
        "x": x, "y": y,
        "energy": np.full(shape, nan),
        "point_class": np.zeros(shape, dtype=np.int64),
        "end_state": np.zeros(shape, dtype=np.int64),
        "equilibrium": np.zeros(shape, dtype=bool),
        "contained": np.zeros(shape, dtype=bool),
        "l_open": np.full(shape, nan),
        "caging_score": np.zeros(shape),
        "finger_mode": np.zeros((2,) + shape, dtype=np.int64),
        "theta1": np.full((2,) + shape, nan),
        "theta2": np.full((2,) + shape, nan),
        "k1": np.full((2,) + shape, nan),
        "k2": np.full((2,) + shape, nan),
        "tip_overlap": np.zeros((2,) + shape, dtype=bool),
        "end_index": np.full(shape, -1, dtype=np.int64),
    }
    caged_and_crossed = 0

    # --- Per point: configurations, energy, class, equilibrium, containment, opening -------
    for jj in range(ny):
        for ii in range(nx):
            rec = grid.point(jj, ii)
            if rec["point_class"] == INFEASIBLE:
                continue                                    # class 0, NaN values (D6)
            for fi, res in enumerate(rec["fingers"]):
                out["finger_mode"][fi, jj, ii] = res["mode"]
                out["theta1"][fi, jj, ii] = res["t1"]
                out["theta2"][fi, jj, ii] = res["t2"]
                out["k1"][fi, jj, ii] = res["k1"]
                out["k2"][fi, jj, ii] = res["k2"]
                out["tip_overlap"][fi, jj, ii] = res["tip_overlap"]
            for key in ("energy", "point_class", "contained", "l_open", "equilibrium",
                        "caging_score"):
                out[key][jj, ii] = rec[key]
            caged_and_crossed += rec["caged"] and rec["crossed"]

    # --- Trajectories: discrete steepest descent (M8, D7) and sliding (D16) ------------------
    counts = {END_CAGED: 0, END_TIP_PREHENSION: 0, END_EJECTION: 0, END_STALLED: 0}
    lam = palm = 0.0
    for jj in range(ny):
        for ii in range(nx):
            if out["point_class"][jj, ii] != REACHED:
                out["end_state"][jj, ii] = END_NONE
                continue
            state, (ej, ei), _ = grid.trajectory_end(jj, ii)
            out["end_state"][jj, ii] = state
            out["end_index"][jj, ii] = ej * nx + ei
            counts[state] += 1
            if state == END_CAGED:
                lam += out["caging_score"][ej, ei]
                if abs(y[jj] - r) <= PALM_TOL:       # D36: the palm row is half a cell
                    palm += out["caging_score"][ej, ei]

    out["Lambda"] = lam
    out["caging_area"] = (lam - 0.5 * palm) * h * h
    out["n_caged"] = counts[END_CAGED]
    out["n_tip_prehension"] = counts[END_TIP_PREHENSION]
    out["n_ejection"] = counts[END_EJECTION]
    out["n_stalled"] = counts[END_STALLED]
    out["n_crossed_caged"] = int(caged_and_crossed)
    out["slides"] = grid.slides
    out["slide_ends"] = grid.slide_ends
    out["cascade_moves"] = grid.cascade_moves
    return out


def naive_trajectory(start, l1, l2, r1, r2, w, r, mu, f_left=1.0, f_right=1.0, h=0.05,
                     xlim=None, ylim=None, theta2_min=math.radians(-5.0),
                     theta2_max=math.radians(90.0), reconfig_step=0.01, root_tol=1e-12,
                     trajectory="sliding", mu_left=None, mu_right=None,
                     step_resolution=STEP_RESOLUTION):
    """The trajectory of one start of naive_map's grid (same arguments; start = (x, y), a grid
    point), computing only the grid points it visits or looks at.

    Returns a dict: end_state, end_index (flat (y, x) index; END_NONE and -1 off P_j), stop
    ((x, y, energy) where the part stopped: off the grid for a slide that stalled or ejected;
    None off P_j), slides, slide_ends and cascade_moves (as naive_map's, for the slides on the
    way)."""
    grid = ReferenceGrid(l1, l2, r1, r2, w, r, mu, f_left, f_right, h, xlim, ylim, theta2_min,
                         theta2_max, reconfig_step, root_tol, trajectory, mu_left, mu_right,
                         step_resolution)
    ii = int(np.argmin(np.abs(grid.x - start[0])))
    jj = int(np.argmin(np.abs(grid.y - start[1])))
    if abs(grid.x[ii] - start[0]) > GRID_TOL * h or abs(grid.y[jj] - start[1]) > GRID_TOL * h:
        raise ValueError(f"start {start!r} is not a point of the grid")
    out = {"slides": grid.slides, "slide_ends": grid.slide_ends,
           "cascade_moves": grid.cascade_moves}
    if grid.point(jj, ii)["point_class"] != REACHED:
        return {"end_state": END_NONE, "end_index": -1, "stop": None, **out}
    state, (ej, ei), stop = grid.trajectory_end(jj, ii)
    return {"end_state": state, "end_index": ej * grid.nx + ei, "stop": stop, **out}
