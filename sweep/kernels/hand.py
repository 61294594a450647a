"""Two fingers and the part (MODEL 7-9): where the part sits between the fingers (equilibrium,
containment, opening), and `finger_collision` (MODEL 9, model-notes D14): the fingers close
together and stop where they first meet.

*The part.*
World frame (origin at the palm centre). Finger configurations come in each finger's own frame;
`finger_polyline` places them (the left finger mirrored).

*Finger collision.*
Both fingers advance along their closing paths with a shared progress p (the joint travel
t1 + (t2 - theta2_min)). The meeting is defined by a search: step p by
`collision.progress_step` to the first node where the polylines cross (`fingers_cross`), then
bisect that step to `collision.tol` (`meeting_progress`, the reference). A map finds the same
bits faster (`resolve_collisions`, model-notes D14 "How a map finds the meeting"):

1. Until the first finger's proximal contact (p <= a = min t1) both fingers sweep rigidly and
   are mirror images, so the symmetric closing's meeting is one search per map
   (`symmetric_meeting`); every point whose first crossing node falls in it takes its answer.
2. After a, each finger rests or turns about a fixed joint (rigid sweep about J, distal
   closing about B), so a vertex of one finger first meets a segment of the other where a
   circle crosses the segment (one finger at rest: closed form, `one_term_root`) or at the
   first root of a sum of sines of frequencies 1 and 2 (both turning: safe steps,
   `two_term_root`). The earliest contact (`first_contact`) locates the first crossing node
   and the bisection's switch point; the reference's bisection is then replayed
   (`predicted_meeting`) with its own predicate evaluated only where the replay cannot be
   sure, and the final bracket and the node are checked with it. A point where a check fails,
   or the contact is grazing, is searched by the reference from the node after a.
3. Answers are reused where the inputs are the same numbers: the mirror point, the left
   neighbour, and in the sweep a per-thread memo across the cells of one geometry group
   (records.SettledFingers). `collide` does one point anywhere, with the symmetric sweep as
   the first phase of its contact search.

A finger that took the tip path (tip_contact) is stopped on its own path instead
(model-notes D29, `field.collide_on_own_paths`); `resolve_collisions` leaves such points alone.
"""
import math
import numpy as np


from .jit import entry, inner
from .records import LEFT, RIGHT
from ..model import (
    DISTAL_ONLY,
    FREE,
    GAP_TOL,
    PALM_TOL,
    PROXIMAL_ONLY,
    PROXIMAL_TIP,
    RANGE_TOL,
    TIP_ONLY,
    TWO_PHALANX,
)


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


@inner
def tip_contact_normal(angles, n, side, mode, x, y, t1, t2, l1, l2, w, cone_half_angle):
    """Add a finger's tip contact (tip_contact, model-notes D15): normal from the tip to the
    part centre, world frame."""
    if mode == TIP_ONLY or mode == PROXIMAL_TIP:
        _, _, _, _, tx, ty = finger_polyline(side, t1, t2, l1, l2, w)
        n = add_contact(angles, n, math.atan2(y - ty, x - tx), cone_half_angle)
    return n


@inner
def origin_in_cone_hull(angles, n):
    """MODEL 7: the origin lies in the convex hull of unit edge directions iff no angular gap > pi.

    Sorts angles[:n] in place (n <= 10).
    """
    if n == 0:
        return False
    for i in range(n):
        angles[i] = angles[i] % (2.0 * math.pi)
    sort_small(angles, n)
    largest_gap = angles[0] + 2.0 * math.pi - angles[n - 1]
    for i in range(1, n):
        largest_gap = max(largest_gap, angles[i] - angles[i - 1])
    return largest_gap <= math.pi + GAP_TOL


@inner
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
                        l2, tip):
    """Cone-hull equilibrium of the part with both fingers' tangent contacts, their tip contacts
    (with tip_contact: `tip.on`) and the palm, each contact with its own friction cone:
    `cones` = (palm, left finger, right finger) half-angles (`friction_cones`).

    `angles` is scratch space of length >= 10. Fewer than two contacts: no equilibrium.
    """
    cone_palm, cone_l, cone_r = cones
    n = finger_contact_normals(angles, np.int64(0), LEFT, mode_l, t1_l, t2_l, cone_l)
    n = finger_contact_normals(angles, n, RIGHT, mode_r, t1_r, t2_r, cone_r)
    if tip.on:
        n = tip_contact_normal(angles, n, LEFT, mode_l, x, y, t1_l, t2_l, l1, l2, w, cone_l)
        n = tip_contact_normal(angles, n, RIGHT, mode_r, x, y, t1_r, t2_r, l1, l2, w, cone_r)
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
def mouth_opening(left, right):
    """L_open (MODEL 8): the largest part that could escape between the fingertips; 0 if the
    fingers' polylines intersect."""
    if fingers_cross(left, right):
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


# ---------------------------------------------------------------------------------------------
# Finger collision
# ---------------------------------------------------------------------------------------------
MAX_PROGRESS_STEPS = 10_000_000  # defence in depth, as for the reconfiguration path


# ---------------------------------------------------------------------------------------------
# The rule and its reference search
# ---------------------------------------------------------------------------------------------
@inner
def closing_path_angles(progress, t1_end, t2_end, theta2_min):
    """(t1, t2) of a finger at closing progress p along the path to (t1_end, t2_end): the
    rigid sweep t1 = p (distal on its lower stop), then the distal closes about B,
    t2 = theta2_min + (p - t1_end); p is the joint travel t1 + (t2 - theta2_min)."""
    if progress <= t1_end:
        return progress, theta2_min
    return t1_end, min(theta2_min + (progress - t1_end), t2_end)


@entry
def paths_cross_at(progress, t1l, t2l, t1r, t2r, finger, w):
    a1l, a2l = closing_path_angles(progress, t1l, t2l, finger.theta2_min)
    a1r, a2r = closing_path_angles(progress, t1r, t2r, finger.theta2_min)
    return fingers_cross(finger_polyline(LEFT, a1l, a2l, finger.l1, finger.l2, w),
                         finger_polyline(RIGHT, a1r, a2r, finger.l1, finger.l2, w))


@inner
def path_end(t1l, t2l, t1r, t2r, theta2_min):
    """The progress at which the later finger's closing path ends."""
    return max(t1l + (t2l - theta2_min), t1r + (t2r - theta2_min))


@inner
def node_progress(n, step, p_end):
    """Progress of search node n (the last node is the end of the paths)."""
    return min(n * step, p_end)


@entry
def meeting_progress(t1l, t2l, t1r, t2r, finger, w, collision):
    """The last shared progress before the fingers' closing paths first meet (within
    collision.tol), or -1 if they do not meet on the way to their configurations (or already
    touch when open). The reference search: every node from the start."""
    if paths_cross_at(0.0, t1l, t2l, t1r, t2r, finger, w):
        return -1.0
    n = first_crossing_node(t1l, t2l, t1r, t2r, finger, w, collision, np.int64(1))
    if n < 0:
        return -1.0
    return bisect_crossing_step(n, t1l, t2l, t1r, t2r, finger, w, collision)


@inner
def first_crossing_node(t1l, t2l, t1r, t2r, finger, w, collision, n_start):
    """The first search node n >= n_start where the fingers cross (-1 if none), the nodes
    before n_start being known not to cross.

    No point of a finger moves faster than (l1 + l2) per unit of progress (dt1 + dt2 <= dp),
    so fingers a distance D apart cannot meet within D / (2 (l1 + l2)) of progress: those
    nodes are skipped, which changes no answer (the first node where they cross is the same)."""
    p_end = path_end(t1l, t2l, t1r, t2r, finger.theta2_min)
    step = collision.progress_step
    n_max = int(min(math.ceil(p_end / step), MAX_PROGRESS_STEPS)) + 1
    speed2 = 2.0 * (finger.l1 + finger.l2)
    gap = paths_gap_at(node_progress(n_start - 1, step, p_end), t1l, t2l, t1r, t2r, finger, w)
    skip_to = n_start + int(min(gap / (speed2 * step), float(n_max)))
    for n in range(n_start, n_max + 1):
        hi = node_progress(n, step, p_end)
        if n < skip_to and hi < p_end:
            continue
        if paths_cross_at(hi, t1l, t2l, t1r, t2r, finger, w):
            return n
        if hi >= p_end:
            break
        gap = paths_gap_at(hi, t1l, t2l, t1r, t2r, finger, w)
        skip_to = n + 1 + int(min(gap / (speed2 * step), float(n_max)))
    return -1


@inner
def bisect_crossing_step(n, t1l, t2l, t1r, t2r, finger, w, collision):
    """The last progress before the crossing in the step ending at node n, bisected to
    collision.tol (bounded)."""
    step = collision.progress_step
    p_end = path_end(t1l, t2l, t1r, t2r, finger.theta2_min)
    lo = node_progress(n - 1, step, p_end)
    hi = node_progress(n, step, p_end)
    for _ in range(200):
        if hi - lo <= collision.tol:
            break
        mid = 0.5 * (lo + hi)
        if paths_cross_at(mid, t1l, t2l, t1r, t2r, finger, w):
            hi = mid
        else:
            lo = mid
    return lo


@inner
def paths_gap_at(progress, t1l, t2l, t1r, t2r, finger, w):
    """A lower bound, less a safety margin, of the distance between the two fingers at a
    progress where they do not meet (0 if unsure): the least distance between their segments,
    leaving out the two proximal links when they share a base (w = 0), where only a distal
    joint on the other proximal link counts as meeting (fingers_cross)."""
    a1l, a2l = closing_path_angles(progress, t1l, t2l, finger.theta2_min)
    a1r, a2r = closing_path_angles(progress, t1r, t2r, finger.theta2_min)
    jlx, jly, blx, bly, tlx, tly = finger_polyline(LEFT, a1l, a2l, finger.l1, finger.l2, w)
    jrx, jry, brx, bry, trx, try_ = finger_polyline(RIGHT, a1r, a2r, finger.l1, finger.l2, w)
    gap2 = min(segment_gap2(jlx, jly, blx, bly, brx, bry, trx, try_),
               segment_gap2(blx, bly, tlx, tly, jrx, jry, brx, bry),
               segment_gap2(blx, bly, tlx, tly, brx, bry, trx, try_))
    if (jlx - jrx) ** 2 + (jly - jry) ** 2 <= TOUCH2:
        gap2 = min(gap2, point_segment_distance2(blx, bly, jrx, jry, brx, bry),
                   point_segment_distance2(brx, bry, jlx, jly, blx, bly))
    else:
        gap2 = min(gap2, segment_gap2(jlx, jly, blx, bly, jrx, jry, brx, bry))
    return max(math.sqrt(gap2) - 1e-9, 0.0)


@inner
def segment_gap2(ax, ay, bx, by, cx, cy, dx, dy):
    """Squared distance between segments AB and CD that do not cross (the least of the four
    endpoint-to-segment distances)."""
    return min(point_segment_distance2(ax, ay, cx, cy, dx, dy),
               point_segment_distance2(bx, by, cx, cy, dx, dy),
               point_segment_distance2(cx, cy, ax, ay, bx, by),
               point_segment_distance2(dx, dy, ax, ay, bx, by))


@entry
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


@inner
def rests_on_other_finger(mode, t1, t2, finger):
    """A finger that finger_collision stopped on the other (`stopped_finger`): free short of
    its fully closed configuration (t1 = pi, t2 = theta2_max), or proximal-only with its distal
    short of its upper stop; no settled finger looks like that (a settled free finger is fully
    closed, a settled proximal-only one has its distal on the stop, MODEL 4). Its pose has a
    finger-finger contact, whose force the model's statics leave open (model-notes D17)."""
    if mode == FREE:
        return t1 != math.pi or t2 != finger.theta2_max
    if mode == PROXIMAL_ONLY:
        return t2 != finger.theta2_max
    return False


@entry
def settled_fingers_cross(t1l, t2l, t1r, t2r, finger, w):
    """The test that selects the points to re-run: the fingers cross in their final
    configurations (elsewhere they are taken not to have met on the way, model-notes D14)."""
    return fingers_cross(finger_polyline(LEFT, t1l, t2l, finger.l1, finger.l2, w),
                         finger_polyline(RIGHT, t1r, t2r, finger.l1, finger.l2, w))


@inner
def settled_angles(fingers, j, i):
    """(t1 left, t2 left, t1 right, t2 right) of point (j, i)."""
    return fingers.t1[0, j, i], fingers.t2[0, j, i], fingers.t1[1, j, i], fingers.t2[1, j, i]


@inner
def stop_fingers_at(fingers, j, i, p, theta2_min):
    """Stop both fingers of point (j, i) at the meeting progress p (in place); True if one
    changed."""
    changed = False
    for side in range(2):
        c, m, a1, a2, k1, k2 = stopped_finger(
            p, np.int64(fingers.mode[side, j, i]), fingers.t1[side, j, i], fingers.t2[side, j, i],
            fingers.k1[side, j, i], fingers.k2[side, j, i], theta2_min)
        if c:
            changed = True
            fingers.mode[side, j, i] = m
            fingers.t1[side, j, i] = a1
            fingers.t2[side, j, i] = a2
            fingers.k1[side, j, i] = k1
            fingers.k2[side, j, i] = k2
    return changed


@entry
def resolve_collisions_reference(ys, finger, w, fingers, collision):
    """resolve_collisions by the reference search at every point (the way of the first
    implementation, kept to test the map's way against)."""
    if not collision.on:
        return 0
    n_changed = 0
    for j in range(ys.shape[0]):
        for i in range(fingers.mode.shape[2]):
            if fingers.mode[0, j, i] < 0 or fingers.mode[1, j, i] < 0:  # infeasible
                continue
            t1l, t2l, t1r, t2r = settled_angles(fingers, j, i)
            if not settled_fingers_cross(t1l, t2l, t1r, t2r, finger, w):
                continue
            p = meeting_progress(t1l, t2l, t1r, t2r, finger, w, collision)
            if p >= 0.0 and stop_fingers_at(fingers, j, i, p, finger.theta2_min):
                n_changed += 1
    return n_changed


# ---------------------------------------------------------------------------------------------
# The map's way: one symmetric search per map, the first contact after it in closed form
# ---------------------------------------------------------------------------------------------
SYMMETRIC_END_STEPS = 2  # the symmetric search runs to pi + 2 steps: beyond any t1
REPLAY_WINDOW = 1e-13    # bisection midpoints this close to the predicted switch are evaluated
GRAZING_SPEED = 1e-4     # a contact approached slower (distance per rad) is left to the search
TOUCH_SHIFT_MAX = RANGE_TOL / GRAZING_SPEED  # touching starts at most this much before contact
PHASE_OVERLAP = 1e-9     # a contact this close after a phase's end is found in that phase
SAFE_STEPS = 200         # bound on the safe steps of one contact search
NO_CONTACT = math.inf
UNSURE = -1.0            # a contact search that could not decide
PHASE_SIZE = 24          # a phase in first_contact: start, end, 2 motions, 2 x 3 vertices,
#                          2 x 2 links' unit vectors
SETTLED = 6 + 5 * PHASE_SIZE  # where the scratch holds the settled links (settle_links)
HINT = SETTLED + 12      # and the pair (f v seg as 6 f + 2 v + seg) that met first last time
WORK_SIZE = HINT + 1     # scratch: 6 events, up to 5 phases, 2 x 6 settled links, the hint


@inner
def symmetric_meeting(finger, w, collision):
    """(starts_crossed, node progress, meeting) of the symmetric closing of one map: both
    fingers sweep rigidly; `node progress` is the first crossing node's progress (inf if none
    before the sweep ends), `meeting` its bisected meeting (the reference's answer for every
    point whose fingers are both still sweeping at that node)."""
    th = finger.theta2_min
    end = math.pi + SYMMETRIC_END_STEPS * collision.progress_step
    if paths_cross_at(0.0, end, th, end, th, finger, w):
        return True, math.inf, math.inf
    n = first_crossing_node(end, th, end, th, finger, w, collision, np.int64(1))
    if n < 0:
        return False, math.inf, math.inf
    return (False, node_progress(n, collision.progress_step, end),
            bisect_crossing_step(n, end, th, end, th, finger, w, collision))


@inner
def meeting_after_symmetric(t1l, t2l, t1r, t2r, finger, w, collision, sym_meeting, work):
    """The reference's meeting for a point whose fingers did not cross while both swept
    rigidly (every node up to a = min t1 is symmetric and does not cross)."""
    a = min(t1l, t1r)
    step = collision.progress_step
    if sym_meeting > a:  # the symmetric fingers do not touch before a: predict the contact
        p = predicted_meeting(t1l, t2l, t1r, t2r, finger, w, collision, a, work)
        if p != UNSURE:
            return p
    n_start = int(a / step) + 1  # the first node after a
    while n_start > 1 and (n_start - 1) * step > a:
        n_start -= 1
    while n_start * step <= a:
        n_start += 1
    n = first_crossing_node(t1l, t2l, t1r, t2r, finger, w, collision, n_start)
    if n < 0:
        return -1.0
    return bisect_crossing_step(n, t1l, t2l, t1r, t2r, finger, w, collision)


@inner
def predicted_meeting(t1l, t2l, t1r, t2r, finger, w, collision, a, work):
    """The reference's answer, found from the first contact after a (UNSURE if a check
    fails): the contact gives the first crossing node and the switch point of the predicate
    in its step; the bisection is replayed, the predicate evaluated where the switch is
    within REPLAY_WINDOW, and both ends of the final bracket are checked with it."""
    th = finger.theta2_min
    p_end = path_end(t1l, t2l, t1r, t2r, th)
    tau = first_contact(t1l, t2l, t1r, t2r, finger, w, a, p_end, work)
    if tau == UNSURE or tau == NO_CONTACT or tau > p_end:
        return UNSURE
    step = collision.progress_step
    cache = work[SETTLED:SETTLED + 12]
    n = int(tau / step) + 1
    while n > 1 and node_progress(n - 1, step, p_end) >= tau:
        n -= 1
    while node_progress(n, step, p_end) < tau:
        n += 1
    lo = node_progress(n - 1, step, p_end)
    hi = node_progress(n, step, p_end)
    if tau - lo <= REPLAY_WINDOW or hi - tau <= REPLAY_WINDOW:
        return UNSURE
    node_hi = hi
    lo_checked = False
    hi_checked = False
    while hi - lo > collision.tol:  # the reference's bisection
        lo, hi, near = bisect_by_comparison(lo, hi, tau, collision.tol)
        if not near:
            break
        mid = 0.5 * (lo + hi)  # within REPLAY_WINDOW of tau: the predicate decides
        if crossing_at(mid, t1l, t2l, t1r, t2r, finger, w, cache):
            hi = mid
            hi_checked = True
        else:
            lo = mid
            lo_checked = True
    if not hi_checked and not crossing_at(hi, t1l, t2l, t1r, t2r, finger, w, cache):
        return UNSURE
    if not lo_checked and crossing_at(lo, t1l, t2l, t1r, t2r, finger, w, cache):
        return UNSURE
    # the node itself must cross (a contact that ends within the step is the search's case;
    # the last node, the paths' end, crosses: that is why the point is re-run)
    if hi != node_hi and node_hi != p_end and not crossing_at(node_hi, t1l, t2l, t1r, t2r,
                                                              finger, w, cache):
        return UNSURE
    return lo


@entry
def bisect_by_comparison(lo, hi, tau, tol):
    """The reference's bisection steps while the midpoint is farther than REPLAY_WINDOW from
    tau (decided by comparison): (lo, hi, stopped at a midpoint near tau).

    Where lo and hi share a binade [2^e, 2^(e+1)) the steps run on the integer mantissas
    M = x 2^(53 - e), exactly as the floating-point ones: lo + hi rounds M_lo + M_hi to even,
    and halving it is exact, so M_mid = q + (s & q & 1) with s = M_lo + M_hi, q = s >> 1
    (half the latency of the floating-point chain)."""
    m_lo, e_lo = math.frexp(lo)
    m_hi, e_hi = math.frexp(hi)
    if lo <= 0.0 or e_lo != e_hi:
        return bisect_by_comparison_float(lo, hi, tau, tol)
    scale = 53 - e_lo
    a = int(math.ldexp(m_lo, 53))
    b = int(math.ldexp(m_hi, 53))
    t = int(math.ldexp(math.frexp(tau)[0], 53))
    done = int(math.floor(math.ldexp(tol, scale)))
    near = int(math.floor(math.ldexp(REPLAY_WINDOW, scale)))
    stopped = False
    for _ in range(200):
        if b - a <= done:
            break
        s = a + b
        q = s >> 1
        mid = q + (s & q & 1)
        if abs(mid - t) <= near:
            stopped = True
            break
        up = mid > t
        b = mid if up else b
        a = a if up else mid
    return math.ldexp(float(a), -scale), math.ldexp(float(b), -scale), stopped


@inner
def bisect_by_comparison_float(lo, hi, tau, tol):
    """bisect_by_comparison in floating point (lo and hi in different binades)."""
    for _ in range(200):
        if hi - lo <= tol:
            return lo, hi, False
        mid = 0.5 * (lo + hi)
        if abs(mid - tau) <= REPLAY_WINDOW:
            return lo, hi, True
        up = mid > tau
        hi = mid if up else hi
        lo = lo if up else mid
    return lo, hi, False


@inner
def settle_links(cache, side, t1, t2, l1c, l1s, l2c, l2s):
    """A settled finger's angles and link vectors (`part.link_vectors`) into cache[6 side:]:
    t1, l1 cos t1, l1 sin t1, phi = t1 + t2, l2 cos phi, l2 sin phi (`crossing_at`)."""
    c = 6 * side
    cache[c] = t1
    cache[c + 1] = l1c
    cache[c + 2] = l1s
    cache[c + 3] = t1 + t2
    cache[c + 4] = l2c
    cache[c + 5] = l2s


@inner
def settled_polyline(side, w, cache):
    """The settled finger's polyline from its cached link vectors."""
    c = 6 * side
    return polyline_from_links(side, w, cache[c + 1], cache[c + 2], cache[c + 4], cache[c + 5])


@inner
def crossing_at(progress, t1l, t2l, t1r, t2r, finger, w, cache):
    """paths_cross_at, bit for bit, with the settled fingers' link vectors taken from `cache`
    (`settle_links`) wherever a finger's angle is its settled one."""
    th = finger.theta2_min
    a1l, a2l = closing_path_angles(progress, t1l, t2l, th)
    a1r, a2r = closing_path_angles(progress, t1r, t2r, th)
    return fingers_cross(polyline_at(LEFT, a1l, a2l, finger, w, cache),
                         polyline_at(RIGHT, a1r, a2r, finger, w, cache))


@inner
def polyline_at(side, t1, t2, finger, w, cache):
    """finger_polyline(side, t1, t2, ...) with the cached link vectors where they apply."""
    c = 6 * side
    if t1 == cache[c]:
        l1c = cache[c + 1]
        l1s = cache[c + 2]
    else:
        l1c = finger.l1 * math.cos(t1)
        l1s = finger.l1 * math.sin(t1)
    phi = t1 + t2
    if phi == cache[c + 3]:
        l2c = cache[c + 4]
        l2s = cache[c + 5]
    else:
        l2c = finger.l2 * math.cos(phi)
        l2s = finger.l2 * math.sin(phi)
    return polyline_from_links(side, w, l1c, l1s, l2c, l2s)


@inner
def first_contact(t1l, t2l, t1r, t2r, finger, w, a, p_end, work):
    """The progress after `a` at which the two polylines first come within RANGE_TOL (where
    `fingers_cross` starts to hold), NO_CONTACT if they do not before p_end, UNSURE for a
    grazing contact. `work`: scratch of WORK_SIZE, the settled fingers' links at SETTLED.

    Between the events (a finger's rigid sweep ends at its t1, its path at its end) each
    finger rests or turns about a fixed point at unit rate (the right counter-clockwise, the
    left clockwise), so every vertex-on-segment contact is a root of a short trigonometric sum
    (`vertex_segment_contact`). A tip meeting the other distal link is the usual first
    contact: those two pairs and the pair that met first at the previous point (work[HINT])
    are followed through the phases first, and every other pair is then searched only before
    the earliest contact found."""
    th = finger.theta2_min
    events = work[:6]
    events[0] = a
    events[1] = t1l
    events[2] = t1r
    events[3] = t1l + (t2l - th)
    events[4] = t1r + (t2r - th)
    events[5] = p_end
    sort_small(events, np.int64(6))
    n_phase = 0  # phases after a (start, end, motions, vertices at the start), set up in turn
    e = 0
    best = math.inf  # the earliest progress at which a pair comes within RANGE_TOL
    while True:  # the tips against the other distal links, phase by phase
        while e < 5 and (events[e] < a or events[e + 1] <= events[e]):
            e += 1
        if e == 5:
            break
        set_phase(work[6 + PHASE_SIZE * n_phase:6 + PHASE_SIZE * (n_phase + 1)], events[e],
                  events[e + 1], t1l, t2l, t1r, t2r, finger, w, work[SETTLED:SETTLED + 12])
        ph = work[6 + PHASE_SIZE * n_phase:6 + PHASE_SIZE * (n_phase + 1)]
        n_phase += 1
        e += 1
        limit = search_limit(ph, best)
        limit_pa = limit_pseudo_angle(limit)
        for pair in (5, 11, int(work[HINT])):  # each tip on the other distal link, the hint
            p = pair_contact(ph, pair // 6, (pair % 6) // 2, pair % 2, limit, limit_pa, finger)
            if p == UNSURE:
                return UNSURE
            best = min(best, p)
        if best < math.inf:
            break
    for k in range(n_phase):  # every other pair, before the earliest contact
        ph = work[6 + PHASE_SIZE * k:6 + PHASE_SIZE * (k + 1)]
        if ph[0] >= best:
            break
        limit = search_limit(ph, best)
        limit_pa = limit_pseudo_angle(limit)
        for pair in range(12):  # vertex finger f, vertex v (J, B, T), segment (prox, dist)
            f = pair // 6
            v = (pair % 6) // 2
            seg = pair % 2
            if pair == 5 or pair == 11 or pair == int(work[HINT]):
                continue  # done
            if v == 0 and (seg == 0 and w == 0.0 or palm_out_of_reach(ph, 1 - f)):
                continue
            p = pair_contact(ph, f, v, seg, limit, limit_pa, finger)
            if p == UNSURE:
                return UNSURE
            if p < best:
                best = p
                work[HINT] = pair  # the next point of the row is likely to meet the same way
                limit = search_limit(ph, best)
                limit_pa = limit_pseudo_angle(limit)
    return best if best < math.inf else NO_CONTACT


@inner
def search_limit(ph, before):
    """How far into phase `ph` a pair's contact is searched: to the earliest contact found
    (plus the largest touching shift), or a little past the phase's end (a contact at the end
    is found in it)."""
    return min(before + TOUCH_SHIFT_MAX, ph[1] + PHASE_OVERLAP) - ph[0]


@inner
def palm_out_of_reach(ph, g):
    """Finger g's links cannot reach the other finger's palm joint J in phase `ph`: sweeping
    rigidly with t1 short of pi, its links stay off the palm line except on its own side of
    the palm, where they dip below it (t1 < -theta2_min); only at t1 = pi does its proximal
    link lie on the palm, reaching the other base. (With w = 0 the proximal links share J
    and meet only at a distal joint: first_contact leaves that pair out.)"""
    return int(ph[2 + g]) == 2 and ph[1] + PHASE_OVERLAP < math.pi - 1e-6


@inner
def set_phase(ph, p0, p1, t1l, t2l, t1r, t2r, finger, w, cache):
    """A phase of first_contact: start, end, the motions of both fingers in it (0 rest,
    1 distal about B, 2 rigid about J), the vertices J, B, T of both at its start, the unit
    vectors of both fingers' links."""
    th = finger.theta2_min
    ph[0] = p0
    ph[1] = p1
    ph[2] = finger_motion(p0, t1l, t2l, th)
    ph[3] = finger_motion(p0, t1r, t2r, th)
    for s in range(2):
        a1, a2 = closing_path_angles(p0, t1l if s == 0 else t1r, t2l if s == 0 else t2r, th)
        jx, jy, bx, by, tx, ty = polyline_at(s, a1, a2, finger, w, cache)
        ph[4 + 6 * s] = jx
        ph[5 + 6 * s] = jy
        ph[6 + 6 * s] = bx
        ph[7 + 6 * s] = by
        ph[8 + 6 * s] = tx
        ph[9 + 6 * s] = ty
        ph[16 + 4 * s] = (bx - jx) / finger.l1
        ph[17 + 4 * s] = (by - jy) / finger.l1
        ph[18 + 4 * s] = (tx - bx) / finger.l2
        ph[19 + 4 * s] = (ty - by) / finger.l2


@inner
def pair_contact(ph, f, v, seg, limit, limit_pa, finger):
    """When vertex v of finger f first comes within RANGE_TOL of segment `seg` of the other
    finger during phase `ph` (see set_phase), if within `limit` of the phase's start
    (`limit_pa` its limit_pseudo_angle): the progress, else NO_CONTACT (UNSURE if grazing)."""
    g = 1 - f
    p0 = ph[0]
    # the vertex turns about its joint vc at rate sv, the segment about sc at ss, or rest
    sv, vc = turning(f, int(ph[2 + f]), v)
    ss, sc = turning(g, int(ph[2 + g]), seg + 1)
    if sv == 0.0 and ss == 0.0:
        return NO_CONTACT
    # in the segment's frame, relative to its start U:
    # Y(theta) - U = (Cs - U) + R(-ss theta)(Cv - Cs) + R((sv - ss) theta)(V - Cv)
    ux = ph[4 + 6 * g + 2 * seg]
    uy = ph[5 + 6 * g + 2 * seg]
    vx = ph[4 + 6 * f + 2 * v]
    vy = ph[5 + 6 * f + 2 * v]
    ex = ph[16 + 4 * g + 2 * seg]
    ey = ph[17 + 4 * g + 2 * seg]
    length = finger.l1 if seg == 0 else finger.l2
    if ss == 0.0:  # the segment rests, the vertex turns about Cv
        cvx = ph[4 + 6 * f + 2 * vc]
        cvy = ph[5 + 6 * f + 2 * vc]
        theta, speed = one_term_root(cvx - ux, cvy - uy, vx - cvx, vy - cvy, sv, ex, ey,
                                     length, limit, limit_pa)
    else:
        csx = ph[4 + 6 * g + 2 * sc]
        csy = ph[5 + 6 * g + 2 * sc]
        if sv == 0.0:  # the vertex rests: it turns the other way about Cs, in the frame
            theta, speed = one_term_root(csx - ux, csy - uy, vx - csx, vy - csy, -ss, ex, ey,
                                         length, limit, limit_pa)
        else:
            cvx = ph[4 + 6 * f + 2 * vc]
            cvy = ph[5 + 6 * f + 2 * vc]
            theta, speed = vertex_segment_contact(
                csx - ux, csy - uy, cvx - csx, cvy - csy, -ss, vx - cvx, vy - cvy, sv - ss,
                ex, ey, length, limit)
    if theta == UNSURE:
        return UNSURE
    if theta == NO_CONTACT:
        return NO_CONTACT
    # the predicate holds from distance RANGE_TOL on, just before the contact itself
    return p0 + theta - RANGE_TOL / speed


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


@entry
def resolve_collisions(ys, finger, w, fingers, collision, settled, handled):
    """Apply finger_collision to solved finger fields in place; returns the number of points
    where a finger's configuration changed (0 when the effect is off).

    Only points whose fingers cross in their final configurations are re-run: elsewhere the
    fingers are taken not to have met on the way (model-notes D14). The answers are the
    reference search's (`resolve_collisions_reference`), bit for bit: the symmetric closing is
    searched once, the rest predicted from the first contact (module docstring).

    The meeting depends only on the two settled configurations (and the links and the palm),
    and is unchanged when the fingers swap sides (the predicate is exactly mirror-symmetric):
    a point whose mirror point, left neighbour, or memo entry (the sweep's `settled`, a
    records.SettledFingers; records.no_settled_fingers() elsewhere) has the same configurations
    takes its answer. Where `settled.known`, the settled fingers' polylines come from their link
    vectors, without trigonometry (same bits as `finger_polyline`). `handled` (y, x), or empty:
    points already resolved on the fingers' own paths (a finger took the tip path,
    field.tip_path_collisions), left alone."""
    if not collision.on:
        return 0
    any_handled = handled.shape[0] > 0
    th = finger.theta2_min
    starts_crossed, sym_node, sym_meeting = symmetric_meeting(finger, w, collision)
    if starts_crossed:  # the open fingers touch: no point's fingers are re-run (as reference)
        return 0
    nx = fingers.mode.shape[2]
    meet = np.empty(nx)
    work = np.empty(WORK_SIZE)
    work[HINT] = 5
    n_changed = 0
    for j in range(ys.shape[0]):
        for i in range(nx):
            meet[i] = -1.0
            if fingers.mode[0, j, i] < 0 or fingers.mode[1, j, i] < 0:  # infeasible
                continue
            if any_handled and handled[j, i]:
                continue
            t1l, t2l, t1r, t2r = settled_angles(fingers, j, i)
            m = nx - 1 - i
            if m < i and fingers.mode[1, j, m] >= 0 and fingers.mode[0, j, m] >= 0 \
                    and fingers.t1[1, j, m] == t1l and fingers.t2[1, j, m] == t2l \
                    and fingers.t1[0, j, m] == t1r and fingers.t2[0, j, m] == t2r:
                meet[i] = meet[m]  # the mirror point's fingers, swapped
            elif i > 0 and fingers.mode[0, j, i - 1] >= 0 and fingers.mode[1, j, i - 1] >= 0 \
                    and fingers.t1[0, j, i - 1] == t1l and fingers.t2[0, j, i - 1] == t2l \
                    and fingers.t1[1, j, i - 1] == t1r and fingers.t2[1, j, i - 1] == t2r:
                meet[i] = meet[i - 1]  # the same fingers as the left neighbour
            else:
                if settled.memo_read:
                    memo = settled.memo
                    if memo[j, i, 0] == t1l and memo[j, i, 1] == t2l and memo[j, i, 2] == t1r \
                            and memo[j, i, 3] == t2r:
                        meet[i] = memo[j, i, 4]
                        continue
                cache = work[SETTLED:SETTLED + 12]
                for s in range(2):
                    t1 = t1l if s == 0 else t1r
                    t2 = t2l if s == 0 else t2r
                    if not settled.known:
                        l1c, l1s, l2c, l2s = link_vectors(t1, t2, finger.l1, finger.l2)
                    else:
                        lk = settled.links
                        c = (settled.left_start + settled.left_stride * i if s == 0
                             else settled.right_start + settled.right_stride * i)
                        l1c, l1s, l2c, l2s = lk[0, j, c], lk[1, j, c], lk[2, j, c], lk[3, j, c]
                    settle_links(cache, s, t1, t2, l1c, l1s, l2c, l2s)
                meet[i] = meeting_of(t1l, t2l, t1r, t2r, finger, w, collision, sym_node,
                                     sym_meeting, work,
                                     fingers_cross(settled_polyline(LEFT, w, cache),
                                                   settled_polyline(RIGHT, w, cache)))
            if settled.memo_write:
                memo = settled.memo
                memo[j, i, 0] = t1l
                memo[j, i, 1] = t2l
                memo[j, i, 2] = t1r
                memo[j, i, 3] = t2r
                memo[j, i, 4] = meet[i]
        for i in range(nx):
            if meet[i] >= 0.0 and stop_fingers_at(fingers, j, i, meet[i], th):
                n_changed += 1
    return n_changed


@entry
def collide(finger, w, collision, mode_l, t1l, t2l, k1l, k2l, mode_r, t1r, t2r, k1r, k2r):
    """finger_collision at one part position, anywhere (no map around it): (changed, left,
    right), each side (mode, t1, t2, k1, k2). The reference's answer (`meeting_progress` at a
    point whose settled fingers cross, model-notes D14), found as a map finds it but with the
    symmetric closing as the first phase of the contact search (`meeting_at`). Unchanged when
    the effect is off."""
    left = (mode_l, t1l, t2l, k1l, k2l)
    right = (mode_r, t1r, t2r, k1r, k2r)
    if not collision.on:
        return False, left, right
    if mode_l < 0 or mode_r < 0:  # the part overlaps a finger's joint: infeasible
        return False, left, right
    work = np.empty(WORK_SIZE)
    return stopped_pair(meeting_at(t1l, t2l, t1r, t2r, finger, w, collision, work), finger,
                        left, right)


@inner
def stopped_pair(p, finger, left, right):
    """(changed, left, right) of both fingers, each (mode, t1, t2, k1, k2), stopped at the
    meeting p (-1: they do not meet, unchanged)."""
    if p < 0.0:
        return False, left, right
    th = finger.theta2_min
    cl, ml, a1l, a2l, b1l, b2l = stopped_finger(p, left[0], left[1], left[2], left[3], left[4],
                                                th)
    cr, mr, a1r, a2r, b1r, b2r = stopped_finger(p, right[0], right[1], right[2], right[3],
                                                right[4], th)
    return cl or cr, (ml, a1l, a2l, b1l, b2l), (mr, a1r, a2r, b1r, b2r)


@inner
def settled_fingers_cross_cached(t1l, t2l, t1r, t2r, finger, w, work):
    """settled_fingers_cross, the settled links kept in work's cache (`settle_links`)."""
    cache = work[SETTLED:SETTLED + 12]
    for s in range(2):
        t1 = t1l if s == 0 else t1r
        t2 = t2l if s == 0 else t2r
        l1c, l1s, l2c, l2s = link_vectors(t1, t2, finger.l1, finger.l2)
        settle_links(cache, s, t1, t2, l1c, l1s, l2c, l2s)
    return fingers_cross(settled_polyline(LEFT, w, cache), settled_polyline(RIGHT, w, cache))


# The first entry of a slide context (NumPy booleans: a Python constant in a returned tuple
# keeps a literal type, and its callees would compile once more).
NEAR, ALONE = np.bool_(True), np.bool_(False)


@entry
def slide_context(finger, w, collision):
    """What `collide_near` keeps between the positions of one map's slides: the symmetric
    closing (`symmetric_meeting`) and a scratch of WORK_SIZE whose hint carries over from one
    position to the next (a slide's positions are near each other): (True, symmetric closing,
    scratch). Unused when the effect is off."""
    work = np.empty(WORK_SIZE)
    if not collision.on:
        return NEAR, (True, 0.0, -1.0), work
    work[HINT] = 5
    return NEAR, symmetric_meeting(finger, w, collision), work


@entry
def no_slide_context():
    """The context of a position evaluated on its own (`collide`, not `collide_near`): its
    first entry False, the rest of slide_context's types."""
    return ALONE, (True, 0.0, -1.0), np.empty(0)


@entry
def collide_near(finger, w, collision, context, mode_l, t1l, t2l, k1l, k2l, mode_r, t1r, t2r,
                 k1r, k2r):
    """collide for one of many positions of a map (`context` from slide_context): the meeting
    found as resolve_collisions finds a grid point's (`meeting_of`: the map's symmetric
    closing, then the first contact after it), the reference's answer as collide's."""
    left = (mode_l, t1l, t2l, k1l, k2l)
    right = (mode_r, t1r, t2r, k1r, k2r)
    if not collision.on or mode_l < 0 or mode_r < 0:
        return False, left, right
    _, (starts_crossed, sym_node, sym_meeting), work = context
    if starts_crossed:  # the open fingers touch: nothing is re-run (as the reference)
        return False, left, right
    crossed = settled_fingers_cross_cached(t1l, t2l, t1r, t2r, finger, w, work)
    return stopped_pair(meeting_of(t1l, t2l, t1r, t2r, finger, w, collision, sym_node,
                                   sym_meeting, work, crossed), finger, left, right)


@inner
def meeting_at(t1l, t2l, t1r, t2r, finger, w, collision, work):
    """The meeting of one point, -1 if its settled fingers do not cross or do not meet on the
    way: the reference's bits (`meeting_progress`), predicted from the first contact from the
    start of the closing (its first phase is the symmetric rigid sweep) and replayed; the
    reference itself where a check fails. `work`: scratch of WORK_SIZE."""
    if not settled_fingers_cross_cached(t1l, t2l, t1r, t2r, finger, w, work):
        return -1.0
    work[HINT] = 5
    p = predicted_meeting(t1l, t2l, t1r, t2r, finger, w, collision, 0.0, work)
    if p != UNSURE:
        return p
    return meeting_progress(t1l, t2l, t1r, t2r, finger, w, collision)


@inner
def meeting_of(t1l, t2l, t1r, t2r, finger, w, collision, sym_node, sym_meeting, work,
               crossed):
    """The reference's meeting of one point (-1: the fingers are left as they settled)."""
    if not crossed:
        return -1.0
    if sym_node <= min(t1l, t1r):
        return sym_meeting  # first crossing node while both still sweep rigidly
    return meeting_after_symmetric(t1l, t2l, t1r, t2r, finger, w, collision, sym_meeting, work)
