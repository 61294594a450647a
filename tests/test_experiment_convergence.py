"""scripts/experiment_convergence.py: the slice it sweeps and the rule it counts by, on cases
worked by hand (docs/accuracy.md, "Each experiment's outputs as h halves")."""
from __future__ import annotations

import importlib.util
from pathlib import Path

import numpy as np
import yaml

from sweep.config.parse import load_scene

ROOT = Path(__file__).resolve().parents[1]
_spec = importlib.util.spec_from_file_location("experiment_convergence",
                                               ROOT / "scripts" / "experiment_convergence.py")
conv = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(conv)


def test_the_slice_keeps_the_parts_and_widths_and_makes_every_design_a_candidate(tmp_path):
    path = conv.slice_config(ROOT / "configs" / "paper.yaml", 0.025, tmp_path / "s.yaml")
    cfg = yaml.safe_load(path.read_text())
    paper = yaml.safe_load((ROOT / "configs" / "paper.yaml").read_text())
    assert cfg["parts"] == paper["parts"] and cfg["designs"]["w"] == paper["designs"]["w"]
    assert cfg["designs"]["l1"] == [1.2, 2.0] and cfg["designs"]["r2"] == [0.02, 0.1, 0.18]
    assert cfg["grid"]["h"] == 0.025 and "refine" not in cfg
    designs = 2 * 2 * 3 * 3 * 6
    assert cfg["outputs"]["manipulation"] and cfg["outputs"]["scenario_a_top_k"] >= designs
    tip = yaml.safe_load(conv.slice_config(ROOT / "configs" / "paper-tip.yaml", 0.05,
                                           tmp_path / "t.yaml").read_text())
    assert not tip["outputs"].get("manipulation")       # tip_contact has no manipulation metric
    load_scene(tmp_path / "t.yaml")
    scene = load_scene(path)        # the slice is a valid config
    assert scene.h == 0.025


def test_the_rule_counts_relative_changes_and_small_values_absolutely():
    # one part (r, mu axes of size 1), four designs; the part's largest fine value is 10
    fine = np.array([10.0, 2.0, 0.05, 0.0]).reshape(4, 1, 1)
    coarse = np.array([10.4, 2.2, 0.14, 0.2]).reshape(4, 1, 1)
    s = conv.compare("caging_area", coarse, fine)
    # 10 -> 10.4: 4 % (within 5); 2 -> 2.2: 10 % (within 15 only); 0.05 and 0 are below 1 % of
    # 10 = 0.1: absolute changes 0.09 (within) and 0.2 (not)
    assert s["n"] == 4
    assert s["within5"] == 2 / 4 and s["within15"] == 3 / 4
    # relative changes by the larger of the value and 1 % of the part's largest: 0.04, 0.1,
    # 0.09 / 0.1, 0.2 / 0.1
    assert np.isclose(s["worst"], 2.0) and np.isclose(s["median"], (0.1 + 0.9) / 2)


def test_undefined_values_are_left_out():
    fine = np.array([[1.0, np.nan], [2.0, 3.0]])             # (r, mu): Scenario B per part
    coarse = np.array([[1.0, 5.0], [np.nan, 3.3]])
    s = conv.compare("manipulation_b_area", coarse, fine)
    assert s["n"] == 2 and s["within5"] == 0.5 and np.isclose(s["worst"], 0.1)
