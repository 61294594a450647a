"""Every variable a store holds is declared in the schema (`sweep.schema.STORE_FIELDS`), with
the dimensions, type and attributes declared there, and docs/outputs.md lists it (`make lint`).

The stores are written from item files of stand-in summaries (tests/sweep_cases.py), with the
manipulation metric and Scenario C from empty reductions: every variable `write_store` can write,
and nothing computed. The refinement's variables are the schema's `REFINE_FIELDS`, which
`add_refinement` writes one by one."""
from __future__ import annotations

import ast
from pathlib import Path

import h5py
import numpy as np
import pytest

from sweep.compute.manipulation import ManipulationChunk
from sweep.config.parse import scene_from_dict
from sweep.schema import REFINE_FIELDS, STORE_FIELDS, SUMMARY
from sweep.storage.itemfile import KIND_PART, read_item_file, write_item_file
from sweep.storage.store import write_store
from sweep_cases import fake_items, tiny

ROOT = Path(__file__).resolve().parents[1]
MANIPULATION = {"manipulation": True, "scenario_a_top_k": 2}
SCENES = {
    "base": tiny(),
    "two-commands": tiny(commands=[{"f_left": 1.0, "f_right": 1.0},
                                   {"f_left": 0.4, "f_right": 1.6}]),
    "collision": tiny(effects={"finger_collision": True}),
    "manipulation": tiny(outputs=MANIPULATION),
    "scenario-c": tiny(outputs={**MANIPULATION, "scenario_c": {"mu_low": 0.0}}),
}


def _item_file(scene, path: Path):
    """Every item of the scene in one part file, with empty manipulation data when the scene has
    the metric (a metric of 0 per item, no part's reductions)."""
    n = scene.n_items
    manipulation = None
    if scene.manipulation:
        manipulation = ManipulationChunk(0, n, np.zeros(n), {},
                                         c_metric=np.zeros(n) if scene.scenario_c else None)
    write_item_file(path, scene, 0, n, fake_items(scene, 0, n), KIND_PART, 0.0,
                    manipulation=manipulation)
    return read_item_file(path, with_data=False)


def _dims(ds: h5py.Dataset) -> tuple[str, ...]:
    """The dimensions of a variable: its attached scales' names (a coordinate: its own)."""
    if ds.is_scale:
        return (ds.name.lstrip("/"),)
    return tuple(axis[0].name.lstrip("/") for axis in ds.dims)


@pytest.mark.parametrize("name", SCENES)
def test_every_store_variable_is_declared_in_the_schema(name, tmp_path):
    scene = scene_from_dict(SCENES[name])
    out = tmp_path / "store.h5"
    write_store(out, scene, [_item_file(scene, tmp_path / "items.h5")], {}, "test")
    summary = {f.name for f in SUMMARY}
    with h5py.File(out, "r") as f:
        names = list(f)
        assert names and not [n for n in names if n not in STORE_FIELDS], \
            "declare these in sweep/schema.py (STORE_FIELDS)"
        for n in names:
            declared = STORE_FIELDS[n]
            assert _dims(f[n]) == (scene.store_dims if n in summary else declared.dims), n
            assert f[n].dtype == (h5py.string_dtype() if declared.dtype == "str"
                                  else np.dtype(declared.dtype)), n
            attrs = {k: v for k, v in f[n].attrs.items()
                     if k not in ("DIMENSION_LIST", "REFERENCE_LIST", "CLASS", "NAME",
                                  "_Netcdf4Dimid")}
            want = declared.attrs()
            assert set(attrs) == set(want), n
            for k, v in want.items():
                got = attrs[k].decode() if isinstance(attrs[k], bytes) else attrs[k]
                assert np.array_equal(got, v), (n, k)


def test_the_refinement_writes_only_declared_variables():
    """`add_refinement` writes the schema's REFINE_FIELDS, each by its declaration."""
    tree = ast.parse((ROOT / "sweep" / "storage" / "store.py").read_text())
    add = next(n for n in tree.body if isinstance(n, ast.FunctionDef)
               and n.name == "add_refinement")
    loops = [n for n in ast.walk(add) if isinstance(n, ast.For)
             and isinstance(n.iter, ast.Name) and n.iter.id == "REFINE_FIELDS"]
    writes = [n for n in ast.walk(add) if isinstance(n, ast.Call)
              and getattr(n.func, "id", None) in ("write_variable", "create_variable")]
    assert loops and writes and all(any(w is c for c in ast.walk(loops[0])) for w in writes)
    assert all(f.name in STORE_FIELDS for f in REFINE_FIELDS)


def test_outputs_doc_lists_every_store_variable():
    text = (ROOT / "docs" / "outputs.md").read_text()
    assert not [n for n in STORE_FIELDS if f"| `{n}` |" not in text], \
        "regenerate with: .venv/bin/python -m sweep.schema > docs/outputs.md"
