"""Side-by-side speed of several source trees of sweep (before/after a change), in one run.

Each measurement is a fresh child process with PYTHONPATH pointing at one tree (so it imports
that tree's `sweep`), which compiles or loads its kernels on the same code paths, then times one
run. Trees rotate (A B, B A, ... ; A B C, B C A, ...) so that the machine's drift affects all
alike. Prints every repeat's seconds, the medians and the ratio of each tree to the first.
Workloads (--what):
  - `sweep`: --cells random paper cells (seed 1) x 6 widths at h, summaries (summarize_cells);
  - `collision`: the same with the finger_collision effect (the collision scene);
  - `maps`: the three maps of `bench.py baseline` at h / 2 (compute_map);
  - `forces`: the same three maps, contact forces off versus on, in the last tree only;
  - `run`, `run-collision`: `sweep run` of a slice of configs/paper.yaml (paper-collision.yaml),
    l1 = 1.6 .. 2.0 and mu = 0.4, without `refine:` (7,200 maps with the manipulation metric),
    as `make run` runs it: the runner's sub-chunks, threads and the manipulation path (the
    sample workloads call one kernel driver; the regression of P15's first thread split, 1.11x
    and 1.17x on the full sweeps, did not show there). The config is this tree's.
`git worktree add --detach <dir> <commit>` gives an old tree to compare with. Warm each tree's
kernel cache first (a first run that compiles is timed like any other).
"""
from __future__ import annotations

import json
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import yaml

from .timing import header, print_side_by_side, side_by_side

NAME = "trees"
SCRIPTS = Path(__file__).resolve().parents[1]

# Runs in the tree under test: only names that every tree since 3ec87e7 has, at the module
# paths of P14's layout (sweep/compute/) or of the flat layout before it.
CHILD = r"""
import json, sys, time
sys.path.insert(0, {scripts!r})
from benchmarks.workloads import THREE_MAPS, paper_sample, paper_widths
try:
    from sweep.compute.batch import summarize_cells
    from sweep.compute.maps import compute_map
except ImportError:
    from sweep.batch import summarize_cells
    from sweep.maps import compute_map
from sweep.model import Accuracy, Command, Design, Effects, Grid, Limits, Part
what, n_cells, h = sys.argv[1], int(sys.argv[2]), float(sys.argv[3])
sample, widths = paper_sample(n_cells), paper_widths()
maps = [(Design(*d), Part(*p)) for d, p in THREE_MAPS]
kw = {{"forces": True}} if what == "maps_forces" else {{}}
effects = Effects(finger_collision=True) if what == "sweep_collision" else Effects()
def run():
    if what.startswith("sweep"):
        summarize_cells(sample, widths, Command(), h, Limits(), Accuracy(), effects)
    else:
        for d, p in maps:
            compute_map(d, p, grid=Grid(h=h / 2), **kw)
# warm up: compile or load the kernels on the same code paths
summarize_cells(sample[:1], widths, Command(), 0.4, Limits(), Accuracy(), effects)
for d, p in maps:
    compute_map(d, p, grid=Grid(h=0.4), **kw)
wall, cpu = time.perf_counter(), time.process_time()
run()
print(json.dumps([time.perf_counter() - wall, time.process_time() - cpu]))
"""


def add_arguments(ap) -> None:
    ap.add_argument("trees", nargs="+", metavar="NAME=TREE",
                    help="a name and a source tree (the folder holding sweep/); the first is "
                         "the reference of the ratios, e.g. before=<old tree> after=.")
    ap.add_argument("--what", default="sweep,collision,maps,forces",
                    help="comma-separated workloads: sweep, collision, maps, forces, run, "
                         "run-collision [sweep,collision,maps,forces]")
    ap.add_argument("--h", type=float, default=0.05,
                    help="sweep spacing; the maps use h / 2 [0.05]")
    ap.add_argument("--cells", type=int, default=64, help="paper cells of `sweep` [64]")
    ap.add_argument("--repeats", type=int, default=7, help="rounds [7]")


def child_seconds(tree: Path, what: str, cells: int, h: float) -> tuple[float, float]:
    """(wall, CPU) seconds of one timed run of `what` in a fresh process on `tree`."""
    env = dict(os.environ, PYTHONPATH=str(tree))
    code = CHILD.format(scripts=str(SCRIPTS))
    out = subprocess.run([sys.executable, "-c", code, what, str(cells), str(h)], env=env,
                         cwd=str(tree), check=True, capture_output=True, text=True)
    wall, cpu = json.loads(out.stdout.strip().splitlines()[-1])
    return float(wall), float(cpu)


def run_slice(config: Path, out_dir: Path) -> Path:
    """The slice of a paper config that the `run` workloads sweep (module docstring)."""
    cfg = yaml.safe_load(config.read_text())
    cfg["designs"]["l1"] = {"lower": 1.6, "upper": 2.0, "step": 0.2}
    cfg["parts"]["mu"] = {"lower": 0.4, "upper": 0.4, "step": 0.3}
    cfg.pop("refine", None)
    cfg["name"] = f"{cfg['name']}-slice"
    path = out_dir / f"{cfg['name']}.yaml"
    path.write_text(yaml.safe_dump(cfg))
    return path


def run_seconds(tree: Path, config: Path) -> tuple[float, float]:
    """(wall, CPU of the child) seconds of `sweep run config` in a fresh process on `tree`."""
    env = dict(os.environ, PYTHONPATH=str(tree))
    with tempfile.TemporaryDirectory() as tmp:
        before = resource.getrusage(resource.RUSAGE_CHILDREN)
        wall = time.perf_counter()
        subprocess.run([sys.executable, "-m", "sweep", "run", str(config), "--out",
                        str(Path(tmp) / "out.h5"), "--no-progress"], env=env, cwd=str(tree),
                       check=True, capture_output=True, text=True)
        wall = time.perf_counter() - wall
        after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return wall, (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


def run(args) -> int:
    trees = {}
    for spec in args.trees:
        name, sep, tree = spec.partition("=")
        if not sep or not name or not (Path(tree) / "sweep").is_dir():
            raise SystemExit(f"bench.py trees: {spec!r} is not NAME=TREE with TREE a folder "
                             "holding sweep/")
        trees[name] = Path(tree).resolve()
    what = args.what.split(",")
    if set(what) - {"sweep", "collision", "maps", "forces", "run", "run-collision"}:
        raise SystemExit("bench.py trees: --what takes sweep, collision, maps, forces, run, "
                         "run-collision")
    header(NAME)
    for name, tree in trees.items():
        print(f"# {name}: {tree}")
    names = list(trees)
    if "sweep" in what:
        print_side_by_side(
            f"paper-sweep sample ({args.cells} cells x 6 widths = {6 * args.cells} maps, "
            f"summaries), h = {args.h}",
            side_by_side(names, lambda k: child_seconds(trees[k], "sweep", args.cells, args.h),
                         args.repeats))
    if "collision" in what:
        print_side_by_side(
            f"the same sample with finger_collision (the collision scene), h = {args.h}",
            side_by_side(names, lambda k: child_seconds(trees[k], "sweep_collision", args.cells,
                                                        args.h), args.repeats))
    if "maps" in what:
        print_side_by_side(
            f"three whole maps at h = {args.h / 2} (compute_map)",
            side_by_side(names, lambda k: child_seconds(trees[k], "maps", args.cells, args.h),
                         args.repeats))
    for workload, config in (("run", "paper.yaml"), ("run-collision", "paper-collision.yaml")):
        if workload not in what:
            continue
        with tempfile.TemporaryDirectory() as tmp:
            slices = {}
            for k in names:
                (Path(tmp) / k).mkdir()
                slices[k] = run_slice(trees[k] / "configs" / config, Path(tmp) / k)
                run_seconds(trees[k], slices[k])   # warm: compile or load the kernels
            print_side_by_side(
                f"sweep run of configs/{config}, l1 = 1.6 .. 2.0, mu = 0.4 (7,200 maps, "
                "manipulation metric, no refinement)",
                side_by_side(names, lambda k, s=slices: run_seconds(trees[k], s[k]), args.repeats))
    if "forces" in what:
        last = trees[names[-1]]
        kind = {"forces off": "maps", "forces on": "maps_forces"}
        print_side_by_side(
            f"contact forces: three maps at h = {args.h / 2}, off versus on ({names[-1]})",
            side_by_side(list(kind), lambda k: child_seconds(last, kind[k], args.cells, args.h),
                         args.repeats))
    return 0
