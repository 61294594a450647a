"""Slow, independent reference of the `tip_contact` effect (docs/model-notes.md D15), for tests.

Written from the specification (D15, MODEL 4-5.3, D3, D4), not from the fast kernels. Plain
Python + NumPy + SciPy. It reuses the base model's reference functions of tests/naive.py (rigid
sweep, distal closing, reconfiguration path, grid, equilibrium, containment, ...) and adds:

- `finger_holds`: MODEL 5.1 feasibility as D15 states it (tau is a non-negative combination of
  the cone-edge columns of the contacts and the engaged stops), solved as a linear program with
  `scipy.optimize.linprog` (the kernel uses closed forms);
- `naive_tip_finger`: the closing sequence of D15 (cases 1-5) and the tip path;
- `naive_tip_map`: naive.naive_map with the tip finger and tip contacts in part equilibrium.

Frames as in naive.py: everything is in the right finger's frame, J = (0, 0), d = p - J.

Where D15 leaves a detail open, this reference decides (the kernel agrees on all but the second):
- "lost" because the tip's circle about J misses the disc uses MODEL 4's vertex function with
  D3's graze rule (acos argument >= 1 - 1e-12), the function the tip path's t1(t2) comes from;
- the tip path's stops: nodes t2_0 + n step with the last one clamped to theta2_max, so the
  distal stop ends exactly at t2 = theta2_max (as D4's proximal stop ends exactly at t1 = 0);
  the proximal stop holds when t1 leaves [0, pi] by more than the model's slack (D2: every
  range inclusive by 1e-12), and the state is reported with t1 clamped onto the stop;
- a tip path that loses the part is SLIPPED at the bracket end with contact, k1 = 0, k2 = l2;
- cases 2-4 count a joint as resting on a stop within 1e-12 (D2) of its limit.
"""
from __future__ import annotations

import math
from contextlib import contextmanager

import numpy as np
from scipy.optimize import linprog

import naive
from naive import (
    CL_TANGENT, CL_TIP, EV_DISTAL, EV_NONE, EV_PROXIMAL, EV_VERTEX_B, EV_VERTEX_T, PI,
    RANGE_TOL, close_distal, finger_feasible, g_max, lower_stop_admissible, reconfigure,
    rigid_sweep, vertex_entry, wrap,
)
from sweep.model import DISTAL_ONLY, FREE, PROXIMAL_ONLY, SLIPPED, TWO_PHALANX

# New final modes of D15 (stored codes, only with the effect); spelled out from the text.
TIP_ONLY = 6
PROXIMAL_TIP = 7

# Stop columns of D15 (which sign of torque each stop can supply).
STOP_COLUMNS = {
    "proximal_lower": (-1.0, 0.0),   # t1 = 0: closing
    "proximal_upper": (1.0, 0.0),    # t1 = pi: opening
    "distal_lower": (0.0, -1.0),     # t2 = theta2_min: closing
    "distal_upper": (0.0, 1.0),      # t2 = theta2_max: opening
}

HOLD_TOL = 1e-9   # finger_holds: residual of the best non-negative combination (unit columns)


# ---------------------------------------------------------------------------------------------
# Small vector helpers (2-D)
# ---------------------------------------------------------------------------------------------
def cross(u, v) -> float:
    """u x v = u_x v_y - u_y v_x (MODEL 5.1)."""
    return u[0] * v[1] - u[1] * v[0]


def rot90(v):
    return (-v[1], v[0])


def sub(u, v):
    return (u[0] - v[0], u[1] - v[1])


def finger_geometry(t1, t2, l1, l2):
    """B, T, a_x, b_x in the finger frame (MODEL 2)."""
    ax = (math.cos(t1), math.sin(t1))
    bx = (math.cos(t1 + t2), math.sin(t1 + t2))
    B = (l1 * ax[0], l1 * ax[1])
    T = (B[0] + l2 * bx[0], B[1] + l2 * bx[1])
    return B, T, ax, bx


def unit(v):
    n = math.hypot(v[0], v[1])
    return (v[0] / n, v[1] / n)


# ---------------------------------------------------------------------------------------------
# MODEL 5.1 / D15: does the finger hold?
# ---------------------------------------------------------------------------------------------
def contact_column(c, e, on_distal, B):
    """Column (c x e, (c - B) x e) of a force direction e at finger point c (D15); the second
    entry only for a contact on the distal link."""
    second = cross(sub(c, B), e) if on_distal else 0.0
    return (cross(c, e), second)


def holds_columns(contacts, stops, mu_s, B=None):
    """All columns of D15's cone: both friction-cone edges n +- mu_s t of each contact and one
    column per engaged stop."""
    cols = []
    for c, n, on_distal in contacts:
        if on_distal and B is None:
            raise ValueError("a distal contact needs B")
        t = rot90(n)
        for s in (1.0, -1.0):
            e = (n[0] + s * mu_s * t[0], n[1] + s * mu_s * t[1])
            cols.append(contact_column(c, e, on_distal, B))
    for name in stops:
        cols.append(STOP_COLUMNS[name])
    return cols


def finger_holds(tau, contacts, stops, mu_s, B=None, tol=HOLD_TOL) -> bool:
    """MODEL 5.1 as D15 states it: tau is a non-negative combination of the contacts' cone-edge
    columns and the engaged stops' columns.

    contacts: iterable of (c, n, on_distal): finger-frame point, unit normal (finger on part),
    whether the point is on the distal link (then B, the distal joint, is needed). stops: names
    of STOP_COLUMNS. Decided by linear programming: minimise the L1 residual of
    sum lambda_j col_j - tau over lambda >= 0 with unit columns and unit tau; holds iff the
    residual is <= tol.
    """
    tau = np.asarray(tau, dtype=float)
    tau_norm = float(np.hypot(*tau))
    if tau_norm == 0.0:
        return True
    cols = [np.asarray(c, dtype=float) for c in holds_columns(contacts, stops, mu_s, B)]
    cols = [c / np.hypot(*c) for c in cols if np.hypot(*c) > 1e-300]
    if not cols:
        return False
    A = np.array(cols).T                       # 2 x m
    m = A.shape[1]
    # variables: lambda (m), s_plus (2), s_minus (2); A lambda + s+ - s- = tau / |tau|
    A_eq = np.hstack([A, np.eye(2), -np.eye(2)])
    cost = np.concatenate([np.zeros(m), np.ones(4)])
    res = linprog(cost, A_eq=A_eq, b_eq=tau / tau_norm, bounds=[(0, None)] * (m + 4),
                  method="highs",
                  options={"primal_feasibility_tolerance": 1e-10,
                           "dual_feasibility_tolerance": 1e-10})
    if res.status != 0:
        raise RuntimeError(f"linprog failed: {res.message}")
    lam = res.x[:m]
    residual = float(np.abs(A @ lam - tau / tau_norm).sum())   # re-measured, not the LP's value
    return residual <= tol


def tip_contact(dx, dy, t1, t2, l1, l2):
    """The tip as a contact (D15): (T, n, on_distal=True) with n = (d - T) / |d - T|, and B."""
    B, T, _, _ = finger_geometry(t1, t2, l1, l2)
    return (T, unit(sub((dx, dy), T)), True), B


def tip_columns(dx, dy, t1, t2, l1, l2):
    """c_n and c_t of D15: the tip's columns for its normal and its tangent."""
    (T, n, _), B = tip_contact(dx, dy, t1, t2, l1, l2)
    t = rot90(n)
    return contact_column(T, n, True, B), contact_column(T, t, True, B)


def engaged_stops(t1, t2, theta2_min, theta2_max):
    """Stops a configuration rests on (within the model's range slack)."""
    stops = []
    if abs(t1) <= RANGE_TOL:
        stops.append("proximal_lower")
    if abs(t1 - PI) <= RANGE_TOL:
        stops.append("proximal_upper")
    if abs(t2 - theta2_min) <= RANGE_TOL:
        stops.append("distal_lower")
    if abs(t2 - theta2_max) <= RANGE_TOL:
        stops.append("distal_upper")
    return stops


# ---------------------------------------------------------------------------------------------
# The tip path (D15)
# ---------------------------------------------------------------------------------------------
def tip_entry_t2(dx, dy, t1, l1, l2, r):
    """The tip's entry angle into the disc about B with t1 fixed (MODEL 4's vertex formula with
    rho = l2, delta = 0; the base model's tip_overlap function), as t2; None if the tip's circle
    about B misses the disc. Where cases 3 and 4 start the tip path."""
    ex = dx - l1 * math.cos(t1)
    ey = dy - l1 * math.sin(t1)
    phi = vertex_entry(ex, ey, l2, r, 0.0)
    if phi is None:
        return None
    return wrap(phi - t1)


def tip_strike_t1(dx, dy, t2, l1, l2, r):
    """t1(t2) of the tip path: where the finger with distal angle t2, turning about J, first
    meets the disc with its tip (MODEL 4's vertex formula with the tip's radius
    rho = |l1 + l2 e^(i t2)| and polar offset delta = arg(l1 + l2 e^(i t2)); at theta2_min the
    rigid sweep's strike). None if the tip's circle about J misses the disc (D3's graze rule)."""
    tx = l1 + l2 * math.cos(t2)
    ty = l2 * math.sin(t2)
    return vertex_entry(dx, dy, math.hypot(tx, ty), r, math.atan2(ty, tx))


TIP_EVENTS = ("stick", "distal_stop", "proximal_stop", "lost")   # also the tie order


def normal_force(tau, c_n, c_t):
    """F of tau = F c_n + G c_t (G = F mu), solved as a 2 x 2 linear system (numpy); +inf where
    c_n and c_t are parallel (links aligned), which D15 does not treat specially."""
    a = np.array([[c_n[0], c_t[0]], [c_n[1], c_t[1]]])
    if abs(np.linalg.det(a)) < 1e-300:
        return math.inf
    return float(np.linalg.solve(a, np.asarray(tau, dtype=float))[0])


def proximal_gap(dx, dy, t1, l1, r) -> float:
    """D21: the proximal link's distance from the centre over r, less 1 (< 0: inside)."""
    B = (l1 * math.cos(t1), l1 * math.sin(t1))
    s = min(max((dx * B[0] + dy * B[1]) / (l1 * l1), 0.0), 1.0)
    return math.hypot(dx - s * B[0], dy - s * B[1]) / r - 1.0


def link_enters_before_tip(dx, dy, t1, t2, l1, l2, r) -> bool:
    """D20: the distal link's points just before the tip lie inside the disc (the link would cut
    through the part): the tip's distance to the centre grows along the link towards the tip,
    d/de |T - e u - d|^2 at e = 0 is -2 u . (T - d) < 0, beyond the model's slack."""
    B, T, _, _ = finger_geometry(t1, t2, l1, l2)
    u = unit(sub(T, B))
    return (u[0] * (T[0] - dx) + u[1] * (T[1] - dy)) / r > RANGE_TOL


def tip_path(dx, dy, t2_0, l1, l2, r1, r2, r, mu, theta2_min, theta2_max, step, root_tol):
    """D15's tip path: t2 increasing from t2_0, t1 = tip_strike_t1(t2); the first event met
    (smallest t2) wins, ties in TIP_EVENTS order. Nodes t2_0 + n step, the last clamped to
    theta2_max; each event holding at a node is bisected in its bracket down to root_tol.

    Returns (mode, t1, t2, why): TIP_ONLY (why: stick, distal_stop, proximal_stop; at the
    bracket end where the event holds, t1 clamped into [0, pi]), PROXIMAL_TIP (why:
    proximal_contact, the proximal link resting on the part, D21) or SLIPPED (why: miss,
    pull_off; at the bracket end where the tip still touches and presses)."""
    tau = (r1, r2)

    def holds(event, t2):
        if event == "distal_stop":
            return t2 >= theta2_max
        t1 = tip_strike_t1(dx, dy, t2, l1, l2, r)
        if t1 is None:
            return event == "lost"
        if event == "proximal_stop":     # leaves [0, pi], inclusive by the model's slack (D2),
            return (t1 < -RANGE_TOL or t1 > PI + RANGE_TOL     # or the proximal link reaches
                    or proximal_gap(dx, dy, t1, l1, r) < -RANGE_TOL)  # the part (D21)
        c_n, c_t = tip_columns(dx, dy, t1, t2, l1, l2)
        balanced = cross(tau, c_n) + mu * abs(cross(tau, c_t)) >= 0.0
        if event == "stick":             # a multiplier balances the tendon with a pushing tip
            return balanced and normal_force(tau, c_n, c_t) >= 0.0
        if event == "lost":              # pulled off, only a pulling tip would balance, or
            return (tau[0] * c_n[0] + tau[1] * c_n[1] < 0.0        # the distal link reaches
                    or (balanced and normal_force(tau, c_n, c_t) < 0.0)  # the tip from inside
                    or link_enters_before_tip(dx, dy, t1, t2, l1, l2, r))  # the disc (D20)
        raise ValueError(event)

    n = 1
    prev = t2_0
    while True:
        node = min(t2_0 + n * step, theta2_max)
        holding = [ev for ev in TIP_EVENTS if holds(ev, node)]
        if holding:
            break
        prev = node
        n += 1

    def first_held(ev, free, held, tol):
        """Bisect where ev starts: (free, held), ev not holding at free, holding at held."""
        while held - free > tol:
            mid = 0.5 * (free + held)
            if mid <= free or mid >= held:
                break
            if holds(ev, mid):
                held = mid
            else:
                free = mid
        return free, held

    crossings = []
    for priority, ev in enumerate(TIP_EVENTS):
        if ev not in holding:
            continue
        tol = root_tol                   # a joint stop, and events of one step: 1e-12 (D19)
        if len(holding) > 1 or ev in ("distal_stop", "proximal_stop"):
            tol = min(root_tol, 1e-12)
        lo, hi = first_held(ev, prev, node, tol)   # the event holds at hi, not at lo
        crossings.append((hi, priority, ev, lo))
    crossings.sort()
    hi, _, winner, lo = crossings[0]
    reported = lo if winner == "lost" else hi
    t1_reported = tip_strike_t1(dx, dy, reported, l1, l2, r)
    if (winner != "lost" and t1_reported is not None
            and link_enters_before_tip(dx, dy, t1_reported, reported, l1, l2, r)):
        # the distal link cuts into the part where the path ends: it reached the disc at the
        # tip within the step, unseen at the nodes (D20 as D19): lost where it is first met
        lo, hi = first_held("lost", prev, reported, min(root_tol, 1e-12))
        winner, reported = "lost", lo
    if winner == "lost" and holds("stick", reported) and not holds("stick", prev):
        # the tip holds where it last touched: the tendon stopped driving it along the path
        # (and would pull it off beyond) within the step, unseen at the nodes: it stuck where the
        # stick first holds (D15 "Within one step", as D19 and D20). Not at the path's start
        # (prev = t2_0, decided by the strike's hold test with its stops)
        _, hi = first_held("stick", prev, reported, min(root_tol, 1e-12))
        winner, reported = "stick", hi
    if winner != "proximal_stop" and holds("proximal_stop", reported):
        # the proximal stop (or the part, D21) was passed within the step, unseen at the nodes:
        # the path ends where it is first met (D19)
        _, hi = first_held("proximal_stop", prev, reported, min(root_tol, 1e-12))
        winner = "proximal_stop"
    if winner == "lost":
        t1 = tip_strike_t1(dx, dy, lo, l1, l2, r)
        cause = "miss" if tip_strike_t1(dx, dy, hi, l1, l2, r) is None else "pull_off"
        return SLIPPED, t1, lo, cause
    t1 = min(max(tip_strike_t1(dx, dy, hi, l1, l2, r), 0.0), PI)
    if winner == "proximal_stop" and proximal_gap(dx, dy, t1, l1, r) <= RANGE_TOL:
        return PROXIMAL_TIP, t1, hi, "proximal_contact"          # D21: resting on the part
    return TIP_ONLY, t1, hi, winner


# ---------------------------------------------------------------------------------------------
# The finger (D15 cases 1-5)
# ---------------------------------------------------------------------------------------------
def _result(mode, t1, t2, k1, k2, tip_normal=None):
    out = {"mode": int(mode), "t1": float(t1), "t2": float(t2), "k1": float(k1),
           "k2": float(k2), "tip_overlap": False}
    if tip_normal is not None:
        out["tip_normal"] = tip_normal
    return out


def naive_tip_finger(dx, dy, l1, l2, r1, r2, r, mu, theta2_min, theta2_max,
                     reconfig_step=0.01, root_tol=1e-12, trace=None, tip_start=None):
    """Configuration one finger reaches with `tip_contact` (D15). Returns a dict like
    naive.naive_finger (mode, t1, t2, k1, k2, tip_overlap=False), plus `tip_normal` (finger
    frame) for the modes with a tip contact. `trace`, a list, receives the D15 case taken;
    `tip_start`, a list, the (t1, t2) where the tip path began, if the finger took it (D29)."""
    if not finger_feasible(dx, dy, r):
        nan = float("nan")
        return _result(-1, nan, nan, nan, nan)
    tau = (r1, r2)

    def note(what):
        if trace is not None:
            trace.append(what)

    def tip_result(mode, t1, t2, k1=0.0):
        (_, n, _), _ = tip_contact(dx, dy, t1, t2, l1, l2)
        return _result(mode, t1, t2, k1, l2, tip_normal=n if mode != SLIPPED else None)

    def follow_tip(t1_0, t2_0):
        note("tip_path")
        if tip_start is not None:
            tip_start.append((t1_0, t2_0))
        mode, t1, t2, why = tip_path(dx, dy, t2_0, l1, l2, r1, r2, r, mu, theta2_min,
                                     theta2_max, reconfig_step, root_tol)
        note(why)
        k1 = 0.0
        if mode == PROXIMAL_TIP:            # D21: the proximal contact where the link touches
            k1 = min(max(dx * math.cos(t1) + dy * math.sin(t1), 0.0), l1)
        return tip_result(mode, t1, t2, k1)

    def reconfigured(t1_0):
        note("reconfigure")
        mode, t1, t2, k2 = reconfigure(dx, dy, t1_0, l1, l2, r1, r2, r, mu, theta2_max,
                                       reconfig_step, root_tol)
        if mode == SLIPPED:                 # case 5: the tip takes over at the crossing
            note("case5")
            return follow_tip(t1, t2)
        return _result(DISTAL_ONLY, t1, t2, 0.0, k2)

    def tip_hold_or_path(t1, t2, extra_contacts=(), k1=0.0):
        """Cases 2-4: the tip (plus extra contacts and the engaged stops) holds, or the path."""
        tip, B = tip_contact(dx, dy, t1, t2, l1, l2)
        contacts = list(extra_contacts) + [tip]
        stops = engaged_stops(t1, t2, theta2_min, theta2_max)
        if finger_holds(tau, contacts, stops, mu, B=B):
            return tip_result(PROXIMAL_TIP if extra_contacts else TIP_ONLY, t1, t2, k1)
        return follow_tip(t1, t2)

    kind, t1, k = rigid_sweep(dx, dy, l1, l2, r, theta2_min)

    if kind == EV_PROXIMAL:                                   # MODEL 4.3
        k1 = k
        closing = close_distal(dx, dy, t1, l1, l2, r, theta2_min, theta2_max)
        if closing[0] == CL_TANGENT:
            _, t2, k2 = closing
            if g_max(t2, k2, l1, r1, r2, mu) >= 0.0:
                return _result(TWO_PHALANX, t1, t2, k1, k2)
            return reconfigured(t1)
        if closing[0] == CL_TIP:                              # case 4
            note("case4")
            t2 = closing[1]
            ax = (math.cos(t1), math.sin(t1))
            proximal = ((k1 * ax[0], k1 * ax[1]), (-ax[1], ax[0]), False)
            return tip_hold_or_path(t1, t2, extra_contacts=(proximal,), k1=k1)
        return _result(PROXIMAL_ONLY, t1, theta2_max, k1, 0.0)

    if kind == EV_DISTAL:                                     # MODEL 4.4 / 5.3
        k2 = k
        if lower_stop_admissible(theta2_min, k2, l1, r1, r2, mu):
            return _result(DISTAL_ONLY, t1, theta2_min, 0.0, k2)
        return reconfigured(t1)

    if kind == EV_VERTEX_B:                                   # case 1
        note("case1")
        return reconfigured(t1)

    if kind == EV_VERTEX_T:                                   # case 2
        note("case2")
        return tip_hold_or_path(t1, theta2_min)

    assert kind == EV_NONE
    closing = close_distal(dx, dy, PI, l1, l2, r, theta2_min, theta2_max)
    if closing[0] == CL_TANGENT:
        _, t2, k2 = closing
        if g_max(t2, k2, l1, r1, r2, mu) >= 0.0:
            return _result(DISTAL_ONLY, PI, t2, 0.0, k2)
        return reconfigured(PI)
    if closing[0] == CL_TIP:                                  # case 3
        note("case3")
        return tip_hold_or_path(PI, closing[1])
    return _result(FREE, PI, theta2_max, 0.0, 0.0)


# ---------------------------------------------------------------------------------------------
# Maps: naive.naive_map with the tip finger and tip contacts in part equilibrium
# ---------------------------------------------------------------------------------------------
def tip_contact_normals(res, finger):
    """naive.contact_normals plus the tip's normal for modes tip / proximal_tip (world frame,
    mirrored for the left finger)."""
    t1, t2, mode = res["t1"], res["t2"], res["mode"]
    normals = []
    if mode in (PROXIMAL_ONLY, TWO_PHALANX, PROXIMAL_TIP):
        normals.append((-math.sin(t1), math.cos(t1)))
    if mode in (TWO_PHALANX, DISTAL_ONLY):
        normals.append((-math.sin(t1 + t2), math.cos(t1 + t2)))
    if mode in (TIP_ONLY, PROXIMAL_TIP):
        normals.append(tuple(res["tip_normal"]))
    if finger == 0:
        normals = [(-nx, ny) for nx, ny in normals]
    return normals


@contextmanager
def _tip_model():
    """Run naive.naive_map's own code with the tip finger and tip normals (naive.py unedited)."""
    saved = naive.naive_finger, naive.contact_normals
    naive.naive_finger = naive_tip_finger
    naive.contact_normals = tip_contact_normals
    try:
        yield
    finally:
        naive.naive_finger, naive.contact_normals = saved


def naive_tip_map(*args, **kwargs):
    """naive.naive_map (same arguments and outputs) with the tip_contact effect on."""
    with _tip_model():
        return naive.naive_map(*args, **kwargs)
