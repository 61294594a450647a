"""The sbatch scripts of a chunked sweep, and their submission.

`sbatch_script` and `merge_script` are pure functions of their inputs (golden-file tested).
Array task ``i`` runs ``sweep run CONFIG --out DIR --chunks N``; `sweep run` reads the chunk index
from ``SLURM_ARRAY_TASK_ID`` and its thread count from ``SLURM_CPUS_PER_TASK``. Logs go to
``DIR/logs/%A_%a.out`` (job id, array index). The merge job runs ``sweep merge`` and
``sweep report`` once every array task has succeeded; with a config's `refine:` the merge job
only merges, and a refine job (`refine_script`, submitted with a dependency on the merge job,
the array tasks' cores) runs ``sweep refine`` and ``sweep report``. `submit` hands a script file
to ``sbatch`` and returns the job id.
"""
from __future__ import annotations

import shlex
import subprocess
from collections.abc import Mapping, Sequence
from pathlib import Path

from ..files import write_text_atomic


def sbatch_script(*, config: str, out_dir: str, n_chunks: int, job_name: str,
                  sweep_cmd: str = "sweep", parallel: int | None = None,
                  cpus_per_task: int = 4, time: str = "01:00:00", mem: str | None = None,
                  partition: str | None = None, account: str | None = None,
                  extra: Mapping[str, str] | None = None, n_maps: int | None = None,
                  config_hash: str | None = None) -> str:
    """Text of an sbatch script running chunks 0..n_chunks-1 as one job array.

    `parallel` caps how many array tasks run at once (``%P``); `extra` adds ``#SBATCH --key=value``
    lines. ``#SBATCH`` flags are sorted by name.
    """
    if n_chunks < 1:
        raise ValueError(f"n_chunks must be >= 1, got {n_chunks}")
    array = f"0-{n_chunks - 1}" + (f"%{parallel}" if parallel else "")
    flags = _job_flags(out_dir, "%A_%a", job_name, cpus_per_task, time, mem)
    flags["array"] = array
    lines = _header(flags, partition, account, extra)
    lines.append("")
    about = f"# {n_chunks} chunks" + (f" of a {n_maps:,}-map sweep" if n_maps else "")
    if config_hash:
        about += f" (config {config_hash[:12]})"
    lines += [
        about,
        "# Each task computes shard $SLURM_ARRAY_TASK_ID with $SLURM_CPUS_PER_TASK threads and",
        "# resumes if rerun. Afterwards:",
        f"#   {sweep_cmd} status {shlex.quote(out_dir)}",
        f"#   {sweep_cmd} merge {shlex.quote(out_dir)} --out RESULTS.h5",
        "set -euo pipefail",
        "export OMP_NUM_THREADS=1",
        f"exec {sweep_cmd} run {shlex.quote(config)} --out {shlex.quote(out_dir)} "
        f"--chunks {n_chunks}",
        "",
    ]
    return "\n".join(lines)


def _job_flags(out_dir: str, log_stem: str, job_name: str, cpus_per_task: int, time: str,
               mem: str | None) -> dict:
    """The #SBATCH flags every job of a run has (logs DIR/logs/STEM.out and .err)."""
    flags = {
        "cpus-per-task": str(cpus_per_task),
        "error": f"{out_dir}/logs/{log_stem}.err",
        "job-name": job_name,
        "ntasks": "1",
        "output": f"{out_dir}/logs/{log_stem}.out",
        "time": time,
    }
    if mem:
        flags["mem"] = mem
    return flags


def _header(flags: dict, partition: str | None, account: str | None,
            extra: Mapping[str, str] | None) -> list[str]:
    """The shebang and the #SBATCH lines, sorted (one place for both scripts)."""
    flags = dict(flags)
    if partition:
        flags["partition"] = partition
    if account:
        flags["account"] = account
    for k, v in (extra or {}).items():
        flags[k.lstrip("-")] = str(v)
    return ["#!/bin/bash"] + [f"#SBATCH --{k}={v}" for k, v in sorted(flags.items())]


def report_dir(results: str) -> str:
    """Where the merge job writes the report of the store `results`: beside it, `NAME_report`."""
    path = Path(results)
    return str(path.with_name(path.stem + "_report"))


def merge_script(*, out_dir: str, results: str, job_name: str, sweep_cmd: str = "sweep",
                 time: str = "01:00:00", partition: str | None = None,
                 account: str | None = None, extra: Mapping[str, str] | None = None,
                 refine: bool = False) -> str:
    """Text of the sbatch script that merges the shards of `out_dir` into the store `results`
    and writes its report (`report_dir(results)`); with `refine`, it only merges
    (``--no-refine``): the refine job (`refine_script`) refines and reports.

    It is submitted with ``--dependency=afterok:<array job id>`` (the id is known only then), so
    it runs once, after every array task succeeded. One core: the merge only copies arrays.
    """
    flags = {
        "cpus-per-task": "1",
        "error": f"{out_dir}/logs/merge_%j.err",
        "job-name": job_name,
        "ntasks": "1",
        "output": f"{out_dir}/logs/merge_%j.out",
        "time": time,
    }
    lines = _header(flags, partition, account, extra)
    lines += [
        "",
        "# Runs after every array task succeeded (submitted with --dependency=afterok:ARRAY_ID).",
        "set -euo pipefail",
    ]
    if refine:
        lines += [f"{sweep_cmd} merge {shlex.quote(out_dir)} --out {shlex.quote(results)} "
                  "--no-refine",
                  "# The refine job (--dependency=afterok:THIS_JOB) refines and reports.", ""]
        return "\n".join(lines)
    lines += [
        f"{sweep_cmd} merge {shlex.quote(out_dir)} --out {shlex.quote(results)}",
        _REPORT_COMMENT,
        f"{sweep_cmd} report {shlex.quote(results)} --out {shlex.quote(report_dir(results))}",
        "",
    ]
    return "\n".join(lines)


_REPORT_COMMENT = ("# The report of the merged store: figures, tables, report.md (see "
                   "`sweep report --help`).")


def refine_script(*, out_dir: str, results: str, job_name: str, sweep_cmd: str = "sweep",
                  cpus_per_task: int = 4, time: str = "01:00:00", mem: str | None = None,
                  partition: str | None = None, account: str | None = None,
                  extra: Mapping[str, str] | None = None) -> str:
    """Text of the sbatch script that refines the merged store `results` (`sweep refine`: the
    contenders' maps on finer grids, threads = the task's cores; resumes if rerun) and writes
    its report. Submitted with ``--dependency=afterok:<merge job id>``."""
    flags = _job_flags(out_dir, "refine_%j", job_name, cpus_per_task, time, mem)
    lines = _header(flags, partition, account, extra)
    lines += [
        "",
        "# Runs after the merge job succeeded (submitted with --dependency=afterok:MERGE_ID).",
        "# Resumes from RESULTS.refine/ if rerun: sbatch this script again.",
        "set -euo pipefail",
        "export OMP_NUM_THREADS=1",
        f"{sweep_cmd} refine {shlex.quote(results)} --no-progress",
        _REPORT_COMMENT,
        f"{sweep_cmd} report {shlex.quote(results)} --out {shlex.quote(report_dir(results))}",
        "",
    ]
    return "\n".join(lines)


class SubmitError(RuntimeError):
    """sbatch is missing or refused a script; the message is sbatch's own."""


def check(script_text: str, sbatch: str = "sbatch") -> None:
    """Ask the scheduler whether it would accept the script (``sbatch --test-only``): a bad
    partition, account or limit is refused here, before anything is written or submitted."""
    cmd = [sbatch, "--test-only"]
    try:
        res = subprocess.run(cmd, input=script_text, capture_output=True, text=True)
    except OSError as exc:
        raise SubmitError(f"cannot run {sbatch}: {exc.strerror}") from None
    if res.returncode != 0:
        why = " ".join(res.stderr.split()) or f"exit code {res.returncode}"
        raise SubmitError(f"sbatch refuses the array script: {why}")


def write_script(path: Path, text: str) -> None:
    """The script written atomically (the one writer of sweep.files)."""
    write_text_atomic(path, text)


def submit(script_path: str, options: Sequence[str] = (), sbatch: str = "sbatch") -> str:
    """Submit `script_path` with ``sbatch --parsable`` (plus `options`); return the job id."""
    cmd = [sbatch, "--parsable", *options, str(script_path)]
    try:
        res = subprocess.run(cmd, capture_output=True, text=True)
    except OSError as exc:
        raise SubmitError(f"cannot run {sbatch}: {exc.strerror}") from None
    if res.returncode != 0:
        why = " ".join(res.stderr.split()) or f"exit code {res.returncode}"
        raise SubmitError(f"{' '.join(cmd)}: {why}")
    job_id = res.stdout.strip().split(";")[0]      # --parsable: "ID" or "ID;CLUSTER"
    if not job_id.isdigit():
        raise SubmitError(f"{' '.join(cmd)}: unexpected answer {res.stdout.strip()!r}")
    return job_id
