"""`sweep run`, `sweep merge`, `sweep refine`: compute a results store, merge a run
directory's shards into one, refine a store's best designs (`sweep.runs`).
"""
from __future__ import annotations

import errno
import sys

import click

from ..interrupts import EXIT_INTERRUPTED, interrupted_message
from .common import (CONFIG, PROGRESS, RUN_DIR, STORE, STORE_OR_RUN_OUT, STORE_OUT, THREADS, WAIT,
                     SweepCommand, UserError, check_path)


@click.command("run", cls=SweepCommand, short_help="Compute a sweep (one machine, or one chunk).")
@click.argument("config", type=CONFIG)
@click.option("--out", type=STORE_OR_RUN_OUT, required=True,
              help="Results store (.h5) to write; with --chunks, the run directory.")
@click.option("--chunk", type=int, default=None,
              help="Which chunk to compute, 0..N-1 (default: from the array job's environment).")
@click.option("--chunks", type=int, default=None,
              help="Split the sweep into N chunks and compute one (cluster runs).")
@THREADS
@PROGRESS
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
    from ..runs import runner
    from ..files import OutputError
    from ..runs.rundir import RunDir, SingleRun

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
        check_path(out, "run-dir-out", "--out (with --chunks)")
    else:
        check_path(out, "store-out", "--out (without --chunks)")
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
    from ..runs.refine import refine_store
    from ..runs.rundir import refine_dir

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
@click.argument("store", type=STORE)
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
@PROGRESS
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
    levels (certified), or up to the level cap (then the part has a near-tie set). Where a
    part's check that no design left out could be the best fails, those designs are re-admitted
    and recomputed until it holds. Equal-R designs (same l1, l2, w and r2/r1) give the same map
    and count once.

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

    from ..runs import runner
    from ..config.scene import RefineSettings
    from ..config.parse import scene_from_frozen
    from ..storage.store import read_store

    threads = runner.resolve_threads(threads)
    scene = scene_from_frozen(read_store(store).frozen)
    settings = scene.refine or RefineSettings()
    changes = {k: v for k, v in (("levels", levels), ("bound", bound),
                                 ("min_contenders", min_contenders)) if v is not None}
    settings = dataclasses.replace(settings, **changes)
    if changes:
        from ..config.parse import refine_settings
        from ..config.scene import SceneError

        try:
            refine_settings(settings.as_dict(), scene.values, scene.h)
        except SceneError as exc:
            raise UserError(str(exc).replace("refine.", "--").replace("_", "-")) from None
    _run_refinement(store, settings, threads, progress, restart, wait, force)


@click.command("merge", cls=SweepCommand, short_help="Merge finished shards into one store.")
@click.argument("directory", type=RUN_DIR)
@click.option("--out", type=STORE_OUT, required=True, help="Results store (.h5) to write.")
@click.option("--overwrite", is_flag=True, help="Replace an existing --out file.")
@click.option("--refine/--no-refine", "do_refine", default=True, show_default=True,
              help="When the config has `refine:`, refine the merged store (as `sweep refine`).")
@THREADS
@WAIT
def merge(directory, out, overwrite, do_refine, threads, wait):
    """Merge the shards of a chunked run directory into one results store; then, when the
    config has `refine:` (and not --no-refine), refine it as `sweep refine` does.

    Refuses (exit code 2, nothing written) when a shard is missing, corrupt, duplicated, or from
    a different config, chunking or sweep version.
    """
    from ..runs import runner
    from ..runs.rundir import merge_shards

    threads = runner.resolve_threads(threads)
    scene, st = merge_shards(directory, out, overwrite=overwrite, wait=wait)
    click.echo(f"wrote {out}: {scene.n_maps:,} maps from {st.n_chunks} shards "
               f"(config {scene.config_hash[:12]})")
    if do_refine and scene.refine is not None:
        _run_refinement(out, scene.refine, threads, sys.stderr.isatty(), False, wait)
