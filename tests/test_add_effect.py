"""Adding an effect is shown, not promised (issue P14): docs/architecture.md's recipe "add an
effect", applied to a copy of the package, gives a working toy effect.

The toy effect is a kernel block that changes nothing, with its own `--effects` name, parameter
flag (`--gain`), summary field (`n_toy`: the grid points it saw) and file attribute (its
parameter). The edits below are the recipe's steps, one per file; the test checks that they are
exactly the files the recipe names (at most 4 outside tests/), then runs `sweep map` from the
copy: the toy's map has the plain map's bytes in every field, its summary field and attribute,
and its parameter is checked at the edge like the others (one line, exit code 2).

`make test` runs the copy with its kernels interpreted (NUMBA_DISABLE_JIT=1, a private cache
folder: a few seconds), which checks every step of the recipe but not that Numba compiles the
toy's block. `make test-long` (SWEEP_LONG_RECIPE=1, tests/profiles.py) runs the same checks on
the copy compiled: its own kernel set (about 80 s on two cores), cached under the user's kernel
cache, keyed by the edited sources; the copy lives in a folder keyed by them too (so the next
run finds its cache).
"""
from __future__ import annotations

import hashlib
import json
import os
import re
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

import h5py
import pytest

from profiles import LONG_RECIPE

ROOT = Path(__file__).resolve().parents[1]

#: The recipe's edits: file -> [(anchor, text, "before" or "after" the anchor)]; each anchor
#: occurs once in its file.
TOY = {
    "sweep/model.py": [
        # 1. model: the switch and parameter in Effects, its validation, the spec in EFFECTS
        ("    spring_k2: float = 0.0\n", "    toy: bool = False\n    toy_gain: float = 0.0\n",
         "after"),
        ("def validate_scene(",
         "def validate_toy(design, command, limits, effects):\n"
         "    if not effects.toy_gain <= 10:\n"
         "        raise ModelInputError(f'toy: gain must be <= 10, got {effects.toy_gain!r}')\n"
         "\n\n", "before"),
        (")\nEFFECT_NAMES = ",
         '    EffectSpec("toy", params=(("gain", "toy_gain"),),\n'
         '               params_text="gain, e.g. toy: {gain: 1}", params_help=("The gain",),\n'
         '               validate=validate_toy,\n'
         '               summary_fields=(("n_toy", "grid points the toy effect saw"),)),\n',
         "before"),
    ],
    "sweep/kernels/records.py": [
        # 2. records: the block's record, and its builder in BLOCKS (a map-level block: last)
        ("class FingerCollision(NamedTuple):",
         "class Toy(NamedTuple):\n    on: bool\n    gain: float\n\n\n", "before"),
        ("     FingerCollision(False, 0.0, 0.0)),\n)\n",
         '    ("toy", lambda effects, accuracy, tension: Toy(True, float(effects.toy_gain)),\n'
         '     Toy(False, 0.0)),\n', "before-last-line"),
    ],
    "sweep/kernels/one_map.py": [
        # 3. kernels: a small function taking the block, called where the physics needs it
        ('S_COLLISION_CHANGED = SUMMARY_INDEX["n_collision_changed"]\n',
         'S_TOY = SUMMARY_INDEX["n_toy"]\n', "after"),
        ("    summary[S_COLLISION_CHANGED] = n_collision_changed\n",
         "    summary[S_TOY] = toy_points(effects.toy, summary[S_POINTS])\n\n\n"
         "@inner\n"
         "def toy_points(toy, n):\n"
         "    if not toy.on:\n"
         "        return 0.0\n"
         "    return n if toy.gain >= 0 else 0.0\n", "after"),
    ],
}


def _apply(text: str, anchor: str, insert: str, where: str) -> str:
    assert text.count(anchor) == 1, f"recipe anchor not found once: {anchor[:60]!r}"
    if where == "after":
        return text.replace(anchor, anchor + insert)
    if where == "before-last-line":   # before the anchor's last line (a closing bracket)
        head, last = anchor[:-1].rsplit("\n", 1)
        return text.replace(anchor, head + "\n" + insert + last + "\n")
    return text.replace(anchor, insert + anchor)


def _recipe_files() -> set[str]:
    """The files outside tests/ that docs/architecture.md's recipe "add an effect" names."""
    doc = (ROOT / "docs" / "architecture.md").read_text()
    recipe = doc.split("## Recipe: add an effect", 1)[1].split("\n## ", 1)[0]
    return set(re.findall(r"`(sweep/[\w/]+\.py)", recipe))


def test_the_recipe_names_the_files_the_toy_effect_edits():
    assert _recipe_files() == set(TOY)
    assert len(TOY) <= 4


@pytest.fixture(scope="module")
def toy_tree(tmp_path_factory):
    """A copy of the package with the toy effect added by the recipe's edits, and the
    environment its commands run in (compiled or interpreted: the module's docstring)."""
    edited = {}
    for name, edits in TOY.items():
        text = (ROOT / name).read_text()
        for anchor, insert, where in edits:
            text = _apply(text, anchor, insert, where)
        edited[name] = text
    digest = hashlib.sha256()
    for path in sorted((ROOT / "sweep").rglob("*.py")):
        name = str(path.relative_to(ROOT))
        digest.update(name.encode() + edited.get(name, path.read_text()).encode())
    tree = Path(tempfile.gettempdir()) / f"sweep-toy-effect-{digest.hexdigest()[:16]}"
    if not (tree / "done").exists():   # unchanged files keep their times: the kernel cache hits
        shutil.rmtree(tree, ignore_errors=True)
        shutil.copytree(ROOT / "sweep", tree / "sweep",
                        ignore=shutil.ignore_patterns("__pycache__"))
        for name, text in edited.items():
            (tree / name).write_text(text)
        (tree / "done").write_text("")
    env = {**os.environ, "PYTHONPATH": str(tree)}
    if not LONG_RECIPE:   # interpreted, and nothing left in the user's kernel cache
        env.update(NUMBA_DISABLE_JIT="1",
                   NUMBA_CACHE_DIR=str(tmp_path_factory.mktemp("toy-kernel-cache")))
    return tree, env


def _sweep(toy, *args) -> subprocess.CompletedProcess:
    tree, env = toy
    return subprocess.run([sys.executable, "-m", "sweep", *args], capture_output=True, text=True,
                          env=env, cwd=tree, timeout=900)


MAP = ["map", "--l1", "2.0", "--l2", "1.6", "--r1", "0.2", "--r2", "0.14", "--w", "0.8", "--r",
       "0.4", "--mu", "0.4", "--h", "0.2", "--threads", "2"]


def test_a_toy_effect_added_by_the_recipe_changes_nothing_but_its_own_fields(toy_tree, tmp_path):
    plain, toy = tmp_path / "plain.h5", tmp_path / "toy.h5"
    res = _sweep(toy_tree, *MAP, "--out", str(plain))
    assert res.returncode == 0, res.stderr
    res = _sweep(toy_tree, *MAP, "--effects", "friction,toy", "--gain", "0.5", "--out", str(toy))
    assert res.returncode == 0, res.stderr
    with h5py.File(plain, "r") as f, h5py.File(toy, "r") as g:
        assert json.loads(g.attrs["effects_on"]) == ["friction", "toy"]
        assert json.loads(g.attrs["toy"]) == {"gain": 0.5}       # its file attribute
        assert int(g.attrs["n_toy"]) == int(g.attrs["n_points"]) > 0   # its summary field
        assert "n_toy" not in f.attrs and "toy" not in f.attrs
        names = [k for k in f if isinstance(f[k], h5py.Dataset)]
        assert "energy" in names
        assert set(names) == {k for k in g if isinstance(g[k], h5py.Dataset)}
        for name in names:   # the block changes nothing
            a, b = f[name][()], g[name][()]
            assert (list(a) == list(b)) if a.dtype.kind == "O" else a.tobytes() == b.tobytes()


@pytest.mark.parametrize("flags, message", [
    (["--effects", "friction,toy"], "--effects toy needs --gain"),
    (["--gain", "0.5"], "add toy to --effects"),
    (["--effects", "friction,toy", "--gain", "-1"], "--gain: must be >= 0"),
    (["--effects", "friction,toy", "--gain", "11"], "toy: gain must be <= 10"),
])
def test_the_toy_effects_parameter_is_checked_at_the_edge(toy_tree, tmp_path, flags, message):
    out = tmp_path / "m.h5"
    res = _sweep(toy_tree, *MAP, *flags, "--out", str(out))
    assert res.returncode == 2, res.stderr
    assert message in res.stderr and len(res.stderr.strip().splitlines()) == 1, res.stderr
    assert not out.exists()
