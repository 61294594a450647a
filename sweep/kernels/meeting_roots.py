"""Where a vertex of one finger first meets a segment of the other, in closed form (MODEL 9,
model-notes D14, "How a map finds the meeting", step 2).

After the first proximal contact each finger rests or turns about a fixed joint (rigid sweep
about J, distal closing about B), so a vertex first meets a segment where a circle crosses the
segment (one finger at rest: `one_term_root`) or at the first root of a sum of sines of
frequencies 1 and 2 (both turning: safe steps, `two_term_root`). A contact approached slower
than GRAZING_SPEED is UNSURE: the search decides it.
"""
import math

from ..model import RANGE_TOL
from .jit import inner
from .hand import point_segment_distance2


GRAZING_SPEED = 1e-4     # a contact approached slower (distance per rad) is left to the search
SAFE_STEPS = 200         # bound on the safe steps of one contact search
NO_CONTACT = math.inf
UNSURE = -1.0            # a contact search that could not decide


@inner
def finger_motion(progress, t1_end, t2_end, theta2_min):
    """How a finger moves just after `progress`: 2 rigid sweep (about J), 1 distal closing
    (about B), 0 at rest."""
    if progress < t1_end:
        return 2
    if progress < t1_end + (t2_end - theta2_min):
        return 1
    return 0


@inner
def turning(side, motion, point):
    """(rate, centre) of a finger's vertex (point 0 J, 1 B, 2 T) or link (by its far end:
    1 proximal, 2 distal) while the finger moves by `motion`: the rate is the world rotation
    per unit progress (right +1, left -1; 0 at rest), the centre 0 (J) or 1 (B)."""
    rate = 1.0 if side == 1 else -1.0
    if motion == 2 and point > 0:
        return rate, 0
    if motion == 1 and point == 2:
        return rate, 1
    return 0.0, 0


@inner
def vertex_segment_contact(kx, ky, ex, ey, w1, xx, xy, w2, ux, uy, nd, theta_max):
    """First theta in [0, theta_max] at which Y(theta) = K + R(w1 theta) E + R(w2 theta) X
    (w1 = +-1, w2 = +-2: both fingers turn) lies on the segment from the origin along the
    unit vector u, of length nd, with the contact's approach speed (distance per unit theta);
    NO_CONTACT if none, UNSURE if the contact is grazing or the search cannot decide.

    The signed distance to the segment's line and the position along it are sums of cosines
    and sines of w1 theta and w2 theta; safe steps find the first root (`two_term_root`).
    With one finger at rest, `one_term_root` finds it in closed form."""
    # f = f0 + p1 cos(w1 t) + q1 sin(w1 t) + p2 cos(w2 t) + q2 sin(w2 t); g likewise
    f0 = ux * ky - uy * kx
    g0 = ux * kx + uy * ky
    p1 = ux * ey - uy * ex
    q1 = ux * ex + uy * ey
    p2 = ux * xy - uy * xx
    q2 = ux * xx + uy * xy
    a1 = math.sqrt(p1 * p1 + q1 * q1)
    a2 = math.sqrt(p2 * p2 + q2 * q2)
    if abs(f0) > a1 + a2 + 1e-9 or g0 + a1 + a2 < -1e-9 or g0 - a1 - a2 > nd + 1e-9:
        return NO_CONTACT, 0.0  # the line, or the segment's span, is never reached
    # the vertex stays between |a1 - a2| and a1 + a2 from the segment's centre of turn (at K
    # from the segment's start): the segment's points must reach that annulus
    near = math.sqrt(point_segment_distance2(kx, ky, 0.0, 0.0, ux * nd, uy * nd))
    far = math.sqrt(max(kx * kx + ky * ky, (kx - ux * nd) ** 2 + (ky - uy * nd) ** 2))
    if near > a1 + a2 + 1e-9 or far < abs(a1 - a2) - 1e-9:
        return NO_CONTACT, 0.0
    return two_term_root(f0, g0, p1, q1, a1, w1, p2, q2, a2, w2, nd, theta_max)


@inner
def contact_or_not(g, speed, nd):
    """A root of the line distance is a contact if it lies within the segment's span."""
    if -RANGE_TOL <= g <= nd + RANGE_TOL:
        if speed < GRAZING_SPEED:
            return False, True
        return True, False
    return False, False


@inner
def one_term_root(kx, ky, xx, xy, w, ux, uy, nd, theta_max, limit_pseudo_angle):
    """vertex_segment_contact for Y(theta) = K + R(w theta) X, w = +-1: a circle about K of
    radius |X|, met by the segment {t u, 0 <= t <= nd} where
    t^2 - 2 t (u . K) + |K|^2 - |X|^2 = 0, i.e. t = b +- sqrt(disc) with b = u . K and
    disc = |X|^2 - (u x K)^2; the point crosses the line there at speed sqrt(disc).
    `limit_pseudo_angle`: pseudo_angle of theta_max (4 or more: any turn)."""
    rho2 = xx * xx + xy * xy
    f_start = ux * (ky + xy) - uy * (kx + xx)  # signed distance to the line at theta = 0
    reach2 = rho2 * theta_max * theta_max  # |dY/dtheta| = |X|
    if f_start * f_start > reach2:
        return NO_CONTACT, 0.0
    g_start = ux * (kx + xx) + uy * (ky + xy)
    if g_start < -RANGE_TOL and g_start * g_start > reach2 or \
            g_start > nd + RANGE_TOL and (g_start - nd) ** 2 > reach2:
        return NO_CONTACT, 0.0
    b = ux * kx + uy * ky
    h = ux * ky - uy * kx
    disc = rho2 - h * h
    if disc < GRAZING_SPEED * GRAZING_SPEED:
        if disc > -2.0 * RANGE_TOL * math.sqrt(rho2) and -RANGE_TOL <= b <= nd + RANGE_TOL:
            return UNSURE, 0.0  # the circle touches, or nearly, the segment
        if disc < 0.0:
            return NO_CONTACT, 0.0
    speed = math.sqrt(max(disc, 0.0))
    best = math.inf
    for t in (b - speed, b + speed):
        if t < -RANGE_TOL or t > nd + RANGE_TOL:
            continue
        zx = t * ux - kx  # the contact point less the centre: X turned by w theta
        zy = t * uy - ky
        sin_turn = w * (xx * zy - xy * zx)
        cos_turn = xx * zx + xy * zy
        if pseudo_angle(cos_turn / rho2, sin_turn) > limit_pseudo_angle:
            continue  # turned farther than theta_max (checked without the arctangent)
        turn = math.atan2(sin_turn, cos_turn) % (2.0 * math.pi)
        if turn <= theta_max:
            best = min(best, turn)
    if best == math.inf:
        return NO_CONTACT, 0.0
    if speed < GRAZING_SPEED:
        return UNSURE, 0.0
    return best, speed


@inner
def pseudo_angle(cos_a, sin_a):
    """A monotone function of the angle a in [0, 2 pi) from its cosine and the sign of its
    sine: 1 - cos a on [0, pi], 3 + cos a on (pi, 2 pi); 4 and more for a >= 2 pi."""
    return 1.0 - cos_a if sin_a >= 0.0 else 3.0 + cos_a


@inner
def limit_pseudo_angle(theta_max):
    """pseudo_angle of a search limit (with a margin: the arctangent decides near it)."""
    if theta_max >= 2.0 * math.pi:
        return 5.0
    return pseudo_angle(math.cos(theta_max), math.sin(theta_max)) + 1e-9


@inner
def two_terms(f0, p1, q1, w1, p2, q2, w2, theta):
    """(f, f', c1, s1, c2, s2) of f = f0 + p1 cos(w1 t) + q1 sin(w1 t) + p2 cos(w2 t) + ..."""
    c = math.cos(theta)
    s = math.sin(theta)
    c1 = c
    s1 = s * w1
    if w2 == 1.0 or w2 == -1.0:
        c2 = c
        s2 = s * w2
    else:
        c2 = c * c - s * s
        s2 = s * c * w2
    f = f0 + p1 * c1 + q1 * s1 + p2 * c2 + q2 * s2
    fp = w1 * (q1 * c1 - p1 * s1) + w2 * (q2 * c2 - p2 * s2)
    return f, fp, c1, s1, c2, s2


@inner
def two_term_root(f0, g0, p1, q1, a1, w1, p2, q2, a2, w2, nd, theta_max):
    """vertex_segment_contact with both fingers turning (w1 = +-1, w2 = +-2).

    |f''| <= L2 = w1^2 a1 + w2^2 a2, so from theta no root lies within the h where
    |f| - v h - L2 h^2 / 2 stays positive (v the speed towards the line): those safe steps
    never pass a root, and near one they are Newton steps (quadratic)."""
    l2 = w1 * w1 * a1 + w2 * w2 * a2
    theta = 0.0
    f = f0 + p1 + p2  # at theta = 0 without trigonometry
    reach = (abs(w1) * a1 + abs(w2) * a2) * theta_max
    g = g0 + q1 + q2
    if abs(f) > reach or g + reach < -RANGE_TOL or g - reach > nd + RANGE_TOL:
        return NO_CONTACT, 0.0
    fp = w1 * q1 + w2 * q2
    c1, s1, c2, s2 = 1.0, 0.0, 1.0, 0.0
    f_prev = 0.0
    for it in range(SAFE_STEPS):
        if it > 0:
            f, fp, c1, s1, c2, s2 = two_terms(f0, p1, q1, w1, p2, q2, w2, theta)
        if f_prev != 0.0 and (f > 0.0) != (f_prev > 0.0):
            # the last step passed a root (round-off at a safe step's limit): back to it
            if fp != 0.0:
                theta -= f / fp
            f = 0.0
        af = abs(f)
        approach = -fp if f > 0.0 else fp
        if af <= 1e-15 * (1.0 + a1 + a2):  # at a root: a contact if within the span
            if approach > 0.0:
                theta += af / approach
            ok, grazing = contact_or_not(g0 + q1 * c1 - p1 * s1 + q2 * c2 - p2 * s2, abs(fp), nd)
            if grazing:
                return UNSURE, 0.0
            if ok:
                return theta, abs(fp)
            theta += 1e-12  # past a root off the segment: the search goes on
            f_prev = 0.0
        else:
            if af <= 2.0 * RANGE_TOL and abs(approach) <= GRAZING_SPEED and -RANGE_TOL <= (
                    g0 + q1 * c1 - p1 * s1 + q2 * c2 - p2 * s2) <= nd + RANGE_TOL:
                return UNSURE, 0.0  # within touching distance of the segment, not crossing
            if approach > 0.0:
                h = 2.0 * af / (approach + math.sqrt(approach * approach + 2.0 * l2 * af))
            else:
                h = (-approach + math.sqrt(approach * approach + 2.0 * l2 * af)) / l2
            f_prev = f
            theta += h
        if theta > theta_max:
            return NO_CONTACT, 0.0
    return UNSURE, 0.0
