"""Speed benchmark: kernels vs a paper-style least_squares baseline, sweep throughput, cost vs h.

Prints, in one run:
  1. compile/cache-load time of the kernels (kept out of every other timing);
  2. points/s of the Numba kernels on a few maps (whole maps, warm);
  3. points/s of the paper-style baseline (scripts/paper_baseline.py) on a random sample of the
     same maps' grid points, the speed ratio per point, and the agreement of point classes;
  4. maps/s of the sweep (shared finger fields, all threads) on a random sample of the paper's
     cells;
  5. time versus grid spacing h (0.2, 0.1, 0.05, 0.025) for one cell's six maps.

    .venv/bin/python scripts/bench.py [--baseline-points 120] [--cells 96] [--threads N]
"""
from __future__ import annotations

import argparse
import itertools
import math
import os
import platform
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import paper_baseline  # noqa: E402  (scripts/ is not a package)

from sweep import __version__  # noqa: E402
from sweep.batch import summarize_cells  # noqa: E402
from sweep.maps import compute_map, finger_offsets, map_grid  # noqa: E402
from sweep.model import (INFEASIBLE, Accuracy, Command, Design,  # noqa: E402
                         Grid, Limits, Part)

BENCH_MAPS = [  # (design, part): the reference design and two contrasting ones
    (Design(2.0, 1.6, 0.2, 0.14, 0.8), Part(0.4, 0.4)),
    (Design(1.0, 0.8, 0.04, 0.18, 1.2), Part(0.8, 0.1)),
    (Design(0.6, 0.4, 0.12, 0.1, 0.4), Part(1.2, 1.0)),
]
PAPER_AXES = dict(l1=(0.4, 2.0, 0.2), l2=(0.4, 1.6, 0.4), r1=(0.04, 0.20, 0.04),
                  r2=(0.02, 0.18, 0.04), w=(0.0, 2.0, 0.4), r=(0.4, 1.6, 0.4), mu=(0.1, 1.0, 0.3))


def axis(lower, upper, step):
    n = int(math.floor((upper - lower) / step + 1e-9))
    return [lower + i * step for i in range(n + 1)]


def paper_cells():
    a = {k: axis(*v) for k, v in PAPER_AXES.items()}
    cells = np.array(list(itertools.product(a["l1"], a["l2"], a["r1"], a["r2"], a["r"], a["mu"])))
    return cells, np.array(a["w"])


def machine():
    cpu = "unknown cpu"
    try:
        for line in open("/proc/cpuinfo"):
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    return (f"{platform.node()} | {cpu} | {os.cpu_count()} cores | "
            f"Python {platform.python_version()}")


def time_call(fn, repeat=3):
    best = math.inf
    for _ in range(repeat):
        t = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - t)
    return best


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--baseline-points", type=int, default=120,
                        help="grid points per map solved by the baseline (random sample)")
    parser.add_argument("--cells", type=int, default=96,
                        help="paper cells (x 6 widths = maps) timed for the sweep throughput")
    parser.add_argument("--threads", type=int, default=None)
    parser.add_argument("--h", type=float, default=0.05)
    args = parser.parse_args(argv)
    import numba

    if args.threads:
        numba.set_num_threads(args.threads)
    limits, accuracy = Limits(), Accuracy()
    print(f"# sweep {__version__} bench, {time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}")
    print(f"# machine: {machine()}; numba threads {numba.get_num_threads()}")
    print(f"# accuracy: reconfig_step {accuracy.reconfig_step} rad, root_tol {accuracy.root_tol}")

    t = time.perf_counter()
    compute_map(*BENCH_MAPS[0], grid=Grid(h=0.4))
    summarize_cells(paper_cells()[0][:1], np.array([0.0]), Command(), 0.4, limits, accuracy)
    print(f"\n## compile or cache load (excluded below): {time.perf_counter() - t:.2f} s")

    print(f"\n## kernels vs paper-style baseline (h = {args.h}, same maps; baseline on "
          f"{args.baseline_points} random grid points per map)")
    print("| map | points | kernel points/s | baseline points/s | ratio | classes agree |")
    print("|---|---|---|---|---|---|")
    rng = np.random.default_rng(0)
    total_agree = total_compared = 0
    ratios = []
    for design, part in BENCH_MAPS:
        grid = Grid(h=args.h)
        seconds = time_call(lambda d=design, p=part, g=grid: compute_map(d, p, grid=g))
        m = compute_map(design, part, grid=grid)
        n = m.fields["energy"].size
        kernel_rate = n / seconds
        g = map_grid(design, part, grid)
        dx_left, dx_right = finger_offsets(g.i, design.w, g.h)
        pick = rng.choice(n, size=min(args.baseline_points, n), replace=False)
        agree = 0
        t = time.perf_counter()
        for p in pick:
            j, i = divmod(int(p), g.x.size)
            modes = []
            for dxs in (dx_left, dx_right):
                out = paper_baseline.baseline_finger(
                    float(dxs[i]), float(g.y[j]), design.l1, design.l2, design.r1, design.r2,
                    part.r, part.mu, limits.theta2_min, limits.theta2_max,
                    accuracy.reconfig_step, accuracy.root_tol)
                modes.append(out[0])
            base_class = (INFEASIBLE if -1 in modes
                          else paper_baseline.point_class(modes[0], modes[1]))
            agree += int(base_class == m.fields["point_class"][j, i])
        base_rate = len(pick) / (time.perf_counter() - t)
        ratios.append(kernel_rate / base_rate)
        total_agree += agree
        total_compared += len(pick)
        label = (f"l1={design.l1} l2={design.l2} r1={design.r1} r2={design.r2} w={design.w}; "
                 f"r={part.r} mu={part.mu}")
        print(f"| {label} | {n:,} | {kernel_rate:,.0f} | {base_rate:,.1f} | "
              f"{kernel_rate / base_rate:,.0f}x | {agree}/{len(pick)} |")
    print(f"\nper-point speed-up: {min(ratios):,.0f}x to {max(ratios):,.0f}x; "
          f"classes agree on {total_agree}/{total_compared} points")

    cells, widths = paper_cells()
    pick = np.random.default_rng(1).choice(len(cells), size=min(args.cells, len(cells)),
                                           replace=False)
    sample = cells[np.sort(pick)]
    t = time.perf_counter()
    out = summarize_cells(sample, widths, Command(), args.h, limits, accuracy)
    seconds = time.perf_counter() - t
    n_maps = sample.shape[0] * widths.size
    points = out[..., list(summarize_fields()).index("n_points")].sum()
    print(f"\n## sweep throughput (random sample of {sample.shape[0]} paper cells x "
          f"{widths.size} widths = {n_maps} maps, h = {args.h})")
    print(f"{n_maps / seconds:,.1f} maps/s, {points / seconds:,.0f} points/s; "
          f"projected full paper sweep (86,400 maps): {86_400 / (n_maps / seconds):,.0f} s")

    print("\n## time versus grid spacing (one cell: l1=1.2 l2=0.8 r1=0.12 r2=0.1 r=0.8 "
          "mu=0.4, six widths)")
    print("| h | points (6 maps) | seconds | ns per point |")
    print("|---|---|---|---|")
    cell = np.array([[1.2, 0.8, 0.12, 0.1, 0.8, 0.4]])
    for h in (0.2, 0.1, 0.05, 0.025):
        seconds = time_call(lambda h=h: summarize_cells(cell, widths, Command(), h, limits,
                                                    accuracy), repeat=2)
        res = summarize_cells(cell, widths, Command(), h, limits, accuracy)
        pts = res[..., list(summarize_fields()).index("n_points")].sum()
        print(f"| {h} | {pts:,.0f} | {seconds:.4f} | {seconds / pts * 1e9:,.0f} |")
    return 0


def summarize_fields():
    from sweep.batch import SUMMARY_FIELDS

    return SUMMARY_FIELDS


if __name__ == "__main__":
    sys.exit(main())
