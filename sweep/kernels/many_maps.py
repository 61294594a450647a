"""Many maps at once (`summarize_cells`): per-map summaries of cells (l1, l2, r1, r2, r, mu) x
palm widths, from one shared finger field, and the contact forces per pose of the manipulation
metric (MODEL 10).

A finger's solution depends only on the part centre relative to its base, so when every palm
half-width is a whole number of grid steps, one right-finger field over integer offsets serves
both fingers of every width: the right finger at world column i reads offset i - s, the left
finger offset -i - s (model-notes D1). The offsets are the same floating-point numbers the
direct computation uses, so the maps are bitwise identical to `compute_map`'s.
"""
import numpy as np

from ..model import REACHED
from .hull import convex_hull, inscribed_radius
from .jit import entry, inner
from .records import (
    cell_finger,
    FieldStatics,
    FingerState,
    Hand,
    LEFT,
    MapPlace,
    new_finger_arrays,
    new_outcome_arrays,
    new_pose_forces,
    no_field_statics,
    no_force_arrays,
    no_pose_forces,
    no_settled_fingers,
    RIGHT,
    SettledFingers,
    wants_manipulation,
    wants_scenario_c,
    with_friction,
)
from .hand import (
    fingers_cross,
    friction_cones,
    link_vectors,
    part_contained,
    part_in_equilibrium,
    polyline_from_links,
    mouth_opening,
    touches_palm,
)
from .meeting import rests_on_other_finger
from .meeting_search import collide
from .outcome import cage_score, classify_point
from .one_map import (
    ALL_OUTPUTS,
    CONTAINED,
    finger_rows,
    finger_statics_at,
    fingers_touch,
    HALF_ROWS,
    map_from_fingers,
    SCRATCH_ANGLES,
    SHARED,
    STABLE_POINTS,
    WHOLE_ROWS,
)


# ---------------------------------------------------------------------------------------------
# Many maps
# ---------------------------------------------------------------------------------------------
@inner
def shared_field_extent(palm_steps, ncols):
    """(m_lo, number of offsets) of the shared field that serves every width of a cell."""
    m_lo = 0
    m_hi = 0
    for k in range(palm_steps.shape[0]):
        m_lo = min(m_lo, -ncols[k] - palm_steps[k])
        m_hi = max(m_hi, ncols[k] - palm_steps[k])
    return m_lo, m_hi - m_lo + 1


@entry
def shared_finger_field(finger, solver, effects, palm_steps, ncols, ny, h):
    """The right finger's field over every offset any width of the cell needs."""
    m_lo, nm = shared_field_extent(palm_steps, ncols)
    dxs = np.empty(nm)
    for m in range(nm):
        dxs[m] = (m + m_lo) * h
    ys = np.empty(ny)
    for j in range(ny):
        ys[j] = finger.r + j * h
    shared = new_finger_arrays(np.int64(1), ny, nm)
    finger_rows(np.int64(0), ny, dxs, ys, finger, solver, effects, shared, SHARED)
    return shared, m_lo, ys


@entry
def gather_fingers(shared, m_lo, step, ncol, ny, h):
    """Both fingers of the map of palm half-width `step` grid steps, from the shared field:
    (world xs, FingerArrays on (2, ny, 2 ncol + 1)). Copied row by row, one finger's field at a
    time: reads and writes run along rows (column by column it took over a third of the
    per-map work after the finger field); one call per field, not per row (each call with
    arrays costs reference-count pairs, docs/performance.md)."""
    nx = 2 * ncol + 1
    xs = np.empty(nx)
    for c in range(nx):
        xs[c] = (c - ncol) * h
    fingers = new_finger_arrays(np.int64(2), ny, nx)
    gather_field(shared.mode, fingers.mode, m_lo, step, ncol)
    gather_field(shared.t1, fingers.t1, m_lo, step, ncol)
    gather_field(shared.t2, fingers.t2, m_lo, step, ncol)
    gather_field(shared.k1, fingers.k1, m_lo, step, ncol)
    gather_field(shared.k2, fingers.k2, m_lo, step, ncol)
    gather_field(shared.tip_overlap, fingers.tip_overlap, m_lo, step, ncol)
    gather_field(shared.first_event, fingers.first_event, m_lo, step, ncol)
    return xs, fingers


@inner
def gather_field(src, dst, m_lo, step, ncol):
    """One field of both fingers, row by row: world column c (i = c - ncol) of the right finger
    (side 1) reads offset i - step (a shift), of the left finger offset -i - step (a mirror)."""
    nx = dst.shape[2]
    for side in range(2):
        for j in range(dst.shape[1]):
            if side == 1:
                base = -ncol - step - m_lo
                for c in range(nx):
                    dst[side, j, c] = src[0, j, base + c]
            else:
                base = ncol - step - m_lo
                for c in range(nx):
                    dst[side, j, c] = src[0, j, base - c]


@inner
def shared_finger_links(shared, finger):
    """Per point of a cell's shared finger field, the link vectors l1 (cos t1, sin t1) and
    l2 (cos phi, sin phi) in the finger's frame: (4, y, offset)."""
    ny, nm = shared.mode.shape[1], shared.mode.shape[2]
    links = np.empty((4, ny, nm))
    for j in range(ny):
        for m in range(nm):
            # what finger_polyline forms, so world coordinates match it bit for bit
            l1c, l1s, l2c, l2s = link_vectors(shared.t1[0, j, m], shared.t2[0, j, m],
                                              finger.l1, finger.l2)
            links[0, j, m] = l1c
            links[1, j, m] = l1s
            links[2, j, m] = l2c
            links[3, j, m] = l2s
    return links


@inner
def shared_finger_links_and_statics(shared, finger):
    """Per point of a cell's shared finger field, what every width's map reads from it for the
    manipulation metric: the link vectors (`shared_finger_links`) and the finger's statics per
    unit tension (determined, resultant x, y): records.FieldStatics."""
    ny, nm = shared.mode.shape[1], shared.mode.shape[2]
    links = shared_finger_links(shared, finger)
    statics = np.empty((3, ny, nm))
    for j in range(ny):
        for m in range(nm):
            st = finger_statics_at(shared, SHARED, j, m, finger)
            statics[0, j, m] = 1.0 if st.determined else 0.0
            statics[1, j, m] = st.resultant_x
            statics[2, j, m] = st.resultant_y
    return FieldStatics(links, statics)


@inner
def collect_counted_forces(xs, ys, finger, hand, outs, fingers, shared, place, manip, c, forces):
    """The counted poses of one map (MODEL 10): reached, not touching the palm, not in
    equilibrium, S_geo > 0, both fingers' forces determined by statics (model-notes D9; not
    where finger_collision stopped a finger on the other, D17: `fingers` are the map's, after
    the effect). Elsewhere the fingers are the shared field's, whose links and statics are
    precomputed (`shared`, records.FieldStatics, read where `place` says: records.MapPlace).
    Scenario B entries (command 1/1) go into row c of `manip`; Scenario A forces (each command
    F_left of manip.a_commands, F_right = 2 - F_left) into the cell's per-pose `forces`
    (records.PoseForces). Forces are the fingers' per-unit-tension resultants (world frame)
    times S_geo."""
    capacity = manip.pose.shape[1]
    n_lattice = 2 * manip.lattice_ncol[c] + 1
    links, statics = shared.links, shared.statics
    m_lo, step, ncol, ncol_max = place.m_lo, place.palm_steps, place.ncol, place.ncol_max
    a_count, a_fx, a_fy = forces.count, forces.fx, forces.fy
    for j in range(ys.shape[0]):
        y = ys[j]
        for col in range(xs.shape[0]):
            if outs.point_class[j, col] != REACHED or outs.equilibrium[j, col]:
                continue
            x = xs[col]
            if touches_palm(x, y, hand.w, finger.r) or fingers_touch(fingers, j, col, finger):
                continue
            i = col - ncol                    # world column: x = i h
            src_l = -i - step - m_lo          # the shared field's columns (gather_fingers)
            src_r = i - step - m_lo
            # cheapest first: statics (precomputed), containment, then the opening
            if statics[0, j, src_l] == 0.0 or statics[0, j, src_r] == 0.0:
                continue
            left = polyline_from_links(LEFT, hand.w, links[0, j, src_l], links[1, j, src_l],
                                       links[2, j, src_l], links[3, j, src_l])
            right = polyline_from_links(RIGHT, hand.w, links[0, j, src_r], links[1, j, src_r],
                                        links[2, j, src_r], links[3, j, src_r])
            if not part_contained(x, y, left, right):
                continue
            crossed = fingers_cross(left, right)
            s_geo = cage_score(CONTAINED, mouth_opening(left, right, crossed), finger.r)
            if s_geo <= 0.0:
                continue
            lx = -statics[1, j, src_l]         # the left finger's frame is mirrored in x
            ly = statics[2, j, src_l]
            rx = statics[1, j, src_r]
            ry = statics[2, j, src_r]
            e = manip.n_entries[c]
            if e < capacity:
                manip.pose[c, e] = j * n_lattice + i + manip.lattice_ncol[c]
                manip.fx[c, e] = (lx + rx) * s_geo
                manip.fy[c, e] = (ly + ry) * s_geo
                manip.width[c, e] = place.width
                manip.crossed[c, e] = crossed
            manip.n_entries[c] = e + 1
            a = col - ncol + ncol_max
            for f_left in manip.a_commands:
                n = a_count[j, a]
                a_fx[j, a, n] = (f_left * lx + (2.0 - f_left) * rx) * s_geo
                a_fy[j, a, n] = (f_left * ly + (2.0 - f_left) * ry) * s_geo
                a_count[j, a] = n + 1


@inner
def collect_pair_forces(xs, ys, finger, hand, effects, left, left_statics, right, right_statics,
                        place, commands, forces, half):
    """Scenario C (MODEL 10): the counted poses of one map whose left finger touches the part
    with friction hand.mu_left and the right with hand.mu_right (the palm: finger.mu_s), the
    left finger read from the shared field `left` (solved at that friction, with its links and
    statics `left_statics`, records.FieldStatics), the right from `right`, where `place` says
    (records.MapPlace); every command's force (F_left of `commands`, F_right = 2 - F_left) into
    the per-pose `forces` (records.PoseForces).

    The count rule of collect_counted_forces, pose by pose, with the same functions, so that a
    pair's poses are those of its map (`compute_map(mu_left=, mu_right=)`): settled fingers
    first (class, palm, statics, containment, S_geo), then finger_collision where the settled
    fingers cross (meeting_search.collide: a finger stopped on the other leaves the pose
    undetermined, D17), then the part's equilibrium with each contact's own cone.

    Each counted pose x = i h also gives the pose -x of the swapped pair (left with
    hand.mu_right, right with hand.mu_left), its mirror image (the model is mirror-symmetric,
    MODEL 11; the fields, links and statics are the same numbers, and its forces are formed as
    the swapped pair's own would be, bit for bit); with `half` (a pair that is its own swap),
    only the poses x <= 0 are visited."""
    r = finger.r
    w = hand.w
    collision = effects.finger_collision
    cones = friction_cones(finger.mu_s, hand.mu_left, hand.mu_right)
    scratch = np.empty(SCRATCH_ANGLES)
    mode_l, t1_l, t2_l, k1_l, k2_l = left.mode, left.t1, left.t2, left.k1, left.k2
    mode_r, t1_r, t2_r, k1_r, k2_r = right.mode, right.t1, right.t2, right.k1, right.k2
    tip_l, tip_r = left.tip_overlap, right.tip_overlap
    links_l, statics_l = left_statics.links, left_statics.statics
    links_r, statics_r = right_statics.links, right_statics.statics
    m_lo, step, ncol, ncol_max = place.m_lo, place.palm_steps, place.ncol, place.ncol_max
    count, fx, fy = forces.count, forces.fx, forces.fy
    n_cols = ncol + 1 if half else xs.shape[0]
    for j in range(ys.shape[0]):
        y = ys[j]
        for col in range(n_cols):
            i = col - ncol                    # world column: x = i h
            src_l = -i - step - m_lo          # the shared fields' columns (gather_fingers)
            src_r = i - step - m_lo
            ml = np.int64(mode_l[0, j, src_l])
            mr = np.int64(mode_r[0, j, src_r])
            if classify_point(y, r, ml, mr) != REACHED:
                continue
            x = xs[col]
            if touches_palm(x, y, w, r):
                continue
            if statics_l[0, j, src_l] == 0.0 or statics_r[0, j, src_r] == 0.0:
                continue
            left_line = polyline_from_links(LEFT, w, links_l[0, j, src_l], links_l[1, j, src_l],
                                            links_l[2, j, src_l], links_l[3, j, src_l])
            right_line = polyline_from_links(RIGHT, w, links_r[0, j, src_r],
                                             links_r[1, j, src_r], links_r[2, j, src_r],
                                             links_r[3, j, src_r])
            if not part_contained(x, y, left_line, right_line):
                continue
            crossed = fingers_cross(left_line, right_line)
            s_geo = cage_score(CONTAINED, mouth_opening(left_line, right_line, crossed), r)
            if s_geo <= 0.0:
                continue
            t1l, t2l = t1_l[0, j, src_l], t2_l[0, j, src_l]
            t1r, t2r = t1_r[0, j, src_r], t2_r[0, j, src_r]
            if crossed and collision.on:  # (fingers that do not cross are left as settled)
                changed, new_l, new_r = collide(
                    finger, w, collision,
                    FingerState(ml, t1l, t2l, k1_l[0, j, src_l], k2_l[0, j, src_l],
                                tip_l[0, j, src_l]),
                    FingerState(mr, t1r, t2r, k1_r[0, j, src_r], k2_r[0, j, src_r],
                                tip_r[0, j, src_r]))
                if changed:
                    if (rests_on_other_finger(new_l[0], new_l[1], new_l[2], finger)
                            or rests_on_other_finger(new_r[0], new_r[1], new_r[2], finger)):
                        continue
                    ml, t1l, t2l = new_l[0], new_l[1], new_l[2]
                    mr, t1r, t2r = new_r[0], new_r[1], new_r[2]
                    if classify_point(y, r, ml, mr) != REACHED:
                        continue
            if part_in_equilibrium(scratch, x, y, w, r, cones, ml, t1l, t2l, mr, t1r, t2r,
                                   finger.l1, finger.l2, effects.tip_contact):
                continue
            lx = -statics_l[1, j, src_l]         # the left finger's frame is mirrored in x
            ly = statics_l[2, j, src_l]
            rx = statics_r[1, j, src_r]
            ry = statics_r[2, j, src_r]
            a = col - ncol + ncol_max
            for f_left in commands:
                n = count[j, a]
                fx[j, a, n] = (f_left * lx + (2.0 - f_left) * rx) * s_geo
                fy[j, a, n] = (f_left * ly + (2.0 - f_left) * ry) * s_geo
                count[j, a] = n + 1
            if not (half and i == 0):
                # the swapped pair at -x: its left finger is this right one mirrored (x force
                # -rx), its right finger this left one (x force -lx)
                a = -i + ncol_max
                for f_left in commands:
                    n = count[j, a]
                    fx[j, a, n] = (f_left * -rx + (2.0 - f_left) * -lx) * s_geo
                    fy[j, a, n] = (f_left * ry + (2.0 - f_left) * ly) * s_geo
                    count[j, a] = n + 1


@inner
def append_forces(forces, more):
    """Each pose's forces in `more` appended to its own in `forces` (records.PoseForces)."""
    count, fx, fy = forces.count, forces.fx, forces.fy
    more_count, more_fx, more_fy = more.count, more.fx, more.fy
    for j in range(count.shape[0]):
        for a in range(count.shape[1]):
            n = count[j, a]
            for q in range(more_count[j, a]):
                fx[j, a, n + q] = more_fx[j, a, q]
                fy[j, a, n + q] = more_fy[j, a, q]
            count[j, a] = n + more_count[j, a]


@inner
def friction_field(finger, mu, solver, effects, palm_steps, ncols, ny, h):
    """The shared finger field of a cell with the finger's contacts at friction `mu`, and its
    links and statics, records.FieldStatics (Scenario C's low-friction surface)."""
    switched = with_friction(finger, mu)
    field, _, _ = shared_finger_field(switched, solver, effects, palm_steps, ncols, ny, h)
    return field, shared_finger_links_and_statics(field, switched)


@inner
def surrounds_origin(fx, fy):
    """Forces on both sides of the origin in x and in y: without that, the origin is not
    strictly inside their hull and the pose's value is 0 (hull.inscribed_radius returns 0 for
    such a hull, so this only spares the hull)."""
    left = right = below = above = False
    for q in range(fx.shape[0]):
        left |= fx[q] < 0.0
        right |= fx[q] > 0.0
        below |= fy[q] < 0.0
        above |= fy[q] > 0.0
    return left and right and below and above


@entry
def pose_radius_sum(count, fx, fy, pose_value, c):
    """Sum over poses of the inscribed radius of the hull of each pose's forces (MODEL 10);
    each pose's value also into pose_value[c] when that array has rows."""
    keep = pose_value.shape[0] > 0
    total = 0.0
    for j in range(count.shape[0]):
        for a in range(count.shape[1]):
            n = count[j, a]
            value = 0.0
            if n >= 3 and surrounds_origin(fx[j, a, :n], fy[j, a, :n]):
                hx, hy = convex_hull(fx[j, a, :n], fy[j, a, :n])
                value = inscribed_radius(hx, hy, hx.shape[0])
            total += value
            if keep:
                pose_value[c, j, a] = value
    return total


@entry(nogil=True)
def summarize_cells(maps, first, last, solver, effects, out, want, manip, memo, memo_key):
    """The maps of cells first .. last - 1 of `maps` (records.CellMaps: the cells, the widths
    and the layout of each map) at every width, each cell's from one shared finger field, in
    order on the calling thread, without the GIL (`sweep.compute.threads` runs ranges of cells
    on several threads). One function, not one per cell: each level of the call tree above the
    model compiles the whole tree below it again (docs/performance.md).

    out: (n, n_w, N_SUMMARY); want: bool (n, n_w), the maps to compute (out[c, k] of another
    stays as it was: the refinement asks for a few widths of a cell, and a width's map costs far
    more than its share of the field). With `manip` (a ManipulationOut with a row per cell;
    without: records.no_manipulation()) the contact forces are computed too and row c of
    `manip` receives the cell's manipulation metric data (MODEL 10), Scenario C's too when
    `manip` has its low friction (a second shared field at that friction, the pairs with a
    switched finger: collect_pair_forces). With finger_collision, `memo` is the calling thread's
    memo of meetings (records.SettledFingers: (n_w, y, x, 5), one map per width, as large as
    the largest map of `maps`: new_meeting_memo) and `memo_key` (2,) the l1, l2 of the cells that
    filled it: kept across the thread's ranges (a thread takes the next range, mostly of the
    same links), cleared when the links change; the memo changes no result (an entry is read
    only where the settled angles it stores are the point's, for the same links)."""
    cells, ws, palm_steps, ncols, nys, h = (maps.cells, maps.widths, maps.palm_steps, maps.ncols,
                                            maps.nys, maps.h)
    manipulation = wants_manipulation(manip)
    scenario_c = manipulation and wants_scenario_c(manip)
    collision = effects.finger_collision.on
    no_forces = no_force_arrays()
    # Scenario C's low-friction field depends on the cell without its mu (the cells of one
    # (l1, l2, r1, r2, r) are neighbours in the work order): kept while they follow each other
    low_key = np.full(5, np.nan)
    low = new_finger_arrays(np.int64(1), np.int64(0), np.int64(0))
    low_statics = no_field_statics()
    # the pair (mu_low, mu_low) does not depend on the part's mu either (palm poses never
    # count): its forces, kept with the field (the manipulation metric wants every width)
    low_forces = no_pose_forces()
    for c in range(first, last):
        finger = cell_finger(cells, c, maps.theta2_min, maps.theta2_max)
        ny = nys[c]
        cell_ncols = ncols[c]
        shared, m_lo, ys = shared_finger_field(finger, solver, effects, palm_steps, cell_ncols,
                                               ny, h)
        ncol_max = np.int64(0)
        slots = 0
        a_forces = no_pose_forces()
        shared_statics = no_field_statics()
        if manipulation:
            for k in range(ws.shape[0]):
                ncol_max = max(ncol_max, cell_ncols[k])
            slots = ws.shape[0] * manip.a_commands.shape[0]
            a_forces = new_pose_forces(ny, 2 * ncol_max + 1, slots)
            manip.n_entries[c] = 0
            shared_statics = shared_finger_links_and_statics(shared, finger)
        elif collision:
            shared_statics = FieldStatics(shared_finger_links(shared, finger),
                                          np.empty((3, 0, 0)))
        # Scenario C: the pairs with a finger on the low friction, unless it is the part's own
        # (then the four pairs are A's one, and C is A)
        mu_low = manip.c_mu_low[0] if scenario_c else finger.mu_s
        switching = mu_low != finger.mu_s
        c_forces = no_pose_forces()
        fresh_low = False
        if switching:
            c_forces = new_pose_forces(ny, 2 * ncol_max + 1, 4 * slots)
            key = (finger.l1, finger.l2, finger.r1, finger.r2, finger.r)
            fresh_low = not (low_key[0] == key[0] and low_key[1] == key[1]
                             and low_key[2] == key[2] and low_key[3] == key[3]
                             and low_key[4] == key[4])
            if fresh_low:
                low, low_statics = friction_field(finger, mu_low, solver, effects, palm_steps,
                                                  cell_ncols, ny, h)
                for q in range(5):
                    low_key[q] = key[q]
                low_forces = new_pose_forces(ny, 2 * ncol_max + 1, slots)
        memo_read = False
        if collision:
            memo_read = memo_key[0] == finger.l1 and memo_key[1] == finger.l2
            if not memo_read:
                memo[:] = np.nan  # meetings depend on the links (and the widths, one memo each)
                memo_key[0] = finger.l1
                memo_key[1] = finger.l2
        for k in range(ws.shape[0]):
            if not want[c, k]:
                continue
            place = MapPlace(k, m_lo, palm_steps[k], cell_ncols[k], ncol_max)
            xs, fingers = gather_fingers(shared, m_lo, place.palm_steps, place.ncol, ny, h)
            outs = new_outcome_arrays(ny, xs.shape[0])
            stack = np.empty(ny * xs.shape[0], dtype=np.int64)
            hand = Hand(ws[k], maps.f_left, maps.f_right, h, finger.mu_s, finger.mu_s)
            settled = no_settled_fingers()
            if collision:  # the settled fingers' links, as gather_fingers reads the shared field:
                # column c (world i = c - ncol) at offset -i - s (left), i - s (right), less m_lo
                left_start = place.ncol - place.palm_steps - m_lo
                right_start = -place.ncol - place.palm_steps - m_lo
                settled = SettledFingers(True, shared_statics.links, left_start, -1, right_start,
                                         1, memo[k], memo_read, True)
            map_from_fingers(xs, ys, finger, solver, hand, effects, fingers, outs, no_forces,
                             stack, out[c, k], STABLE_POINTS, ALL_OUTPUTS, ALL_OUTPUTS, settled)
            if manipulation:
                collect_counted_forces(xs, ys, finger, hand, outs, fingers, shared_statics, place,
                                       manip, c, a_forces)
            if switching:
                # (mu_low, mu_s), and its mirror image (mu_s, mu_low)
                collect_pair_forces(
                    xs, ys, finger, Hand(ws[k], maps.f_left, maps.f_right, h, mu_low,
                                         finger.mu_s),
                    effects, low, low_statics, shared, shared_statics, place, manip.a_commands,
                    c_forces, WHOLE_ROWS)
            if fresh_low:  # (mu_low, mu_low), its own mirror image: half the poses
                collect_pair_forces(
                    xs, ys, finger, Hand(ws[k], maps.f_left, maps.f_right, h, mu_low, mu_low),
                    effects, low, low_statics, low, low_statics, place, manip.a_commands,
                    low_forces, HALF_ROWS)
        if manipulation:
            manip.a_metric[c] = pose_radius_sum(a_forces.count, a_forces.fx, a_forces.fy,
                                                manip.a_pose_value, c)
        if switching:
            append_forces(c_forces, low_forces)
            append_forces(c_forces, a_forces)
            manip.c_metric[c] = pose_radius_sum(c_forces.count, c_forces.fx, c_forces.fy,
                                                manip.c_pose_value, c)
        elif scenario_c:  # mu_low is the part's own: the same forces as A
            manip.c_metric[c] = pose_radius_sum(a_forces.count, a_forces.fx, a_forces.fy,
                                                manip.c_pose_value, c)
