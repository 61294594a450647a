"""The results store: written from item files, amended by the refinement, read.

The store holds every map's summary on the labelled dimensions ``l1, l2, r1, r2, w, r, mu``
(plus ``command`` when a sweep has several), one variable per summary field, and root attributes
with the config, effects, grid, provenance and timings; with the manipulation metric, its
variables too (`sweep.storage.manipulation`); after the refinement stage, the refinement's
(`add_refinement`). Every variable is declared in `sweep.schema` (`STORE_FIELDS`). It opens with
``xarray.open_dataset(path, engine="h5netcdf")``. It is written from item files (part files or
shards, `sweep.storage.itemfile`) one file, one geometry group and one range of a part's poses at
a time, straight to its temporary file (`write_store`, through `sweep.storage.h5.atomic_file`:
a file with its final name is always complete), so that writing it holds no more as the sweep
grows (`write_bytes`).

Which files a run has, where they live and what state they are in (work directories, shards,
manifest, status, merge) is `sweep.runs.rundir`'s.
"""
from __future__ import annotations

import json
from collections.abc import Iterator, Sequence
from dataclasses import dataclass, field
from functools import partial
from pathlib import Path

import h5py
import numpy as np

from ..grid import SCENARIO_A_COMMANDS, SCENARIO_A_EXTREMES
from .h5 import (CorruptFile, StoreError,  # noqa: F401 (the errors of the store)
                 FILL_CACHE_BYTES, atomic_amend, atomic_file, attr_text, create_variable,
                 file_differences, first_line, plain, provenance, read_json_attr, set_root_attrs,
                 write_coordinate, write_variable)
from ..compute.manipulation import BATCH_ROWS, PARAMETER_NAMES
from ..config.scene import GROUP_AXES, ITEM_ORDER, REDUCTION_ROW_BYTES, STORE_DIMS, Scene
from ..model import DEFAULT_OUTPUTS
from ..schema import (
    A_DIMS, COUNT_FIELDS, PART_DIMS, REFINE_FIELDS, STORE_FIELDS, SUMMARY_FIELDS,
    summary_field_on,
)
from .itemfile import (KIND_PART, KIND_SHARD, ItemFile, in_item_order, manipulation_group,
                       summaries_of)
from .manipulation import (MERGE_ROWS, SCENARIO_C_NOTE, candidate_variables, part_arrays,
                           write_coordinates as write_manipulation_coordinates)

KIND_STORE = "sweep-store"

GRID_NOTE = ("each map uses its own design's whole-reach grid (MODEL 8): x = i h, y = r + j h; "
             "its edge is unreached, so trajectories never leave through a window edge")


def store_arrays(scene: Scene, items: np.ndarray, one_group: bool = False) -> dict[str, np.ndarray]:
    """Summaries (n_items, n_w, n_fields) in item order -> one array per field on
    `scene.store_dims`; with `one_group`, those of one geometry group (its l1, l2 and r axes of
    length 1: the store's slab `group_slab`)."""
    target = scene.store_dims if "command" in scene.store_dims else scene.store_dims + ("command",)
    arr = _item_axes(scene, np.asarray(items, dtype=np.float64), ("w", "field"),
                     target + ("field",), one_group)
    if "command" not in scene.store_dims:
        arr = arr[..., 0, :]
    out = {}
    for k, name in enumerate(SUMMARY_FIELDS):
        v = np.ascontiguousarray(arr[..., k])
        if name in COUNT_FIELDS:
            as_int = np.rint(v)
            if not np.array_equal(as_int, v):
                raise ValueError(f"{name}: non-integral counts from the kernels")
            v = as_int.astype(np.int32)
        out[name] = v
    return out


def _item_axes(scene: Scene, values: np.ndarray, trailing: tuple[str, ...],
               target: tuple[str, ...], one_group: bool) -> np.ndarray:
    """Values of items in item order (first axis; then the axes `trailing`) on the axes `target`
    (every ITEM_ORDER axis and `trailing`); of every item, or of one geometry group."""
    lead = (1,) * GROUP_AXES if one_group else scene.item_shape[:GROUP_AXES]
    axes = ITEM_ORDER + trailing
    arr = values.reshape(lead + scene.item_shape[GROUP_AXES:] + values.shape[1:])
    return arr.transpose([axes.index(d) for d in target])


def group_slab(scene: Scene, group: int, dims: Sequence[str]) -> tuple[slice, ...]:
    """Where geometry group `group` (items group * group_size onwards) lies in a variable on
    `dims`: one index of l1, l2 and r, every value of the other dimensions."""
    at = dict(zip(ITEM_ORDER[:GROUP_AXES],
                  np.unravel_index(group, scene.item_shape[:GROUP_AXES])))
    return tuple(slice(int(at[d]), int(at[d]) + 1) if d in at else slice(None) for d in dims)


def iter_groups(scene: Scene, item_files: Sequence[ItemFile], read) -> Iterator[tuple[int, list]]:
    """(group index, arrays of its items) of every geometry group in item order, from item
    files that tile every item (in item order), reading one file at a time: `read(item_file)`
    gives arrays whose first axis is the file's items. A group split between files is
    gathered."""
    size = scene.group_size
    pending = None
    for b in item_files:
        arrays = read(b)
        i = b.start
        while i < b.stop:
            group, offset = divmod(i, size)
            n = min(size - offset, b.stop - i)
            pieces = [a[i - b.start:i - b.start + n] for a in arrays]
            i += n
            if n == size:
                yield group, pieces
                continue
            if offset == 0:
                pending = [np.empty((size,) + p.shape[1:], dtype=p.dtype) for p in pieces]
            for whole, piece in zip(pending, pieces):
                whole[offset:offset + n] = piece
            if offset + n == size:
                yield group, pending
                pending = None


def write_store(path: Path, scene: Scene, item_files: Sequence[ItemFile], timings: dict,
                created_by: str, extra_attrs: dict | None = None) -> None:
    """The results store (see the module docstring) of item files that tile every item, written
    atomically; with the manipulation metric's variables (from the item files) when the scene
    has it.

    Memory stays flat as the sweep grows: every variable is created at its full size and filled
    one geometry group at a time, reading one item file at a time; the manipulation reductions are
    merged one part at a time; the file is written as it grows (`atomic_file(stream=True)`).
    The content is bit for bit that of the assembled arrays written at once."""
    item_files = in_item_order(item_files, 0, scene.n_items)
    dims = scene.store_dims
    fields = [n for n in SUMMARY_FIELDS if summary_field_on(n, scene.effects.names_on())]
    with atomic_file(path, stream=True) as f:
        for d in dims:
            if d == "command":
                write_coordinate(f, d, np.arange(len(scene.commands), dtype=np.int32),
                                 _attrs(d))
            else:
                write_coordinate(f, d, np.array(scene.values[d], dtype=np.float64), _attrs(d))
        if "command" in dims:
            for k in ("f_left", "f_right"):
                write_variable(f, k, np.array([getattr(c, k) for c in scene.commands]),
                               STORE_FIELDS[k].dims, _attrs(k))
        # held open while they are filled: closing a variable writes out its chunk cache, and
        # every later group would read, inflate and deflate those chunks again
        out = {name: create_variable(f, name, scene.store_shape,
                                     np.int32 if name in COUNT_FIELDS else np.float64, dims,
                                     _attrs(name))
               for name in fields}
        if scene.manipulation:
            write_manipulation_coordinates(f, scene)
            for name in candidate_variables(scene):
                out[name] = create_variable(f, name, [scene.axis_len(d) for d in A_DIMS],
                                            np.float64, A_DIMS, _attrs(name))
        h2 = scene.h * scene.h
        for group, items in iter_groups(scene, item_files, partial(_item_rows, scene)):
            arrays = store_arrays(scene, items[0], one_group=True)
            at = group_slab(scene, group, dims)
            for name in fields:
                out[name][at] = arrays[name]
            if scene.manipulation:        # one command (scene validation)
                at = group_slab(scene, group, A_DIMS)
                for metric, name in zip(items[1:], ("manipulation_a", "manipulation_c")):
                    value = _item_axes(scene, metric, (), A_DIMS + ("command",), True)[..., 0]
                    out[name][at] = value
                    out[name + "_area"][at] = value * h2
        if scene.manipulation:
            for name, value in part_arrays(scene, item_files).items():
                write_variable(f, name, value, STORE_FIELDS[name].dims, _attrs(name))
        attrs = dict(
            title=f"energy-map sweep summaries: {scene.name}",
            sweep_file_kind=KIND_STORE, name=scene.name,
            config=scene.source, config_resolved=scene.resolved(), config_hash=scene.config_hash,
            frozen_config=scene.frozen(),
            effects_on=" ".join(scene.effects.names_on()) or "none",
            effects={k: bool(v) for k, v in scene.resolved()["effects"].items()},
            # absent: the default outputs energy, equilibrium, caging (older stores too)
            **({"outputs_on": " ".join(scene.outputs.names_on())}
               if tuple(scene.outputs.names_on()) != DEFAULT_OUTPUTS else {}),
            grid_h=scene.h, grid_bounds=scene.bounds, grid_note=GRID_NOTE,
            theta2_min_deg=scene.limits.theta2_min_deg, theta2_max_deg=scene.limits.theta2_max_deg,
            reconfig_step=scene.accuracy.reconfig_step, root_tol=scene.accuracy.root_tol,
            trajectory=scene.accuracy.trajectory,
            n_maps=scene.n_maps, created_by=created_by,
            **{k: float(v) for k, v in timings.items()},
            **provenance(),
        )
        if len(scene.commands) == 1:
            attrs.update(f_left=scene.commands[0].f_left, f_right=scene.commands[0].f_right)
        if scene.manipulation:
            attrs.update(manipulation_scenario_a_commands_f_left=list(SCENARIO_A_COMMANDS),
                         manipulation_scenario_a_computed_f_left=list(SCENARIO_A_EXTREMES),
                         manipulation_scenario_b_command=[1.0, 1.0],
                         manipulation_scenario_a_top_k=scene.scenario_a_top_k,
                         manipulation_note="forces per unit tendon tension times the pose's "
                         "geometric cage score S_geo; values are unitless")
        if scene.scenario_c:
            attrs.update(manipulation_scenario_c_mu_low=scene.scenario_c_mu_low,
                         manipulation_scenario_c_note=SCENARIO_C_NOTE)
        attrs.update(extra_attrs or {})
        set_root_attrs(f, attrs)


def _attrs(name: str) -> dict:
    """A store variable's attributes, from its one declaration (KeyError if it has none)."""
    return STORE_FIELDS[name].attrs()


def _item_rows(scene: Scene, b: ItemFile) -> list[np.ndarray]:
    """What the store needs of an item file per item: its summaries and, with the manipulation
    metric, its Scenario A metrics (and Scenario C's, when the scene has it)."""
    out = [summaries_of(b)]
    if scene.manipulation:
        names = ("a_metric", "c_metric") if scene.scenario_c else ("a_metric",)
        with manipulation_group(b.path) as g:
            for name in names:
                if name not in g:
                    raise CorruptFile(f"{b.path.name}: no {name} (written without Scenario C?)")
                metric = g[name][...]
                if metric.shape != (b.stop - b.start,):
                    raise CorruptFile(f"{b.path.name}: {metric.shape[0]} {name} values for "
                                      f"items {b.start}-{b.stop}")
                out.append(metric)
    return out


def file_kind(path: Path) -> str | None:
    """Which sweep file `path` is, from its contents: "store", "shard" or "part" (its
    `sweep_file_kind`), "map" (a map file, `sweep.storage.mapfile`: an energy field and its
    design), "hdf5" (any other HDF5 file, or one too damaged to tell); None when it is not an
    HDF5 file. OSError when it cannot be read at all."""
    if not h5py.is_hdf5(path):
        return None
    kinds = {KIND_STORE: "store", KIND_SHARD: "shard", KIND_PART: "part"}
    try:
        with h5py.File(path, "r") as f:
            kind = attr_text(f.attrs.get("sweep_file_kind", ""))
            if kind in kinds:
                return kinds[kind]
            if "energy" in f and "design" in f.attrs:
                return "map"
    except (OSError, KeyError, ValueError):
        pass
    return "hdf5"


@dataclass
class StoreView:
    path: Path
    dims: tuple[str, ...]
    coords: dict[str, np.ndarray]
    variables: dict[str, np.ndarray]
    var_attrs: dict[str, dict]
    attrs: dict
    frozen: dict           # the frozen config (`Scene.frozen()`); `scene_from_frozen` rebuilds it
    refine: dict = field(default_factory=dict)   # refinement variables (`add_refinement`), if any


def read_store(path: Path) -> StoreView:
    """Read a results store with h5py (no xarray needed); raises StoreError if it is not one."""
    path = Path(path)
    if not path.is_file():
        raise StoreError(f"{path}: {'is a directory' if path.is_dir() else 'no such file'}")
    try:
        if not h5py.is_hdf5(path):
            raise StoreError(f"{path}: not a sweep results store (not an HDF5 file)")
        with h5py.File(path, "r") as f:
            kind = attr_text(f.attrs.get("sweep_file_kind", ""))
            if kind != KIND_STORE:
                raise StoreError(f"{path}: not a sweep results store (kind {kind or 'unknown'!r})")
            frozen = read_json_attr(f, "frozen_config")
            dims = STORE_DIMS + (("command",) if "command" in f else ())
            coords = {d: f[d][...] for d in dims}
            variables = {n: f[n][...] for n in SUMMARY_FIELDS if n in f}
            var_attrs = {n: {k: plain(v) for k, v in f[n].attrs.items()
                             if k not in ("DIMENSION_LIST",)} for n in variables}
            attrs = {k: plain(v) for k, v in f.attrs.items()}
            refine = {fld.name: f[fld.name][...] for fld in REFINE_FIELDS if fld.name in f}
    except StoreError:
        raise
    except (OSError, KeyError, ValueError, json.JSONDecodeError) as exc:
        raise StoreError(f"{path}: cannot read results store ({first_line(exc)})") from None
    return StoreView(path, dims, coords, variables, var_attrs, attrs, frozen, refine)


#: Root attributes that say how and when a store was made, not what it holds: they may differ
#: between stores of the same results (`store_differences`).
RUN_ATTRS = ("created_by", "created_utc", "wall_seconds", "compute_seconds", "maps_per_second",
             "threads", "saved_maps_dir", "refine_created_utc", "refine_level_seconds")


def store_differences(path_a: Path, path_b: Path) -> list[str]:
    """What differs between two stores' contents (h5.file_differences), their RUN_ATTRS aside."""
    return file_differences(path_a, path_b, RUN_ATTRS)


def part_dims(scene: Scene) -> tuple[str, ...]:
    """Dimensions of a per-part variable of the store: (r, mu) plus command when present."""
    return ("r", "mu") + (("command",) if "command" in scene.store_dims else ())


def add_refinement(path: Path, scene: Scene, ref, attrs: dict) -> None:
    """Add the refinement variables (`sweep.schema.REFINE_FIELDS`) of `ref` (a
    `sweep.runs.refine.Refinement`) and its root attributes to the store `path`, rewritten
    atomically; an earlier refinement's variables are replaced. The screened variables are not
    touched."""
    shape = scene.store_shape
    pshape = tuple(scene.axis_len(d) for d in part_dims(scene))
    arrays = dict(refined_caging_area=ref.value, refined_level=ref.level,
                  refined_error=ref.error, refine_role=ref.role, refine_status=ref.status,
                  refine_finest_h=ref.finest_h(), refine_margin=ref.margin,
                  refine_bound_held=ref.bound_held, refine_bound_used=ref.bound_used,
                  refine_n_contenders=ref.n_contenders, refine_readmitted=ref.readmitted,
                  refine_widenings=ref.widenings, refine_n_readmitted=ref.n_readmitted,
                  refine_bound_widened=ref.bound_widened, refine_audit_designs=ref.audit_designs,
                  refine_audit_rise=ref.audit_rise,
                  refine_audit_h=np.where(ref.audit_level > 0,
                                          scene.h / 2.0 ** ref.audit_level.astype(float),
                                          np.nan))
    with atomic_amend(path) as f:
        for fld in REFINE_FIELDS:
            if fld.name in f:
                del f[fld.name]
            per_part = fld.dims == PART_DIMS
            data = np.asarray(arrays[fld.name], dtype=fld.dtype).reshape(
                pshape if per_part else shape)
            write_variable(f, fld.name, data, part_dims(scene) if per_part else scene.store_dims,
                           fld.attrs())
        s = ref.settings
        set_root_attrs(f, dict(
            refine_levels=s.levels, refine_bound=s.bound, refine_min_contenders=s.min_contenders,
            refine_level_h=[s.level_h(scene.h, k) for k in range(1, s.levels + 1)],
            refine_level_maps=list(ref.level_maps),
            refine_level_seconds=[float(x) for x in ref.level_seconds],
            refine_widen_maps=int(ref.widen_maps),
            refine_counts=ref.counts(), refine_created_utc=provenance()["created_utc"],
            refine_note="contenders: the refine_min_contenders best designs and those whose "
                        "screened caging area is at least (1 - refine_bound_used) times the "
                        "part's best (equal-R designs, same l1, l2, w and r2/r1, count once); "
                        "recomputed at refine_level_h until the best's lead over every other "
                        "contender exceeds the error estimates of both; a stratified sample of "
                        "the other designs is recomputed too (the audit, refine_audit_*), and "
                        "where a design left out could then win it is re-admitted and "
                        "recomputed until none can (refine_widenings, refine_readmitted; "
                        "refine_widen_maps of the refine_level_maps) (docs/sweeps.md, "
                        "model-notes D37)",
            **attrs))


def write_bytes(scene: Scene, file_items: int) -> int:
    """What `write_store` holds besides the interpreter and its modules, from item files of at
    most `file_items` items: one file's summaries and one geometry group's in the store's layout,
    the chunk cache of every variable, and with the manipulation metric one range of a part's
    poses being merged (MERGE_ROWS kept points, each held about 8 times over by
    `PartReduction.reduce`: the two folded, their concatenation, its sorted copy, the output), a
    dense batch (BATCH_ROWS), one part's per-pose results and every part's pose values. It does
    not grow with the sweep, only with the item files and the parts' lattices."""
    n_summaries = len(scene.values["w"]) * len(SUMMARY_FIELDS)
    total = (file_items + 3 * scene.group_size) * n_summaries * 8
    total += (len(SUMMARY_FIELDS) + 2) * FILL_CACHE_BYTES
    if scene.manipulation:
        lattice = (scene.lattice_rows() + 1) * (2 * int(scene.lattice_columns().max()) + 1)
        total += 8 * MERGE_ROWS * REDUCTION_ROW_BYTES + 2 * BATCH_ROWS * REDUCTION_ROW_BYTES
        n_parts = len(scene.values["r"]) * len(scene.values["mu"])
        metrics = 2 if scene.scenario_c else 1   # A's metric per item, and C's
        total += lattice * 8 * (2 + len(PARAMETER_NAMES) + n_parts) + metrics * file_items * 8
    return total
