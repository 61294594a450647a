"""Sweep configs ("scenes"): the YAML schema, loading, validation, expansion and the config hash.

A scene names everything that decides the numbers of a sweep (MODEL 1, 8, 9, 10): the design and
part values, the command(s), the grid, the joint limits, the accuracy settings and the effects.
It is validated once, here, before any work starts; every error is a `SceneError` (a
`ModelInputError`) whose one-line message starts with the key it is about, e.g.
``designs.l1.step: must be > 0, got 0``.

Parameter values are written either as a range ``{lower, upper, step}``, an explicit list, or a
single number. A range expands by integer index, value ``i = lower + i*step`` for
``0 <= i <= floor((upper - lower)/step)``, computed in exact decimal arithmetic from the numbers as
written and rounded once to the nearest double: ``0.4 + 3*0.2`` is ``1.0``, not
``1.0000000000000002``, and nothing is ever accumulated.

Work order (see `ITEM_ORDER`): a *work item* is one cell ``(l1, l2, r1, r2, r, mu)`` under one
command, evaluated at every palm width ``w`` (the unit of `sweep.batch.summarize_cells`). Items are
numbered with ``(l1, l2, r)`` outermost, so the items that share finger contact geometry form one
contiguous *geometry group*; chunks and sub-chunks are cut along those groups (`sweep.chunks`).
"""
from __future__ import annotations

import contextlib
import dataclasses
import hashlib
import json
import math
import re
import sys
from dataclasses import dataclass, field
from decimal import Decimal, InvalidOperation
from pathlib import Path

import numpy as np
import yaml

from . import __version__
from .batch import (CELL_COLUMNS, ENTRY_CAPACITY, cell_bytes, cell_extent,
                    part_lattice_columns)
from .manipulation import REDUCTIONS
from .maps import grid_index_bounds
from .model import (IMPLEMENTED_EFFECTS, RECONFIG_STEP_RANGE, ROOT_TOL_RANGE, TRAJECTORY_METHODS,
                    Accuracy, Command, Design, Effects, Grid, Limits, ModelInputError, Outputs,
                    Part, validate_inputs)
from .schema import SUMMARY_FIELDS

DESIGN_KEYS = ("l1", "l2", "r1", "r2", "w")
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
ACCURACY_KEYS = ("reconfig_step", "root_tol", "trajectory")
EFFECT_KEYS = ("friction", "tip_contact", "joint_springs", "finger_collision")
MAP_OUTPUT_KEYS = ("energy", "equilibrium", "caging", "forces")  # model.OUTPUT_NAMES
OUTPUT_KEYS = MAP_OUTPUT_KEYS + ("save_maps", "manipulation", "scenario_a_top_k")
SPRING_KEYS = ("K1", "K2")
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
#: a compute node (where `sweep.runner` checks the whole run against the free memory).
MAX_MAP_BYTES = 4 * 1024**3
#: The merged manipulation reductions (sweep.manipulation.PartReduction): a kept point is 12
#: floats and a geometry index; a pose keeps its hull's vertices and near points, a handful
#: (measured: docs/performance.md, "Memory").
REDUCTION_ROW_BYTES = 12 * 8 + 8
KEPT_PER_POSE = 4

#: `grid_points` of a grid too fine to count (any number above the memory limit would do).
TOO_MANY_POINTS = sys.maxsize
#: Fewest grid points a map needs along each axis: a trajectory steps to neighbours, and a caged
#: region needs points around it.
MIN_POINTS_PER_AXIS = 3

_NAME_RE = re.compile(r"^[A-Za-z0-9][A-Za-z0-9_.-]*$")


class SceneError(ModelInputError):
    """A bad config; the message starts with the key it is about."""


@dataclass(frozen=True)
class RefineSettings:
    """The refinement stage (`refine:` in a config; docs/sweeps.md, "Refinement";
    `sweep.refine`): after the screening sweep at `h`, per part and command, the contenders
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
        """Items [start, stop) as `sweep.batch` cells: float64 (n, 6) in CELL_COLUMNS order
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
                multi.append(_index_of(self.values[a], point[a]))
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
                          root_tol=self.accuracy.root_tol, trajectory=self.accuracy.trajectory),
            effects={k: getattr(self.effects, k) for k in EFFECT_KEYS},
            item_order=list(ITEM_ORDER),
            # only when on / not the default, so that the hashes of configs without them stay
            # what they were (and stores of different scenes never merge)
            **({"joint_springs": dict(K1=self.effects.spring_k1, K2=self.effects.spring_k2)}
               if self.effects.joint_springs else {}),
            **self._resolved_outputs(),
        )

    def _resolved_outputs(self) -> dict:
        out = {}
        if self.manipulation:
            out["manipulation"] = True
        if self.outputs != Outputs():
            out["on"] = self.outputs.names_on()
        return {"outputs": out} if out else {}

    @property
    def config_hash(self) -> str:
        """sha256 of the resolved config. Name, outputs, refine and run settings do not enter
        it: they change no summary, so a rerun with another sub-chunk size still resumes (the
        refinement's own identity is `sweep.refine.refine_identity`)."""
        text = json.dumps(self.resolved(), sort_keys=True, separators=(",", ":"))
        return hashlib.sha256(text.encode()).hexdigest()

    def frozen(self) -> dict:
        """What a run directory / output file records about the config (habit 8)."""
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

    # --- memory (every array a run holds; docs/performance.md, "Memory") ---------------------
    def cell_bytes(self) -> int:
        """What one thread holds for the scene's largest cell (batch.cell_bytes): the largest
        l1, l2 and r, every width."""
        l1, l2, r = (max(self.values[k]) for k in ("l1", "l2", "r"))
        ny, nx_max, n_shared = cell_extent(l1, l2, r, self.values["w"], self.h)
        return cell_bytes(ny, nx_max, n_shared, len(self.values["w"]), self.manipulation)

    def held_bytes(self) -> int:
        """What a run holds besides its threads' cells: the summaries of every item, twice (the
        assembled array and the store's image, rendered in memory before it is written), and
        with the manipulation metric a sub-chunk's Scenario B entries and the merged per-part
        reductions (KEPT_PER_POSE points of REDUCTION_ROW_BYTES per pose of every part's
        lattice, both reductions)."""
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
    """Points of the default whole-reach grid of one map (MODEL 8; as `sweep.maps.map_grid`)."""
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


def _index_of(values, v) -> int:
    for i, x in enumerate(values):
        if math.isclose(x, float(v), rel_tol=1e-9, abs_tol=1e-12):
            return i
    raise KeyError(v)


# ---------------------------------------------------------------------------------------------
# Loading
# ---------------------------------------------------------------------------------------------
class _UniqueKeyLoader(yaml.SafeLoader):
    """SafeLoader that refuses duplicate mapping keys (PyYAML silently keeps the last one)."""


def _construct_mapping(loader, node, deep=False):
    seen = set()
    for key_node, _ in node.value:
        key = loader.construct_object(key_node, deep=deep)
        if key in seen:
            raise SceneError(f"{key}: duplicate key (line {key_node.start_mark.line + 1})")
        seen.add(key)
    return yaml.SafeLoader.construct_mapping(loader, node, deep=deep)


_UniqueKeyLoader.add_constructor(yaml.resolver.BaseResolver.DEFAULT_MAPPING_TAG, _construct_mapping)
# YAML 1.1 (PyYAML) reads 1e-12 (no dot) as a string; read it as the number YAML 1.2 and every
# reader means, so that numbers can be checked strictly (a quoted "0.2" is refused).
_UniqueKeyLoader.add_implicit_resolver(
    "tag:yaml.org,2002:float", re.compile(r"^[-+]?(?:[0-9][0-9_]*)(?:\.[0-9_]*)?[eE][-+]?[0-9]+$"),
    list("-+0123456789"))


def load_scene(path: str | Path) -> Scene:
    """Read, validate and expand a YAML config. Raises SceneError naming the bad key."""
    path = Path(path)
    try:
        data = path.read_bytes()
    except OSError as exc:
        raise SceneError(f"{path}: cannot read config ({exc.strerror or exc})") from None
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError as exc:   # e.g. an HDF5 store given where the config goes
        raise SceneError(f"{path}: not a YAML config (byte {exc.start} is not UTF-8 text); "
                         "give the sweep's .yaml file") from None
    try:
        raw = yaml.load(text, Loader=_UniqueKeyLoader)
    except yaml.YAMLError as exc:
        where = getattr(exc, "problem_mark", None)
        line = f" (line {where.line + 1})" if where is not None else ""
        problem = str(getattr(exc, "problem", None) or exc).splitlines()[0]
        raise SceneError(f"{path.name}: not valid YAML{line}: {problem}") from None
    except RecursionError:
        raise SceneError(f"{path.name}: not a config: nested too deeply") from None
    return dataclasses.replace(scene_from_dict(raw, default_name=path.stem), path=str(path))


def scene_from_dict(raw, default_name: str = "sweep") -> Scene:
    """Validate and expand a parsed config mapping."""
    raw = _mapping(raw, "config", TOP_KEYS, required=("designs", "parts"))

    name = raw.get("name", default_name)
    if not isinstance(name, str):
        raise SceneError(f"name: must be text, got the {type(name).__name__} {name!r}; quote it "
                         f"(name: \"{name}\")")
    if not _NAME_RE.match(name):
        raise SceneError(f"name: must start with a letter or digit and hold only letters, "
                         f"digits, '_', '.' or '-' (used in file and job names), got {name!r}")

    values = {}
    designs = _mapping(raw["designs"], "designs", DESIGN_KEYS, required=DESIGN_KEYS)
    parts = _mapping(raw["parts"], "parts", PART_KEYS, required=PART_KEYS)
    for k in DESIGN_KEYS:
        values[k] = _expand(designs[k], f"designs.{k}")
    for k in PART_KEYS:
        values[k] = _expand(parts[k], f"parts.{k}")
    _check_physical(values)

    commands = _commands(raw.get("commands", [dict(f_left=1.0, f_right=1.0)]))

    grid = _mapping(raw.get("grid", {}), "grid", GRID_KEYS)
    h = _number(grid.get("h", 0.05), "grid.h")
    if not h > 0:
        raise SceneError(f"grid.h: must be > 0, got {h!r}")
    bounds = grid.get("bounds", "reach")
    if bounds not in GRID_BOUNDS:
        raise SceneError(f"grid.bounds: must be one of {', '.join(GRID_BOUNDS)} (the whole reach "
                         f"of each design, MODEL 8), got {bounds!r}")

    lim = _mapping(raw.get("limits", {}), "limits", LIMIT_KEYS)
    limits = Limits(
        theta2_min_deg=_number(lim.get("theta2_min_deg", -5.0), "limits.theta2_min_deg"),
        theta2_max_deg=_number(lim.get("theta2_max_deg", 90.0), "limits.theta2_max_deg"))
    if not -90.0 < limits.theta2_min_deg <= 0.0:
        raise SceneError(f"limits.theta2_min_deg: must be in (-90, 0] (MODEL 1), "
                         f"got {limits.theta2_min_deg!r}")
    if not limits.theta2_min_deg < limits.theta2_max_deg <= 180.0:
        raise SceneError(f"limits.theta2_max_deg: must be in (theta2_min_deg, 180], "
                         f"got {limits.theta2_max_deg!r}")

    acc = _mapping(raw.get("accuracy", {}), "accuracy", ACCURACY_KEYS)
    accuracy = Accuracy(
        reconfig_step=_number(acc.get("reconfig_step", 0.01), "accuracy.reconfig_step"),
        root_tol=_number(acc.get("root_tol", 1e-12), "accuracy.root_tol"),
        trajectory=acc.get("trajectory", Accuracy.trajectory))
    for key, (low, high) in (("reconfig_step", RECONFIG_STEP_RANGE),
                             ("root_tol", ROOT_TOL_RANGE)):
        value = getattr(accuracy, key)
        if not (math.isfinite(value) and low <= value <= high):
            raise SceneError(f"accuracy.{key}: must be in [{low:g}, {high:g}] rad, "
                             f"got {value!r}")
    if accuracy.trajectory not in TRAJECTORY_METHODS:
        raise SceneError(f"accuracy.trajectory: {accuracy.trajectory!r} is not implemented "
                         f"(valid: {', '.join(TRAJECTORY_METHODS)}; 'discrete' means grid8)")

    eff = _mapping(raw.get("effects", {}), "effects", EFFECT_KEYS)
    flags = {}
    springs = eff.get("joint_springs", False)
    if isinstance(springs, dict):  # joint_springs: {K1: .., K2: ..} switches the effect on
        spring = _mapping(springs, "effects.joint_springs", SPRING_KEYS, required=SPRING_KEYS)
        for key in SPRING_KEYS:
            value = _number(spring[key], f"effects.joint_springs.{key}")
            if not value >= 0:
                raise SceneError(f"effects.joint_springs.{key}: must be >= 0, got {value!r}")
            flags["spring_k" + key[1]] = value
        eff = {**eff, "joint_springs": True}
    elif springs is True:
        raise SceneError("effects.joint_springs: give the stiffnesses, e.g. "
                         "joint_springs: {K1: 0.01, K2: 0.01}")
    for k in EFFECT_KEYS:
        v = eff.get(k, k == "friction")
        if not isinstance(v, bool):
            raise SceneError(f"effects.{k}: must be true or false, got {v!r}")
        if v and k not in IMPLEMENTED_EFFECTS:
            raise SceneError(f"effects.{k}: not implemented yet (implemented: "
                             f"{', '.join(sorted(IMPLEMENTED_EFFECTS))}); set it to false")
        flags[k] = v
    effects = Effects(**flags)
    if not effects.friction and any(m != 0 for m in values["mu"]):
        raise SceneError("effects.friction: false, but parts.mu has values other than 0; for a "
                         "frictionless sweep write parts.mu: [0.0]")

    # Backstop: the model's own edge validation on the extreme corners of the sweep.
    for pick in (min, max):
        design = Design(**{k: pick(values[k]) for k in DESIGN_KEYS})
        part = Part(r=pick(values["r"]), mu=pick(values["mu"]))
        for c in commands:
            try:
                validate_inputs(design, part, c, limits, accuracy, effects)
            except ModelInputError as exc:
                raise SceneError(f"config: {exc}") from None

    _check_countable(values, h)
    _check_coarse(values, h)

    outputs = _mapping(raw.get("outputs", {}) or {}, "outputs", OUTPUT_KEYS)
    map_outputs = {}
    for k in MAP_OUTPUT_KEYS:
        v = outputs.get(k, getattr(Outputs(), k))
        if not isinstance(v, bool):
            raise SceneError(f"outputs.{k}: must be true or false, got {v!r}")
        map_outputs[k] = v
    map_outputs = Outputs(**map_outputs)
    try:
        map_outputs.validate()
    except ModelInputError as exc:
        raise SceneError(str(exc)) from None
    if not map_outputs.caging:
        # the store's summaries are caging summaries (Lambda ranks the designs); an energy-only
        # map is `sweep map --outputs energy`
        raise SceneError("outputs.caging: a sweep stores caging summaries and needs it on; for "
                         "energy-only maps use `sweep map --outputs energy`")
    save_maps = _save_maps(outputs.get("save_maps", []) or [], values, len(commands))
    manipulation = outputs.get("manipulation", False)
    if not isinstance(manipulation, bool):
        raise SceneError(f"outputs.manipulation: must be true or false, got {manipulation!r}")
    top_k = outputs.get("scenario_a_top_k", 10)
    if isinstance(top_k, bool) or not isinstance(top_k, int) or top_k < 1:
        raise SceneError(f"outputs.scenario_a_top_k: must be a whole number >= 1, got {top_k!r}")
    if manipulation:
        if len(commands) != 1:
            raise SceneError("outputs.manipulation: needs exactly one command (the caging "
                             "sweep's); Scenarios A and B use their own (MODEL 10)")
        for w in values["w"]:
            s = w / (2.0 * h)
            if abs(s - round(s)) > 1e-9:
                raise SceneError(f"outputs.manipulation: every palm width must be a multiple of "
                                 f"2h = {2 * h:g} (poses are shared lattice points); w = {w:g}")

    _check_memory(values, h, manipulation)

    if effects.joint_springs:
        if any((c.f_left, c.f_right) != (1.0, 1.0) for c in commands):
            # the sweep solves one finger field for both fingers at unit tension
            raise SceneError("effects.joint_springs: a sweep with springs needs the command "
                             "f_left = f_right = 1 (scale K1, K2 instead)")
        if map_outputs.forces or manipulation:
            raise SceneError("effects.joint_springs: forces and the manipulation metric leave "
                             "the springs out; switch them off")

    if effects.tip_contact and (map_outputs.forces or manipulation):
        raise SceneError("effects.tip_contact: forces and the manipulation metric have no tip "
                         "contacts (model-notes D15); switch them off")

    refine = refine_settings(raw.get("refine", False), values, h)

    run = _mapping(raw.get("run", {}) or {}, "run", RUN_KEYS)
    sub = run.get("sub_chunk_cells")
    if sub is not None and (isinstance(sub, bool) or not isinstance(sub, int) or sub < 1):
        raise SceneError(f"run.sub_chunk_cells: must be a whole number >= 1, got {sub!r}")

    return Scene(name=name, values=values, commands=commands, h=h, bounds=bounds, limits=limits,
                 accuracy=accuracy, effects=effects, save_maps=save_maps, sub_chunk_cells=sub,
                 outputs=map_outputs, manipulation=manipulation, scenario_a_top_k=top_k,
                 refine=refine, source=_jsonable(raw))


# ---------------------------------------------------------------------------------------------
# Pieces
# ---------------------------------------------------------------------------------------------
def _mapping(obj, key: str, valid, required=()) -> dict:
    if not isinstance(obj, dict):
        raise SceneError(f"{key}: must be a mapping with keys {', '.join(valid)}, "
                         f"got {type(obj).__name__} {obj!r}")
    for k in obj:
        if k not in valid:
            raise SceneError(f"{_join(key, k)}: unknown key (valid: {', '.join(valid)})")
    for k in required:
        if k not in obj:
            raise SceneError(f"{_join(key, k)}: missing (required: {', '.join(required)})")
    return obj


def _join(prefix: str, k) -> str:
    return str(k) if prefix == "config" else f"{prefix}.{k}"


def _number(v, key: str) -> float:
    """A finite number. Quoted strings are refused, as a strict schema would (the loader reads
    YAML 1.1's unquoted ``1e-12`` as a number)."""
    if isinstance(v, bool):
        raise SceneError(f"{key}: must be a number, got {v!r}")
    if isinstance(v, str):
        hint = ""
        with contextlib.suppress(ValueError):
            float(v)
            hint = " (a quoted string: write the number without quotes)"
        raise SceneError(f"{key}: must be a number, got {v!r}{hint}")
    if not isinstance(v, (int, float)) or not math.isfinite(v):
        raise SceneError(f"{key}: must be a finite number, got {v!r}")
    return float(v)


def _decimal(v: float) -> Decimal:
    return Decimal(repr(float(v)))


def _expand(spec, key: str) -> tuple[float, ...]:
    """A parameter spec -> strictly increasing tuple of floats (see the module docstring)."""
    if isinstance(spec, dict):
        _mapping(spec, key, RANGE_KEYS, required=RANGE_KEYS)
        lower, upper, step = (_number(spec[k], f"{key}.{k}") for k in RANGE_KEYS)
        if not step > 0:
            raise SceneError(f"{key}.step: must be > 0, got {spec['step']!r}")
        if lower > upper:
            raise SceneError(f"{key}: empty range, lower ({lower!r}) > upper ({upper!r})")
        lo, up, st = _decimal(lower), _decimal(upper), _decimal(step)
        try:
            n = int((up - lo) // st) + 1
        except InvalidOperation:
            n = MAX_VALUES_PER_PARAMETER + 1
        if n > MAX_VALUES_PER_PARAMETER:
            raise SceneError(f"{key}.step: {step!r} gives {n} values, more than "
                             f"{MAX_VALUES_PER_PARAMETER}")
        return tuple(float(lo + i * st) for i in range(n))
    if isinstance(spec, list):
        if not spec:
            raise SceneError(f"{key}: empty list")
        vals = tuple(_number(v, f"{key}[{i}]") for i, v in enumerate(spec))
        for i in range(1, len(vals)):
            if not vals[i] > vals[i - 1]:
                raise SceneError(f"{key}[{i}]: list must be strictly increasing, got "
                                 f"{vals[i]!r} after {vals[i - 1]!r}")
        return vals
    if isinstance(spec, (int, float, str)) and not isinstance(spec, bool):
        return (_number(spec, key),)
    raise SceneError(f"{key}: must be {{lower, upper, step}}, a list or a number, got {spec!r}")


_PHYSICAL = dict(l1="designs.l1", l2="designs.l2", r1="designs.r1", r2="designs.r2",
                 w="designs.w", r="parts.r", mu="parts.mu")


def _check_physical(values: dict) -> None:
    for k, key in _PHYSICAL.items():
        lo = values[k][0]
        if k in ("w", "mu"):
            if lo < 0:
                raise SceneError(f"{key}: must be >= 0, got {lo!r}")
        elif not lo > 0:
            raise SceneError(f"{key}: must be > 0, got {lo!r}")


def _commands(spec) -> tuple[Command, ...]:
    if not isinstance(spec, list) or not spec:
        raise SceneError(f"commands: must be a non-empty list of {{f_left, f_right}}, got {spec!r}")
    out = []
    for i, c in enumerate(spec):
        key = f"commands[{i}]"
        _mapping(c, key, COMMAND_KEYS, required=COMMAND_KEYS)
        fl, fr = (_number(c[k], f"{key}.{k}") for k in COMMAND_KEYS)
        for k, v in (("f_left", fl), ("f_right", fr)):
            if v < 0:
                raise SceneError(f"{key}.{k}: must be >= 0, got {v!r}")
        if fl == 0 and fr == 0:
            raise SceneError(f"{key}: f_left and f_right are both 0 (nothing closes)")
        cmd = Command(f_left=fl, f_right=fr)
        if cmd in out:
            raise SceneError(f"{key}: duplicate of commands[{out.index(cmd)}]")
        out.append(cmd)
    return tuple(out)


def _check_countable(values: dict, h: float) -> None:
    l1, l2, w, r = (max(values[k]) for k in ("l1", "l2", "w", "r"))
    if grid_points(l1, l2, w, r, h) == TOO_MANY_POINTS:
        raise SceneError(f"grid.h: {h!r} gives the largest design (l1={l1}, l2={l2}, w={w}, "
                         f"r={r}) too many grid points to count (over 1e9 per axis), far above "
                         f"the {MAX_MAP_BYTES / 1024**3:.0f} GiB limit; use a larger grid.h or "
                         f"smaller designs")


def _check_memory(values: dict, h: float, manipulation: bool) -> None:
    """One thread's largest cell (its maps, its shared finger field and, with the manipulation
    metric, its force buffers: batch.cell_bytes) within MAX_MAP_BYTES."""
    l1, l2, w, r = (max(values[k]) for k in ("l1", "l2", "w", "r"))
    ny, nx_max, n_shared = cell_extent(l1, l2, r, values["w"], h)
    need = cell_bytes(ny, nx_max, n_shared, len(values["w"]), manipulation)
    if need > MAX_MAP_BYTES:
        points = grid_points(l1, l2, w, r, h)
        raise SceneError(
            f"grid.h: {h!r} gives {points:,} grid points for the largest design (l1={l1}, "
            f"l2={l2}, w={w}, r={r}), about {need / 1024**3:.1f} GiB per thread (its maps, "
            f"shared finger field{' and manipulation buffers' if manipulation else ''}), above "
            f"the {MAX_MAP_BYTES / 1024**3:.0f} GiB limit; use a larger grid.h")


def _check_coarse(values: dict, h: float) -> None:
    """Every map of the sweep has at least MIN_POINTS_PER_AXIS grid points along x and y."""
    for l1 in values["l1"]:
        for l2 in values["l2"]:
            for w in values["w"]:
                for r in values["r"]:
                    ny, nx = grid_shape(l1, l2, w, r, h)
                    if min(ny, nx) < MIN_POINTS_PER_AXIS:
                        raise SceneError(
                            f"grid.h: {h!r} gives the map of l1={l1}, l2={l2}, w={w}, r={r} only "
                            f"{nx} x {ny} grid points (x by y), fewer than "
                            f"{MIN_POINTS_PER_AXIS} along an axis; use a smaller grid.h")


def refine_settings(spec, values: dict, h: float) -> RefineSettings | None:
    """`refine:` false (or absent): off; true: the defaults; a mapping: those keys (validated,
    the finest level's memory too)."""
    if spec is False or spec is None:
        return None
    if spec is True:
        spec = {}
    spec = _mapping(spec, "refine", REFINE_KEYS)
    default = RefineSettings()
    levels = spec.get("levels", default.levels)
    if isinstance(levels, bool) or not isinstance(levels, int) or \
            not 1 <= levels <= MAX_REFINE_LEVELS:
        raise SceneError(f"refine.levels: must be a whole number from 1 to {MAX_REFINE_LEVELS}, "
                         f"got {levels!r}")
    bound = _number(spec.get("bound", default.bound), "refine.bound")
    if not 0.0 <= bound <= 1.0:
        raise SceneError(f"refine.bound: must be in [0, 1] (a fraction of the part's best "
                         f"screened caging area), got {bound!r}")
    floor = spec.get("min_contenders", default.min_contenders)
    if isinstance(floor, bool) or not isinstance(floor, int) or floor < 2:
        raise SceneError(f"refine.min_contenders: must be a whole number >= 2 (the best and a "
                         f"runner-up), got {floor!r}")
    settings = RefineSettings(levels=levels, bound=bound, min_contenders=floor)
    finest = settings.level_h(h, levels)
    try:
        _check_memory(values, finest, manipulation=False)  # refinement recomputes summaries only
    except SceneError as exc:
        raise SceneError(f"refine.levels: the finest level h/2^{levels} = {finest:g}: "
                         f"{str(exc).removeprefix('grid.h: ')}") from None
    return settings


def _save_maps(spec, values: dict, n_commands: int) -> tuple[dict, ...]:
    if not isinstance(spec, list):
        raise SceneError(f"outputs.save_maps: must be a list of designs, got {spec!r}")
    out = []
    for i, entry in enumerate(spec):
        key = f"outputs.save_maps[{i}]"
        _mapping(entry, key, SAVE_MAP_KEYS, required=STORE_DIMS)
        point = {}
        for k in STORE_DIMS:
            v = _number(entry[k], f"{key}.{k}")
            try:
                point[k] = values[k][_index_of(values[k], v)]
            except KeyError:
                raise SceneError(f"{key}.{k}: {v!r} is not one of the sweep's {k} values "
                                 f"{_short(values[k])}") from None
        c = entry.get("command", 0)
        if isinstance(c, bool) or not isinstance(c, int) or not 0 <= c < n_commands:
            raise SceneError(f"{key}.command: must be an index 0..{n_commands - 1}, got {c!r}")
        point["command"] = c
        if point not in out:
            out.append(point)
    return tuple(out)


def _short(vals) -> str:
    s = ", ".join(f"{v:g}" for v in vals[:8])
    return f"({s}{', ...' if len(vals) > 8 else ''})"


def _jsonable(obj):
    return json.loads(json.dumps(obj, default=str))
