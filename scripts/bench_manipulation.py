"""What the manipulation metric (MODEL 10, Scenarios A and B) adds to the caging sweep's time.

In one process, on the same items of configs/paper.yaml, alternating: the caging summaries alone
(`runner.compute_items`) versus the summaries with the manipulation data
(`runner.compute_items_with_manipulation`: Scenario A per cell, Scenario B entries reduced into
per-part hull reductions). Kernels are compiled or loaded first. Prints every repeat and the
ratio of the medians.

    .venv/bin/python scripts/bench_manipulation.py [--groups 6] [--repeats 3]
"""
from __future__ import annotations

import argparse
import os
import platform
import statistics
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]


def main(argv=None) -> int:
    from sweep.runner import compute_items, compute_items_with_manipulation
    from sweep.scene import load_scene

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--groups", type=int, default=6,
                    help="geometry groups (l1, l2, r) of the paper sweep, spread evenly")
    ap.add_argument("--repeats", type=int, default=3)
    args = ap.parse_args(argv)
    scene = load_scene(ROOT / "configs" / "paper.yaml")
    picks = np.linspace(0, scene.n_groups - 1, args.groups).round().astype(int)
    ranges = [(int(g) * scene.group_size, (int(g) + 1) * scene.group_size) for g in picks]
    n_maps = sum(b - a for a, b in ranges) * len(scene.values["w"])
    print(f"# bench_manipulation {time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())} on "
          f"{platform.node()}, {os.cpu_count()} cores; {len(ranges)} geometry groups of "
          f"configs/paper.yaml ({n_maps} maps, h = {scene.h})")
    a, b = ranges[0]
    compute_items(scene, a, a + 1)                       # compile / load the kernels
    compute_items_with_manipulation(scene, a, a + 1)
    times = {"caging only": [], "caging + manipulation": []}
    for _ in range(args.repeats):
        for name in times:
            t = time.perf_counter()
            for a, b in ranges:
                if name == "caging only":
                    compute_items(scene, a, b)
                else:
                    compute_items_with_manipulation(scene, a, b)
            times[name].append(time.perf_counter() - t)
    for name, values in times.items():
        print(f"- {name}: median {statistics.median(values):.3f} s; all "
              + ", ".join(f"{v:.3f}" for v in values))
    base, with_m = (statistics.median(v) for v in times.values())
    print(f"- ratio (caging + manipulation) / caging only: {with_m / base:.3f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
