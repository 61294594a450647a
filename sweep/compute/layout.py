"""What one map is, without computing it: its grid (`map_grid`, `finger_offsets`), the kernels'
parameter records of its inputs (`kernel_records`, the one conversion), and the kernels' arrays
and summary row as named fields and attributes (`map_fields`, `summary_attrs`, `EnergyMap`).

Shared by the single map (`maps.compute_map`), the sweep (`batch`) and the picture
(`report.plot`); it needs the kernels' records but none of their code, so it sits below all three.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..kernels.records import (
    EffectBlocks, FingerArrays, FingerModel, ForceArrays, Hand, OutcomeArrays, SolverSettings,
    cell_finger, effect_blocks,
)
from ..grid import (BYTES_PER_POINT, CELL_COLUMNS, check_memory, grid_index_bounds,
                    palm_half_width_steps)
from ..model import (
    DEFAULT_OUTPUTS, STREAMLINE_STEP, TRAJECTORY_METHODS, Accuracy, Command, Design, Effects, Grid,
    Limits, Outputs, Part,
)
from ..schema import COUNT_FIELDS, POINT, SUMMARY, summary_field_on


@dataclass
class MapGrid:
    """Integer grid indices and coordinates of one map (model-notes D1)."""

    h: float
    i: np.ndarray          # column integers, x = i h
    j: np.ndarray          # row integers, y = r + j h
    x: np.ndarray
    y: np.ndarray
    windowed: bool         # True when the user narrowed the window (trajectory edges differ)

    @property
    def shape(self) -> tuple[int, int]:
        return (self.y.size, self.x.size)


def map_grid(design: Design, part: Part, grid: Grid,
             bytes_per_point: int = BYTES_PER_POINT) -> MapGrid:
    """The grid of one map, checked to fit in memory (`bytes_per_point`: what the caller will
    hold per point, `map_bytes_per_point`) before anything is allocated."""
    i0, i1, j0, j1 = grid_index_bounds(design, part, grid)
    check_memory((i1 - i0 + 1) * (j1 - j0 + 1), bytes_per_point=bytes_per_point)
    h = grid.h
    i = np.arange(i0, i1 + 1, dtype=np.int64)
    j = np.arange(j0, j1 + 1, dtype=np.int64)
    return MapGrid(h=h, i=i, j=j, x=i * h, y=part.r + j * h,
                   windowed=grid.xlim is not None or grid.ylim is not None)


def finger_offsets(i: np.ndarray, w: float, h: float) -> tuple[np.ndarray, np.ndarray]:
    """Finger-frame x offsets of the left and right finger for world columns i (model-notes D1)."""
    s = palm_half_width_steps(w, h)
    if s is not None:
        return (-i - s) * h, (i - s) * h
    return -(i * h) - 0.5 * w, i * h - 0.5 * w


@dataclass
class EnergyMap:
    """Labelled arrays of one map. fields[name] is on (y, x) or (finger, y, x), finger 0 = left;
    the names and meanings are those of sweep.schema.POINT_FIELDS."""

    design: Design
    part: Part
    command: Command
    grid: Grid
    limits: Limits
    accuracy: Accuracy
    effects: Effects
    x: np.ndarray
    y: np.ndarray
    fields: dict = field(default_factory=dict)
    attrs: dict = field(default_factory=dict)
    outputs: tuple[str, ...] = DEFAULT_OUTPUTS
    #: each finger's contact friction where it is not the part's mu (MODEL 10, Scenario C);
    #: None: the part's, as in the paper (the palm always keeps it)
    mu_left: float | None = None
    mu_right: float | None = None


def contact_friction(mu, effects: Effects):
    """The contacts' friction coefficient (MODEL 5): the part's `mu`, or 0 where the scene
    switches the friction effect off (a float or an array of them)."""
    return mu if effects.friction else mu * 0.0


def cells_as_kernels_read(cells, effects: Effects) -> np.ndarray:
    """`cells` (n, 6) float64, columns grid.CELL_COLUMNS, with each cell's contact friction."""
    cells = np.array(cells, dtype=np.float64).reshape(-1, len(CELL_COLUMNS))
    mu = CELL_COLUMNS.index("mu")
    cells[:, mu] = contact_friction(cells[:, mu], effects)
    return cells


def kernel_records(design: Design, part: Part, limits: Limits, accuracy: Accuracy,
                   effects: Effects, tension: float = 1.0
                   ) -> tuple[FingerModel, SolverSettings, EffectBlocks]:
    """The kernels' parameter records of a map (one place: the map and the sweep paths).
    An effect that is off has its `off` block in EffectBlocks (its `on` False: the same
    compiled kernels serve every scene; the blocks are built by kernels/records.py's BLOCKS).
    `tension` is the tendon tension of the finger the blocks are for (springs act per unit
    tension)."""
    cell = cells_as_kernels_read([[design.l1, design.l2, design.r1, design.r2, part.r, part.mu]],
                                 effects)
    finger = cell_finger(cell, 0, float(limits.theta2_min), float(limits.theta2_max))
    solver = SolverSettings(float(accuracy.reconfig_step), float(accuracy.root_tol),
                            TRAJECTORY_METHODS.index(accuracy.trajectory), float(STREAMLINE_STEP),
                            float(accuracy.step_resolution))
    return finger, solver, effect_blocks(effects, accuracy, tension)


def hand_record(w: float, command: Command, h: float, finger: FingerModel,
                mu_left: float | None = None, mu_right: float | None = None) -> Hand:
    """The kernels' Hand of a map: palm width, tendon tensions, grid spacing and each finger's
    contact friction (None: the part's, `finger.mu_s`, which is 0 without the friction
    effect)."""
    return Hand(float(w), float(command.f_left), float(command.f_right), float(h),
                float(finger.mu_s if mu_left is None else mu_left),
                float(finger.mu_s if mu_right is None else mu_right))


def side_finger_model(finger: FingerModel, mu: float) -> FingerModel:
    """`finger` with its contacts' friction `mu` (kernels' records.side_finger, in Python)."""
    return finger._replace(mu_s=float(mu))


def finger_arrays_of(fields: dict) -> FingerArrays:
    """A map's per-finger fields (`map_fields`' names) as the kernels' FingerArrays (the
    trajectories' steps read them: model-notes D36)."""
    def f(name, dtype):
        return np.ascontiguousarray(fields[name], dtype=dtype)

    return FingerArrays(f("finger_mode", np.int8), f("theta1", np.float64),
                        f("theta2", np.float64), f("k1", np.float64), f("k2", np.float64),
                        f("tip_overlap", np.bool_), f("first_event", np.int8))


def map_fields(fingers: FingerArrays, outs: OutcomeArrays,
               forces: ForceArrays | None, outputs: Outputs = Outputs()) -> dict[str, np.ndarray]:
    """Kernel arrays -> the named per-point fields of sweep.schema (those of the outputs on)."""
    fields = dict(energy=outs.energy, point_class=outs.point_class, end_state=outs.end_state,
                  equilibrium=outs.equilibrium, contained=outs.contained, l_open=outs.l_open,
                  caging_score=outs.caging_score, finger_mode=fingers.mode, theta1=fingers.t1,
                  theta2=fingers.t2, k1=fingers.k1, k2=fingers.k2,
                  tip_overlap=fingers.tip_overlap, first_event=fingers.first_event,
                  end_index=outs.end_index)
    for name in list(fields):  # the fields of outputs that are off (sweep.schema: Field.output)
        if not getattr(outputs, POINT[name].output):
            del fields[name]
    if forces is not None:
        fields.update(proximal_normal_force=forces.proximal_normal,
                      distal_normal_force=forces.distal_normal,
                      distal_friction_multiplier=forces.distal_multiplier,
                      resultant_force_x=forces.resultant_x, resultant_force_y=forces.resultant_y,
                      forces_determined=forces.determined,
                      geometric_cage_score=forces.geometric_cage_score)
    assert set(fields) <= set(POINT), set(fields) - set(POINT)
    return fields


def summary_attrs(summary: np.ndarray, outputs: Outputs = Outputs(),
                  effects: Effects = Effects()) -> dict:
    """The kernels' summary row as named attributes (floats and counts, sweep.schema.SUMMARY),
    without the ones whose output or effect is off."""
    on = effects.names_on()
    return {f.name: (int(v) if f.name in COUNT_FIELDS else float(v))
            for f, v in zip(SUMMARY, summary)
            if summary_field_on(f.name, on) and getattr(outputs, f.output)}


