"""Scenes with effects and outputs (MODEL 9): the scene and the flags, what files record, that
merge never mixes scenes, and that a map computes only the outputs asked for."""
import json
import shutil

import click
import h5py
import numpy as np
import pytest
from click.testing import CliRunner

from sweep.cli import main
from sweep.cli import register
from sweep.compute.maps import compute_map
from sweep.model import (END_NONE, Design, Effects, Grid, ModelInputError, Outputs,
                         Part)
from sweep.config.scene import SceneError
from sweep.config.parse import scene_from_dict
from sweep_cases import tiny, write_config

REFERENCE = ["--l1", "2.0", "--l2", "1.6", "--r1", "0.2", "--r2", "0.14", "--w", "0.8",
             "--r", "0.4", "--mu", "0.4", "--h", "0.1"]
DESIGN, PART = Design(2.0, 1.6, 0.2, 0.14, 0.8), Part(0.4, 0.4)


# ---------------------------------------------------------------------------------------------
# The scene
# ---------------------------------------------------------------------------------------------
def test_scene_defaults_are_the_papers_map_outputs():
    s = scene_from_dict(tiny())
    assert s.outputs == Outputs() and s.outputs.names_on() == ["energy", "equilibrium", "caging"]
    assert "on" not in s.resolved().get("outputs", {})


def test_scene_outputs_forces_changes_the_hash_and_is_recorded():
    base = scene_from_dict(tiny())
    forces = scene_from_dict(tiny(outputs={"forces": True}))
    assert forces.outputs.forces
    assert forces.resolved()["outputs"]["on"] == ["energy", "equilibrium", "caging", "forces"]
    assert forces.config_hash != base.config_hash


@pytest.mark.parametrize("outputs, message", [
    ({"caging": False}, "outputs.caging"),
    ({"equilibrium": False}, "caging needs equilibrium"),
    ({"energy": False}, "energy cannot be off"),
    ({"forces": "yes"}, "outputs.forces: must be true or false"),
])
def test_scene_refuses_outputs_it_cannot_store(outputs, message):
    with pytest.raises(SceneError, match=message):
        scene_from_dict(tiny(outputs=outputs))


@pytest.mark.parametrize("springs, message", [
    (True, "give the stiffnesses"),
    ({"K1": 0.1}, "K2: missing"),
    ({"K1": 0.1, "K2": -1.0}, "K2: must be >= 0"),
    ({"K1": 0.1, "K2": 0.1, "K3": 0.0}, "K3"),
])
def test_scene_refuses_bad_joint_springs(springs, message):
    with pytest.raises(SceneError, match=message):
        scene_from_dict(tiny(effects={"joint_springs": springs}))


def test_scene_keeps_the_manipulation_and_save_maps_keys():
    s = scene_from_dict(tiny(outputs={"save_maps": [{"l1": 0.8, "l2": 0.4, "r1": 0.12,
                                                     "r2": 0.06, "w": 0.0, "r": 0.4,
                                                     "mu": 0.1}], "forces": True}))
    assert len(s.save_maps) == 1 and s.outputs.forces


# ---------------------------------------------------------------------------------------------
# sweep merge never mixes scenes
# ---------------------------------------------------------------------------------------------
def test_merge_refuses_a_shard_with_other_outputs(tmp_path):
    cli = click.Group("sweep")
    register(cli)

    def run(cfg, out, chunk):
        path = write_config(tmp_path / f"{out}.yaml", cfg)
        res = CliRunner().invoke(cli, ["run", str(path), "--out", str(tmp_path / out),
                                       "--chunks", "2", "--chunk", str(chunk), "--no-progress"])
        assert res.exit_code == 0, res.output

    small = dict(designs={"l1": [0.8], "l2": [0.4], "r1": [0.12], "r2": [0.06],
                          "w": {"lower": 0.0, "upper": 0.5, "step": 0.5}})
    for chunk in range(2):
        run(tiny(**small), "base", chunk)
    run(tiny(**small, outputs={"forces": True}), "forces", 1)
    shutil.copy(tmp_path / "forces" / "shard-0001-of-0002.h5",
                tmp_path / "base" / "shard-0001-of-0002.h5")
    res = CliRunner().invoke(cli, ["merge", str(tmp_path / "base"), "--out",
                                   str(tmp_path / "m.h5")])
    assert res.exit_code == 2 and "shard 1 mismatched" in res.output
    assert not (tmp_path / "m.h5").exists()


# ---------------------------------------------------------------------------------------------
# sweep map: flags, what the file records, refusals before anything is written
# ---------------------------------------------------------------------------------------------
def test_map_flags_record_outputs_and_effects(tmp_path):
    out = tmp_path / "energy.h5"
    res = CliRunner().invoke(main, ["map", *REFERENCE, "--outputs", "energy", "--out", str(out)])
    assert res.exit_code == 0, res.output
    with h5py.File(out, "r") as f:
        assert json.loads(f.attrs["outputs_on"]) == ["energy"]
        assert json.loads(f.attrs["effects_on"]) == ["friction"]
        assert "energy" in f and "theta1" in f
        for absent in ("end_state", "caging_score", "l_open", "contained", "equilibrium"):
            assert absent not in f, absent
        assert "Lambda" not in f.attrs and "n_caged" not in f.attrs


@pytest.mark.parametrize("flags, message", [
    (["--outputs", "energy,cage"], "unknown output 'cage'"),
    (["--outputs", "caging"], "energy cannot be off"),
    (["--outputs", "energy,caging"], "caging needs equilibrium"),
    (["--effects", "friction,springs"], "unknown effect 'springs'"),
    (["--effects", "friction,joint_springs"], "needs --K1 and --K2"),
    (["--K1", "0.1", "--K2", "0.1"], "add joint_springs"),
    (["--effects", "none"], "--mu must be 0"),
    (["--outputs", "energy", "--plot", "x.png"], "needs the caging output"),
    (["--effects", "friction,joint_springs", "--K1", "0.01", "--K2", "0.01", "--forces"],
     "forces with joint_springs are not implemented"),
    (["--effects", "friction,tip_contact", "--forces"],
     "forces with tip_contact are not implemented"),
])
def test_map_refuses_bad_scene_flags_before_writing(tmp_path, flags, message):
    out = tmp_path / "m.h5"
    res = CliRunner().invoke(main, ["map", *REFERENCE, *flags, "--out", str(out)])
    assert res.exit_code == 2, res.output
    assert message in res.output and len(res.output.strip().splitlines()) == 1
    assert not out.exists()


# ---------------------------------------------------------------------------------------------
# Work only for what is on
# ---------------------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def full_map():
    return compute_map(DESIGN, PART, grid=Grid(h=0.1))


@pytest.mark.parametrize("names", [["energy"], ["energy", "equilibrium"]])
def test_fewer_outputs_give_the_same_bits_for_what_they_keep(full_map, names):
    m = compute_map(DESIGN, PART, grid=Grid(h=0.1), outputs=Outputs.from_names(names))
    assert m.outputs == tuple(names)
    for name, values in m.fields.items():
        assert values.tobytes() == full_map.fields[name].tobytes(), name
    assert "end_state" not in m.fields and "caging_score" not in m.fields
    assert ("equilibrium" in m.fields) == ("equilibrium" in names)
    for name in ("n_reached", "n_vertex", "n_eject", "n_unreached", "n_infeasible",
                 "n_tip_overlap", "n_points"):
        assert m.attrs[name] == full_map.attrs[name], name


def test_energy_only_kernels_compute_no_cage_and_no_trajectory():
    # the pipeline itself: with caging off, no containment, L_open, crossing or trajectory is
    # computed (fields keep their "not computed" values), and Lambda is NaN
    from sweep.kernels.one_map import finger_rows, map_from_fingers
    from sweep.kernels.records import (Hand, new_finger_arrays, new_outcome_arrays,
                                       no_force_arrays, no_settled_fingers)
    from sweep.compute.layout import finger_offsets, kernel_records, map_grid
    from sweep.model import Accuracy, Limits
    from sweep.schema import SUMMARY_INDEX

    g = map_grid(DESIGN, PART, Grid(h=0.2))
    finger, solver, blocks = kernel_records(DESIGN, PART, Limits(), Accuracy(), Effects())
    results = {}
    for caging in (True, False):
        fingers = new_finger_arrays(2, *g.shape)
        for side, dxs in enumerate(finger_offsets(g.i, DESIGN.w, g.h)):
            finger_rows(0, g.y.size, dxs, g.y, finger, solver, blocks, fingers, side)
        outs = new_outcome_arrays(*g.shape)
        summary = np.empty(len(SUMMARY_INDEX))
        map_from_fingers(g.x, g.y, finger, solver,
                         Hand(DESIGN.w, 1.0, 1.0, g.h, finger.mu_s, finger.mu_s), blocks,
                         fingers, outs, no_force_arrays(),
                         np.empty(g.x.size * g.y.size, dtype=np.int64), summary, True, True,
                         caging, no_settled_fingers())
        results[caging] = outs, summary
    (full, s_full), (energy, s_energy) = results[True], results[False]
    assert full.contained.any() and full.crossed.any() and (full.end_state != END_NONE).any()
    assert not energy.contained.any() and not energy.crossed.any() and not energy.caged.any()
    assert np.isnan(energy.l_open).all()
    assert (energy.end_state == END_NONE).all() and (energy.end_index == -1).all()
    assert np.isnan(s_energy[SUMMARY_INDEX["Lambda"]]) and s_full[SUMMARY_INDEX["Lambda"]] > 0
    assert energy.equilibrium.tobytes() == full.equilibrium.tobytes()
    assert energy.energy.tobytes() == full.energy.tobytes()


def test_effects_off_in_the_scene_means_the_base_kernels():
    m = compute_map(DESIGN, PART, grid=Grid(h=0.2), effects=Effects())
    base = compute_map(DESIGN, PART, grid=Grid(h=0.2))
    for name, values in base.fields.items():
        assert values.tobytes() == m.fields[name].tobytes(), name


def test_outputs_from_names_refuses_unknown():
    with pytest.raises(ModelInputError, match="unknown output"):
        Outputs.from_names(["energy", "stress"])


@pytest.mark.parametrize("name, on", [("paper-collision", ["friction", "finger_collision"]),
                                      ("small-collision", ["friction", "finger_collision"]),
                                      ("small-springs-collision",
                                       ["friction", "joint_springs", "finger_collision"])])
def test_effect_configs_load(name, on):
    from pathlib import Path

    from sweep.config.parse import load_scene

    s = load_scene(Path(__file__).resolve().parent.parent / "configs" / f"{name}.yaml")
    assert s.effects.names_on() == on
