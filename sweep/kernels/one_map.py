"""One map (`map_from_fingers`): finger fields -> per-point outcomes -> trajectories -> summary.

The finger fields are filled by the caller (`finger_rows`, or gathered from a shared field by
many_maps); the per-point outcomes (`outcome_rows`: class, energy, equilibrium, caging geometry,
forces) read one position's class and energy from outcome.py; the summary (`count_summary`)
counts the trajectories' ends into the row schema.SUMMARY_FIELDS describes. The sweep and
`sweep.compute.maps.compute_map` both go through `map_from_fingers`. The drivers release the GIL
and work on a range of rows: the compute layer runs ranges on several threads
(`sweep.compute.threads`; no `prange`: a parallel loop compiles its whole call tree twice more).
"""
import numpy as np

from ..model import (
    EJECT,
    END_CAGED,
    END_EJECTION,
    END_NONE,
    END_STALLED,
    END_TIP_PREHENSION,
    INFEASIBLE,
    PALM_TOL,
    REACHED,
    TRAJECTORY_GRID8,
    TRAJECTORY_SLIDING,
    UNREACHED,
    VERTEX_POINT,
)
from ..schema import SUMMARY_FIELDS, SUMMARY_INDEX
from .jit import entry, inner
from .records import FingerState, LEFT, RIGHT, side_finger, with_forces
from .streamline import streamline_ends
from .finger_statics import finger_statics
from .finger import closing_constants, solve_finger_branch
from .hand import (
    friction_cones,
    part_in_equilibrium,
)
from .meeting import rests_on_other_finger
from .meeting_search import collisions_of_map
from .outcome import cage_geometry, cage_score, classify_point, point_energy
from .trajectories import trajectory_ends


# ---------------------------------------------------------------------------------------------
# One map
# ---------------------------------------------------------------------------------------------
# Positions in the summary row (sweep.schema), frozen into the kernels as constants.
N_SUMMARY = len(SUMMARY_FIELDS)
S_LAMBDA = SUMMARY_INDEX["Lambda"]
S_CAGING_AREA = SUMMARY_INDEX["caging_area"]
S_CAGED = SUMMARY_INDEX["n_caged"]
S_TIP_PREHENSION = SUMMARY_INDEX["n_tip_prehension"]
S_TIP_AREA = SUMMARY_INDEX["tip_prehension_area"]
S_ENDS_IN_EJECTION = SUMMARY_INDEX["n_ejection"]
S_STALLED = SUMMARY_INDEX["n_stalled"]
S_REACHED = SUMMARY_INDEX["n_reached"]
S_EQUILIBRIUM = SUMMARY_INDEX["n_equilibrium"]
S_VERTEX = SUMMARY_INDEX["n_vertex"]
S_TIP_OVERLAP = SUMMARY_INDEX["n_tip_overlap"]
S_CAGED_CROSSED = SUMMARY_INDEX["n_caged_crossed"]
S_POINTS = SUMMARY_INDEX["n_points"]
S_INFEASIBLE = SUMMARY_INDEX["n_infeasible"]
S_UNREACHED = SUMMARY_INDEX["n_unreached"]
S_EJECT_POINTS = SUMMARY_INDEX["n_eject"]
S_CAGED_POINTS = SUMMARY_INDEX["n_caged_points"]
S_COLLISION_CHANGED = SUMMARY_INDEX["n_collision_changed"]
SCRATCH_ANGLES = 16  # cone-edge scratch of the equilibrium test (at most 10 edges)
# Constant arguments of kernel calls (NumPy scalars: records.LEFT): a map's per-point outputs
# everywhere or only where the part is stable (summaries: `every_point`), its equilibrium and
# caging outputs on, the only finger of a shared field, a part taken as contained, a friction
# pair's poses visited on whole rows or on their half x <= 0 (many_maps.collect_pair_forces).
EVERY_POINT, STABLE_POINTS = np.bool_(True), np.bool_(False)
ALL_OUTPUTS = np.bool_(True)
WHOLE_ROWS = np.bool_(False)
HALF_ROWS = np.bool_(True)
SHARED = np.int64(0)
CONTAINED = np.bool_(True)


# ---------------------------------------------------------------------------------------------
# Finger fields
# ---------------------------------------------------------------------------------------------
@entry(nogil=True)
def finger_rows(first, last, dxs, dys, finger, solver, effects, fingers, side):
    """Solve one finger at every column offset dxs[i] of rows first .. last - 1 of the grid
    dys x dxs (finger-frame offsets: part centre at (dxs[i], dys[j])) into fingers[side].
    Without the GIL: `sweep.compute.threads` runs blocks of rows on several threads."""
    constants = closing_constants(finger)
    for j in range(first, last):
        dy = dys[j]
        for i in range(dxs.shape[0]):
            first, s = solve_finger_branch(dxs[i], dy, finger, constants, solver, effects)
            fingers.first_event[side, j, i] = first
            fingers.mode[side, j, i] = s.mode
            fingers.t1[side, j, i] = s.t1
            fingers.t2[side, j, i] = s.t2
            fingers.k1[side, j, i] = s.k1
            fingers.k2[side, j, i] = s.k2
            fingers.tip_overlap[side, j, i] = s.tip_overlap


# ---------------------------------------------------------------------------------------------
# Per-point outcomes of a map
# ---------------------------------------------------------------------------------------------
@inner
def fill_infeasible(j, i, fingers, outs, forces, forces_on):
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
        if forces_on:
            forces.proximal_normal[side, j, i] = np.nan
            forces.distal_normal[side, j, i] = np.nan
            forces.distal_multiplier[side, j, i] = np.nan
            forces.resultant_x[side, j, i] = np.nan
            forces.resultant_y[side, j, i] = np.nan
            forces.determined[side, j, i] = False
    if forces_on:
        forces.geometric_cage_score[j, i] = np.nan


@inner
def point_forces(j, i, finger_l, finger_r, fingers, forces):
    """Contact forces of both fingers at a feasible point (per unit tension, world frame), each
    finger with its own friction (records.side_finger). Where finger_collision stopped a finger
    on the other, neither finger's forces are determined (the finger-finger contact,
    model-notes D17)."""
    touching = fingers_touch(fingers, j, i, finger_l)
    for side in range(2):
        st = finger_statics_at(fingers, side, j, i, finger_l if side == 0 else finger_r)
        forces.proximal_normal[side, j, i] = st.proximal_normal
        forces.distal_normal[side, j, i] = st.distal_normal
        forces.distal_multiplier[side, j, i] = st.distal_multiplier
        # the left finger's frame is the right one's mirror image in x
        forces.resultant_x[side, j, i] = st.resultant_x if side == 1 else -st.resultant_x
        forces.resultant_y[side, j, i] = st.resultant_y
        forces.determined[side, j, i] = st.determined and not touching


@inner
def fingers_touch(fingers, j, i, finger):
    """finger_collision stopped one of the point's fingers on the other (model-notes D17)."""
    return (rests_on_other_finger(np.int64(fingers.mode[0, j, i]), fingers.t1[0, j, i],
                                  fingers.t2[0, j, i], finger)
            or rests_on_other_finger(np.int64(fingers.mode[1, j, i]), fingers.t1[1, j, i],
                                     fingers.t2[1, j, i], finger))


@inner
def finger_statics_at(fingers, side, j, i, finger):
    return finger_statics(FingerState(fingers.mode[side, j, i], fingers.t1[side, j, i],
                                      fingers.t2[side, j, i], fingers.k1[side, j, i],
                                      fingers.k2[side, j, i], fingers.tip_overlap[side, j, i]),
                          finger)


@inner
def outcome_rows(xs, ys, finger, hand, springs, tip_contact, fingers, outs, forces, scratch,
                 every_point, equilibrium, caging):
    """Class, energy, equilibrium, containment, opening, point score (and contact forces when
    `forces` has room for them: records.with_forces) at every point of the map. One call per
    map, not per row: each call of a kernel whose arguments hold arrays costs a reference-count
    pair per array (36 here), which per row was a tenth of the map's reference counting
    (docs/performance.md).

    `equilibrium` False skips the part-equilibrium test and `caging` False the cage geometry
    (containment, L_open, crossing) at every point: those fields are left False / NaN / 0.

    The finger arrays are overwritten with fill values (-1 / NaN / False) at infeasible points.
    With every_point False (summaries only), containment, L_open and crossing are computed only
    where the part is stable, the only points whose score or counts depend on them; elsewhere
    they are left False / NaN.
    """
    r = finger.r
    # the record's arrays read once: a record field read inside the loop cost a reference-count
    # pair on the points that `continue` (docs/performance.md)
    mode, t1, t2 = fingers.mode, fingers.t1, fingers.t2
    point_class, energy, l_open = outs.point_class, outs.energy, outs.l_open
    equilibrium_out, contained, crossed = outs.equilibrium, outs.contained, outs.crossed
    caged, caging_score = outs.caged, outs.caging_score
    forces_on = with_forces(forces)
    finger_l = side_finger(finger, hand, LEFT)
    finger_r = side_finger(finger, hand, RIGHT)
    cones = friction_cones(finger.mu_s, hand.mu_left, hand.mu_right)
    for j in range(ys.shape[0]):
        y = ys[j]
        for i in range(xs.shape[0]):
            x = xs[i]
            ml = np.int64(mode[0, j, i])
            mr = np.int64(mode[1, j, i])
            c = classify_point(y, r, ml, mr)
            point_class[j, i] = c
            equilibrium_out[j, i] = False
            contained[j, i] = False
            crossed[j, i] = False
            caged[j, i] = False
            caging_score[j, i] = 0.0
            if c == INFEASIBLE:
                fill_infeasible(j, i, fingers, outs, forces, forces_on)
                continue
            if forces_on:
                point_forces(j, i, finger_l, finger_r, fingers, forces)
            t1l = t1[0, j, i]
            t2l = t2[0, j, i]
            t1r = t1[1, j, i]
            t2r = t2[1, j, i]
            energy[j, i] = point_energy(t1l, t2l, t1r, t2r, finger, hand, springs)
            eq = False
            if c == REACHED and equilibrium:
                eq = part_in_equilibrium(scratch, x, y, hand.w, r, cones, ml, t1l, t2l, mr, t1r,
                                         t2r, finger.l1, finger.l2, tip_contact)
                equilibrium_out[j, i] = eq
            l_open[j, i] = np.nan
            # the manipulation metric needs S_geo wherever the part is reached (MODEL 10)
            wants_geometry = caging and (eq or every_point or (forces_on and c == REACHED))
            if forces_on:
                forces.geometric_cage_score[j, i] = 0.0
            if not wants_geometry:
                continue
            inside, intersect, opening = cage_geometry(x, y, t1l, t2l, t1r, t2r, finger, hand)
            contained[j, i] = inside
            l_open[j, i] = opening
            crossed[j, i] = intersect
            score = cage_score(inside, opening, r)
            if forces_on and c == REACHED:
                forces.geometric_cage_score[j, i] = score
            if eq and score > 0.0:
                caged[j, i] = True
                caging_score[j, i] = score


# ---------------------------------------------------------------------------------------------
# The summary row (MODEL 8: Lambda, the caging area and the counts of the trajectories' ends)
# ---------------------------------------------------------------------------------------------
@inner
def count_summary(outs, tip_overlap, score_sum, h, palm_row, out):
    """The per-map summary row, in the order of sweep.schema.SUMMARY. The caging area is the
    integral of the end score over the starts (MODEL 8) by the trapezoidal rule across the
    palm line: where the grid's first row lies on it (`palm_row`), that row's starts stand for
    half a cell (the part cannot start below the palm; model-notes D36)."""
    point_class = outs.point_class
    end_state = outs.end_state
    equilibrium = outs.equilibrium
    caged = outs.caged
    crossed = outs.crossed
    ny, nx = point_class.shape
    for n in range(out.shape[0]):
        out[n] = 0.0
    out[S_LAMBDA] = score_sum
    palm_sum = 0.0
    palm_tip = 0.0
    if palm_row:
        for i in range(nx):
            if point_class[0, i] == REACHED and end_state[0, i] == END_CAGED:
                palm_sum += outs.caging_score.flat[outs.end_index[0, i]]
            elif point_class[0, i] == REACHED and end_state[0, i] == END_TIP_PREHENSION:
                palm_tip += 1.0
    out[S_CAGING_AREA] = (score_sum - 0.5 * palm_sum) * h * h
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
                    out[S_ENDS_IN_EJECTION] += 1
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
                out[S_EJECT_POINTS] += 1
            if c != INFEASIBLE and (tip_overlap[0, j, i] or tip_overlap[1, j, i]):
                out[S_TIP_OVERLAP] += 1
            if caged[j, i]:
                out[S_CAGED_POINTS] += 1
                if crossed[j, i]:
                    out[S_CAGED_CROSSED] += 1
    out[S_POINTS] = ny * nx
    # (no trajectories, no Lambda: NaN, as the caging area)
    tip_area = (out[S_TIP_PREHENSION] - 0.5 * palm_tip) * h * h
    out[S_TIP_AREA] = tip_area if score_sum == score_sum else np.nan


# ---------------------------------------------------------------------------------------------
# The map pipeline
# ---------------------------------------------------------------------------------------------
@entry(nogil=True)
def map_from_fingers(xs, ys, finger, solver, hand, effects, fingers, outs, forces, stack,
                     summary, every_point, equilibrium, caging, settled):
    """From solved finger fields to a scored map: finger_collision, outcomes (and forces),
    trajectories (the method of SolverSettings.trajectory), summary row. The sweep and
    `sweep.compute.maps.compute_map` both come here.

    Only the outputs asked for are computed (MODEL 9): `equilibrium` False skips the part
    equilibrium test, `caging` False the cage geometry and the trajectories (end states none,
    Lambda NaN). Plain run-time flags: they are loop-invariant, and the work they skip is per
    point, so a branch costs nothing measurable (docs/effects.md). `settled`: what the sweep
    knows of the settled fingers for finger_collision (records.SettledFingers). `forces`: the
    ForceArrays to fill, or empty ones (records.with_forces)."""
    n_collision_changed = collisions_of_map(xs, ys, finger, solver, effects, hand, fingers,
                                            settled)
    scratch = np.empty(SCRATCH_ANGLES)
    outcome_rows(xs, ys, finger, hand, effects.joint_springs, effects.tip_contact, fingers, outs,
                 forces, scratch, every_point, equilibrium, caging)
    if not caging:
        outs.end_state[:, :] = END_NONE
        outs.end_index[:, :] = -1
        score_sum = np.nan  # no trajectories: Lambda does not exist
    elif solver.trajectory == TRAJECTORY_GRID8 or solver.trajectory == TRAJECTORY_SLIDING:
        score_sum = trajectory_ends(outs, fingers, xs, ys, finger, solver, effects,
                                    hand, stack, solver.trajectory == TRAJECTORY_SLIDING)
    else:
        score_sum = streamline_ends(outs, hand.h, stack, solver.streamline_step)
    count_summary(outs, fingers.tip_overlap, score_sum, hand.h,
                  abs(ys[0] - finger.r) <= PALM_TOL, summary)
    summary[S_COLLISION_CHANGED] = n_collision_changed
