"""Side-by-side speed of several source trees of sweep, in one run (a generalisation of
scripts/bench_compare.py to N trees). Each measurement is a fresh child process per tree
(bench_compare.child_seconds); the tree order rotates every repeat. Prints every repeat, the
medians and the ratios to the first tree.

    .venv/bin/python scripts/bench_trees.py maps|sweep NAME=TREE [NAME=TREE ...] [--h 0.025]
        [--repeats 9] [--cells 64]

On this machine sched_autogroup is on: `nice` alone does not give the benchmark priority over
other sessions' jobs; run it in its own session with a raised autogroup, e.g.
`setsid -w sh -c 'echo -10 > /proc/self/autogroup; exec nice -n -10 "$@"' _ .venv/bin/python
scripts/bench_trees.py ...` (docs/performance.md, 2026-11-24).
"""
from __future__ import annotations

import argparse
import statistics
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_compare import child_seconds  # noqa: E402


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("what", choices=("maps", "sweep"))
    ap.add_argument("trees", nargs="+", metavar="NAME=TREE")
    ap.add_argument("--h", type=float, default=0.05, help="sweep spacing; maps use h / 2")
    ap.add_argument("--repeats", type=int, default=9)
    ap.add_argument("--cells", type=int, default=64)
    args = ap.parse_args()
    trees = dict(t.split("=", 1) for t in args.trees)
    names = list(trees)
    times: dict[str, list[float]] = {k: [] for k in names}
    for rep in range(args.repeats):
        order = names[rep % len(names):] + names[:rep % len(names)]
        for k in order:
            times[k].append(child_seconds(Path(trees[k]).resolve(), args.what, args.cells,
                                          args.h))
    print(f"# {time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())} {args.what}, h = {args.h}, "
          f"{args.repeats} rotating repeats")
    first = statistics.median(times[names[0]])
    for k in names:
        med = statistics.median(times[k])
        print(f"{k:10s} median {med:.3f} s  ratio {med / first:.3f}  all "
              + ", ".join(f"{x:.3f}" for x in times[k]))
    return 0


if __name__ == "__main__":
    sys.exit(main())
