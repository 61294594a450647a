"""Self-describing HDF5 with h5py: atomic writes, dimension scales, CF flag attributes, provenance.

Every HDF5 file this package writes goes through `atomic_file`: built in memory (or, for a file
that must not be held whole, `stream=True`, written piece by piece to its temporary), under a
temporary name in the same directory and renamed into place only when complete
(`sweep.files`), so a file with the final name is always whole. Dimensions are HDF5 dimension
scales, which `xarray.open_dataset(..., engine="h5netcdf")` reads as labelled coordinates.
"""
from __future__ import annotations

import contextlib
import io
import json
import os
import platform
import sys
import time
from collections.abc import Iterable, Mapping, Sequence
from pathlib import Path

import h5py
import numpy as np

from .. import __version__
from ..files import (CorruptFile, StoreError,  # noqa: F401 (the errors of stored files)
                       atomic_stream, make_parent, write_bytes_atomic)


@contextlib.contextmanager
def atomic_file(path: str | os.PathLike, mode: str = "w", stream: bool = False):
    """Yield a new h5py.File; it appears at `path` only if the `with` body succeeds (temporary
    name, fsync, rename: `sweep.files`).

    Built in memory and written at the end (`write_bytes_atomic`), or with `stream` written to
    its temporary as it grows (`atomic_stream`: memory stays flat however large the file). Both
    ways a full disk or a read-only folder is one clean `OutputError` naming the path, never an
    error inside the HDF5 library (which crashed the process on ENOSPC)."""
    if mode != "w":
        raise ValueError(f"atomic_file writes new files only (mode 'w'), got {mode!r}")
    path = Path(path)
    make_parent(path)
    if stream:
        with atomic_stream(path) as spool:
            with h5py.File(spool, "w") as f:
                yield f
        return
    buffer = io.BytesIO()
    with h5py.File(buffer, "w") as f:
        yield f
    write_bytes_atomic(path, buffer.getbuffer())


@contextlib.contextmanager
def atomic_amend(path: str | os.PathLike):
    """Yield an existing HDF5 file, read into memory and opened for changes; write it back to
    `path` atomically (as `atomic_file`) only if the `with` body succeeds: until then, and if
    it fails or the process is killed, the file on disk is the old one, whole."""
    path = Path(path)
    buffer = io.BytesIO(path.read_bytes())
    with h5py.File(buffer, "r+") as f:
        yield f
    write_bytes_atomic(path, buffer.getbuffer())


def write_coordinate(f: h5py.Group, name: str, values,
                     attrs: Mapping | None = None) -> h5py.Dataset:
    """A 1-D coordinate variable that is also the dimension scale of dimension `name`."""
    values = np.asarray(values)
    if values.dtype.kind in "UO":
        ds = f.create_dataset(name, data=np.array(values, dtype=object), dtype=h5py.string_dtype())
    else:
        ds = f.create_dataset(name, data=values)
    ds.make_scale(name)
    _set_attrs(ds, attrs)
    return ds


def write_variable(f: h5py.Group, name: str, data, dims: Sequence[str],
                   attrs: Mapping | None = None, compression: bool = True) -> h5py.Dataset:
    """An n-D variable whose axes are attached to the named dimension scales in `f`."""
    data = np.asarray(data)
    if data.ndim != len(dims):
        raise ValueError(f"{name}: {data.ndim}-D data with dims {dims}")
    ds = f.create_dataset(name, data=data, **_layout(data.size, compression))
    return _describe(f, ds, dims, attrs)


#: Chunk cache of a variable filled a slab at a time (`create_variable`): partly written chunks
#: wait there until the slabs that complete them come. HDF5 2.0's default, 8 MiB for each open
#: variable, held the store's whole summaries up to 8 MiB a variable (the paper store 5 MB, a 4x
#: store 26 MB); with 1 MiB the memory stays flat and chunks that leave the cache before they are
#: complete are read back and compressed again when the next slab reaches them.
FILL_CACHE_BYTES = 1 << 20


def create_variable(f: h5py.Group, name: str, shape: Sequence[int], dtype, dims: Sequence[str],
                    attrs: Mapping | None = None, compression: bool = True) -> h5py.Dataset:
    """`write_variable` without the data: the variable at its full size, to be filled a slab at
    a time through the returned handle (h5py picks the chunks from the shape and type alone, so
    they are write_variable's), with a chunk cache of FILL_CACHE_BYTES."""
    shape = tuple(int(n) for n in shape)
    if len(shape) != len(dims):
        raise ValueError(f"{name}: {len(shape)}-D data with dims {dims}")
    ds = f.create_dataset(name, shape=shape, dtype=dtype, rdcc_nbytes=FILL_CACHE_BYTES,
                          **_layout(int(np.prod(shape)), compression))
    return _describe(f, ds, dims, attrs)


def _layout(size: int, compression: bool) -> dict:
    """Storage of a variable of `size` values: gzip with shuffle unless it is small."""
    if compression and size >= 1024:
        return dict(compression="gzip", compression_opts=4, shuffle=True)
    return {}


def _describe(f: h5py.Group, ds: h5py.Dataset, dims: Sequence[str],
              attrs: Mapping | None) -> h5py.Dataset:
    for axis, dim in enumerate(dims):
        ds.dims[axis].attach_scale(f[dim])
    _set_attrs(ds, attrs)
    return ds


def flag_attrs(meanings: Sequence[str], long_name: str, **extra) -> dict:
    """CF attributes of a categorical variable coded 0..n-1."""
    return dict(long_name=long_name, flag_values=np.arange(len(meanings), dtype=np.int8),
                flag_meanings=" ".join(meanings), **extra)


def provenance() -> dict:
    """Versions of everything that decides the numbers, for the root attributes."""
    import numba
    import scipy

    return dict(
        sweep_version=__version__,
        python_version=sys.version.split()[0],
        numpy_version=np.__version__,
        numba_version=numba.__version__,
        scipy_version=scipy.__version__,
        h5py_version=h5py.__version__,
        hdf5_version=h5py.version.hdf5_version,
        platform=platform.platform(),
        created_utc=time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()),
    )


def _set_attrs(obj, attrs: Mapping | None) -> None:
    for key, value in (attrs or {}).items():
        obj.attrs[key] = attr_value(value)


def attr_value(value):
    """HDF5-storable form of a Python value (dicts and lists of mixed types become JSON)."""
    if isinstance(value, (dict, list, tuple)) and not _is_homogeneous_numeric(value):
        return json.dumps(value, sort_keys=True, default=_json_default)
    if isinstance(value, bool):
        return np.int8(value)
    if value is None:
        return "none"
    if isinstance(value, str):
        # HDF5 text is UTF-8: a path with bytes that are not (surrogate escapes) is stored with
        # them spelled out as \udcXX
        return value.encode("utf-8", "backslashreplace").decode("utf-8")
    return value


def set_root_attrs(f: h5py.File, attrs: Mapping) -> None:
    _set_attrs(f, attrs)


def _is_homogeneous_numeric(value) -> bool:
    if isinstance(value, dict):
        return False
    return len(value) > 0 and all(isinstance(v, (int, float)) and not isinstance(v, bool)
                                  for v in value)


def _json_default(obj):
    if isinstance(obj, np.generic):
        return obj.item()
    if isinstance(obj, np.ndarray):
        return obj.tolist()
    if isinstance(obj, (set, frozenset)):
        return sorted(obj)
    if isinstance(obj, Path):
        return str(obj)
    raise TypeError(f"not JSON serialisable: {type(obj)}")


def read_json_attr(obj, key: str):
    raw = obj.attrs[key]
    if isinstance(raw, bytes):
        raw = raw.decode()
    return json.loads(raw)


def iter_names(values: Iterable) -> list[str]:
    return [v.decode() if isinstance(v, bytes) else str(v) for v in values]


def attr_text(v) -> str:
    """A text attribute as read by h5py (bytes or str) as str."""
    return v.decode() if isinstance(v, bytes) else str(v)


def plain(v):
    """An attribute's value as a plain Python value (text, number) where it is one."""
    if isinstance(v, bytes):
        return v.decode()
    if isinstance(v, np.ndarray) and v.ndim == 0:
        return v.item()
    if isinstance(v, np.generic):
        return v.item()
    return v


def first_line(exc: BaseException) -> str:
    """The first line of an exception's message (its type's name if it has none)."""
    return (str(exc).strip().splitlines() or [type(exc).__name__])[0]


def file_differences(path_a, path_b, ignore: Sequence[str] = ()) -> list[str]:
    """What differs between the contents of two HDF5 files (empty: the same): every group and
    dataset (type, shape, chunks, compression, dimension scales, the bytes of its values) and
    every attribute, except the root attributes `ignore`."""
    out: list[str] = []

    def attrs(obj) -> dict:
        return {k: v for k, v in obj.attrs.items() if k not in ("DIMENSION_LIST",
                                                                 "REFERENCE_LIST")}

    def same(x, y) -> bool:
        x, y = np.asarray(x), np.asarray(y)
        if x.dtype != y.dtype or x.shape != y.shape:
            return False
        return x.tolist() == y.tolist() if x.dtype.kind == "O" else x.tobytes() == y.tobytes()

    def visit(a, b, where: str) -> None:
        if set(a) != set(b):
            out.append(f"{where or '/'}: members {sorted(set(a) ^ set(b))} in one file only")
        ka, kb = attrs(a), attrs(b)
        skip = set(ignore) if where == "" else set()
        for k in sorted((set(ka) | set(kb)) - skip):
            if k not in ka or k not in kb or not same(ka[k], kb[k]):
                out.append(f"{where or '/'}: attribute {k} differs")
        for name in sorted(set(a) & set(b)):
            x, y = a[name], b[name]
            here = f"{where}/{name}"
            if isinstance(x, h5py.Group) and isinstance(y, h5py.Group):
                visit(x, y, here)
                continue
            if not (isinstance(x, h5py.Dataset) and isinstance(y, h5py.Dataset)):
                out.append(f"{here}: a dataset in one file only")
                continue
            layout = [(d.dtype, d.shape, d.chunks, d.compression, d.compression_opts, d.shuffle,
                       d.fletcher32, [[s.name for s in dim.values()] for dim in d.dims])
                      for d in (x, y)]
            if layout[0] != layout[1]:
                out.append(f"{here}: layout {layout[0]} and {layout[1]}")
            elif not same(x[...], y[...]):
                out.append(f"{here}: values differ")
            ka, kb = attrs(x), attrs(y)
            for k in sorted(set(ka) | set(kb)):
                if k not in ka or k not in kb or not same(ka[k], kb[k]):
                    out.append(f"{here}: attribute {k} differs")

    with h5py.File(path_a, "r") as fa, h5py.File(path_b, "r") as fb:
        visit(fa, fb, "")
    return out
