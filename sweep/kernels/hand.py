"""The part between the two fingers (MODEL 7, 8): the fingers placed in the world frame
(origin at the palm centre; `finger_polyline` mirrors the left finger), the contact normals and
friction cones, the part's equilibrium test, containment, whether the fingers cross, and the
mouth's opening (`mouth_opening`, L_open of MODEL 8).
"""
import math

import numpy as np

from ..model import (
    DISTAL_ONLY,
    GAP_TOL,
    PALM_TOL,
    PROXIMAL_ONLY,
    PROXIMAL_TIP,
    RANGE_TOL,
    TIP_ONLY,
    TWO_PHALANX,
)
from .jit import entry, inner
from .records import LEFT, RIGHT


# ---------------------------------------------------------------------------------------------
# The part between the fingers
# ---------------------------------------------------------------------------------------------
TOUCH2 = RANGE_TOL * RANGE_TOL  # squared distance under which two points or segments touch
BOX_GAP = 1e-9  # bounding boxes this far apart: the segments neither cross nor touch


@entry
def finger_polyline(side, t1, t2, l1, l2, w):
    """World coordinates (Jx, Jy, Bx, By, Tx, Ty) of a finger; side 0 = left, 1 = right."""
    l1c, l1s, l2c, l2s = link_vectors(t1, t2, l1, l2)
    return polyline_from_links(side, w, l1c, l1s, l2c, l2s)


@inner
def link_vectors(t1, t2, l1, l2):
    """The links as vectors in the finger's frame: l1 (cos t1, sin t1), l2 (cos phi, sin phi)."""
    phi = t1 + t2
    return l1 * math.cos(t1), l1 * math.sin(t1), l2 * math.cos(phi), l2 * math.sin(phi)


@inner
def polyline_from_links(side, w, l1c, l1s, l2c, l2s):
    """finger_polyline from the link vectors l1 (cos t1, sin t1), l2 (cos phi, sin phi) in the
    finger's frame (the sweep computes them once per shared field point). The left finger is
    mirrored in x; sign * (l1 cos t1) equals (sign * l1) cos t1 exactly (sign = +-1)."""
    sign = 1.0 if side == 1 else -1.0
    jx = sign * 0.5 * w
    bx = jx + sign * l1c
    tx = bx + sign * l2c
    return jx, 0.0, bx, l1s, tx, l1s + l2s


@inner
def add_contact(angles, n, normal_angle, cone_half_angle):
    """Append the two friction-cone edges of a contact whose normal has this world angle."""
    angles[n] = normal_angle - cone_half_angle
    angles[n + 1] = normal_angle + cone_half_angle
    return n + 2


@inner
def finger_contact_normals(side, mode, t1, t2):
    """The world angles of a finger's tangent contact normals in its final mode (a_y, b_y;
    mirrored on the left): (how many, first, second). Angles, not the cone's array: a kernel
    that takes an array and calls another pays a reference-count pair per call
    (docs/performance.md), and this runs at every stable-candidate point."""
    count = 0
    first = 0.0
    second = 0.0
    if mode == PROXIMAL_ONLY or mode == TWO_PHALANX or mode == PROXIMAL_TIP:
        a = t1 + 0.5 * math.pi  # angle of a_y in the finger frame
        first = a if side == 1 else math.pi - a
        count = 1
    if mode == TWO_PHALANX or mode == DISTAL_ONLY:
        b = t1 + t2 + 0.5 * math.pi  # angle of b_y
        b = b if side == 1 else math.pi - b
        if count == 0:
            first = b
        else:
            second = b
        count += 1
    return count, first, second


@inner
def tip_contact_normal(side, mode, x, y, t1, t2, l1, l2, w):
    """A finger's tip contact (tip_contact, model-notes D15): (whether it has one, the world
    angle of its normal, from the tip to the part centre)."""
    if mode == TIP_ONLY or mode == PROXIMAL_TIP:
        _, _, _, _, tx, ty = finger_polyline(side, t1, t2, l1, l2, w)
        return True, math.atan2(y - ty, x - tx)
    return False, 0.0


@inner(inline="always")
def origin_in_cone_hull(angles, n):
    """MODEL 7: the origin lies in the convex hull of unit edge directions iff no angular gap > pi.

    Sorts angles[:n] in place (n <= 10).
    """
    if n == 0:
        return False
    for i in range(n):
        angles[i] = angle_in_turn(angles[i])
    sort_small(angles, n)
    largest_gap = angles[0] + 2.0 * math.pi - angles[n - 1]
    for i in range(1, n):
        largest_gap = max(largest_gap, angles[i] - angles[i - 1])
    return largest_gap <= math.pi + GAP_TOL


@entry
def angle_in_turn(a):
    """a % (2 pi), Python's float modulo (in [0, 2 pi)), the same bits without a call to fmod
    for the angles the cone hull meets, within one turn of [0, 2 pi): there fmod(a, 2 pi) is a
    itself or a - 2 pi exactly (Sterbenz), so only the final addition rounds, as in `%`."""
    turn = 2.0 * math.pi
    if 0.0 < a < turn:
        return a
    if -turn <= a < 0.0:
        return a + turn
    if turn <= a < 2.0 * turn:
        return a - turn
    if a == 0.0:
        return 0.0  # -0.0 % turn is +0.0
    return a % turn


@inner(inline="always")
def sort_small(values, n):
    """Sort values[:n] in place, ascending (insertion sort: a handful of values, where np.sort
    costs more than the sorting)."""
    for i in range(1, n):
        a = values[i]
        j = i - 1
        while j >= 0 and values[j] > a:
            values[j + 1] = values[j]
            j -= 1
        values[j + 1] = a


@entry
def touches_palm(x, y, w, r):
    """The part rests on the palm (MODEL 7): |y - r| <= PALM_TOL and |x| <= w/2 + PALM_TOL."""
    return abs(y - r) <= PALM_TOL and abs(x) <= 0.5 * w + PALM_TOL


@inner
def friction_cones(mu_palm, mu_left, mu_right):
    """The friction cones' half-angles atan(mu) of the palm and of each finger's contacts
    (MODEL 7; per finger: MODEL 10, Scenario C), once per row of a map, not per point."""
    return math.atan(mu_palm), math.atan(mu_left), math.atan(mu_right)


@inner
def part_in_equilibrium(angles, x, y, w, r, cones, mode_l, t1_l, t2_l, mode_r, t1_r, t2_r, l1,
                        l2, tip_contact):
    """Cone-hull equilibrium of the part with both fingers' tangent contacts, their tip contacts
    (with tip_contact: `tip.on`) and the palm, each contact with its own friction cone:
    `cones` = (palm, left finger, right finger) half-angles (`friction_cones`).

    `angles` is scratch space of length >= 10. Fewer than two contacts: no equilibrium.
    """
    cone_palm, cone_l, cone_r = cones
    n = np.int64(0)   # (a literal 0 would compile add_contact a second time, for Literal[int](0))
    count, first, second = finger_contact_normals(LEFT, mode_l, t1_l, t2_l)
    if count > 0:
        n = add_contact(angles, n, first, cone_l)
    if count > 1:
        n = add_contact(angles, n, second, cone_l)
    count, first, second = finger_contact_normals(RIGHT, mode_r, t1_r, t2_r)
    if count > 0:
        n = add_contact(angles, n, first, cone_r)
    if count > 1:
        n = add_contact(angles, n, second, cone_r)
    if tip_contact.on:
        has_tip, normal = tip_contact_normal(LEFT, mode_l, x, y, t1_l, t2_l, l1, l2, w)
        if has_tip:
            n = add_contact(angles, n, normal, cone_l)
        has_tip, normal = tip_contact_normal(RIGHT, mode_r, x, y, t1_r, t2_r, l1, l2, w)
        if has_tip:
            n = add_contact(angles, n, normal, cone_r)
    if touches_palm(x, y, w, r):
        n = add_contact(angles, n, 0.5 * math.pi, cone_palm)
    if n < 4:
        return False
    return origin_in_cone_hull(angles, n)


@inner
def _edge_toggles(px, py, ax, ay, bx, by):
    """PNPOLY's crossing rule for one polygon edge (model-notes D5)."""
    return (ay > py) != (by > py) and px < (bx - ax) * (py - ay) / (by - ay) + ax


@entry
def part_contained(px, py, left, right):
    """The part centre strictly inside the polygon J_L, B_L, T_L, T_R, B_R, J_R.

    Even-odd (PNPOLY) test; a centre within RANGE_TOL of the boundary (e.g. exactly on the mouth
    segment T_L-T_R) is not contained, so boundary points are decided by a tolerance, not by
    round-off (model-notes D5).
    """
    jlx, jly, blx, bly, tlx, tly = left
    jrx, jry, brx, bry, trx, try_ = right
    inside = False
    if _edge_toggles(px, py, jlx, jly, blx, bly):
        inside = not inside
    if _edge_toggles(px, py, blx, bly, tlx, tly):
        inside = not inside
    if _edge_toggles(px, py, tlx, tly, trx, try_):
        inside = not inside
    if _edge_toggles(px, py, trx, try_, brx, bry):
        inside = not inside
    if _edge_toggles(px, py, brx, bry, jrx, jry):
        inside = not inside
    if _edge_toggles(px, py, jrx, jry, jlx, jly):
        inside = not inside
    if not inside:
        return False
    boundary = min(point_segment_distance2(px, py, jlx, jly, blx, bly),
                   point_segment_distance2(px, py, blx, bly, tlx, tly),
                   point_segment_distance2(px, py, tlx, tly, trx, try_),
                   point_segment_distance2(px, py, trx, try_, brx, bry),
                   point_segment_distance2(px, py, brx, bry, jrx, jry),
                   point_segment_distance2(px, py, jrx, jry, jlx, jly))
    return boundary > TOUCH2


@inner
def point_segment_distance2(px, py, ax, ay, bx, by):
    """Squared distance from a point to a segment."""
    vx = bx - ax
    vy = by - ay
    length2 = vx * vx + vy * vy
    s = 0.0
    if length2 > 0.0:
        s = min(max(((px - ax) * vx + (py - ay) * vy) / length2, 0.0), 1.0)
    dx = px - (ax + s * vx)
    dy = py - (ay + s * vy)
    return dx * dx + dy * dy


@inner
def point_segment_distance(px, py, ax, ay, bx, by):
    return math.sqrt(point_segment_distance2(px, py, ax, ay, bx, by))


@inner
def _orientation(ax, ay, bx, by, cx, cy):
    return (bx - ax) * (cy - ay) - (by - ay) * (cx - ax)


@inner
def segments_intersect(ax, ay, bx, by, cx, cy, dx, dy):
    """Segments AB and CD cross, or touch within RANGE_TOL (model-notes D5).

    Segments whose bounding boxes are more than BOX_GAP apart do neither (the answer the
    full test gives, found without it)."""
    if (max(ax, bx) < min(cx, dx) - BOX_GAP or max(cx, dx) < min(ax, bx) - BOX_GAP
            or max(ay, by) < min(cy, dy) - BOX_GAP or max(cy, dy) < min(ay, by) - BOX_GAP):
        return False
    if (_orientation(ax, ay, bx, by, cx, cy) * _orientation(ax, ay, bx, by, dx, dy) < 0.0
            and _orientation(cx, cy, dx, dy, ax, ay) * _orientation(cx, cy, dx, dy, bx, by) < 0.0):
        return True
    return min(point_segment_distance2(ax, ay, cx, cy, dx, dy),
               point_segment_distance2(bx, by, cx, cy, dx, dy),
               point_segment_distance2(cx, cy, ax, ay, bx, by),
               point_segment_distance2(dx, dy, ax, ay, bx, by)) <= TOUCH2


@entry
def fingers_cross(left, right):
    """The two fingers' polylines intersect (cross or touch), not counting a shared base.

    With w = 0 both proximal links start at the palm centre; they meet elsewhere only if they
    overlap, i.e. one distal joint lies on the other proximal link.
    """
    jlx, jly, blx, bly, tlx, tly = left
    jrx, jry, brx, bry, trx, try_ = right
    if (jlx - jrx) ** 2 + (jly - jry) ** 2 <= TOUCH2:
        proximal_pair = (point_segment_distance2(blx, bly, jrx, jry, brx, bry) <= TOUCH2
                         or point_segment_distance2(brx, bry, jlx, jly, blx, bly) <= TOUCH2)
    else:
        proximal_pair = segments_intersect(jlx, jly, blx, bly, jrx, jry, brx, bry)
    return (proximal_pair
            or segments_intersect(jlx, jly, blx, bly, brx, bry, trx, try_)
            or segments_intersect(blx, bly, tlx, tly, jrx, jry, brx, bry)
            or segments_intersect(blx, bly, tlx, tly, brx, bry, trx, try_))


@entry
def mouth_opening(left, right, crossed):
    """L_open (MODEL 8): the largest part that could escape between the fingertips; 0 if the
    fingers' polylines intersect (`crossed`: `fingers_cross(left, right)`, which the caller
    needs too)."""
    if crossed:
        return 0.0
    return tip_clearance(left, right)


@inner
def tip_clearance(left, right):
    """L_open of fingers known not to intersect: the least tip-to-tip and tip-to-finger distance."""
    jlx, jly, blx, bly, tlx, tly = left
    jrx, jry, brx, bry, trx, try_ = right
    opening = math.sqrt((tlx - trx) ** 2 + (tly - try_) ** 2)
    opening = min(opening, point_segment_distance(tlx, tly, jrx, jry, brx, bry))
    opening = min(opening, point_segment_distance(tlx, tly, brx, bry, trx, try_))
    opening = min(opening, point_segment_distance(trx, try_, jlx, jly, blx, bly))
    opening = min(opening, point_segment_distance(trx, try_, blx, bly, tlx, tly))
    return opening
