"""Sweep configs: schema, validation messages naming the key, exact expansion, work order, hash."""
from pathlib import Path

import numpy as np
import pytest
import yaml

from sweep.config.scene import ITEM_ORDER, STORE_DIMS, SceneError
from sweep.config.parse import load_scene, scene_from_dict
from sweep_cases import tiny, write_config

CONFIGS = Path(__file__).resolve().parent.parent / "configs"


def test_paper_config_is_the_papers_table():
    s = load_scene(CONFIGS / "paper.yaml")
    assert s.store_dims == STORE_DIMS
    assert s.store_shape == (9, 4, 5, 5, 6, 4, 4)
    assert s.n_maps == 86_400 and s.n_items == 14_400
    # exact values, as the decimal numbers of the table (no 1.0000000000000002)
    assert s.values["l1"] == (0.4, 0.6, 0.8, 1.0, 1.2, 1.4, 1.6, 1.8, 2.0)
    assert s.values["l2"] == (0.4, 0.8, 1.2, 1.6)
    assert s.values["r1"] == (0.04, 0.08, 0.12, 0.16, 0.2)
    assert s.values["r2"] == (0.02, 0.06, 0.1, 0.14, 0.18)
    assert s.values["w"] == (0.0, 0.4, 0.8, 1.2, 1.6, 2.0)
    assert s.values["r"] == (0.4, 0.8, 1.2, 1.6)
    assert s.values["mu"] == (0.1, 0.4, 0.7, 1.0)
    assert s.h == 0.05 and s.bounds == "reach"
    assert [(c.f_left, c.f_right) for c in s.commands] == [(1.0, 1.0)]
    assert s.effects.names_on() == ["friction"]
    assert s.limits.theta2_min_deg == -5 and s.limits.theta2_max_deg == 90
    # r1 == r2 never occurs on the paper's grid (MODEL 1)
    assert not set(s.values["r1"]) & set(s.values["r2"])


def test_small_config_is_small():
    s = load_scene(CONFIGS / "small.yaml")
    assert s.n_maps <= 100
    assert s.h >= 0.1


@pytest.mark.parametrize("spec, expected", [
    pytest.param({"lower": 0.4, "upper": 2.0, "step": 0.2},
                 (0.4, 0.6, 0.8, 1.0, 1.2, 1.4, 1.6, 1.8, 2.0), id="paper-l1"),
    pytest.param({"lower": 0.1, "upper": 0.3, "step": 0.1}, (0.1, 0.2, 0.3),
                 id="no-float-accumulation"),  # 0.1 + 0.1 + 0.1 != 0.3 in floats
    pytest.param({"lower": 0.0, "upper": 1.0, "step": 0.3}, (0.0, 0.3, 0.6, 0.9),
                 id="step-not-dividing"),
    pytest.param({"lower": 0.5, "upper": 0.5, "step": 0.1}, (0.5,), id="one-value-range"),
    pytest.param([0.4, 1.6], (0.4, 1.6), id="list"),
    pytest.param(0.8, (0.8,), id="scalar"),
])
def test_parameter_expansion(spec, expected):
    s = scene_from_dict(tiny(designs={"w": spec}))
    assert s.values["w"] == expected


def test_range_values_are_lower_plus_index_times_step():
    s = scene_from_dict(tiny(parts={"mu": {"lower": 0.0, "upper": 3.0, "step": 0.1}}))
    assert len(s.values["mu"]) == 31
    assert s.values["mu"][3] == 0.3 and s.values["mu"][30] == 3.0
    assert np.all(np.diff(s.values["mu"]) > 0)


@pytest.mark.parametrize("changes, key", [
    pytest.param({"colour": "red"}, "colour", id="unknown-top-key"),
    pytest.param({"designs": {"l3": [1.0]}}, "designs.l3", id="unknown-design-key"),
    pytest.param({"designs": {"l1": {"lower": 1, "upper": 2, "stp": 0.1}}}, "designs.l1.stp",
                 id="unknown-range-key"),
    pytest.param({"designs": {"l1": {"lower": 1, "upper": 2}}}, "designs.l1.step",
                 id="missing-step"),
    pytest.param({"designs": {"l1": []}}, "designs.l1", id="empty-list"),
    pytest.param({"designs": {"l1": {"lower": 1, "upper": 2, "step": 0}}}, "designs.l1.step",
                 id="step-zero"),
    pytest.param({"designs": {"l2": {"lower": 1, "upper": 2, "step": -0.1}}}, "designs.l2.step",
                 id="step-negative"),
    pytest.param({"parts": {"r": {"lower": 1.6, "upper": 0.4, "step": 0.4}}}, "parts.r",
                 id="lower-above-upper"),
    pytest.param({"designs": {"r1": {"lower": 0.1, "upper": 0.2, "step": 1e-9}}},
                 "designs.r1.step", id="too-many-values"),
    pytest.param({"designs": {"l1": [1.2, 0.8]}}, "designs.l1[1]", id="list-not-increasing"),
    pytest.param({"designs": {"l1": [0.0, 0.8]}}, "designs.l1", id="l1-not-positive"),
    pytest.param({"designs": {"w": [-0.4, 0.8]}}, "designs.w", id="w-negative"),
    pytest.param({"parts": {"mu": [-0.1]}}, "parts.mu", id="mu-negative"),
    pytest.param({"parts": {"r": ["big"]}}, "parts.r[0]", id="not-a-number"),
    pytest.param({"grid": {"h": 0}}, "grid.h", id="h-zero"),
    pytest.param({"grid": {"h": 1e-5}}, "grid.h", id="grid-too-large-for-memory"),
    pytest.param({"grid": {"bounds": "window"}}, "grid.bounds", id="bounds-unknown"),
    pytest.param({"limits": {"theta2_min_deg": 5}}, "limits.theta2_min_deg",
                 id="theta2-min-positive"),
    pytest.param({"limits": {"theta2_max_deg": -10}}, "limits.theta2_max_deg",
                 id="theta2-max-below-min"),
    pytest.param({"accuracy": {"trajectory": "rk4"}}, "accuracy.trajectory",
                 id="trajectory-unknown"),
    pytest.param({"accuracy": {"reconfig_step": 2.0}}, "accuracy.reconfig_step",
                 id="reconfig-step-too-large"),
    pytest.param({"effects": {"tip_contact": True}, "outputs": {"forces": True}},
                 "effects.tip_contact", id="tip-contact-with-forces"),
    pytest.param({"effects": {"friction": "yes"}}, "effects.friction", id="effect-not-bool"),
    pytest.param({"effects": {"friction": False}}, "effects.friction",
                 id="frictionless-with-mu"),
    pytest.param({"commands": []}, "commands", id="no-command"),
    pytest.param({"commands": [{"f_left": -1.0, "f_right": 1.0}]}, "commands[0].f_left",
                 id="negative-tension"),
    pytest.param({"commands": [{"f_left": 1.0, "f_right": 1.0}, {"f_left": 1, "f_right": 1}]},
                 "commands[1]", id="duplicate-command"),
    pytest.param({"outputs": {"save_maps": [dict(l1=0.8, l2=0.4, r1=0.12, r2=0.06, w=0.25,
                                                 r=0.4, mu=0.1)]}},
                 "outputs.save_maps[0].w", id="save-map-off-grid"),
    pytest.param({"outputs": {"save_maps": [dict(l1=0.8)]}}, "outputs.save_maps[0].l2",
                 id="save-map-incomplete"),
    pytest.param({"run": {"sub_chunk_cells": 0}}, "run.sub_chunk_cells", id="sub-chunk-zero"),
    pytest.param({"name": "two words"}, "name", id="name-not-a-file-name"),
])
def test_bad_config_names_the_key(changes, key):
    with pytest.raises(SceneError) as err:
        scene_from_dict(tiny(**changes))
    assert str(err.value).startswith(f"{key}:"), str(err.value)
    assert "\n" not in str(err.value)


def test_missing_section_is_named():
    cfg = tiny()
    del cfg["parts"]
    with pytest.raises(SceneError, match=r"^parts: missing"):
        scene_from_dict(cfg)


def test_duplicate_yaml_key_is_refused(tmp_path):
    p = tmp_path / "dup.yaml"
    p.write_text(yaml.safe_dump(tiny(), sort_keys=False) + "grid: {h: 0.1}\n")
    with pytest.raises(SceneError, match=r"^grid: duplicate key"):
        load_scene(p)


def test_unreadable_and_invalid_yaml(tmp_path):
    with pytest.raises(SceneError, match="cannot read config"):
        load_scene(tmp_path / "nope.yaml")
    bad = tmp_path / "bad.yaml"
    bad.write_text("designs: [1, 2\n")
    with pytest.raises(SceneError, match="not valid YAML"):
        load_scene(bad)


def test_equal_pulley_radii_are_accepted():
    """r1 == r2 (R = 1) is handled by the kernels (MODEL 5.4), so it is not a config error."""
    s = scene_from_dict(tiny(designs={"r1": [0.1], "r2": [0.1]}))
    assert s.values["r1"] == s.values["r2"] == (0.1,)


def test_name_defaults_to_file_stem(tmp_path):
    cfg = tiny()
    del cfg["name"]
    s = load_scene(write_config(tmp_path / "quick-look.yaml", cfg))
    assert s.name == "quick-look" and s.path.endswith("quick-look.yaml")


def test_hash_depends_on_the_science_only():
    base = scene_from_dict(tiny())
    same_values = scene_from_dict(tiny(designs={"w": [0.0, 0.5]}, name="other",
                                           run={"sub_chunk_cells": 1}))
    assert same_values.config_hash == base.config_hash
    for changes in ({"grid": {"h": 0.2}}, {"parts": {"mu": [0.1, 0.8]}},
                    {"limits": {"theta2_max_deg": 80}}, {"accuracy": {"reconfig_step": 0.02}},
                    {"commands": [{"f_left": 0.5, "f_right": 1.5}]}):
        assert scene_from_dict(tiny(**changes)).config_hash != base.config_hash, changes


def test_items_put_shared_finger_geometry_together():
    s = scene_from_dict(tiny(commands=[{"f_left": 1.0, "f_right": 1.0},
                                       {"f_left": 0.5, "f_right": 1.5}]))
    assert ITEM_ORDER[:3] == ("l1", "l2", "r")
    cells, cmd = s.cells(0, s.n_items)
    # columns l1, l2, r1, r2, r, mu; every group of group_size items has one (l1, l2, r)
    for g in range(s.n_groups):
        block = cells[g * s.group_size:(g + 1) * s.group_size]
        assert len({(row[0], row[1], row[4]) for row in block}) == 1
    # every (cell, command) exactly once
    combos = {tuple(row) + (c,) for row, c in zip(cells.tolist(), cmd.tolist())}
    assert len(combos) == s.n_items == 2 * 2 * 1 * 2 * 2 * 2
    assert s.store_dims == STORE_DIMS + ("command",)


def test_item_of_inverts_cells():
    s = scene_from_dict(tiny())
    cells, cmd = s.cells(0, s.n_items)
    for i, (row, c) in enumerate(zip(cells, cmd)):
        point = dict(zip(("l1", "l2", "r1", "r2", "r", "mu"), row), w=0.0, command=int(c))
        assert s.item_of(point) == i


def test_group_costs_grow_with_reach():
    s = scene_from_dict(tiny())
    costs = s.group_costs()
    assert costs.shape == (s.n_groups,)
    # groups ordered (l1, l2): (0.8, 0.4), (0.8, 0.8), (1.2, 0.4), (1.2, 0.8)
    assert costs[0] < costs[1] < costs[3] and costs[2] < costs[3]
