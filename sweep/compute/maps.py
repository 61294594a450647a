"""One energy map: design, part, command and grid in; labelled arrays out (MODEL 8).

`compute_map` validates its inputs (the public edge), lays out the grid, solves both fingers at
every grid point (rows on several threads), then classifies points, follows trajectories and
scores the map.
What a map is (grid, kernel records, named fields) is `layout.py`, shared with the sweep.
"""
from __future__ import annotations

import time

import numpy as np

from ..kernels.one_map import EVERY_POINT, finger_rows, map_from_fingers
from ..kernels.records import (LEFT, RIGHT, new_finger_arrays, new_force_arrays,
                               new_outcome_arrays, no_force_arrays, no_settled_fingers)
from ..grid import map_bytes_per_point
from ..model import (END_CAGED, Accuracy, Command, Design, Effects, Grid, Limits, Outputs, Part,
                     validate_finger_friction, validate_inputs, validate_scene)
from ..schema import SUMMARY_FIELDS
from .layout import (EnergyMap, finger_offsets, hand_record, kernel_records, map_fields, map_grid,
                     side_finger_model, summary_attrs)
from .threads import over_ranges


def compute_map(design: Design, part: Part, command: Command = Command(), grid: Grid = Grid(),
                limits: Limits = Limits(), accuracy: Accuracy = Accuracy(),
                effects: Effects = Effects(), *, forces: bool = False,
                outputs: Outputs | None = None, mu_left: float | None = None,
                mu_right: float | None = None) -> EnergyMap:
    """Compute one friction-based energy map (MODEL 2-8); with `forces` (or `outputs.forces`),
    also the contact forces of both fingers at every feasible point (MODEL 5.1, 5.6). Only the
    outputs on are computed (MODEL 9): without `caging` no containment, L_open or trajectories,
    without `equilibrium` no part-equilibrium test either.

    `mu_left`, `mu_right`: each finger's contact friction when its surface is not the part's
    mu (MODEL 10, Scenario C: the finger's configuration, forces and cone in the part's
    equilibrium); the palm keeps `part.mu`. None: the part's mu, the paper's model."""
    outputs = outputs or Outputs()
    if forces and not outputs.forces:
        outputs = Outputs(**{**outputs.__dict__, "forces": True})
    forces = outputs.forces
    validate_scene(effects, outputs)
    validate_inputs(design, part, command, limits, accuracy, effects)
    validate_finger_friction(effects, mu_left, mu_right)
    g = map_grid(design, part, grid, map_bytes_per_point(forces))
    ny, nx = g.shape
    finger, solver, blocks = kernel_records(design, part, limits, accuracy, effects)
    hand = hand_record(design.w, command, g.h, finger, mu_left, mu_right)
    started = time.perf_counter()

    fingers = new_finger_arrays(2, ny, nx)
    dx_left, dx_right = finger_offsets(g.i, design.w, g.h)
    for side, dxs, tension, mu in ((LEFT, dx_left, command.f_left, hand.mu_left),
                                   (RIGHT, dx_right, command.f_right, hand.mu_right)):
        _, _, side_blocks = kernel_records(design, part, limits, accuracy, effects, tension)
        side_finger = side_finger_model(finger, mu)

        def rows(first, last, dxs=dxs, side_blocks=side_blocks, side=side,
                 side_finger=side_finger):
            finger_rows(first, last, dxs, g.y, side_finger, solver, side_blocks, fingers, side)

        over_ranges(ny, rows)
    solved = time.perf_counter()

    outs = new_outcome_arrays(ny, nx)
    force_arrays = new_force_arrays(ny, nx) if forces else no_force_arrays()
    summary = np.empty(len(SUMMARY_FIELDS))
    map_from_fingers(xs=g.x, ys=g.y, finger=finger, solver=solver, hand=hand, effects=blocks,
                     fingers=fingers, outs=outs, forces=force_arrays,
                     stack=np.empty(ny * nx if outputs.caging else 0, dtype=np.int64),
                     summary=summary, every_point=EVERY_POINT,
                     equilibrium=bool(outputs.equilibrium), caging=bool(outputs.caging),
                     settled=no_settled_fingers())
    finished = time.perf_counter()

    attrs = summary_attrs(summary, outputs, effects)
    attrs.update(window_edge="user window: trajectories stop at its edge" if g.windowed
                 else "whole reach", seconds_fingers=solved - started,
                 seconds_total=finished - started)
    return EnergyMap(design=design, part=part, command=command, grid=grid, limits=limits,
                     accuracy=accuracy, effects=effects, x=g.x, y=g.y,
                     fields=map_fields(fingers, outs, force_arrays if forces else None, outputs),
                     attrs=attrs,
                     outputs=tuple(outputs.names_on()),
                     mu_left=None if mu_left is None else float(mu_left),
                     mu_right=None if mu_right is None else float(mu_right))


def scene_map(scene, design: dict, r: float, mu: float, mu_left: float | None = None,
              mu_right: float | None = None) -> EnergyMap:
    """The map of one design (`l1 l2 r1 r2 w`) of a scene (a `sweep.config.scene.Scene`: its
    first command, grid step, limits, accuracy and effects) for the part (r, mu): the map the
    report draws for a design the sweep picked; `mu_left`, `mu_right` as in `compute_map`."""
    return compute_map(Design(**design), Part(r=float(r), mu=float(mu)), scene.commands[0],
                       Grid(h=scene.h), scene.limits, scene.accuracy, scene.effects,
                       mu_left=mu_left, mu_right=mu_right)


def draw_in_then_hold(draw: EnergyMap, hold: EnergyMap) -> tuple[float, int]:
    """Caging under friction modulation, "draw in, then hold" (MODEL 10, Scenario C): a start
    point counts when its trajectory on `draw` (the fingers on the low friction) ends CAGED at a
    point q, and the trajectory from q on `hold` (the fingers on the part's friction; the same
    design, part, command and grid) ends CAGED too. Returns (Lambda, counted starts): Lambda
    sums, over the counted starts, the caging score of the point where the part is finally held
    (MODEL 8's Lambda with S_end taken at the end of the second trajectory; model-notes D33)."""
    if not (np.array_equal(draw.x, hold.x) and np.array_equal(draw.y, hold.y)):
        raise ValueError("draw in, then hold: the two maps must share one grid")
    for m in (draw, hold):
        if "end_index" not in m.fields:
            raise ValueError("draw in, then hold: the maps need the caging output (trajectories)")
    drawn = np.asarray(draw.fields["end_state"]).ravel() == END_CAGED
    q = np.asarray(draw.fields["end_index"]).ravel()[drawn]
    held = np.asarray(hold.fields["end_state"]).ravel()[q] == END_CAGED
    ends = np.asarray(hold.fields["end_index"]).ravel()[q[held]]
    return float(np.asarray(hold.fields["caging_score"]).ravel()[ends].sum()), int(held.sum())
