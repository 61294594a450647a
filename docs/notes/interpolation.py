"""A map predicted from the maps of neighbouring designs, and the caging answer of any map's
fields (docs/optimisation.md, "The paper's suggestion tested: interpolation in energy map
space"; docs/notes/interpolation_study.py, beside it, runs the study).

*Interpolation.* The maps of the 2^k corner designs of a box in design space (k varied
parameters), all on one grid (the same x and y: maps of different reach computed on a common
window, never extrapolated), are blended with multilinear weights (`corner_weights`):

- energy: the weighted mean over the corners where it is finite (weights renormalised);
- point class: the class with the largest total weight (ties: the smallest class code);
- equilibrium, caged: true where the corners that say so hold more than half of the weight
  (a tie is false: the prediction does not call a point caged on an even vote);
- caging score: the weighted mean over the corners caged there, where the prediction is caged.

The energy of a design that is itself a corner is that corner's, and an energy field linear (or
multilinear) in the design is reproduced exactly; the classes are votes, so critical points and
basins, which move with the design, are not interpolated, only outvoted.

*The caging answer of fields* (`caging_of_fields`): the pipeline's own trajectories
(`kernels.trajectories.trajectory_ends`, MODEL 8) on the given fields; the caging area is the
map score Lambda times h^2 as `count_summary` forms it. With `sliding` the slides evaluate the
model of the given design off the grid (the pipeline's method), so on a true map's fields it
gives `compute_map`'s answer; a predicted map has no model between its points, so it is read
with the grid-only method (sliding off, MODEL 8's 8-neighbour descent).
"""
from __future__ import annotations

import itertools

import numpy as np

from sweep.kernels.records import OutcomeArrays, new_finger_arrays
from sweep.kernels.trajectories import trajectory_ends
from sweep.model import END_CAGED, FREE, REACHED, Accuracy, Command, Design, Effects, Limits, Part
from sweep.compute.layout import finger_arrays_of, hand_record, kernel_records

#: The fields a prediction carries (what the trajectories read).
FIELDS = ("energy", "point_class", "equilibrium", "caging_score")


def corner_offsets(k: int) -> np.ndarray:
    """The 2^k corners of a k-dimensional box as 0 (lower) / 1 (upper) per parameter, in
    itertools.product order: (2^k, k) int."""
    return np.array(list(itertools.product((0, 1), repeat=k)), dtype=np.int64).reshape(-1, k)


def corner_weights(target, lower, upper) -> np.ndarray:
    """Multilinear weights of the 2^k corners (`corner_offsets` order) of the box
    [lower, upper] at `target` (each (k,)); they sum to 1 and reproduce any function linear in
    each parameter. A parameter with lower == upper gives its whole weight to the lower corner."""
    t, lo, hi = (np.asarray(v, float).reshape(-1) for v in (target, lower, upper))
    width = hi - lo
    frac = np.where(width > 0, (t - lo) / np.where(width > 0, width, 1.0), 0.0)
    offsets = corner_offsets(t.size)
    return np.prod(np.where(offsets == 1, frac, 1.0 - frac), axis=1)


def caged_points(fields: dict) -> np.ndarray:
    """The caged points of a map's fields: a positive caging score (MODEL 8: S = 1 - L_open/2r
    is positive exactly where the point is CAGED, L_open < 2r)."""
    return np.asarray(fields["caging_score"]) > 0


def interpolate_fields(corners: list, weights) -> dict:
    """The predicted fields (FIELDS) from the corners' fields (dicts with FIELDS, one shape)
    and their weights (module docstring)."""
    w = np.asarray(weights, float)
    if len(corners) != w.size:
        raise ValueError("one weight per corner")
    energy = np.stack([np.asarray(c["energy"], float) for c in corners])
    pclass = np.stack([np.asarray(c["point_class"]) for c in corners])
    shape = energy.shape[1:]
    wb = w.reshape((-1,) + (1,) * len(shape))
    finite = np.isfinite(energy)
    w_finite = np.sum(np.where(finite, wb, 0.0), axis=0)
    e_sum = np.sum(np.where(finite, wb * np.where(finite, energy, 0.0), 0.0), axis=0)
    with np.errstate(invalid="ignore", divide="ignore"):
        pred_energy = np.where(w_finite > 0, e_sum / np.where(w_finite > 0, w_finite, 1), np.nan)
    codes = np.unique(pclass)
    votes = np.stack([np.sum(np.where(pclass == c, wb, 0.0), axis=0) for c in codes])
    pred_class = codes[np.argmax(votes, axis=0)].astype(np.int8)    # first of the largest
    total = float(np.sum(w))

    def majority(flags):
        return np.sum(np.where(flags, wb, 0.0), axis=0) > 0.5 * total

    equilibrium = majority(np.stack([np.asarray(c["equilibrium"], bool) for c in corners]))
    equilibrium &= pred_class == REACHED
    caged_c = np.stack([caged_points(c) for c in corners])
    caged = majority(caged_c) & equilibrium
    score = np.stack([np.asarray(c["caging_score"], float) for c in corners])
    w_caged = np.sum(np.where(caged_c, wb, 0.0), axis=0)
    s_sum = np.sum(np.where(caged_c, wb * score, 0.0), axis=0)
    pred_score = np.where(caged, s_sum / np.where(w_caged > 0, w_caged, 1.0), 0.0)
    out = dict(energy=pred_energy, point_class=pred_class, equilibrium=equilibrium,
               caging_score=pred_score)
    if all("first_event" in c for c in corners):   # where steps are checked (D36): by vote
        first = np.stack([np.asarray(c["first_event"]) for c in corners])
        fcodes = np.unique(first)
        wf = w.reshape((-1,) + (1,) * (first.ndim - 1))
        fvotes = np.stack([np.sum(np.where(first == c, wf, 0.0), axis=0) for c in fcodes])
        out["first_event"] = fcodes[np.argmax(fvotes, axis=0)].astype(np.int8)
    return out


def caging_of_fields(fields: dict, x, y, h: float, design: Design, part: Part,
                     command: Command = Command(), limits: Limits = Limits(),
                     accuracy: Accuracy = Accuracy(), effects: Effects = Effects(),
                     sliding: bool = False) -> tuple[float, np.ndarray, np.ndarray]:
    """(caging area, end_state, end_index) of the trajectories on `fields` (FIELDS on the grid
    x, y at spacing h): the pipeline's trajectories (module docstring). `design`, `part` and
    the settings give the model the slides and the step checks evaluate (with `sliding`; the
    steps are checked where the fields' `first_event`, when given, says they could cross a
    wall: model-notes D36). The caging area is the trapezoid across the palm line, as a map's."""
    energy = np.ascontiguousarray(fields["energy"], dtype=np.float64)
    ny, nx = energy.shape
    score = np.ascontiguousarray(fields["caging_score"], dtype=np.float64)
    outs = OutcomeArrays(
        energy, np.ascontiguousarray(fields["point_class"], dtype=np.int8),
        np.ascontiguousarray(fields["equilibrium"], dtype=np.bool_),
        np.zeros((ny, nx), dtype=np.bool_), np.zeros((ny, nx)), np.zeros((ny, nx), dtype=np.bool_),
        np.ascontiguousarray(caged_points(fields), dtype=np.bool_), score,
        np.zeros((ny, nx), dtype=np.int8), np.full((ny, nx), -1, dtype=np.int64))
    finger, solver, blocks = kernel_records(design, part, limits, accuracy, effects)
    hand = hand_record(design.w, command, h, finger)
    if all(k in fields for k in ("finger_mode", "theta1", "theta2", "k1", "k2", "tip_overlap",
                                 "first_event")):
        fingers = finger_arrays_of(fields)   # where the steps are checked (D36)
    else:                                    # predicted fields: one closing stage, no meeting
        fingers = new_finger_arrays(2, ny, nx)
        fingers.first_event[:] = np.asarray(fields["first_event"]) if "first_event" in fields \
            else 0
        fingers.mode[:] = FREE
        fingers.t1[:] = np.pi
        fingers.t2[:] = finger.theta2_max
    lam = trajectory_ends(outs, fingers,
                          np.ascontiguousarray(x, dtype=np.float64),
                          np.ascontiguousarray(y, dtype=np.float64), finger, solver, blocks,
                          hand, np.empty(ny * nx, dtype=np.int64), np.bool_(sliding))
    caged = (outs.point_class[0] == REACHED) & (outs.end_state[0] == END_CAGED)
    palm = 0.0
    for i in np.flatnonzero(caged):   # in order, as the kernels sum it
        palm += float(score.ravel()[outs.end_index[0, i]])
    return (float(lam) - 0.5 * palm) * h * h, outs.end_state.copy(), outs.end_index.copy()


def ends_caged(end_state: np.ndarray, point_class: np.ndarray) -> np.ndarray:
    """The points of P_j whose trajectory ends CAGED."""
    return (np.asarray(point_class) == REACHED) & (np.asarray(end_state) == END_CAGED)
