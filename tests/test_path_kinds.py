"""A path of another kind than a command takes is named: what the path is and which command takes
it, exit code 2, nothing written (`sweep.runs.rundir.path_kind`, `sweep.cli.common.check_path`).

The fuzz campaign (tests/test_fuzz.py, `test_a_path_of_another_kind_is_named`) gives every path
parameter every artefact of another kind; the cases here are the ones a user meets, with their
whole messages, and the classification itself.
"""
from __future__ import annotations

import shutil

import pytest
from click.testing import CliRunner

import fuzz_cli as fz
from sweep.cli import main
from sweep.cli.common import KindPath, SceneParam
from sweep.runs.rundir import path_kind


@pytest.fixture(scope="module")
def art(tmp_path_factory):
    """A config, its store (with its kept work folder), a run directory of two shards, a map
    and its picture, a plain folder and a text file."""
    root = tmp_path_factory.mktemp("kinds")
    (root / "config.yaml").write_text(fz.FUZZ_CONFIG)
    for args in (["run", "config.yaml", "--out", "store.h5", "--no-progress", "--keep-parts"],
                 ["run", "config.yaml", "--out", "rundir", "--chunks", "2", "--chunk", "0",
                  "--no-progress"],
                 ["run", "config.yaml", "--out", "rundir", "--chunks", "2", "--chunk", "1",
                  "--no-progress"],
                 ["map", *fz.MAP_ARGS, "--out", "map.h5", "--plot", "map.png"]):
        res = fz.invoke(main, args, cwd=root)
        assert res.exit_code == 0, (args, res.output)
    (root / "folder").mkdir()
    (root / "notes.txt").write_text("not a sweep file\n")
    return root


@pytest.fixture
def case(art, tmp_path):
    """A copy of the artefacts to run a command in; `check` runs it and requires a refusal."""
    for p in art.iterdir():
        (shutil.copytree if p.is_dir() else shutil.copyfile)(p, tmp_path / p.name)
    return tmp_path


def refused(cwd, *args) -> str:
    """Run `sweep ARGS` in `cwd`: exit 2, one line, nothing written or changed; the line."""
    before = fz.snapshot(cwd)
    res = fz.invoke(main, list(args), cwd=cwd)
    assert res.exit_code == 2, (args, res.output)
    lines = res.output.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in res.output, res.output
    assert fz.snapshot(cwd) == before, args
    return lines[0].removeprefix("Error: ")


def test_path_kind_tells_the_artefacts_apart(art):
    shard = sorted((art / "rundir").glob("shard-*.h5"))[0]
    part = sorted((art / "store.h5.parts").glob("items-*.h5"))[0]
    want = {"config.yaml": "config", "store.h5": "store", "rundir": "run-dir", "map.h5": "map",
            "map.png": "picture", "folder": "folder", "notes.txt": "file",
            "store.h5.parts": "work-dir", "absent.h5": "missing"}
    for name, kind in want.items():
        assert path_kind(art / name) == kind, name
    assert path_kind(shard) == "shard" and path_kind(part) == "part"


def test_a_config_is_told_by_its_keys_without_a_yaml_name(art, tmp_path):
    (tmp_path / "sweep.conf").write_text(fz.FUZZ_CONFIG)
    assert path_kind(tmp_path / "sweep.conf") == "config"
    (tmp_path / "other.conf").write_text("name: x\n")
    assert path_kind(tmp_path / "other.conf") == "file"


def test_a_store_where_a_run_directory_is_expected(case):
    for args in (("status", "store.h5"), ("merge", "store.h5", "--out", "merged.h5")):
        assert refused(case, *args) == (
            "DIRECTORY: store.h5 is a results store, not a run directory: `sweep top`, `show`, "
            "`report` or `refine` takes it")
    line = refused(case, "slurm", "config.yaml", "--chunks", "2", "--out", "store.h5")
    assert line.startswith("--out: store.h5 is a results store, not a run directory")
    line = refused(case, "run", "config.yaml", "--out", "store.h5", "--chunks", "2", "--chunk",
                   "0")
    assert line.startswith("--out (with --chunks): store.h5 is a results store, not a run "
                           "directory: `sweep top`")


def test_a_run_directory_where_a_store_is_expected(case):
    tail = ("rundir is a run directory (the shards of a chunked sweep), not a results store: "
            "`sweep status` or `sweep merge` takes it")
    assert refused(case, "top", "rundir") == f"RESULTS: {tail}"
    assert refused(case, "refine", "rundir") == f"STORE: {tail}"
    assert refused(case, "report", "rundir", "--out", "rep") == f"STORES: {tail}"
    assert "not a sweep file" in refused(case, "show", "rundir")
    line = refused(case, "run", "config.yaml", "--out", "rundir")
    assert line == ("--out (without --chunks): rundir is a run directory (the shards of a "
                    "chunked sweep), not a results store file: `sweep status` or `sweep merge` "
                    "takes it")
    assert refused(case, "merge", "rundir", "--out", "rundir").startswith(
        "--out: rundir is a run directory")


def test_a_config_where_a_store_is_expected_and_the_other_way_round(case):
    tail = "config.yaml is a sweep config (YAML), not a results store: `sweep run`, `slurm` or " \
           "`accuracy` takes it"
    assert refused(case, "top", "config.yaml") == f"RESULTS: {tail}"
    assert refused(case, "refine", "config.yaml") == f"STORE: {tail}"
    assert refused(case, "report", "config.yaml", "--out", "rep") == f"STORES: {tail}"
    for command in (["run"], ["accuracy"], ["slurm"]):
        extra = ["--chunks", "2", "--out", "r"] if command == ["slurm"] else \
            ["--out", "x.h5"] if command == ["run"] else []
        assert refused(case, *command, "store.h5", *extra) == (
            "CONFIG: store.h5 is a results store, not a sweep config (YAML): `sweep top`, "
            "`show`, `report` or `refine` takes it")
    # an output over the config is refused even with --overwrite: it is not a results file
    assert refused(case, "merge", "rundir", "--out", "config.yaml", "--overwrite").startswith(
        "--out: config.yaml is a sweep config (YAML), not a results store file")
    assert refused(case, "run", "config.yaml", "--out", "config.yaml", "--overwrite"
                   ).startswith("--out: config.yaml is a sweep config (YAML)")


def test_a_folder_where_a_file_is_expected(case):
    assert refused(case, "top", "folder") == "RESULTS: folder is a folder, not a results store"
    assert refused(case, "merge", "rundir", "--out", "folder") == \
        "--out: folder is a folder, not a results store file"
    assert refused(case, "map", *fz.MAP_ARGS, "--out", "folder") == \
        "--out: folder is a folder, not a map file"
    assert refused(case, "map", *fz.MAP_ARGS, "--out", "m.h5", "--plot", "folder") == \
        "--plot: folder is a folder, not a PNG picture"
    assert refused(case, "show", "store.h5.parts").startswith(
        "RESULTS: store.h5.parts is a run's work folder (finished pieces kept for resuming), "
        "not a sweep file")


def test_a_file_where_a_folder_is_expected(case):
    assert refused(case, "status", "notes.txt") == \
        "DIRECTORY: notes.txt is a file, not a run directory"
    assert refused(case, "report", "store.h5", "--out", "map.h5") == \
        "--out: map.h5 is a map file (one energy map), not a folder: `sweep show` describes it"
    assert refused(case, "accuracy", "config.yaml", "--out", "store.h5").startswith(
        "--out: store.h5 is a results store, not a folder")
    assert refused(case, "slurm", "config.yaml", "--chunks", "2", "--out", "notes.txt") == \
        "--out: notes.txt is a file, not a run directory"
    shard = sorted((case / "rundir").glob("shard-*.h5"))[0].relative_to(case)
    assert refused(case, "status", str(shard)) == (
        f"DIRECTORY: {shard} is a shard of a chunked run (one chunk's summaries), not a run "
        "directory: `sweep show` describes it; `sweep merge rundir` merges its run directory")


def test_a_map_where_a_store_is_expected_and_a_store_where_a_map_is(case):
    assert refused(case, "top", "map.h5") == ("RESULTS: map.h5 is a map file (one energy map), "
                                              "not a results store: `sweep show` describes it")
    assert refused(case, "map", *fz.MAP_ARGS, "--out", "store.h5", "--overwrite") == (
        "--out: store.h5 is a results store, not a map file: `sweep top`, `show`, `report` or "
        "`refine` takes it")
    # the right kinds still work: a map file replaced by a map, a store shown
    res = fz.invoke(main, ["map", *fz.MAP_ARGS, "--out", "map.h5", "--overwrite"], cwd=case)
    assert res.exit_code == 0, res.output
    res = fz.invoke(main, ["show", "map.h5"], cwd=case)
    assert res.exit_code == 0 and "one energy map" in res.output, res.output


def test_every_path_parameter_has_a_kind():
    """Every command's path parameters go through the one check (`KindPath`, or the config
    type, which checks before loading): a new command cannot take a path unchecked."""
    params = [(cmd.name, p) for cmd in fz.commands(main) for p in cmd.paths]
    unchecked = [f"{name} {fz.opt_name(p)}" for name, p in params
                 if not isinstance(p.type, (KindPath, SceneParam))]
    assert not unchecked, unchecked
    assert len(params) >= 17      # run, map, merge, refine, top, show, report, slurm, ...


def test_a_text_file_where_a_store_is_expected_says_it_is_not_hdf5(case):
    res = CliRunner().invoke(main, ["top", str(case / "notes.txt")])
    assert res.exit_code == 2
    assert res.output.strip() == f"Error: {case / 'notes.txt'}: not a sweep results store (not " \
                                 "an HDF5 file)"
