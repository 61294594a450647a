"""One finger's contact geometry (MODEL 3) and vertex strikes (MODEL 4), in closed form.

Right-finger frame: origin at the proximal joint J, `d = p - J` the part's centre; the left
finger calls the same code with `d` mirrored. Functions return `math.inf` (NO_ANGLE) or a
negative length for "no such contact" instead of raising, so they run on any input. The
`*_slack` functions measure by how much a closed-form contact misses being exact: a tangency
that round-off would reject is decided by them the way that keeps links out of the part
(MODEL 4, model-notes D30).
"""
import math

from ..model import RANGE_TOL, TOUCH_REL
from .jit import entry, inner


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
def rigid_sweep(r, l1, theta2_min):
    """A finger's constants of the rigid sweep (MODEL 3.3): (r' = rigid_sweep_offset,
    l1 cos theta2_min), computed once per finger, not per point (docs/performance.md)."""
    return rigid_sweep_offset(r, l1, theta2_min), l1 * math.cos(theta2_min)


@inner
def tangent_length_error(k, delta):
    """Round-off of a tangent length k = sqrt(D - r^2) whose D carries an absolute error
    delta: delta / (2 k), and sqrt(delta) once k^2 is below delta."""
    return delta / (2.0 * k) if k * k > delta else math.sqrt(delta)


@inner
def rigid_tangency_slack(dx, dy, l1, r_eff, l1_cos_min, k2):
    """(slack of k2, slack of t1) of MODEL 3.3's tangency: RANGE_TOL plus their round-off.
    K = k2 + l1 cos(theta2_min) = sqrt(|d|^2 - r'^2) comes through asin(r'/|d|), which near 1
    leaves K known only to about sqrt(eps) |d| and the angle to about K's error / r'. With
    theta2_min near -90 deg a tangency at k2 = 0 (the distal link tangent at B as B grazes
    the disc) is exactly there, and RANGE_TOL alone let round-off reject it (model-notes
    D30). r_eff = rigid_sweep_offset, l1_cos_min = l1 cos(theta2_min) (rigid_sweep)."""
    dist2 = dx * dx + dy * dy
    big = max(dist2, r_eff * r_eff)
    dk = (tangent_length_error(max(k2 + l1_cos_min, 0.0), 8.0 * EPS * big)
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
def proximal_tangency(alpha, dx, dy, r):
    """MODEL 3.1: (t1, k1) of the proximal link tangent to the part; k1 < 0 if d is inside the
    disc. alpha = atan2(dy, dx), the polar angle of d: the closing sweep computes it once for
    all its events (the same bits, one arctangent instead of up to four, docs/performance.md).
    """
    k1 = tangent_length(dx * dx + dy * dy, r)
    if k1 < 0.0:
        return NO_ANGLE, -1.0
    return alpha - math.atan2(r, k1), k1


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
def rigid_distal_tangency(alpha, dx, dy, theta2_min, r_eff, l1_cos_min):
    """MODEL 3.3: (t1, k2) of the distal link (held at theta2_min) tangent during the rigid sweep;
    alpha = atan2(dy, dx) (proximal_tangency), r_eff and l1_cos_min the finger's (rigid_sweep).

    Returns (inf, -1) if the distal line never reaches the part.
    """
    dist2 = dx * dx + dy * dy
    if dist2 < r_eff * r_eff * (1.0 - TOUCH_REL):
        return NO_ANGLE, -1.0
    dist = math.sqrt(dist2)
    offset = math.asin(min(r_eff / dist, 1.0))  # alpha - phi
    phi = alpha - offset
    k2 = dist * math.cos(offset) - l1_cos_min
    return phi - theta2_min, k2


@entry
def vertex_entry(dx, dy, rho, delta, r):
    """MODEL 4: turning angle at which a vertex at radius rho, polar offset delta, enters the disc.

    The vertex turns counter-clockwise about the origin of (dx, dy). Returns inf if it never does,
    or only grazes the disc (model-notes D3).
    """
    return vertex_entry_at(math.atan2(dy, dx), dx, dy, rho, delta, r)


@inner
def enters_disc(c):
    """Whether a vertex whose MODEL 4 acos argument is c enters the disc: a graze (c = 1)
    touches without entering, c < -1 never reaches it."""
    return -1.0 <= c < 1.0 - RANGE_TOL


@inner
def vertex_entry_at(alpha, dx, dy, rho, delta, r):
    """vertex_entry with alpha = atan2(dy, dx) given (proximal_tangency)."""
    c = entry_cosine(dx, dy, rho, r)
    if not enters_disc(c):
        return NO_ANGLE
    return alpha - math.acos(c) - delta


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
def joint_strike_angle(alpha, dx, dy, l1, r):
    """MODEL 4: the rigid sweep's angle at which B, turning about J, strikes the
    part. A graze of B counts (vertex_entry ignores it): a link attached to B enters the disc
    just after, the distal link when the disc is outside B's circle (it leaves B at
    theta2_min > -90 deg from the proximal, towards the centre) and the proximal link when it
    is inside. A graze is the acos argument within RANGE_TOL below 1 or within its own
    round-off above it (model-notes D30). alpha = atan2(dy, dx) (proximal_tangency)."""
    t_b = vertex_entry_at(alpha, dx, dy, l1, 0.0, r)
    if t_b != NO_ANGLE:
        return t_b
    c = entry_cosine(dx, dy, l1, r)
    dist2 = dx * dx + dy * dy
    err_c = 4.0 * EPS * (l1 * l1 + dist2 + r * r) / (2.0 * l1 * math.sqrt(dist2))
    if c < 1.0 - RANGE_TOL or c > 1.0 + err_c:
        return NO_ANGLE
    return alpha - math.acos(min(c, 1.0))
