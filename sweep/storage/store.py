"""File formats of a sweep: blocks (parts and shards) and the results store, written and read.

Three kinds of HDF5 file, all written through `sweep.storage.h5.atomic_file` (a file with its final
name is always complete, see `sweep.files`):

- *block* files hold the summaries of a contiguous range of work items
  (`sweep.config.scene.ITEM_ORDER`) at every width: variable ``summaries(item, w, field)`` (float64,
  Fletcher-32 checksummed), with the frozen config, its hash and the package version as attributes.
  A run writes one *part* block per finished sub-chunk into a work directory; a cluster chunk ends
  as one *shard* block.
- the *store* holds every map's summary on the labelled dimensions
  ``l1, l2, r1, r2, w, r, mu`` (plus ``command`` when a sweep has several), one variable per
  summary field, and root attributes with the config, effects, grid, provenance and timings.
  It opens with ``xarray.open_dataset(path, engine="h5netcdf")``. It is written from the blocks
  one block, one geometry group and one range of a part's poses at a time, straight to its
  temporary file (`write_store`), so that writing it holds no more as the sweep grows
  (`write_bytes`).

Which files a run has, where they live and what state they are in (work directories, shards,
manifest, status, merge) is `sweep.runs.rundir`'s.
"""
from __future__ import annotations

import contextlib
import json
from collections.abc import Iterator, Sequence
from dataclasses import dataclass, field
from functools import partial
from pathlib import Path

import h5py
import numpy as np

from .. import __version__
from ..grid import SCENARIO_A_COMMANDS, SCENARIO_A_EXTREMES
from ..config.chunks import Range, exact_cover
from .h5 import (CorruptFile, StoreError,  # noqa: F401 (the errors of the store)
                 FILL_CACHE_BYTES, atomic_amend, atomic_file, create_variable, file_differences,
                 iter_names,
                 provenance, read_json_attr, set_root_attrs, write_coordinate, write_variable)
from ..compute.manipulation import (BATCH_ROWS, PARAMETER_NAMES, ManipulationChunk, PartSource,
                                    merge_parts, part_keys, pose_cuts, usage_of)
from ..config.scene import GROUP_AXES, ITEM_ORDER, REDUCTION_ROW_BYTES, STORE_DIMS, Scene
from ..model import DEFAULT_OUTPUTS
from ..schema import (
    A_DIMS, COUNT_FIELDS, PART_DIMS, REFINE_FIELDS, STORE_FIELDS, SUMMARY_FIELDS,
    summary_field_on,
)

KIND_PART = "sweep-part"
KIND_SHARD = "sweep-shard"
KIND_STORE = "sweep-store"

GRID_NOTE = ("each map uses its own design's whole-reach grid (MODEL 8): x = i h, y = r + j h; "
             "its edge is unreached, so trajectories never leave through a window edge")


# ---------------------------------------------------------------------------------------------
# Blocks (parts and shards)
# ---------------------------------------------------------------------------------------------
@dataclass
class ItemFile:
    path: Path
    kind: str
    start: int
    stop: int
    config_hash: str
    version: str
    frozen: dict
    compute_seconds: float
    chunk: int | None = None
    n_chunks: int | None = None
    data: np.ndarray | None = field(default=None, repr=False)
    has_manipulation: bool = False

    @property
    def range(self) -> Range:
        return (self.start, self.stop)


def write_item_file(path: Path, scene: Scene, start: int, stop: int, data: np.ndarray, kind: str,
                compute_seconds: float, chunk: int | None = None,
                n_chunks: int | None = None,
                manipulation: ManipulationChunk | None = None) -> None:
    """Summaries of items [start, stop), float64 (stop - start, n_w, n_fields), atomically; with
    the manipulation data of the same items in a `manipulation` group when the scene has it."""
    data = np.asarray(data, dtype=np.float64)
    expect = (stop - start, len(scene.values["w"]), len(SUMMARY_FIELDS))
    if data.shape != expect:
        raise ValueError(f"block {start}-{stop}: summaries of shape {data.shape}, "
                         f"expected {expect}")
    with atomic_file(path) as f:
        write_coordinate(f, "item", np.arange(start, stop, dtype=np.int64),
                         dict(long_name="work item index (ITEM_ORDER numbering)", units="1"))
        write_coordinate(f, "w", scene.widths, _attrs("w"))
        write_coordinate(f, "field", np.array(SUMMARY_FIELDS, dtype=object),
                         dict(long_name="summary field"))
        ds = f.create_dataset("summaries", data=data, fletcher32=True,
                              chunks=data.shape if data.size else None)
        for axis, dim in enumerate(("item", "w", "field")):
            ds.dims[axis].attach_scale(f[dim])
        ds.attrs["long_name"] = "per-map summaries, one row per work item and width"
        if manipulation is not None:
            if (manipulation.start, manipulation.stop) != (start, stop):
                raise ValueError(f"block {start}-{stop}: manipulation data of items "
                                 f"{manipulation.start}-{manipulation.stop}")
            manipulation.write(f.create_group("manipulation"))
        attrs = dict(sweep_file_kind=kind, item_start=start, item_stop=stop,
                     n_items_total=scene.n_items, item_order=list(ITEM_ORDER),
                     config_hash=scene.config_hash, sweep_version=__version__,
                     frozen_config=scene.frozen(), compute_seconds=float(compute_seconds),
                     name=scene.name)
        if chunk is not None:
            attrs.update(chunk=chunk, n_chunks=n_chunks)
        set_root_attrs(f, attrs)


def read_item_file(path: Path, with_data: bool = True) -> ItemFile:
    """Read and check a block file; raises CorruptFile if it is unreadable or inconsistent.
    The data is always read (the Fletcher-32 checksums are checked on read)."""
    path = Path(path)
    try:
        with h5py.File(path, "r") as f:
            a = f.attrs
            kind = _str(a["sweep_file_kind"])
            if kind not in (KIND_PART, KIND_SHARD):
                raise CorruptFile(f"{path.name}: not a sweep part or shard (kind {kind!r})")
            start, stop = int(a["item_start"]), int(a["item_stop"])
            data = f["summaries"][...]
            fields = iter_names(f["field"][...])
            frozen = read_json_attr(f, "frozen_config")
            block = ItemFile(path=path, kind=kind, start=start, stop=stop,
                          config_hash=_str(a["config_hash"]), version=_str(a["sweep_version"]),
                          frozen=frozen, compute_seconds=float(a["compute_seconds"]),
                          chunk=int(a["chunk"]) if "chunk" in a else None,
                          n_chunks=int(a["n_chunks"]) if "n_chunks" in a else None,
                          has_manipulation="manipulation" in f)
    except CorruptFile:
        raise
    except (OSError, KeyError, ValueError, TypeError, json.JSONDecodeError) as exc:
        raise CorruptFile(f"{path.name}: unreadable ({first_line(exc)})") from None
    if tuple(fields) != SUMMARY_FIELDS:
        raise CorruptFile(f"{path.name}: summary fields {fields} differ from {SUMMARY_FIELDS}")
    if data.ndim != 3 or data.shape[0] != stop - start or data.shape[2] != len(SUMMARY_FIELDS):
        raise CorruptFile(f"{path.name}: summaries of shape {data.shape} for items {start}-{stop}")
    if with_data:
        block.data = data
    return block


# ---------------------------------------------------------------------------------------------
# The store
# ---------------------------------------------------------------------------------------------
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
    """(group index, arrays of its items) of every geometry group in item order, from blocks
    that tile every item (in item order), reading one block at a time: `read(block)` gives
    arrays whose first axis is the block's items. A group split between blocks is gathered."""
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
    """The results store (see the module docstring) of blocks that tile every item, written
    atomically; with the manipulation metric's variables (from the blocks' files) when the scene
    has it.

    Memory stays flat as the sweep grows: every variable is created at its full size and filled
    one geometry group at a time, reading one block at a time; the manipulation reductions are
    merged one part at a time; the file is written as it grows (`atomic_file(stream=True)`).
    The content is bit for bit that of the assembled arrays written at once."""
    item_files = _in_item_order(item_files, 0, scene.n_items)
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
            _write_manipulation_coordinates(f, scene)
            for name in candidate_variables(scene):
                out[name] = create_variable(f, name, [scene.axis_len(d) for d in A_DIMS],
                                            np.float64, A_DIMS, _attrs(name))
        h2 = scene.h * scene.h
        for group, items in iter_groups(scene, item_files, partial(_block_items, scene)):
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


def _in_item_order(item_files: Sequence[ItemFile], start: int, stop: int) -> list[ItemFile]:
    """The blocks that tile items [start, stop) exactly, in item order; StoreError if none do."""
    pick = exact_cover(start, stop, [b.range for b in item_files])
    if pick is None:
        have = sorted(b.range for b in item_files)
        raise StoreError(f"blocks {have} do not cover items {start}-{stop}")
    return [item_files[i] for i in pick]


def _block_items(scene: Scene, b: ItemFile) -> list[np.ndarray]:
    """What the store needs of a block per item: its summaries and, with the manipulation
    metric, its Scenario A metrics (and Scenario C's, when the scene has it)."""
    out = [b.data if b.data is not None else read_item_file(b.path).data]
    if scene.manipulation:
        names = ("a_metric", "c_metric") if scene.scenario_c else ("a_metric",)
        with _manipulation_group(b.path) as g:
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
            kind = _str(f.attrs.get("sweep_file_kind", ""))
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
            kind = _str(f.attrs.get("sweep_file_kind", ""))
            if kind != KIND_STORE:
                raise StoreError(f"{path}: not a sweep results store (kind {kind or 'unknown'!r})")
            frozen = read_json_attr(f, "frozen_config")
            dims = STORE_DIMS + (("command",) if "command" in f else ())
            coords = {d: f[d][...] for d in dims}
            variables = {n: f[n][...] for n in SUMMARY_FIELDS if n in f}
            var_attrs = {n: {k: _plain(v) for k, v in f[n].attrs.items()
                             if k not in ("DIMENSION_LIST",)} for n in variables}
            attrs = {k: _plain(v) for k, v in f.attrs.items()}
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
                  refine_bound_widened=ref.bound_widened)
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
                        "contender exceeds the change between the last two levels of both; "
                        "where the bound check then fails, the designs that could win are "
                        "re-admitted and recomputed until it holds (refine_widenings, "
                        "refine_readmitted; refine_widen_maps of the refine_level_maps) "
                        "(docs/sweeps.md)",
            **attrs))


@contextlib.contextmanager
def _manipulation_group(path: Path):
    """The `manipulation` group of a block file, open for reading (CorruptFile if missing or
    unreadable)."""
    try:
        with h5py.File(path, "r") as f:
            yield f["manipulation"]
    except (OSError, KeyError, ValueError) as exc:
        raise CorruptFile(f"{Path(path).name}: no readable manipulation data "
                          f"({first_line(exc)})") from None


def read_manipulation(path: Path) -> ManipulationChunk:
    """The manipulation data of a block file (CorruptFile if missing or unreadable)."""
    with _manipulation_group(path) as g:
        return ManipulationChunk.read(g)


def assemble_manipulation(scene: Scene, item_files: Sequence[ItemFile], start: int = 0,
                          stop: int | None = None) -> ManipulationChunk | None:
    """The manipulation data of items [start, stop), merged from blocks that tile it; None when
    the scene has no manipulation output."""
    if not scene.manipulation:
        return None
    stop = scene.n_items if stop is None else stop
    # one block at a time (in item order): the merged data of the range and one block are held
    return ManipulationChunk.merge_stream(read_manipulation(b.path)
                                          for b in _in_item_order(item_files, start, stop))


SCENARIO_C_NOTE = ("Scenario C: Scenario A's gripper whose fingers each present either the "
                   "part's mu or manipulation_scenario_c_mu_low (friction modulation, MODEL 10); "
                   "per pose the hull over every width, command and friction pair (mu_left, "
                   "mu_right); candidates as Scenario A's")


def candidate_variables(scene: Scene) -> tuple[str, ...]:
    """The store's variables per candidate (l1, l2, r1, r2) and part: Scenario A's, and C's."""
    names = ("manipulation_a", "manipulation_a_area")
    return names + (("manipulation_c", "manipulation_c_area") if scene.scenario_c else ())


#: Kept points of a part's reductions read from all its blocks at once when they are merged: the
#: poses of a part are merged a range at a time (`part_arrays`), so that what a merge holds stays
#: flat as the sweep grows (one part of the paper sweep keeps up to 1,249 points at a pose and
#: 120,000 in all, a 4x sweep 4,594 and 244,000).
MERGE_ROWS = 1 << 16


def part_arrays(scene: Scene, item_files: Sequence[ItemFile]) -> dict[str, np.ndarray]:
    """The store's Scenario B variables (per part) from the reductions in the blocks' files
    (blocks that tile every item, in item order).

    One part and one range of its poses at a time (`MERGE_ROWS`): a pose's hull depends only on
    its own points, so each range is merged over the blocks holding the part in one pass (the
    states `ManipulationChunk.merge_stream` folds, bit for bit: a state is a function of its
    candidate set), and the per-pose values are joined in pose order before they are
    summed."""
    n_r, n_mu = len(scene.values["r"]), len(scene.values["mu"])
    n_cols = scene.lattice_columns()
    n_max, m = int(n_cols.max()), scene.lattice_rows()
    pose_value = np.zeros((n_r, n_mu, m + 1, 2 * n_max + 1))
    b = np.zeros((n_r, n_mu))
    b_uncrossed = np.zeros((n_r, n_mu))
    n_positive = np.zeros((n_r, n_mu), dtype=np.int32)
    usage = np.full((n_r, n_mu, len(PARAMETER_NAMES)), np.nan)
    search = np.array([max(scene.values[p]) - min(scene.values[p]) for p in PARAMETER_NAMES])
    holders: dict[tuple[int, int], list[ItemFile]] = {}
    for block in item_files:
        with _manipulation_group(block.path) as g:
            for key in part_keys(g):
                holders.setdefault(key, []).append(block)
    for (ri, mui), held_by in sorted(holders.items()):
        width = 2 * int(n_cols[ri]) + 1
        pose_ids, values, ranges, uncrossed = [], [], [], []
        for merged in _merged_by_poses(held_by, (ri, mui), (m + 1) * width):
            v, r = merged["all"].values_and_ranges()
            pose_ids.append(merged["all"].pose_ids)
            values.append(v)
            ranges.append(r)
            uncrossed.append(merged["uncrossed"].values())
        values = np.concatenate(values)
        pose_rows, cols = np.divmod(np.concatenate(pose_ids), width)
        pose_value[ri, mui, pose_rows, cols - int(n_cols[ri]) + n_max] = values
        b[ri, mui] = values.sum()
        b_uncrossed[ri, mui] = np.concatenate(uncrossed).sum()
        n_positive[ri, mui] = int((values > 0).sum())
        usage[ri, mui] = usage_of(np.concatenate(ranges), values > 0.0, search)
    h2 = scene.h * scene.h
    return dict(manipulation_b=b, manipulation_b_area=b * h2, manipulation_b_uncrossed=b_uncrossed,
                manipulation_b_poses=n_positive, parameter_usage=usage,
                manipulation_b_pose_value=pose_value)


#: Block files held open at once while a part's poses are merged: far below the usual limit of
#: 1,024 open files (a cluster merge may have thousands of shards, each holding every part).
OPEN_BLOCKS = 64


@contextlib.contextmanager
def _part_sources(blocks: Sequence[ItemFile], key: tuple[int, int]):
    """The reductions of part `key` in each of `blocks`, their files open meanwhile."""
    with contextlib.ExitStack() as files:
        yield [PartSource(files.enter_context(_manipulation_group(block.path)), key)
               for block in blocks]


def _merged_by_poses(held_by: Sequence[ItemFile], key: tuple[int, int], n_poses: int):
    """The reductions of part `key` (of a lattice of `n_poses` poses) merged over the blocks
    holding it, one range of poses after another, each range's points from every block adding
    up to at most MERGE_ROWS (or one pose). A range is merged in one pass over every block's
    points (a pose's state is a function of its candidate set, kernels/hull.py: the streamed
    fold's hulls bit for bit, without rebuilding each pose once per block). The blocks' files
    stay open while the part is merged (opening one and looking up its datasets costs more than
    reading a range), unless there are more than OPEN_BLOCKS: then a range opens them
    OPEN_BLOCKS at a time."""
    batches = [held_by[i:i + OPEN_BLOCKS] for i in range(0, len(held_by), OPEN_BLOCKS)]
    with contextlib.ExitStack() as kept:
        held = kept.enter_context(_part_sources(held_by, key)) if len(batches) == 1 else None

        def over_blocks(work) -> list:
            if held is not None:
                return [work(source) for source in held]
            out = []
            for batch in batches:
                with _part_sources(batch, key) as sources:
                    out += [work(source) for source in sources]
            return out

        rows = np.zeros(n_poses, dtype=np.int64)
        for per_pose in over_blocks(lambda source: source.rows_per_pose(n_poses)):
            rows += per_pose
        for poses in pose_cuts(rows, MERGE_ROWS):
            yield merge_parts(over_blocks(lambda source, poses=poses: source.read(poses)))


def write_bytes(scene: Scene, block_items: int) -> int:
    """What `write_store` holds besides the interpreter and its modules, from blocks of at most
    `block_items` items: one block's summaries and one geometry group's in the store's layout,
    the chunk cache of every variable, and with the manipulation metric one range of a part's
    poses being merged (MERGE_ROWS kept points, each held about 8 times over by
    `PartReduction.reduce`: the two folded, their concatenation, its sorted copy, the output), a
    dense batch (BATCH_ROWS), one part's per-pose results and every part's pose values. It does
    not grow with the sweep, only with the blocks and the parts' lattices."""
    n_summaries = len(scene.values["w"]) * len(SUMMARY_FIELDS)
    total = (block_items + 3 * scene.group_size) * n_summaries * 8
    total += (len(SUMMARY_FIELDS) + 2) * FILL_CACHE_BYTES
    if scene.manipulation:
        lattice = (scene.lattice_rows() + 1) * (2 * int(scene.lattice_columns().max()) + 1)
        total += 8 * MERGE_ROWS * REDUCTION_ROW_BYTES + 2 * BATCH_ROWS * REDUCTION_ROW_BYTES
        n_parts = len(scene.values["r"]) * len(scene.values["mu"])
        metrics = 2 if scene.scenario_c else 1   # A's metric per item, and C's
        total += lattice * 8 * (2 + len(PARAMETER_NAMES) + n_parts) + metrics * block_items * 8
    return total


def _write_manipulation_coordinates(f, scene: Scene) -> None:
    n_max = int(scene.lattice_columns().max())
    write_coordinate(f, "parameter", np.array(PARAMETER_NAMES, dtype=object), _attrs("parameter"))
    write_coordinate(f, "pose_row", np.arange(scene.lattice_rows() + 1, dtype=np.int32),
                     _attrs("pose_row"))
    write_coordinate(f, "pose_column", np.arange(-n_max, n_max + 1, dtype=np.int32),
                     _attrs("pose_column"))


def assemble(scene: Scene, item_files: Sequence[ItemFile], start: int = 0,
             stop: int | None = None) -> np.ndarray:
    """Summaries of items [start, stop) from blocks that tile it exactly."""
    stop = scene.n_items if stop is None else stop
    out = np.empty((stop - start, len(scene.values["w"]), len(SUMMARY_FIELDS)), dtype=np.float64)
    for b in _in_item_order(item_files, start, stop):
        out[b.start - start:b.stop - start] = b.data if b.data is not None else \
            read_item_file(b.path).data
    return out


# ---------------------------------------------------------------------------------------------
def _attrs(name: str) -> dict:
    """A store variable's attributes, from its one declaration (KeyError if it has none)."""
    return STORE_FIELDS[name].attrs()


def _str(v) -> str:
    return v.decode() if isinstance(v, bytes) else str(v)


def _plain(v):
    if isinstance(v, bytes):
        return v.decode()
    if isinstance(v, np.ndarray) and v.ndim == 0:
        return v.item()
    if isinstance(v, np.generic):
        return v.item()
    return v


def first_line(exc: BaseException) -> str:
    return (str(exc).strip().splitlines() or [type(exc).__name__])[0]


