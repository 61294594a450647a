"""Paper-style baseline: energy maps the way the paper's Methods describe them.

For every grid point and each finger, the vector-loop equations of the paper (eq. "proximal vector
loop" and "distal vector loop") are solved by ``scipy.optimize.least_squares`` on their residual,
with bounds from the joint limits and the link lengths; a loop is *satisfied* when the residual norm
left by the solver is below ``RES_TOL`` (1e-9) inside the bounds. No closed form of docs/model.md 3
is
used. On top of these solves the closing sequence (MODEL 4), the stick-slip cases and the
reconfiguration (MODEL 5, docs/model-notes.md D4: step ``t1`` down, solve the distal loop by
least squares at every node, then bisect), the energy (MODEL 6) and the point classes (MODEL 8) are
applied, one Python call chain per point.

This is the reference the speed benchmark compares the Numba kernels against (same maps, same
classes: `scripts/bench.py baseline`; points/s of one map alone: `scripts/bench.py
baseline-map`). It is realistic, not tuned: analytic Jacobians and a geometric first guess for
every solve, a couple of extra starts when the first one does not converge, and warm starts
along the reconfiguration path. Knife-edge points can be classed differently from the kernels:
the solver accepts a loop whose exact solution lies outside a bound by up to ~RES_TOL (MODEL 5.5
uses 1e-12).

Conventions (docs/model-notes.md): finger index 0 = left, 1 = right; angles in radians; a left
finger is solved in its own mirrored frame. Infeasible points have ``point_class`` 0, NaN energy and
``finger_mode`` -1 (``NOT_SOLVED``); points skipped by ``max_points`` have ``point_class`` -1.
"""
from __future__ import annotations

import math
import sys
import time
from pathlib import Path

import numpy as np
from scipy.optimize import least_squares

try:
    from sweep import model as M
except ImportError:  # running from a checkout without the package installed
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
    from sweep import model as M

PI = math.pi
RES_TOL = 1e-9          # a vector loop is satisfied when |residual| < RES_TOL
NOT_SOLVED = -1         # finger_mode / point_class where nothing was solved
THETA2_MIN = math.radians(-5.0)
THETA2_MAX = math.radians(90.0)

# "dogbox" lands exactly on active bounds (e.g. t1 = 0 on the palm row); "trf" creeps towards them
# and stops at |residual| ~ 1e-8. gtol/xtol tight so a true solution drives the residual to ~1e-15;
# ftol = 1e-8 (scipy's default) ends loops without a solution (linear convergence to a residual
# minimum, the common case for the distal loop) after ~10-20 evaluations.
_LSQ = dict(method="dogbox", xtol=1e-12, ftol=1e-8, gtol=1e-15, max_nfev=60)


# ------------------------------------------------------------------------------------------------
# Vector-loop residuals (right-finger frame: d = p - J, paper eqs. proximal / distal vector loop)
# ------------------------------------------------------------------------------------------------
def _prox_res(x, d, r):
    """d = R(t1) [k1, r]; unknowns x = (t1, k1)."""
    t1, k1 = x
    c, s = math.cos(t1), math.sin(t1)
    return np.array([k1 * c - r * s - d[0], k1 * s + r * c - d[1]])


def _prox_jac(x, d, r):
    t1, k1 = x
    c, s = math.cos(t1), math.sin(t1)
    return np.array([[-k1 * s - r * c, c], [k1 * c - r * s, s]])


def _dist_res_t2(x, t1, d, l1, r):
    """d = l1 a_x(t1) + R(t1 + t2) [k2, r]; t1 given, unknowns x = (t2, k2)."""
    t2, k2 = x
    phi = t1 + t2
    c, s = math.cos(phi), math.sin(phi)
    return np.array([l1 * math.cos(t1) + k2 * c - r * s - d[0],
                     l1 * math.sin(t1) + k2 * s + r * c - d[1]])


def _dist_jac_t2(x, t1, d, l1, r):
    t2, k2 = x
    phi = t1 + t2
    c, s = math.cos(phi), math.sin(phi)
    return np.array([[-k2 * s - r * c, c], [k2 * c - r * s, s]])


def _dist_res_t1(x, t2, d, l1, r):
    """Same loop with t2 given (distal on its stop), unknowns x = (t1, k2)."""
    t1, k2 = x
    phi = t1 + t2
    c, s = math.cos(phi), math.sin(phi)
    return np.array([l1 * math.cos(t1) + k2 * c - r * s - d[0],
                     l1 * math.sin(t1) + k2 * s + r * c - d[1]])


def _dist_jac_t1(x, t2, d, l1, r):
    t1, k2 = x
    phi = t1 + t2
    c, s = math.cos(phi), math.sin(phi)
    return np.array([[-l1 * math.sin(t1) - k2 * s - r * c, c],
                     [l1 * math.cos(t1) + k2 * c - r * s, s]])


def _vertex_res(x, base_angle, rho_vec, d, r):
    """|vertex - d| - r for a vertex rigidly attached to a link turning by x[0].

    The vertex is ``R(x + base_angle) rho_vec`` about the proximal joint (rigid sweep) or, with
    ``rho_vec`` and the distal joint folded into ``d``, about the distal joint.
    """
    a = x[0] + base_angle
    c, s = math.cos(a), math.sin(a)
    vx, vy = c * rho_vec[0] - s * rho_vec[1], s * rho_vec[0] + c * rho_vec[1]
    return np.array([math.hypot(vx - d[0], vy - d[1]) - r])


def _vertex_jac(x, base_angle, rho_vec, d, r):
    a = x[0] + base_angle
    c, s = math.cos(a), math.sin(a)
    vx, vy = c * rho_vec[0] - s * rho_vec[1], s * rho_vec[0] + c * rho_vec[1]
    dist = math.hypot(vx - d[0], vy - d[1])
    if dist == 0.0:
        return np.array([[0.0]])
    return np.array([[((vx - d[0]) * -vy + (vy - d[1]) * vx) / dist]])


# ------------------------------------------------------------------------------------------------
# Least-squares drivers
# ------------------------------------------------------------------------------------------------
def _solve_loop(fun, jac, starts, lb, ub, args):
    """Try the starts in order; return the first solution with |residual| < RES_TOL, else None."""
    lb = np.asarray(lb, float)
    ub = np.asarray(ub, float)
    for x0 in starts:
        x0 = np.clip(np.asarray(x0, float), lb, ub)
        sol = least_squares(fun, x0, jac=jac, bounds=(lb, ub), args=args, **_LSQ)
        if np.linalg.norm(sol.fun) < RES_TOL:
            return sol.x
    return None


def _first_strike(base_angle, rho_vec, d, r, lo, hi):
    """Smallest turning angle in [lo, hi] at which the vertex enters the disc, or None.

    Least squares on |vertex - d| - r from a few starts inside the range (a start on a bound
    stalls trf); the smallest root found is kept. If that root is an exit (distance increasing),
    the entry lies before it: search again on [lo, root].
    """
    args = (base_angle, rho_vec, d, r)

    def roots_in(a, b, fractions):
        found = []
        for frac in fractions:
            sol = least_squares(_vertex_res, [a + frac * (b - a)], jac=_vertex_jac,
                                bounds=([a], [b]), args=args, **_LSQ)
            if abs(sol.fun[0]) < RES_TOL:
                found.append(float(sol.x[0]))
        return found

    roots = roots_in(lo, hi, (0.1, 0.5, 0.9))
    if not roots:
        return None
    t = min(roots)
    for _ in range(4):
        if t <= lo or _vertex_jac([t], *args)[0, 0] <= 0.0:
            break
        earlier = [u for u in roots_in(lo, t, (0.1, 0.4)) if u < t]   # t was an exit root
        if not earlier:
            break
        t = min(earlier)
    return t


def _proximal_loop(d, l1, r):
    """Proximal vector loop: (t1, k1) with 0 <= t1 <= pi, 0 <= k1 <= l1, or None."""
    aim = min(max(math.atan2(d[1], d[0]), 0.0), PI)
    starts = ((aim, min(math.hypot(d[0], d[1]), l1)), (0.25 * PI, 0.5 * l1), (0.75 * PI, 0.5 * l1))
    return _solve_loop(_prox_res, _prox_jac, starts, (0.0, 0.0), (PI, l1), (d, r))


def _distal_loop_t2(t1, d, l1, l2, r, t2min, t2max):
    """Distal vector loop with t1 given: (t2, k2) within the joint limits and 0 <= k2 <= l2."""
    ex, ey = d[0] - l1 * math.cos(t1), d[1] - l1 * math.sin(t1)
    aim = math.remainder(math.atan2(ey, ex) - t1, 2 * PI)
    starts = ((aim, min(math.hypot(ex, ey), l2)), (0.5 * (t2min + t2max), 0.5 * l2))
    return _solve_loop(_dist_res_t2, _dist_jac_t2, starts, (t2min, 0.0), (t2max, l2),
                       (t1, d, l1, r))


def _distal_loop_t1(t2, d, l1, l2, r):
    """Distal vector loop with the distal on its stop t2: (t1, k2), 0 <= t1 <= pi, 0 <= k2 <= l2."""
    aim = min(max(math.atan2(d[1], d[0]), 0.0), PI)
    starts = ((aim, 0.5 * l2), (0.25 * PI, 0.5 * l2), (0.75 * PI, 0.5 * l2))
    return _solve_loop(_dist_res_t1, _dist_jac_t1, starts, (0.0, 0.0), (PI, l2), (t2, d, l1, r))


def _path_point(t1, d, l1, r, x0, k2max):
    """Distal tangency at a given t1 without range checks (reconfiguration path), warm-started."""
    lb = np.array([-PI, 0.0])
    ub = np.array([PI, k2max])
    x0 = np.clip(np.asarray(x0, float), lb, ub)
    sol = least_squares(_dist_res_t2, x0, jac=_dist_jac_t2, bounds=(lb, ub), args=(t1, d, l1, r),
                        **_LSQ)
    return sol.x


# ------------------------------------------------------------------------------------------------
# Statics (MODEL 5)
# ------------------------------------------------------------------------------------------------
def _gmax(t2, k2, l1, r1, r2, mu):
    """max over |mu'| <= mu of g = k1 k2 F1 / F (MODEL 5.2, 5.3)."""
    return r1 * k2 - r2 * (l1 * math.cos(t2) + k2) + mu * r2 * l1 * abs(math.sin(t2))


def _reconfigure(t1_0, x_0, d, l1, l2, r1, r2, r, mu, t2max, step, root_tol):
    """MODEL 5.3 / model-notes D4. Returns (mode, t1, t2, k2)."""
    k2max = math.hypot(d[0], d[1]) + l1 + r

    def events(t1, x):
        t2, k2 = x
        return (_gmax(t2, k2, l1, r1, r2, mu) >= 0.0,   # stick
                t2 >= t2max - M.RANGE_TOL,              # distal stop
                t1 <= 0.0,                              # proximal stop
                k2 > l2 + M.RANGE_TOL)                  # slip

    prev_t1, prev_x = t1_0, np.asarray(x_0, float)
    n = 0
    while True:
        n += 1
        t1n = t1_0 - n * step
        if t1n <= 0.0:
            t1n = 0.0
        xn = _path_point(t1n, d, l1, r, prev_x, k2max)
        ev = events(t1n, xn)
        if any(ev):
            break
        prev_t1, prev_x = t1n, xn

    best = None  # (t1, event index, x)
    for idx in range(4):
        if not ev[idx]:
            continue
        if idx == 2:
            cand = (0.0, idx, xn)
        else:
            lo, xlo, hi, xhi = t1n, xn, prev_t1, prev_x
            while hi - lo > root_tol:
                mid = 0.5 * (lo + hi)
                if mid <= lo or mid >= hi:
                    break
                xm = _path_point(mid, d, l1, r, xhi, k2max)
                if events(mid, xm)[idx]:
                    lo, xlo = mid, xm
                else:
                    hi, xhi = mid, xm
            cand = (lo, idx, xlo)
        if best is None or cand[0] > best[0]:
            best = cand
    t1, idx, (t2, k2) = best
    return (M.SLIPPED if idx == 3 else M.DISTAL_ONLY), t1, float(t2), float(k2)


# ------------------------------------------------------------------------------------------------
# One finger
# ------------------------------------------------------------------------------------------------
def baseline_finger(dx, dy, l1, l2, r1, r2, r, mu, theta2_min=THETA2_MIN, theta2_max=THETA2_MAX,
                    reconfig_step=0.01, root_tol=1e-9):
    """Final configuration of one finger for a part at ``d = (dx, dy)`` in the finger's frame.

    Returns ``(mode, t1, t2, k1, k2)`` with ``mode`` a ``sweep.model`` finger-mode code, or
    ``NOT_SOLVED`` (-1) with NaNs when the disc overlaps the proximal joint (infeasible).
    """
    if theta2_min > 0.0:
        raise ValueError("theta2_min must be <= 0 (MODEL 1)")
    nan = float("nan")
    if dx * dx + dy * dy < r * r * (1.0 - M.TOUCH_REL):
        return NOT_SOLVED, nan, nan, nan, nan
    d = (float(dx), float(dy))
    t2min, t2max = theta2_min, theta2_max

    def after_distal_only(t1, t2, k2):
        """Distal-only contact that cannot stick: reconfigure from it."""
        mode, t1f, t2f, k2f = _reconfigure(t1, (t2, k2), d, l1, l2, r1, r2, r, mu, t2max,
                                           reconfig_step, root_tol)
        return mode, t1f, t2f, 0.0, k2f

    # --- rigid sweep, proximal loop first (MODEL 4.2)
    prox = _proximal_loop(d, l1, r)
    if prox is not None:
        t1, k1 = float(prox[0]), float(prox[1])
        # --- distal closes about B with t1 fixed (MODEL 4.3)
        dist = _distal_loop_t2(t1, d, l1, l2, r, t2min, t2max)
        if dist is None:
            return M.PROXIMAL_ONLY, t1, t2max, k1, 0.0
        t2, k2 = float(dist[0]), float(dist[1])
        if _gmax(t2, k2, l1, r1, r2, mu) >= 0.0:          # cases 1 and 3
            return M.TWO_PHALANX, t1, t2, k1, k2
        return after_distal_only(t1, t2, k2)               # case 2: lift-off

    # --- no proximal contact: earliest of distal tangency (t2 on its stop), B strike, T strike
    events = []  # (t1, priority, kind, payload)
    dist = _distal_loop_t1(t2min, d, l1, l2, r)
    if dist is not None:
        events.append((float(dist[0]), 0, "distal", float(dist[1])))
    tb = _first_strike(0.0, (l1, 0.0), d, r, 0.0, PI)
    if tb is not None:
        events.append((tb, 1, "B", None))
    tip = (l1 + l2 * math.cos(t2min), l2 * math.sin(t2min))
    tt = _first_strike(0.0, tip, d, r, 0.0, PI)
    if tt is not None:
        events.append((tt, 1, "T", None))
    if events:
        tmin_event = min(e[0] for e in events)
        # ties within 1e-12: the tangency wins (model-notes D3)
        first = min((e for e in events if e[0] <= tmin_event + M.RANGE_TOL),
                    key=lambda e: (e[1], e[0]))
        t1 = first[0]
        if first[2] == "B":
            return M.VERTEX, t1, t2min, l1, 0.0
        if first[2] == "T":
            return M.VERTEX, t1, t2min, 0.0, l2
        k2 = first[3]
        # first contact with the distal on its lower stop (MODEL 5.3)
        mu_star = mu * (1.0 if math.sin(t2min) > 0 else (-1.0 if math.sin(t2min) < 0 else 0.0))
        lever = l1 * math.cos(t2min) + k2 - mu_star * l1 * math.sin(t2min)
        if _gmax(t2min, k2, l1, r1, r2, mu) >= 0.0 and lever > 0.0:
            return M.DISTAL_ONLY, t1, t2min, 0.0, k2
        return after_distal_only(t1, t2min, k2)

    # --- nothing met before t1 = pi: the distal closes with the proximal on its upper stop
    t1 = PI
    dist = _distal_loop_t2(t1, d, l1, l2, r, t2min, t2max)
    if dist is not None:
        t2, k2 = float(dist[0]), float(dist[1])
        if _gmax(t2, k2, l1, r1, r2, mu) >= 0.0:
            return M.DISTAL_ONLY, t1, t2, 0.0, k2
        return after_distal_only(t1, t2, k2)
    bx, by = l1 * math.cos(t1), l1 * math.sin(t1)
    ts = _first_strike(t1, (l2, 0.0), (d[0] - bx, d[1] - by), r, t2min, t2max)
    if ts is not None:
        return M.VERTEX, t1, ts, 0.0, l2
    return M.FREE, t1, t2max, 0.0, 0.0


def finger_energy(t1, t2, r1, r2, theta2_min=THETA2_MIN, force=1.0):
    """MODEL 6: V = -F [r1 (t1 - 0) + r2 (t2 - theta2_min)]."""
    return -force * (r1 * t1 + r2 * (t2 - theta2_min))


def point_class(mode_left, mode_right):
    """MODEL 8, first that applies (feasible points)."""
    modes = (mode_left, mode_right)
    if M.SLIPPED in modes:
        return M.EJECT
    if M.VERTEX in modes:
        return M.VERTEX_POINT
    if mode_left == M.FREE and mode_right == M.FREE:
        return M.UNREACHED
    return M.REACHED


# ------------------------------------------------------------------------------------------------
# One map
# ------------------------------------------------------------------------------------------------
def grid_indices(l1, l2, w, r, h, xlim=None, ylim=None):
    """Integer grid indices (model-notes D1): x_i = i h, y_j = r + j h."""
    if xlim is None:
        n = math.floor((w / 2 + l1 + l2 + r) / h + M.GRID_TOL)
        i_idx = np.arange(-n, n + 1)
    else:
        i_idx = np.arange(math.ceil(xlim[0] / h - M.GRID_TOL),
                          math.floor(xlim[1] / h + M.GRID_TOL) + 1)
    if ylim is None:
        m = math.floor((l1 + l2) / h + M.GRID_TOL)   # ((r + l1 + l2) - r) / h
        j_idx = np.arange(0, m + 1)
    else:
        j_idx = np.arange(math.ceil((ylim[0] - r) / h - M.GRID_TOL),
                          math.floor((ylim[1] - r) / h + M.GRID_TOL) + 1)
    return i_idx, j_idx


def baseline_map(l1, l2, r1, r2, w, r, mu, f_left=1.0, f_right=1.0, h=0.1, xlim=None, ylim=None,
                 max_points=None, theta2_min=THETA2_MIN, theta2_max=THETA2_MAX,
                 reconfig_step=0.01, root_tol=1e-9):
    """Class and energy map, paper style. ``max_points`` limits the grid points solved (row-major,
    from the palm row up); the rest get ``point_class`` -1 and NaN energy."""
    i_idx, j_idx = grid_indices(l1, l2, w, r, h, xlim, ylim)
    x = i_idx * h
    y = r + j_idx * h
    ny, nx = len(y), len(x)
    pc = np.full((ny, nx), NOT_SOLVED, dtype=np.int8)
    energy = np.full((ny, nx), np.nan)
    modes = np.full((2, ny, nx), NOT_SOLVED, dtype=np.int8)
    half = w / (2 * h)
    s = round(half)
    integral = abs(half - s) <= 1e-9
    forces = (f_left, f_right)
    n_solved = 0
    t0 = time.perf_counter()
    for jj in range(ny):
        for ii in range(nx):
            if max_points is not None and n_solved >= max_points:
                break
            n_solved += 1
            i = int(i_idx[ii])
            dy = float(y[jj])
            if integral:
                dxs = ((-i - s) * h, (i - s) * h)
            else:
                dxs = (-i * h - w / 2, i * h - w / 2)
            if dy < r - M.RANGE_TOL or any(dx * dx + dy * dy < r * r * (1.0 - M.TOUCH_REL)
                                           for dx in dxs):
                pc[jj, ii] = M.INFEASIBLE
                continue
            e = 0.0
            for f in (M.LEFT, M.RIGHT):
                mode, t1, t2, _k1, _k2 = baseline_finger(
                    dxs[f], dy, l1, l2, r1, r2, r, mu, theta2_min, theta2_max,
                    reconfig_step, root_tol)
                modes[f, jj, ii] = mode
                e += finger_energy(t1, t2, r1, r2, theta2_min, forces[f])
            energy[jj, ii] = e
            pc[jj, ii] = point_class(modes[0, jj, ii], modes[1, jj, ii])
    seconds = time.perf_counter() - t0
    return dict(x=x, y=y, point_class=pc, energy=energy, finger_mode=modes,
                n_points_solved=n_solved, seconds=seconds)

