"""A cold compilation, for real (long: `make test-long`, SWEEP_LONG_COMPILE=1; about a minute).

In a new, empty kernel cache: both kernel sets of compute/warm.py compile each kernel once, with
one signature (a second signature would compile the kernel and everything below it again, and
two processes compiling different signatures of one kernel could spoil the cache's index:
docs/architecture.md, "One compilation for every scene"; `gather_field` copies three
dtypes): counted as the dispatchers record them and as the cache holds them.
In another: `ensure_compiled` (the two sets in two processes), then `make run`'s commands (both
scenes with the refinement, and the report) on a small config compile nothing more: no cache
file is added."""
from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest
import yaml

from profiles import LONG_COMPILE

ROOT = Path(__file__).resolve().parents[1]
pytestmark = pytest.mark.skipif(not LONG_COMPILE, reason="long profile: SWEEP_LONG_COMPILE=1")

#: Kernels that legitimately have several signatures (their argument dtypes differ by design).
SEVERAL = {"gather_field": 3}

SIGNATURES = r"""
import json, numba
from sweep.compute import warm
warm.compile_maps()          # both kernel sets in this process, to see every signature
warm.compile_summaries()
import sweep.kernels as k
found = {}
import importlib, pkgutil
for info in pkgutil.iter_modules(k.__path__):     # every kernel module
    name = info.name
    module = importlib.import_module(f"sweep.kernels.{name}")
    for attr, f in vars(module).items():
        if isinstance(f, numba.core.registry.CPUDispatcher) and f.__module__ == module.__name__:
            found[f"{name}.{attr}"] = len(f.signatures)
print(json.dumps(found))
"""


def cache_files(cache: Path) -> set[str]:
    return {str(p.relative_to(cache)) for p in cache.rglob("*") if p.suffix in (".nbi", ".nbc")}


def test_every_kernel_compiles_with_one_signature(tmp_path):
    env = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path / "cache"))
    out = subprocess.run([sys.executable, "-c", SIGNATURES], env=env, capture_output=True,
                         text=True, check=True, cwd=ROOT)
    counts = json.loads(out.stdout.strip().splitlines()[-1])
    several = {name: n for name, n in counts.items() if n > SEVERAL.get(name.split(".")[1], 1)}
    assert not several, f"kernels compiled with several signatures: {several}"
    assert sum(counts.values()) > 100   # (the compilation ran here, not from a cache)
    # what was compiled, as the cache holds it: one file per signature, named
    # module.kernel-LINE.pyXY.K.nbc. A kernel called from kernels only has its signatures
    # recorded here: a call with a literal argument (`n = 0; n = f(n)`) compiled such a kernel,
    # and everything it calls, once more for Literal[int](0), unseen by `.signatures`
    per_kernel: dict = {}
    for path in (tmp_path / "cache").rglob("*.nbc"):
        kernel = path.name.split("-")[0]
        per_kernel[kernel] = per_kernel.get(kernel, 0) + 1
    several = {k: n for k, n in per_kernel.items() if n > SEVERAL.get(k.split(".")[-1], 1)}
    assert not several, f"kernels compiled with several signatures: {several}"
    assert len(per_kernel) > 100


def test_one_compilation_serves_make_run(tmp_path):
    cache = tmp_path / "cache"
    env = dict(os.environ, NUMBA_CACHE_DIR=str(cache))
    out = subprocess.run([sys.executable, "-c", "from sweep.compute import warm; "
                          "warm.ensure_compiled()"], env=env, capture_output=True, text=True,
                         check=True, cwd=ROOT)
    assert "compiling kernels (first run only" in out.stderr
    compiled = cache_files(cache)

    configs = []
    for name in ("paper", "paper-collision"):
        config = yaml.safe_load((ROOT / "configs" / f"{name}.yaml").read_text())
        config["designs"] = {"l1": [1.2, 2.0], "l2": [0.8, 1.6], "r1": [0.12, 0.2],
                             "r2": [0.06, 0.14], "w": [0.4, 0.8]}
        config["parts"] = {"r": [0.4, 0.8], "mu": [0.4]}
        config["grid"]["h"] = 0.2
        config["run"] = {"sub_chunk_cells": 4}
        configs.append(tmp_path / f"{name}.yaml")
        configs[-1].write_text(yaml.safe_dump(config))
    stores = [tmp_path / f"{c.stem}.h5" for c in configs]
    for config, store in zip(configs, stores):
        res = subprocess.run([sys.executable, "-m", "sweep", "run", str(config), "--out",
                              str(store)], env=env, capture_output=True, text=True, cwd=ROOT)
        assert res.returncode == 0, res.stderr
        assert "compiling kernels" not in res.stderr
    res = subprocess.run([sys.executable, "-m", "sweep", "report", *map(str, stores), "--out",
                          str(tmp_path / "report")], env=env, capture_output=True, text=True,
                         cwd=ROOT)
    assert res.returncode == 0, res.stderr
    assert cache_files(cache) == compiled, "make run compiled kernels ensure_compiled did not"
