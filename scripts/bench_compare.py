"""Side-by-side speed of two source trees of sweep (before/after a change), in one run.

Each measurement runs in a fresh child process with PYTHONPATH pointing at one tree; trees
alternate (A B A B ...) so that the machine's drift affects both alike. Kernels are compiled or
loaded from the cache before timing. Prints the absolute seconds of every repeat and the ratio of
the medians (after / before). Also, for the `after` tree alone, the cost of the contact-force
output (forces on versus off, on the same maps, alternating).

    .venv/bin/python scripts/bench_compare.py --before /path/to/old/tree --after . \
        [--cells 48] [--repeats 5] [--h 0.05]

`git worktree add --detach /tmp/before <commit>` gives an old tree to compare with.
"""
from __future__ import annotations

import argparse
import json
import os
import platform
import statistics
import subprocess
import sys
import time
from pathlib import Path

CHILD = r"""
import json, sys, time
import numpy as np
from sweep.batch import summarize_cells
from sweep.maps import compute_map
from sweep.model import Accuracy, Command, Design, Grid, Limits, Part
sys.path.insert(0, {scripts!r})
from bench import paper_cells
what, n_cells, h = sys.argv[1], int(sys.argv[2]), float(sys.argv[3])
cells, widths = paper_cells()
pick = np.random.default_rng(1).choice(len(cells), size=min(n_cells, len(cells)), replace=False)
sample = cells[np.sort(pick)]
maps = [(Design(2.0, 1.6, 0.2, 0.14, 0.8), Part(0.4, 0.4)),
        (Design(1.0, 0.8, 0.04, 0.18, 1.2), Part(0.8, 0.1)),
        (Design(0.6, 0.4, 0.12, 0.1, 0.4), Part(1.2, 1.0))]
kw = {{"forces": True}} if what == "maps_forces" else {{}}
def run():
    if what == "sweep":
        summarize_cells(sample, widths, Command(), h, Limits(), Accuracy())
    else:
        for d, p in maps:
            compute_map(d, p, grid=Grid(h=h / 2), **kw)
# warm up: compile or load the kernels on the same code paths
summarize_cells(sample[:1], widths, Command(), 0.4, Limits(), Accuracy())
for d, p in maps:
    compute_map(d, p, grid=Grid(h=0.4), **kw)
t = time.perf_counter()
run()
print(json.dumps(time.perf_counter() - t))
"""


def child_seconds(tree: Path, what: str, cells: int, h: float) -> float:
    env = dict(os.environ, PYTHONPATH=str(tree))
    code = CHILD.format(scripts=str(Path(__file__).resolve().parent))
    out = subprocess.run([sys.executable, "-c", code, what, str(cells), str(h)], env=env,
                         cwd=str(tree), check=True, capture_output=True, text=True)
    return float(json.loads(out.stdout.strip().splitlines()[-1]))


def compare(label: str, runs: list[tuple[str, Path, str]], repeats: int, cells: int,
            h: float) -> None:
    times: dict[str, list[float]] = {name: [] for name, _, _ in runs}
    for _ in range(repeats):
        for name, tree, what in runs:
            times[name].append(child_seconds(tree, what, cells, h))
    (a, _, _), (b, _, _) = runs
    ma, mb = statistics.median(times[a]), statistics.median(times[b])
    print(f"\n## {label}")
    for name in (a, b):
        print(f"- {name}: median {statistics.median(times[name]):.3f} s; all "
              + ", ".join(f"{t:.3f}" for t in times[name]))
    print(f"- ratio {b} / {a}: {mb / ma:.3f}")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--before", type=Path, required=True)
    ap.add_argument("--after", type=Path, default=Path("."))
    ap.add_argument("--cells", type=int, default=48)
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--h", type=float, default=0.05)
    args = ap.parse_args(argv)
    before, after = args.before.resolve(), args.after.resolve()
    print(f"# bench_compare {time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())} on "
          f"{platform.node()}, {os.cpu_count()} cores; h = {args.h}, {args.cells} paper cells "
          f"x 6 widths; {args.repeats} alternating repeats")
    print(f"# before: {before}\n# after:  {after}")
    compare(f"paper-sweep sample ({args.cells * 6} maps, summaries)",
            [("before", before, "sweep"), ("after", after, "sweep")], args.repeats, args.cells,
            args.h)
    compare(f"three whole maps at h = {args.h / 2} (compute_map)",
            [("before", before, "maps"), ("after", after, "maps")], args.repeats, args.cells,
            args.h)
    compare(f"contact forces: three maps at h = {args.h / 2}, off versus on (after)",
            [("forces off", after, "maps"), ("forces on", after, "maps_forces")], args.repeats,
            args.cells, args.h)
    return 0


if __name__ == "__main__":
    sys.exit(main())
