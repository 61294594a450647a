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
    effect_blocks,
)
from ..grid import BYTES_PER_POINT, check_memory, grid_index_bounds, palm_half_width_steps
from ..model import (
    DEFAULT_OUTPUTS, STREAMLINE_STEP, TRAJECTORY_METHODS, Accuracy, Command, Design, Effects, Grid,
    Limits, Outputs, Part,
)
from ..schema import COUNT_FIELDS, POINT, SUMMARY_FIELDS, summary_field_on


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


def kernel_records(design: Design, part: Part, limits: Limits, accuracy: Accuracy,
                   effects: Effects, tension: float = 1.0
                   ) -> tuple[FingerModel, SolverSettings, EffectBlocks]:
    """The kernels' parameter records of a map (one place: the map and the sweep paths).
    An effect that is off has its `off` block in EffectBlocks (its `on` False: the same
    compiled kernels serve every scene; the blocks are built by kernels/records.py's BLOCKS).
    `tension` is the tendon tension of the finger the blocks are for (springs act per unit
    tension)."""
    mu_s = part.mu if effects.friction else 0.0
    finger = FingerModel(float(design.l1), float(design.l2), float(design.r1), float(design.r2),
                         float(part.r), float(mu_s), limits.theta2_min, limits.theta2_max)
    solver = SolverSettings(float(accuracy.reconfig_step), float(accuracy.root_tol),
                            TRAJECTORY_METHODS.index(accuracy.trajectory), float(STREAMLINE_STEP))
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


# Per-point fields that exist only with an output (the rest come with the energy).
CAGING_FIELDS = ("end_state", "contained", "l_open", "caging_score", "end_index")


def map_fields(fingers: FingerArrays, outs: OutcomeArrays,
               forces: ForceArrays | None, outputs: Outputs = Outputs()) -> dict[str, np.ndarray]:
    """Kernel arrays -> the named per-point fields of sweep.schema (those of the outputs on)."""
    fields = dict(energy=outs.energy, point_class=outs.point_class, end_state=outs.end_state,
                  equilibrium=outs.equilibrium, contained=outs.contained, l_open=outs.l_open,
                  caging_score=outs.caging_score, finger_mode=fingers.mode, theta1=fingers.t1,
                  theta2=fingers.t2, k1=fingers.k1, k2=fingers.k2,
                  tip_overlap=fingers.tip_overlap, end_index=outs.end_index)
    if not outputs.caging:
        for name in CAGING_FIELDS:
            del fields[name]
    if not outputs.equilibrium:
        del fields["equilibrium"]
    if forces is not None:
        fields.update(proximal_normal_force=forces.proximal_normal,
                      distal_normal_force=forces.distal_normal,
                      distal_friction_multiplier=forces.distal_multiplier,
                      resultant_force_x=forces.resultant_x, resultant_force_y=forces.resultant_y,
                      forces_determined=forces.determined,
                      geometric_cage_score=forces.geometric_cage_score)
    assert set(fields) <= set(POINT), set(fields) - set(POINT)
    return fields


# Summary fields that exist only with an output (trajectory and caging counts, equilibrium count).
CAGING_SUMMARY = ("Lambda", "caging_area", "n_caged", "n_tip_prehension", "n_ejection",
                  "n_stalled", "n_caged_points", "n_caged_crossed")


def summary_attrs(summary: np.ndarray, outputs: Outputs = Outputs(),
                  effects: Effects = Effects()) -> dict:
    """The kernels' summary row as named attributes (floats and counts, sweep.schema.SUMMARY),
    without the ones whose output or effect is off."""
    on = effects.names_on()
    attrs = {name: (int(v) if name in COUNT_FIELDS else float(v))
             for name, v in zip(SUMMARY_FIELDS, summary) if summary_field_on(name, on)}
    if not outputs.caging:
        for name in CAGING_SUMMARY:
            attrs.pop(name, None)
    if not outputs.equilibrium:
        attrs.pop("n_equilibrium", None)
    return attrs


