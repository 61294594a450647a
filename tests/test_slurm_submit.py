"""`sweep slurm --submit` without a scheduler: the merge script's text, and the input errors that
must stop it before anything is written. The real submission is tested against a real SLURM by
`make test-slurm` (tests/slurm/)."""
import stat
from pathlib import Path

import click
import pytest
from click.testing import CliRunner

from sweep.cli import register
from sweep.runs.slurm import merge_script
from sweep_cases import tiny, write_config

DATA = Path(__file__).resolve().parent / "data"


@pytest.fixture
def cli():
    group = click.Group("sweep")
    register(group)
    return group


def invoke(cli, *args, env=None):
    return CliRunner().invoke(cli, [str(a) for a in args], env=env)


def test_merge_script_golden():
    text = merge_script(out_dir="/scratch/runs/paper", results="/scratch/my results/paper.h5",
                        job_name="sweep-paper-merge", sweep_cmd="/opt/venv/bin/sweep",
                        time="02:00:00", partition="compute", account="lab",
                        extra={"qos": "normal"})
    assert text == (DATA / "sbatch_merge.golden").read_text()


def test_results_needs_submit(cli, tmp_path):
    cfg = write_config(tmp_path / "tiny.yaml", tiny())
    res = invoke(cli, "slurm", cfg, "--chunks", 2, "--out", tmp_path / "run",
                 "--results", tmp_path / "r.h5")
    assert res.exit_code == 2 and "--submit" in res.output
    assert not (tmp_path / "run").exists()


def test_submit_without_sbatch_writes_nothing(cli, tmp_path):
    cfg = write_config(tmp_path / "tiny.yaml", tiny())
    empty = tmp_path / "bin"
    empty.mkdir()
    res = invoke(cli, "slurm", cfg, "--chunks", 2, "--out", tmp_path / "run", "--submit",
                 env={"PATH": str(empty)})
    assert res.exit_code == 2 and "sbatch is not on PATH" in res.output
    assert len(res.output.strip().splitlines()) == 1
    assert not (tmp_path / "run").exists()


def test_submit_refuses_existing_results(cli, tmp_path):
    cfg = write_config(tmp_path / "tiny.yaml", tiny())
    (tmp_path / "r.h5").write_bytes(b"earlier results")
    res = invoke(cli, "slurm", cfg, "--chunks", 2, "--out", tmp_path / "run", "--submit",
                 "--results", tmp_path / "r.h5")
    assert res.exit_code == 2 and "r.h5 exists" in res.output
    assert not (tmp_path / "run").exists()
    assert (tmp_path / "r.h5").read_bytes() == b"earlier results"


def test_submit_reports_a_refusing_sbatch_before_writing(cli, tmp_path):
    """A stand-in sbatch that refuses every script, as a scheduler does for a bad partition."""
    cfg = write_config(tmp_path / "tiny.yaml", tiny())
    bindir = tmp_path / "bin"
    bindir.mkdir()
    fake = bindir / "sbatch"
    fake.write_text("#!/bin/sh\necho 'sbatch: error: invalid partition specified: x' >&2\n"
                    "exit 1\n")
    fake.chmod(fake.stat().st_mode | stat.S_IXUSR)
    res = invoke(cli, "slurm", cfg, "--chunks", 2, "--out", tmp_path / "run", "--submit",
                 "--partition", "x", env={"PATH": str(bindir)})
    assert res.exit_code == 2 and "invalid partition specified: x" in res.output
    assert not (tmp_path / "run").exists()
