"""The life of a run on disk: every path name, work directories and their part files, the
chunked run directory's manifest, shards, status and merge.

File formats (what an item file or a store holds) are `sweep.storage`'s; how a file is locked,
written atomically and cleaned up is `sweep.files`'. This module decides which files a run has and
what state they are in:

- one machine (`SingleRun`): ``RESULTS``, its work directory ``RESULTS.parts/`` (one part file
  ``items-SSSSSSSS-EEEEEEEE.h5`` per finished sub-chunk, `part_path`) and ``RESULTS.maps/``;
- the refinement of any store (`refine_dir`): ``RESULTS.refine/`` (one file per finished batch
  of maps, `sweep.runs.refine`);
- a cluster run (`RunDir`): ``DIR/sweep-manifest.json``, ``DIR/shard-IIII-of-NNNN.h5``,
  ``DIR/parts/shard-IIII-of-NNNN/``, ``DIR/maps/``, ``DIR/logs/``.

`prepare_parts_dir` creates or checks a work directory and lists its finished parts;
`scan_shards` says which shards are done, missing, corrupt or mismatched; `merge_shards` refuses
anything but a complete, consistent set.
"""
from __future__ import annotations

import json
import re
import sys
from dataclasses import dataclass
from pathlib import Path

from .. import __version__
from ..config.chunks import Range, chunk_ranges
from ..grid import check_memory_need
from ..files import (
    OutputLock, claim_output, os_errors_named, remove_stale_temporaries, write_json_atomic,
)
from ..config.parse import looks_like_config, scene_from_frozen
from ..config.scene import Scene
from ..storage.h5 import first_line
from ..storage.itemfile import KIND_SHARD, ItemFile, read_item_file
from ..storage.store import CorruptFile, StoreError, file_kind, write_bytes, write_store


MANIFEST = "sweep-manifest.json"
PARTS_MANIFEST = "manifest.json"
PART_PREFIX = "items-"
_SHARD_RE = re.compile(r"^shard-(\d+)-of-(\d+)\.h5$")


@dataclass(frozen=True)
class RunDir:
    """Every path of a chunked run directory (one object owns the naming)."""

    root: Path

    @property
    def manifest(self) -> Path:
        return self.root / MANIFEST

    @property
    def results(self) -> Path:
        """The merged store of an array job (`sweep slurm --submit`'s default --results)."""
        return self.root / "results.h5"

    @property
    def logs(self) -> Path:
        return self.root / "logs"

    @property
    def maps(self) -> Path:
        return self.root / "maps"

    @property
    def parts_root(self) -> Path:
        return self.root / "parts"

    @staticmethod
    def _stem(chunk: int, n_chunks: int) -> str:
        width = max(4, len(str(n_chunks)))
        return f"shard-{chunk:0{width}d}-of-{n_chunks:0{width}d}"

    def shard(self, chunk: int, n_chunks: int) -> Path:
        return self.root / f"{self._stem(chunk, n_chunks)}.h5"

    def parts(self, chunk: int, n_chunks: int) -> Path:
        return self.parts_root / self._stem(chunk, n_chunks)


@dataclass(frozen=True)
class SingleRun:
    """Every path of a one-machine run: the store RESULTS, its work directory RESULTS.parts/ and
    its saved maps RESULTS.maps/ beside it."""

    out: Path

    @property
    def parts(self) -> Path:
        return self.out.with_name(self.out.name + ".parts")

    @property
    def maps(self) -> Path:
        return self.out.with_name(self.out.name + ".maps")

    @property
    def refine(self) -> Path:
        return refine_dir(self.out)


def refine_dir(store: Path) -> Path:
    """Work directory of the refinement of the store `store` (`sweep.runs.refine`): beside it."""
    store = Path(store)
    return store.with_name(store.name + ".refine")


#: What each kind of path `path_kind` tells apart is, in words.
PATH_KINDS = {
    "missing": "missing",
    "unknown": "unreadable",
    "store": "a results store",
    "shard": "a shard of a chunked run (one chunk's summaries)",
    "part": "a part file (one finished sub-chunk of a run, kept for resuming)",
    "map": "a map file (one energy map)",
    "hdf5": "an HDF5 file that is not a sweep file",
    "config": "a sweep config (YAML)",
    "picture": "a PNG picture",
    "file": "a file",
    "run-dir": "a run directory (the shards of a chunked sweep)",
    "work-dir": "a run's work folder (finished pieces kept for resuming)",
    "maps-dir": "a run's folder of saved maps",
    "folder": "a folder",
}
#: The first bytes of a PNG file.
PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"
#: Bytes of a file read to tell a config from other text.
PEEK_BYTES = 1 << 16


def path_kind(path: Path) -> str:
    """What `path` is, as far as its name and contents tell: a key of PATH_KINDS. The one place
    that tells the kinds of path apart (run directories and the work folders of runs by their
    names, sweep files by `sweep.storage.store.file_kind`, configs by
    `sweep.config.parse.looks_like_config`); "unknown" when it cannot be read, so that the
    command's own message says why."""
    path = Path(path)
    try:
        if not path.exists():
            return "missing"
        if path.is_dir():
            if RunDir(path).manifest.exists() or any(_SHARD_RE.match(p.name)
                                                     for p in path.iterdir()):
                return "run-dir"
            if path.name.endswith((".parts", ".refine")) or (
                    path.name == "parts" and RunDir(path.parent).manifest.exists()):
                return "work-dir"
            if path.name.endswith(".maps") or (path.name == "maps" and
                                               RunDir(path.parent).manifest.exists()):
                return "maps-dir"
            return "folder"
        kind = file_kind(path)
        if kind is not None:
            return kind
        with open(path, "rb") as fh:
            head = fh.read(PEEK_BYTES)
    except (OSError, RuntimeError):     # RuntimeError: a symlink loop on some Pythons
        return "unknown"
    if head.startswith(PNG_SIGNATURE):
        return "picture"
    return "config" if looks_like_config(head, path.name) else "file"


def part_path(parts_dir: Path, start: int, stop: int) -> Path:
    """One finished sub-chunk (items [start, stop)) in a work directory."""
    return Path(parts_dir) / f"{PART_PREFIX}{start:08d}-{stop:08d}.h5"


def map_file_name(point: dict, n_commands: int) -> str:
    """File name of a saved full map (`outputs.save_maps`)."""
    name = "map_" + "_".join(f"{k}={point[k]:.12g}"
                             for k in ("l1", "l2", "r1", "r2", "w", "r", "mu"))
    if n_commands > 1:
        name += f"_command={point['command']}"
    return name + ".h5"


def manifest_dict(scene: Scene, n_chunks: int) -> dict:
    ranges = chunk_ranges(scene.n_items, n_chunks, scene.group_size, scene.group_costs())
    return dict(sweep_file_kind="sweep-manifest", n_chunks=n_chunks, n_items=scene.n_items,
                n_maps=scene.n_maps, chunk_ranges=[list(r) for r in ranges],
                group_size=scene.group_size, **scene.frozen())


def read_json(path: Path) -> dict:
    try:
        with open(path) as fh:
            return json.load(fh)
    except (OSError, json.JSONDecodeError) as exc:
        raise StoreError(f"{path}: unreadable ({first_line(exc)})") from None


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
    readable: list[ItemFile] = []
    for p in files:
        m = _SHARD_RE.match(p.name)
        name_chunk, name_n = int(m.group(1)), int(m.group(2))
        try:
            b = read_item_file(p, with_data=False)
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
            holder = OutputLock(rundir.shard(k, n_chunks)).holder()
            if holder:
                detail = (detail or "in progress") + (f", locked by pid {holder.get('pid')} on "
                                                      f"host {holder.get('host')}")
            shards.append(ShardState(k, "missing", rundir.shard(k, n_chunks), detail,
                                     range=ranges[k] if ranges else None, parts_done=n_parts))
        elif len(found) == 1:
            shards.append(found[0])
        else:
            names = ", ".join(s.path.name for s in found)
            shards.append(ShardState(k, "duplicate", found[0].path,
                                     f"{len(found)} files claim chunk {k}: {names}"))
    return DirStatus(root, n_chunks, manifest, shards, stray)


def merge_shards(root: Path, out: Path, overwrite: bool = False,
                 wait: bool = False) -> tuple[Scene, DirStatus]:
    """One store from a complete, consistent set of shards; StoreError otherwise, OutputError if
    `out` cannot be written (exists without `overwrite`, locked by another writer, ...)."""
    status = scan_shards(root)
    if not status.complete:
        bad = [s for s in status.shards + status.stray if s.state != "done"]
        desc = "; ".join(f"shard {s.chunk} {s.state}"
                         + (f" ({s.path.name}: {s.detail})" if s.detail and s.path else
                            f" ({s.path.name})" if s.path else "") for s in bad)
        raise StoreError(f"cannot merge {root}: {len(bad)} of {status.n_chunks} shards not usable: "
                         f"{desc}")
    scene = scene_from_frozen(read_item_file(status.shards[0].path, with_data=False).frozen)
    # the store is written a shard and a part at a time: the largest shard counts, not the sweep
    check_memory_need(write_bytes(scene, max(s.range[1] - s.range[0] for s in status.shards)),
                      f"the merge of {root}", "merge on a machine with more memory")
    with claim_output(out, overwrite=overwrite, wait=wait):
        # without their data: the store is written from one shard at a time (write_store)
        item_files = [read_item_file(s.path, with_data=False) for s in status.shards]
        scene = scene_from_frozen(item_files[0].frozen)
        for b in item_files:
            if (b.config_hash, b.version) != (scene.config_hash, item_files[0].version):
                raise StoreError(f"cannot merge {root}: {b.path.name} has config "
                                 f"{b.config_hash[:12]} / version {b.version}, "
                                 f"{item_files[0].path.name} has {scene.config_hash[:12]} / "
                                 f"{item_files[0].version}")
        if item_files[0].version != __version__:
            raise StoreError(f"cannot merge {root}: shards written by sweep "
                             f"{item_files[0].version}, this is sweep {__version__}")
        compute = sum(b.compute_seconds for b in item_files)
        maps_dir = RunDir(root).maps
        saved = sorted(p.name for p in maps_dir.glob("*.h5")) if maps_dir.is_dir() else []
        write_store(out, scene, item_files, timings=dict(
            compute_seconds=compute,
            maps_per_second=scene.n_maps / compute if compute > 0 else 0.0),
            created_by=f"sweep merge of {status.n_chunks} shards",
            extra_attrs=dict(saved_maps=saved, saved_maps_dir=str(maps_dir)) if saved else None)
    return scene, status


# ---------------------------------------------------------------------------------------------
# Work directories (one per single-machine run, one per chunk in progress)
# ---------------------------------------------------------------------------------------------
def prepare_parts_dir(parts_dir: Path, scene: Scene, start: int, stop: int) -> list:
    """Create or check the work directory; return the finished, valid parts found in it.
    The caller holds the output's lock, so every temporary in it is a killed writer's."""
    manifest = parts_dir / PARTS_MANIFEST
    if manifest.exists():
        have = read_json(manifest)
        if (have.get("config_hash"), have.get("sweep_version")) != (scene.config_hash,
                                                                     __version__):
            raise StoreError(
                f"{parts_dir} holds partial results of another config or sweep version "
                f"(config {str(have.get('config_hash'))[:12]}, version "
                f"{have.get('sweep_version')}; this run: {scene.config_hash[:12]}, "
                f"{__version__}); delete it or pass --restart")
    else:
        write_json_atomic(manifest, dict(item_start=start, item_stop=stop, **scene.frozen()))
    remove_stale_temporaries(parts_dir, owned=True)
    item_files = []
    for p in sorted(parts_dir.glob(f"{PART_PREFIX}*.h5")):
        try:
            b = read_item_file(p, with_data=False)
        except CorruptFile as exc:
            print(f"sweep: discarding unreadable part {p.name}: {exc}", file=sys.stderr)
            with os_errors_named(p, "cannot remove"):
                p.unlink()
            continue
        if (b.config_hash, b.version) != (scene.config_hash, __version__) or \
                b.start < start or b.stop > stop:
            raise StoreError(f"{p}: a part of another sweep in this work directory; delete "
                             f"{parts_dir} or pass --restart")
        item_files.append(b)
    return item_files


def _short(v) -> str:
    return v[:12] if isinstance(v, str) and len(v) == 64 else str(v)
