"""finger_collision against the base model in the sweep, side by side in one run (issue P12).

Two workloads, summaries only, as `sweep run` computes them:
  - the paper sample: --cells random cells of the paper's table (seed 1) x 6 widths, one kernel
    call (64 cells = 384 maps; `--cells 96` is the sample of `bench.py baseline`);
  - the 1,200 maps of the issue: the 150 designs with l1 = 2, l2 = 1.6 (all r1, r2, w), parts
    r in {0.4, 0.8} x all four mu, one kernel call per geometry group (l1, l2, r) of 100 cells,
    as the runner's sub-chunks.
Kernels of both scenes are compiled or loaded first; then --repeats rounds time both scenes in
this process, the order swapped every round. Prints every repeat, the medians and the ratio
finger_collision / base.
"""
from __future__ import annotations

from .timing import header, print_side_by_side, side_by_side, timed
from .workloads import issue_1200_groups, paper_sample, paper_widths

NAME = "collision"


def add_arguments(ap) -> None:
    ap.add_argument("--repeats", type=int, default=7, help="rounds [7]")
    ap.add_argument("--h", type=float, default=0.05, help="grid spacing [0.05]")
    ap.add_argument("--cells", type=int, default=64, help="paper sample size [64]")


def run(args) -> int:
    from sweep.compute.batch import summarize_cells
    from sweep.model import Accuracy, Command, Effects, Limits

    scenes = {"base": Effects(), "finger_collision": Effects(finger_collision=True)}
    header(NAME)
    widths = paper_widths()
    workloads = ((f"paper sample ({args.cells} cells x 6 widths = {6 * args.cells} maps), "
                  f"h = {args.h}", [paper_sample(args.cells)]),
                 (f"issue's 1,200 maps (l1 = 2, l2 = 1.6), h = {args.h}", issue_1200_groups()))
    for label, groups in workloads:
        for effects in scenes.values():  # compile or load the kernels of both scenes
            summarize_cells(groups[0][:1], widths, Command(), 0.1, Limits(), Accuracy(),
                            effects)

        def measure(name, groups=groups):
            def sweep_groups():
                for cells in groups:
                    summarize_cells(cells, widths, Command(), args.h, Limits(), Accuracy(),
                                    scenes[name])
            return timed(sweep_groups)

        print_side_by_side(label, side_by_side(list(scenes), measure, args.repeats))
    return 0
