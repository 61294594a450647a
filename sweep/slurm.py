"""The sbatch array script of a chunked sweep: a pure function of its inputs (golden-file tested).

Array task ``i`` runs ``sweep run CONFIG --out DIR --chunks N``; `sweep run` reads the chunk index
from ``SLURM_ARRAY_TASK_ID`` and its thread count from ``SLURM_CPUS_PER_TASK``. Logs go to
``DIR/logs/%A_%a.out`` (job id, array index).
"""
from __future__ import annotations

import shlex
from collections.abc import Mapping


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
    flags = {
        "array": array,
        "cpus-per-task": str(cpus_per_task),
        "error": f"{out_dir}/logs/%A_%a.err",
        "job-name": job_name,
        "ntasks": "1",
        "output": f"{out_dir}/logs/%A_%a.out",
        "time": time,
    }
    if mem:
        flags["mem"] = mem
    if partition:
        flags["partition"] = partition
    if account:
        flags["account"] = account
    for k, v in (extra or {}).items():
        flags[k.lstrip("-")] = str(v)
    lines = ["#!/bin/bash"]
    lines += [f"#SBATCH --{k}={v}" for k, v in sorted(flags.items())]
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
