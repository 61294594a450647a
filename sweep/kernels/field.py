"""Grids of points: finger fields, per-point outcomes, trajectories and the summary of a map
(MODEL 7, 8).

The map pipeline, `map_from_fingers`: outcomes -> trajectories -> summary, from finger fields
that the caller fills (directly with `finger_field`, or by gathering a shared field in
`kernels.cells`). The sweep's shared-field path and the plot go through it; `sweep.compute.
maps.compute_map` through `map_from_fingers_parallel`, the same steps with the outcome rows in
`prange`. Row functions do the work; `finger_field` and `outcome_rows_parallel` loop over rows
with `prange` (one map, all threads), `finger_field_serial` and `map_from_fingers` run inside the
sweep's own parallel loop over maps (Numba's default threading layer does not nest parallel
regions).
"""

import numpy as np
from numba import njit, prange

from ..model import (
    EJECT,
    END_CAGED,
    END_EJECTION,
    END_NONE,
    END_STALLED,
    END_TIP_PREHENSION,
    INFEASIBLE,
    RANGE_TOL,
    REACHED,
    UNREACHED,
    VERTEX_POINT,
)
from ..schema import SUMMARY_FIELDS, SUMMARY_INDEX
from .collision import resolve_collisions, rests_on_other_finger
from .finger import finger_statics, solve_finger
from .part import finger_polyline, fingers_cross, part_contained, part_in_equilibrium, \
    tip_clearance
from .point import classify_point, point_energy
from .records import FingerState, blocks_of
from .trajectory import trajectories

# Positions in the summary row (sweep.schema), frozen into the kernels as constants.
N_SUMMARY = len(SUMMARY_FIELDS)
S_LAMBDA = SUMMARY_INDEX["Lambda"]
S_CAGING_AREA = SUMMARY_INDEX["caging_area"]
S_CAGED = SUMMARY_INDEX["n_caged"]
S_TIP_PREHENSION = SUMMARY_INDEX["n_tip_prehension"]
S_EJECTION = SUMMARY_INDEX["n_ejection"]
S_STALLED = SUMMARY_INDEX["n_stalled"]
S_REACHED = SUMMARY_INDEX["n_reached"]
S_EQUILIBRIUM = SUMMARY_INDEX["n_equilibrium"]
S_VERTEX = SUMMARY_INDEX["n_vertex"]
S_TIP_OVERLAP = SUMMARY_INDEX["n_tip_overlap"]
S_CAGED_CROSSED = SUMMARY_INDEX["n_caged_crossed"]
S_POINTS = SUMMARY_INDEX["n_points"]
S_INFEASIBLE = SUMMARY_INDEX["n_infeasible"]
S_UNREACHED = SUMMARY_INDEX["n_unreached"]
S_EJECT = SUMMARY_INDEX["n_eject"]
S_CAGED_POINTS = SUMMARY_INDEX["n_caged_points"]
S_COLLISION_CHANGED = SUMMARY_INDEX["n_collision_changed"]
SCRATCH_ANGLES = 16  # cone-edge scratch of the equilibrium test (at most 10 edges)


# ---------------------------------------------------------------------------------------------
# Finger fields
# ---------------------------------------------------------------------------------------------
@njit(cache=True)
def finger_row(j, dxs, dy, finger, solver, effects, fingers, side):
    """Solve one finger at every column offset dxs[i] of row j (part centre at (dxs[i], dy))
    into fingers[side]."""
    for i in range(dxs.shape[0]):
        s = solve_finger(dxs[i], dy, finger, solver, effects)
        fingers.mode[side, j, i] = s.mode
        fingers.t1[side, j, i] = s.t1
        fingers.t2[side, j, i] = s.t2
        fingers.k1[side, j, i] = s.k1
        fingers.k2[side, j, i] = s.k2
        fingers.tip_overlap[side, j, i] = s.tip_overlap


@njit(cache=True)
def finger_field(dxs, dys, finger, solver, effects, fingers, side):
    """One finger over the grid dys x dxs (finger-frame offsets), rows in parallel."""
    finger_field_of_blocks(dxs, dys, finger, solver, fingers, side, *effects[:])


@njit(cache=True, parallel=True)
def finger_field_of_blocks(dxs, dys, finger, solver, fingers, side, b0=None, b1=None, b2=None,
                           b3=None, b4=None, b5=None):
    """finger_field's parallel loop. The blocks come as arguments (records.blocks_of): a prange
    loop cannot capture a record of blocks, nor a record unpacked from one (parfor lowering
    finds no definition of it, numba 0.68.1), but it can capture a record that is an argument."""
    for j in prange(dys.shape[0]):
        finger_row_of_blocks(j, dxs, dys[j], finger, solver, fingers, side, b0, b1, b2, b3, b4,
                             b5)


@njit(cache=True)
def finger_row_of_blocks(j, dxs, dy, finger, solver, fingers, side, b0, b1, b2, b3, b4, b5):
    finger_row(j, dxs, dy, finger, solver, blocks_of(b0, b1, b2, b3, b4, b5), fingers, side)


@njit(cache=True)
def finger_field_serial(dxs, dys, finger, solver, effects, fingers, side):
    for j in range(dys.shape[0]):
        finger_row(j, dxs, dys[j], finger, solver, effects, fingers, side)


# ---------------------------------------------------------------------------------------------
# Per-point outcomes of a map
# ---------------------------------------------------------------------------------------------
@njit(cache=True)
def fill_infeasible(j, i, fingers, outs, forces):
    """Fill values where the point does not exist (model-notes D6)."""
    outs.energy[j, i] = np.nan
    outs.l_open[j, i] = np.nan
    for side in range(2):
        fingers.mode[side, j, i] = -1
        fingers.t1[side, j, i] = np.nan
        fingers.t2[side, j, i] = np.nan
        fingers.k1[side, j, i] = np.nan
        fingers.k2[side, j, i] = np.nan
        fingers.tip_overlap[side, j, i] = False
        if forces is not None:
            forces.proximal_normal[side, j, i] = np.nan
            forces.distal_normal[side, j, i] = np.nan
            forces.distal_multiplier[side, j, i] = np.nan
            forces.resultant_x[side, j, i] = np.nan
            forces.resultant_y[side, j, i] = np.nan
            forces.determined[side, j, i] = False
    if forces is not None:
        forces.geometric_cage_score[j, i] = np.nan


@njit(cache=True)
def point_forces(j, i, finger, fingers, forces):
    """Contact forces of both fingers at a feasible point (per unit tension, world frame).
    Where finger_collision stopped a finger on the other, neither finger's forces are
    determined (the finger-finger contact, model-notes D17)."""
    touching = fingers_touch(fingers, j, i, finger)
    for side in range(2):
        st = finger_statics_at(fingers, side, j, i, finger)
        forces.proximal_normal[side, j, i] = st.proximal_normal
        forces.distal_normal[side, j, i] = st.distal_normal
        forces.distal_multiplier[side, j, i] = st.distal_multiplier
        # the left finger's frame is the right one's mirror image in x
        forces.resultant_x[side, j, i] = st.resultant_x if side == 1 else -st.resultant_x
        forces.resultant_y[side, j, i] = st.resultant_y
        forces.determined[side, j, i] = st.determined and not touching


@njit(cache=True)
def fingers_touch(fingers, j, i, finger):
    """finger_collision stopped one of the point's fingers on the other (model-notes D17)."""
    return (rests_on_other_finger(fingers.mode[0, j, i], fingers.t1[0, j, i],
                                  fingers.t2[0, j, i], finger)
            or rests_on_other_finger(fingers.mode[1, j, i], fingers.t1[1, j, i],
                                     fingers.t2[1, j, i], finger))


@njit(cache=True)
def finger_statics_at(fingers, side, j, i, finger):
    return finger_statics(FingerState(fingers.mode[side, j, i], fingers.t1[side, j, i],
                                      fingers.t2[side, j, i], fingers.k1[side, j, i],
                                      fingers.k2[side, j, i], fingers.tip_overlap[side, j, i]),
                          finger)


@njit(cache=True)
def outcome_row(j, xs, y, finger, hand, springs, tip, fingers, outs, forces, scratch,
                every_point, equilibrium, caging):
    """Class, energy, equilibrium, containment, opening, point score (and contact forces when
    `forces` is not None) along row j.

    `equilibrium` False skips the part-equilibrium test and `caging` False the cage geometry
    (containment, L_open, crossing) at every point: those fields are left False / NaN / 0.

    The finger arrays are overwritten with fill values (-1 / NaN / False) at infeasible points.
    With every_point False (summaries only), containment, L_open and crossing are computed only
    where the part is stable, the only points whose score or counts depend on them; elsewhere
    they are left False / NaN.
    """
    r = finger.r
    # the record's arrays read once: a record field read inside the loop cost a reference-count
    # pair on the points that `continue` (docs/performance.md, 2026-11-24)
    mode, t1, t2 = fingers.mode, fingers.t1, fingers.t2
    point_class, energy, l_open = outs.point_class, outs.energy, outs.l_open
    equilibrium_out, contained, crossed = outs.equilibrium, outs.contained, outs.crossed
    caged, caging_score = outs.caged, outs.caging_score
    for i in range(xs.shape[0]):
        x = xs[i]
        ml = mode[0, j, i]
        mr = mode[1, j, i]
        c = classify_point(y, r, ml, mr)
        point_class[j, i] = c
        equilibrium_out[j, i] = False
        contained[j, i] = False
        crossed[j, i] = False
        caged[j, i] = False
        caging_score[j, i] = 0.0
        if c == INFEASIBLE:
            fill_infeasible(j, i, fingers, outs, forces)
            continue
        if forces is not None:
            point_forces(j, i, finger, fingers, forces)
        a1l = t1[0, j, i]
        a2l = t2[0, j, i]
        a1r = t1[1, j, i]
        a2r = t2[1, j, i]
        energy[j, i] = point_energy(a1l, a2l, a1r, a2r, finger, hand, springs)
        eq = False
        if c == REACHED and equilibrium:
            eq = part_in_equilibrium(scratch, x, y, hand.w, r, finger.mu_s, ml, a1l, a2l, mr,
                                     a1r, a2r, finger.l1, finger.l2, tip)
            equilibrium_out[j, i] = eq
        l_open[j, i] = np.nan
        # the manipulation metric needs S_geo wherever the part is reached (MODEL 10)
        wants_geometry = caging and (eq or every_point or (forces is not None and c == REACHED))
        if forces is not None:
            forces.geometric_cage_score[j, i] = 0.0
        if not wants_geometry:
            continue
        inside, intersect, opening = cage_geometry(x, y, a1l, a2l, a1r, a2r, finger, hand)
        contained[j, i] = inside
        l_open[j, i] = opening
        crossed[j, i] = intersect
        score = cage_score(inside, opening, r)
        if forces is not None and c == REACHED:
            forces.geometric_cage_score[j, i] = score
        if eq and score > 0.0:
            caged[j, i] = True
            caging_score[j, i] = score


@njit(cache=True)
def cage_score(inside, opening, r):
    """S = 1 - L_open / (2r) where the part is contained and L_open < 2r, else 0 (MODEL 8; an
    exact tie L_open == 2r is not caged, model-notes D5). Stability is the caller's business:
    S of a stable point is the caging score, of any reached point S_geo (MODEL 10)."""
    if inside and opening < 2.0 * r - RANGE_TOL:
        return 1.0 - opening / (2.0 * r)
    return 0.0


@njit(cache=True)
def cage_geometry(x, y, a1l, a2l, a1r, a2r, finger, hand):
    """(contained, fingers cross, L_open) of the part at (x, y) between the fingers (MODEL 8)."""
    left = finger_polyline(0, a1l, a2l, finger.l1, finger.l2, hand.w)
    right = finger_polyline(1, a1r, a2r, finger.l1, finger.l2, hand.w)
    inside = part_contained(x, y, left, right)
    intersect = fingers_cross(left, right)
    opening = 0.0 if intersect else tip_clearance(left, right)  # = mouth_opening
    return inside, intersect, opening


# ---------------------------------------------------------------------------------------------
# Trajectories (MODEL 8): discrete steepest descent, each downhill step computed once
# ---------------------------------------------------------------------------------------------
# Neighbour order E, NE, N, NW, W, SW, S, SE (ties go to the first); j grows with y (north).
@njit(cache=True)
def count_summary(outs, tip_overlap, score_sum, h, out):
    """The per-map summary row, in the order of sweep.schema.SUMMARY."""
    point_class = outs.point_class
    end_state = outs.end_state
    equilibrium = outs.equilibrium
    caged = outs.caged
    crossed = outs.crossed
    ny, nx = point_class.shape
    for n in range(out.shape[0]):
        out[n] = 0.0
    out[S_LAMBDA] = score_sum
    out[S_CAGING_AREA] = score_sum * h * h
    for j in range(ny):
        for i in range(nx):
            c = point_class[j, i]
            if c == REACHED:
                e = end_state[j, i]
                if e == END_CAGED:
                    out[S_CAGED] += 1
                elif e == END_TIP_PREHENSION:
                    out[S_TIP_PREHENSION] += 1
                elif e == END_EJECTION:
                    out[S_EJECTION] += 1
                elif e == END_STALLED:
                    out[S_STALLED] += 1
                out[S_REACHED] += 1
                if equilibrium[j, i]:
                    out[S_EQUILIBRIUM] += 1
            elif c == VERTEX_POINT:
                out[S_VERTEX] += 1
            elif c == INFEASIBLE:
                out[S_INFEASIBLE] += 1
            elif c == UNREACHED:
                out[S_UNREACHED] += 1
            elif c == EJECT:
                out[S_EJECT] += 1
            if c != INFEASIBLE and (tip_overlap[0, j, i] or tip_overlap[1, j, i]):
                out[S_TIP_OVERLAP] += 1
            if caged[j, i]:
                out[S_CAGED_POINTS] += 1
                if crossed[j, i]:
                    out[S_CAGED_CROSSED] += 1
    out[S_POINTS] = ny * nx


# ---------------------------------------------------------------------------------------------
# The map pipeline
# ---------------------------------------------------------------------------------------------
@njit(cache=True)
def map_from_fingers(xs, ys, finger, solver, hand, effects, fingers, outs, forces, stack,
                     summary, every_point, equilibrium=True, caging=True, links=None):
    """From solved finger fields to a scored map: outcomes (and forces) -> trajectories ->
    summary row. Serial (the sweep calls it inside its own parallel loop over maps);
    `map_from_fingers_parallel` is the same pipeline with the outcome rows in parallel.

    Only the outputs asked for are computed (MODEL 9): `equilibrium` False skips the part
    equilibrium test, `caging` False the cage geometry and the trajectories (end states none,
    Lambda NaN). Plain run-time flags: they are loop-invariant, and the work they skip is per
    point, so a branch costs nothing measurable (docs/effects.md). `links`: the settled
    fingers' link vectors for finger_collision (the sweep's, `collision.resolve_collisions`)."""
    n_collision_changed = resolve_collisions(ys, finger, hand.w, fingers,
                                             effects.finger_collision, links)
    scratch = np.empty(SCRATCH_ANGLES)
    for j in range(ys.shape[0]):
        outcome_row(j, xs, ys[j], finger, hand, effects.joint_springs, effects.tip_contact,
                    fingers, outs, forces,
                    scratch, every_point, equilibrium, caging)
    map_after_outcomes(xs, ys, finger, solver, hand, effects, fingers, outs, stack, summary,
                       caging, n_collision_changed)


@njit(cache=True)
def map_from_fingers_parallel(xs, ys, finger, solver, hand, effects, fingers, outs, forces,
                              stack, summary, every_point, equilibrium=True, caging=True):
    """map_from_fingers with the outcome rows in parallel (one map, all threads: compute_map).
    Rows are independent, so the results are those of the serial pipeline, bit for bit."""
    n_collision_changed = resolve_collisions(ys, finger, hand.w, fingers,
                                             effects.finger_collision)
    outcome_rows_parallel(xs, ys, finger, hand, effects.joint_springs, effects.tip_contact,
                          fingers, outs, forces, every_point, equilibrium, caging)
    map_after_outcomes(xs, ys, finger, solver, hand, effects, fingers, outs, stack, summary,
                       caging, n_collision_changed)


@njit(cache=True, parallel=True)
def outcome_rows_parallel(xs, ys, finger, hand, springs, tip, fingers, outs, forces,
                          every_point, equilibrium, caging):
    """The outcome rows of one map, in parallel (records and blocks as arguments: see
    finger_field_of_blocks)."""
    for j in prange(ys.shape[0]):
        scratch = np.empty(SCRATCH_ANGLES)  # per row: each thread its own
        outcome_row(j, xs, ys[j], finger, hand, springs, tip, fingers, outs, forces, scratch,
                    every_point, equilibrium, caging)


@njit(cache=True)
def map_after_outcomes(xs, ys, finger, solver, hand, effects, fingers, outs, stack, summary,
                       caging, n_collision_changed):
    """Trajectories and the summary row of a map whose outcomes are filled."""
    if caging:
        score_sum = trajectories(outs, xs, ys, finger, solver, effects, hand, stack)
    else:
        outs.end_state[:, :] = END_NONE
        outs.end_index[:, :] = -1
        score_sum = np.nan  # no trajectories: Lambda does not exist
    count_summary(outs, fingers.tip_overlap, score_sum, hand.h, summary)
    summary[S_COLLISION_CHANGED] = n_collision_changed
