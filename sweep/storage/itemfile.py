"""Item files: part files and shards, the summaries of a contiguous range of work items.

An item file holds the summaries of work items [start, stop) (`sweep.config.scene.ITEM_ORDER`)
at every width: variable ``summaries(item, w, field)`` (float64, Fletcher-32 checksummed), with
the frozen config, its hash and the package version as attributes, and, when the scene has the
manipulation metric, the same items' manipulation data in a ``manipulation`` group. A run
writes one *part file* per finished sub-chunk into a work directory; a cluster chunk ends as one
*shard*. Every one is written through `sweep.storage.h5.atomic_file` (a file with its final name
is always complete, see `sweep.files`). `sweep.storage.store` merges item files that tile every
item into the store.
"""
from __future__ import annotations

import contextlib
import json
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

import h5py
import numpy as np

from .. import __version__
from ..compute.manipulation import ManipulationChunk
from ..config.chunks import Range, exact_cover
from ..config.scene import ITEM_ORDER, Scene
from ..schema import STORE_FIELDS, SUMMARY_FIELDS
from .h5 import (CorruptFile, StoreError, atomic_file, attr_text, first_line, iter_names,
                 read_json_attr, set_root_attrs, write_coordinate)

KIND_PART = "sweep-part"
KIND_SHARD = "sweep-shard"


@dataclass
class ItemFile:
    """What an item file says of itself (`read_item_file`); its summaries in `data` when read
    with them (or held in memory, without a file)."""

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
        raise ValueError(f"item file {start}-{stop}: summaries of shape {data.shape}, "
                         f"expected {expect}")
    with atomic_file(path) as f:
        write_coordinate(f, "item", np.arange(start, stop, dtype=np.int64),
                         dict(long_name="work item index (ITEM_ORDER numbering)", units="1"))
        write_coordinate(f, "w", scene.widths, STORE_FIELDS["w"].attrs())
        write_coordinate(f, "field", np.array(SUMMARY_FIELDS, dtype=object),
                         dict(long_name="summary field"))
        ds = f.create_dataset("summaries", data=data, fletcher32=True,
                              chunks=data.shape if data.size else None)
        for axis, dim in enumerate(("item", "w", "field")):
            ds.dims[axis].attach_scale(f[dim])
        ds.attrs["long_name"] = "per-map summaries, one row per work item and width"
        if manipulation is not None:
            if (manipulation.start, manipulation.stop) != (start, stop):
                raise ValueError(f"item file {start}-{stop}: manipulation data of items "
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
    """Read and check an item file; raises CorruptFile if it is unreadable or inconsistent.
    The data is always read (the Fletcher-32 checksums are checked on read)."""
    path = Path(path)
    try:
        with h5py.File(path, "r") as f:
            a = f.attrs
            kind = attr_text(a["sweep_file_kind"])
            if kind not in (KIND_PART, KIND_SHARD):
                raise CorruptFile(f"{path.name}: not a sweep part file or shard (kind {kind!r})")
            start, stop = int(a["item_start"]), int(a["item_stop"])
            data = f["summaries"][...]
            fields = iter_names(f["field"][...])
            frozen = read_json_attr(f, "frozen_config")
            item_file = ItemFile(path=path, kind=kind, start=start, stop=stop,
                                 config_hash=attr_text(a["config_hash"]),
                                 version=attr_text(a["sweep_version"]),
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
        item_file.data = data
    return item_file


def summaries_of(item_file: ItemFile) -> np.ndarray:
    """An item file's summaries: those held in memory, else read from its file."""
    return item_file.data if item_file.data is not None else read_item_file(item_file.path).data


def in_item_order(item_files: Sequence[ItemFile], start: int, stop: int) -> list[ItemFile]:
    """The item files that tile items [start, stop) exactly, in item order; StoreError if none
    do."""
    pick = exact_cover(start, stop, [b.range for b in item_files])
    if pick is None:
        have = sorted(b.range for b in item_files)
        raise StoreError(f"item files {have} do not cover items {start}-{stop}")
    return [item_files[i] for i in pick]


def assemble(scene: Scene, item_files: Sequence[ItemFile], start: int = 0,
             stop: int | None = None) -> np.ndarray:
    """Summaries of items [start, stop) from item files that tile it exactly."""
    stop = scene.n_items if stop is None else stop
    out = np.empty((stop - start, len(scene.values["w"]), len(SUMMARY_FIELDS)), dtype=np.float64)
    for b in in_item_order(item_files, start, stop):
        out[b.start - start:b.stop - start] = summaries_of(b)
    return out


@contextlib.contextmanager
def manipulation_group(path: Path):
    """The `manipulation` group of an item file, open for reading (CorruptFile if missing or
    unreadable)."""
    try:
        with h5py.File(path, "r") as f:
            yield f["manipulation"]
    except (OSError, KeyError, ValueError) as exc:
        raise CorruptFile(f"{Path(path).name}: no readable manipulation data "
                          f"({first_line(exc)})") from None


def read_manipulation(path: Path) -> ManipulationChunk:
    """The manipulation data of an item file (CorruptFile if missing or unreadable)."""
    with manipulation_group(path) as g:
        return ManipulationChunk.read(g)


def assemble_manipulation(scene: Scene, item_files: Sequence[ItemFile], start: int = 0,
                          stop: int | None = None) -> ManipulationChunk | None:
    """The manipulation data of items [start, stop), merged from item files that tile it; None
    when the scene has no manipulation output."""
    if not scene.manipulation:
        return None
    stop = scene.n_items if stop is None else stop
    # one item file at a time (in item order): the merged data of the range and one file's held
    return ManipulationChunk.merge_stream(read_manipulation(b.path)
                                          for b in in_item_order(item_files, start, stop))
