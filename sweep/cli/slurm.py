"""`sweep slurm`, `sweep status`: a sweep as an HPC array job, and which of its shards are
done (`sweep.runs.slurm`, `sweep.runs.rundir`).
"""
from __future__ import annotations

import shutil
import sys
from pathlib import Path

import click

from .common import CONFIG, RUN_DIR, RUN_DIR_OUT, STORE_OUT, SweepCommand, UserError, real_path


@click.command("slurm", cls=SweepCommand,
               short_help="Print (or --submit) an sbatch array script for a sweep.")
@click.argument("config", type=CONFIG)
@click.option("--chunks", type=click.IntRange(min=1), required=True,
              help="Number of chunks (array tasks).")
@click.option("--out", type=RUN_DIR_OUT, required=True, help="Run directory for the shards.")
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
@click.option("--results", type=STORE_OUT, default=None,
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
    from ..runs import slurm
    from ..config.chunks import chunk_ranges
    from ..files import os_errors_named
    from ..runs.rundir import RunDir, ensure_manifest

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
    rundir = RunDir(real_path(out))
    job_name = job_name or f"sweep-{scene.name}"
    text = slurm.sbatch_script(
        config=str(real_path(scene.path)), out_dir=str(rundir.root), n_chunks=chunks,
        job_name=job_name, sweep_cmd=sweep_cmd, parallel=parallel,
        cpus_per_task=cpus_per_task, time=time_limit, mem=mem, partition=partition,
        account=account, extra=extra, n_maps=scene.n_maps, config_hash=scene.config_hash)
    sbatch = None
    if submit:  # everything checked before anything is written
        results = real_path(results or rundir.results)
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
    from ..runs import slurm

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
@click.argument("directory", type=RUN_DIR)
def status(directory):
    """Say which shards of a chunked run directory are done, missing, corrupt or mismatched.

    Exit code 0 when every shard is done (ready for `sweep merge`), 1 otherwise, 2 if DIR is not
    a chunked run directory.
    """
    from ..runs.rundir import scan_shards

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
