"""The reports' numerical error of each experiment (sweep/report/experiment_error.py): rows of the
measured table apply to the store whose scene (effects, h, trajectory settings) they were
measured on, and the sentence the reports print follows the table."""
from __future__ import annotations

from pathlib import Path
from types import SimpleNamespace

from sweep.config.parse import load_scene
from sweep.report.experiment_error import (EXPERIMENT_ERROR_TABLE, experiment_error_text,
                                           measured_error, read_table, scene_key, write_rows)

ROOT = Path(__file__).resolve().parents[1]


def store(effects_on="friction finger_collision", h=0.05, trajectory="sliding",
          step_resolution=0.025):
    accuracy = SimpleNamespace(trajectory=trajectory, step_resolution=step_resolution)
    return SimpleNamespace(scene=SimpleNamespace(h=h, accuracy=accuracy),
                           attrs={"effects_on": effects_on})


def row(output, within5, scene=None, h="0.05"):
    return dict(scene=scene or scene_key("friction finger_collision", "sliding", 0.025), h=h,
                reference_h="0.0125", output=output, n="100", median="0.01", p90="0.08",
                worst="2.5", within5=str(within5), within15="0.97", slice="a slice",
                command="scripts/experiment_convergence.py x.yaml")


def test_a_row_applies_to_its_scene_in_any_order_of_the_effects(tmp_path):
    table = tmp_path / "t.csv"
    write_rows([row("caging_area", 0.91), row("parameter_usage", 0.85)], table)
    st = store(effects_on="finger_collision friction")
    assert [r["output"] for r in measured_error(st, ["parameter_usage", "caging_area"], table)] \
        == ["parameter_usage", "caging_area"]
    text = experiment_error_text(st, ["caging_area"], table)
    assert "`caging_area` 91% within 5 %" in text and "against h = 0.0125" in text


def test_the_sentence_follows_the_table(tmp_path):
    table = tmp_path / "t.csv"
    write_rows([row("caging_area", 0.91)], table)
    write_rows([row("caging_area", 0.62)], table)          # replaced, not added
    assert len(read_table(table)) == 1
    assert "`caging_area` 62% within 5 %" in experiment_error_text(store(), ["caging_area"], table)


def test_another_spacing_trajectory_or_scene_is_not_measured(tmp_path):
    table = tmp_path / "t.csv"
    write_rows([row("caging_area", 0.91)], table)
    for st in (store(h=0.025), store(trajectory="grid8"), store(step_resolution=0.0125),
               store(effects_on="friction")):
        assert measured_error(st, ["caging_area"], table) == []
        assert "not measured" in experiment_error_text(st, ["caging_area"], table)
    assert "not measured" in experiment_error_text(store(), ["caging_area"], tmp_path / "no.csv")


def test_rows_of_other_scenes_and_outputs_are_kept(tmp_path):
    table = tmp_path / "t.csv"
    other = scene_key("friction", "sliding", 0.025)
    write_rows([row("caging_area", 0.91), row("caging_area", 0.8, scene=other)], table)
    write_rows([row("tip_prehension_area", 0.97)], table)
    assert sorted((r["scene"] == other, r["output"]) for r in read_table(table)) == \
        [(False, "caging_area"), (False, "tip_prehension_area"), (True, "caging_area")]


def test_the_shipped_table_covers_make_runs_scenes_as_configured():
    """Fails when a config's effects or accuracy settings change without a new measurement
    (scripts/experiment_convergence.py CONFIG --work DIR --table)."""
    for config, outputs in (("paper.yaml", 5), ("paper-collision.yaml", 5),
                            ("paper-tip.yaml", 2), ("paper-tip-collision.yaml", 2)):
        scene = load_scene(ROOT / "configs" / config)
        st = store(" ".join(scene.effects.names_on()), scene.h, scene.accuracy.trajectory,
                   scene.accuracy.step_resolution)
        rows = measured_error(st, ["caging_area", "tip_prehension_area", "manipulation_a_area",
                                   "manipulation_b_area", "parameter_usage"],
                              EXPERIMENT_ERROR_TABLE)
        assert len(rows) == outputs, config
