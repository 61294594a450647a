"""Slow, independent reference of the in-hand manipulation metric (MODEL 10), for the tests.

Written from MODEL.md 10, 5.1, 5.6, 7 and 8 without looking at the kernels. Configurations come
from tests/naive.py (the reference finger solver); contact forces from the general statics of
MODEL 5.1 solved as a linear programme (scipy.optimize.linprog), NOT from the closed forms of 5.2;
hulls from scipy.spatial.ConvexHull. For tiny configurations only (a few geometries, a few hundred
poses): every pose costs a few LP solves.

Decisions spelled out here (the lead's rules for the reference):
- A finger's contact forces are undetermined, and the pose dropped, when its number of contacts
  plus its number of joints resting on a limit (within 1e-12 rad: t1 = 0 or pi, t2 = theta2_min or
  theta2_max) exceeds 2, its two joint equations. A finger with no contact gives zero force.
- Least |mu| (MODEL 5.6): among the admissible solutions of the finger's statics (normal forces
  >= 0, |tangential| <= mu_s normal, every stop torque of its admissible sign), the one with the
  least sum of |tangential forces|. With one contact that carries moment this is the least |mu|;
  a contact whose tangential force has no moment about any joint gets mu = 0.
- A force p coincides with a hull vertex v when |p - v| <= 1e-12 |v|.
"""
from __future__ import annotations

import math
from functools import lru_cache

import numpy as np
from scipy.optimize import linprog
from scipy.spatial import ConvexHull, QhullError

from sweep.model import DISTAL_ONLY, FREE, PROXIMAL_ONLY, SLIPPED, TWO_PHALANX, VERTEX

from naive import (contact_normals, contained, finger_feasible, finger_points, in_equilibrium,
                   naive_finger, opening, to_world)

LIMIT_TOL = 1e-12      # a joint rests on a limit (the lead's rule)
COINCIDE_REL = 1e-12   # MODEL 10: a force coincides with a hull vertex
INSIDE_REL = 1e-12     # MODEL 10: origin strictly inside, relative to the largest force
PALM_TOL = 1e-9        # MODEL 7
RANGE_TOL = 1e-12      # D5: CAGED needs L_open < 2r - 1e-12
GRID_TOL = 1e-9        # D1
CONE_SLACK = 1e-9      # relative: a reconfiguration stop sticks at |mu| = mu_s up to round-off

PARAMETER_NAMES = ("w", "l1", "l2", "r1", "r2")
PAPER_SEARCH_RANGES = (2.0, 1.6, 1.2, 0.16, 0.16)   # upper - lower of MODEL 1's table

SCENARIO_A_COMMANDS = tuple((k / 10.0, 2.0 - k / 10.0) for k in range(2, 19, 2))
SCENARIO_B_COMMANDS = ((1.0, 1.0),)

THETA2_MIN = math.radians(-5.0)
THETA2_MAX = math.radians(90.0)


def cross(a, b):
    return a[0] * b[1] - a[1] * b[0]


def rot90(v):
    return np.array([-v[1], v[0]])


# ---------------------------------------------------------------------------------------------
# Statics of one finger (MODEL 5.1, 5.6), in the right finger's frame
# ---------------------------------------------------------------------------------------------
def finger_contacts(res, l1):
    """[(link, point c, unit normal n)] of a finger's tangent contacts; link 1 proximal, 2
    distal."""
    t1, t2, mode = res["t1"], res["t2"], res["mode"]
    a_x = np.array([math.cos(t1), math.sin(t1)])
    b_x = np.array([math.cos(t1 + t2), math.sin(t1 + t2)])
    contacts = []
    if mode in (PROXIMAL_ONLY, TWO_PHALANX):
        contacts.append((1, res["k1"] * a_x, rot90(a_x)))
    if mode in (TWO_PHALANX, DISTAL_ONLY):
        contacts.append((2, l1 * a_x + res["k2"] * b_x, rot90(b_x)))
    return contacts


def on_limit(angle, limit):
    """Within 1e-12 rad of a limit. Plus a few ulps: the reconfiguration stops on the distal limit
    at t2 >= fl(theta2_max - 1e-12), which can lie 1e-12 + 1 ulp below it (seen: 1.0001e-12)."""
    return abs(angle - limit) <= LIMIT_TOL + 4.0 * np.spacing(abs(limit))


def joint_limits(res, theta2_min, theta2_max):
    """[(joint, sign)] of joints resting on a limit; sign of the stop torque it can supply
    (+1: a lower stop pushes closing, -1: an upper stop pushes opening)."""
    limits = []
    if on_limit(res["t1"], 0.0):
        limits.append((1, 1.0))
    elif on_limit(res["t1"], math.pi):
        limits.append((1, -1.0))
    if on_limit(res["t2"], theta2_min):
        limits.append((2, 1.0))
    elif on_limit(res["t2"], theta2_max):
        limits.append((2, -1.0))
    return limits


def finger_forces(res, l1, r1, r2, mu, theta2_min=THETA2_MIN, theta2_max=THETA2_MAX,
                  tension=1.0):
    """Contact forces of one finger on the part, in its own (right-finger) frame.

    Unknowns: per contact a normal force N >= 0 and a tangential force G (|G| <= mu N, split as
    G+ - G-), per joint on a limit a stop torque of its admissible sign. Equations (MODEL 5.1):
        J:  tension r1 + tau1 = sum over all contacts      (c - J) x (N n + G t)
        B:  tension r2 + tau2 = sum over distal contacts   (c - B) x (N n + G t)
    Objective: least sum |G| (MODEL 5.6). Returns a dict: determined (the lead's count rule),
    force (resultant on the part), contacts [(c, f)], stop torques {joint: tau}, mu per contact,
    unique (the resultant does not change over the optimal set), admissible (False if the LP has
    no solution: the configuration cannot be in static equilibrium, which MODEL 4-5 exclude)."""
    contacts = finger_contacts(res, l1)
    limits = joint_limits(res, theta2_min, theta2_max)
    out = {"determined": len(contacts) + len(limits) <= 2, "force": np.zeros(2), "contacts": [],
           "stops": {}, "mu": [], "unique": True, "admissible": True}
    if not contacts or not out["determined"]:
        return out
    n_c, n_l = len(contacts), len(limits)
    n_var = 3 * n_c + n_l
    b_pt = l1 * np.array([math.cos(res["t1"]), math.sin(res["t1"])])
    a_eq = np.zeros((2, n_var))
    for i, (link, c, n) in enumerate(contacts):
        t = rot90(n)
        a_eq[0, i] = cross(c, n)
        a_eq[0, n_c + i], a_eq[0, 2 * n_c + i] = cross(c, t), -cross(c, t)
        if link == 2:
            a_eq[1, i] = cross(c - b_pt, n)
            a_eq[1, n_c + i], a_eq[1, 2 * n_c + i] = cross(c - b_pt, t), -cross(c - b_pt, t)
    for k, (joint, _) in enumerate(limits):
        a_eq[joint - 1, 3 * n_c + k] = -1.0
    b_eq = np.array([tension * r1, tension * r2])
    mu_cone = mu * (1.0 + CONE_SLACK)
    a_ub = np.zeros((2 * n_c, n_var))
    for i in range(n_c):
        a_ub[2 * i, [i, n_c + i, 2 * n_c + i]] = (-mu_cone, 1.0, -1.0)
        a_ub[2 * i + 1, [i, n_c + i, 2 * n_c + i]] = (-mu_cone, -1.0, 1.0)
    b_ub = np.zeros(2 * n_c)
    bounds = [(0, None)] * (3 * n_c) + [((0, None) if sign > 0 else (None, 0))
                                         for _, sign in limits]
    cost = np.zeros(n_var)
    cost[n_c:3 * n_c] = 1.0
    sol = linprog(cost, A_ub=a_ub, b_ub=b_ub, A_eq=a_eq, b_eq=b_eq, bounds=bounds,
                  method="highs-ds")
    if sol.status != 0:              # the configuration's statics fail: a bug upstream, reported
        out["admissible"] = False
        return out
    x = sol.x

    # Uniqueness: over the optimal set, does any component of the resultant move?
    resultant_rows = np.zeros((2, n_var))
    for i, (_, _c, n) in enumerate(contacts):
        t = rot90(n)
        resultant_rows[:, i] = n
        resultant_rows[:, n_c + i], resultant_rows[:, 2 * n_c + i] = t, -t
    opt_ub = np.vstack([a_ub, cost])
    opt_b = np.append(b_ub, sol.fun + 1e-12 * tension)
    spread = 0.0
    for row in resultant_rows:
        lo = linprog(row, A_ub=opt_ub, b_ub=opt_b, A_eq=a_eq, b_eq=b_eq, bounds=bounds,
                     method="highs-ds")
        hi = linprog(-row, A_ub=opt_ub, b_ub=opt_b, A_eq=a_eq, b_eq=b_eq, bounds=bounds,
                     method="highs-ds")
        if lo.status == 0 and hi.status == 0:
            spread = max(spread, -hi.fun - lo.fun)
        else:
            spread = math.inf
    out["unique"] = spread <= 1e-9 * tension

    total = np.zeros(2)
    for i, (_, c, n) in enumerate(contacts):
        normal, tangential = x[i], x[n_c + i] - x[2 * n_c + i]
        f = normal * n + tangential * rot90(n)
        out["contacts"].append((c, f))
        out["mu"].append(tangential / normal if normal > 0 else 0.0)
        total += f
    out["stops"] = {joint: x[3 * n_c + k] for k, (joint, _) in enumerate(limits)}
    out["force"] = total
    return out


def mirror(v):
    """Left finger's frame -> world (and back): x changes sign."""
    return np.array([-v[0], v[1]])


# ---------------------------------------------------------------------------------------------
# One pose of one geometry (MODEL 10 count conditions)
# ---------------------------------------------------------------------------------------------
def finger_offsets(i, h, w):
    """(dx_left, dx_right) of a lattice column, as docs/model-notes.md D1 computes them."""
    half = w / (2.0 * h)
    s = round(half)
    if abs(half - s) <= GRID_TOL:
        return (-i - s) * h, (i - s) * h
    return -(i * h) - w / 2.0, i * h - w / 2.0


@lru_cache(maxsize=None)   # configurations do not depend on the command: reuse across scenarios
def pose_forces(geometry, part, i, j, h, theta2_min=THETA2_MIN, theta2_max=THETA2_MAX,
                mu_left=None, mu_right=None):
    """Per-unit-tension resultants of both fingers at lattice pose (i, j), already times S_geo.
    mu_left, mu_right: each finger's own contact friction (Scenario C; None: the part's mu),
    which solves that finger and is its contacts' cone in the part's equilibrium.

    Returns dict(counts, reason, f_left, f_right (world frame), s_geo, crossed, unique); the
    result is cached and shared: do not modify it."""
    w, l1, l2, r1, r2 = geometry
    r, mu = part
    mus = (mu if mu_left is None else mu_left, mu if mu_right is None else mu_right)
    px, py = i * h, r + j * h
    out = {"counts": False, "reason": "", "f_left": np.zeros(2), "f_right": np.zeros(2),
           "s_geo": 0.0, "crossed": False, "unique": True}
    dx_left, dx_right = finger_offsets(i, h, w)
    if not (py >= r - RANGE_TOL and finger_feasible(dx_left, py, r)
            and finger_feasible(dx_right, py, r)):
        out["reason"] = "infeasible"
        return out
    fingers = [naive_finger(dx, py, l1, l2, r1, r2, r, m, theta2_min, theta2_max)
               for dx, m in zip((dx_left, dx_right), mus)]
    modes = [f["mode"] for f in fingers]
    if SLIPPED in modes or VERTEX in modes or modes == [FREE, FREE]:
        out["reason"] = "not reached"
        return out
    if abs(py - r) <= PALM_TOL and abs(px) <= w / 2.0 + PALM_TOL:
        out["reason"] = "palm contact"
        return out
    left, right = contact_normals(fingers[0], 0), contact_normals(fingers[1], 1)
    if in_equilibrium(left + right, [mus[0]] * len(left) + [mus[1]] * len(right)):
        out["reason"] = "equilibrium"
        return out
    pts = [[to_world(p, fi, w) for p in finger_points(res["t1"], res["t2"], l1, l2)]
           for fi, res in enumerate(fingers)]
    (jl, bl, tl), (jr, br, tr) = pts
    l_open, crossed = opening(pts[0], pts[1])
    if not (contained([jl, bl, tl, tr, br, jr], px, py) and l_open < 2.0 * r - RANGE_TOL):
        out["reason"] = "not caged"
        return out
    s_geo = 1.0 - l_open / (2.0 * r)
    if not s_geo > 0.0:
        out["reason"] = "not caged"
        return out
    statics = [finger_forces(res, l1, r1, r2, m, theta2_min, theta2_max)
               for res, m in zip(fingers, mus)]
    if not all(s["determined"] for s in statics):
        out["reason"] = "undetermined"
        return out
    if not all(s["admissible"] for s in statics):
        out["reason"] = "no admissible statics"
        return out
    out.update(counts=True, s_geo=s_geo, crossed=crossed,
               unique=all(s["unique"] for s in statics),
               f_left=s_geo * mirror(statics[0]["force"]), f_right=s_geo * statics[1]["force"])
    return out


# ---------------------------------------------------------------------------------------------
# The metric
# ---------------------------------------------------------------------------------------------
def world_lattice(geometries, r, h):
    """Every lattice pose (i, j) within the largest reach (MODEL 8 default window, MODEL 10)."""
    x_reach = max(w / 2.0 + l1 + l2 + r for w, l1, l2, _, _ in geometries)
    y_reach = max(r + l1 + l2 for _, l1, l2, _, _ in geometries)
    n = math.floor(x_reach / h + GRID_TOL)
    m = math.floor((y_reach - r) / h + GRID_TOL)
    return [(i, j) for j in range(m + 1) for i in range(-n, n + 1)], (n, m)


def hull_value(points):
    """(value, hull vertices) by Qhull: radius of the largest origin-centred circle inside the
    hull."""
    points = np.asarray(points, dtype=float).reshape(-1, 2)
    if len(points) < 3:
        return 0.0, points[:0]
    try:
        hull = ConvexHull(points)
    except QhullError:
        return 0.0, points[:0]          # all forces on one line
    dist = -hull.equations[:, 2]
    largest = np.hypot(points[:, 0], points[:, 1]).max()
    value = dist.min() if dist.min() > INSIDE_REL * largest else 0.0
    return float(value), points[hull.vertices]


def scenario_c_frictions(mu_low, mu_s):
    """MODEL 10, Scenario C: each finger on mu_low or the part's mu_s, the four pairs
    (mu_left, mu_right) (one when mu_low == mu_s)."""
    return sorted({(a, b) for a in (mu_low, mu_s) for b in (mu_low, mu_s)})


def naive_metric(geometries, part, h, commands, poses=None, search_ranges=PAPER_SEARCH_RANGES,
                 theta2_min=THETA2_MIN, theta2_max=THETA2_MAX, frictions=((None, None),)):
    """The in-hand manipulation metric of one part (MODEL 10), pose by pose.

    geometries: sequence of (w, l1, l2, r1, r2); part: (r, mu_s); commands: (F_left, F_right)
    pairs; poses: lattice indices (i, j), default every pose of the world lattice; frictions:
    the fingers' friction pairs (mu_left, mu_right) whose forces count too (Scenario C:
    `scenario_c_frictions`; default the part's own).
    Returns dict:
      values   per-pose values; shape (M+1, 2N+1) indexed [j, i + N] for the default lattice,
               else one per given pose
      total, total_h2   sum of the values, and times h^2
      usage    per parameter (w, l1, l2, r1, r2): mean over positive poses of the hull-vertex
               geometries' range / search range (NaN if no pose is positive)
      n_forces per pose, the number of counted (geometry, command) forces
      poses, x, y, reasons (per geometry, per pose: why it did not count, "" if it did),
      crossed_value (sum of values of poses where a counted geometry has crossed fingers),
      nonunique (poses where a finger's least-|mu| forces are not unique),
      inadmissible ((i, j, geometry) dropped because a finger's statics have no solution),
      forces (per pose: (geometry index of each counted force, forces (n, 2)), commands in order
      within each geometry)."""
    geometries = [tuple(float(v) for v in g) for g in geometries]
    part = tuple(float(v) for v in part)
    r, _ = part
    default = poses is None
    if default:
        poses, (n, m) = world_lattice(geometries, r, h)
    poses = [tuple(p) for p in poses]
    params = np.array(geometries)
    values = np.zeros(len(poses))
    n_forces = np.zeros(len(poses), dtype=int)
    ranges = []
    reasons = [[None] * len(poses) for _ in geometries]
    crossed_value = 0.0
    nonunique, inadmissible, counted = [], [], []
    for k, (i, j) in enumerate(poses):
        forces, owners, crossed = [], [], False
        for g, geometry in enumerate(geometries):
            for mu_left, mu_right in frictions:
                pf = pose_forces(geometry, part, i, j, h, theta2_min, theta2_max, mu_left,
                                 mu_right)
                reasons[g][k] = pf["reason"]
                if pf["reason"] == "no admissible statics":
                    inadmissible.append((i, j, g))
                if not pf["counts"]:
                    continue
                crossed |= pf["crossed"]
                if not pf["unique"]:
                    nonunique.append((i, j, g))
                for f_left, f_right in commands:
                    forces.append(f_left * pf["f_left"] + f_right * pf["f_right"])
                    owners.append(g)
        n_forces[k] = len(forces)
        counted.append((np.array(owners, dtype=int), np.array(forces, dtype=float).reshape(-1, 2)))
        value, verts = hull_value(forces)
        values[k] = value
        if value > 0.0:
            forces = np.array(forces)
            used = set()
            for v in verts:
                near = np.hypot(*(forces - v).T) <= COINCIDE_REL * np.hypot(*v)
                used.update(np.array(owners)[near].tolist())
            chosen = params[sorted(used)]
            ranges.append((chosen.max(axis=0) - chosen.min(axis=0)) / np.asarray(search_ranges))
            if crossed:
                crossed_value += value
    usage = np.mean(ranges, axis=0) if ranges else np.full(5, np.nan)
    out = {"total": float(values.sum()), "total_h2": float(values.sum()) * h * h,
           "usage": usage, "poses": poses, "reasons": reasons, "crossed_value": crossed_value,
           "nonunique": nonunique, "inadmissible": inadmissible, "forces": counted,
           "x": np.array([i * h for i, _ in poses]), "y": np.array([r + j * h for _, j in poses])}
    if default:
        out["values"] = values.reshape(m + 1, 2 * n + 1)
        out["n_forces"] = n_forces.reshape(m + 1, 2 * n + 1)
    else:
        out["values"] = values
        out["n_forces"] = n_forces
    return out
