"""Sweep commands of the CLI: run, slurm, status, merge, top, show, report.

Each command is declared once, here, as a click command (`COMMANDS`); `register(group)` adds them to
a group (`sweep.cli.main` does so). Each is a thin layer over `sweep.config.scene`,
`sweep.runs.runner`, `sweep.runs.rundir`, `sweep.storage.store` and `sweep.runs.slurm`. A config is
loaded and validated by the CONFIG argument's type, before anything is written; errors reach the
user through `sweep.cli_base.user_errors` (one line, exit code 2; Ctrl-C and SIGTERM exit 130).
"""
from __future__ import annotations

import errno
import shutil
import sys
from pathlib import Path

import click

from .cli_base import (EXIT_INTERRUPTED, SweepCommand, SweepGroup, UserError, interrupted_message,
                       real_path)


class SceneParam(click.ParamType):
    """A YAML sweep config, loaded, validated and expanded into a `sweep.config.scene.Scene`."""

    name = "config"

    def convert(self, value, param, ctx):
        from .model import ModelInputError
        from .config.scene import Scene, load_scene

        if isinstance(value, Scene):
            return value
        try:
            scene = load_scene(value)
        except ModelInputError as exc:
            # a bad config is not a usage mistake: one line naming the file and key, exit 2
            msg = str(exc)
            if not msg.startswith((str(value), Path(value).name)):
                msg = f"{value}: {msg}"
            raise UserError(msg) from None
        return scene


CONFIG = SceneParam()
PATH = click.Path(path_type=Path)
FILE = click.Path(dir_okay=False, path_type=Path)
WAIT = click.option("--wait", is_flag=True,
                    help="If another sweep is writing the same output, wait for it instead of "
                         "stopping at once.")
THREADS = click.option("--threads", type=int, default=None,
                       help="Numba threads (default: SLURM_CPUS_PER_TASK, else every core).")


# ---------------------------------------------------------------------------------------------
@click.command("run", cls=SweepCommand, short_help="Compute a sweep (one machine, or one chunk).")
@click.argument("config", type=CONFIG)
@click.option("--out", type=PATH, required=True,
              help="Results store (.h5) to write; with --chunks, the run directory.")
@click.option("--chunk", type=int, default=None,
              help="Which chunk to compute, 0..N-1 (default: from the array job's environment).")
@click.option("--chunks", type=int, default=None,
              help="Split the sweep into N chunks and compute one (cluster runs).")
@THREADS
@click.option("--progress/--no-progress", default=True, show_default=True,
              help="Progress bar on stderr (maps done, maps/s, ETA).")
@click.option("--restart", is_flag=True,
              help="Discard finished sub-chunks of an earlier run instead of resuming.")
@click.option("--overwrite", is_flag=True,
              help="Replace an existing results file of another config.")
@click.option("--keep-parts", is_flag=True,
              help="Keep the RESULTS.parts/ work directory after assembling the store.")
@WAIT
def run(config, out, chunk, chunks, threads, progress, restart, overwrite, keep_parts, wait):
    """Compute a sweep: the whole of it into one store, or one chunk of it into a run directory.

    \b
    One machine:   sweep run configs/paper.yaml --out paper.h5
    One chunk:     sweep run configs/paper.yaml --out runs/paper --chunk 3 --chunks 64

    Every core is used unless --threads (or SLURM_CPUS_PER_TASK) says otherwise. Finished
    sub-chunks are written as they complete into a work directory (`RESULTS.parts/`, or
    `DIR/parts/` for a chunk); Ctrl-C, a kill or a time limit loses at most the sub-chunk in
    flight, and rerunning the same command resumes. The results are bit-identical to an
    uninterrupted run. The final file appears (atomically) only when complete.

    With --chunks N and no --chunk, the chunk index comes from the array job:
    SLURM_ARRAY_TASK_ID or PBS_ARRAY_INDEX (0..N-1), SGE_TASK_ID or LSB_JOBINDEX (1..N).
    """
    from .runs import runner
    from .outputs import OutputError
    from .runs.rundir import RunDir, SingleRun

    scene = config
    if chunk is not None and chunks is None:
        raise click.UsageError("--chunk needs --chunks (the total number of chunks)")
    threads = runner.resolve_threads(threads)
    if chunks is not None:
        if chunks < 1:
            raise UserError(f"--chunks must be >= 1, got {chunks}")
        source = "--chunk"
        if chunk is None:
            found = runner.chunk_index_from_env()
            if found is None:
                raise click.UsageError(
                    "--chunks without --chunk: give --chunk I, or run as an array job "
                    "(SLURM_ARRAY_TASK_ID, PBS_ARRAY_INDEX, SGE_TASK_ID or LSB_JOBINDEX)")
            chunk, source = found
        if not 0 <= chunk < chunks:
            raise UserError(f"{source}: chunk index {chunk} outside 0..{chunks - 1}")
        if out.exists() and not out.is_dir():
            raise UserError(f"--out: {out} is a file; with --chunks it names a run directory")
    elif out.is_dir():
        raise UserError(f"--out: {out} is a directory; without --chunks it names the results "
                        "file")
    try:
        if chunks is None:
            res = runner.run_single(scene, out, threads=threads, progress=progress,
                                    restart=restart, overwrite=overwrite,
                                    keep_parts=keep_parts, wait=wait)
        else:
            res = runner.run_chunk(scene, out, chunk, chunks, threads=threads,
                                   progress=progress, restart=restart, wait=wait)
    except KeyboardInterrupt as exc:
        where = SingleRun(out).parts if chunks is None else RunDir(out).parts_root
        hint = (f"finished sub-chunks are kept in {where}; rerun the same command to resume"
                if where.exists() else "")
        click.echo(interrupted_message(exc, hint), err=True)
        sys.exit(EXIT_INTERRUPTED)
    except OutputError as exc:
        where = SingleRun(out).parts if chunks is None else RunDir(out).parts_root
        if exc.errno in (errno.ENOSPC, errno.EDQUOT) and where.exists():
            raise UserError(f"{exc}; finished sub-chunks are kept in {where}: free space, then "
                            "rerun the same command to resume") from None
        raise
    if res.already_done:
        click.echo(f"{res.path} is already complete ({res.n_maps:,} maps, config "
                   f"{scene.config_hash[:12]}); nothing to do")
    else:
        rate = res.n_maps / res.compute_seconds if res.compute_seconds > 0 else float("nan")
        click.echo(f"wrote {res.path}: {res.n_maps:,} maps ({res.computed_maps:,} computed now) "
                   f"in {res.wall_seconds:.1f} s; {rate:,.0f} maps/s of compute")
    if chunks is None and scene.refine is not None:
        _run_refinement(out, scene.refine, threads, progress, restart, wait)


def _run_refinement(store, settings, threads, progress, restart, wait, force=False):
    """The refinement stage of a store (`sweep run`, `sweep merge`, `sweep refine`), with the
    CLI's messages."""
    from .runs.refine import refine_store
    from .runs.rundir import refine_dir

    try:
        res = refine_store(store, settings, threads=threads, progress=progress,
                           restart=restart, wait=wait, force=force)
    except KeyboardInterrupt as exc:
        where = refine_dir(store)
        hint = (f"finished refinement batches are kept in {where}; rerun the same command to "
                "resume" if where.exists() else "")
        click.echo(interrupted_message(exc, hint), err=True)
        sys.exit(EXIT_INTERRUPTED)
    if res.already_done:
        click.echo(f"{store} is already refined; nothing to do")
        return
    ref = res.refinement
    counts = ref.counts()
    levels = ", ".join(f"{n:,} at h = {ref.settings.level_h(ref.h, k + 1):g}"
                       for k, n in enumerate(ref.level_maps))
    frac = ref.seconds / res.screening_seconds if res.screening_seconds > 0 else float("nan")
    click.echo(f"refined {store}: {counts['certified']} parts certified, {counts['near_tie']} "
               f"near-tie sets" + (f", {counts['not_refined']} not refined (no design cages)"
                                   if counts["not_refined"] else "")
               + f"; maps {levels or 'none'}; {ref.seconds:.1f} s of compute, {frac:.0%} of the "
               f"screening's {res.screening_seconds:.1f} s ({res.wall_seconds:.1f} s wall)")


@click.command("refine", cls=SweepCommand,
               short_help="Refine a store's best designs on finer grids and certify them.")
@click.argument("store", type=FILE)
@click.option("--levels", type=click.IntRange(min=1), default=None,
              help="Level cap: recompute at h/2 ... h/2^LEVELS [default: the config's refine:, "
                   "else 3].")
@click.option("--bound", type=click.FloatRange(0.0, 1.0), default=None,
              help="Cap of each part's contender bound: no design whose screened caging area "
                   "is below (1 - BOUND) times the part's best contends [default: the config's, "
                   "else 0.1].")
@click.option("--min-contenders", type=click.IntRange(min=2), default=None,
              help="Floor: at least this many contending designs per part (equal-R designs "
                   "once) [default: the config's, else 3].")
@THREADS
@click.option("--progress/--no-progress", default=True, show_default=True,
              help="Progress bar on stderr, one per level.")
@click.option("--restart", is_flag=True,
              help="Discard finished batches of an earlier refinement instead of resuming.")
@click.option("--force", is_flag=True,
              help="Refine again even if the store is refined with these settings (timing).")
@WAIT
def refine(store, levels, bound, min_contenders, threads, progress, restart, force, wait):
    """Refine the best designs of a results store: per part and command, recompute the
    contenders (the --min-contenders best designs by screened caging area, and those that
    their change from screening to h/2 says could still be the best, capped by --bound) at
    h/2, h/4, ... until the
    best design's lead over every other contender exceeds the change between the last two
    levels (certified), or up to the level cap (then the part has a near-tie set). Equal-R
    designs (same l1, l2, w and r2/r1) give the same map and count once.

    \b
    sweep refine results/paper.h5
    sweep refine runs/paper/results.h5 --levels 4

    The refined values, levels and certification are added to STORE (rewritten atomically; the
    screened values stay). Resumable: finished batches of maps are kept in STORE.refine/ and a
    rerun computes only the rest, with identical results. `sweep run` does this itself when the
    config has `refine:`, `sweep merge` too unless --no-refine. A store already refined with the
    same settings is left alone.
    """
    import dataclasses

    from .runs import runner
    from .config.scene import RefineSettings
    from .storage.store import read_store, scene_from_frozen

    threads = runner.resolve_threads(threads)
    scene = scene_from_frozen(read_store(store).frozen)
    settings = scene.refine or RefineSettings()
    changes = {k: v for k, v in (("levels", levels), ("bound", bound),
                                 ("min_contenders", min_contenders)) if v is not None}
    settings = dataclasses.replace(settings, **changes)
    if changes:
        from .config.scene import SceneError, refine_settings

        try:
            refine_settings(settings.as_dict(), scene.values, scene.h)
        except SceneError as exc:
            raise UserError(str(exc).replace("refine.", "--").replace("_", "-")) from None
    _run_refinement(store, settings, threads, progress, restart, wait, force)


@click.command("slurm", cls=SweepCommand,
               short_help="Print (or --submit) an sbatch array script for a sweep.")
@click.argument("config", type=CONFIG)
@click.option("--chunks", type=click.IntRange(min=1), required=True,
              help="Number of chunks (array tasks).")
@click.option("--out", type=PATH, required=True, help="Run directory for the shards.")
@click.option("--parallel", type=click.IntRange(min=1), default=None,
              help="Most array tasks running at once (--array=0-{N-1}%P).")
@click.option("--cpus-per-task", type=click.IntRange(min=1), default=4, show_default=True,
              help="Cores per task (becomes the task's thread count).")
@click.option("--time", "time_limit", default="01:00:00", show_default=True,
              help="Wall-time limit per task; a task that hits it resumes when resubmitted.")
@click.option("--mem", default=None, help="Memory per task, e.g. 4G.")
@click.option("--partition", default=None, help="Slurm partition.")
@click.option("--account", default=None, help="Slurm account.")
@click.option("--job-name", default=None, help="Job name (default: sweep-NAME).")
@click.option("--sweep-cmd", default=None,
              help="Command that runs sweep on the nodes (default: this installation's).")
@click.option("--sbatch", "sbatch_opts", multiple=True, metavar="KEY=VALUE",
              help="Extra #SBATCH option, repeatable (e.g. --sbatch qos=long).")
@click.option("--submit", is_flag=True,
              help="Submit the array and a dependent merge job instead of printing.")
@click.option("--results", type=click.Path(dir_okay=False, path_type=Path), default=None,
              help="With --submit: the store the merge job writes [default: DIR/results.h5].")
def slurm_command(config, chunks, out, parallel, cpus_per_task, time_limit, mem, partition,
                  account, job_name, sweep_cmd, sbatch_opts, submit, results):
    """Print an sbatch array script that runs the sweep as N chunks, or --submit it.

    \b
    sweep slurm configs/paper.yaml --chunks 64 --out runs/paper > paper.sbatch
    sbatch paper.sbatch        # or pipe: ... | sbatch
    sweep status runs/paper
    sweep merge runs/paper --out paper.h5

    \b
    sweep slurm configs/paper.yaml --chunks 64 --out runs/paper --submit
    submits the array and a merge job that runs once every task succeeded
    (--dependency=afterok), writing --results (default DIR/results.h5); prints both job ids.
    The scripts are kept as DIR/sweep-array.sbatch and DIR/sweep-merge.sbatch; resubmit a
    failed task I with `sbatch --array=I DIR/sweep-array.sbatch` (it resumes its shard). When
    the config has `refine:`, a third job (DIR/sweep-refine.sbatch, --dependency=afterok on the
    merge, --cpus-per-task cores) refines the merged store and writes its report.

    Creates DIR and DIR/logs (Slurm does not create log directories) and writes the frozen config
    and chunk plan to DIR/sweep-manifest.json, so every task checks it runs the same sweep.
    """
    from .runs import slurm
    from .config.chunks import chunk_ranges
    from .outputs import os_errors_named
    from .runs.rundir import RunDir, ensure_manifest

    scene = config
    if results is not None and not submit:
        raise click.UsageError("--results names the merge job's output: it needs --submit")
    extra = {}
    for item in sbatch_opts:
        key, sep, value = item.partition("=")
        if not sep or not key.strip("-"):
            raise UserError(f"--sbatch: expected KEY=VALUE, got {item!r}")
        extra[key.strip().lstrip("-")] = value
    try:
        chunk_ranges(scene.n_items, chunks, scene.group_size)
    except ValueError as exc:
        raise UserError(f"--chunks: {exc}") from None
    if sweep_cmd is None:
        exe = Path(sys.executable).parent / "sweep"
        sweep_cmd = str(exe) if exe.exists() else (shutil.which("sweep") or "sweep")
    if out.exists() and not out.is_dir():
        raise UserError(f"--out: {out} is a file; it names the run directory")
    rundir = RunDir(real_path(out))
    job_name = job_name or f"sweep-{scene.name}"
    text = slurm.sbatch_script(
        config=str(real_path(scene.path)), out_dir=str(rundir.root), n_chunks=chunks,
        job_name=job_name, sweep_cmd=sweep_cmd, parallel=parallel,
        cpus_per_task=cpus_per_task, time=time_limit, mem=mem, partition=partition,
        account=account, extra=extra, n_maps=scene.n_maps, config_hash=scene.config_hash)
    sbatch = None
    if submit:  # everything checked before anything is written
        results = real_path(results or rundir.root / "results.h5")
        if results.exists():
            raise UserError(f"--results: {results} exists; the merge job would refuse "
                            "to replace it: move it away or choose another --results")
        sbatch = shutil.which("sbatch")
        if sbatch is None:
            raise UserError("--submit: sbatch is not on PATH (run this on a SLURM "
                            "login node, or drop --submit and copy the script)")
        try:
            slurm.check(text, sbatch)
        except slurm.SubmitError as exc:
            raise UserError(f"--submit: {exc}") from None
    ensure_manifest(rundir, scene, chunks)
    with os_errors_named(rundir.logs, "cannot create folder"):
        rundir.logs.mkdir(parents=True, exist_ok=True)
    if not submit:
        click.echo(text, nl=False)
        return
    refine_text = None
    if scene.refine is not None:
        refine_text = slurm.refine_script(
            out_dir=str(rundir.root), results=str(results), job_name=f"{job_name}-refine",
            sweep_cmd=sweep_cmd, cpus_per_task=cpus_per_task, time=time_limit, mem=mem,
            partition=partition, account=account, extra=extra)
    _submit_array_and_merge(rundir, text, slurm.merge_script(
        out_dir=str(rundir.root), results=str(results), job_name=f"{job_name}-merge",
        sweep_cmd=sweep_cmd, time=time_limit, partition=partition, account=account,
        extra=extra, refine=refine_text is not None), results, chunks, sbatch, refine_text)


def _submit_array_and_merge(rundir, array_text, merge_text, results, chunks, sbatch,
                            refine_text=None):
    """Write the scripts into the run directory (kept for resubmitting a task), submit the
    array, then the merge job depending on it, then (with `refine_text`, a config with
    `refine:`) the refine job depending on the merge; print the job ids."""
    from .runs import slurm

    array_path = rundir.root / "sweep-array.sbatch"
    merge_path = rundir.root / "sweep-merge.sbatch"
    refine_path = rundir.root / "sweep-refine.sbatch"
    slurm.write_script(array_path, array_text)
    slurm.write_script(merge_path, merge_text)
    if refine_text is not None:
        slurm.write_script(refine_path, refine_text)
    try:
        array_id = slurm.submit(array_path, sbatch=sbatch)
    except slurm.SubmitError as exc:
        raise UserError(str(exc)) from None
    click.echo(f"array job {array_id}: {chunks} tasks writing shards into {rundir.root}")
    try:
        merge_id = slurm.submit(merge_path, [f"--dependency=afterok:{array_id}"], sbatch=sbatch)
    except slurm.SubmitError as exc:
        raise UserError(f"array job {array_id} is submitted but the merge job is "
                        f"not ({exc}); merge by hand with `sweep merge "
                        f"{rundir.root} --out {results}` once it is done") from None
    click.echo(f"merge job {merge_id}: after every task of {array_id} succeeds, writes {results}")
    if refine_text is not None:
        try:
            refine_id = slurm.submit(refine_path, [f"--dependency=afterok:{merge_id}"],
                                     sbatch=sbatch)
        except slurm.SubmitError as exc:
            raise UserError(f"the array and merge jobs are submitted but the refine job is "
                            f"not ({exc}); once the merge is done run `sweep refine {results}` "
                            f"or `sbatch {refine_path}`") from None
        click.echo(f"refine job {refine_id}: after the merge, refines {results} and writes its "
                   "report")
    click.echo(f"resubmit a failed task I with: sbatch --array=I {array_path}")


@click.command("status", cls=SweepCommand, short_help="Which shards of a run directory are done.")
@click.argument("directory", type=PATH)
def status(directory):
    """Say which shards of a chunked run directory are done, missing, corrupt or mismatched.

    Exit code 0 when every shard is done (ready for `sweep merge`), 1 otherwise, 2 if DIR is not
    a chunked run directory.
    """
    from .runs.rundir import scan_shards

    st = scan_shards(directory)
    counts = st.counts()
    summary = ", ".join(f"{counts[k]} {k}" for k in ("done", "missing", "corrupt", "mismatched",
                                                      "duplicate") if counts.get(k))
    cfg = st.manifest["config_hash"][:12] if st.manifest else "unknown (no manifest)"
    click.echo(f"{directory}: {st.n_chunks} shards: {summary}; config {cfg}")
    for s in st.shards + st.stray:
        rng = f"items {s.range[0]}-{s.range[1]}" if s.range else ""
        name = s.path.name if s.path else ""
        line = f"  {s.chunk:>5}  {s.state:<10}  {name:<28} {rng}"
        if s.detail:
            line += f"  {s.detail}"
        click.echo(line.rstrip())
    if not st.complete:
        sys.exit(1)


@click.command("merge", cls=SweepCommand, short_help="Merge finished shards into one store.")
@click.argument("directory", type=PATH)
@click.option("--out", type=FILE, required=True, help="Results store (.h5) to write.")
@click.option("--overwrite", is_flag=True, help="Replace an existing --out file.")
@click.option("--refine/--no-refine", "do_refine", default=True, show_default=True,
              help="When the config has `refine:`, refine the merged store (as `sweep refine`).")
@click.option("--threads", type=int, default=None,
              help="Numba threads of the refinement (default: SLURM_CPUS_PER_TASK, else every "
                   "core).")
@WAIT
def merge(directory, out, overwrite, do_refine, threads, wait):
    """Merge the shards of a chunked run directory into one results store; then, when the
    config has `refine:` (and not --no-refine), refine it as `sweep refine` does.

    Refuses (exit code 2, nothing written) when a shard is missing, corrupt, duplicated, or from
    a different config, chunking or sweep version.
    """
    from .runs import runner
    from .runs.rundir import merge_shards

    threads = runner.resolve_threads(threads)
    scene, st = merge_shards(directory, out, overwrite=overwrite, wait=wait)
    click.echo(f"wrote {out}: {scene.n_maps:,} maps from {st.n_chunks} shards "
               f"(config {scene.config_hash[:12]})")
    if do_refine and scene.refine is not None:
        _run_refinement(out, scene.refine, threads, sys.stderr.isatty(), False, wait)


TOP_COLUMNS = ("Lambda", "caging_area", "n_caged", "n_tip_prehension", "n_ejection", "n_stalled",
               "n_reached")


@click.command("top", cls=SweepCommand, short_help="Best designs of each part, as tables.")
@click.argument("results", type=FILE)
@click.option("--r", "r", type=float, default=None,
              help="Part radius (a value of the store); default: every radius.")
@click.option("--mu", type=float, default=None,
              help="Part friction (a value of the store); default: every value.")
@click.option("-n", "n", type=int, default=None,
              help="How many designs per part [default: 10 for one part, else 1].")
@click.option("--by", default=None,
              help="Summary variable to rank by (e.g. Lambda, caging_area, n_caged) "
                   "[default: the refined ranking when the store is refined, else Lambda].")
@click.option("--ascending", is_flag=True, help="Smallest first.")
@click.option("--command", "command", type=int, default=0, show_default=True,
              help="Command index, for stores with several commands.")
def top(results, r, mu, n, by, ascending, command):
    """Print the best designs of each part (r, mu) of a results store, as tables.

    In a refined store (`refine:`, `sweep refine`) the designs are ranked by the refinement:
    the designs still in the running at the finest grid first (the best, then its near-tie
    set), then the other contenders, then the rest, each group by refined caging area (the
    screened one for designs not refined); each part's table is headed by its best design, its
    lead over the runner-up, the finest h reached and "certified" or the near-tie set. Otherwise,
    and with --by, designs are ranked by that screened summary variable (default Lambda, the
    paper's caging metric), largest first unless --ascending; ties keep the store's order.
    Without --r / --mu every part of the store is listed (by default its best design only).
    Examples: sweep top paper.h5 --r 0.4 --mu 0.1 -n 10; sweep top paper.h5 --by n_caged
    """
    import numpy as np

    from .compute.batch import SUMMARY_FIELDS
    from .storage.store import read_store

    if by is not None and by not in SUMMARY_FIELDS:
        raise UserError(f"--by: unknown field {by!r} (valid: {', '.join(SUMMARY_FIELDS)})")
    if n is None:
        n = 10 if (r is not None and mu is not None) else 1
    if n < 1:
        raise UserError(f"-n: must be >= 1, got {n}")
    view = read_store(results)
    if by is None and not view.refine:
        by = "Lambda"
    chosen = {}
    for name, value in (("r", r), ("mu", mu)):
        coord = view.coords[name]
        if value is None:
            chosen[name] = list(range(coord.size))
            continue
        hits = np.flatnonzero(np.isclose(coord, value, rtol=1e-9, atol=1e-12))
        if hits.size != 1:
            raise UserError(f"--{name}: {value:g} is not in the store (values: "
                                  f"{', '.join(f'{v:g}' for v in coord)})")
        chosen[name] = [int(hits[0])]
    ncmd = view.coords["command"].size if "command" in view.dims else 1
    if not 0 <= command < ncmd:
        raise UserError(f"--command: must be an index 0..{ncmd - 1}, got {command}")
    for k, (ri, mui) in enumerate((a, b) for a in chosen["r"] for b in chosen["mu"]):
        if k:
            click.echo("")
        _print_top(view, ri, mui, n, by, ascending, command)


def _design_text(designs, d) -> str:
    l1, l2, r1, r2, w = designs[d]
    return f"l1={l1:g} l2={l2:g} r1={r1:g} r2={r2:g} w={w:g}"


def _refined_header(view, designs, pick, pick_part):
    """Lines describing one part's refinement, the refined ranking and the outcome."""
    import numpy as np

    from .runs.refine import equal_r_classes, part_outcome, ranking

    ref = view.refine
    role, value, error = (pick(ref[k]) for k in ("refine_role", "refined_caging_area",
                                                  "refined_error"))
    out = part_outcome(equal_r_classes(designs), role, value, error,
                       pick_part(ref["refine_status"]), pick_part(ref["refine_finest_h"]),
                       pick_part(ref["refine_margin"]), pick_part(ref["refine_bound_held"]))
    order = ranking(role, value, pick(view.variables["caging_area"]).astype(np.float64))
    if out.status == "not_refined":
        return ["  refinement: not refined (no design cages at the screening spacing)"], \
            order, out
    twins = f" (+{out.n_best - 1} equal-R)" if out.n_best > 1 else ""
    b = out.best
    rel = out.margin / value[b] if value[b] > 0 else float("nan")
    lines = [f"  refinement: {out.status.replace('_', '-')} at h = {out.finest_h:g}; best "
             f"{_design_text(designs, b)}{twins}, refined caging area {value[b]:.6g} "
             f"(error {error[b]:.2g}), lead over the runner-up {out.margin:.3g} ({rel:.2%})"
             + ("" if out.bound_held else "; the contender bound did not hold (a design left out "
                "could be the best: raise refine.bound)")]
    if not out.certified:
        lines.append(f"  near-tie set ({len(out.members)}): " + "; ".join(
            f"{_design_text(designs, d)}: {value[d]:.6g} +- {error[d]:.2g}"
            for d in out.members))
    return lines, order, out


def _print_top(view, ri, mui, n, by, ascending, command):
    import numpy as np

    from .runs.refine import designs_of_coords

    sel = {"r": ri, "mu": mui}
    if "command" in view.dims:
        sel["command"] = command
    design_dims = ("l1", "l2", "r1", "r2", "w")

    def pick(arr):
        index = tuple(sel.get(d, slice(None)) for d in view.dims)
        return arr[index].reshape(-1)       # remaining dims are design_dims, in order

    def pick_part(arr):
        return arr[(ri, mui) + ((command,) if "command" in view.dims else ())]

    values = {f: pick(view.variables[f]) for f in view.variables}
    designs = designs_of_coords(view.coords)
    header = []
    refined = by is None
    if refined:
        header, order, _ = _refined_header(view, designs, pick, pick_part)
        order = order[:n]
        values["refined_caging_area"] = pick(view.refine["refined_caging_area"])
        values["refined_error"] = pick(view.refine["refined_error"])
        level = pick(view.refine["refined_level"]).astype(np.float64)
        values["refined_h"] = np.where(level > 0, view.attrs["grid_h"] / 2.0 ** level, np.nan)
        cols = ["refined_caging_area", "refined_error", "refined_h"] + list(TOP_COLUMNS)
        what = "the refined ranking"
    else:
        key = values[by].astype(np.float64)
        key = np.where(np.isnan(key), -np.inf if not ascending else np.inf, key)
        order = np.argsort(key if ascending else -key, kind="stable")[:n]
        cols = list(TOP_COLUMNS) if by in TOP_COLUMNS else [by] + list(TOP_COLUMNS)
        what = f"{by}{' (ascending)' if ascending else ''}"
    head = ["rank"] + list(design_dims) + cols
    rows = []
    for rank, i in enumerate(order, 1):
        row = [str(rank)] + [f"{designs[i][k]:g}" for k in range(len(design_dims))]
        for c in cols:
            v = values[c][i]
            row.append(("-" if np.isnan(v) else f"{v:.6g}")
                       if np.issubdtype(values[c].dtype, np.floating) else f"{v:d}")
        rows.append(row)
    widths = [max(len(h), *(len(r_[k]) for r_ in rows)) for k, h in enumerate(head)]
    cmd = ""
    if "command" in view.dims:
        cmd = f", command {command}"
    elif "f_left" in view.attrs:
        cmd = f", F_left {view.attrs['f_left']:g}, F_right {view.attrs['f_right']:g}"
    click.echo(f"part r = {view.coords['r'][sel['r']]:g}, mu = {view.coords['mu'][sel['mu']]:g}"
               f"{cmd}: top {len(rows)} of {designs.shape[0]:,} designs by {what}; screened at "
               f"h = {view.attrs.get('grid_h', '?')}")
    for line in header:
        click.echo(line)
    click.echo("  ".join(h.rjust(w) for h, w in zip(head, widths)))
    for row in rows:
        click.echo("  ".join(v.rjust(w) for v, w in zip(row, widths)))


@click.command("show", cls=SweepCommand,
               short_help="What a results store (or any sweep file) holds.")
@click.argument("results", type=FILE)
def show(results):
    """Print what a results store holds: dimensions, variables, config, effects, grid,
    provenance and timings. Shard and part files, and single maps (`sweep map`,
    outputs.save_maps), get a short description."""
    import numpy as np

    from .storage.store import CorruptFile, StoreError, read_block, read_store

    try:
        view = read_store(results)
    except StoreError as store_exc:
        try:
            b = read_block(results, with_data=False)
        except CorruptFile:
            lines = _describe_map_file(results)
            if lines is None:
                raise UserError(str(store_exc)) from None
            click.echo("\n".join(lines))
            return
        click.echo(f"{results}: {b.kind} of sweep {b.frozen.get('name')!r}, items "
                   f"{b.start}-{b.stop} of {b.frozen and _n_items(b)}"
                   + (f", chunk {b.chunk} of {b.n_chunks}" if b.chunk is not None else ""))
        click.echo(f"  config {b.config_hash[:12]}, sweep {b.version}, compute "
                   f"{b.compute_seconds:.1f} s")
        return
    a = view.attrs
    click.echo(f"{results}: results store of sweep {a.get('name')!r} ({a.get('created_by')}, "
               f"{a.get('created_utc')})")
    shape = " x ".join(f"{d} {view.coords[d].size}" for d in view.dims)
    click.echo(f"  {int(a.get('n_maps', 0)):,} maps on {shape}")
    for d in view.dims:
        v = view.coords[d]
        click.echo(f"    {d:<8} {', '.join(f'{x:g}' for x in v)}")
    click.echo("  variables (" + ", ".join(view.dims) + "):")
    for name, arr in view.variables.items():
        ln = view.var_attrs[name].get("long_name", "")
        click.echo(f"    {name:<17} {str(arr.dtype):<8} {ln}")
    click.echo(f"  grid: h = {a.get('grid_h')}, bounds {a.get('grid_bounds')}; limits theta2 "
               f"[{a.get('theta2_min_deg')}, {a.get('theta2_max_deg')}] deg; accuracy: "
               f"reconfig_step {a.get('reconfig_step')}, root_tol {a.get('root_tol')}, "
               f"trajectory {a.get('trajectory')}")
    if "f_left" in a:
        click.echo(f"  command: F_left {a['f_left']:g}, F_right {a['f_right']:g}")
    click.echo(f"  effects on: {a.get('effects_on')}")
    click.echo(f"  config {str(a.get('config_hash'))[:12]}, sweep {a.get('sweep_version')}, "
               f"numba {a.get('numba_version')}, numpy {a.get('numpy_version')}, "
               f"HDF5 {a.get('hdf5_version')}")
    timing = [f"compute {a['compute_seconds']:.1f} s" if "compute_seconds" in a else "",
              f"wall {a['wall_seconds']:.1f} s" if "wall_seconds" in a else "",
              f"{a['maps_per_second']:,.0f} maps/s" if "maps_per_second" in a else ""]
    click.echo("  timings: " + ", ".join(t for t in timing if t))
    if view.refine:
        click.echo(f"  refinement: {a.get('refine_counts')}; levels h = "
                   f"{', '.join(f'{x:g}' for x in np.atleast_1d(a.get('refine_level_h', [])))}; "
                   f"cap bound {a.get('refine_bound')}, at least {a.get('refine_min_contenders')} "
                   f"contenders; {a.get('refine_compute_seconds', float('nan')):.1f} s of compute "
                   f"(variables: {', '.join(view.refine)})")
    if "saved_maps" in a:
        import json

        names = json.loads(a["saved_maps"])
        click.echo(f"  {len(names)} full maps saved in {a.get('saved_maps_dir')}:")
        for name in names:
            click.echo(f"    {name}")


def _describe_map_file(path: Path) -> list[str] | None:
    """A few lines about a single-map file, or None if `path` is not one."""
    import json

    import h5py

    try:
        with h5py.File(path, "r") as f:
            if "energy" not in f or "design" not in f.attrs:
                return None
            a = {k: (v.decode() if isinstance(v, bytes) else v) for k, v in f.attrs.items()}
            ny, nx = f["energy"].shape
    except (OSError, KeyError, ValueError):
        return None

    def fmt(key):
        try:
            return ", ".join(f"{k} {v:g}" for k, v in json.loads(a[key]).items()
                             if isinstance(v, (int, float)))
        except (KeyError, TypeError, ValueError):
            return "?"

    return [f"{path}: one energy map (written by `sweep map` or a sweep's outputs.save_maps; "
            "`sweep show` describes results stores in full, open this one with xarray)",
            f"  design: {fmt('design')}; part: {fmt('part')}; command: {fmt('command')}",
            f"  grid: {ny} x {nx} points at h = {a.get('h')}; Lambda {a.get('Lambda')}, "
            f"caging_area {a.get('caging_area')}, caged {a.get('n_caged')}, "
            f"reached {a.get('n_reached')}",
            f"  sweep {a.get('sweep_version')}, written {a.get('created_utc')}"]


def _n_items(b) -> str:
    try:
        from .storage.store import scene_from_frozen

        return f"{scene_from_frozen(b.frozen).n_items:,}"
    except Exception:  # noqa: BLE001 - display only
        return "?"


@click.command("report", cls=SweepCommand,
               short_help="The paper's experiments from one results store, or two scenes.")
@click.argument("stores", type=FILE, nargs=-1, required=True)
@click.option("--out", type=PATH, required=True, help="Directory for the report's files.")
@click.option("--top-k", type=int, default=None,
              help="Scenario A candidates per part [default: the store's "
                   "manipulation_scenario_a_top_k].")
@click.option("--overwrite", is_flag=True,
              help="Replace a report in DIR made from another store.")
@WAIT
def report(stores, out, top_k, overwrite, wait):
    """Turn a results store into the paper's four experiments: best_caging.png,
    caging_vs_tip.png, manipulation.png, parameter_usage.png, their tables as CSV, and
    report.md (tables, rules, settings, run time, a reading).

    \b
    sweep report results/paper.h5 --out results/
    sweep report results/paper.h5 results/paper-collision.h5 --out results/

    With two stores of the same designs, parts and grid (two scenes: say, as the paper models
    the fingers and with finger_collision), one report puts the scenes side by side
    (best_designs.png, caging_vs_tip.png, manipulation.png, parameter_usage.png, report.md).

    Rerunning on the same store(s) with the same settings is a no-op; a stale report of the
    same store(s) is redone; a report of another store in DIR needs --overwrite. A store
    without the manipulation metric (config option `outputs: {manipulation: true}`) gets the
    caging parts only, with a note in report.md.
    """
    import json

    from .outputs import OutputLock, make_parent
    from .report import ALL_FILES, MARKER, build_report, identity, open_store, resolve_top_k
    from .report_compare import FILES, build_comparison, comparison_identity, open_pair

    if len(stores) > 2:
        raise UserError(f"give one store, or two to compare (got {len(stores)})")
    if out.exists() and not out.is_dir():
        raise UserError(f"--out: {out} is a file; it names the report's directory")
    if len(stores) == 1:
        st = open_store(stores[0])
        top_k = resolve_top_k(st, top_k)
        wanted = identity(st, top_k)
        names = ALL_FILES
        what = f"the report of {stores[0]}"
    else:
        pair = open_pair(stores[0], stores[1], top_k)
        top_k = pair[2]
        wanted = comparison_identity(*pair)
        names = tuple(sorted(set(FILES) | set(ALL_FILES)))
        what = f"the report comparing {stores[0]} and {stores[1]}"
    make_parent(out / MARKER)
    with OutputLock(out / MARKER, what=f"the report in {out}").acquire(wait=wait):
        try:
            found = json.loads((out / MARKER).read_text())
        except (OSError, ValueError):
            found = None
        same = found is not None and all(found.get(k) == v for k, v in wanted.items())
        if same and not overwrite and found.get("complete") and all(
                (out / name).exists() for name in found.get("files", [])):
            click.echo(f"{out}: {what} is already complete; nothing to do")
            return
        present = [name for name in names if (out / name).exists()]
        # Like `sweep run`: the report of these stores (same files, same configs) is redone
        # when stale (store rewritten, other --top-k); a report of others needs --overwrite.
        ours = found is not None and all(found.get(k) == wanted[k]
                                         for k in ("store", "config_hash"))
        if present and found is not None and not ours and not overwrite:
            raise UserError(f"--out: {out} holds the report of another store "
                            f"({found.get('store')}); pass --overwrite to replace it")
        if present and found is None and not overwrite:
            raise UserError(f"--out: {out} already holds {present[0]}; pass --overwrite to "
                            "replace it")
        log = lambda msg: click.echo(f"report: {msg}", err=True)  # noqa: E731
        if len(stores) == 1:
            build_report(stores[0], out, top_k, log=log, st=st)
        else:
            build_comparison(stores[0], stores[1], out, top_k, log=log, pair=pair)
    click.echo(f"wrote {what} to {out}/ (report.md and its figures and tables)")


# ---------------------------------------------------------------------------------------------
COMMANDS = (run, slurm_command, status, merge, refine, top, show, report)


def register(group: click.Group) -> None:
    """Add the sweep commands to `group`."""
    for command in COMMANDS:
        group.add_command(command)


def main(argv=None):
    """`python -m sweep.cli_sweep ...`: the sweep commands without the rest of the CLI."""
    group = SweepGroup("sweep", help="Sweep commands.")
    register(group)
    return group.main(args=argv, prog_name="sweep")


if __name__ == "__main__":  # pragma: no cover
    main()
