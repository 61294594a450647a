"""Faults and bad input, as a user or an operator meets them (issue P8).

Every failure is one line naming the path or value, exit code 2, no traceback; nothing that
existed is changed; nothing is left behind (temporaries, locks). The read-only and disk-full
folders are real file systems: a tmpfs mounted read-only / 64 KiB small when the tests run as
root (skipped otherwise, or made with chmod where that binds).
"""
from __future__ import annotations

import hashlib
import json
import os
import random
import shutil
import signal
import socket
import subprocess
import sys
import threading
import time
from pathlib import Path

import h5py
import pytest
from click.testing import CliRunner

from sweep.runs import runner
from sweep.cli import main
from sweep.files import OutputLock
from sweep_cases import tiny, write_config

ROOT = Path(__file__).resolve().parents[1]
SMALL = ROOT / "configs" / "small.yaml"
MAP = ["map", "--l1", "2.0", "--l2", "1.6", "--r1", "0.2", "--r2", "0.14", "--w", "0.8",
       "--r", "0.4", "--mu", "0.4"]
NO_ARRAY_ENV = {var: None for var, _ in runner.ARRAY_INDEX_VARS} | {"SLURM_CPUS_PER_TASK": None}
HOST = socket.gethostname()


def invoke(*args):
    return CliRunner().invoke(main, [str(a) for a in args], env=NO_ARRAY_ENV)


def refused(res, *names):
    """Exit 2, one line on the output naming every `names`, no traceback."""
    assert res.exit_code == 2, res.output
    assert res.exception is None or isinstance(res.exception, SystemExit), res.exception
    assert "Traceback" not in res.output
    lines = [ln for ln in res.output.splitlines() if ln.strip()]
    assert len(lines) == 1, res.output
    for name in names:
        assert str(name) in lines[0], (name, lines[0])
    return lines[0]


def snapshot(root: Path) -> dict:
    """Every file under root (hidden ones too) -> sha256 of its bytes."""
    return {str(p.relative_to(root)): hashlib.sha256(p.read_bytes()).hexdigest()
            for p in sorted(root.rglob("*")) if p.is_file()}


def leftovers(root: Path) -> list[Path]:
    return [p for p in root.rglob("*") if ".tmp" in p.name or p.name.endswith(".lock")]


def _mount_tmpfs(path: Path, options: str) -> bool:
    if os.geteuid() != 0 or shutil.which("mount") is None:
        return False
    path.mkdir(parents=True, exist_ok=True)
    res = subprocess.run(["mount", "-t", "tmpfs", "-o", options, "tmpfs", str(path)],
                         capture_output=True)
    return res.returncode == 0


def _umount(path: Path) -> None:
    subprocess.run(["umount", str(path)], capture_output=True)


@pytest.fixture
def readonly_dir(tmp_path):
    ro = tmp_path / "RO"
    if _mount_tmpfs(ro, "ro,size=64k"):
        yield ro
        _umount(ro)
        return
    if os.geteuid() == 0:
        pytest.skip("root, but cannot mount a read-only tmpfs (and chmod does not bind root)")
    ro.mkdir()
    ro.chmod(0o555)
    yield ro
    ro.chmod(0o755)


@pytest.fixture
def full_dir(tmp_path):
    full = tmp_path / "FULL"
    if not _mount_tmpfs(full, "size=64k"):
        pytest.skip("needs root and mount to make a 64 KiB tmpfs (a real full disk)")
    yield full
    _umount(full)


@pytest.fixture(scope="module")
def done(tmp_path_factory):
    """configs/small.yaml run once, and as 2 finished chunks (for merges)."""
    root = tmp_path_factory.mktemp("done")
    res = invoke("run", SMALL, "--out", root / "a.h5", "--no-progress")
    assert res.exit_code == 0, res.output
    for k in range(2):
        res = invoke("run", SMALL, "--out", root / "run", "--chunks", 2, "--chunk", k,
                     "--no-progress")
        assert res.exit_code == 0, res.output
    return root


# ---------------------------------------------------------------------------------------------
# Outputs that cannot be written
# ---------------------------------------------------------------------------------------------
def test_read_only_output_folder_is_refused_by_every_command(readonly_dir, done, tmp_path):
    before = snapshot(tmp_path)
    for args, name in (
            (("run", SMALL, "--out", readonly_dir / "out.h5", "--no-progress"), "out.h5"),
            (("run", SMALL, "--out", readonly_dir / "run", "--chunks", 2, "--chunk", 0,
              "--no-progress"), "RO"),
            (("slurm", SMALL, "--chunks", 2, "--out", readonly_dir / "shards"), "RO"),
            (("merge", done / "run", "--out", readonly_dir / "m.h5"), "m.h5"),
            ((*MAP, "--h", "0.2", "--out", readonly_dir / "m.h5"), "m.h5")):
        line = refused(invoke(*args), name)
        assert "read-only" in line or "permission denied" in line, line
    assert snapshot(tmp_path) == before


def test_output_under_a_regular_file_is_refused_before_any_work(tmp_path, monkeypatch):
    import sweep.compute.maps

    def no_compute(*args, **kwargs):
        raise AssertionError("computed a map for an output that cannot be written")

    monkeypatch.setattr(sweep.compute.maps, "compute_map", no_compute)
    blocker = tmp_path / "f"
    blocker.write_text("a file")
    for args in (("run", SMALL, "--out", blocker / "out.h5", "--no-progress"),
                 ("run", SMALL, "--out", blocker / "run", "--chunks", 2, "--chunk", 0),
                 ("slurm", SMALL, "--chunks", 2, "--out", blocker / "shards"),
                 (*MAP, "--h", "0.2", "--out", blocker / "out.h5")):
        line = refused(invoke(*args), "f")
        assert "not a directory" in line
    assert [p.name for p in tmp_path.iterdir()] == ["f"] and blocker.read_text() == "a file"


def test_disk_full_is_one_line_and_keeps_finished_parts(full_dir, tmp_path):
    """A real `sweep map` process (the HDF5 library crashed on ENOSPC before), then a run."""
    out = full_dir / "m.h5"
    res = subprocess.run([sys.executable, "-m", "sweep", *MAP, "--h", "0.05", "--out",
                          str(out)], capture_output=True, text=True)
    assert res.returncode == 2, res.stderr
    assert "no space left on device" in res.stderr and str(out) in res.stderr
    assert "Traceback" not in res.stderr and len(res.stderr.strip().splitlines()) == 1
    assert list(full_dir.iterdir()) == []

    res = invoke("run", SMALL, "--out", full_dir / "a.h5", "--no-progress")
    line = refused(res, "no space left on device", "a.h5.parts")
    assert "rerun" in line
    parts = sorted((full_dir / "a.h5.parts").glob("items-*.h5"))
    assert parts                                        # finished parts kept, each complete
    for p in parts:
        with h5py.File(p, "r") as f:
            f["summaries"][...]
    assert not leftovers(full_dir) and not (full_dir / "a.h5").exists()


def test_merge_onto_a_full_disk_is_one_line_and_leaves_nothing(full_dir, done):
    """The store is written to disk as it grows (P13, flat memory): a disk that fills up halfway
    through is still one line from a real process, never an error inside the HDF5 library (which
    crashed the process at exit), and no temporary is left."""
    out = full_dir / "m.h5"
    with open(full_dir / "filler", "wb") as fh:           # leave a few KiB of the 64 free
        fh.write(b"\0" * 56 * 1024)
    res = subprocess.run([sys.executable, "-m", "sweep", "merge", str(done / "run"), "--out",
                          str(out)], capture_output=True, text=True)
    assert res.returncode == 2, res.stderr
    assert "no space left on device" in res.stderr and str(out) in res.stderr
    assert "Traceback" not in res.stderr and len(res.stderr.strip().splitlines()) == 1
    assert sorted(p.name for p in full_dir.iterdir()) == ["filler"]
    (full_dir / "filler").unlink()                         # with room, the same merge works
    res = subprocess.run([sys.executable, "-m", "sweep", "merge", str(done / "run"), "--out",
                          str(out)], capture_output=True, text=True)
    assert res.returncode == 0, res.stderr
    assert _variables(out) == _variables(done / "a.h5")


# ---------------------------------------------------------------------------------------------
# Existing files
# ---------------------------------------------------------------------------------------------
def test_map_refuses_to_replace_its_output_without_overwrite(tmp_path):
    out = tmp_path / "m.h5"
    out.write_bytes(b"an earlier result")
    refused(invoke(*MAP, "--h", "0.3", "--out", out), str(out), "--overwrite")
    assert out.read_bytes() == b"an earlier result"
    res = invoke(*MAP, "--h", "0.3", "--out", out, "--overwrite")
    assert res.exit_code == 0, res.output
    with h5py.File(out, "r") as f:
        assert "energy" in f


def test_map_refuses_the_same_file_for_map_and_plot(tmp_path):
    out = tmp_path / "x.h5"
    refused(invoke(*MAP, "--h", "0.3", "--out", out, "--plot", out), "--plot", "x.h5")
    assert not out.exists()


def test_merge_refuses_an_existing_output(done, tmp_path):
    out = tmp_path / "m.h5"
    out.write_bytes(b"keep me")
    refused(invoke("merge", done / "run", "--out", out), str(out), "--overwrite")
    assert out.read_bytes() == b"keep me"


# ---------------------------------------------------------------------------------------------
# Locks and temporaries of killed writers
# ---------------------------------------------------------------------------------------------
def test_a_second_writer_is_refused_naming_the_holder(done, tmp_path):
    before = snapshot(tmp_path)
    out = tmp_path / "same.h5"
    with OutputLock(out).acquire():
        line = refused(invoke("run", SMALL, "--out", out, "--no-progress"),
                       f"pid {os.getpid()}", HOST, "same.h5.lock")
        assert "--wait" in line
    merged = tmp_path / "m.h5"
    with OutputLock(merged).acquire():
        refused(invoke("merge", done / "run", "--out", merged), f"pid {os.getpid()}")
    run_dir = tmp_path / "run"
    shutil.copytree(done / "run", run_dir)
    shard = next(run_dir.glob("shard-0000-*.h5"))
    shard.unlink()
    before = snapshot(tmp_path)
    with OutputLock(shard).acquire():
        refused(invoke("run", SMALL, "--out", run_dir, "--chunks", 2, "--chunk", 0,
                       "--no-progress"), "chunk 0", f"pid {os.getpid()}")
    assert snapshot(tmp_path) == before and not leftovers(tmp_path)


def test_status_names_the_holder_of_a_shard_in_progress(done, tmp_path):
    run_dir = tmp_path / "run"
    shutil.copytree(done / "run", run_dir)
    shard = next(run_dir.glob("shard-0001-*.h5"))
    shard.unlink()
    with OutputLock(shard).acquire():
        res = invoke("status", run_dir)
    assert res.exit_code == 1
    assert f"locked by pid {os.getpid()} on host {HOST}" in res.output


def test_wait_takes_the_output_when_the_holder_finishes(done, tmp_path):
    out = tmp_path / "m.h5"
    lock = OutputLock(out).acquire()
    threading.Timer(0.3, lock.release).start()
    res = invoke("merge", done / "run", "--out", out, "--wait")
    assert res.exit_code == 0, res.output
    assert out.exists() and not leftovers(tmp_path)


def _dead_pid() -> int:
    proc = subprocess.Popen([sys.executable, "-c", "pass"])
    proc.wait()
    return proc.pid


def test_stale_locks_and_temporaries_of_killed_writers_are_removed(done, tmp_path):
    pid = _dead_pid()
    out = tmp_path / "m.h5"
    (tmp_path / "m.h5.lock").write_text(json.dumps(dict(host=HOST, pid=pid)))
    for name in (f".m.h5.tmp.{HOST}.{pid}", ".m.h5.tmp.another-node.17", f".m.h5.tmp{pid}"):
        (tmp_path / name).write_bytes(b"x" * 1000)
    other = tmp_path / f".other.h5.tmp.another-node.{pid}"    # not ours to judge: kept
    other.write_bytes(b"")
    res = invoke("merge", done / "run", "--out", out)
    assert res.exit_code == 0, res.output
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(["m.h5", other.name])


def test_a_live_lock_on_another_host_is_not_taken(tmp_path):
    out = tmp_path / "a.h5"
    (tmp_path / "a.h5.lock").write_text(json.dumps(dict(host="node-elsewhere", pid=1,
                                                        command="sweep run x")))
    refused(invoke("run", SMALL, "--out", out, "--no-progress"), "node-elsewhere", "a.h5.lock")
    assert not out.exists()


# ---------------------------------------------------------------------------------------------
# Ctrl-C and SIGTERM
# ---------------------------------------------------------------------------------------------
def test_ctrl_c_while_the_config_loads_is_one_line(tmp_path, monkeypatch):
    import sweep.config.parse

    def interrupted(path):
        raise KeyboardInterrupt

    monkeypatch.setattr(sweep.config.parse, "load_scene", interrupted)
    res = invoke("run", SMALL, "--out", tmp_path / "a.h5", "--no-progress")
    assert res.exit_code == 130 and "Traceback" not in res.output
    assert res.output.strip() == "sweep: interrupted; nothing was written"
    assert list(tmp_path.iterdir()) == []


def test_sigterm_during_a_map_is_one_line(tmp_path, monkeypatch):
    import sweep.compute.maps

    def killed(*args, **kwargs):
        os.kill(os.getpid(), signal.SIGTERM)
        time.sleep(5)                       # the handler interrupts this at once
        raise AssertionError("SIGTERM was not handled")

    monkeypatch.setattr(sweep.compute.maps, "compute_map", killed)
    res = invoke(*MAP, "--h", "0.3", "--out", tmp_path / "m.h5")
    assert res.exit_code == 130 and res.output.strip().startswith("sweep: terminated")
    assert list(tmp_path.iterdir()) == []               # no map, no lock


# ---------------------------------------------------------------------------------------------
# Config values
# ---------------------------------------------------------------------------------------------
@pytest.mark.parametrize("changes, names", [
    pytest.param(dict(grid={"h": 100}), ["grid.h", "100", "1 x 1"], id="one-point-grid"),
    pytest.param(dict(grid={"h": "0.2"}), ["grid.h", "'0.2'", "quoted"], id="quoted-number"),
    pytest.param(dict(name=123), ["name", "123", "quote"], id="numeric-name"),
    pytest.param(dict(grid={"h": 1e-12}), ["grid.h", "too many grid points to count"],
                 id="uncountable-grid"),
    pytest.param(dict(designs={"l1": [1e9]}), ["grid.h", "l1=1000000000.0", "too many"],
                 id="huge-design"),
])
def test_bad_config_values_are_named(tmp_path, changes, names):
    cfg = write_config(tmp_path / "c.yaml", tiny(**changes))
    line = refused(invoke("run", cfg, "--out", tmp_path / "a.h5", "--no-progress"), *names)
    assert "9,223,372,036,854,775,807" not in line and "must be letters, digits" not in line
    assert not (tmp_path / "a.h5").exists()


def test_unquoted_exponent_is_a_number_and_grid_defaults_to_the_papers(tmp_path):
    from sweep.config.parse import load_scene

    cfg = tiny()
    del cfg["grid"]
    text = write_config(tmp_path / "c.yaml", cfg).read_text()
    (tmp_path / "c.yaml").write_text(text.replace("root_tol: 1.0e-12", "root_tol: 1e-12"))
    scene = load_scene(tmp_path / "c.yaml")
    assert scene.accuracy.root_tol == 1e-12 and scene.h == 0.05 and scene.bounds == "reach"
    docs = (ROOT / "docs" / "sweeps.md").read_text()
    assert "h = 0.05" in docs and "Failure modes" in docs


def test_show_says_what_a_map_file_is(tmp_path):
    out = tmp_path / "m.h5"
    assert invoke(*MAP, "--h", "0.3", "--out", out).exit_code == 0
    res = invoke("show", out)
    assert res.exit_code == 0 and "one energy map" in res.output and "unknown" not in res.output
    assert "l1 2, l2 1.6" in res.output


# ---------------------------------------------------------------------------------------------
# Fault injection: SIGKILL at random points
# ---------------------------------------------------------------------------------------------
KILL_SEED = 20261123
#: Kills per command (bounded), and the window (seconds after start) each kill lands in: from
#: inside the imports to about the end of the command on configs/small.yaml, so that start-up,
#: compute, part writes and the final assembly can all be hit.
KILLS_PER_COMMAND = 3
KILL_WINDOWS = {"run": (0.1, 1.6), "chunk": (0.1, 1.2), "merge": (0.1, 0.8)}


def _variables(path: Path) -> dict:
    with h5py.File(path, "r") as f:
        return {name: (f[name].dtype.str, f[name].shape, f[name][...].tobytes())
                for name in f if isinstance(f[name], h5py.Dataset)}


def _kill_at_random(args, rng, window) -> str:
    """Start `sweep ARGS` and SIGKILL it after a random delay; 'killed' or 'finished'."""
    proc = subprocess.Popen([sys.executable, "-m", "sweep", *map(str, args)],
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                            env={k: v for k, v in os.environ.items() if k not in NO_ARRAY_ENV})
    try:
        proc.wait(timeout=rng.uniform(*window))
        return "finished"
    except subprocess.TimeoutExpired:
        proc.kill()
        proc.wait()
        return "killed"


@pytest.mark.slow
def test_sigkill_at_random_points_then_rerun_is_bit_identical(done, tmp_path):
    """Runs, chunked runs and merges of configs/small.yaml killed at seeded random points; the
    next command completes them to stores whose every variable is bit-identical to an
    uninterrupted run, and leaves no temporary file and no lock behind."""
    rng = random.Random(KILL_SEED)
    reference = _variables(done / "a.h5")
    out, run_dir, merged = tmp_path / "k.h5", tmp_path / "run", tmp_path / "m.h5"
    steps = [("run", ["run", SMALL, "--out", out, "--no-progress"])]
    steps += [("chunk", ["run", SMALL, "--out", run_dir, "--chunks", 2, "--chunk", k,
                         "--no-progress"]) for k in range(2)]
    steps += [("merge", ["merge", run_dir, "--out", merged, "--overwrite"])]
    outcomes = []
    for kind, args in steps:
        for _ in range(KILLS_PER_COMMAND):
            outcomes.append(_kill_at_random(args, rng, KILL_WINDOWS[kind]))
            if outcomes[-1] == "finished":
                break                       # done: later kills would hit a finished command
        res = invoke(*args)                 # the next successful command
        assert res.exit_code == 0, res.output
    assert "killed" in outcomes, outcomes
    assert _variables(out) == reference
    assert _variables(merged) == reference
    assert not leftovers(tmp_path), leftovers(tmp_path)
    assert not (tmp_path / "k.h5.parts").exists() and not (run_dir / "parts").exists()


def test_two_merges_to_one_output_at_once_write_it_once(done, tmp_path):
    """Whatever their timing, one merge writes and the other is refused (locked, or exists)."""
    out = tmp_path / "m.h5"
    procs = [subprocess.Popen([sys.executable, "-m", "sweep", "merge", str(done / "run"),
                               "--out", str(out)], stdout=subprocess.PIPE,
                              stderr=subprocess.PIPE, text=True) for _ in range(2)]
    results = [(p.wait(), p.stderr.read()) for p in procs]
    for p in procs:
        p.stdout.close()
        p.stderr.close()
    assert sorted(rc for rc, _ in results) == [0, 2], results
    err = next(e for rc, e in results if rc == 2)
    assert str(out) in err and "Traceback" not in err
    assert ("being written by" in err) or ("exists" in err)
    assert _variables(out) == _variables(done / "a.h5") and not leftovers(tmp_path)


def test_a_run_removes_the_temporaries_of_its_killed_predecessor(tmp_path):
    """Store assembly and part writes killed earlier (old and new temporary names)."""
    cfg = write_config(tmp_path / "c.yaml", tiny())
    pid = _dead_pid()
    parts = tmp_path / "a.h5.parts"
    parts.mkdir()
    for p in (tmp_path / f".a.h5.tmp{pid}", tmp_path / f".a.h5.tmp.{HOST}.{pid}",
              parts / f".items-00000000-00000003.h5.tmp.{HOST}.{pid}"):
        p.write_bytes(b"x" * 136_000)
    (tmp_path / "a.h5.lock").write_text(json.dumps(dict(host=HOST, pid=pid)))
    res = invoke("run", cfg, "--out", tmp_path / "a.h5", "--no-progress")
    assert res.exit_code == 0, res.output
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.h5", "c.yaml"]
