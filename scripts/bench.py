"""The benchmarks of sweep, one subcommand each (docs/performance.md, "How to benchmark").

    .venv/bin/python scripts/bench.py SUBCOMMAND [OPTIONS]     # or: make bench ARGS="..."
    .venv/bin/python scripts/bench.py SUBCOMMAND --help        # what it measures, its options

Every subcommand prints the date, the machine, the load and its own command line first; it
compiles or loads the kernels before timing; side-by-side subcommands time their variants in one
run, in rounds whose order rotates, and print the ratios with the absolute seconds beside them.
Compare ratios, not absolute times from different runs: this machine's speed drifts. For both
cores on a shared machine, run in a session of its own with a raised autogroup:

    setsid -w sh -c 'echo -10 > /proc/self/autogroup; exec nice -n -10 "$@"' _ \\
        .venv/bin/python scripts/bench.py SUBCOMMAND ...
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from benchmarks import (baseline, baseline_map, collision, compilation, effects,  # noqa: E402
                        manipulation, scale, schedule, trajectory, trees)

SUBCOMMANDS = [baseline, baseline_map, compilation, collision, effects, manipulation, trajectory,
               trees, scale, schedule]


def parser() -> argparse.ArgumentParser:
    ap = argparse.ArgumentParser(prog="bench.py", description=__doc__.split("\n\n")[0],
                                 epilog=__doc__.split("\n\n", 1)[1],
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = ap.add_subparsers(dest="subcommand", required=True, metavar="SUBCOMMAND")
    for module in SUBCOMMANDS:
        doc = module.__doc__.strip()
        p = sub.add_parser(module.NAME, help=doc.splitlines()[0], description=doc,
                           formatter_class=argparse.RawDescriptionHelpFormatter)
        module.add_arguments(p)
        p.set_defaults(run=module.run)
    return ap


def main(argv=None) -> int:
    args = parser().parse_args(argv)
    return args.run(args)


if __name__ == "__main__":
    sys.exit(main())
