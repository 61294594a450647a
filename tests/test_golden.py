"""Every map and store the project writes stays bitwise identical across refactorings.

tests/data/golden/ holds files written by scripts/golden.py when the default trajectory method
became `sliding` (model-notes D16; at that change the grid8 maps and store were checked to be
bitwise the earlier golden files, written before the kernel-records refactoring, in every
variable). This test writes the same maps and store with the current code and compares
every variable byte for byte (same dtype, same shape, same bits, NaN where NaN) and every root
and variable attribute, except the ones that say when, where, how fast and with which library
versions a file was written.
"""
from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import h5py
import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]
GOLDEN = ROOT / "tests" / "data" / "golden"
sys.path.insert(0, str(ROOT / "scripts"))
from golden import GOLDEN_MAPS  # noqa: E402

VOLATILE = {"created_utc", "platform", "python_version", "numpy_version", "numba_version",
            "scipy_version", "h5py_version", "hdf5_version", "seconds_fingers", "seconds_total",
            "wall_seconds", "compute_seconds", "maps_per_second", "threads", "saved_maps_dir",
            "DIMENSION_LIST", "REFERENCE_LIST"}


def _plain(v):
    if isinstance(v, bytes):
        return v.decode()
    if isinstance(v, np.ndarray):
        return v.tolist()
    if isinstance(v, np.generic):
        return v.item()
    return v


def assert_same_file(new: Path, old: Path) -> None:
    with h5py.File(new, "r") as a, h5py.File(old, "r") as b:
        names_a, names_b = set(a.keys()), set(b.keys())
        assert names_a == names_b, f"variables differ: {names_a ^ names_b}"
        for name in sorted(names_b):
            x, y = a[name][...], b[name][...]
            assert x.dtype == y.dtype and x.shape == y.shape, name
            if x.dtype.kind in "OS":
                assert x.tolist() == y.tolist(), name
            else:
                assert x.tobytes() == y.tobytes(), f"{name}: values differ"
            attrs_a = {k: _plain(v) for k, v in a[name].attrs.items() if k not in VOLATILE}
            attrs_b = {k: _plain(v) for k, v in b[name].attrs.items() if k not in VOLATILE}
            assert attrs_a == attrs_b, f"{name}: attributes differ"
        ra = {k: _plain(v) for k, v in a.attrs.items() if k not in VOLATILE}
        rb = {k: _plain(v) for k, v in b.attrs.items() if k not in VOLATILE}
        assert set(ra) == set(rb), f"root attributes differ: {set(ra) ^ set(rb)}"
        for k in rb:
            assert ra[k] == rb[k], f"root attribute {k}: {ra[k]!r} != {rb[k]!r}"


@pytest.mark.parametrize("name,design,part,command,grid,accuracy", GOLDEN_MAPS,
                         ids=[g[0] for g in GOLDEN_MAPS])
def test_map_files_are_unchanged(tmp_path, name, design, part, command, grid, accuracy):
    from sweep.storage.mapfile import write_map
    from sweep.compute.maps import compute_map

    write_map(tmp_path / name, compute_map(design, part, command, grid, accuracy=accuracy))
    assert_same_file(tmp_path / name, GOLDEN / name)


def test_store_is_unchanged(tmp_path):
    out = tmp_path / "store_small.h5"
    subprocess.run([sys.executable, "-m", "sweep.cli", "run", str(ROOT / "configs/small.yaml"),
                    "--out", str(out), "--no-progress"], check=True, capture_output=True)
    assert_same_file(out, GOLDEN / "store_small.h5")
    saved = sorted(p.name for p in (GOLDEN / "store_small.h5.maps").glob("*.h5"))
    assert saved
    for name in saved:
        assert_same_file(tmp_path / "store_small.h5.maps" / name,
                         GOLDEN / "store_small.h5.maps" / name)


def test_outputs_doc_is_generated_from_the_schema():
    """docs/outputs.md is `python -m sweep.schema`'s output: the docs read the one schema."""
    from sweep.schema import markdown_table

    assert (ROOT / "docs" / "outputs.md").read_text() == markdown_table(), \
        "regenerate with: .venv/bin/python -m sweep.schema > docs/outputs.md"
