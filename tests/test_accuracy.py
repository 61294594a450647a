"""`sweep accuracy`: the sample rule, the ranking metrics against plain-Python references, and
the command on configs/small.yaml (outputs, recommendation rule, resume, input errors).

The command's study runs on a sample of 2 Halton cells and each part's best cell in `make test`;
`make test-long` (SWEEP_LONG_ORACLES=1, tests/profiles.py) runs it on the default sample, every
cell of the config (about twice the time)."""
import csv
import itertools
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from sweep.runs import accuracy as acc
from sweep.cli import main
from sweep.config.parse import load_scene

from profiles import LONG_ORACLES

ROOT = Path(__file__).resolve().parents[1]
SMALL = ROOT / "configs" / "small.yaml"
#: The command's sample: the default (every cell of the small config) in the long profile.
SAMPLE = [] if LONG_ORACLES else ["--sample", "2"]


def test_halton_is_the_van_der_corput_sequence():
    assert [acc.halton(n, 2) for n in range(1, 5)] == [0.5, 0.25, 0.75, 0.125]
    assert [acc.halton(n, 3) for n in range(1, 4)] == pytest.approx([1 / 3, 2 / 3, 1 / 9])


def tau_b(x, y):
    """Kendall tau-b by counting pairs."""
    conc = disc = tx = ty = 0
    for i, j in itertools.combinations(range(len(x)), 2):
        dx, dy = np.sign(x[i] - x[j]), np.sign(y[i] - y[j])
        if dx == 0 and dy == 0:
            continue
        if dx == 0:
            tx += 1
        elif dy == 0:
            ty += 1
        elif dx == dy:
            conc += 1
        else:
            disc += 1
    return (conc - disc) / np.sqrt((conc + disc + tx) * (conc + disc + ty))


def test_ranking_metrics():
    ref = np.array([3.0, 3.0, 1.0, 2.0, 0.5, 0.1, 0.0])
    # best tied between designs 0 and 1: a setting that picks design 1 agrees
    assert acc.top1_agrees(np.array([2.0, 3.0, 1.0, 2.5, 0.5, 0.1, 0.0]), ref)
    assert not acc.top1_agrees(np.array([2.0, 1.0, 1.0, 2.5, 0.5, 0.1, 0.0]), ref)
    # ties within TIE_REL of the larger value count as ties
    assert acc.top1_agrees(np.array([3.0, 3.0 + 1e-12, 0, 0, 0, 0, 0]), ref)
    # top-5 of the setting: 0, 1, 3, 2, 4 (all in the reference's top 5) -> 1
    assert acc.top5_overlap(ref.copy(), ref) == 1.0
    shuffled = np.array([0.0, 0.1, 0.5, 2.0, 1.0, 3.0, 3.0])
    # setting's top 5: designs 5, 6, 3, 4, 2 -> reference values 0.1, 0.0, 2.0, 0.5, 1.0;
    # the reference's 5th best is 0.5, so 3 of them count
    assert acc.top5_overlap(shuffled, ref) == pytest.approx(3 / 5)
    rng = np.random.default_rng(7)
    for _ in range(5):
        x = rng.integers(0, 4, 12).astype(float)
        y = rng.integers(0, 4, 12).astype(float)
        assert acc.kendall_tau(x, y) == pytest.approx(tau_b(x, y))
    assert acc.kendall_tau(np.ones(4), np.ones(4)) == 1.0


def test_sample_holds_every_parts_best_and_is_deterministic():
    scene = load_scene(SMALL)
    cells = acc.design_cells(scene)
    rng = np.random.default_rng(3)
    areas = rng.random((cells.shape[0], scene.widths.size, len(acc.parts(scene))))
    s1 = acc.sample_cells(scene, 3, areas)
    assert np.array_equal(s1, acc.sample_cells(scene, 3, areas))
    for k in range(areas.shape[-1]):
        best_cell = np.unravel_index(np.argmax(areas[..., k]), areas.shape[:2])[0]
        assert best_cell in s1
    assert len(s1) <= 3 + areas.shape[-1]
    # a sample at least as large as the config's cells is every cell (the command's default
    # sample on this config)
    for n in (cells.shape[0], acc.DEFAULT_SAMPLE):
        assert np.array_equal(acc.sample_cells(scene, n, areas), np.arange(cells.shape[0]))


def test_recommendation_is_the_cheapest_agreeing_setting():
    rows = [dict(axis="h", default=True, top1_agreement=1.0, seconds_per_map=1.0),
            dict(axis="h", default=False, top1_agreement=0.5, seconds_per_map=0.1),
            dict(axis="h", default=False, top1_agreement=1.0, seconds_per_map=0.5),
            dict(axis="root_tol", default=False, top1_agreement=1.0, seconds_per_map=0.95),
            dict(axis="reference/2", default=False, top1_agreement=1.0, seconds_per_map=3.0),
            dict(axis="reference", default=False, top1_agreement=1.0, seconds_per_map=0.01)]
    assert acc.recommend(rows) is rows[2]
    rows[2]["seconds_per_map"] = 0.95  # less than MIN_SAVING cheaper: keep the config's own
    assert acc.recommend(rows) is rows[0]
    for r in rows[:4]:
        r["top1_agreement"] = 0.5
    assert acc.recommend(rows) is rows[4]  # the reference's settings one halving coarser
    rows[4]["top1_agreement"] = 0.5
    assert acc.recommend(rows) is rows[5]  # nothing cheaper agrees: the reference itself


def test_accuracy_command_on_the_small_config(tmp_path):
    out = tmp_path / "acc"
    runner = CliRunner()
    witness = "2,1.6,0.2,0.14,0.8,0.4,0.4"
    config = tmp_path / "small-refine.yaml"  # the small config with its refinement stage on
    config.write_text(SMALL.read_text() + "refine: {levels: 2, bound: 0.5, min_contenders: 2}\n")
    res = runner.invoke(main, ["accuracy", str(config), "--out", str(out), "--no-progress",
                               "--map", witness, *SAMPLE])
    assert res.exit_code == 0, res.output
    for name in ("accuracy.md", "accuracy.csv", "accuracy.png", "convergence.png",
                 "convergence.csv"):
        assert (out / name).stat().st_size > 0
    scene = load_scene(config)
    rows = list(csv.DictReader(open(out / "accuracy.csv")))
    settings, _ = acc.ladder(scene)
    assert len(rows) == len(settings) + 2
    ref = [r for r in rows if r["axis"] == "reference"][0]
    assert float(ref["worst_error"]) == 0.0 and float(ref["top1_agreement"]) == 1.0
    # the reference is one halving finer than the finest rung; its own check one coarser
    finest = min(float(r["h"]) for r in rows if r["axis"] == "h")
    assert float(ref["h"]) == pytest.approx(finest / 2)
    coarse = [r for r in rows if r["axis"] == "reference/2"][0]
    assert float(coarse["h"]) == pytest.approx(finest)
    assert coarse["trajectory"] == ref["trajectory"] == "sliding"
    rec = [r for r in rows if r["recommended"] == "True"]
    assert len(rec) == 1 and float(rec[0]["top1_agreement"]) == 1.0
    assert {r["axis"] for r in rows} == {"h", "reconfig_step", "root_tol", "trajectory",
                                          "reference", "reference/2"}
    assert {r["setting"] for r in rows if r["axis"] == "trajectory"} == \
        {"sliding", "grid8", "continuous"}
    for r in rows:
        assert 0.0 <= float(r["top5_overlap"]) <= 1.0
        assert -1.0 <= float(r["kendall_tau"]) <= 1.0
        assert float(r["median_error"]) <= float(r["worst_error"])
    # convergence: every method at h, h/2, h/4, h/8; the change is |area - area at 2h|
    conv = list(csv.DictReader(open(out / "convergence.csv")))
    assert [(r["method"], float(r["h"])) for r in conv] == [
        (m, scene.h / 2 ** n) for m in ("sliding", "grid8", "continuous") for n in range(4)]
    for m in ("sliding", "grid8", "continuous"):
        sel = [r for r in conv if r["method"] == m]
        assert sel[0]["change"] == ""
        for a, b in zip(sel, sel[1:]):
            assert float(b["change"]) == pytest.approx(abs(float(b["caging_area"])
                                                           - float(a["caging_area"])))
        assert all(0.0 <= float(r["stalled_share"]) <= 1.0 for r in sel)
    text = (out / "accuracy.md").read_text()
    assert "Has the reference converged?" in text and "## Convergence as h halves" in text
    # the refinement stage on the sample: a verdict per part, judged against the reference
    section = text.split("## The refinement stage on the sample")[1]
    verdict_rows = [line for line in section.splitlines() if line.startswith("| 0.")]
    assert len(verdict_rows) == len(acc.parts(scene))
    assert all(line.rstrip(" |").rsplit("| ", 1)[1] in ("agrees", "contains", "differs",
                                                         "not refined")
               for line in verdict_rows)
    assert "l1=2 l2=1.6 r1=0.2 r2=0.14 w=0.8, r=0.4 mu=0.4" in text  # the --map witness
    # resumable: a rerun reads the finished steps and rewrites none of them
    work = sorted(out.glob("work-*/*.npz"))
    stamps = [p.stat().st_mtime_ns for p in work]
    res = runner.invoke(main, ["accuracy", str(config), "--out", str(out), "--no-progress",
                               "--map", witness, *SAMPLE])
    assert res.exit_code == 0, res.output
    assert [p.stat().st_mtime_ns for p in work] == stamps
    assert f"--map {witness}" in text
    # a change of the config's accuracy settings alone keeps the work directory: the
    # reference (its own settings, the same sample) is read back, the config's rungs recomputed
    coarser = tmp_path / "small-refine-coarser-step.yaml"
    coarser.write_text(config.read_text().replace("reconfig_step: 0.01", "reconfig_step: 0.05"))
    assert load_scene(coarser).accuracy.reconfig_step == 0.05
    res = runner.invoke(main, ["accuracy", str(coarser), "--out", str(out), "--no-progress",
                               "--map", witness, *SAMPLE])
    assert res.exit_code == 0, res.output
    assert len(list(out.glob("work-*"))) == 1
    reference = [p for p in work for h in (scene.h / 8, scene.h / 4)
                 if p.name.startswith(f"h{h:.6g}_s0.002_t1e-12_sliding-")]
    assert len(reference) == 2  # the reference and its own check one halving coarser
    assert all(p.stat().st_mtime_ns == s for p, s in zip(work, stamps) if p in reference)
    rungs = sorted(out.glob("work-*/h*_s0.05_t1e-12_sliding-*.npz"))
    assert any(p not in work for p in rungs)  # the config's own rungs are new


@pytest.mark.parametrize("args", [["--sample", "0"], ["--sample", "-3"], ["--map", "1,2,3"],
                                  ["--map", "2,1.6,0.2,0.14,0.8,-0.4,0.4"],
                                  ["--map", "a,b,c,d,e,f,g"]])
def test_accuracy_bad_input_exits_2_before_writing(tmp_path, args):
    out = tmp_path / "acc"
    res = CliRunner().invoke(main, ["accuracy", str(SMALL), "--out", str(out), *args])
    assert res.exit_code == 2
    assert not out.exists()


def test_accuracy_bad_config_exits_2(tmp_path):
    bad = tmp_path / "bad.yaml"
    bad.write_text(SMALL.read_text().replace("trajectory: sliding", "trajectory: rk4"))
    res = CliRunner().invoke(main, ["accuracy", str(bad), "--out", str(tmp_path / "acc")])
    assert res.exit_code == 2
    assert not (tmp_path / "acc").exists()
