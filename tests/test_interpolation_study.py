"""Interpolation in energy map space (docs/notes/interpolation.py and the study that uses it,
docs/notes/interpolation_study.py): a design on a corner reproduces that corner's map, an energy
linear in the design is interpolated exactly, the caged flag is a strict weighted majority, the
caging answer of a true map's fields is `compute_map`'s, and the script runs end to end on a
small config.
"""
from __future__ import annotations

import csv
import sys
from pathlib import Path

import numpy as np
import pytest

from sweep.compute.maps import compute_map
from sweep.model import END_CAGED, EJECT, REACHED, UNREACHED, Design, Grid, Part

ROOT = Path(__file__).resolve().parents[1]
NOTES = ROOT / "docs" / "notes"        # the study and its module, beside the doc that reports it
sys.path.insert(0, str(NOTES))
from interpolation import (  # noqa: E402 (from docs/notes/, on the path above)
    FIELDS, caging_of_fields, corner_offsets, corner_weights, interpolate_fields,
)


def synthetic_corner(rng, shape) -> dict:
    """A map's fields that are consistent as a map's are: equilibrium only in P_j, a positive
    caging score only at equilibrium points."""
    pc = rng.choice(np.array([UNREACHED, EJECT, REACHED], dtype=np.int8), size=shape)
    eq = (pc == REACHED) & (rng.random(shape) < 0.5)
    score = np.where(eq & (rng.random(shape) < 0.6), rng.uniform(0.05, 1.0, shape), 0.0)
    return dict(energy=rng.normal(size=shape), point_class=pc, equilibrium=eq,
                caging_score=score)


@pytest.mark.parametrize("k", [1, 2, 5])
def test_a_design_on_a_corner_reproduces_that_corners_map(k):
    rng = np.random.default_rng(k)
    lower, upper = rng.uniform(0.1, 1.0, k), rng.uniform(1.1, 2.0, k)
    corners = [synthetic_corner(rng, (7, 9)) for _ in range(2 ** k)]
    for c, off in enumerate(corner_offsets(k)):
        target = np.where(off == 1, upper, lower)
        w = corner_weights(target, lower, upper)
        assert w[c] == 1.0 and w.sum() == 1.0
        pred = interpolate_fields(corners, w)
        for name in FIELDS:
            assert np.array_equal(pred[name], corners[c][name]), (c, name)


def test_an_energy_linear_in_the_design_is_interpolated_exactly():
    rng = np.random.default_rng(7)
    k, shape = 5, (6, 8)
    slope, offset = rng.normal(size=(k,) + shape), rng.normal(size=shape)
    lower, upper = np.array([1.0, 0.8, 0.08, 0.06, 0.4]), np.array([1.4, 1.6, 0.16, 0.14, 1.2])

    def field(d):   # linear in the design, different at every point
        return offset + np.tensordot(np.asarray(d, float), slope, axes=1)

    corners = []
    for off in corner_offsets(k):
        c = synthetic_corner(rng, shape)
        c["energy"] = field(np.where(off == 1, upper, lower))
        corners.append(c)
    for target in (0.5 * (lower + upper), lower + rng.random(k) * (upper - lower)):
        pred = interpolate_fields(corners, corner_weights(target, lower, upper))
        np.testing.assert_allclose(pred["energy"], field(target), rtol=0, atol=1e-12)


def test_the_caged_flag_is_a_strict_weighted_majority_and_an_infinite_energy_is_skipped():
    shape = (1, 3)
    caged = dict(energy=np.array([[1.0, np.nan, 3.0]]),
                 point_class=np.full(shape, REACHED, np.int8),
                 equilibrium=np.ones(shape, bool), caging_score=np.full(shape, 0.5))
    tip = dict(energy=np.array([[3.0, 2.0, np.nan]]), point_class=np.full(shape, REACHED, np.int8),
               equilibrium=np.ones(shape, bool), caging_score=np.zeros(shape))
    even = interpolate_fields([caged, tip], [0.5, 0.5])
    assert not even["caging_score"].any() and even["equilibrium"].all()
    np.testing.assert_array_equal(even["energy"], [[2.0, 2.0, 3.0]])
    more = interpolate_fields([caged, tip], [0.75, 0.25])
    assert (more["caging_score"] == 0.5).all()


@pytest.fixture(scope="module")
def small_scene():
    from sweep.config.parse import load_scene

    return load_scene(ROOT / "configs" / "small.yaml")


def settings(scene):
    return scene.commands[0], scene.limits, scene.accuracy, scene.effects


def test_the_caging_answer_of_a_true_maps_fields_is_compute_maps(small_scene):
    """Sliding on: the pipeline's caging area and ends, bit for bit; sliding off on the same
    fields: the grid-only descent, which can only stall more and so never cages more."""
    s = small_scene
    design, part = Design(2.0, 1.6, 0.2, 0.14, 0.8), Part(0.4, 0.4)
    m = compute_map(design, part, s.commands[0], Grid(h=s.h), s.limits, s.accuracy, s.effects)
    assert m.attrs["caging_area"] > 0
    area, ends, index = caging_of_fields(m.fields, m.x, m.y, s.h, design, part, *settings(s),
                                         sliding=True)
    assert area == m.attrs["caging_area"]
    assert np.array_equal(ends, m.fields["end_state"])
    assert np.array_equal(index, m.fields["end_index"])
    grid8, ends8, _ = caging_of_fields(m.fields, m.x, m.y, s.h, design, part, *settings(s))
    reached = m.fields["point_class"] == REACHED
    assert grid8 <= area + 1e-12
    assert np.count_nonzero(ends8[reached] == END_CAGED) <= np.count_nonzero(
        ends[reached] == END_CAGED)


def test_a_prediction_on_a_corner_of_real_maps_has_that_corners_caging_area(small_scene):
    s = small_scene
    part = Part(0.4, 0.4)
    designs = [Design(1.2, 1.6, 0.2, 0.14, 0.8), Design(2.0, 1.6, 0.2, 0.14, 0.8)]
    X = max(0.5 * d.w + d.l1 + d.l2 + part.r for d in designs)
    grid = Grid(h=s.h, xlim=(-X, X), ylim=(part.r, part.r + 3.6))
    maps = [compute_map(d, part, s.commands[0], grid, s.limits, s.accuracy, s.effects)
            for d in designs]
    assert maps[0].fields["energy"].shape == maps[1].fields["energy"].shape
    pred = interpolate_fields([m.fields for m in maps], corner_weights([2.0], [1.2], [2.0]))
    got = caging_of_fields(pred, maps[1].x, maps[1].y, s.h, designs[1], part, *settings(s))[0]
    want = caging_of_fields(maps[1].fields, maps[1].x, maps[1].y, s.h, designs[1], part,
                            *settings(s))[0]
    assert got == want and want > 0


def test_the_study_script_runs_on_a_small_config(tmp_path, capsys):
    """One varied parameter (l1 with a middle value): every held-out design's row, its true
    caging area the whole-reach map's and its discretisation error |A(h) - A(h/2)|."""
    text = (ROOT / "configs" / "small.yaml").read_text().replace("l1: [1.2, 2.0]",
                                                                  "l1: [1.2, 1.6, 2.0]")
    config = tmp_path / "small3.yaml"
    config.write_text(text)
    import interpolation_study

    out = tmp_path / "study.csv"
    interpolation_study.main([str(config), "--vary", "l1", "--per-part", "3", "--part",
                              "0.4,0.4", "--out", str(out)])
    rows = list(csv.DictReader(open(out)))
    assert len(rows) == 3 and all(float(r["l1"]) == 1.6 for r in rows)
    from sweep.config.parse import load_scene

    s = load_scene(config)
    for row in rows:
        d = Design(*(float(row[k]) for k in ("l1", "l2", "r1", "r2", "w")))
        m, m2 = (compute_map(d, Part(0.4, 0.4), s.commands[0], Grid(h=h), s.limits, s.accuracy,
                             s.effects) for h in (s.h, s.h / 2))
        assert float(row["area_true"]) == pytest.approx(m.attrs["caging_area"], rel=1e-9)
        assert float(row["discretisation"]) == pytest.approx(
            abs(m.attrs["caging_area"] - m2.attrs["caging_area"]), rel=1e-9, abs=1e-12)
        assert 0.0 <= float(row["agreement"]) <= 1.0
    assert "| all |" in capsys.readouterr().out
