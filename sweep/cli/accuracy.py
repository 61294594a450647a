"""`sweep accuracy CONFIG`: what accuracy costs in time on the user's own config
(sweep/runs/accuracy.py, sweep/report/accuracy.py, docs/accuracy.md)."""
from __future__ import annotations

import math
import shlex
import sys
import time
from pathlib import Path

import click

from .common import CONFIG, FOLDER_OUT, PROGRESS, SweepCommand, UserError, check_path


@click.command("accuracy", cls=SweepCommand,
               short_help="Accuracy settings versus time on a config's maps.")
@click.argument("config", type=CONFIG)
@click.option("--sample", "n_sample", type=int, default=None,
              help="Halton-spread design cells in the sample (each part's best cell is "
                   "always added) [default: 24].")
@click.option("--out", type=FOLDER_OUT, default=None,
              help="Directory for accuracy.md, .csv, .png and the resumable work files "
                   "[default: results/accuracy-<config name>].")
@click.option("--map", "maps", multiple=True, metavar="L1,L2,R1,R2,W,R,MU",
              help="Also show this map's convergence as h halves, on its own (repeatable).")
@PROGRESS
def accuracy(config, n_sample, out, maps, progress):
    """Run a ladder of accuracy settings (h, reconfig_step, root_tol, trajectory method) on
    a deterministic sample of CONFIG's maps against a reference one halving finer than the
    finest rung (and say whether the reference itself has converged); show how each
    trajectory method converges as h halves; write tables (markdown + CSV) and plots, and
    name the recommended setting: the cheapest whose best design per part equals the
    reference's. Resumes if killed."""
    from ..report.accuracy import write_outputs
    from ..runs.refine import refine_designs
    from ..runs.accuracy import (DEFAULT_SAMPLE, check_sample, parse_witness, run_study,
                                 work_dir_key)
    from ..model import ModelInputError
    from ..files import make_parent

    given = n_sample is not None
    n_sample = DEFAULT_SAMPLE if n_sample is None else n_sample
    try:
        check_sample(n_sample)
        witnesses = [parse_witness(m) for m in maps]
    except ModelInputError as exc:
        raise UserError(str(exc)) from None
    n_cells = math.prod(len(config.values[a]) for a in ("l1", "l2", "r1", "r2"))
    if out is None:    # the default is checked like a given --out
        out = Path("results") / f"accuracy-{config.name}"
        check_path(out, "folder-out", "--out (default)")
    work = out / f"work-{work_dir_key(config, n_sample)}"
    make_parent(work / "x")     # an unwritable --out fails here, in one line, before any work
    from tqdm import tqdm

    bar = tqdm(total=1, desc="accuracy", unit="step", disable=not progress,
               file=sys.stderr, dynamic_ncols=True)

    def tell(done, total, label):
        bar.total = total
        bar.n = done
        bar.set_postfix_str(label)
        bar.refresh()

    started = time.perf_counter()
    study = run_study(config, n_sample, work, tell, witnesses, refine_designs)
    bar.close()
    words = ["sweep", "accuracy", config.path or config.name]
    if n_sample != DEFAULT_SAMPLE:
        words += ["--sample", str(n_sample)]
    for m in maps:
        words += ["--map", m]
    paths = write_outputs(study, out, shlex.join(words), time.perf_counter() - started)
    if given and n_sample > n_cells:
        click.echo(f"note: --sample {n_sample} is more than the config's {n_cells} design cells "
                   "(l1, l2, r1, r2): every cell was sampled")
    rec = study.recommended
    click.echo(f"recommended: {rec['setting']} (h = {rec['h']:g}, reconfig_step = "
               f"{rec['reconfig_step']:g}, root_tol = {rec['root_tol']:g}, "
               f"{rec['trajectory']})")
    for p in paths:
        click.echo(f"wrote {p}")
