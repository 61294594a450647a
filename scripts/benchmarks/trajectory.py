"""What the sliding trajectory method (model-notes D16) costs next to grid8, side by side.

In one process, kernels loaded first (untimed), then --repeats rounds of the two methods (the
order swapped every round), for each workload of --what:
  - `sample`: --cells random cells of the paper's table (seed 0) x its 6 widths, through the
    sweep's shared-field path (summarize_cells);
  - `1200`: the 1,200 maps of issue P10 (l1 = 2, l2 = 1.6, every r1, r2, w; r in {0.4, 0.8} x
    every mu), the same path, one kernel call;
  - `map`: compute_map of the MODEL 8 crease map (2, 1.6, 0.16, 0.06, 1.2; r = 0.4, mu = 0.1).
Prints the median wall and CPU seconds (all threads) of each method, the ratios sliding / grid8
and every repeat. On a machine shared with other jobs the CPU time is the steadier figure
(run with NUMBA_NUM_THREADS=1 to compare CPU time per map).
"""
from __future__ import annotations

from .timing import header, print_side_by_side, side_by_side, timed
from .workloads import CREASE_MAP, issue_1200_flat, paper_sample, paper_widths

NAME = "trajectory"
METHODS = ["grid8", "sliding"]


def add_arguments(ap) -> None:
    ap.add_argument("--h", type=float, default=0.05, help="grid spacing [0.05]")
    ap.add_argument("--cells", type=int, default=64, help="paper sample size [64]")
    ap.add_argument("--repeats", type=int, default=5, help="rounds [5]")
    ap.add_argument("--what", default="sample,1200,map",
                    help="comma-separated workloads: sample, 1200, map [all three]")
    ap.add_argument("--reconfig-step", type=float, default=0.05,
                    help="accuracy.reconfig_step of both methods [0.05, configs/paper.yaml's]: "
                         "a cheaper finger field makes the trajectories' share larger")


def run(args) -> int:
    from sweep.compute.batch import summarize_cells
    from sweep.compute.maps import compute_map
    from sweep.model import Accuracy, Command, Design, Grid, Limits, Part

    what = args.what.split(",")
    unknown = set(what) - {"sample", "1200", "map"}
    if unknown:
        raise SystemExit(f"bench.py trajectory: unknown workload {sorted(unknown)[0]!r} in "
                         "--what (sample, 1200, map)")
    h = args.h
    workloads = {}
    if "sample" in what:
        sample, widths = paper_sample(args.cells, seed=0, in_table_order=False), paper_widths()
        workloads[f"sample ({len(sample)} paper cells x 6 widths), h = {h}, "
                  f"reconfig_step = {args.reconfig_step}"] = (
            lambda acc: summarize_cells(sample, widths, Command(), h, Limits(), acc))
    if "1200" in what:
        c1200, w1200 = issue_1200_flat()
        workloads[f"1200 (the 1,200 maps of issue P10), h = {h}, "
                  f"reconfig_step = {args.reconfig_step}"] = (
            lambda acc: summarize_cells(c1200, w1200, Command(), h, Limits(), acc))
    if "map" in what:
        d, p = Design(*CREASE_MAP[0]), Part(*CREASE_MAP[1])
        workloads[f"map (compute_map, the crease map), h = {h}"] = (
            lambda acc: compute_map(d, p, Command(), Grid(h=h), accuracy=acc))
    header(NAME)
    for label, work in workloads.items():
        for m in METHODS:  # load (or compile) the kernels of both methods: untimed
            work(Accuracy(reconfig_step=args.reconfig_step, trajectory=m))
        times = side_by_side(METHODS, lambda m, work=work: timed(
            lambda: work(Accuracy(reconfig_step=args.reconfig_step, trajectory=m))),
            args.repeats)
        print_side_by_side(label, times)
    return 0
