"""finger_collision (MODEL 9, model-notes D14): the rule and its reference search, and fingers
stopped on their own paths.

Both fingers advance along their closing paths with a shared progress p (the joint travel
t1 + (t2 - theta2_min)). The meeting is defined by a search: step p by
`collision.progress_step` to the first node where the polylines cross (`fingers_cross`), then
bisect that step to `collision.tol` (`meeting_progress`, the reference); each finger stops at
the meeting (`stopped_finger`). A finger that took the tip path (tip_contact) is stopped on its
own path instead (model-notes D29, `collide_on_own_paths`). meeting_search finds the same bits
faster for a whole map.
"""
import math
import numpy as np

from ..model import FREE, PROXIMAL_ONLY, PROXIMAL_TIP, TIP_ONLY, TWO_PHALANX
from .jit import entry, inner
from .records import LEFT, RIGHT, side_finger
from .finger_paths import tip_on_disc
from .finger import finger_effects, tip_path_start, took_tip_path
from .hand import finger_polyline, fingers_cross, point_segment_distance2, TOUCH2


# ---------------------------------------------------------------------------------------------
# The rule and its reference search
# ---------------------------------------------------------------------------------------------
MAX_PROGRESS_STEPS = 10_000_000  # defence in depth, as for the reconfiguration path


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
# finger_collision for a finger that took the tip path (tip_contact; model-notes D29)
# ---------------------------------------------------------------------------------------------
# A finger's own path (path tuples): (t1, t2) its final angles; on_tip, (t1s, t2s) where its
# tip path began (finger.tip_path_start); (dx, dy) the part in its frame. Without the tip path
# it is the closing D14 rebuilds from the final angles; with it, that closing up to (t1s, t2s),
# then the tip path (the tip on the disc, t1 following, t2 up to the final t2), progress
# counting t2's travel there.
@inner
def own_path_end(path, theta2_min):
    t1, t2, on_tip, t1s, t2s, _, _ = path
    if not on_tip:
        return t1 + (t2 - theta2_min)
    return t1s + (t2s - theta2_min) + (t2 - t2s)


@inner
def own_path_angles(progress, path, finger):
    """(t1, t2) of a finger at shared progress p along its own path (the final angles from
    its end on)."""
    t1, t2, on_tip, t1s, t2s, dx, dy = path
    th = finger.theta2_min
    if not on_tip:
        return closing_path_angles(progress, t1, t2, th)
    if progress >= own_path_end(path, th):
        return t1, t2
    start = t1s + (t2s - th)
    if progress <= start:
        return closing_path_angles(progress, t1s, t2s, th)
    a2 = t2s + (progress - start)
    _, _, a1 = tip_on_disc(a2, dx, dy, finger)
    return min(max(a1, 0.0), math.pi), a2


@inner
def own_paths_cross_at(progress, left, right, finger, w):
    a1l, a2l = own_path_angles(progress, left, finger)
    a1r, a2r = own_path_angles(progress, right, finger)
    return fingers_cross(finger_polyline(LEFT, a1l, a2l, finger.l1, finger.l2, w),
                         finger_polyline(RIGHT, a1r, a2r, finger.l1, finger.l2, w))


@inner
def own_paths_meeting(left, right, finger, w, collision):
    """hand.meeting_progress on the fingers' own paths: the first node (every
    collision.progress_step) where they cross, that step bisected to collision.tol; -1 if they
    cross from the start (as the reference) or never. Every node is tried: on the tip path no
    speed bound lets nodes be skipped, and these points are few."""
    if own_paths_cross_at(0.0, left, right, finger, w):
        return -1.0
    th = finger.theta2_min
    p_end = max(own_path_end(left, th), own_path_end(right, th))
    step = collision.progress_step
    n_max = int(min(math.ceil(p_end / step), MAX_PROGRESS_STEPS)) + 1
    for n in range(1, n_max + 1):
        hi = min(n * step, p_end)
        if own_paths_cross_at(hi, left, right, finger, w):
            lo = min((n - 1) * step, p_end)
            for _ in range(200):
                if hi - lo <= collision.tol:
                    break
                mid = 0.5 * (lo + hi)
                if own_paths_cross_at(mid, left, right, finger, w):
                    hi = mid
                else:
                    lo = mid
            return lo
        if hi >= p_end:
            break
    return -1.0


@inner
def stopped_on_own_path(progress, state, path, k1_start, finger):
    """hand.stopped_finger on the finger's own path: (changed, mode, t1, t2, k1, k2). In its
    closing to where the tip path began, D14's rule (FREE, or PROXIMAL_ONLY with that closing's
    proximal contact); on the tip path, held by the other finger with its tip on the part
    (TIP_ONLY)."""
    mode, t1, t2, k1, k2 = state
    _, _, on_tip, t1s, t2s, _, _ = path
    th = finger.theta2_min
    if not on_tip:
        return stopped_finger(progress, mode, t1, t2, k1, k2, th)
    if progress >= own_path_end(path, th):
        return False, mode, t1, t2, k1, k2
    if progress < t1s + (t2s - th):
        return stopped_finger(progress, PROXIMAL_ONLY if k1_start > 0.0 else FREE, t1s, t2s,
                              k1_start, 0.0, th)
    a1, a2 = own_path_angles(progress, path, finger)
    return True, TIP_ONLY, a1, a2, 0.0, finger.l2


@entry
def collide_on_own_paths(x, y, finger, solver, effects, hand, collision, left, right):
    """finger_collision at a part position where a finger took the tip path (D29): (changed,
    left, right), each (mode, t1, t2, k1, k2), both fingers stopped on their own paths at the
    first meeting, if their final configurations cross (D14)."""
    w = hand.w
    if left[0] < 0 or right[0] < 0 or not collision.on:
        return False, left, right
    if not settled_fingers_cross(left[1], left[2], right[1], right[2], finger, w):
        return False, left, right
    dxl = -x - 0.5 * w
    dxr = x - 0.5 * w
    on_l, t1sl, t2sl, k1sl = tip_path_start(dxl, y, left[0], left[1], left[2],
                                            side_finger(finger, hand, LEFT), solver,
                                            finger_effects(effects, hand.f_left))
    on_r, t1sr, t2sr, k1sr = tip_path_start(dxr, y, right[0], right[1], right[2],
                                            side_finger(finger, hand, RIGHT), solver,
                                            finger_effects(effects, hand.f_right))
    path_l = (left[1], left[2], on_l, t1sl, t2sl, dxl, y)
    path_r = (right[1], right[2], on_r, t1sr, t2sr, dxr, y)
    p = own_paths_meeting(path_l, path_r, finger, w, collision)
    if p < 0.0:
        return False, left, right
    cl, ml, a1l, a2l, b1l, b2l = stopped_on_own_path(p, left, path_l, k1sl, finger)
    cr, mr, a1r, a2r, b1r, b2r = stopped_on_own_path(p, right, path_r, k1sr, finger)
    return cl or cr, (ml, a1l, a2l, b1l, b2l), (mr, a1r, a2r, b1r, b2r)


@inner
def tip_path_collisions(xs, ys, finger, solver, effects, hand, fingers, collision, tip_contact):
    """The grid's points where a finger took the tip path, by collide_on_own_paths (in place):
    (points changed, handled), `handled` marking them for meeting_search.resolve_collisions to leave
    alone. Without tip_contact no finger took it: nothing is handled."""
    handled = np.zeros((fingers.mode.shape[1], fingers.mode.shape[2]), dtype=np.bool_)
    n_changed = 0
    for j in range(ys.shape[0]):
        for i in range(xs.shape[0]):
            if not (took_tip_path(np.int64(fingers.mode[0, j, i]), tip_contact)
                    or took_tip_path(np.int64(fingers.mode[1, j, i]), tip_contact)):
                continue
            handled[j, i] = True
            left = (np.int64(fingers.mode[0, j, i]), fingers.t1[0, j, i], fingers.t2[0, j, i],
                    fingers.k1[0, j, i], fingers.k2[0, j, i])
            right = (np.int64(fingers.mode[1, j, i]), fingers.t1[1, j, i], fingers.t2[1, j, i],
                     fingers.k1[1, j, i], fingers.k2[1, j, i])
            changed, new_l, new_r = collide_on_own_paths(xs[i], ys[j], finger, solver, effects,
                                                         hand, collision, left, right)
            if changed:
                n_changed += 1
                set_finger(fingers, LEFT, j, i, new_l)
                set_finger(fingers, RIGHT, j, i, new_r)
    return n_changed, handled


@inner
def set_finger(fingers, side, j, i, state):
    fingers.mode[side, j, i] = state[0]
    fingers.t1[side, j, i] = state[1]
    fingers.t2[side, j, i] = state[2]
    fingers.k1[side, j, i] = state[3]
    fingers.k2[side, j, i] = state[4]
