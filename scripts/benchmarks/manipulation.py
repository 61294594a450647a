"""What the manipulation metric (MODEL 10, Scenarios A and B, and Scenario C) adds to the caging
sweep's time.

In one process, on the same items of a config (--config, default configs/paper.yaml; --groups
geometry groups (l1, l2, r), spread evenly over the sweep), the order rotating every round: the
caging summaries alone (`runner.compute_items`), the summaries with the manipulation data
(`runner.compute_items_with_manipulation`: Scenario A per cell, Scenario B entries reduced into
per-part hulls) and, with --scenario-c MU_LOW, the same with Scenario C (friction modulation)
too. The config's own outputs.scenario_c is ignored. Kernels are compiled or loaded first.
Prints every repeat and the ratios of the medians to the caging sweep alone.
"""
from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np

from .timing import header, medians, print_side_by_side, side_by_side, timed

NAME = "manipulation"
ROOT = Path(__file__).resolve().parents[2]


def add_arguments(ap) -> None:
    ap.add_argument("--groups", type=int, default=6,
                    help="geometry groups (l1, l2, r) of the paper sweep, spread evenly [6]")
    ap.add_argument("--repeats", type=int, default=3, help="rounds [3]")
    ap.add_argument("--config", type=Path, default=ROOT / "configs" / "paper.yaml",
                    help="a config with `outputs: {manipulation: true}` [configs/paper.yaml]")
    ap.add_argument("--scenario-c", type=float, default=None, metavar="MU_LOW",
                    help="also time the manipulation metric with Scenario C at this low "
                         "friction [off]")


def run(args) -> int:
    from sweep.runs.runner import compute_items, compute_items_with_manipulation
    from sweep.config.parse import load_scene

    scene = dataclasses.replace(load_scene(args.config), scenario_c_mu_low=None)
    with_c = dataclasses.replace(scene, scenario_c_mu_low=args.scenario_c)
    picks = np.linspace(0, scene.n_groups - 1, args.groups).round().astype(int)
    ranges = [(int(g) * scene.group_size, (int(g) + 1) * scene.group_size) for g in picks]
    n_maps = sum(b - a for a, b in ranges) * len(scene.values["w"])
    header(NAME)
    a, _ = ranges[0]
    compute_items(scene, a, a + 1)                       # compile or load the kernels
    compute_items_with_manipulation(scene, a, a + 1)
    compute = {"caging only": (compute_items, scene),
               "caging + manipulation": (compute_items_with_manipulation, scene)}
    if args.scenario_c is not None:
        compute_items_with_manipulation(with_c, a, a + 1)
        compute[f"caging + manipulation + Scenario C (mu_low {args.scenario_c:g})"] = (
            compute_items_with_manipulation, with_c)

    def measure(name):
        fn, sc = compute[name]
        return timed(lambda: [fn(sc, a, b) for a, b in ranges])

    times = side_by_side(list(compute), measure, args.repeats)
    print_side_by_side(f"{len(ranges)} geometry groups of {args.config.name} ({n_maps} maps, "
                       f"h = {scene.h})", times)
    if args.scenario_c is not None:  # what `make run` would pay for C: against A and B alone
        (_, (wall_m, cpu_m)), (name, (wall_c, cpu_c)) = list(medians(times).items())[1:]
        print(f"- ratio {name} / caging + manipulation: {wall_c / wall_m:.3f} "
              f"(cpu {cpu_c / cpu_m:.3f})")
    return 0
