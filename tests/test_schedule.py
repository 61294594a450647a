"""Variable geometry during the grasp (MODEL 12, model-notes D35): schedules of settings read
from maps' trajectory ends (`sweep.compute.schedules`), the ladder and verdicts
(`sweep.runs.schedule`), `sweep schedule STORE` and its file.

Against the slow reference of tests/naive_schedule.py, which runs both trajectories point by
point from the two maps' fields (grid8 maps walked, sliding maps read end by end, and maps of
tests/naive.py's reference), against hand-made maps with a known answer, and for the identities
the model states: X -> X is the fixed map's own caging area bit for bit, the best schedule is
never below the best fixed setting, mirror symmetry, and the store's own values.
"""
from __future__ import annotations

import dataclasses

import math
from pathlib import Path
from types import SimpleNamespace

import h5py
import numpy as np
import pytest
from click.testing import CliRunner
from hypothesis import given, strategies as st

import naive_schedule
from naive import naive_map
from sweep.cli import main
from sweep.compute.chassis_maps import settings_maps
from sweep.compute.maps import compute_map
from sweep.compute.schedules import (Ends, best_of_three, chained, chained_areas, lattice_of,
                                     on_lattice, schedule_values, tie_key)
from sweep.model import (END_CAGED, END_EJECTION, END_NONE, END_STALLED, END_TIP_PREHENSION,
                         Accuracy, Command, Design, Effects, Grid, Limits, Part)
from sweep.runs import ladder
from sweep.runs import schedule as sched

ROOT = Path(__file__).resolve().parents[1]
SMALL = ROOT / "configs" / "small.yaml"


def maps_of(l1, l2, pairs, widths, part, h, accuracy=Accuracy(), effects=Effects()):
    """compute_map's maps of every (r1, r2) x w, the pairs outer."""
    return [compute_map(Design(l1, l2, r1, r2, w), part, grid=Grid(h=h), accuracy=accuracy,
                        effects=effects) for r1, r2 in pairs for w in widths]


def values_of(maps, part, h):
    lat = lattice_of(maps, h, part.r)
    ends = [on_lattice(m, lat) for m in maps]
    return lat, ends, schedule_values(ends, h)


# ---------------------------------------------------------------------------------------------
# Against the slow reference
# ---------------------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def grid8_maps():
    """Maps whose trajectories the reference can walk from their fields: grid8 without step
    checks (model-notes D36: the walk reads grid values only), three palm widths (three grid
    extents), two ratios, a part the maps cage and hold."""
    part = Part(0.4, 0.4)
    acc = Accuracy(trajectory="grid8", reconfig_step=0.05, step_resolution=0.0)
    return part, maps_of(1.2, 0.8, [(0.12, 0.06), (0.12, 0.14)], [0.0, 0.4, 0.8], part, 0.1,
                         acc)


def test_the_reference_walk_is_the_kernels_grid8(grid8_maps):
    """The reference's trajectories are the kernels' own where both run grid8."""
    _, maps = grid8_maps
    for m in maps:
        state, index = m.fields["end_state"], m.fields["end_index"]
        for j in range(m.y.size):
            for i in range(m.x.size):
                got = naive_schedule.trajectory(m, j, i, walk=True)
                if state[j, i] == END_NONE:
                    assert got[0] == END_NONE
                    continue
                assert got[0] == state[j, i] and got[1] * m.x.size + got[2] == index[j, i]


def test_every_schedule_against_the_reference_walking_both_maps(grid8_maps):
    part, maps = grid8_maps
    h = 0.1
    lat, ends, (caging, tip) = values_of(maps, part, h)
    n_switching = 0
    for a, x in enumerate(maps):
        for b, y in enumerate(maps):
            ref = naive_schedule.schedule([x] if a == b else [x, y], walk=True)
            assert caging[a, b] == pytest.approx(ref["lam"] * h * h, rel=1e-12, abs=1e-15)
            assert tip[a, b] == ref["n_tip"] * h * h
            n_switching += a != b and ref["n_caged"] > 0
            state, end = chained([ends[a]] if a == b else [ends[a], ends[b]])
            for (sx, sy), (s, ex, ey) in ref["final"].items():
                p = lat_index(lat, sx, sy)
                assert state[p] == s
                if s != END_NONE:
                    assert lat_xy(lat, end[p]) == pytest.approx((ex, ey), abs=1e-9)
    assert n_switching > 10      # the switches do something here


def lat_index(lat, x, y) -> int:
    return int(round((y - lat.r) / lat.h)) * lat.nx + int(round(x / lat.h)) + lat.n


def lat_xy(lat, p) -> tuple:
    j, i = divmod(int(p), lat.nx)
    return float(lat.x[i]), float(lat.y[j])


def test_sliding_maps_against_the_reference_reading_end_by_end():
    """The default trajectories (sliding) cannot be walked from the fields: the reference
    reads each map's end fields one start at a time."""
    part, h = Part(0.8, 0.1), 0.1
    maps = maps_of(2.0, 1.6, [(0.2, 0.02), (0.12, 0.06)], [0.0, 0.8, 1.2], part, h,
                   Accuracy(reconfig_step=0.05))
    _, _, (caging, tip) = values_of(maps, part, h)
    for a, x in enumerate(maps):
        for b, y in enumerate(maps):
            ref = naive_schedule.schedule([x] if a == b else [x, y])
            assert caging[a, b] == pytest.approx(ref["lam"] * h * h, rel=1e-12, abs=1e-15)
            assert tip[a, b] == ref["n_tip"] * h * h
    assert caging.max() > caging.diagonal().max()       # a switch gains on this part


def test_schedules_of_the_reference_maps():
    """Maps of tests/naive.py's reference (a plain-Python map, point by point), composed by the
    slow reference, against the schedules of the kernels' maps."""
    part, h = Part(0.4, 0.4), 0.2
    designs = [(0.16, 0.06, 0.0), (0.16, 0.06, 0.4), (0.12, 0.14, 0.4)]
    refs = []
    for r1, r2, w in designs:
        ref = naive_map(1.6, 0.8, r1, r2, w, part.r, part.mu, h=h)
        refs.append(SimpleNamespace(**ref))
    maps = [compute_map(Design(1.6, 0.8, r1, r2, w), part, grid=Grid(h=h))
            for r1, r2, w in designs]
    _, _, (caging, tip) = values_of(maps, part, h)
    for a in range(len(designs)):
        for b in range(len(designs)):
            ref = naive_schedule.schedule([refs[a]] if a == b else [refs[a], refs[b]])
            assert caging[a, b] == pytest.approx(ref["lam"] * h * h, rel=1e-9, abs=1e-15)
            assert tip[a, b] == ref["n_tip"] * h * h


# ---------------------------------------------------------------------------------------------
# Identities
# ---------------------------------------------------------------------------------------------
@pytest.mark.parametrize("effects", [Effects(), Effects(finger_collision=True)],
                         ids=["base", "finger_collision"])
def test_x_to_x_is_the_fixed_maps_caging_area_bit_for_bit(effects):
    part, h = Part(0.4, 0.1), 0.1
    maps = [compute_map(Design(2.0, 1.6, r1, r2, w), part, grid=Grid(h=h), effects=effects,
                        accuracy=Accuracy(reconfig_step=0.05))
            for r1, r2 in ((0.2, 0.1), (0.08, 0.02)) for w in (0.0, 0.4, 1.2)]
    _, ends, (caging, tip) = values_of(maps, part, h)
    for k, m in enumerate(maps):
        assert caging[k, k] == m.attrs["caging_area"]            # ==, not approx
        assert tip[k, k] == m.attrs["tip_prehension_area"]
        assert chained_areas([ends[k]], h) == (caging[k, k], tip[k, k])
    assert caging.max() >= caging.diagonal().max()


def test_the_sweeps_maps_are_compute_maps():
    """chassis_maps (one finger field per pulley pair, the sweep's way) gives compute_map's
    ends and summary, and a palm half-width off the grid falls back to compute_map."""
    part, h = Part(0.8, 0.4), 0.1
    settings = [(0.12, 0.06, 0.0), (0.2, 0.1, 0.4), (0.12, 0.06, 1.2), (0.12, 0.06, 0.3),
                (0.2, 0.1, 0.0)]
    got = settings_maps(1.2, 0.8, settings, part, Command(), h, Limits(),
                        Accuracy(reconfig_step=0.05), Effects())
    for (r1, r2, w), g in zip(settings, got):
        m = compute_map(Design(1.2, 0.8, r1, r2, w), part, grid=Grid(h=h),
                        accuracy=Accuracy(reconfig_step=0.05))
        for name in ("end_state", "end_index", "caging_score"):
            assert np.array_equal(getattr(g, name), m.fields[name]), (w, name)
        assert np.array_equal(g.x, m.x) and np.array_equal(g.y, m.y)
        assert g.caging_area == m.attrs["caging_area"]
        assert g.n_tip_prehension == m.attrs["n_tip_prehension"]


def mirrored(m):
    """Map m's ends mirrored in x (the map of the mirror-image hand)."""
    ny, nx = m.end_state.shape if hasattr(m, "end_state") else m.fields["end_state"].shape
    f = naive_schedule.field
    index = np.asarray(f(m, "end_index"))
    j, i = np.divmod(np.where(index >= 0, index, 0), nx)
    flipped = np.where(index >= 0, j * nx + (nx - 1 - i), -1)[:, ::-1]
    return SimpleNamespace(x=-np.asarray(m.x)[::-1], y=np.asarray(m.y),
                           end_state=np.asarray(f(m, "end_state"))[:, ::-1],
                           end_index=np.ascontiguousarray(flipped),
                           caging_score=np.asarray(f(m, "caging_score"))[:, ::-1])


def test_mirror_symmetry():
    """Schedules commute with mirroring: the maps of the mirror-image hand (each map's ends
    mirrored in x) give the same areas and every start's final end mirrored. (A map's own
    trajectories are mirror images only up to its tie-breaking order, E before W: MODEL 8.)"""
    part, h = Part(0.8, 0.4), 0.1
    maps = maps_of(2.0, 1.6, [(0.16, 0.1), (0.16, 0.18)], [0.0, 1.2], part, h,
                   Accuracy(reconfig_step=0.05))
    lat, ends, (caging, tip) = values_of(maps, part, h)
    flipped = [on_lattice(mirrored(m), lat) for m in maps]
    caging_m, tip_m = schedule_values(flipped, h)
    assert np.allclose(caging_m, caging, rtol=1e-12, atol=1e-15)
    assert np.array_equal(tip_m, tip)
    for a in range(len(ends)):
        for b in range(len(ends)):
            seq = [a] if a == b else [a, b]
            state, end = chained([ends[k] for k in seq])
            state_m, end_m = chained([flipped[k] for k in seq])
            assert np.array_equal(state_m.reshape(lat.ny, lat.nx),
                                  state.reshape(lat.ny, lat.nx)[:, ::-1])
            j, i = np.divmod(np.where(end >= 0, end, 0), lat.nx)
            want = np.where(end >= 0, j * lat.nx + (lat.nx - 1 - i), -1)
            assert np.array_equal(end_m.reshape(lat.ny, lat.nx),
                                  want.reshape(lat.ny, lat.nx)[:, ::-1])
    assert caging.max() > caging.diagonal().max()


# ---------------------------------------------------------------------------------------------
# Hand-made maps
# ---------------------------------------------------------------------------------------------
def toy(x, end_state, end_index, score, h=1.0, r=0.0):
    return SimpleNamespace(x=np.asarray(x, float), y=np.array([r]),
                           end_state=np.array([end_state], np.int8),
                           end_index=np.array([end_index], np.int64),
                           caging_score=np.array([score], float))


C, T, E, S, N = END_CAGED, END_TIP_PREHENSION, END_EJECTION, END_STALLED, END_NONE


def off_the_palm(e):
    """A hand-made row's ends as if the row lay above the palm line (every start a whole cell;
    the palm row's half cells are the trapezoid's, tested on real maps)."""
    return dataclasses.replace(e, palm=0)


def test_the_palm_rows_starts_count_half():
    """model-notes D36: a one-row lattice lies on the palm line, so each start is half a cell:
    X's two tip starts give 1.0, its caged start at 1 (score 0.5) 0.25."""
    X = toy([-1, 0, 1], [T, T, C], [1, 1, 2], [0, 0, 0.5])
    lat = lattice_of([X], 1.0, 0.0)
    caging, tip = schedule_values([on_lattice(X, lat)], 1.0)
    assert caging[0, 0] == 0.25 and tip[0, 0] == 1.0


def test_a_synthetic_pair_with_a_known_answer():
    """One row of part positions; X covers x = -1, 0, 1 (a narrow palm), Y x = -2 .. 2.
    X: the start at -1 ends in tip prehension at 0; 0 is a tip point; 1 stalls at itself.
    Y: -2 is off P_j; -1 and 0 end caged at -1 (score 0.8); 1 is caged itself (score 0.5);
    2 ejects. So X -> Y: the three starts go on to Y from 0, 0 and 1: 0.8 + 0.8 + 0.5;
    Y -> X: Y's caged ends -1 (two starts) and 1 (one start, at itself) go on to X: -1 ends in
    tip prehension at 0 there (two), 1 stalls (not counted): no cage, two tips."""
    X = toy([-1, 0, 1], [T, T, S], [1, 1, 2], [0, 0, 0])
    Y = toy([-2, -1, 0, 1, 2], [N, C, C, C, E], [-1, 1, 1, 3, 4], [0, 0.8, 0, 0.5, 0])
    lat = lattice_of([X, Y], 1.0, 0.0)
    assert (lat.n, lat.ny) == (2, 1)
    ends = [off_the_palm(on_lattice(m, lat)) for m in (X, Y)]
    caging, tip = schedule_values(ends, 1.0)
    assert caging[0, 0] == 0.0 and tip[0, 0] == 2.0
    assert caging[1, 1] == pytest.approx(0.8 + 0.8 + 0.5) and tip[1, 1] == 0.0
    assert caging[0, 1] == pytest.approx(2.1) and tip[0, 1] == 0.0
    assert caging[1, 0] == 0.0 and tip[1, 0] == 2.0
    state, end = chained(ends)
    assert list(state) == [N, C, C, C, N] and list(end) == [-1, 1, 1, 3, -1]


def test_no_switch_is_no_switch():
    """A stall recorded at a grid point whose own trajectory goes on (there: to a cage) stays a
    stall under X -> X (D35), where composing X with itself would cage it."""
    X = toy([-1, 0, 1], [S, C, C], [1, 2, 2], [0, 0, 0.5])
    Y = toy([-1, 0, 1], [C, C, C], [0, 1, 2], [0.25, 0.25, 0.25])
    lat = lattice_of([X, Y], 1.0, 0.0)
    ends = [off_the_palm(on_lattice(m, lat)) for m in (X, Y)]
    caging, _ = schedule_values(ends, 1.0)
    assert caging[0, 0] == 1.0                      # the starts at 0 and 1, caged at 1
    assert chained_areas([ends[0], ends[0]], 1.0)[0] == 1.5     # what a self-switch would say
    assert caging[0, 1] == pytest.approx(0.75)      # Y takes the stall and both cages on


def level(h, settings, caging, tip):
    return ladder.Level(h, np.array(settings), np.array(caging, float), np.array(tip, float))


TABLE = [ladder.Setting(0.1, 0.05, 0.0), ladder.Setting(0.1, 0.05, 0.4),
         ladder.Setting(0.1, 0.1, 0.0), ladder.Setting(0.1, 0.1, 0.4)]


def test_verdicts_on_a_hand_made_ladder():
    """The best schedule 0 -> 3 gains 1.0 at the finer level; its change 0.3 and the fixed
    setting's 0.2 make u = 0.5 < 1.0: a gain. Then the same with a larger change: none."""
    caging0 = [[2.0, 2.1, 2.5, 3.5], [1.0, 1.0, 0, 0], [0, 0, 0.5, 0], [0, 0, 0, 1.5]]
    caging1 = [[2.2, 2.4, 2.0, 3.2], [1.0, 1.1, 0, 0], [0, 0, 0.5, 0], [0, 0, 0, 1.4]]
    zero = np.zeros((4, 4))
    res = ladder.CaseResult(None, [level(0.1, [0, 1, 2, 3], caging0, zero),
                                  level(0.05, [0, 1, 2, 3], caging1, zero)])
    fixed = ladder.best_of_kind(res, TABLE, "caging", "fixed", 2)
    best = ladder.best_of_kind(res, TABLE, "caging", "schedule", 2)
    assert (fixed.draw, fixed.hold, best.draw, best.hold) == (0, 0, 0, 3)
    assert best.error == pytest.approx(0.3) and fixed.error == pytest.approx(0.2)
    d, u, verdict = ladder.verdict(fixed, best, 1)
    assert (d, u, verdict) == (pytest.approx(1.0), pytest.approx(0.5), "gain")
    r_sw = ladder.best_of_kind(res, TABLE, "caging", "r_switch", 2)
    w_sw = ladder.best_of_kind(res, TABLE, "caging", "w_switch", 2)
    assert (r_sw.draw, r_sw.hold) == (0, 2) and (w_sw.draw, w_sw.hold) == (0, 1)
    caging1[0][3] = 4.9                        # a change of 1.4: d = 2.7 > u = 1.4 + 0.2
    res.levels[1] = level(0.05, [0, 1, 2, 3], caging1, zero)
    best = ladder.best_of_kind(res, TABLE, "caging", "schedule", 2)
    d, u, verdict = ladder.verdict(fixed, best, 1)
    assert d == pytest.approx(2.7) and u == pytest.approx(1.6) and verdict == "gain"
    caging1[0][3] = 2.3                        # d = 0.1 < u = 1.2 + 0.2
    res.levels[1] = level(0.05, [0, 1, 2, 3], caging1, zero)
    best = ladder.best_of_kind(res, TABLE, "caging", "schedule", 2)
    assert (best.draw, best.hold) == (0, 1)    # 2.4: the best schedule is now 0 -> 1
    d, u, verdict = ladder.verdict(fixed, best, 1)
    assert verdict == "none" and d == pytest.approx(0.2) and u == pytest.approx(0.5)
    # one level: no error estimate
    one = ladder.CaseResult(None, [res.levels[0]])
    f1, b1 = (ladder.best_of_kind(one, TABLE, "caging", k, 1) for k in ("fixed", "schedule"))
    assert ladder.verdict(f1, b1, 0)[2] == "unestimated" and math.isnan(b1.error)


def test_ties_go_to_the_fixed_setting_and_contenders_are_positive():
    caging = np.array([[1.0, 1.0, 0.0, 0.0], [0.0, 0.5, 0.0, 0.0], [0.0, 0.0, 0.0, 0.0],
                       [0.0, 0.0, 0.0, 0.0]])
    lv = level(0.1, [0, 1, 2, 3], caging, np.zeros((4, 4)))
    res = ladder.CaseResult(None, [lv])
    best = ladder.best_of_kind(res, TABLE, "caging", "schedule", 1)
    assert (best.draw, best.hold) == (0, 0)
    assert ladder.verdict(ladder.best_of_kind(res, TABLE, "caging", "fixed", 1), best, 0)[:1] \
        == (0.0,)
    # the contenders: fixed 0 and 1, the switch 0 -> 1 (w switch); nothing of 2 and 3
    assert list(ladder.contender_settings(lv, TABLE, 2)) == [0, 1]


# ---------------------------------------------------------------------------------------------
# Properties on random ends
# ---------------------------------------------------------------------------------------------
@st.composite
def random_ends(draw, mirror=False):
    """Settings' ends on one lattice of ny x nx points (nx odd), drawn at random; with
    `mirror`, each setting's ends are mirror images in x of themselves."""
    ny = draw(st.integers(1, 3))
    half = draw(st.integers(0, 3))
    nx = 2 * half + 1
    n = draw(st.integers(1, 4))
    size = ny * nx
    out = []
    for _ in range(n):
        state = np.array(draw(st.lists(st.sampled_from([N, C, T, E, S]), min_size=size,
                                       max_size=size)), np.int8)
        end = np.array(draw(st.lists(st.integers(0, size - 1), min_size=size, max_size=size)))
        score = np.array(draw(st.lists(st.floats(0.0, 1.0), min_size=size, max_size=size)))
        if mirror:
            s2, e2, c2 = state.reshape(ny, nx), end.reshape(ny, nx), score.reshape(ny, nx)
            s2[:, half + 1:] = s2[:, :half][:, ::-1]
            c2[:, half + 1:] = c2[:, :half][:, ::-1]
            j, i = np.divmod(e2[:, :half][:, ::-1], nx)
            e2[:, half + 1:] = j * nx + (nx - 1 - i)
            e2[:, half] = np.where((e2[:, half] % nx) == half, e2[:, half],
                                   (e2[:, half] // nx) * nx + half)
        end = np.where(state == N, -1, end)
        out.append(Ends(state, end, score))
    return ny, nx, out


def plain(ends, seq, h):
    """The schedule through the settings `seq` (indices), start by start in plain Python."""
    lam, tips = 0.0, 0
    for s in range(ends[0].state.size):
        state, end = int(ends[seq[0]].state[s]), int(ends[seq[0]].end[s])
        for k in seq[1:]:
            if state not in (C, T, S):
                break
            state, end = int(ends[k].state[end]), int(ends[k].end[end])
        if state == C:
            lam += float(ends[seq[-1]].score[end])
        tips += state == T
    return lam * h * h, tips * h * h


@given(random_ends())
def test_every_schedule_is_the_plain_sum_and_never_below_the_best_fixed(drawn):
    _, _, ends = drawn
    h = 0.1
    caging, tip = schedule_values(ends, h)
    for a in range(len(ends)):
        for b in range(len(ends)):
            lam, tips = plain(ends, [a] if a == b else [a, b], h)
            assert caging[a, b] == (lam if a == b else pytest.approx(lam, rel=1e-12, abs=1e-15))
            assert tip[a, b] == pytest.approx(tips, abs=1e-12)
    assert caging.max() >= caging.diagonal().max() and tip.max() >= tip.diagonal().max()


@given(random_ends(mirror=True))
def test_mirrored_ends_give_mirrored_schedules(drawn):
    ny, nx, ends = drawn
    for a in range(len(ends)):
        for b in range(len(ends)):
            state, end = chained([ends[a]] if a == b else [ends[a], ends[b]])
            s2, e2 = state.reshape(ny, nx), end.reshape(ny, nx)
            assert np.array_equal(s2, s2[:, ::-1])
            on = e2 >= 0
            j, i = np.divmod(np.where(on, e2, 0), nx)
            assert np.array_equal(j[on], j[:, ::-1][on])
            assert np.array_equal(i[on], nx - 1 - i[:, ::-1][on])


@given(random_ends())
def test_the_best_of_three_is_the_brute_forces(drawn):
    _, _, ends = drawn
    h = 0.1
    got = best_of_three(ends, h, k=2)
    for o, name in enumerate(("caging", "tip_prehension")):
        brute = [(plain(ends, [x, y, z], h)[o], (x, y, z)) for x in range(len(ends))
                 for y in range(len(ends)) for z in range(len(ends)) if y != x and z != y]
        best = max([v for v, _ in brute], default=0.0)
        found = got[name]
        assert len(found) <= 2
        if not best > 0:
            assert not found
            continue
        assert tie_key(found[0][0]) == tie_key(best)
        for value, triple in found:
            assert plain(ends, list(triple), h)[o] == pytest.approx(value, rel=1e-12, abs=1e-15)
        # each draw setting's best, the largest first, no draw setting twice
        assert len({t[0] for _, t in found}) == len(found)
        assert [tie_key(v) for v, _ in found] == sorted((tie_key(v) for v, _ in found),
                                                        reverse=True)


# ---------------------------------------------------------------------------------------------
# `sweep schedule STORE`
# ---------------------------------------------------------------------------------------------
def invoke(*args):
    return CliRunner().invoke(main, [str(a) for a in args])


@pytest.fixture(scope="module")
def small_store(tmp_path_factory) -> Path:
    """configs/small.yaml with its refinement (one level): each part's best chassis refined."""
    import yaml

    raw = yaml.safe_load(SMALL.read_text())
    raw["refine"] = {"levels": 1, "min_contenders": 2}
    root = tmp_path_factory.mktemp("schedule")
    config = root / "small-refined.yaml"
    config.write_text(yaml.safe_dump(raw))
    out = root / "small.h5"
    res = invoke("run", config, "--out", out, "--threads", 1, "--no-progress")
    assert res.exit_code == 0, res.output
    return out


OPTS = ("--ladder", "0.2,0.1", "--threads", 1, "--no-progress")
#: Variables and root attributes that time the run (they differ between a run and its resume).
TIMING = ("seconds_maps", "seconds_values")


@pytest.fixture(scope="module")
def scheduled(small_store, tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("scheduled") / "small.schedule.h5"
    res = invoke("schedule", small_store, *OPTS, "--third-switch", "--out", out)
    assert res.exit_code == 0, res.output
    assert "caging: fixed" in res.output and "tip_prehension: fixed" in res.output
    return out


def contents(path: Path) -> tuple[dict, dict]:
    from sweep.storage.schedule import RUN_ATTRS

    with h5py.File(path, "r") as f:
        data = {k: f[k][...] for k in f if k not in TIMING}
        attrs = {k: v for k, v in f.attrs.items() if k not in RUN_ATTRS}
    return data, attrs


def test_the_file_is_self_describing(scheduled):
    import xarray as xr

    with xr.open_dataset(scheduled, engine="h5netcdf") as ds:
        assert ds.schedule_area.dims == ("case", "objective", "level", "draw", "hold")
        assert list(ds.objective.values) == ["caging", "tip_prehension"]
        assert list(ds.kind.values) == ["fixed", "schedule", "r_switch", "w_switch"]
        assert list(ds.h.values) == [0.2, 0.1]
        for name in ("verdict", "chassis_source", "part_status"):
            assert "flag_values" in ds[name].attrs and "flag_meanings" in ds[name].attrs
        for name in ds.data_vars:
            assert "long_name" in ds[name].attrs, name
        a = ds.attrs
        assert a["sweep_file_kind"] == "sweep-schedule"
        for key in ("sweep_version", "config_hash", "store_config", "grid_h", "identity",
                    "ladder", "effects_on",
                    "switch_rule", "verdict_rule", "created_utc", "compute_seconds",
                    "wall_seconds", "screening_compute_seconds", "numba_version"):
            assert key in a, key


def test_the_stores_identities(small_store, scheduled):
    """Read independently of the command's code: every fixed setting at the first spacing is
    the store's design bit for bit (caging area, tip-prehension count), each part's best
    chassis is the refined store's best design's, the best schedule is never below the best
    fixed setting, the gain, its error and the verdict are those of the stored areas."""
    import xarray as xr

    from sweep.storage.schedule import KINDS, VERDICTS

    store = xr.open_dataset(small_store, engine="h5netcdf")
    ds = xr.open_dataset(scheduled, engine="h5netcdf")
    fixed, sched_k = KINDS.index("fixed"), KINDS.index("schedule")
    n_checked = 0
    for c in range(ds.case.size):
        l1, l2, r, mu = (float(ds[k][c]) for k in ("l1", "l2", "r", "mu"))
        part = store.sel(r=r, mu=mu)
        if int(ds.chassis_source[c]) == 0:           # the part's best chassis
            role = part.refine_role.values
            best = np.argwhere(role == 3)[0]         # REFINE_ROLE_MEANINGS: best
            assert (float(store.l1[best[0]]), float(store.l2[best[1]])) == (l1, l2)
        for s in range(ds.setting.size):
            r1, r2, w = (float(ds[k][s]) for k in ("setting_r1", "setting_r2", "setting_w"))
            design = part.sel(l1=l1, l2=l2, r1=r1, r2=r2, w=w)
            assert float(ds.schedule_area[c, 0, 0, s, s]) == float(design.caging_area)
            assert float(ds.schedule_area[c, 1, 0, s, s]) == float(design.tip_prehension_area)
            n_checked += 1
        for o in range(2):
            k = int(ds.finest_level[c])
            area = ds.best_area[c, o, :, k].values
            assert area[sched_k] >= area[fixed]
            assert ds.screened_area[c, o, sched_k] >= ds.screened_area[c, o, fixed]
            screened_fixed = float(ds.screened_area[c, o, fixed])
            diag = np.diagonal(ds.schedule_area[c, o, 0].values)
            assert screened_fixed == pytest.approx(np.nanmax(diag), rel=1e-12)
            d = float(ds.gain[c, o])
            assert d == pytest.approx(area[sched_k] - area[fixed], abs=1e-12)
            errors = ds.best_error[c, o].values
            for kind in (fixed, sched_k):
                a = ds.best_area[c, o, kind].values
                assert errors[kind] == pytest.approx(abs(a[k] - a[k - 1]))
            u = float(ds.gain_error[c, o])
            assert u == pytest.approx(errors[fixed] + errors[sched_k])
            assert VERDICTS[int(ds.verdict[c, o])] == ("gain" if d > u else "none")
            # the best of the finest level is its best among the schedules computed there
            top = ds.schedule_area[c, o, k].values
            assert area[sched_k] == pytest.approx(np.nanmax(top), rel=1e-9)
    assert n_checked > 0
    store.close()
    ds.close()


def test_the_third_switch_is_recomputed_independently(small_store, scheduled):
    """The stored three-setting schedule and the best of two, at both spacings, are what the
    slow reference gives on compute_map's maps of their settings."""
    from sweep.config.parse import scene_from_frozen
    from sweep.storage.store import read_store

    scene = scene_from_frozen(read_store(small_store).frozen)
    with h5py.File(scheduled, "r") as f:
        checked = 0
        for c in range(f["case"].size):
            for o in range(2):
                triple = [int(t) for t in f["third_settings"][c, o]]
                if min(triple) < 0:
                    continue
                pair = [int(t) for t in f["third_two_settings"][c, o]]
                part = Part(float(f["r"][c]), float(f["mu"][c]))
                for k in range(2):
                    h = float(f["h"][k])

                    def m(t, c=c, part=part, h=h):
                        return compute_map(
                            Design(float(f["l1"][c]), float(f["l2"][c]),
                                   float(f["setting_r1"][t]), float(f["setting_r2"][t]),
                                   float(f["setting_w"][t])), part, scene.commands[0],
                            Grid(h=h), scene.limits, scene.accuracy, scene.effects)

                    ref = naive_schedule.schedule([m(t) for t in triple])
                    got = f["third_area"][c, o, k]
                    want = ref["lam"] if o == 0 else ref["n_tip"]
                    assert got == pytest.approx(want * h * h, rel=1e-9, abs=1e-15), (c, o, k)
                    two = naive_schedule.schedule([m(t) for t in dict.fromkeys(pair)])
                    want = two["lam"] if o == 0 else two["n_tip"]
                    assert f["third_best_two"][c, o, k] == pytest.approx(want * h * h,
                                                                         rel=1e-9, abs=1e-15)
                d = f["third_area"][c, o, 1] - f["third_best_two"][c, o, 1]
                u = (abs(f["third_area"][c, o, 1] - f["third_area"][c, o, 0])
                     + abs(f["third_best_two"][c, o, 1] - f["third_best_two"][c, o, 0]))
                assert f["third_error"][c, o] == pytest.approx(u)
                assert bool(f["third_adds"][c, o]) == (d > u and tie_key(
                    f["third_area"][c, o, 1]) != tie_key(f["third_best_two"][c, o, 1]))
                checked += 1
        assert checked > 0


def test_a_rerun_is_a_no_op_and_a_killed_run_resumes(small_store, scheduled, tmp_path,
                                                     monkeypatch):
    again = invoke("schedule", small_store, *OPTS, "--third-switch", "--out", scheduled)
    assert again.exit_code == 0 and "nothing computed" in again.output
    out = tmp_path / "killed.h5"
    real = sched.run_case
    calls = {"n": 0}

    def dies(*args, **kwargs):
        calls["n"] += 1
        if calls["n"] > 1:
            raise KeyboardInterrupt
        return real(*args, **kwargs)

    monkeypatch.setattr(sched, "run_case", dies)
    res = invoke("schedule", small_store, *OPTS, "--third-switch", "--out", out)
    assert res.exit_code == 130, res.output
    assert not out.exists()
    assert (tmp_path / "killed.h5.work" / "case-0000.npz").exists()
    monkeypatch.setattr(sched, "run_case", real)
    res = invoke("schedule", small_store, *OPTS, "--third-switch", "--out", out)
    assert res.exit_code == 0, res.output
    assert not (tmp_path / "killed.h5.work").exists()
    same(scheduled, out)
    with h5py.File(out, "r") as f:
        assert f.attrs["computed_cases"] < f["case"].size


def test_cases_side_by_side_give_the_same_results(small_store, tmp_path, monkeypatch):
    """Two threads run two cases at once (each on one thread): the same results as one case
    after another; killed there, the cases running finish and are kept, and the rerun gives
    the same results again."""
    import numba

    if numba.config.NUMBA_NUM_THREADS < 2:
        pytest.skip("one core")
    named = ("--chassis", "1.2,0.8", "--chassis", "2.0,1.6")
    one = tmp_path / "one.h5"
    assert invoke("schedule", small_store, *OPTS, *named, "--out", one).exit_code == 0
    opts = [o if o != 1 else 2 for o in OPTS] + list(named)       # --threads 2
    out = tmp_path / "two.h5"
    res = invoke("schedule", small_store, *opts, "--out", out)
    assert res.exit_code == 0, res.output
    with h5py.File(out, "r") as f:
        assert f["case"].size == 4
    same(one, out)
    real = sched.run_case
    calls = {"n": 0}

    def dies(case, *args, **kwargs):
        calls["n"] += 1
        if calls["n"] == 3:
            raise KeyboardInterrupt
        return real(case, *args, **kwargs)

    killed = tmp_path / "killed.h5"
    monkeypatch.setattr(sched, "run_case", dies)
    res = invoke("schedule", small_store, *opts, "--out", killed)
    assert res.exit_code == 130, res.output
    assert not killed.exists()
    kept = sorted(p.name for p in (tmp_path / "killed.h5.work").glob("case-*.npz"))
    assert len(kept) >= 2
    monkeypatch.setattr(sched, "run_case", real)
    assert invoke("schedule", small_store, *opts, "--out", killed).exit_code == 0
    same(one, killed)


def same(a: Path, b: Path) -> None:
    (da, aa), (db, ab) = contents(a), contents(b)
    assert sorted(da) == sorted(db)
    for k in da:
        assert np.array_equal(da[k], db[k], equal_nan=da[k].dtype.kind == "f"), k
    assert set(aa) == set(ab)


@pytest.mark.parametrize("args, names", [
    (("--chassis", "0,1.6"), ("--chassis",)),
    (("--chassis", "2.0"), ("--chassis", "2 numbers")),
    (("--chassis", "2.0,nan"), ("--chassis",)),
    (("--ladder", "0.1,0.2"), ("--ladder", "decrease")),
    (("--ladder", "0.2,x"), ("--ladder",)),
    (("--ladder", "0.2,-0.1"), ("--ladder",)),
    (("--part", "0.5,0.4"), ("--part", "0.5,0.4")),
    (("--part", "0.4"), ("--part",)),
    (("--contenders", "0"), ("--contenders",)),
    (("--ladder", "0.2,0.0002"), ("points", "raise h")),
])
def test_bad_input_is_refused_before_anything_is_written(small_store, tmp_path, args, names):
    out = tmp_path / "s.h5"
    res = invoke("schedule", small_store, *args, "--out", out)
    assert res.exit_code == 2, res.output
    assert "Traceback" not in res.output
    lines = [ln for ln in res.output.splitlines() if ln.strip()]
    assert len(lines) == 1, res.output
    for name in names:
        assert name in lines[0], (name, lines[0])
    assert not out.exists() and not (tmp_path / "s.h5.work").exists()


def test_the_store_is_not_an_output(small_store):
    res = invoke("schedule", small_store, "--out", small_store)
    assert res.exit_code == 2 and "the store itself" in res.output


def test_the_report_has_the_section(small_store, scheduled, tmp_path):
    """`sweep report` adds variable_geometry.csv/png and its section when STORE.schedule.h5 is
    beside the store; the table's numbers are the results file's (read here with h5py)."""
    import csv
    import shutil

    store = tmp_path / "small.h5"
    shutil.copy(small_store, store)
    shutil.copy(scheduled, tmp_path / "small.schedule.h5")
    res = invoke("report", store, "--out", tmp_path / "report")
    assert res.exit_code == 0, res.output
    out = tmp_path / "report"
    assert (out / "variable_geometry.png").stat().st_size > 0
    md = (out / "report.md").read_text()
    assert "## 7. Variable geometry in the grasp" in md and "Reading, part by part" in md
    rows = list(csv.DictReader(open(out / "variable_geometry.csv")))
    with h5py.File(scheduled, "r") as f:
        assert len(rows) == 2 * f["case"].size
        for row in rows[:4]:
            c = [k for k in range(f["case"].size)
                 if float(f["r"][k]) == float(row["r"]) and float(f["l1"][k]) ==
                 float(row["l1"]) and float(f["l2"][k]) == float(row["l2"])][0]
            o = 0 if row["objective"] == "caging" else 1
            k = int(f["finest_level"][c])
            assert float(row["fixed_area"]) == pytest.approx(f["best_area"][c, o, 0, k],
                                                             rel=1e-5)
            assert float(row["schedule_area"]) == pytest.approx(f["best_area"][c, o, 1, k],
                                                                rel=1e-5)
    # a rerun is a no-op; a new schedule file makes it stale
    res = invoke("report", store, "--out", out)
    assert res.exit_code == 0 and "nothing to do" in res.output, res.output
