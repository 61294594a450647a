"""The command line: the `sweep` group and its commands, one module per command (or small group).

    map.py       sweep map              one energy map
    run.py       sweep run, merge, refine
    slurm.py     sweep slurm, status    a sweep as an HPC array job
    results.py   sweep top, show        what a store holds
    report.py    sweep report           the paper's experiments from one store, or two scenes
    accuracy.py  sweep accuracy         accuracy settings versus time on a config's maps
    optimize.py  sweep optimize         the best design between the grid's points
    schedule.py  sweep schedule         variable geometry in the grasp: draw in, then hold
    common.py    what the commands share: error handling (`user_errors`), `SweepCommand`,
                 `SweepGroup`, parameter types and options (CONFIG, THREADS, WAIT, ...)

Command modules import `common` and the layers below, never each other (tests/test_layers.py).
Only click is imported at start-up; each command imports its computation when it runs, so Ctrl-C
in the first second is handled like any other and `sweep --help` stays quick.
"""
from __future__ import annotations

import click

from .. import __version__
from . import accuracy, map, optimize, report, results, run, schedule, slurm
from .common import SweepGroup


@click.group(cls=SweepGroup,
             context_settings=dict(help_option_names=["-h", "--help"], max_content_width=100))
@click.version_option(__version__, prog_name="sweep")
def main():
    """Friction-based potential energy maps for two-finger tendon-pulley grippers.

    `sweep map` computes one map (one design, one part, one command); the sweep commands run the
    paper's design-space search from a YAML config, on one machine or as an HPC array job.
    """


#: Every command, once.
COMMANDS = (map.map_command, run.run, slurm.slurm_command, slurm.status, run.merge, run.refine,
            results.top, results.show, report.report, accuracy.accuracy,
            optimize.optimize, schedule.schedule)


def register(group: click.Group) -> None:
    """Add every command to `group` (`main`; the tests build plain groups with it)."""
    for command in COMMANDS:
        group.add_command(command)


register(main)
