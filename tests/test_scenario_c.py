"""Scenario C, friction modulation (MODEL 10): A's gripper whose fingers each switch between the
part's mu_s and a low friction mu_low; per pose, the hull over every width, command and friction
pair (mu_left, mu_right) in {mu_low, mu_s}^2, the palm keeping mu_s.

Against the slow reference tests/naive_manipulation.py (naive fingers, LP statics, Qhull) with
per-finger friction; with finger_collision, against the maps of each friction pair
(`compute_map(mu_left=, mu_right=)`, the map pipeline's own collisions) reduced in plain Python;
and by what C must be: A exactly when mu_low = mu_s, at least A always (a superset of forces)."""
from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from naive_manipulation import (SCENARIO_A_COMMANDS, hull_value, naive_metric,
                                scenario_c_frictions, world_lattice)
from strategies import paper_table_designs
from sweep.compute.batch import manipulation_cells
from sweep.compute.maps import compute_map
from sweep.grid import SCENARIO_A_EXTREMES
from sweep.model import (REACHED, Accuracy, Command, Design, Effects, Grid, Limits, Outputs,
                         Part)

H = 0.2


def kernel_metrics(candidate, part, widths, h=H, mu_low=0.0, effects=Effects()):
    """(A, C) of one candidate (l1, l2, r1, r2) and part (r, mu) through the sweep's cell."""
    geometries = [(w, *candidate) for w in widths]
    n_col = world_lattice(geometries, part[0], h)[1][0]
    _, chunk = manipulation_cells(np.array([[*candidate, *part]]), np.array(widths), h,
                                  Limits(), Accuracy(), effects, np.array([0]),
                                  np.array([[0, 0]]), np.array([n_col]), mu_low=mu_low)
    return float(chunk.a_metric[0]), float(chunk.c_metric[0])


@pytest.mark.parametrize("candidate, part, mu_low, widths", [
    ((0.8, 0.8, 0.16, 0.06), (0.8, 1.0), 0.0, (0.0,)),
    ((1.2, 0.4, 0.16, 0.02), (0.8, 0.4), 0.0, (0.0, 0.4)),
    ((1.2, 1.2, 0.04, 0.10), (0.4, 1.0), 0.1, (0.4, 1.2)),
    ((0.8, 0.8, 0.16, 0.06), (0.8, 0.1), 0.7, (0.0,)),       # mu_low above the part's mu
], ids=["short-fingers", "short-distal", "mu_low-0.1", "mu_low-above-mu"])
def test_scenario_c_of_a_candidate_matches_the_reference(candidate, part, mu_low, widths):
    geometries = [(w, *candidate) for w in widths]
    a_ref = naive_metric(geometries, part, H, SCENARIO_A_COMMANDS)
    c_ref = naive_metric(geometries, part, H, SCENARIO_A_COMMANDS,
                         frictions=scenario_c_frictions(mu_low, part[1]))
    a, c = kernel_metrics(candidate, part, widths, mu_low=mu_low)
    assert c_ref["total"] > a_ref["total"]   # the case shows modulation doing something
    assert a == pytest.approx(a_ref["total"], rel=1e-9, abs=1e-12)
    assert c == pytest.approx(c_ref["total"], rel=1e-9, abs=1e-12)


CELLS = st.tuples(paper_table_designs(), st.sets(st.integers(0, 5), min_size=1, max_size=3))


@settings(max_examples=8)
@given(design=paper_table_designs().filter(lambda d: d[0] + d[1] <= 2.0),
       mu_low=st.sampled_from([0.0, 0.05, 0.5]))
def test_scenario_c_matches_the_reference_on_random_designs_and_parts(design, mu_low):
    """Random designs and parts of the paper's table, the shorter fingers (the reference solves
    every pose of the lattice for each friction pair: a few seconds a design)."""
    l1, l2, r1, r2, w, r, mu = design
    geometries = [(w, l1, l2, r1, r2)]
    ref = naive_metric(geometries, (r, mu), H, SCENARIO_A_COMMANDS,
                       frictions=scenario_c_frictions(mu_low, mu))
    _, c = kernel_metrics((l1, l2, r1, r2), (r, mu), (w,), mu_low=mu_low)
    assert c == pytest.approx(ref["total"], rel=1e-9, abs=1e-12)


@settings(max_examples=15)
@given(CELLS)
def test_scenario_c_with_mu_low_equal_to_mu_is_scenario_a_exactly(cell):
    (l1, l2, r1, r2, _, r, mu), ws = cell
    widths = tuple(0.4 * k for k in sorted(ws))
    a, c = kernel_metrics((l1, l2, r1, r2), (r, mu), widths, h=H, mu_low=mu)
    assert c == a     # bit for bit


@pytest.mark.parametrize("collision", [False, True], ids=["base", "collision"])
@settings(max_examples=15)
@given(cell=CELLS, mu_low=st.sampled_from([0.0, 0.1, 0.5]))
def test_scenario_c_is_never_below_scenario_a(collision, cell, mu_low):
    (l1, l2, r1, r2, _, r, mu), ws = cell
    widths = tuple(0.4 * k for k in sorted(ws))
    a, c = kernel_metrics((l1, l2, r1, r2), (r, mu), widths, h=H, mu_low=mu_low,
                          effects=Effects(finger_collision=collision))
    assert c >= a


def test_scenario_c_is_at_least_a_pose_by_pose():
    """Per pose, C's forces are a superset of A's: its value is never below A's, and the values
    sum to the metrics."""
    from sweep.compute.batch import scenario_a_pose_values, scenario_c_pose_values

    candidate, part, widths = (2.0, 1.6, 0.20, 0.14), (0.8, 0.4), (0.0, 0.8, 1.6)
    xa, ya, va, a = scenario_a_pose_values(candidate, part, widths, H)
    xc, yc, vc, c = scenario_c_pose_values(candidate, part, widths, H, 0.0)
    assert np.array_equal(xa, xc) and np.array_equal(ya, yc)
    assert (vc >= va).all() and (vc > va).any()
    assert va.sum() == pytest.approx(a) and vc.sum() == pytest.approx(c)


def pair_map_metric(candidate, part, widths, mu_low, effects, h):
    """Scenario C from whole maps: for each width and friction pair the map of
    `compute_map(mu_left=, mu_right=)` with its forces, the count rule of MODEL 10 read from its
    fields (reached, off the palm, not in equilibrium, S_geo > 0, both fingers' forces
    determined), every pose's forces under A's extreme commands hulled by Qhull."""
    forces: dict = {}
    for w in widths:
        for mu_l, mu_r in scenario_c_frictions(mu_low, part[1]):
            m = compute_map(Design(*candidate, w), Part(*part), Command(), Grid(h=h), Limits(),
                            Accuracy(), effects, outputs=Outputs(forces=True), mu_left=mu_l,
                            mu_right=mu_r)
            f = m.fields
            on_palm = ((np.abs(m.y - part[0]) <= 1e-9)[:, None]
                       & (np.abs(m.x) <= 0.5 * w + 1e-9)[None, :])
            counted = ((f["point_class"] == REACHED) & ~f["equilibrium"] & ~on_palm
                       & (f["geometric_cage_score"] > 0) & f["forces_determined"].all(axis=0))
            for j, i in np.argwhere(counted):
                s = f["geometric_cage_score"][j, i]
                left = np.array([f["resultant_force_x"][0, j, i], f["resultant_force_y"][0, j, i]])
                right = np.array([f["resultant_force_x"][1, j, i],
                                  f["resultant_force_y"][1, j, i]])
                pose = (j, int(round(m.x[i] / h)))
                for f_left in SCENARIO_A_EXTREMES:
                    forces.setdefault(pose, []).append(
                        (f_left * left + (2.0 - f_left) * right) * s)
    return sum(hull_value(points)[0] for points in forces.values())


@pytest.mark.parametrize("candidate, part, mu_low", [
    ((2.0, 1.6, 0.16, 0.10), (0.4, 0.7), 0.0),      # with finger_collision: 0 (crossed poses)
    ((2.0, 1.6, 0.20, 0.14), (0.8, 1.0), 0.1),
    ((1.6, 0.8, 0.16, 0.14), (0.4, 0.4), 0.0),
    ((1.6, 1.2, 0.16, 0.14), (0.8, 0.7), 0.0),      # with finger_collision: A 0, C positive
])
@pytest.mark.parametrize("collision", [False, True], ids=["base", "collision"])
def test_scenario_c_matches_the_maps_of_each_friction_pair(candidate, part, mu_low, collision):
    """The cell's pairs are their maps' (finger_collision included: the map pipeline resolves
    the whole map, the cell only the crossed poses it counts, meeting_search.collide)."""
    widths = (0.0, 0.8, 1.6)
    effects = Effects(finger_collision=collision)
    _, c = kernel_metrics(candidate, part, widths, h=0.1, mu_low=mu_low, effects=effects)
    ref = pair_map_metric(candidate, part, widths, mu_low, effects, 0.1)
    assert ref > 0 or (collision and candidate[0] == 2.0 and part[0] == 0.4)
    assert c == pytest.approx(ref, rel=1e-9, abs=1e-12)


# ---------------------------------------------------------------------------------------------
# The config, the store, chunks and merge, `sweep map`
# ---------------------------------------------------------------------------------------------
CONFIG = __import__("pathlib").Path(__file__).parent / "data" / "scenario_c.yaml"


def _tiny_manipulation(**outputs):
    from sweep_cases import tiny

    return tiny(outputs={"manipulation": True, **outputs})


@pytest.mark.parametrize("outputs, message", [
    (dict(manipulation=False, scenario_c={"mu_low": 0.0}),
     "outputs.scenario_c: is part of the manipulation metric"),
    (dict(scenario_c={"mu_low": -0.1}), "outputs.scenario_c.mu_low: must be a number >= 0"),
    (dict(scenario_c={"mu_low": "low"}), "outputs.scenario_c.mu_low: must be a number >= 0"),
    (dict(scenario_c={"mu_low": True}), "outputs.scenario_c.mu_low: must be a number >= 0"),
    (dict(scenario_c={"mu_lo": 0.0}), "outputs.scenario_c.mu_lo:"),
    (dict(scenario_c=0.0), "outputs.scenario_c: must be true, false or a mapping"),
], ids=["without-manipulation", "negative", "not-a-number", "bool", "unknown-key", "number"])
def test_bad_scenario_c_configs_name_the_key(outputs, message):
    from sweep.config.parse import scene_from_dict
    from sweep.config.scene import SceneError

    with pytest.raises(SceneError) as err:
        scene_from_dict(_tiny_manipulation(**outputs))
    assert str(err.value).startswith(message), str(err.value)
    assert "\n" not in str(err.value)


def test_scenario_c_needs_friction():
    from sweep.config.parse import scene_from_dict
    from sweep.config.scene import SceneError
    from sweep_cases import tiny

    cfg = tiny(parts={"mu": [0.0]}, effects={"friction": False},
               outputs={"manipulation": True, "scenario_c": True})
    with pytest.raises(SceneError, match="^outputs.scenario_c: switches the fingers' friction"):
        scene_from_dict(cfg)


def test_scenario_c_in_the_scene_and_its_identity():
    from sweep.config.parse import scene_from_dict

    off = scene_from_dict(_tiny_manipulation())
    assert not off.scenario_c and off.scenario_c_mu_low is None
    assert scene_from_dict(_tiny_manipulation(scenario_c=False)).config_hash == off.config_hash
    default = scene_from_dict(_tiny_manipulation(scenario_c=True))
    assert default.scenario_c_mu_low == 0.0
    low = scene_from_dict(_tiny_manipulation(scenario_c={"mu_low": 0.05}))
    assert low.scenario_c_mu_low == 0.05
    # C's metrics are in the item files: a run with it never resumes or merges one without
    assert len({off.config_hash, default.config_hash, low.config_hash}) == 3
    assert default.cell_bytes() > off.cell_bytes()


@pytest.fixture(scope="module")
def store(tmp_path_factory):
    from click.testing import CliRunner

    from sweep.cli import main

    out = tmp_path_factory.mktemp("c") / "c.h5"
    res = CliRunner().invoke(main, ["run", str(CONFIG), "--out", str(out), "--no-progress"])
    assert res.exit_code == 0, res.output
    return out


def test_the_store_holds_scenario_c(store):
    import xarray as xr

    with xr.open_dataset(store, engine="h5netcdf") as ds:
        a, c = ds["manipulation_a"], ds["manipulation_c"]
        assert c.dims == ("l1", "l2", "r1", "r2", "r", "mu")
        assert ds.attrs["manipulation_scenario_c_mu_low"] == 0.0
        assert "friction pair" in ds.attrs["manipulation_scenario_c_note"]
        assert c.attrs["units"] and c.attrs["long_name"]
        assert (c.values >= a.values).all()
        assert (c.values > a.values).any()
        h = ds.attrs["grid_h"]
        np.testing.assert_array_equal(ds["manipulation_c_area"].values, c.values * (h * h))
        # one candidate and part against the sweep's own cell
        l1, l2, r1, r2, r, mu = 1.6, 0.8, 0.16, 0.14, 0.4, 1.0
        widths = tuple(ds["w"].values)
        stored = float(c.sel(l1=l1, l2=l2, r1=r1, r2=r2, r=r, mu=mu))
    n_col = world_lattice([(w, 1.6, 0.8, 0, 0) for w in widths], r, 0.2)[1][0]
    _, chunk = manipulation_cells(np.array([[l1, l2, r1, r2, r, mu]]), np.array(widths), 0.2,
                                  Limits(), Accuracy(), Effects(), np.array([0]),
                                  np.array([[0, 0]]), np.array([n_col]), mu_low=0.0)
    assert stored == chunk.c_metric[0]


def test_a_chunked_run_with_scenario_c_merges_to_the_same_bytes(store, tmp_path):
    import h5py
    from click.testing import CliRunner

    from sweep.cli import main

    runner = CliRunner()
    for chunk in range(2):
        res = runner.invoke(main, ["run", str(CONFIG), "--chunk", str(chunk), "--chunks", "2",
                                   "--out", str(tmp_path / "run"), "--no-progress"])
        assert res.exit_code == 0, res.output
    res = runner.invoke(main, ["merge", str(tmp_path / "run"), "--out", str(tmp_path / "m.h5")])
    assert res.exit_code == 0, res.output
    with h5py.File(store) as whole, h5py.File(tmp_path / "m.h5") as merged:
        for name in ("manipulation_a", "manipulation_c", "manipulation_c_area",
                     "manipulation_b"):
            assert whole[name][...].tobytes() == merged[name][...].tobytes(), name


REFERENCE = ["--l1", "2.0", "--l2", "1.6", "--r1", "0.2", "--r2", "0.14", "--w", "0.8",
             "--r", "0.4", "--mu", "0.4", "--h", "0.2"]


def test_sweep_map_with_per_finger_friction(tmp_path):
    import json

    import h5py
    import xarray as xr
    from click.testing import CliRunner

    from sweep.cli import main

    runner = CliRunner()
    plain, same, switched = (tmp_path / f"{k}.h5" for k in ("plain", "same", "switched"))
    for out, extra in ((plain, []), (same, ["--mu-left", "0.4"]),
                       (switched, ["--mu-left", "0", "--mu-right", "0.4"])):
        res = runner.invoke(main, ["map", *REFERENCE, *extra, "--out", str(out)])
        assert res.exit_code == 0, res.output
    assert "finger friction: left 0, right 0.4 (palm 0.4)" in res.output
    with xr.open_dataset(plain, engine="h5netcdf") as p, \
            xr.open_dataset(same, engine="h5netcdf") as s, \
            xr.open_dataset(switched, engine="h5netcdf") as w:
        assert "finger_friction" not in p.attrs
        for name in p.data_vars:
            np.testing.assert_array_equal(p[name].values, s[name].values, err_msg=name)
        assert not np.array_equal(p["finger_mode"].values, w["finger_mode"].values)
    with h5py.File(switched) as f:
        assert json.loads(f.attrs["finger_friction"]) == {"left": 0.0, "right": 0.4,
                                                          "palm": 0.4}


@pytest.mark.parametrize("extra, message", [
    (["--mu-left", "-0.5"], "--mu-left must be >= 0"),
    (["--mu-right", "nan"], "--mu-right must be >= 0"),
])
def test_sweep_map_refuses_bad_finger_frictions(tmp_path, extra, message):
    from click.testing import CliRunner

    from sweep.cli import main

    res = CliRunner().invoke(main, ["map", *REFERENCE, *extra, "--out", str(tmp_path / "m.h5")])
    assert res.exit_code == 2
    assert message in res.output
    assert not (tmp_path / "m.h5").exists()


@pytest.mark.parametrize("plain, friction", [("paper.yaml", "paper-friction.yaml"),
                                             ("paper-collision.yaml",
                                              "paper-collision-friction.yaml")])
def test_the_friction_configs_are_make_runs_with_scenario_c(plain, friction):
    """`make friction` runs `make run`'s two scenes with Scenario C and nothing else changed."""
    from pathlib import Path

    from sweep.config.parse import load_scene

    configs = Path(__file__).resolve().parent.parent / "configs"
    a, c = load_scene(configs / plain), load_scene(configs / friction)
    assert not a.scenario_c and c.scenario_c_mu_low == 0.0
    ra, rc = a.resolved(), c.resolved()
    assert rc["outputs"].pop("scenario_c") == {"mu_low": 0.0}
    assert ra == rc
    assert (a.refine, a.scenario_a_top_k, a.sub_chunk_cells) == (c.refine, c.scenario_a_top_k,
                                                                c.sub_chunk_cells)
