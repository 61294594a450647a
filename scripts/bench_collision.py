"""finger_collision against the base model in the sweep, side by side in one run (issue P12).

Two workloads, both summaries only, as `sweep run` computes them:
- the paper sample of scripts/bench_compare.py: 64 random cells of the paper table (seed 1)
  x 6 widths = 384 maps, one kernel call (`--cells 96`: the sample of scripts/bench.py);
- the issue's 1,200 maps: the 150 designs with l1 = 2, l2 = 1.6 (all r1, r2, w), parts
  r in {0.4, 0.8} x all four mu, one kernel call per geometry group (l1, l2, r) of 100 cells,
  as the runner's sub-chunks.
Each repeat times both scenes in one process (kernels compiled or loaded first), the order
alternating; prints every repeat, the medians and the ratio collision / base.

    .venv/bin/python scripts/bench_collision.py [--repeats 7] [--h 0.05] [--cells 64]

On this machine run it in its own session with a raised autogroup (docs/performance.md):
`setsid -w sh -c 'echo -10 > /proc/self/autogroup; exec nice -n -10 "$@"' _ .venv/bin/python
scripts/bench_collision.py`.
"""
from __future__ import annotations

import argparse
import statistics
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench import PAPER_AXES, axis, paper_cells  # noqa: E402

from sweep.batch import summarize_cells  # noqa: E402
from sweep.model import Accuracy, Command, Effects, Limits  # noqa: E402

SCENES = {"base": Effects(), "finger_collision": Effects(finger_collision=True)}


def paper_sample(n_cells: int = 64):
    cells, widths = paper_cells()
    pick = np.random.default_rng(1).choice(len(cells), size=n_cells, replace=False)
    return [cells[np.sort(pick)]], widths


def issue_1200():
    """The 1,200 maps of issue P12 in the runner's order: one group (l1, l2, r) per call."""
    a = {k: axis(*v) for k, v in PAPER_AXES.items()}
    groups = [np.array([(2.0, 1.6, r1, r2, r, mu) for r1 in a["r1"] for r2 in a["r2"]
                        for mu in a["mu"]]) for r in (0.4, 0.8)]
    return groups, np.array(a["w"])


def seconds(groups, widths, effects, h) -> float:
    t = time.perf_counter()
    for cells in groups:
        summarize_cells(cells, widths, Command(), h, Limits(), Accuracy(), effects)
    return time.perf_counter() - t


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=7)
    ap.add_argument("--h", type=float, default=0.05)
    ap.add_argument("--cells", type=int, default=64, help="paper sample size (bench.py: 96)")
    args = ap.parse_args()
    print(f"# bench_collision {time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}, "
          f"h = {args.h}, {args.repeats} alternating repeats")
    for label, (groups, widths) in ((f"paper sample ({args.cells} cells x 6 widths = "
                                     f"{6 * args.cells} maps)", paper_sample(args.cells)),
                                    ("issue's 1,200 maps (l1 = 2, l2 = 1.6)", issue_1200())):
        for effects in SCENES.values():  # compile or load the kernels of both scenes
            summarize_cells(groups[0][:1], widths, Command(), 0.1, Limits(), Accuracy(),
                            effects)
        times = {name: [] for name in SCENES}
        for rep in range(args.repeats):
            names = list(SCENES) if rep % 2 == 0 else list(SCENES)[::-1]
            for name in names:
                times[name].append(seconds(groups, widths, SCENES[name], args.h))
        print(f"\n## {label}")
        for name in SCENES:
            print(f"- {name}: median {statistics.median(times[name]):.3f} s; all "
                  + ", ".join(f"{t:.3f}" for t in times[name]))
        ratio = statistics.median(times["finger_collision"]) / statistics.median(times["base"])
        print(f"- ratio finger_collision / base: {ratio:.3f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
