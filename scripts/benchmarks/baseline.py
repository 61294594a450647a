"""Kernels against the paper-style baseline, sweep throughput, and cost versus h (`make bench`).

Prints, in one run:
  1. compile or cache-load time of the kernels (kept out of every other timing);
  2. points/s of the Numba kernels on three maps (whole maps, warm, best of 3);
  3. points/s of the paper-style baseline (scripts/paper_baseline.py: least_squares on the
     vector loops, per point) on a random sample of the same maps' grid points, the ratio per
     point, and whether the two agree on each sampled point's class;
  4. maps/s of the sweep (shared finger fields, all threads) on a random sample of the paper's
     cells, and the projected time of the whole paper sweep;
  5. time versus grid spacing h (0.2, 0.1, 0.05, 0.025) for one cell's six maps.
"""
from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np

from .timing import best_of, header
from .workloads import ONE_CELL, THREE_MAPS, paper_cells, paper_sample, paper_widths

NAME = "baseline"


def add_arguments(ap) -> None:
    ap.add_argument("--baseline-points", type=int, default=120,
                    help="grid points per map solved by the baseline (random sample) [120]")
    ap.add_argument("--cells", type=int, default=96,
                    help="paper cells (x 6 widths = maps) timed for the sweep throughput [96]")
    ap.add_argument("--threads", type=int, default=None, help="Numba threads [all cores]")
    ap.add_argument("--h", type=float, default=0.05, help="grid spacing [0.05]")


def run(args) -> int:
    import numba

    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
    import paper_baseline  # scripts/paper_baseline.py, the reference (not a package)

    from sweep import __version__
    from sweep.compute.batch import SUMMARY_FIELDS, summarize_cells
    from sweep.compute.maps import compute_map, finger_offsets, map_grid
    from sweep.model import INFEASIBLE, Accuracy, Command, Design, Grid, Limits, Part

    if args.threads:
        numba.set_num_threads(args.threads)
    limits, accuracy = Limits(), Accuracy()
    n_points_column = list(SUMMARY_FIELDS).index("n_points")
    header(NAME)
    print(f"# sweep {__version__}; numba threads {numba.get_num_threads()}; accuracy: "
          f"reconfig_step {accuracy.reconfig_step} rad, root_tol {accuracy.root_tol}, "
          f"trajectory {accuracy.trajectory}")
    maps = [(Design(*d), Part(*p)) for d, p in THREE_MAPS]
    widths = paper_widths()

    t = time.perf_counter()
    compute_map(*maps[0], grid=Grid(h=0.4))
    summarize_cells(paper_cells()[0][:1], np.array([0.0]), Command(), 0.4, limits, accuracy)
    print(f"\n## compile or cache load (excluded below): {time.perf_counter() - t:.2f} s")

    print(f"\n## kernels vs paper-style baseline (h = {args.h}, same maps; baseline on "
          f"{args.baseline_points} random grid points per map)")
    print("| map | points | kernel points/s | baseline points/s | ratio | classes agree |")
    print("|---|---|---|---|---|---|")
    rng = np.random.default_rng(0)
    total_agree = total_compared = 0
    ratios = []
    for design, part in maps:
        grid = Grid(h=args.h)
        seconds = best_of(lambda d=design, p=part, g=grid: compute_map(d, p, grid=g))
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
              f"{kernel_rate / base_rate:,.0f}x | {agree}/{len(pick)} |", flush=True)
    print(f"\nper-point speed-up: {min(ratios):,.0f}x to {max(ratios):,.0f}x; "
          f"classes agree on {total_agree}/{total_compared} points")

    sample = paper_sample(args.cells)
    t = time.perf_counter()
    out = summarize_cells(sample, widths, Command(), args.h, limits, accuracy)
    seconds = time.perf_counter() - t
    n_maps = sample.shape[0] * widths.size
    points = out[..., n_points_column].sum()
    print(f"\n## sweep throughput (random sample of {sample.shape[0]} paper cells x "
          f"{widths.size} widths = {n_maps} maps, h = {args.h})")
    print(f"{n_maps / seconds:,.1f} maps/s, {points / seconds:,.0f} points/s; "
          f"projected full paper sweep (86,400 maps): {86_400 / (n_maps / seconds):,.0f} s")

    print("\n## time versus grid spacing (one cell: l1={} l2={} r1={} r2={} r={} mu={}, six "
          "widths)".format(*ONE_CELL))
    print("| h | points (6 maps) | seconds | ns per point |")
    print("|---|---|---|---|")
    cell = np.array([ONE_CELL])
    for h in (0.2, 0.1, 0.05, 0.025):
        seconds = best_of(lambda h=h: summarize_cells(cell, widths, Command(), h, limits,
                                                      accuracy), repeat=2)
        res = summarize_cells(cell, widths, Command(), h, limits, accuracy)
        pts = res[..., n_points_column].sum()
        print(f"| {h} | {pts:,.0f} | {seconds:.4f} | {seconds / pts * 1e9:,.0f} |")
    return 0
