"""The subcommands of `scripts/bench.py`, one module each (docs/performance.md, "How to benchmark").

workloads  the maps and cells the benchmarks time (pure NumPy: no `sweep` import, so a child
           process of `bench.py trees` can use it against any tree)
timing     header (date, machine, command), side-by-side timing in rounds, medians and ratios
others     one subcommand each: `NAME`, `add_arguments(parser)`, `run(args) -> exit code`, and
           the module docstring is the subcommand's --help
"""
