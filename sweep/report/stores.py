"""Opening the stores a report reads: one (`open_store` -> `StoreData`), or two scenes checked
comparable (`open_pair`). Above `data.py`, which every experiment module reads without opening
anything."""
from __future__ import annotations

from pathlib import Path

from ..config.parse import scene_from_frozen
from ..storage.store import read_store
from .data import MANIPULATION_VARIABLES, ReportError, StoreData, check_comparable, resolve_top_k


def open_store(path: Path) -> StoreData:
    """Read a results store (ReportError / StoreError if it cannot be used)."""
    import xarray as xr

    view = read_store(path)                   # kind check, one-line StoreError otherwise
    if "command" in view.dims:
        raise ReportError(f"{path}: the report needs a store with one command "
                          f"(this one has {view.coords['command'].size}); the paper's "
                          "experiments use F_left = F_right = 1")
    try:
        with xr.open_dataset(path, engine="h5netcdf") as ds:
            ds = ds.load()
    except (OSError, ValueError) as exc:
        raise ReportError(f"{path}: cannot read with xarray ({exc})") from None
    scene = scene_from_frozen(view.frozen)
    have = [v for v in MANIPULATION_VARIABLES if v in ds]
    return StoreData(Path(path), ds, scene, view.attrs,
                     manipulation=len(have) == len(MANIPULATION_VARIABLES))


def open_pair(store_1: Path, store_2: Path, top_k: int | None):
    """Both stores, checked comparable, and the Scenario A top-k they share."""
    st1, st2 = open_store(Path(store_1)), open_store(Path(store_2))
    check_comparable(st1, st2)
    k1, k2 = resolve_top_k(st1, top_k), resolve_top_k(st2, top_k)
    if k1 != k2:
        raise ReportError(f"cannot compare {st1.path} with {st2.path}: their Scenario A top-k "
                          f"differ ({k1} against {k2}); pass --top-k to use one for both")
    return st1, st2, k1
