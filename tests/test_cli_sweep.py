"""The sweep commands end to end, with the real kernels on tiny configs.

Covers the issue's acceptance checks: one run == 4 chunks + merge; status reports a deleted shard
as missing and a truncated one as corrupt, merge refuses both (exit 2); an interrupted run (Ctrl-C
in-process, SIGKILL in a subprocess) resumes to results bit-identical to an uninterrupted run and
never leaves a half-written file under a final name; bad configs fail before any work (exit 2).
"""
import os
import re
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import click
import h5py
import numpy as np
import pytest
from click.testing import CliRunner

from sweep.compute import batch
from sweep.runs import runner
from sweep.compute.batch import SUMMARY_FIELDS
from sweep.cli import register
from sweep.runs.rundir import SingleRun, prepare_parts_dir
from sweep.config.parse import scene_from_dict
from sweep.runs.slurm import sbatch_script
from sweep.storage.itemfile import read_item_file
from sweep.storage.store import read_store
from sweep_cases import tiny, write_config

DATA = Path(__file__).resolve().parent / "data"
NO_ARRAY_ENV = {var: None for var, _ in runner.ARRAY_INDEX_VARS} | {"SLURM_CPUS_PER_TASK": None}


@pytest.fixture(scope="module")
def cli():
    group = click.Group("sweep")
    register(group)
    return group


def invoke(cli, *args, env=None):
    result = CliRunner().invoke(cli, [str(a) for a in args], env=NO_ARRAY_ENV | (env or {}))
    if result.exception and not isinstance(result.exception, SystemExit):
        raise result.exception
    return result


def summaries(path):
    view = read_store(path)
    # fields of effects that are off are not stored (sweep.schema.EFFECT_SUMMARY)
    return {f: view.variables[f] for f in SUMMARY_FIELDS if f in view.variables}


def assert_same_summaries(a, b):
    va, vb = summaries(a), summaries(b)
    assert set(va) == set(vb)
    for f in va:
        assert va[f].dtype == vb[f].dtype
        np.testing.assert_array_equal(va[f], vb[f], err_msg=f)


@pytest.fixture(scope="module")
def reference(tmp_path_factory):
    """The tiny sweep run once, uninterrupted, on one machine (real kernels)."""
    root = tmp_path_factory.mktemp("reference")
    cfg = write_config(root / "tiny.yaml", tiny())
    group = click.Group("sweep")
    register(group)
    res = invoke(group, "run", cfg, "--out", root / "a.h5", "--no-progress")
    assert res.exit_code == 0, res.output
    return cfg, root / "a.h5"


@pytest.fixture(scope="module")
def chunked(reference, tmp_path_factory):
    """The same sweep as 4 chunks; the chunk index comes from each kind of array-job variable."""
    cfg, _ = reference
    root = tmp_path_factory.mktemp("chunked") / "run"
    group = click.Group("sweep")
    register(group)
    for args, env in ((["--chunk", 0], {}),
                      ([], {"SLURM_ARRAY_TASK_ID": "1"}),
                      ([], {"PBS_ARRAY_INDEX": "2"}),
                      ([], {"SGE_TASK_ID": "4"})):          # SGE counts from 1
        res = invoke(group, "run", cfg, "--out", root, "--chunks", 4, "--no-progress", *args,
                     env=env)
        assert res.exit_code == 0, res.output
    return root


def copy_run(chunked, tmp_path):
    dst = tmp_path / "run"
    shutil.copytree(chunked, dst)
    return dst


# ---------------------------------------------------------------------------------------------
def test_main_cli_has_the_sweep_commands():
    from sweep.cli import main

    assert {"run", "slurm", "status", "merge", "top", "show"} <= set(main.commands)


def test_run_writes_a_store_of_real_maps(reference):
    _, path = reference
    view = read_store(path)
    s = scene_from_dict(tiny())
    assert view.variables["Lambda"].shape == s.store_shape
    assert not list(path.parent.glob("*.parts"))            # work directory cleaned up
    n = view.variables
    # the kernels' counts are consistent: trajectories start from reached points only
    ends = n["n_caged"] + n["n_tip_prehension"] + n["n_ejection"] + n["n_stalled"]
    assert np.all(ends <= n["n_reached"]) and np.all(n["n_reached"] <= n["n_points"])
    assert n["n_caged"].sum() > 0                            # the tiny sweep does cage something


def test_chunks_and_merge_equal_one_run(cli, reference, chunked, tmp_path):
    _, single = reference
    res = invoke(cli, "status", chunked)
    assert res.exit_code == 0 and "4 done" in res.output
    assert not (chunked / "parts").exists()
    out = tmp_path / "merged.h5"
    res = invoke(cli, "merge", chunked, "--out", out)
    assert res.exit_code == 0, res.output
    assert_same_summaries(single, out)
    assert read_store(out).attrs["config_hash"] == read_store(single).attrs["config_hash"]


def test_status_and_merge_refuse_missing_and_corrupt_shards(cli, chunked, tmp_path):
    run = copy_run(chunked, tmp_path)
    (run / "shard-0001-of-0004.h5").unlink()
    shard = run / "shard-0002-of-0004.h5"
    shard.write_bytes(shard.read_bytes()[:1000])
    res = invoke(cli, "status", run)
    assert res.exit_code == 1
    lines = {int(m.group(1)): m.group(2)
             for m in re.finditer(r"^\s+(\d+)\s+(\w+)", res.output, re.M)}
    assert lines == {0: "done", 1: "missing", 2: "corrupt", 3: "done"}
    out = tmp_path / "m.h5"
    res = invoke(cli, "merge", run, "--out", out)
    assert res.exit_code == 2
    assert "shard 1 missing" in res.output and "shard 2 corrupt" in res.output
    assert not out.exists()


def test_merge_refuses_a_shard_of_another_config(cli, chunked, tmp_path):
    run = copy_run(chunked, tmp_path)
    other = write_config(tmp_path / "other.yaml", tiny(parts={"mu": [0.1, 0.8]}))
    foreign = tmp_path / "foreign"
    res = invoke(cli, "run", other, "--out", foreign, "--chunks", 4, "--chunk", 3, "--no-progress")
    assert res.exit_code == 0
    shutil.copy(foreign / "shard-0003-of-0004.h5", run / "shard-0003-of-0004.h5")
    res = invoke(cli, "merge", run, "--out", tmp_path / "m.h5")
    assert res.exit_code == 2 and "shard 3 mismatched" in res.output and "config" in res.output


def test_a_chunk_refuses_a_run_directory_of_another_config(cli, chunked, tmp_path):
    run = copy_run(chunked, tmp_path)
    other = write_config(tmp_path / "other.yaml", tiny(grid={"h": 0.3}))
    res = invoke(cli, "run", other, "--out", run, "--chunks", 4, "--chunk", 0, "--no-progress")
    assert res.exit_code == 2 and "different config" in res.output


def test_rerun_of_a_finished_run_does_nothing(cli, reference, monkeypatch):
    cfg, path = reference
    before = path.stat().st_mtime_ns
    monkeypatch.setattr(batch, "summarize_cells", _forbidden)
    res = invoke(cli, "run", cfg, "--out", path, "--no-progress")
    assert res.exit_code == 0 and "already complete" in res.output
    assert path.stat().st_mtime_ns == before


def _forbidden(*args, **kwargs):
    raise AssertionError("nothing should be computed")


def test_finished_chunk_is_not_recomputed(cli, chunked, tmp_path, monkeypatch):
    run = copy_run(chunked, tmp_path)
    cfg = write_config(tmp_path / "tiny.yaml", tiny())
    monkeypatch.setattr(batch, "summarize_cells", _forbidden)
    res = invoke(cli, "run", cfg, "--out", run, "--chunks", 4, "--chunk", 2, "--no-progress")
    assert res.exit_code == 0 and "already complete" in res.output


def test_ctrl_c_keeps_finished_work_and_rerun_resumes(cli, reference, tmp_path, monkeypatch):
    cfg, single = reference
    real = batch.summarize_cells
    calls = []

    def interrupted_after_two(cells, *args, **kwargs):
        if len(calls) == 2:
            raise KeyboardInterrupt
        calls.append(len(cells))
        return real(cells, *args, **kwargs)

    out = tmp_path / "a.h5"
    monkeypatch.setattr(batch, "summarize_cells", interrupted_after_two)
    res = invoke(cli, "run", cfg, "--out", out, "--no-progress")
    assert res.exit_code == 130 and "rerun the same command to resume" in res.output
    assert not out.exists()
    parts = sorted((tmp_path / "a.h5.parts").glob("items-*.h5"))
    assert len(parts) == 2 and all(read_item_file(p).stop > read_item_file(p).start for p in parts)
    assert not list(tmp_path.rglob(".*.tmp*"))              # nothing half-written left behind

    counted = []

    def counting(cells, *args, **kwargs):
        counted.append(len(cells))
        return real(cells, *args, **kwargs)

    monkeypatch.setattr(batch, "summarize_cells", counting)
    res = invoke(cli, "run", cfg, "--out", out, "--no-progress")
    assert res.exit_code == 0, res.output
    assert sum(counted) == scene_from_dict(tiny()).n_items - sum(calls)  # only what was missing
    assert_same_summaries(single, out)


def test_every_sub_chunk_runs_on_the_threads_asked_for(cli, reference, tmp_path, monkeypatch):
    """The runner computes sub-chunks in worker threads, where Numba's thread count is the
    thread's own: `--threads 1` must reach every kernel call there, and the store is the same."""
    import numba

    cfg, single = reference
    real = batch.summarize_cells
    seen = []

    def recording(cells, *args, **kwargs):
        seen.append(numba.get_num_threads())
        return real(cells, *args, **kwargs)

    monkeypatch.setattr(batch, "summarize_cells", recording)
    out = tmp_path / "one-thread.h5"
    res = invoke(cli, "run", cfg, "--out", out, "--no-progress", "--threads", 1)
    assert res.exit_code == 0, res.output
    assert len(seen) >= 2 and set(seen) == {1}
    assert_same_summaries(single, out)


def test_foreign_work_directory_needs_restart(cli, reference, tmp_path):
    cfg, single = reference
    other = write_config(tmp_path / "other.yaml", tiny(grid={"h": 0.3}))
    out = tmp_path / "a.h5"
    prepare_parts_dir(SingleRun(out).parts, scene_from_dict(tiny(grid={"h": 0.3})), 0, 1)
    res = invoke(cli, "run", cfg, "--out", out, "--no-progress")
    assert res.exit_code == 2 and "--restart" in res.output and not out.exists()
    res = invoke(cli, "run", cfg, "--out", out, "--no-progress", "--restart")
    assert res.exit_code == 0
    assert_same_summaries(single, out)
    assert other.exists()


@pytest.mark.parametrize("changes, key", [
    pytest.param({"designs": {"l1": {"lower": 0.8, "upper": 1.2, "step": 0}}}, "designs.l1.step",
                 id="step-zero"),
    pytest.param({"designs": {"l1": {"lower": 1.2, "upper": 0.8, "step": 0.2}}}, "designs.l1",
                 id="lower-above-upper"),
    pytest.param({"parts": {"mu": []}}, "parts.mu", id="empty"),
    pytest.param({"grid": {"h": 1e-5}}, "grid.h", id="grid-too-large"),
    pytest.param({"speed": "fast"}, "speed", id="unknown-key"),
    pytest.param({"effects": {"joint_springs": True}}, "effects.joint_springs",
                 id="effect-not-implemented"),
])
@pytest.mark.parametrize("mode", ["single", "chunk", "slurm"])
def test_bad_config_fails_before_any_work(cli, tmp_path, monkeypatch, changes, key, mode):
    monkeypatch.setattr(batch, "summarize_cells", _forbidden)
    cfg = write_config(tmp_path / "bad.yaml", tiny(**changes))
    out = tmp_path / "out"
    args = {"single": ["run", cfg, "--out", out],
            "chunk": ["run", cfg, "--out", out, "--chunks", 2, "--chunk", 0],
            "slurm": ["slurm", cfg, "--out", out, "--chunks", 2]}[mode]
    res = invoke(cli, *args)
    assert res.exit_code == 2
    assert f"{key}:" in res.output
    assert list(tmp_path.iterdir()) == [cfg]                # nothing written


@pytest.mark.parametrize("args, env, message", [
    pytest.param(["--chunks", 4], {}, "--chunks without --chunk", id="no-chunk-index"),
    pytest.param(["--chunks", 4, "--chunk", 4], {}, "outside 0..3", id="chunk-too-large"),
    pytest.param(["--chunks", 4], {"SLURM_ARRAY_TASK_ID": "7"}, "SLURM_ARRAY_TASK_ID",
                 id="env-chunk-too-large"),
    pytest.param(["--chunks", 99, "--chunk", 0], {}, "at most 16", id="more-chunks-than-items"),
    pytest.param(["--threads", 0], {}, "threads must be", id="zero-threads"),
    pytest.param(["--chunk", 1], {}, "--chunk needs --chunks", id="chunk-without-chunks"),
])
def test_bad_run_options_exit_2(cli, tmp_path, monkeypatch, args, env, message):
    monkeypatch.setattr(batch, "summarize_cells", _forbidden)
    cfg = write_config(tmp_path / "tiny.yaml", tiny())
    res = invoke(cli, "run", cfg, "--out", tmp_path / "out", *args, env=env)
    assert res.exit_code == 2 and message in res.output


@pytest.mark.parametrize("env, expected", [
    pytest.param({}, None, id="none"),
    pytest.param({"SLURM_ARRAY_TASK_ID": "3"}, (3, "SLURM_ARRAY_TASK_ID"), id="slurm"),
    pytest.param({"PBS_ARRAY_INDEX": "0"}, (0, "PBS_ARRAY_INDEX"), id="pbs"),
    pytest.param({"SGE_TASK_ID": "1"}, (0, "SGE_TASK_ID"), id="sge-1-based"),
    pytest.param({"SGE_TASK_ID": "undefined"}, None, id="sge-not-array"),
    pytest.param({"LSB_JOBINDEX": "5"}, (4, "LSB_JOBINDEX"), id="lsf-1-based"),
    pytest.param({"LSB_JOBINDEX": "0"}, None, id="lsf-not-array"),
])
def test_chunk_index_from_env(env, expected):
    assert runner.chunk_index_from_env(env) == expected


@pytest.mark.parametrize("threads, env, expected", [
    pytest.param(None, {}, None, id="default"),
    pytest.param(None, {"SLURM_CPUS_PER_TASK": "2"}, 2, id="slurm"),
    pytest.param(1, {"SLURM_CPUS_PER_TASK": "2"}, 1, id="option-wins"),
])
def test_thread_count(threads, env, expected):
    assert runner.resolve_threads(threads, env) == expected


def test_thread_count_is_set_and_restored():
    import numba

    before = numba.get_num_threads()
    with runner.numba_threads(1) as n:
        assert n == numba.get_num_threads() == 1
    assert numba.get_num_threads() == before


def test_progress_bar_counts_maps(cli, tmp_path):
    cfg = write_config(tmp_path / "tiny.yaml", tiny(designs={"l1": [0.8], "l2": [0.4]}))
    res = invoke(cli, "run", cfg, "--out", tmp_path / "a.h5")
    assert res.exit_code == 0
    assert "8/8" in res.stderr and "map/s" in res.stderr


# ---------------------------------------------------------------------------------------------
def test_sbatch_script_golden():
    text = sbatch_script(config="/work/configs/paper.yaml", out_dir="/scratch/runs/paper",
                         n_chunks=64, job_name="sweep-paper", sweep_cmd="/opt/venv/bin/sweep",
                         parallel=16, cpus_per_task=8, time="02:00:00", mem="4G",
                         partition="compute", extra={"qos": "normal"}, n_maps=86_400,
                         config_hash="ffca9e46392c" + "0" * 52)
    assert text == (DATA / "sbatch_paper.golden").read_text()


def test_slurm_command_prepares_the_run_directory(cli, reference, tmp_path):
    cfg, _ = reference
    out = tmp_path / "runs" / "tiny"
    res = invoke(cli, "slurm", cfg, "--chunks", 4, "--out", out, "--parallel", 2,
                 "--sbatch", "qos=short")
    assert res.exit_code == 0, res.output
    text = res.stdout
    assert "#SBATCH --array=0-3%2" in text and "#SBATCH --qos=short" in text
    assert f"#SBATCH --output={out.resolve()}/logs/%A_%a.out" in text
    assert f"run {cfg.resolve()} --out {out.resolve()} --chunks 4" in text
    flags = [line for line in text.splitlines() if line.startswith("#SBATCH")]
    assert flags == sorted(flags)
    assert (out / "logs").is_dir() and (out / "sweep-manifest.json").exists()
    res = invoke(cli, "status", out)                         # nothing run yet
    assert res.exit_code == 1 and "4 missing" in res.output
    assert len(re.findall(r"^\s+\d+\s+missing", res.output, re.M)) == 4


def test_top_ranks_designs_of_one_part(cli, reference):
    _, path = reference
    res = invoke(cli, "top", path, "--r", 0.4, "--mu", 0.7, "-n", 3, "--by", "caging_area")
    assert res.exit_code == 0, res.output
    view = read_store(path)
    area = view.variables["caging_area"][:, :, :, :, :, 0, 1].reshape(-1)
    best = np.sort(area)[::-1][:3]
    rows = [line.split() for line in res.output.splitlines()[2:]]
    head = res.output.splitlines()[1].split()
    assert [r[0] for r in rows] == ["1", "2", "3"]
    got = [float(r[head.index("caging_area")]) for r in rows]
    np.testing.assert_allclose(got, best, rtol=1e-5)
    assert invoke(cli, "top", path, "--r", 0.5, "--mu", 0.7).exit_code == 2
    assert invoke(cli, "top", path, "--r", 0.4, "--mu", 0.7, "--by", "speed").exit_code == 2


def test_top_without_a_part_lists_the_best_design_of_every_part(cli, reference):
    _, path = reference
    res = invoke(cli, "top", path)
    assert res.exit_code == 0, res.output
    view = read_store(path)
    n_parts = view.coords["r"].size * view.coords["mu"].size
    headers = [line for line in res.output.splitlines() if line.startswith("part r = ")]
    assert len(headers) == n_parts > 1
    lam = view.variables["Lambda"]
    best_rows = [line.split() for line in res.output.splitlines() if line.startswith("   1 ")]
    head = res.output.splitlines()[1].split()
    got = sorted(float(row[head.index("Lambda")]) for row in best_rows)
    want = sorted(lam[:, :, :, :, :, i, k].max() for i in range(view.coords["r"].size)
                  for k in range(view.coords["mu"].size))
    np.testing.assert_allclose(got, want, rtol=1e-5)


def test_show_describes_the_store(cli, reference):
    _, path = reference
    res = invoke(cli, "show", path)
    assert res.exit_code == 0
    s = scene_from_dict(tiny())
    assert "32 maps" in res.output and s.config_hash[:12] in res.output
    assert "effects on: friction" in res.output and "caging_area" in res.output


@pytest.mark.skipif(shutil.which("h5ls") is None or shutil.which("h5dump") is None,
                    reason="HDF5 command-line tools not installed")
def test_store_opens_with_the_hdf5_tools(reference):
    _, path = reference
    listing = subprocess.run(["h5ls", str(path)], capture_output=True, text=True, check=True)
    assert re.search(r"^Lambda\s+Dataset \{2, 2, 1, 2, 2, 1, 2\}", listing.stdout, re.M)
    dump = subprocess.run(["h5dump", "-a", "/config_hash", str(path)], capture_output=True,
                          text=True, check=True)
    assert scene_from_dict(tiny()).config_hash in dump.stdout


def test_show_refuses_other_files(cli, tmp_path):
    p = tmp_path / "x.h5"
    with h5py.File(p, "w") as f:
        f["a"] = 1
    assert invoke(cli, "show", p).exit_code == 2


def test_saved_maps_agree_with_the_summaries(cli, tmp_path):
    point = dict(l1=1.2, l2=0.8, r1=0.12, r2=0.1, w=0.5, r=0.4, mu=0.7)
    cfg = write_config(tmp_path / "tiny.yaml",
                       tiny(outputs={"save_maps": [point]}, designs={"l1": [1.2]}))
    out = tmp_path / "a.h5"
    assert invoke(cli, "run", cfg, "--out", out, "--no-progress").exit_code == 0
    maps = list((tmp_path / "a.h5.maps").glob("*.h5"))
    assert len(maps) == 1
    view = read_store(out)
    idx = tuple(int(np.flatnonzero(view.coords[d] == point[d])[0]) for d in view.dims)
    with h5py.File(maps[0], "r") as f:
        assert f.attrs["Lambda"] == view.variables["Lambda"][idx]
        assert f.attrs["n_caged"] == view.variables["n_caged"][idx]


def test_saved_maps_of_another_config_are_recomputed(cli, tmp_path):
    """A rerun with --overwrite and another grid must not keep the old config's map file."""
    point = dict(l1=1.2, l2=0.8, r1=0.12, r2=0.1, w=0.5, r=0.4, mu=0.7)
    out = tmp_path / "a.h5"
    for h in (0.2, 0.1):
        cfg = write_config(tmp_path / f"h{h}.yaml", tiny(outputs={"save_maps": [point]},
                                                         designs={"l1": [1.2]}, grid={"h": h}))
        res = invoke(cli, "run", cfg, "--out", out, "--no-progress", "--overwrite")
        assert res.exit_code == 0, res.output
    (saved,) = (tmp_path / "a.h5.maps").glob("*.h5")
    view = read_store(out)
    idx = tuple(int(np.flatnonzero(view.coords[d] == point[d])[0]) for d in view.dims)
    with h5py.File(saved, "r") as f:
        assert f.attrs["h"] == 0.1
        assert f.attrs["Lambda"] == view.variables["Lambda"][idx]


def test_top_refuses_a_command_index_the_store_does_not_have(cli, reference):
    _, path = reference
    assert invoke(cli, "top", path, "--r", 0.4, "--mu", 0.7, "--command", 3).exit_code == 2


@pytest.mark.parametrize("changes, key", [
    (dict(accuracy={"reconfig_step": 1e-9}), "accuracy.reconfig_step"),
    (dict(accuracy={"root_tol": 0.0}), "accuracy.root_tol"),
    (dict(grid={"h": 1e-320}), "grid.h"),
    (dict(designs={"l1": [1e308]}), "l1"),   # beyond the lengths the model accepts
])
def test_extreme_configs_fail_at_the_edge(cli, tmp_path, changes, key):
    cfg = write_config(tmp_path / "bad.yaml", tiny(**changes))
    res = invoke(cli, "run", cfg, "--out", tmp_path / "bad.h5", "--no-progress")
    assert res.exit_code == 2, res.output
    assert key in res.output
    assert not (tmp_path / "bad.h5").exists()


# ---------------------------------------------------------------------------------------------
KILL_CFG = dict(
    name="killme",
    designs={"l1": [1.6, 2.0], "l2": [1.2, 1.6], "r1": [0.08, 0.12, 0.16, 0.2],
             "r2": [0.06, 0.14], "w": {"lower": 0.0, "upper": 2.0, "step": 0.4}},
    parts={"r": [0.4], "mu": [0.4, 1.0]},
    grid={"h": 0.05},
    run={"sub_chunk_cells": 2},
)


def _wait_for_parts(proc, parts, n, seen):
    """Poll until `n` part files exist; read each one as soon as it is visible."""
    while len(seen) < n:
        assert proc.poll() is None, proc.communicate()
        for p in parts.glob("items-*.h5") if parts.exists() else []:
            if p not in seen:
                read_item_file(p)                                # complete the moment it is visible
                seen.add(p)
        time.sleep(0.005)


def test_sigterm_and_sigkill_then_rerun_is_bit_identical(tmp_path):
    """A real `sweep run` in a subprocess: SIGTERM once sub-chunks appear (exit 130, message),
    rerun and SIGKILL it, rerun to the end: results equal an uninterrupted run bit for bit, and
    every file that appears under a final name is complete when first seen."""
    cfg = write_config(tmp_path / "k.yaml", tiny(**KILL_CFG))
    out = tmp_path / "k.h5"
    parts = tmp_path / "k.h5.parts"
    cmd = [sys.executable, "-m", "sweep.cli", "run", str(cfg), "--out", str(out),
           "--no-progress", "--threads", "1"]
    env = {k: v for k, v in os.environ.items() if k not in NO_ARRAY_ENV}
    seen = set()
    for sig, expected_rc in ((signal.SIGTERM, 130), (signal.SIGKILL, -signal.SIGKILL)):
        proc = subprocess.Popen(cmd, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                                text=True)
        try:
            _wait_for_parts(proc, parts, len(seen) + 2, seen)
        finally:
            proc.send_signal(sig)
            _, err = proc.communicate()
        assert proc.returncode == expected_rc, err
        if sig == signal.SIGTERM:
            assert "terminated" in err and "rerun the same command" in err
            assert not list(tmp_path.rglob(".*.tmp*"))       # a clean stop leaves no tmp file
        assert not out.exists()
        for p in parts.glob("items-*.h5"):
            read_item_file(p)                                    # what survived is whole

    res = subprocess.run(cmd, env=env, capture_output=True, text=True)
    assert res.returncode == 0, res.stderr
    total = scene_from_dict(tiny(**KILL_CFG)).n_maps
    computed = int(re.search(r"\(([\d,]+) computed now\)", res.stdout).group(1).replace(",", ""))
    assert 0 < computed <= total - 4 * 2 * 6                 # resumed: >= 4 parts of 2 cells kept
    assert not parts.exists() and not list(tmp_path.glob(".*.tmp*"))

    ref = tmp_path / "ref.h5"
    runner.run_single(scene_from_dict(tiny(**KILL_CFG)), ref, progress=False)
    assert_same_summaries(ref, out)


def test_small_config_run_equals_four_chunks_merged(cli, tmp_path):
    """The issue's acceptance check, on configs/small.yaml itself (including its saved map)."""
    cfg = Path(__file__).resolve().parent.parent / "configs" / "small.yaml"
    res = invoke(cli, "run", cfg, "--out", tmp_path / "a.h5", "--no-progress")
    assert res.exit_code == 0, res.output
    for k in range(4):
        res = invoke(cli, "run", cfg, "--out", tmp_path / "run", "--chunks", 4, "--chunk", k,
                     "--no-progress")
        assert res.exit_code == 0, res.output
    assert invoke(cli, "merge", tmp_path / "run", "--out", tmp_path / "b.h5").exit_code == 0
    assert_same_summaries(tmp_path / "a.h5", tmp_path / "b.h5")
    a, b = read_store(tmp_path / "a.h5").attrs, read_store(tmp_path / "b.h5").attrs
    if "saved_maps" in a:                                    # sweep.maps present
        assert a["saved_maps"] == b["saved_maps"]
