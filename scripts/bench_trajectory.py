"""What the sliding trajectory method (model-notes D16) costs next to grid8, side by side.

In one process, kernels loaded first (untimed), then `--repeats` rounds alternating the two
methods (the order swapped every round), each timing:

  - `sample`: the paper sample, `--cells` random cells (l1, l2, r1, r2, r, mu) of the paper's
    table x its 6 palm widths, through the sweep's shared-field path (summarize_cells);
  - `1200`: the 1,200 maps of issue P10 (l1 = 2, l2 = 1.6, every r1, r2, w; r in {0.4, 0.8} x
    every mu), the same path;
  - `map`: compute_map of the MODEL 8 crease map (2, 1.6, 0.16, 0.06, 1.2; r = 0.4, mu = 0.1).

Prints the median wall and CPU seconds (all threads) of each method, the ratios sliding / grid8
and every repeat. On a machine shared with other jobs the CPU time is the steadier figure.

    .venv/bin/python scripts/bench_trajectory.py [--h 0.05] [--cells 64] [--repeats 5]
        [--what sample,1200,map]
"""
from __future__ import annotations

import argparse
import itertools
import statistics
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench import machine, paper_cells  # noqa: E402

from sweep.batch import summarize_cells  # noqa: E402
from sweep.maps import compute_map  # noqa: E402
from sweep.model import Accuracy, Command, Design, Grid, Limits, Part  # noqa: E402

METHODS = ("grid8", "sliding")


def issue_cells():
    r1 = (0.04, 0.08, 0.12, 0.16, 0.2)
    r2 = (0.02, 0.06, 0.1, 0.14, 0.18)
    rows = [(2.0, 1.6, a, b, r, mu) for r, mu in itertools.product((0.4, 0.8), (0.1, 0.4, 0.7, 1.0))
            for a in r1 for b in r2]
    return np.array(rows), np.array([0.0, 0.4, 0.8, 1.2, 1.6, 2.0])


def workloads(what, h, n_cells):
    cells, widths = paper_cells()
    rng = np.random.default_rng(0)
    sample = cells[rng.choice(len(cells), size=n_cells, replace=False)]
    out = {}
    if "sample" in what:
        out["sample"] = lambda acc: summarize_cells(sample, widths, Command(), h, Limits(), acc)
    if "1200" in what:
        c1200, w1200 = issue_cells()
        out["1200"] = lambda acc: summarize_cells(c1200, w1200, Command(), h, Limits(), acc)
    if "map" in what:
        d, p = Design(2.0, 1.6, 0.16, 0.06, 1.2), Part(0.4, 0.1)
        out["map"] = lambda acc: compute_map(d, p, Command(), Grid(h=h), accuracy=acc)
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--h", type=float, default=0.05)
    ap.add_argument("--cells", type=int, default=64)
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--what", default="sample,1200,map")
    args = ap.parse_args(argv)
    print(f"# {time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}  {machine()}  "
          f"h = {args.h}  repeats = {args.repeats}")
    for name, work in workloads(args.what.split(","), args.h, args.cells).items():
        for m in METHODS:  # load (or compile) the kernels of both methods: untimed
            work(Accuracy(trajectory=m))
        wall = {m: [] for m in METHODS}
        cpu = {m: [] for m in METHODS}
        for k in range(args.repeats):
            for m in (METHODS if k % 2 == 0 else METHODS[::-1]):
                started, started_cpu = time.perf_counter(), time.process_time()
                work(Accuracy(trajectory=m))
                wall[m].append(time.perf_counter() - started)
                cpu[m].append(time.process_time() - started_cpu)
        for label, times in (("wall", wall), ("cpu", cpu)):
            med = {m: statistics.median(t) for m, t in times.items()}
            print(f"{name:7s} {label:4s} grid8 {med['grid8']:.3f} s  sliding {med['sliding']:.3f} s"
                  f"  ratio {med['sliding'] / med['grid8']:.3f}")
            for m in METHODS:
                print(f"             {m:8s} " + ", ".join(f"{t:.3f}" for t in times[m]))
    return 0


if __name__ == "__main__":
    sys.exit(main())
