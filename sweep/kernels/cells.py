"""Many maps at once: per-map summaries of cells (l1, l2, r1, r2, r, mu) x palm widths.

A finger's solution depends only on the part centre relative to its base, so when every palm
half-width is a whole number of grid steps, one right-finger field over integer offsets serves
both fingers of every width: the right finger at world column i reads offset i - s, the left
finger offset -i - s (model-notes D1). The offsets are the same floating-point numbers the
direct computation uses, so the maps are bitwise identical to `compute_map`'s. Each map then goes
through the one map pipeline, `field.map_from_fingers`.
"""
import numba
import numpy as np
from numba import njit, prange

from ..model import REACHED
from .field import (N_SUMMARY, cage_score, finger_field_serial, finger_statics_at, fingers_touch,
                    map_from_fingers)
from .part import (fingers_cross, link_vectors, part_contained, polyline_from_links,
                   tip_clearance, touches_palm)
from .hull import convex_hull, inscribed_radius
from .records import (
    blocks_of,
    FingerModel,
    Hand,
    SettledFingers,
    finger_blocks,
    new_finger_arrays,
    new_force_arrays,
    new_outcome_arrays,
)


@njit(cache=True)
def shared_field_extent(steps, ncols):
    """(m_lo, number of offsets) of the shared field that serves every width of a cell."""
    m_lo = 0
    m_hi = 0
    for k in range(steps.shape[0]):
        m_lo = min(m_lo, -ncols[k] - steps[k])
        m_hi = max(m_hi, ncols[k] - steps[k])
    return m_lo, m_hi - m_lo + 1


@njit(cache=True)
def shared_finger_field(finger, solver, effects, steps, ncols, ny, h):
    """The right finger's field over every offset any width of the cell needs."""
    m_lo, nm = shared_field_extent(steps, ncols)
    dxs = np.empty(nm)
    for m in range(nm):
        dxs[m] = (m + m_lo) * h
    ys = np.empty(ny)
    for j in range(ny):
        ys[j] = finger.r + j * h
    shared = new_finger_arrays(1, ny, nm)
    finger_field_serial(dxs, ys, finger, solver, finger_blocks(effects), shared, 0)
    return shared, m_lo, ys


@njit(cache=True)
def gather_fingers(shared, m_lo, step, ncol, ny, h):
    """Both fingers of the map of palm half-width `step` grid steps, from the shared field:
    (world xs, FingerArrays on (2, ny, 2 ncol + 1)). Copied row by row, one finger's field at a
    time: reads and writes run along rows (column by column it took over a third of the
    per-map work after the finger field)."""
    nx = 2 * ncol + 1
    xs = np.empty(nx)
    for c in range(nx):
        xs[c] = (c - ncol) * h
    fingers = new_finger_arrays(2, ny, nx)
    for side in range(2):
        for j in range(ny):
            gather_row(shared.mode[0, j], fingers.mode[side, j], side, m_lo, step, ncol)
            gather_row(shared.t1[0, j], fingers.t1[side, j], side, m_lo, step, ncol)
            gather_row(shared.t2[0, j], fingers.t2[side, j], side, m_lo, step, ncol)
            gather_row(shared.k1[0, j], fingers.k1[side, j], side, m_lo, step, ncol)
            gather_row(shared.k2[0, j], fingers.k2[side, j], side, m_lo, step, ncol)
            gather_row(shared.tip_overlap[0, j], fingers.tip_overlap[side, j], side, m_lo, step,
                       ncol)
    return xs, fingers


@njit(cache=True)
def gather_row(src, dst, side, m_lo, step, ncol):
    """One row of one finger field: world column c (i = c - ncol) of the right finger reads
    offset i - step (a shift), of the left finger offset -i - step (a mirror)."""
    if side == 1:
        base = -ncol - step - m_lo
        for c in range(dst.shape[0]):
            dst[c] = src[base + c]
    else:
        base = ncol - step - m_lo
        for c in range(dst.shape[0]):
            dst[c] = src[base - c]


@njit(cache=True)
def summarize_cell(finger, solver, effects, ws, steps, ncols, ny, h, f_left, f_right, out, want,
                   manip, c, memo, memo_key, memo_next):
    """All widths of one cell from one shared finger field. out: (n_w, N_SUMMARY); `want`
    (n_w,): the widths whose maps are computed (out[k] of another stays as it was: the
    refinement asks for a few widths of a cell, and a width's map costs far more than its share
    of the field).

    steps[k] is the palm half-width of width k in grid steps; the map of width k has columns
    i = -ncols[k] .. ncols[k] and rows y_j = r + j h, j = 0 .. ny - 1. With `manip` (a
    ManipulationOut, None when off) the contact forces are computed too and row c of `manip`
    receives the cell's manipulation metric data (MODEL 10). With finger_collision, `memo`
    (n_w, y, x, 5) and `memo_key` (l1, l2 of the cell that filled it) are this thread's memo
    of meetings (records.SettledFingers), filled when `memo_next` (the next cell has the same
    links), cleared when the links change.
    """
    shared, m_lo, ys = shared_finger_field(finger, solver, effects, steps, ncols, ny, h)
    if manip is not None:
        ncol_max = 0
        for k in range(ws.shape[0]):
            ncol_max = max(ncol_max, ncols[k])
        slots = ws.shape[0] * manip.a_commands.shape[0]
        a_count = np.zeros((ny, 2 * ncol_max + 1), dtype=np.int64)
        a_fx = np.empty((ny, 2 * ncol_max + 1, slots))
        a_fy = np.empty((ny, 2 * ncol_max + 1, slots))
        manip.n_entries[c] = 0
        links, statics = shared_finger_links_and_statics(shared, finger)
    elif effects.finger_collision is not None:
        links = shared_finger_links(shared, finger)
    memo_read = False
    if effects.finger_collision is not None:
        memo_read = memo_key[0] == finger.l1 and memo_key[1] == finger.l2
        if memo_next and not memo_read:
            memo[:] = np.nan  # meetings depend on the links (and the widths, one memo each)
            memo_key[0] = finger.l1
            memo_key[1] = finger.l2
    for k in range(ws.shape[0]):
        if not want[k]:
            continue
        xs, fingers = gather_fingers(shared, m_lo, steps[k], ncols[k], ny, h)
        outs = new_outcome_arrays(ny, xs.shape[0])
        stack = np.empty(ny * xs.shape[0], dtype=np.int64)
        hand = Hand(ws[k], f_left, f_right, h)
        if effects.finger_collision is None:
            map_from_fingers(xs, ys, finger, solver, hand, effects, fingers, outs, None, stack,
                             out[k], False)  # summaries only
        else:  # the settled fingers' links, as gather_fingers reads the shared field
            map_from_fingers(xs, ys, finger, solver, hand, effects, fingers, outs, None, stack,
                             out[k], False, True, True,
                             SettledFingers(links, ncols[k] - steps[k] - m_lo, -1,
                                            -ncols[k] - steps[k] - m_lo, 1, memo[k],
                                            memo_read, memo_next))
        if manip is not None:
            collect_counted_forces(xs, ys, finger, hand, outs, fingers, links, statics, m_lo,
                                   steps[k], ncols[k], ncol_max, k, manip, c, a_count, a_fx,
                                   a_fy)
    if manip is not None:
        manip.a_metric[c] = pose_radius_sum(a_count, a_fx, a_fy, manip.a_pose_value, c)


@njit(cache=True)
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


@njit(cache=True)
def shared_finger_links_and_statics(shared, finger):
    """Per point of a cell's shared finger field, what every width's map reads from it for the
    manipulation metric: the link vectors (`shared_finger_links`) and the finger's statics per
    unit tension (determined, resultant x, y)."""
    ny, nm = shared.mode.shape[1], shared.mode.shape[2]
    links = shared_finger_links(shared, finger)
    statics = np.empty((3, ny, nm))
    for j in range(ny):
        for m in range(nm):
            st = finger_statics_at(shared, 0, j, m, finger)
            statics[0, j, m] = 1.0 if st.determined else 0.0
            statics[1, j, m] = st.resultant_x
            statics[2, j, m] = st.resultant_y
    return links, statics


@njit(cache=True)
def collect_counted_forces(xs, ys, finger, hand, outs, fingers, links, statics, m_lo, step, ncol,
                           ncol_max, k, manip, c, a_count, a_fx, a_fy):
    """The counted poses of one map (MODEL 10): reached, not touching the palm, not in
    equilibrium, S_geo > 0, both fingers' forces determined by statics (model-notes D9; not
    where finger_collision stopped a finger on the other, D17: `fingers` are the map's, after
    the effect). Elsewhere the fingers are the shared field's, whose links and statics are
    precomputed. Scenario B entries (command 1/1) go into row c of `manip`; Scenario A forces
    (each command F_left of manip.a_commands, F_right = 2 - F_left) into the cell's per-pose
    buffers. Forces are the fingers' per-unit-tension resultants (world frame) times S_geo."""
    capacity = manip.pose.shape[1]
    n_lattice = 2 * manip.lattice_ncol[c] + 1
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
            left = polyline_from_links(0, hand.w, links[0, j, src_l], links[1, j, src_l],
                                       links[2, j, src_l], links[3, j, src_l])
            right = polyline_from_links(1, hand.w, links[0, j, src_r], links[1, j, src_r],
                                        links[2, j, src_r], links[3, j, src_r])
            if not part_contained(x, y, left, right):
                continue
            crossed = fingers_cross(left, right)
            s_geo = cage_score(True, 0.0 if crossed else tip_clearance(left, right), finger.r)
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
                manip.width[c, e] = k
                manip.crossed[c, e] = crossed
            manip.n_entries[c] = e + 1
            a = col - ncol + ncol_max
            for f_left in manip.a_commands:
                n = a_count[j, a]
                a_fx[j, a, n] = (f_left * lx + (2.0 - f_left) * rx) * s_geo
                a_fy[j, a, n] = (f_left * ly + (2.0 - f_left) * ry) * s_geo
                a_count[j, a] = n + 1


@njit(cache=True)
def pose_radius_sum(count, fx, fy, pose_value, c):
    """Sum over poses of the inscribed radius of the hull of each pose's forces (MODEL 10);
    each pose's value also into pose_value[c] when that array has rows."""
    keep = pose_value.shape[0] > 0
    total = 0.0
    for j in range(count.shape[0]):
        for a in range(count.shape[1]):
            n = count[j, a]
            value = 0.0
            if n >= 3:
                hx, hy = convex_hull(fx[j, a, :n], fy[j, a, :n])
                value = inscribed_radius(hx, hy, hx.shape[0])
            total += value
            if keep:
                pose_value[c, j, a] = value
    return total


@njit(cache=True)
def cell_finger_model(cells, c, theta2_min, theta2_max):
    return FingerModel(cells[c, 0], cells[c, 1], cells[c, 2], cells[c, 3], cells[c, 4],
                       cells[c, 5], theta2_min, theta2_max)


@njit(cache=True)
def summarize_cells_shared(cells, ws, steps, ncols, nys, h, f_left, f_right, theta2_min,
                           theta2_max, solver, effects, out, want, manip, n_threads):
    """summarize_cell for every cell, cells in parallel. cells: (n, 6) l1 l2 r1 r2 r mu;
    want: bool (n, n_w), the maps to compute; manip: a ManipulationOut with one row per cell,
    or None; n_threads: Numba's thread count (numba.get_num_threads(), which a cached kernel
    cannot call)."""
    memo_shape = (0, 0, 0, 0, 5)  # finger_collision: each thread's memo of meetings
    if effects.finger_collision is not None and cells.shape[0] > 0:
        memo_shape = (n_threads, ws.shape[0], nys.max(), 2 * ncols.max() + 1, 5)
    memo = np.empty(memo_shape)
    memo_key = np.full((memo_shape[0], 2), np.nan)
    # prange captures blocks only as arguments (records.blocks_of)
    summarize_cells_of_blocks(cells, ws, steps, ncols, nys, h, f_left, f_right, theta2_min,
                              theta2_max, solver, out, want, manip, memo, memo_key,
                              *effects[:])


@njit(cache=True, parallel=True)
def summarize_cells_of_blocks(cells, ws, steps, ncols, nys, h, f_left, f_right, theta2_min,
                              theta2_max, solver, out, want, manip, memo, memo_key, b0=None,
                              b1=None, b2=None, b3=None, b4=None, b5=None):
    for c in prange(cells.shape[0]):
        t = numba.get_thread_id() if memo.shape[0] > 0 else 0
        memo_next = (c + 1 < cells.shape[0] and cells[c + 1, 0] == cells[c, 0]
                     and cells[c + 1, 1] == cells[c, 1])
        summarize_cell(cell_finger_model(cells, c, theta2_min, theta2_max), solver,
                       blocks_of(b0, b1, b2, b3, b4, b5), ws, steps, ncols[c],
                       nys[c], h, f_left, f_right, out[c], want[c], manip, c,
                       memo[t] if memo.shape[0] > 0 else memo[:0].reshape((0, 0, 0, 5)),
                       memo_key[t] if memo.shape[0] > 0 else memo_key[:0].reshape(0),
                       memo_next)


@njit(cache=True)
def cell_map(finger, solver, effects, w, step, ncol, ny, h, f_left, f_right, every_point,
             with_forces):
    """The full map of one width of a cell through the shared-field path (per-point outputs of
    the sweep path): (xs, ys, fingers, outcomes, forces, summary row); the force arrays are
    empty unless with_forces."""
    steps = np.array([step])
    ncols = np.array([ncol])
    shared, m_lo, ys = shared_finger_field(finger, solver, effects, steps, ncols, ny, h)
    xs, fingers = gather_fingers(shared, m_lo, step, ncol, ny, h)
    outs = new_outcome_arrays(ny, xs.shape[0])
    stack = np.empty(ny * xs.shape[0], dtype=np.int64)
    summary = np.empty(N_SUMMARY)
    if with_forces:
        forces = new_force_arrays(ny, xs.shape[0])
        map_from_fingers(xs, ys, finger, solver, Hand(w, f_left, f_right, h), effects, fingers,
                         outs, forces, stack, summary, every_point)
    else:
        forces = new_force_arrays(0, 0)  # same return type either way
        map_from_fingers(xs, ys, finger, solver, Hand(w, f_left, f_right, h), effects, fingers,
                         outs, None, stack, summary, every_point)
    return xs, ys, fingers, outs, forces, summary


@njit(cache=True)
def summarize_direct_map(finger, solver, effects, hand, dx_left, dx_right, xs, ys, out):
    """One map with each finger solved at its own offsets (palm half-width off the grid)."""
    ny = ys.shape[0]
    nx = xs.shape[0]
    fingers = new_finger_arrays(2, ny, nx)
    finger_field_serial(dx_left, ys, finger, solver, finger_blocks(effects), fingers, 0)
    finger_field_serial(dx_right, ys, finger, solver, finger_blocks(effects), fingers, 1)
    outs = new_outcome_arrays(ny, nx)
    stack = np.empty(ny * nx, dtype=np.int64)
    map_from_fingers(xs, ys, finger, solver, hand, effects, fingers, outs, None, stack, out,
                     False)
