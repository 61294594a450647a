"""Sweep configs ("scenes"): the YAML schema, the resolved `Scene`, its sizes and the config hash.

A scene names everything that decides the numbers of a sweep (MODEL 1, 8, 9, 10): the design and
part values, the command(s), the grid, the joint limits, the accuracy settings and the effects.
It is validated once, before any work starts, by `sweep/config/parse.py` (`load_scene`,
`scene_from_dict`); every error is a `SceneError` (a `ModelInputError`) whose one-line message
starts with the key it is about, e.g. ``designs.l1.step: must be > 0, got 0``.

Parameter values are written either as a range ``{lower, upper, step}``, an explicit list, or a
single number. A range expands by integer index, value ``i = lower + i*step`` for
``0 <= i <= floor((upper - lower)/step)``, computed in exact decimal arithmetic from the numbers as
written and rounded once to the nearest double: ``0.4 + 3*0.2`` is ``1.0``, not
``1.0000000000000002``, and nothing is ever accumulated.

Work order (see `ITEM_ORDER`): a *work item* is one cell ``(l1, l2, r1, r2, r, mu)`` under one
command, evaluated at every palm width ``w`` (the unit of `sweep.compute.batch.summarize_cells`).
Items are numbered with ``(l1, l2, r)`` outermost, so the items that share finger contact geometry
form one contiguous *geometry group*; chunks and sub-chunks are cut along those groups
(`sweep.config.chunks`).
"""
from __future__ import annotations

import hashlib
import json
import math
import sys
from dataclasses import dataclass, field

import numpy as np

from .. import __version__
from ..grid import (CELL_COLUMNS, ENTRY_CAPACITY, REDUCTIONS, cell_bytes, cell_extent,
                   grid_index_bounds, part_lattice_columns)
from ..model import (EFFECT_NAMES, OUTPUT_NAMES, Accuracy, Design, Effects, Grid, Limits,
                     ModelInputError, Outputs, Part, effect_attributes)
from ..schema import DESIGN_KEYS, SUMMARY_FIELDS  # noqa: F401 (DESIGN_KEYS: config keys)

PART_KEYS = ("r", "mu")
#: Dimensions of the results store, in storage order (a `command` dimension is appended when a
#: scene has more than one command).
STORE_DIMS = ("l1", "l2", "r1", "r2", "w", "r", "mu")
#: Work-item numbering, outermost first: (l1, l2, r) lead so that items sharing finger geometry are
#: contiguous. `w` is not here: every item covers all widths.
ITEM_ORDER = ("l1", "l2", "r", "command", "r1", "r2", "mu")
#: How many leading entries of ITEM_ORDER define a geometry group.
GROUP_AXES = 3

TOP_KEYS = ("name", "designs", "parts", "commands", "grid", "limits", "accuracy", "effects",
            "outputs", "refine", "run")
RANGE_KEYS = ("lower", "upper", "step")
COMMAND_KEYS = ("f_left", "f_right")
GRID_KEYS = ("h", "bounds")
GRID_BOUNDS = ("reach",)
LIMIT_KEYS = ("theta2_min_deg", "theta2_max_deg")
ACCURACY_KEYS = ("reconfig_step", "root_tol", "trajectory", "step_resolution")
EFFECT_KEYS = EFFECT_NAMES
MAP_OUTPUT_KEYS = OUTPUT_NAMES
OUTPUT_KEYS = MAP_OUTPUT_KEYS + ("save_maps", "manipulation", "scenario_a_top_k", "scenario_c")
SCENARIO_C_KEYS = ("mu_low",)
SAVE_MAP_KEYS = STORE_DIMS + ("command",)
RUN_KEYS = ("sub_chunk_cells",)
REFINE_KEYS = ("levels", "bound", "min_contenders")
#: Most refinement levels a config may ask for (h / 2**6 is 64 times finer than screening).
MAX_REFINE_LEVELS = 6

#: Most values one parameter may expand to (a typo such as step 1e-9 fails here, not in memory).
MAX_VALUES_PER_PARAMETER = 100_000
#: Largest estimated working set of one thread (`Scene.cell_bytes`: its largest cell's maps,
#: shared field and manipulation buffers) that a config may ask for. A fixed cap, not the free
#: memory of the machine that validates: a config checked on a login node must mean the same on
#: a compute node (where `sweep.runs.runner` checks the whole run against the free memory).
MAX_MAP_BYTES = 4 * 1024**3
#: The merged manipulation reductions (sweep.compute.manipulation.PartReduction): a kept point is 12
#: floats and a geometry index; a pose keeps its hull's vertices and near points, a handful
#: (measured: docs/performance-log.md, "Memory").
REDUCTION_ROW_BYTES = 12 * 8 + 8
KEPT_PER_POSE = 4

#: `grid_points` of a grid too fine to count (any number above the memory limit would do).
TOO_MANY_POINTS = sys.maxsize
#: Fewest grid points a map needs along each axis: a trajectory steps to neighbours, and a caged
#: region needs points around it.
MIN_POINTS_PER_AXIS = 3



class SceneError(ModelInputError):
    """A bad config; the message starts with the key it is about."""


@dataclass(frozen=True)
class RefineSettings:
    """The refinement stage (`refine:` in a config; docs/sweeps.md, "Refinement";
    `sweep.runs.refine`): after the screening sweep at `h`, per part and command, the contenders
    (the `min_contenders` best designs, and those their own coarse-versus-fine change calls
    for, never below (1 - bound) times the part's best screened caging area; equal-R designs
    counted once) are recomputed at h/2, h/4, ... h/2**levels until the best is certified.
    The defaults are what `refine: true` means; configs/paper.yaml states its own."""

    levels: int = 3
    bound: float = 0.1
    min_contenders: int = 3

    def as_dict(self) -> dict:
        return dict(levels=self.levels, bound=self.bound, min_contenders=self.min_contenders)

    def level_h(self, h: float, level: int) -> float:
        """Grid spacing of a level: h / 2**level (exact in binary floating point)."""
        return h / 2.0 ** level


# ---------------------------------------------------------------------------------------------
# The resolved scene
# ---------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class Scene:
    """A validated, fully expanded sweep config."""

    name: str
    values: dict            # STORE_DIMS name -> tuple of floats (strictly increasing)
    commands: tuple         # of Command
    h: float
    bounds: str
    limits: Limits
    accuracy: Accuracy
    effects: Effects
    save_maps: tuple = ()   # of dicts with STORE_DIMS keys (+ "command" index)
    sub_chunk_cells: int | None = None
    outputs: Outputs = Outputs()  # outputs.energy/equilibrium/caging/forces (MODEL 9)
    manipulation: bool = False   # outputs.manipulation: Scenarios A and B of MODEL 10
    scenario_a_top_k: int = 10   # outputs.scenario_a_top_k: Scenario A's candidates per part
    #: outputs.scenario_c.mu_low: Scenario C's low friction (MODEL 10); None when C is off
    scenario_c_mu_low: float | None = None
    refine: RefineSettings | None = None  # refine: the refinement stage; None when off
    source: dict = field(default_factory=dict, compare=False)  # the config as written
    path: str | None = field(default=None, compare=False)      # the file it was read from

    # --- shape of the sweep -----------------------------------------------------------------
    @property
    def widths(self) -> np.ndarray:
        return np.array(self.values["w"], dtype=np.float64)

    def axis_len(self, name: str) -> int:
        return len(self.commands) if name == "command" else len(self.values[name])

    @property
    def item_shape(self) -> tuple[int, ...]:
        return tuple(self.axis_len(a) for a in ITEM_ORDER)

    @property
    def n_items(self) -> int:
        return math.prod(self.item_shape)

    @property
    def group_size(self) -> int:
        """Items per geometry group (same l1, l2, r)."""
        return math.prod(self.item_shape[GROUP_AXES:])

    @property
    def n_groups(self) -> int:
        return math.prod(self.item_shape[:GROUP_AXES])

    @property
    def n_maps(self) -> int:
        return self.n_items * len(self.values["w"])

    @property
    def store_dims(self) -> tuple[str, ...]:
        return STORE_DIMS + (("command",) if len(self.commands) > 1 else ())

    @property
    def store_shape(self) -> tuple[int, ...]:
        return tuple(self.axis_len(d) for d in self.store_dims)

    # --- work items ---------------------------------------------------------------------------
    def item_indices(self, start: int, stop: int) -> dict[str, np.ndarray]:
        """Per ITEM_ORDER axis, the value index of every item in [start, stop)."""
        idx = np.unravel_index(np.arange(start, stop, dtype=np.int64), self.item_shape)
        return dict(zip(ITEM_ORDER, idx))

    def cells(self, start: int, stop: int) -> tuple[np.ndarray, np.ndarray]:
        """Items [start, stop) as `sweep.compute.batch` cells: float64 (n, 6) in CELL_COLUMNS order
        (l1, l2, r1, r2, r, mu), and the command index of each item (int64)."""
        ix = self.item_indices(start, stop)
        cols = [np.asarray(self.values[c], dtype=np.float64)[ix[c]] for c in CELL_COLUMNS]
        cells = np.stack(cols, axis=1) if cols[0].size else np.zeros((0, len(CELL_COLUMNS)))
        return np.ascontiguousarray(cells, dtype=np.float64), ix["command"].astype(np.int64)

    def item_of(self, point: dict) -> int:
        """Item index of a save_maps-style entry (values on the sweep's grid)."""
        multi = []
        for a in ITEM_ORDER:
            if a == "command":
                multi.append(int(point.get("command", 0)))
            else:
                multi.append(index_of(self.values[a], point[a]))
        return int(np.ravel_multi_index(tuple(multi), self.item_shape))

    def group_costs(self) -> np.ndarray:
        """Relative cost of each geometry group: grid points summed over its maps (MODEL 8)."""
        costs = []
        l1s, l2s, rs = (self.values[a] for a in ITEM_ORDER[:GROUP_AXES])
        for l1 in l1s:
            for l2 in l2s:
                for r in rs:
                    pts = sum(grid_points(l1, l2, w, r, self.h) for w in self.values["w"])
                    costs.append(pts * self.group_size)
        return np.array(costs, dtype=np.float64)

    # --- identity -----------------------------------------------------------------------------
    def resolved(self) -> dict:
        """Everything that decides the summaries, fully expanded (JSON-able). Hashed."""
        return dict(
            designs={k: list(self.values[k]) for k in DESIGN_KEYS},
            parts={k: list(self.values[k]) for k in PART_KEYS},
            commands=[dict(f_left=c.f_left, f_right=c.f_right) for c in self.commands],
            grid=dict(h=self.h, bounds=self.bounds),
            limits=dict(theta2_min_deg=self.limits.theta2_min_deg,
                        theta2_max_deg=self.limits.theta2_max_deg),
            accuracy=dict(reconfig_step=self.accuracy.reconfig_step,
                          root_tol=self.accuracy.root_tol, trajectory=self.accuracy.trajectory,
                          step_resolution=self.accuracy.step_resolution),
            effects={k: getattr(self.effects, k) for k in EFFECT_KEYS},
            item_order=list(ITEM_ORDER),
            # only when on / not the default, so that the hashes of configs without them stay
            # what they were (and stores of different scenes never merge)
            **effect_attributes(self.effects),
            **self._resolved_outputs(),
        )

    @property
    def scenario_c(self) -> bool:
        """Scenario C (friction modulation) is computed with the manipulation metric."""
        return self.scenario_c_mu_low is not None

    def _resolved_outputs(self) -> dict:
        out = {}
        if self.manipulation:
            out["manipulation"] = True
        if self.scenario_c:  # (C's metrics are in the item files: a part of the identity)
            out["scenario_c"] = {"mu_low": self.scenario_c_mu_low}
        if self.outputs != Outputs():
            out["on"] = self.outputs.names_on()
        return {"outputs": out} if out else {}

    @property
    def config_hash(self) -> str:
        """sha256 of the resolved config. Name, outputs, refine and run settings do not enter
        it: they change no summary, so a rerun with another sub-chunk size still resumes (the
        refinement's own identity is `sweep.runs.refine.refine_identity`)."""
        text = json.dumps(self.resolved(), sort_keys=True, separators=(",", ":"))
        return hashlib.sha256(text.encode()).hexdigest()

    def frozen(self) -> dict:
        """What a run directory / output file records about the config."""
        return dict(name=self.name, config_hash=self.config_hash, sweep_version=__version__,
                    resolved=self.resolved(), source=self.source,
                    save_maps=list(self.save_maps), sub_chunk_cells=self.sub_chunk_cells,
                    **({"scenario_a_top_k": self.scenario_a_top_k} if self.manipulation else {}),
                    **({"refine": self.refine.as_dict()} if self.refine else {}))

    def part_keys(self, start: int, stop: int) -> np.ndarray:
        """(r index, mu index) of items [start, stop): the part each item's maps belong to."""
        ix = self.item_indices(start, stop)
        return np.stack([ix["r"], ix["mu"]], axis=1).astype(np.int64)

    def lattice_columns(self) -> np.ndarray:
        """Per r value, N of the part's shared pose lattice x = i h, |i| <= N (MODEL 10)."""
        return np.array([part_lattice_columns(max(self.values["w"]), max(self.values["l1"]),
                                              max(self.values["l2"]), r, self.h)
                         for r in self.values["r"]], dtype=np.int64)

    # --- memory (every array a run holds; docs/performance-log.md, "Memory") ---------------------
    def cell_bytes(self) -> int:
        """What one thread holds for the scene's largest cell (grid.cell_bytes): the largest
        l1, l2 and r, every width."""
        l1, l2, r = (max(self.values[k]) for k in ("l1", "l2", "r"))
        ny, nx_max, n_shared = cell_extent(l1, l2, r, self.values["w"], self.h)
        return cell_bytes(ny, nx_max, n_shared, len(self.values["w"]), self.manipulation,
                          self.scenario_c)

    def held_bytes(self) -> int:
        """What a run holds besides its threads' cells, at most: the summaries of every item,
        twice, and with the manipulation metric a sub-chunk's Scenario B entries and the merged
        per-part reductions (KEPT_PER_POSE points of REDUCTION_ROW_BYTES per pose of every
        part's lattice, both reductions). A chunk holds that for its own items (its shard,
        assembled and rendered in memory before it is written); a one-machine run writes its
        store an item file and a part at a time, holding less
        (`sweep.storage.store.write_bytes`, what a merge checks)."""
        total = 2 * self.n_maps * len(SUMMARY_FIELDS) * 8
        if self.manipulation:
            # the Scenario B entries of a sub-chunk's cells (batch.manipulation_cells)
            cells = self.sub_chunk_cells or self.group_size
            total += cells * ENTRY_CAPACITY * (4 * 8 + 1)
            poses = sum((2 * int(n) + 1) * (self.lattice_rows() + 1)
                        for n in self.lattice_columns()) * len(self.values["mu"])
            total += poses * len(REDUCTIONS) * KEPT_PER_POSE * REDUCTION_ROW_BYTES
        return total

    def memory_bytes(self, threads: int = 1) -> int:
        """Estimated peak memory of a run of the whole scene on `threads` threads."""
        return threads * self.cell_bytes() + self.held_bytes()

    def lattice_rows(self) -> int:
        """M of every part's lattice y = r + j h, 0 <= j <= M (the largest reach, MODEL 8)."""
        return int(math.floor((max(self.values["l1"]) + max(self.values["l2"])) / self.h
                              + 1e-9))


def grid_points(l1: float, l2: float, w: float, r: float, h: float) -> int:
    """Points of the default whole-reach grid of one map (MODEL 8; as
    `sweep.compute.layout.map_grid`)."""
    try:
        i0, i1, j0, j1 = grid_index_bounds(Design(l1, l2, 1.0, 1.0, w), Part(r, 0.0), Grid(h=h))
    except ModelInputError:
        return TOO_MANY_POINTS  # too fine to count: the memory check refuses it
    return (i1 - i0 + 1) * (j1 - j0 + 1)


def grid_shape(l1: float, l2: float, w: float, r: float, h: float) -> tuple[int, int]:
    """(points along y, points along x) of one map's whole-reach grid; (0, 0) if too fine."""
    try:
        i0, i1, j0, j1 = grid_index_bounds(Design(l1, l2, 1.0, 1.0, w), Part(r, 0.0), Grid(h=h))
    except ModelInputError:
        return (0, 0)
    return (j1 - j0 + 1, i1 - i0 + 1)


def index_of(values, v) -> int:
    for i, x in enumerate(values):
        if math.isclose(x, float(v), rel_tol=1e-9, abs_tol=1e-12):
            return i
    raise KeyError(v)
