"""Closed-form contact geometry of one finger (MODEL 3) and vertex strikes (MODEL 4).

All inputs are in the RIGHT finger's frame: origin at its proximal joint J, `d = p - J`.
Functions return `math.inf` / a negative length for "no such contact" instead of raising, so they
can run inside parallel loops on any input.
"""
import math

from numba import njit

from ..model import RANGE_TOL, TOUCH_REL

NO_ANGLE = math.inf


@njit(cache=True)
def wrap_angle(a):
    """Wrap into (-pi, pi]."""
    if -math.pi < a <= math.pi:
        return a
    return a - 2.0 * math.pi * math.ceil((a - math.pi) / (2.0 * math.pi))


@njit(cache=True)
def tangent_length(dist2, r):
    """Length of the tangent from a point at squared distance dist2 to a disc of radius r.

    Returns -1.0 if the point is inside the disc; points within the MODEL 5.5 tolerance of the
    circle count as touching (length 0).
    """
    r2 = r * r
    if dist2 < r2 * (1.0 - TOUCH_REL):
        return -1.0
    return math.sqrt(max(dist2 - r2, 0.0))


@njit(cache=True)
def in_range(value, lower, upper):
    """Inclusive range check with the MODEL 5.5 slack."""
    return lower - RANGE_TOL <= value <= upper + RANGE_TOL


@njit(cache=True)
def clamp(value, lower, upper):
    return min(max(value, lower), upper)


@njit(cache=True)
def proximal_tangency(dx, dy, r):
    """MODEL 3.1: (t1, k1) of the proximal link tangent to the part; k1 < 0 if d is inside the
    disc."""
    k1 = tangent_length(dx * dx + dy * dy, r)
    if k1 < 0.0:
        return NO_ANGLE, -1.0
    return math.atan2(dy, dx) - math.atan2(r, k1), k1


@njit(cache=True)
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


@njit(cache=True)
def rigid_distal_tangency(dx, dy, l1, r, theta2_min):
    """MODEL 3.3: (t1, k2) of the distal link (held at theta2_min) tangent during the rigid sweep.

    Returns (inf, -1) if the distal line never reaches the part.
    """
    r_eff = r + l1 * math.sin(-theta2_min)
    dist2 = dx * dx + dy * dy
    if dist2 < r_eff * r_eff * (1.0 - TOUCH_REL):
        return NO_ANGLE, -1.0
    dist = math.sqrt(dist2)
    alpha = math.atan2(dy, dx)
    offset = math.asin(min(r_eff / dist, 1.0))  # alpha - phi
    phi = alpha - offset
    k2 = dist * math.cos(offset) - l1 * math.cos(theta2_min)
    return phi - theta2_min, k2


@njit(cache=True)
def vertex_entry(dx, dy, rho, delta, r):
    """MODEL 4: turning angle at which a vertex at radius rho, polar offset delta, enters the disc.

    The vertex turns counter-clockwise about the origin of (dx, dy). Returns inf if it never does,
    or only grazes the disc (model-notes D3).
    """
    c = entry_cosine(dx, dy, rho, r)
    if c >= 1.0 - RANGE_TOL or c < -1.0:  # a graze (c = 1) touches without entering
        return NO_ANGLE
    return math.atan2(dy, dx) - math.acos(c) - delta


@njit(cache=True)
def entry_cosine(dx, dy, rho, r):
    """MODEL 4's acos argument (rho^2 + |d|^2 - r^2) / (2 rho |d|) for a vertex at radius rho
    about the origin of (dx, dy); 2 (no entry) where it is undefined."""
    dist2 = dx * dx + dy * dy
    if dist2 <= 0.0 or rho <= 0.0:
        return 2.0
    dist = math.sqrt(dist2)
    return (rho * rho + dist2 - r * r) / (2.0 * rho * dist)
