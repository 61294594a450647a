"""The part between two fingers: equilibrium, containment, opening (MODEL 7, 8).

World frame (origin at the palm centre). Finger configurations come in each finger's own frame;
`finger_polyline` places them (the left finger mirrored).
"""
import math

from numba import njit

from ..model import (DISTAL_ONLY, FREE, GAP_TOL, PALM_TOL, PROXIMAL_ONLY, PROXIMAL_TIP, RANGE_TOL,
                     TIP_ONLY, TWO_PHALANX)

TOUCH2 = RANGE_TOL * RANGE_TOL  # squared distance under which two points or segments touch


@njit(cache=True)
def finger_polyline(side, t1, t2, l1, l2, w):
    """World coordinates (Jx, Jy, Bx, By, Tx, Ty) of a finger; side 0 = left, 1 = right."""
    l1c, l1s, l2c, l2s = link_vectors(t1, t2, l1, l2)
    return polyline_from_links(side, w, l1c, l1s, l2c, l2s)


@njit(cache=True)
def link_vectors(t1, t2, l1, l2):
    """The links as vectors in the finger's frame: l1 (cos t1, sin t1), l2 (cos phi, sin phi)."""
    phi = t1 + t2
    return l1 * math.cos(t1), l1 * math.sin(t1), l2 * math.cos(phi), l2 * math.sin(phi)


@njit(cache=True)
def polyline_from_links(side, w, l1c, l1s, l2c, l2s):
    """finger_polyline from the link vectors l1 (cos t1, sin t1), l2 (cos phi, sin phi) in the
    finger's frame (the sweep computes them once per shared field point). The left finger is
    mirrored in x; sign * (l1 cos t1) equals (sign * l1) cos t1 exactly (sign = +-1)."""
    sign = 1.0 if side == 1 else -1.0
    jx = sign * 0.5 * w
    bx = jx + sign * l1c
    tx = bx + sign * l2c
    return jx, 0.0, bx, l1s, tx, l1s + l2s


@njit(cache=True)
def add_contact(angles, n, normal_angle, cone_half_angle):
    """Append the two friction-cone edges of a contact whose normal has this world angle."""
    angles[n] = normal_angle - cone_half_angle
    angles[n + 1] = normal_angle + cone_half_angle
    return n + 2


@njit(cache=True)
def finger_contact_normals(angles, n, side, mode, t1, t2, cone_half_angle):
    """Add the tangent contacts of a finger's final mode (normals a_y, b_y; mirrored on the
    left)."""
    if mode == PROXIMAL_ONLY or mode == TWO_PHALANX or mode == PROXIMAL_TIP:
        a = t1 + 0.5 * math.pi  # angle of a_y in the finger frame
        n = add_contact(angles, n, a if side == 1 else math.pi - a, cone_half_angle)
    if mode == TWO_PHALANX or mode == DISTAL_ONLY:
        b = t1 + t2 + 0.5 * math.pi  # angle of b_y
        n = add_contact(angles, n, b if side == 1 else math.pi - b, cone_half_angle)
    return n


@njit(cache=True)
def tip_contact_normal(angles, n, side, mode, x, y, t1, t2, l1, l2, w, cone_half_angle):
    """Add a finger's tip contact (tip_contact, model-notes D15): normal from the tip to the
    part centre, world frame."""
    if mode == TIP_ONLY or mode == PROXIMAL_TIP:
        _, _, _, _, tx, ty = finger_polyline(side, t1, t2, l1, l2, w)
        n = add_contact(angles, n, math.atan2(y - ty, x - tx), cone_half_angle)
    return n


@njit(cache=True)
def origin_in_cone_hull(angles, n):
    """MODEL 7: the origin lies in the convex hull of unit edge directions iff no angular gap > pi.

    Sorts angles[:n] in place (insertion sort: n <= 10).
    """
    if n == 0:
        return False
    for i in range(n):
        angles[i] = angles[i] % (2.0 * math.pi)
    for i in range(1, n):
        a = angles[i]
        j = i - 1
        while j >= 0 and angles[j] > a:
            angles[j + 1] = angles[j]
            j -= 1
        angles[j + 1] = a
    largest_gap = angles[0] + 2.0 * math.pi - angles[n - 1]
    for i in range(1, n):
        largest_gap = max(largest_gap, angles[i] - angles[i - 1])
    return largest_gap <= math.pi + GAP_TOL


@njit(cache=True)
def touches_palm(x, y, w, r):
    """The part rests on the palm (MODEL 7): |y - r| <= PALM_TOL and |x| <= w/2 + PALM_TOL."""
    return abs(y - r) <= PALM_TOL and abs(x) <= 0.5 * w + PALM_TOL


@njit(cache=True)
def part_in_equilibrium(angles, x, y, w, r, mu, mode_l, t1_l, t2_l, mode_r, t1_r, t2_r, l1, l2,
                        tip):
    """Cone-hull equilibrium of the part with both fingers' tangent contacts, their tip contacts
    (tip_contact: `tip` not None) and the palm.

    `angles` is scratch space of length >= 10. Fewer than two contacts: no equilibrium.
    """
    cone = math.atan(mu)
    n = finger_contact_normals(angles, 0, 0, mode_l, t1_l, t2_l, cone)
    n = finger_contact_normals(angles, n, 1, mode_r, t1_r, t2_r, cone)
    if tip is not None:
        n = tip_contact_normal(angles, n, 0, mode_l, x, y, t1_l, t2_l, l1, l2, w, cone)
        n = tip_contact_normal(angles, n, 1, mode_r, x, y, t1_r, t2_r, l1, l2, w, cone)
    if touches_palm(x, y, w, r):
        n = add_contact(angles, n, 0.5 * math.pi, cone)
    if n < 4:
        return False
    return origin_in_cone_hull(angles, n)


@njit(cache=True)
def _edge_toggles(px, py, ax, ay, bx, by):
    """PNPOLY's crossing rule for one polygon edge (model-notes D5)."""
    return (ay > py) != (by > py) and px < (bx - ax) * (py - ay) / (by - ay) + ax


@njit(cache=True)
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


@njit(cache=True)
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


@njit(cache=True)
def point_segment_distance(px, py, ax, ay, bx, by):
    return math.sqrt(point_segment_distance2(px, py, ax, ay, bx, by))


@njit(cache=True)
def _orientation(ax, ay, bx, by, cx, cy):
    return (bx - ax) * (cy - ay) - (by - ay) * (cx - ax)


@njit(cache=True)
def segments_intersect(ax, ay, bx, by, cx, cy, dx, dy):
    """Segments AB and CD cross, or touch within RANGE_TOL (model-notes D5)."""
    if (_orientation(ax, ay, bx, by, cx, cy) * _orientation(ax, ay, bx, by, dx, dy) < 0.0
            and _orientation(cx, cy, dx, dy, ax, ay) * _orientation(cx, cy, dx, dy, bx, by) < 0.0):
        return True
    return min(point_segment_distance2(ax, ay, cx, cy, dx, dy),
               point_segment_distance2(bx, by, cx, cy, dx, dy),
               point_segment_distance2(cx, cy, ax, ay, bx, by),
               point_segment_distance2(dx, dy, ax, ay, bx, by)) <= TOUCH2


@njit(cache=True)
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


@njit(cache=True)
def mouth_opening(left, right):
    """L_open (MODEL 8): the largest part that could escape between the fingertips; 0 if the
    fingers' polylines intersect."""
    if fingers_cross(left, right):
        return 0.0
    return tip_clearance(left, right)


@njit(cache=True)
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


# ---------------------------------------------------------------------------------------------
# finger_collision (MODEL 9, model-notes D14): the fingers close together and stop where they
# first meet
# ---------------------------------------------------------------------------------------------
MAX_PROGRESS_STEPS = 10_000_000  # defence in depth, as for the reconfiguration path


@njit(cache=True)
def closing_path_angles(progress, t1_end, t2_end, theta2_min):
    """(t1, t2) of a finger at closing progress p along the path to (t1_end, t2_end): the
    rigid sweep t1 = p (distal on its lower stop), then the distal closes about B,
    t2 = theta2_min + (p - t1_end); p is the joint travel t1 + (t2 - theta2_min)."""
    if progress <= t1_end:
        return progress, theta2_min
    return t1_end, min(theta2_min + (progress - t1_end), t2_end)


@njit(cache=True)
def paths_cross_at(progress, t1l, t2l, t1r, t2r, finger, w):
    a1l, a2l = closing_path_angles(progress, t1l, t2l, finger.theta2_min)
    a1r, a2r = closing_path_angles(progress, t1r, t2r, finger.theta2_min)
    return fingers_cross(finger_polyline(0, a1l, a2l, finger.l1, finger.l2, w),
                         finger_polyline(1, a1r, a2r, finger.l1, finger.l2, w))


@njit(cache=True)
def meeting_progress(t1l, t2l, t1r, t2r, finger, w, collision):
    """The last shared progress before the fingers' closing paths first meet (within
    collision.tol), or -1 if they do not meet on the way to their configurations (or already
    touch when open)."""
    th = finger.theta2_min
    p_end = max(t1l + (t2l - th), t1r + (t2r - th))
    if paths_cross_at(0.0, t1l, t2l, t1r, t2r, finger, w):
        return -1.0
    step = collision.progress_step
    n_max = int(min(math.ceil(p_end / step), MAX_PROGRESS_STEPS)) + 1
    # No point of a finger moves faster than (l1 + l2) per unit of progress (dt1 + dt2 <= dp), so
    # fingers a distance D apart cannot meet within D / (2 (l1 + l2)) of progress: those nodes
    # are skipped, which changes no answer (the first node where they meet is the same).
    speed2 = 2.0 * (finger.l1 + finger.l2)
    skip_to = 1 + int(min(paths_gap_at(0.0, t1l, t2l, t1r, t2r, finger, w) / (speed2 * step),
                          float(n_max)))
    for n in range(1, n_max + 1):
        hi = min(n * step, p_end)
        if n < skip_to and hi < p_end:
            continue
        lo = min((n - 1) * step, p_end)
        if paths_cross_at(hi, t1l, t2l, t1r, t2r, finger, w):
            for _ in range(200):  # bisection, bounded
                if hi - lo <= collision.tol:
                    break
                mid = 0.5 * (lo + hi)
                if paths_cross_at(mid, t1l, t2l, t1r, t2r, finger, w):
                    hi = mid
                else:
                    lo = mid
            return lo
        if hi >= p_end:
            break
        gap = paths_gap_at(hi, t1l, t2l, t1r, t2r, finger, w)
        skip_to = n + 1 + int(min(gap / (speed2 * step), float(n_max)))
    return -1.0


@njit(cache=True)
def paths_gap_at(progress, t1l, t2l, t1r, t2r, finger, w):
    """A lower bound, less a safety margin, of the distance between the two fingers at a
    progress where they do not meet (0 if unsure): the least distance between their segments,
    leaving out the two proximal links when they share a base (w = 0), where only a distal
    joint on the other proximal link counts as meeting (fingers_cross)."""
    a1l, a2l = closing_path_angles(progress, t1l, t2l, finger.theta2_min)
    a1r, a2r = closing_path_angles(progress, t1r, t2r, finger.theta2_min)
    jlx, jly, blx, bly, tlx, tly = finger_polyline(0, a1l, a2l, finger.l1, finger.l2, w)
    jrx, jry, brx, bry, trx, try_ = finger_polyline(1, a1r, a2r, finger.l1, finger.l2, w)
    gap2 = min(segment_gap2(jlx, jly, blx, bly, brx, bry, trx, try_),
               segment_gap2(blx, bly, tlx, tly, jrx, jry, brx, bry),
               segment_gap2(blx, bly, tlx, tly, brx, bry, trx, try_))
    if (jlx - jrx) ** 2 + (jly - jry) ** 2 <= TOUCH2:
        gap2 = min(gap2, point_segment_distance2(blx, bly, jrx, jry, brx, bry),
                   point_segment_distance2(brx, bry, jlx, jly, blx, bly))
    else:
        gap2 = min(gap2, segment_gap2(jlx, jly, blx, bly, jrx, jry, brx, bry))
    return max(math.sqrt(gap2) - 1e-9, 0.0)


@njit(cache=True)
def segment_gap2(ax, ay, bx, by, cx, cy, dx, dy):
    """Squared distance between segments AB and CD that do not cross (the least of the four
    endpoint-to-segment distances)."""
    return min(point_segment_distance2(ax, ay, cx, cy, dx, dy),
               point_segment_distance2(bx, by, cx, cy, dx, dy),
               point_segment_distance2(cx, cy, ax, ay, bx, by),
               point_segment_distance2(dx, dy, ax, ay, bx, by))


@njit(cache=True)
def stopped_finger(progress, mode, t1, t2, k1, k2, theta2_min):
    """(changed, mode, t1, t2, k1, k2) of a finger stopped by the other at `progress` of its
    closing path. A finger whose path ends first is at rest (the other's stop): unchanged. A
    finger stopped in its rigid sweep has touched nothing yet (FREE); stopped while its distal
    closes it keeps its proximal contact (PROXIMAL_ONLY) or has none (FREE)."""
    if progress >= t1 + (t2 - theta2_min):
        return False, mode, t1, t2, k1, k2
    a1, a2 = closing_path_angles(progress, t1, t2, theta2_min)
    if progress >= t1 and k1 > 0.0 and (mode == TWO_PHALANX or mode == PROXIMAL_ONLY
                                        or mode == PROXIMAL_TIP):
        return True, PROXIMAL_ONLY, a1, a2, k1, 0.0
    return True, FREE, a1, a2, 0.0, 0.0


@njit(cache=True)
def collide(finger, w, collision, mode_l, t1l, t2l, k1l, k2l, mode_r, t1r, t2r, k1r, k2r):
    """finger_collision at one part position: (changed, left, right), each side (mode, t1, t2,
    k1, k2). Only fingers that cross in their final configurations are re-run: elsewhere they
    are taken not to have met on the way (model-notes D14). Unchanged when the effect is off
    (None)."""
    left = (mode_l, t1l, t2l, k1l, k2l)
    right = (mode_r, t1r, t2r, k1r, k2r)
    if collision is None:
        return False, left, right
    if mode_l < 0 or mode_r < 0:  # the part overlaps a finger's joint: infeasible
        return False, left, right
    if not fingers_cross(finger_polyline(0, t1l, t2l, finger.l1, finger.l2, w),
                         finger_polyline(1, t1r, t2r, finger.l1, finger.l2, w)):
        return False, left, right
    p = meeting_progress(t1l, t2l, t1r, t2r, finger, w, collision)
    if p < 0.0:
        return False, left, right
    th = finger.theta2_min
    cl, ml, a1l, a2l, b1l, b2l = stopped_finger(p, mode_l, t1l, t2l, k1l, k2l, th)
    cr, mr, a1r, a2r, b1r, b2r = stopped_finger(p, mode_r, t1r, t2r, k1r, k2r, th)
    return cl or cr, (ml, a1l, a2l, b1l, b2l), (mr, a1r, a2r, b1r, b2r)


@njit(cache=True)
def resolve_collisions(ys, finger, w, fingers, collision):
    """Apply finger_collision to solved finger fields in place (`collide` at every point);
    returns the number of points where a finger's configuration changed (0 when the effect is
    off: None, compiled out)."""
    if collision is None:
        return 0
    n_changed = 0
    for j in range(ys.shape[0]):
        for i in range(fingers.mode.shape[2]):
            changed, left, right = collide(
                finger, w, collision,
                fingers.mode[0, j, i], fingers.t1[0, j, i], fingers.t2[0, j, i],
                fingers.k1[0, j, i], fingers.k2[0, j, i],
                fingers.mode[1, j, i], fingers.t1[1, j, i], fingers.t2[1, j, i],
                fingers.k1[1, j, i], fingers.k2[1, j, i])
            if not changed:
                continue
            n_changed += 1
            for side in range(2):
                m, a1, a2, k1, k2 = left if side == 0 else right
                fingers.mode[side, j, i] = m
                fingers.t1[side, j, i] = a1
                fingers.t2[side, j, i] = a2
                fingers.k1[side, j, i] = k1
                fingers.k2[side, j, i] = k2
    return n_changed
