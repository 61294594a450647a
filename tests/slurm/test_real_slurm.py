"""The sweep as a SLURM array job on a real scheduler (`make test-slurm`; not part of `make test`).

A single-node cluster on loopback (tests/slurm/local_slurm.py: Debian's slurm-wlm + munge,
installed if missing) runs configs/small.yaml as 4 array tasks:
- the script `sweep slurm` prints, under `sbatch --wait`, merges to a store equal to a local
  `sweep run` of the same config: every dataset bit for bit, every attribute but timings;
- one task, stopped once it has written a sub-chunk, is cancelled with `scancel JOB_I`; the
  index resubmitted alone resumes from the kept sub-chunks; the merge is still identical;
- `sweep slurm --submit` submits the array plus a merge job (afterok) that writes the same store
  and its report.
The cluster's daemons are stopped by pid and its directory removed, pass or fail. If SLURM cannot
be installed or started, the test fails with the daemon's name and its log lines.
"""
from __future__ import annotations

import atexit
import json
import os
import re
import signal
import subprocess
import sys
import time
from pathlib import Path

import h5py
import numpy as np
import pytest

from local_slurm import ClusterError, LocalSlurm

REPO = Path(__file__).resolve().parents[2]
SMALL = REPO / "configs" / "small.yaml"
SWEEP = str(Path(sys.executable).parent / "sweep")
N_CHUNKS = 4
# One core per task: two tasks at once on a 2-core node, each with one Numba thread.
SLURM_ARGS = ["--chunks", str(N_CHUNKS), "--cpus-per-task", "1", "--time", "00:10:00"]
HANG_GUARD = 300.0      # seconds; only stops a stuck test, never asserted on

# Attributes that legitimately differ between a local run and a merged cluster run: timings,
# when/how the file was written, and where its saved maps sit (beside each store).
NOT_COMPARED = {"created_utc", "created_by", "threads", "saved_maps_dir", "maps_per_second"}


def _is_timing(name: str) -> bool:
    return name.endswith("_seconds") or name.startswith("seconds_")


# ---------------------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def cluster():
    c = LocalSlurm(log=lambda msg: print(msg, file=sys.stderr))
    atexit.register(_stop_quietly, c)      # if pytest itself is torn down early
    previous = signal.signal(signal.SIGTERM, _sigterm)
    try:
        try:
            c.start()
        except ClusterError as exc:
            _stop_quietly(c)
            pytest.fail(f"SLURM could not be set up here, so the cluster path is untested: {exc}",
                        pytrace=False)
        yield c
    finally:
        signal.signal(signal.SIGTERM, previous)
        try:
            c.stop()
        except ClusterError as exc:
            pytest.fail(f"the test cluster did not stop cleanly: {exc}", pytrace=False)


def _sigterm(signum, frame):
    raise KeyboardInterrupt("SIGTERM")     # unwinds through the fixture, which stops the daemons


def _stop_quietly(c):
    try:
        c.stop()
    except ClusterError as exc:
        print(f"local_slurm: {exc}", file=sys.stderr)


@pytest.fixture(scope="module")
def work(cluster):
    d = cluster.root / "work"
    d.mkdir()
    return d


@pytest.fixture(scope="module")
def local_store(work):
    """configs/small.yaml computed on this machine, no scheduler involved."""
    out = work / "local.h5"
    res = subprocess.run([SWEEP, "run", str(SMALL), "--out", str(out), "--no-progress"],
                         env=_no_slurm_env(), capture_output=True, text=True)
    assert res.returncode == 0, res.stderr
    return out


def _no_slurm_env():
    return {k: v for k, v in os.environ.items()
            if not k.startswith(("SLURM_", "PBS_", "SGE_", "LSB_"))}


def sweep(cluster, *args, cwd=None):
    return subprocess.run([SWEEP, *map(str, args)], env=cluster.env, capture_output=True,
                          text=True, cwd=cwd)


def printed_script(cluster, out):
    res = sweep(cluster, "slurm", SMALL, "--out", out, *SLURM_ARGS)
    assert res.returncode == 0, res.stderr
    assert res.stdout.startswith("#!/bin/bash") and "#SBATCH --array=0-3" in res.stdout
    return res.stdout


def job_logs(out: Path) -> str:
    text = []
    for p in sorted((out / "logs").glob("*")):
        text.append(f"--- {p.name}\n{p.read_text(errors='replace')}")
    return "\n".join(text)


def merge(cluster, out, merged):
    res = sweep(cluster, "merge", out, "--out", merged)
    assert res.returncode == 0, res.stderr + job_logs(out)


# ---------------------------------------------------------------------------------------------
# Independent comparison of two HDF5 files (h5py only, no sweep code)
# ---------------------------------------------------------------------------------------------
def _objects(f: h5py.File) -> dict:
    found = {"/": f}
    f.visititems(lambda name, obj: found.__setitem__(name, obj))
    return found


def _attr_value(f, value):
    """Comparable form of an attribute: object references become the referenced names."""
    arr = np.asarray(value)
    if arr.dtype.kind == "O" or arr.dtype.names:
        return repr(_deref(f, value))
    return arr


def _deref(f, value):
    if isinstance(value, h5py.Reference):
        return f[value].name if value else None
    if isinstance(value, (np.ndarray, list, tuple, np.void)):
        return [_deref(f, v) for v in value]
    if isinstance(value, bytes):
        return value.decode()
    return value


def assert_same_file(a: Path, b: Path):
    """Same objects; every dataset bit for bit (dtype, shape, bytes); every attribute equal
    except timings and where/when the file was written."""
    with h5py.File(a, "r") as fa, h5py.File(b, "r") as fb:
        oa, ob = _objects(fa), _objects(fb)
        assert sorted(oa) == sorted(ob), f"{a.name} vs {b.name}: different objects"
        for name in oa:
            x, y = oa[name], ob[name]
            if isinstance(x, h5py.Dataset):
                assert isinstance(y, h5py.Dataset), name
                assert (x.dtype, x.shape) == (y.dtype, y.shape), name
                vx, vy = np.asarray(x[()]), np.asarray(y[()])
                if vx.dtype.kind == "O":                        # strings: compare the text
                    assert vx.tolist() == vy.tolist(), f"{name}: values differ"
                else:
                    assert vx.tobytes() == vy.tobytes(), f"{name}: values differ"
            keys = {k for k in set(x.attrs) | set(y.attrs)
                    if k not in NOT_COMPARED and not _is_timing(k)}
            for k in sorted(keys):
                assert k in x.attrs and k in y.attrs, f"{name}: attribute {k} only in one file"
                va, vb = _attr_value(fa, x.attrs[k]), _attr_value(fb, y.attrs[k])
                if isinstance(va, str) or isinstance(vb, str):
                    assert va == vb, f"{name}.{k}: {va} != {vb}"
                else:
                    assert va.dtype == vb.dtype and va.tobytes() == vb.tobytes(), \
                        f"{name}.{k}: {va!r} != {vb!r}"


def assert_same_as_local(local: Path, merged: Path, out: Path):
    assert_same_file(local, merged)
    local_maps = sorted(local.with_name(local.name + ".maps").glob("*.h5"))
    cluster_maps = sorted((out / "maps").glob("*.h5"))
    assert local_maps, "configs/small.yaml saves one full map; the local run wrote none"
    assert [p.name for p in local_maps] == [p.name for p in cluster_maps]
    for p, q in zip(local_maps, cluster_maps):
        assert_same_file(p, q)


# ---------------------------------------------------------------------------------------------
def test_printed_script_under_sbatch_wait_merges_to_the_local_result(cluster, work, local_store):
    out = work / "printed"
    script = printed_script(cluster, out)
    res = cluster.run(["sbatch", "--wait"], check=False, input=script, cwd=work,
                      timeout=HANG_GUARD)
    assert res.returncode == 0, res.stderr + job_logs(out)
    assert sweep(cluster, "status", out).returncode == 0
    merge(cluster, out, work / "printed.h5")
    assert_same_as_local(local_store, work / "printed.h5", out)


def test_a_cancelled_task_resubmitted_resumes_its_shard(cluster, work, local_store):
    out = work / "cancelled"
    script = printed_script(cluster, out)
    ranges = json.loads((out / "sweep-manifest.json").read_text())["chunk_ranges"]
    k = max(range(N_CHUNKS), key=lambda i: ranges[i][1] - ranges[i][0])   # most sub-chunks
    shard = out / f"shard-{k:04d}-of-{N_CHUNKS:04d}.h5"
    parts = out / "parts" / shard.stem

    script_file = work / "cancelled.sbatch"
    script_file.write_text(script)
    waiting = subprocess.Popen(["sbatch", "--wait", str(script_file)], env=cluster.env, cwd=work,
                               text=True, stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    try:
        job_id = re.search(r"Submitted batch job (\d+)", waiting.stdout.readline()).group(1)
        pid = _find_task_process(job_id, k, waiting)
        kept_before = _step_until_a_part_exists(pid, parts, shard)
        assert not shard.exists() and kept_before >= 1         # really midway
        cluster.run(["scancel", f"{job_id}_{k}"])              # the task still stopped
        _, err = waiting.communicate(timeout=HANG_GUARD)
    finally:
        if waiting.poll() is None:
            waiting.kill()
            waiting.wait()
    why = f"sbatch --wait: {err}\n{job_logs(out)}"
    assert waiting.returncode != 0, why                         # one task did not succeed
    assert cluster.job_state(f"{job_id}_{k}") == "CANCELLED", why
    for i in range(N_CHUNKS):
        if i != k:
            assert cluster.job_state(f"{job_id}_{i}") == "COMPLETED", why
    task_err = (out / "logs" / f"{job_id}_{k}.err").read_text()
    assert "terminated; finished sub-chunks are kept" in task_err, why   # sweep saw SIGTERM
    assert not shard.exists(), why
    kept = sorted(parts.glob("items-*.h5"))
    assert len(kept) >= kept_before, why
    kept_items = sum(int(b) - int(a) for a, b in
                     (re.match(r"items-(\d+)-(\d+)\.h5", p.name).groups() for p in kept))
    status = sweep(cluster, "status", out)
    assert status.returncode == 1 and re.search(rf"^\s+{k}\s+missing", status.stdout, re.M), \
        status.stdout + why

    # resubmit index k alone (--array on the command line overrides the script's)
    res = cluster.run(["sbatch", "--wait", f"--array={k}", str(script_file)], check=False,
                      cwd=work, timeout=HANG_GUARD)
    assert res.returncode == 0, res.stderr + job_logs(out)
    new_id = re.search(r"Submitted batch job (\d+)", res.stdout).group(1)
    log = (out / "logs" / f"{new_id}_{k}.out").read_text()
    m = re.search(r"wrote .*: ([\d,]+) maps \(([\d,]+) computed now\)", log)
    assert m, log
    n_maps, computed = (int(g.replace(",", "")) for g in m.groups())
    items = ranges[k][1] - ranges[k][0]
    assert computed == n_maps - kept_items * (n_maps // items), log  # only what was not kept
    assert shard.exists() and not parts.exists()
    merge(cluster, out, work / "cancelled.h5")
    assert_same_as_local(local_store, work / "cancelled.h5", out)


def _find_task_process(job_id: str, k: int, waiting) -> int:
    """Pid of array task k's `sweep run`, stopped (SIGSTOP) as soon as it is seen: Python's
    start-up takes far longer than one poll, so it is caught before computing anything."""
    want = {b"SLURM_ARRAY_JOB_ID=" + job_id.encode(), b"SLURM_ARRAY_TASK_ID=" + str(k).encode()}
    deadline = time.monotonic() + HANG_GUARD
    while time.monotonic() < deadline:
        assert waiting.poll() is None, "the array finished before its task could be caught"
        for entry in Path("/proc").iterdir():
            if not entry.name.isdigit():
                continue
            try:
                argv = (entry / "cmdline").read_bytes().split(b"\0")
                # the `sweep` console script: `python .../bin/sweep run ...`
                if b"run" not in argv or not any(a.endswith(b"sweep") or b"sweep.program" in a
                                                 for a in argv):
                    continue
                if not want <= set((entry / "environ").read_bytes().split(b"\0")):
                    continue
            except OSError:
                continue
            pid = int(entry.name)
            os.kill(pid, signal.SIGSTOP)
            return pid
        time.sleep(0.002)
    raise AssertionError(f"array task {job_id}_{k} never started")


def _step_until_a_part_exists(pid: int, parts: Path, shard: Path) -> int:
    """Let the stopped task run in short slices until it has written at least one sub-chunk;
    it is left stopped. Each slice is far shorter than one sub-chunk's compute, so it cannot
    run through the whole chunk between two looks."""
    deadline = time.monotonic() + HANG_GUARD
    while time.monotonic() < deadline:
        _wait_stopped(pid)
        n = len(list(parts.glob("items-*.h5"))) if parts.exists() else 0
        assert not shard.exists(), "the task finished its shard before it could be cancelled"
        if n:
            return n
        os.kill(pid, signal.SIGCONT)
        time.sleep(0.005)
        os.kill(pid, signal.SIGSTOP)
    raise AssertionError("the task wrote no sub-chunk")


def _wait_stopped(pid: int) -> None:
    while True:
        stat = Path(f"/proc/{pid}/stat").read_text()
        if stat.rsplit(")", 1)[1].split()[0] in "Tt":
            return
        time.sleep(0.001)


def test_submit_runs_the_array_and_the_merge_job(cluster, work, local_store):
    out = work / "submitted"
    res = sweep(cluster, "slurm", SMALL, "--out", out, *SLURM_ARGS, "--submit", cwd=work)
    assert res.returncode == 0, res.stderr
    array_id = re.search(r"^array job (\d+)", res.stdout, re.M).group(1)
    merge_id = re.search(r"^merge job (\d+)", res.stdout, re.M).group(1)
    assert (out / "sweep-array.sbatch").exists() and (out / "sweep-merge.sbatch").exists()
    state = _wait_finished(cluster, merge_id)
    assert state == "COMPLETED", job_logs(out)
    for i in range(N_CHUNKS):
        assert cluster.job_state(f"{array_id}_{i}") == "COMPLETED"
    # the dependency held: the merge started only once the last task had ended
    ends = [_job_field(cluster, f"{array_id}_{i}", "EndTime") for i in range(N_CHUNKS)]
    assert _job_field(cluster, merge_id, "StartTime") >= max(ends)   # ISO times sort as text
    assert_same_as_local(local_store, out / "results.h5", out)
    # ... and then wrote the report of the merged store beside it
    assert (out / "results_report" / "report.md").exists(), job_logs(out)
    assert (out / "results_report" / "best_caging.png").exists()


def _job_field(cluster, job_id: str, field: str) -> str:
    show = cluster.run(["scontrol", "-o", "show", "job", job_id]).stdout
    return re.search(rf"\b{field}=(\S+)", show).group(1)


def _wait_finished(cluster, job_id: str) -> str:
    deadline = time.monotonic() + HANG_GUARD
    while time.monotonic() < deadline:
        state = cluster.job_state(job_id)
        if state and state not in ("PENDING", "RUNNING", "CONFIGURING", "COMPLETING"):
            return state
        time.sleep(0.5)
    raise AssertionError(f"job {job_id} still {state} after {HANG_GUARD:.0f} s")


def test_submit_refused_by_the_scheduler_writes_nothing(cluster, work):
    out = work / "refused"
    res = sweep(cluster, "slurm", SMALL, "--out", out, *SLURM_ARGS, "--submit",
                "--partition", "no-such-partition", cwd=work)
    assert res.returncode == 2
    assert "partition" in res.stderr.lower() and len(res.stderr.strip().splitlines()) == 1
    assert not out.exists()
