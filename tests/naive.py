"""Slow, independent reference implementation of the model, for the tests.

Written straight from the model (``docs/model.md``, which keeps the section numbers of the
project's authoritative MODEL.md) and ``docs/model-notes.md`` (D1-D10) without looking at the
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


def proximal_tangency(dx, dy, l1, r):
    """M3.1 with its validity checks. Returns (t1, k1) clamped into range, or None."""
    k1 = tangent_length(dx * dx + dy * dy, r)
    if k1 is None:
        return None
    t1 = math.atan2(dy, dx) - math.atan2(r, k1)
    if in_range(k1, 0.0, l1) and in_range(t1, 0.0, PI):
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
    """M3.2 with its validity checks. Returns (t2, k2) clamped into range, or None."""
    ex = dx - l1 * math.cos(t1)
    ey = dy - l1 * math.sin(t1)
    k2 = tangent_length(ex * ex + ey * ey, r)
    if k2 is None:
        return None
    t2 = wrap(math.atan2(ey, ex) - math.atan2(r, k2) - t1)
    if in_range(k2, 0.0, l2) and in_range(t2, th2_min, th2_max):
        return clamp(t2, th2_min, th2_max), clamp(k2, 0.0, l2)
    return None


def rigid_distal_tangency(dx, dy, l1, l2, r, th2_min):
    """M3.3: distal tangency during the rigid sweep (t2 = theta2_min). Returns (t1, k2) or None."""
    r_prime = r + l1 * math.sin(-th2_min)
    dist2 = dx * dx + dy * dy
    if dist2 < r_prime * r_prime * (1.0 - TOUCH_REL):
        return None
    dist = math.sqrt(dist2)
    alpha = math.atan2(dy, dx)
    phi = alpha - math.asin(min(r_prime / dist, 1.0))
    t1 = phi - th2_min
    k2 = dist * math.cos(alpha - phi) - l1 * math.cos(th2_min)
    if in_range(k2, 0.0, l2) and in_range(t1, 0.0, PI):
        return clamp(t1, 0.0, PI), clamp(k2, 0.0, l2)
    return None


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
    strikes = []
    tb = vertex_entry(dx, dy, l1, r, 0.0)
    if tb is not None and in_range(tb, 0.0, PI):
        strikes.append((clamp(tb, 0.0, PI), 0, EV_VERTEX_B))
    tip_x = l1 + l2 * math.cos(th2_min)
    tip_y = l2 * math.sin(th2_min)
    tt = vertex_entry(dx, dy, math.hypot(tip_x, tip_y), r, math.atan2(tip_y, tip_x))
    if tt is not None and in_range(tt, 0.0, PI):
        strikes.append((clamp(tt, 0.0, PI), 1, EV_VERTEX_T))
    first_strike = min(strikes) if strikes else None   # B before T on an exact tie (D3)

    tan = rigid_distal_tangency(dx, dy, l1, l2, r, th2_min)
    if tan is not None and (first_strike is None or tan[0] <= first_strike[0] + RANGE_TOL):
        return EV_DISTAL, tan[0], tan[1]               # tangency wins ties (D3)
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
    # and events that start in the same step, are bisected to 1e-12 whatever root_tol (D16).
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
    """M7: origin in the convex hull of the friction-cone edges <=> no angular gap > pi + 1e-9."""
    if len(normals) < 2:
        return False
    angles = []
    for nx, ny in normals:
        tx, ty = -ny, nx                       # t = rot90(n)
        for s in (1.0, -1.0):
            angles.append(math.atan2(ny + s * mu * ty, nx + s * mu * tx))
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


# Neighbour order of the discrete steepest descent: E, NE, N, NW, W, SW, S, SE as (di, dj).
NEIGHBOURS = ((1, 0), (1, 1), (0, 1), (-1, 1), (-1, 0), (-1, -1), (0, -1), (1, -1))


def naive_map(l1, l2, r1, r2, w, r, mu, f_left=1.0, f_right=1.0, h=0.05, xlim=None, ylim=None,
              theta2_min=math.radians(-5.0), theta2_max=math.radians(90.0),
              reconfig_step=0.01, root_tol=1e-12):
    """One energy map, point by point (M8). Arrays on (y, x) and (finger, y, x)."""

    # --- Grid (M8, D1) -----------------------------------------------------------------------
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
    i_range = list(range(i_lo, i_hi + 1))
    j_range = list(range(j_lo, j_hi + 1))
    x = np.array([i * h for i in i_range])
    y = np.array([r + j * h for j in j_range])
    nx, ny = len(x), len(y)

    half = w / (2.0 * h)
    s = round(half)
    integer_offsets = abs(half - s) <= GRID_TOL

    def offsets(i):
        """(dx_left, dx_right) of D1."""
        if integer_offsets:
            return (-i - s) * h, (i - s) * h
        return -(i * h) - w / 2.0, i * h - w / 2.0

    @lru_cache(maxsize=None)
    def solve(dx, dy):
        return naive_finger(dx, dy, l1, l2, r1, r2, r, mu, theta2_min, theta2_max,
                            reconfig_step, root_tol)

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
    }
    stable = np.zeros(shape, dtype=bool)
    caged = np.zeros(shape, dtype=bool)
    crossed = np.zeros(shape, dtype=bool)

    # --- Per point: configurations, energy, class, equilibrium, containment, opening -------
    for jj, _j in enumerate(j_range):
        py = y[jj]
        for ii, i in enumerate(i_range):
            px = x[ii]
            dx_left, dx_right = offsets(i)
            feasible = (py >= r - RANGE_TOL and finger_feasible(dx_left, py, r)
                        and finger_feasible(dx_right, py, r))
            if not feasible:
                continue                                    # class 0, NaN values (D6)
            fingers = (solve(dx_left, py), solve(dx_right, py))
            modes = [f["mode"] for f in fingers]
            for fi, res in enumerate(fingers):
                out["finger_mode"][fi, jj, ii] = res["mode"]
                out["theta1"][fi, jj, ii] = res["t1"]
                out["theta2"][fi, jj, ii] = res["t2"]
                out["k1"][fi, jj, ii] = res["k1"]
                out["k2"][fi, jj, ii] = res["k2"]
                out["tip_overlap"][fi, jj, ii] = res["tip_overlap"]
            out["energy"][jj, ii] = (finger_energy(fingers[0], f_left, r1, r2, theta2_min)
                                     + finger_energy(fingers[1], f_right, r1, r2, theta2_min))

            if SLIPPED in modes:
                cls = EJECT
            elif VERTEX in modes:
                cls = VERTEX_POINT
            elif modes[0] == FREE and modes[1] == FREE:
                cls = UNREACHED
            else:
                cls = REACHED
            out["point_class"][jj, ii] = cls

            pts = [[to_world(p, fi, w) for p in finger_points(res["t1"], res["t2"], l1, l2)]
                   for fi, res in enumerate(fingers)]
            (jl, bl, tl), (jr, br, tr) = pts
            out["contained"][jj, ii] = contained([jl, bl, tl, tr, br, jr], px, py)
            l_open, crossed[jj, ii] = opening(pts[0], pts[1])
            out["l_open"][jj, ii] = l_open

            if cls == REACHED:
                normals = contact_normals(fingers[0], 0) + contact_normals(fingers[1], 1)
                if abs(py - r) <= PALM_TOL and abs(px) <= w / 2.0 + PALM_TOL:
                    normals.append((0.0, 1.0))
                out["equilibrium"][jj, ii] = in_equilibrium(normals, mu)
            stable[jj, ii] = cls == REACHED and out["equilibrium"][jj, ii]
            caged[jj, ii] = (stable[jj, ii] and out["contained"][jj, ii]
                             and l_open < 2.0 * r - RANGE_TOL)
            if caged[jj, ii]:
                out["caging_score"][jj, ii] = 1.0 - l_open / (2.0 * r)

    # --- Trajectories: discrete steepest descent (M8, D7) ---------------------------------
    cls = out["point_class"]
    energy = out["energy"]
    in_pj = cls == REACHED

    def successor(jj, ii):
        best, best_slope = None, 0.0
        for di, dj in NEIGHBOURS:
            ni, nj = ii + di, jj + dj
            if not (0 <= ni < nx and 0 <= nj < ny) or cls[nj, ni] == INFEASIBLE:
                continue
            dist = h if (di == 0 or dj == 0) else h * math.sqrt(2.0)
            slope = (energy[jj, ii] - energy[nj, ni]) / dist
            if slope > best_slope:
                best, best_slope = (nj, ni), slope
        return best

    end_point = {}

    def trajectory_end(jj, ii):
        """(end_state, end point) of the trajectory starting at a P_j point."""
        path = []
        cur = (jj, ii)
        while True:
            if cur in end_point:
                result = end_point[cur]
                break
            cj, ci = cur
            if not in_pj[cj, ci]:
                result = (END_EJECTION, cur)
                break
            if stable[cj, ci]:
                result = (END_CAGED if caged[cj, ci] else END_TIP_PREHENSION, cur)
                break
            nxt = successor(cj, ci)
            if nxt is None:
                result = (END_STALLED, cur)
                break
            path.append(cur)
            cur = nxt
        for p in path:
            end_point[p] = result
        end_point[cur] = result
        return result

    counts = {END_CAGED: 0, END_TIP_PREHENSION: 0, END_EJECTION: 0, END_STALLED: 0}
    lam = 0.0
    for jj in range(ny):
        for ii in range(nx):
            if not in_pj[jj, ii]:
                out["end_state"][jj, ii] = END_NONE
                continue
            state, (ej, ei) = trajectory_end(jj, ii)
            out["end_state"][jj, ii] = state
            counts[state] += 1
            if state == END_CAGED:
                lam += out["caging_score"][ej, ei]

    out["Lambda"] = lam
    out["n_caged"] = counts[END_CAGED]
    out["n_tip_prehension"] = counts[END_TIP_PREHENSION]
    out["n_ejection"] = counts[END_EJECTION]
    out["n_stalled"] = counts[END_STALLED]
    out["n_crossed_caged"] = int(np.count_nonzero(caged & crossed))
    return out
