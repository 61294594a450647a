"""The results store, its shards and parts: writing, reading, checking and merging.

Three kinds of HDF5 file, all written through `sweep.h5.atomic_file` (a file with its final name
is always complete):

- *block* files hold the summaries of a contiguous range of work items (`sweep.scene.ITEM_ORDER`)
  at every width: variable ``summaries(item, w, field)`` (float64, Fletcher-32 checksummed), with
  the frozen config, its hash and the package version as attributes. A run writes one *part*
  block per finished sub-chunk into a work directory; a cluster chunk ends as one *shard* block.
- the *store* holds every map's summary on the labelled dimensions
  ``l1, l2, r1, r2, w, r, mu`` (plus ``command`` when a sweep has several), one variable per
  summary field, and root attributes with the config, effects, grid, provenance and timings.
  It opens with ``xarray.open_dataset(path, engine="h5netcdf")``.

`RunDir` owns every path name of a chunked run; `scan_shards` says which shards are done,
missing, corrupt or mismatched; `merge_shards` refuses anything but a complete, consistent set.
"""
from __future__ import annotations

import json
import os
import re
import socket
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

import h5py
import numpy as np

from . import __version__
from .chunks import Range, chunk_ranges, exact_cover
from .h5 import (atomic_file, iter_names, provenance, read_json_attr, set_root_attrs,
                 write_coordinate, write_variable)
from .scene import ITEM_ORDER, STORE_DIMS, Scene, scene_from_dict
from .schema import COUNT_FIELDS, SUMMARY, SUMMARY_FIELDS

KIND_PART = "sweep-part"
KIND_SHARD = "sweep-shard"
KIND_STORE = "sweep-store"

FIELD_ATTRS = {f.name: f.attrs() for f in SUMMARY}  # declared once, in sweep.schema

COORD_ATTRS = {
    "l1": dict(long_name="proximal link length l1", units="length (model units)"),
    "l2": dict(long_name="distal link length l2", units="length (model units)"),
    "r1": dict(long_name="proximal pulley radius r1", units="length (model units)"),
    "r2": dict(long_name="distal pulley radius r2", units="length (model units)"),
    "w": dict(long_name="palm width w", units="length (model units)"),
    "r": dict(long_name="part (disc) radius r", units="length (model units)"),
    "mu": dict(long_name="static friction coefficient mu_s between part and links", units="1"),
    "command": dict(long_name="index of the actuation command (see f_left, f_right)", units="1"),
}

GRID_NOTE = ("each map uses its own design's whole-reach grid (MODEL 8): x = i h, y = r + j h; "
             "its edge is unreached, so trajectories never leave through a window edge")


class StoreError(Exception):
    """A file or directory that is not what an operation needs (CLI exit code 2)."""


class CorruptFile(StoreError):
    """A file with a final name that cannot be read as a complete block/store."""


# ---------------------------------------------------------------------------------------------
# Blocks (parts and shards)
# ---------------------------------------------------------------------------------------------
@dataclass
class Block:
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

    @property
    def range(self) -> Range:
        return (self.start, self.stop)


def write_block(path: Path, scene: Scene, start: int, stop: int, data: np.ndarray, kind: str,
                compute_seconds: float, chunk: int | None = None,
                n_chunks: int | None = None) -> None:
    """Summaries of items [start, stop), float64 (stop - start, n_w, n_fields), atomically."""
    data = np.asarray(data, dtype=np.float64)
    expect = (stop - start, len(scene.values["w"]), len(SUMMARY_FIELDS))
    if data.shape != expect:
        raise ValueError(f"block {start}-{stop}: summaries of shape {data.shape}, "
                         f"expected {expect}")
    with atomic_file(path) as f:
        write_coordinate(f, "item", np.arange(start, stop, dtype=np.int64),
                         dict(long_name="work item index (ITEM_ORDER numbering)", units="1"))
        write_coordinate(f, "w", scene.widths, COORD_ATTRS["w"])
        write_coordinate(f, "field", np.array(SUMMARY_FIELDS, dtype=object),
                         dict(long_name="summary field"))
        ds = f.create_dataset("summaries", data=data, fletcher32=True,
                              chunks=data.shape if data.size else None)
        for axis, dim in enumerate(("item", "w", "field")):
            ds.dims[axis].attach_scale(f[dim])
        ds.attrs["long_name"] = "per-map summaries, one row per work item and width"
        attrs = dict(sweep_file_kind=kind, item_start=start, item_stop=stop,
                     n_items_total=scene.n_items, item_order=list(ITEM_ORDER),
                     config_hash=scene.config_hash, sweep_version=__version__,
                     frozen_config=scene.frozen(), compute_seconds=float(compute_seconds),
                     name=scene.name)
        if chunk is not None:
            attrs.update(chunk=chunk, n_chunks=n_chunks)
        set_root_attrs(f, attrs)


def read_block(path: Path, with_data: bool = True) -> Block:
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
            block = Block(path=path, kind=kind, start=start, stop=stop,
                          config_hash=_str(a["config_hash"]), version=_str(a["sweep_version"]),
                          frozen=frozen, compute_seconds=float(a["compute_seconds"]),
                          chunk=int(a["chunk"]) if "chunk" in a else None,
                          n_chunks=int(a["n_chunks"]) if "n_chunks" in a else None)
    except CorruptFile:
        raise
    except (OSError, KeyError, ValueError, TypeError, json.JSONDecodeError) as exc:
        raise CorruptFile(f"{path.name}: unreadable ({_first_line(exc)})") from None
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
def store_arrays(scene: Scene, full: np.ndarray) -> dict[str, np.ndarray]:
    """(n_items, n_w, n_fields) in item order -> one array per field on `scene.store_dims`."""
    shape = scene.item_shape + (len(scene.values["w"]), len(SUMMARY_FIELDS))
    axes = ITEM_ORDER + ("w", "field")
    arr = np.asarray(full, dtype=np.float64).reshape(shape)
    target = scene.store_dims if "command" in scene.store_dims else scene.store_dims + ("command",)
    arr = arr.transpose([axes.index(d) for d in target] + [axes.index("field")])
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


def write_store(path: Path, scene: Scene, full: np.ndarray, timings: dict, created_by: str,
                extra_attrs: dict | None = None) -> None:
    """The results store (see the module docstring), written atomically."""
    arrays = store_arrays(scene, full)
    dims = scene.store_dims
    with atomic_file(path) as f:
        for d in dims:
            if d == "command":
                write_coordinate(f, d, np.arange(len(scene.commands), dtype=np.int32),
                                 COORD_ATTRS[d])
            else:
                write_coordinate(f, d, np.array(scene.values[d], dtype=np.float64), COORD_ATTRS[d])
        if "command" in dims:
            for k in ("f_left", "f_right"):
                write_variable(f, k, np.array([getattr(c, k) for c in scene.commands]),
                               ("command",), dict(long_name=f"tendon tension of the "
                                                  f"{k[2:]} finger", units="force (model units)"))
        for name in SUMMARY_FIELDS:
            write_variable(f, name, arrays[name], dims, FIELD_ATTRS[name])
        attrs = dict(
            title=f"energy-map sweep summaries: {scene.name}",
            sweep_file_kind=KIND_STORE, name=scene.name,
            config=scene.source, config_resolved=scene.resolved(), config_hash=scene.config_hash,
            frozen_config=scene.frozen(),
            effects_on=" ".join(scene.effects.names_on()) or "none",
            effects={k: bool(v) for k, v in scene.resolved()["effects"].items()},
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
        attrs.update(extra_attrs or {})
        set_root_attrs(f, attrs)


@dataclass
class StoreView:
    path: Path
    dims: tuple[str, ...]
    coords: dict[str, np.ndarray]
    variables: dict[str, np.ndarray]
    var_attrs: dict[str, dict]
    attrs: dict
    frozen: dict           # the frozen config (`Scene.frozen()`); `scene_from_frozen` rebuilds it


def read_store(path: Path) -> StoreView:
    """Read a results store with h5py (no xarray needed); raises StoreError if it is not one."""
    path = Path(path)
    try:
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
    except StoreError:
        raise
    except (OSError, KeyError, ValueError, json.JSONDecodeError) as exc:
        raise StoreError(f"{path}: cannot read results store ({_first_line(exc)})") from None
    return StoreView(path, dims, coords, variables, var_attrs, attrs, frozen)


def scene_from_frozen(frozen: dict) -> Scene:
    """Rebuild the Scene recorded in a file (from the config as written)."""
    scene = scene_from_dict(frozen["source"], default_name=frozen.get("name", "sweep"))
    if scene.config_hash != frozen["config_hash"]:
        raise StoreError("recorded config does not reproduce its hash "
                         f"({scene.config_hash[:12]} != {frozen['config_hash'][:12]}); "
                         "written by another sweep version?")
    return scene


def assemble(scene: Scene, blocks: Sequence[Block], start: int = 0,
             stop: int | None = None) -> np.ndarray:
    """Summaries of items [start, stop) from blocks that tile it exactly."""
    stop = scene.n_items if stop is None else stop
    pick = exact_cover(start, stop, [b.range for b in blocks])
    if pick is None:
        have = sorted(b.range for b in blocks)
        raise StoreError(f"blocks {have} do not cover items {start}-{stop}")
    out = np.empty((stop - start, len(scene.values["w"]), len(SUMMARY_FIELDS)), dtype=np.float64)
    for i in pick:
        b = blocks[i]
        data = b.data if b.data is not None else read_block(b.path).data
        out[b.start - start:b.stop - start] = data
    return out


# ---------------------------------------------------------------------------------------------
# Chunked runs: naming, status, merge
# ---------------------------------------------------------------------------------------------
MANIFEST = "sweep-manifest.json"
_SHARD_RE = re.compile(r"^shard-(\d+)-of-(\d+)\.h5$")


@dataclass(frozen=True)
class RunDir:
    """Every path of a chunked run directory (habit 9: one object owns the naming)."""

    root: Path

    @property
    def manifest(self) -> Path:
        return self.root / MANIFEST

    @property
    def logs(self) -> Path:
        return self.root / "logs"

    @property
    def maps(self) -> Path:
        return self.root / "maps"

    @staticmethod
    def _stem(chunk: int, n_chunks: int) -> str:
        width = max(4, len(str(n_chunks)))
        return f"shard-{chunk:0{width}d}-of-{n_chunks:0{width}d}"

    def shard(self, chunk: int, n_chunks: int) -> Path:
        return self.root / f"{self._stem(chunk, n_chunks)}.h5"

    def parts(self, chunk: int, n_chunks: int) -> Path:
        return self.root / "parts" / self._stem(chunk, n_chunks)


def manifest_dict(scene: Scene, n_chunks: int) -> dict:
    ranges = chunk_ranges(scene.n_items, n_chunks, scene.group_size, scene.group_costs())
    return dict(sweep_file_kind="sweep-manifest", n_chunks=n_chunks, n_items=scene.n_items,
                n_maps=scene.n_maps, chunk_ranges=[list(r) for r in ranges],
                group_size=scene.group_size, **scene.frozen())


def write_json_atomic(path: Path, obj: dict) -> None:
    """JSON written under a temporary name unique across hosts, then renamed into place."""
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(f".{path.name}.tmp{socket.gethostname()}.{os.getpid()}")
    try:
        with open(tmp, "w") as fh:
            json.dump(obj, fh, indent=1, sort_keys=True)
            fh.flush()
            os.fsync(fh.fileno())
        os.replace(tmp, path)
    finally:
        if tmp.exists():
            tmp.unlink()


def read_json(path: Path) -> dict:
    try:
        with open(path) as fh:
            return json.load(fh)
    except (OSError, json.JSONDecodeError) as exc:
        raise StoreError(f"{path}: unreadable ({_first_line(exc)})") from None


def ensure_manifest(rundir: RunDir, scene: Scene, n_chunks: int) -> dict:
    """Write the run directory's manifest, or check that the existing one is this sweep's."""
    want = manifest_dict(scene, n_chunks)
    if rundir.manifest.exists():
        have = read_json(rundir.manifest)
        for key, what in (("config_hash", "config"), ("sweep_version", "sweep version"),
                          ("n_chunks", "number of chunks")):
            if have.get(key) != want[key]:
                raise StoreError(
                    f"{rundir.root} holds a sweep with a different {what} "
                    f"({_short(have.get(key))} there, {_short(want[key])} here); "
                    f"use another --out directory")
        return have
    write_json_atomic(rundir.manifest, want)
    return want


@dataclass
class ShardState:
    chunk: int
    state: str                 # done | missing | corrupt | mismatched | duplicate
    path: Path | None
    detail: str = ""
    range: Range | None = None
    parts_done: int = 0        # finished sub-chunk files of a shard still in progress


@dataclass
class DirStatus:
    root: Path
    n_chunks: int
    manifest: dict | None
    shards: list[ShardState]
    stray: list[ShardState]

    @property
    def complete(self) -> bool:
        return all(s.state == "done" for s in self.shards) and not self.stray

    def counts(self) -> dict[str, int]:
        out: dict[str, int] = {}
        for s in self.shards + self.stray:
            out[s.state] = out.get(s.state, 0) + 1
        return out


def scan_shards(root: Path) -> DirStatus:
    """Classify every shard of a chunked run directory."""
    root = Path(root)
    rundir = RunDir(root)
    if not root.is_dir():
        raise StoreError(f"{root}: no such directory")
    manifest = read_json(rundir.manifest) if rundir.manifest.exists() else None
    files = sorted(p for p in root.iterdir() if _SHARD_RE.match(p.name))
    if manifest is None and not files:
        raise StoreError(f"{root}: neither {MANIFEST} nor shard-*.h5 files: not a chunked run "
                         "directory")
    if manifest is not None:
        n_chunks = int(manifest["n_chunks"])
        ref_hash, ref_version = manifest["config_hash"], manifest["sweep_version"]
        ranges = [tuple(r) for r in manifest["chunk_ranges"]]
    else:
        ns = sorted({int(_SHARD_RE.match(p.name).group(2)) for p in files})
        n_chunks = max(ns, key=lambda n: sum(
            int(_SHARD_RE.match(p.name).group(2)) == n for p in files))
        ref_hash = ref_version = None
        ranges = None

    by_chunk: dict[int, list[ShardState]] = {}
    stray: list[ShardState] = []
    readable: list[Block] = []
    for p in files:
        m = _SHARD_RE.match(p.name)
        name_chunk, name_n = int(m.group(1)), int(m.group(2))
        try:
            b = read_block(p, with_data=False)
        except CorruptFile as exc:
            st = ShardState(name_chunk, "corrupt", p, str(exc))
            (by_chunk.setdefault(name_chunk, []) if name_n == n_chunks else stray).append(st)
            continue
        chunk = b.chunk if b.chunk is not None else name_chunk
        st = ShardState(chunk, "done", p, range=b.range)
        problems = []
        if b.kind != KIND_SHARD:
            problems.append(f"a {b.kind} file, not a shard")
        if b.n_chunks != n_chunks or name_n != n_chunks:
            problems.append(f"one of {b.n_chunks} chunks, this run has {n_chunks}")
        if (b.chunk, b.n_chunks) != (name_chunk, name_n):
            problems.append(f"holds chunk {b.chunk} of {b.n_chunks}")
        if ref_hash is not None and b.config_hash != ref_hash:
            problems.append(f"config {b.config_hash[:12]}, run has {ref_hash[:12]}")
        if ref_version is not None and b.version != ref_version:
            problems.append(f"sweep version {b.version}, run has {ref_version}")
        if ranges is not None and 0 <= chunk < n_chunks and b.range != ranges[chunk]:
            problems.append(f"items {b.start}-{b.stop}, chunk {chunk} should hold "
                            f"{ranges[chunk][0]}-{ranges[chunk][1]}")
        if problems:
            st.state, st.detail = "mismatched", "; ".join(problems)
        if b.n_chunks == n_chunks and 0 <= chunk < n_chunks:
            by_chunk.setdefault(chunk, []).append(st)
            if not problems:
                readable.append(b)
        else:
            st.state = "mismatched"
            stray.append(st)

    # Without a manifest, the shards must at least agree among themselves.
    if manifest is None and readable:
        ref = readable[0]
        for b in readable[1:]:
            if (b.config_hash, b.version) != (ref.config_hash, ref.version):
                for st in by_chunk[b.chunk]:
                    if st.path == b.path and st.state == "done":
                        st.state = "mismatched"
                        st.detail = (f"config {b.config_hash[:12]} / version {b.version} differs "
                                     f"from {ref.path.name} ({ref.config_hash[:12]} / "
                                     f"{ref.version})")

    shards = []
    for k in range(n_chunks):
        found = by_chunk.get(k, [])
        parts_dir = rundir.parts(k, n_chunks)
        if not found:
            n_parts = len(list(parts_dir.glob("items-*.h5"))) if parts_dir.is_dir() else 0
            detail = f"in progress: {n_parts} sub-chunks done" if n_parts else ""
            shards.append(ShardState(k, "missing", rundir.shard(k, n_chunks), detail,
                                     range=ranges[k] if ranges else None, parts_done=n_parts))
        elif len(found) == 1:
            shards.append(found[0])
        else:
            names = ", ".join(s.path.name for s in found)
            shards.append(ShardState(k, "duplicate", found[0].path,
                                     f"{len(found)} files claim chunk {k}: {names}"))
    return DirStatus(root, n_chunks, manifest, shards, stray)


def merge_shards(root: Path, out: Path) -> tuple[Scene, DirStatus]:
    """One store from a complete, consistent set of shards; StoreError otherwise."""
    status = scan_shards(root)
    if not status.complete:
        bad = [s for s in status.shards + status.stray if s.state != "done"]
        desc = "; ".join(f"shard {s.chunk} {s.state}"
                         + (f" ({s.path.name}: {s.detail})" if s.detail and s.path else
                            f" ({s.path.name})" if s.path else "") for s in bad)
        raise StoreError(f"cannot merge {root}: {len(bad)} of {status.n_chunks} shards not usable: "
                         f"{desc}")
    blocks = [read_block(s.path) for s in status.shards]
    scene = scene_from_frozen(blocks[0].frozen)
    for b in blocks:
        if (b.config_hash, b.version) != (scene.config_hash, blocks[0].version):
            raise StoreError(f"cannot merge {root}: {b.path.name} has config {b.config_hash[:12]}"
                             f" / version {b.version}, {blocks[0].path.name} has "
                             f"{scene.config_hash[:12]} / {blocks[0].version}")
    if blocks[0].version != __version__:
        raise StoreError(f"cannot merge {root}: shards written by sweep {blocks[0].version}, "
                         f"this is sweep {__version__}")
    full = assemble(scene, blocks)
    compute = sum(b.compute_seconds for b in blocks)
    maps_dir = RunDir(root).maps
    saved = sorted(p.name for p in maps_dir.glob("*.h5")) if maps_dir.is_dir() else []
    write_store(out, scene, full, timings=dict(
        compute_seconds=compute, maps_per_second=scene.n_maps / compute if compute > 0 else 0.0),
        created_by=f"sweep merge of {status.n_chunks} shards",
        extra_attrs=dict(saved_maps=saved, saved_maps_dir=str(maps_dir)) if saved else None)
    return scene, status


# ---------------------------------------------------------------------------------------------
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


def _short(v) -> str:
    return v[:12] if isinstance(v, str) and len(v) == 64 else str(v)


def _first_line(exc: BaseException) -> str:
    return (str(exc).strip().splitlines() or [type(exc).__name__])[0]


