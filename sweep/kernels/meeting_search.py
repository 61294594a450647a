"""finger_collision over a map: the reference's bits, found faster (MODEL 9, model-notes D14,
"How a map finds the meeting").

1. Until the first finger's proximal contact (p <= a = min t1) both fingers sweep rigidly and
   are mirror images, so the symmetric closing's meeting is one search per map
   (`symmetric_meeting`); every point whose first crossing node falls in it takes its answer.
2. After a, the earliest contact (`first_contact`, from meeting_roots) locates the first
   crossing node and the bisection's switch point; the reference's bisection is then replayed
   (`predicted_meeting`) with its own predicate evaluated only where the replay cannot be sure,
   and the final bracket and the node are checked with it. A point where a check fails, or the
   contact is grazing, is searched by the reference from the node after a.
3. Answers are reused where the inputs are the same numbers: the mirror point, the left
   neighbour, and in the sweep a per-thread memo across the cells of one geometry group
   (records.SettledFingers). `collide` does one point anywhere; `collide_near` one point of a
   slide, near a known answer (`slide_context`).

`collisions_of_map` applies the effect to a map's solved fingers: points where a finger took
the tip path on their own paths (meeting), the rest by `resolve_collisions`.
"""
import math
import numpy as np

from ..model import RANGE_TOL
from .jit import entry, inner
from .records import LEFT, RIGHT
from .hand import fingers_cross, link_vectors, polyline_from_links, sort_small
from .meeting import (
    bisect_crossing_step,
    closing_path_angles,
    first_crossing_node,
    meeting_progress,
    node_progress,
    path_end,
    paths_cross_at,
    stop_fingers_at,
    stopped_finger,
    tip_path_collisions,
)
from .meeting_roots import (
    finger_motion,
    GRAZING_SPEED,
    limit_pseudo_angle,
    NO_CONTACT,
    one_term_root,
    turning,
    UNSURE,
    vertex_segment_contact,
)


# ---------------------------------------------------------------------------------------------
# The map's way: one symmetric search per map, the first contact after it in closed form
# ---------------------------------------------------------------------------------------------
SYMMETRIC_END_STEPS = 2  # the symmetric search runs to pi + 2 steps: beyond any t1
REPLAY_WINDOW = 1e-13    # bisection midpoints this close to the predicted switch are evaluated


TOUCH_SHIFT_MAX = RANGE_TOL / GRAZING_SPEED  # touching starts at most this much before contact
PHASE_OVERLAP = 1e-9     # a contact this close after a phase's end is found in that phase


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
    meeting.tip_path_collisions), left alone."""
    if not collision.on:
        return 0
    any_handled = handled.shape[0] > 0
    th = finger.theta2_min
    starts_crossed, sym_node, sym_meeting = symmetric_meeting(finger, w, collision)
    if starts_crossed:  # the open fingers touch: no point's fingers are re-run (as reference)
        return 0
    # the records' arrays and the cache's view taken once: a record field read or a slice inside
    # the loop cost a reference-count pair per point (docs/performance.md)
    mode, t1a, t2a = fingers.mode, fingers.t1, fingers.t2
    memo, lk = settled.memo, settled.links
    nx = mode.shape[2]
    meet = np.empty(nx)
    work = np.empty(WORK_SIZE)
    work[HINT] = 5
    cache = work[SETTLED:SETTLED + 12]
    n_changed = 0
    for j in range(ys.shape[0]):
        for i in range(nx):
            meet[i] = -1.0
            if mode[0, j, i] < 0 or mode[1, j, i] < 0:  # infeasible
                continue
            if any_handled and handled[j, i]:
                continue
            t1l, t2l, t1r, t2r = t1a[0, j, i], t2a[0, j, i], t1a[1, j, i], t2a[1, j, i]
            m = nx - 1 - i
            if m < i and mode[1, j, m] >= 0 and mode[0, j, m] >= 0 \
                    and t1a[1, j, m] == t1l and t2a[1, j, m] == t2l \
                    and t1a[0, j, m] == t1r and t2a[0, j, m] == t2r:
                meet[i] = meet[m]  # the mirror point's fingers, swapped
            elif i > 0 and mode[0, j, i - 1] >= 0 and mode[1, j, i - 1] >= 0 \
                    and t1a[0, j, i - 1] == t1l and t2a[0, j, i - 1] == t2l \
                    and t1a[1, j, i - 1] == t1r and t2a[1, j, i - 1] == t2r:
                meet[i] = meet[i - 1]  # the same fingers as the left neighbour
            else:
                if settled.memo_read:
                    if memo[j, i, 0] == t1l and memo[j, i, 1] == t2l and memo[j, i, 2] == t1r \
                            and memo[j, i, 3] == t2r:
                        meet[i] = memo[j, i, 4]
                        continue
                for s in range(2):
                    t1 = t1l if s == 0 else t1r
                    t2 = t2l if s == 0 else t2r
                    if not settled.known:
                        l1c, l1s, l2c, l2s = link_vectors(t1, t2, finger.l1, finger.l2)
                    else:
                        c = (settled.left_start + settled.left_stride * i if s == 0
                             else settled.right_start + settled.right_stride * i)
                        l1c, l1s, l2c, l2s = lk[0, j, c], lk[1, j, c], lk[2, j, c], lk[3, j, c]
                    settle_links(cache, s, t1, t2, l1c, l1s, l2c, l2s)
                meet[i] = meeting_of(t1l, t2l, t1r, t2r, finger, w, collision, sym_node,
                                     sym_meeting, work,
                                     fingers_cross(settled_polyline(LEFT, w, cache),
                                                   settled_polyline(RIGHT, w, cache)))
            if settled.memo_write:
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
def collide(finger, w, collision, left, right):
    """finger_collision at one part position, anywhere (no map around it), between the settled
    fingers `left` and `right` (records.FingerState): (changed, left, right), each side
    (mode, t1, t2, k1, k2). The reference's answer (`meeting_progress` at a point whose
    settled fingers cross, model-notes D14), found as a map finds it but with the symmetric
    closing as the first phase of the contact search (`meeting_at`). Unchanged when the effect
    is off."""
    settled_l = meeting_state(left)
    settled_r = meeting_state(right)
    if not collision.on:
        return False, settled_l, settled_r
    if left.mode < 0 or right.mode < 0:  # the part overlaps a finger's joint: infeasible
        return False, settled_l, settled_r
    work = np.empty(WORK_SIZE)
    return stopped_pair(meeting_at(left.t1, left.t2, right.t1, right.t2, finger, w, collision,
                                   work), finger, settled_l, settled_r)


@inner
def meeting_state(state):
    """(mode, t1, t2, k1, k2) of a records.FingerState: a finger as the meeting's functions pass
    it (tip_overlap, a flag of the closing, plays no part in a meeting)."""
    return state.mode, state.t1, state.t2, state.k1, state.k2


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
def collide_near(finger, w, collision, context, left, right):
    """collide for one of many positions of a map (`context` from slide_context): the meeting
    found as resolve_collisions finds a grid point's (`meeting_of`: the map's symmetric
    closing, then the first contact after it), the reference's answer as collide's."""
    settled_l = meeting_state(left)
    settled_r = meeting_state(right)
    if not collision.on or left.mode < 0 or right.mode < 0:
        return False, settled_l, settled_r
    _, (starts_crossed, sym_node, sym_meeting), work = context
    if starts_crossed:  # the open fingers touch: nothing is re-run (as the reference)
        return False, settled_l, settled_r
    t1l, t2l, t1r, t2r = left.t1, left.t2, right.t1, right.t2
    crossed = settled_fingers_cross_cached(t1l, t2l, t1r, t2r, finger, w, work)
    return stopped_pair(meeting_of(t1l, t2l, t1r, t2r, finger, w, collision, sym_node,
                                   sym_meeting, work, crossed), finger, settled_l, settled_r)


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


@inner
def collisions_of_map(xs, ys, finger, solver, effects, hand, fingers, settled):
    """finger_collision on a map's solved fingers (in place): the points where a finger took
    the tip path on their own paths (D29), the rest by resolve_collisions (D14). Returns
    the number of points changed. `settled`: records.SettledFingers."""
    collision = effects.finger_collision
    if not collision.on:
        return 0
    if not effects.tip_contact.on:
        return resolve_collisions(ys, finger, hand.w, fingers, collision, settled,
                                  np.empty((0, 0), dtype=np.bool_))
    n_tip, handled = tip_path_collisions(xs, ys, finger, solver, effects, hand, fingers,
                                         collision, effects.tip_contact)
    return n_tip + resolve_collisions(ys, finger, hand.w, fingers, collision, settled, handled)
