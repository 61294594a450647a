"""Cold compilation of every kernel `make run` needs, for several source trees side by side.

Per tree, `make run`'s three commands (`sweep run` of the paper scene, `sweep run` of the
collision scene, `sweep report` of both; refinement included) on tiny versions of the two
configs (this tree's configs/paper.yaml and paper-collision.yaml with 2 x 2 x 2 x 2 x 2 designs
and 2 parts at h = 0.2: their compute takes seconds), each command a fresh process as `make run`
starts them:
  - cold: NUMBA_CACHE_DIR a new empty folder (every kernel compiles);
  - warm: the same commands again into new output folders, the cache now full.
Cold compilation = cold - warm (the compute, imports and files are in both). Trees rotate each
round; prints every round's seconds per command, the medians and each tree's ratio to the first.
`--sets` also times this tree's kernel sets one by one (`python -m sweep.compute.warm maps`,
`... summaries`, each cold in a new cache) and `ensure_compiled` (both sets at once, the
summaries in a second process).

`git worktree add --detach <dir> <commit>` gives an old tree to compare with.
"""
from __future__ import annotations

import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from .timing import header

NAME = "compile"
ROOT = Path(__file__).resolve().parents[2]


def add_arguments(ap) -> None:
    ap.add_argument("--trees", nargs="+", default=[str(ROOT)], metavar="DIR",
                    help="source trees to compare, the first is the reference [this tree]")
    ap.add_argument("--repeats", type=int, default=1, help="rounds [1]")
    ap.add_argument("--sets", action="store_true",
                    help="also this tree's kernel sets one by one, and ensure_compiled")


def tiny_configs(folder: Path) -> list[Path]:
    """make run's two configs, shrunk to 64 maps each at h = 0.2 (refinement kept)."""
    import yaml

    paths = []
    for name in ("paper", "paper-collision"):
        config = yaml.safe_load((ROOT / "configs" / f"{name}.yaml").read_text())
        config["designs"] = {"l1": [1.2, 2.0], "l2": [0.8, 1.6], "r1": [0.12, 0.2],
                             "r2": [0.06, 0.14], "w": {"lower": 0.4, "upper": 0.8, "step": 0.4}}
        config["parts"] = {"r": [0.4, 0.8], "mu": [0.4]}
        config["grid"]["h"] = 0.2
        config["run"] = {"sub_chunk_cells": 4}
        path = folder / f"{name}.yaml"
        path.write_text(yaml.safe_dump(config))
        paths.append(path)
    return paths


def make_run(tree: str, configs: list[Path], out: Path, cache: Path) -> list[float]:
    """Wall seconds of make run's three commands (fresh processes) from `tree`."""
    env = dict(os.environ, NUMBA_CACHE_DIR=str(cache), PYTHONPATH=tree)
    stores = [out / f"{c.stem}.h5" for c in configs]
    commands = [["run", str(c), "--out", str(s)] for c, s in zip(configs, stores)]
    commands.append(["report", *map(str, stores), "--out", str(out / "report")])
    seconds = []
    for args in commands:
        started = time.perf_counter()
        subprocess.run([sys.executable, "-m", "sweep", *args], env=env, cwd=tree, check=True,
                       stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        seconds.append(time.perf_counter() - started)
    return seconds


def timed_process(args: list[str], cache: Path) -> float:
    env = dict(os.environ, NUMBA_CACHE_DIR=str(cache), PYTHONPATH=str(ROOT))
    started = time.perf_counter()
    subprocess.run([sys.executable, *args], env=env, check=True, cwd=ROOT,
                   stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    return time.perf_counter() - started


def run(args) -> int:
    header(NAME)
    trees = [str(Path(t).resolve()) for t in args.trees]
    cold = {t: [] for t in trees}
    with tempfile.TemporaryDirectory(prefix="sweep-bench-compile-") as tmp:
        configs = tiny_configs(Path(tmp))
        for k in range(args.repeats):
            order = trees[k % len(trees):] + trees[:k % len(trees)]
            for tree in order:
                work = Path(tmp) / f"round{k}-{trees.index(tree)}"
                c = make_run(tree, configs, work / "cold", work / "cache")
                w = make_run(tree, configs, work / "warm", work / "cache")
                cold[tree].append(sum(c) - sum(w))
                print(f"- round {k + 1}, {tree}: cold " + " + ".join(f"{s:.1f}" for s in c)
                      + f" = {sum(c):.1f} s; warm " + " + ".join(f"{s:.1f}" for s in w)
                      + f" = {sum(w):.1f} s; compilation {sum(c) - sum(w):.1f} s", flush=True)
        ref = statistics.median(cold[trees[0]])
        for tree in trees:
            med = statistics.median(cold[tree])
            print(f"{tree}: cold compilation of make run's kernels, median {med:.1f} s, "
                  f"x{med / ref:.2f} of the first tree", flush=True)
        if args.sets:
            for label, argv in (("maps", ["-m", "sweep.compute.warm", "maps"]),
                                ("summaries", ["-m", "sweep.compute.warm", "summaries"]),
                                ("ensure_compiled (both, two processes)",
                                 ["-c", "from sweep.compute.warm import ensure_compiled; "
                                        "ensure_compiled()"])):
                cache = Path(tmp) / f"set-{label.split()[0]}"
                seconds = timed_process(argv, cache)
                warm = timed_process(argv, cache)
                print(f"- kernel set {label}: cold {seconds:.1f} s, warm {warm:.1f} s",
                      flush=True)
    return 0
