"""Which classes each refinement level computes and eliminates, worked by hand (model-notes D18,
D28; docs/sweeps.md, "Refinement").

The maps' caging areas are a table written here, not computed: `batch.caging_areas` is replaced
by a lookup of (part, design, level), and every call of a level is recorded with its label, so
each test pins, per level, which classes are computed (the leader first, then the rest), which
are eliminated without being computed, and what the refinement concludes. The numbers are chosen
so that each rule decides by a clear margin (0.01 or more), never by a rounding of the last bit;
the comments work each step by hand.

One part, six classes A..F (designs of distinct R = r2/r1, one per class, in store order), so a
class is its design index: A = 0, ..., F = 5.
"""
from __future__ import annotations

import numpy as np
import pytest
import yaml

from sweep.config.parse import load_scene
from sweep.config.scene import RefineSettings
from sweep.runs import refine as rf
from sweep.storage.refined import ROLE, STATUS

A, B, C, D, E, F = range(6)
NAMES = "ABCDEF"
CONFIG = dict(
    name="refine-by-hand",
    designs=dict(l1=[2.0], l2=[1.6], r1=[0.2], r2=[0.04, 0.06, 0.08, 0.1, 0.12, 0.14], w=[0.4]),
    parts=dict(r=[0.4], mu=[0.4]),
    grid=dict(h=0.2),
)


@pytest.fixture(scope="module")
def scene(tmp_path_factory):
    path = tmp_path_factory.mktemp("by-hand") / "by-hand.yaml"
    path.write_text(yaml.safe_dump(CONFIG))
    return load_scene(path)


def refine_by_table(scene, tmp_path, monkeypatch, screened: dict, levels: dict,
                    settings: RefineSettings):
    """Refine one part whose caging areas are `screened` {class: value} and `levels` {level:
    {class: value}}. Returns (the Refinement, {label: set of class names computed})."""
    values = np.zeros((len(NAMES), 1))
    for d, v in screened.items():
        values[d, 0] = v

    def table(scene_, designs, parts, keys, h):
        level = int(round(np.log2(scene.h / h)))
        missing = [NAMES[d] for _, d in keys if d not in levels.get(level, {})]
        assert not missing, f"level {level} computes {missing}, which the hand-worked case does not"
        return np.array([levels[level][d] for _, d in keys], dtype=np.float64)

    calls: dict = {}
    real = rf._run_level

    def recorded(scene_, designs, parts, keys, h, label, work, progress):
        assert label not in calls, f"level {label} run twice"
        calls[label] = {NAMES[d] for _, d in keys.tolist()}
        return real(scene_, designs, parts, keys, h, label, work, progress)

    monkeypatch.setattr(rf, "caging_areas", table)
    monkeypatch.setattr(rf, "_run_level", recorded)
    ref = rf.refine_scene(scene, values, settings, tmp_path / "work")
    return ref, {k: v for k, v in calls.items() if v}


def per_class(ref, array) -> dict:
    return {NAMES[d]: array[d, 0] for d in range(len(NAMES))}


def test_leader_first_by_hand(scene, tmp_path, monkeypatch):
    """Level 1: the floor {A, B} at h/2 changes by at most D = 0.2, so the cut is 9.8 - 3 D =
    9.2: C and D contend, E and F do not. Separated at level 1 (best A 9.8 +- 0.2, low 9.6): B
    (9.7 + 0.2) and C (9.6 + 0.1) stay, D (8.9 + 0.4 = 9.3) is eliminated.
    Level 2, leader first: A 9.76, its change 0.04 at most half its last (0.2): +- 0.04 (low
    9.72); B's last interval reaches 9.9, so B is computed; C's reaches only 9.70: eliminated
    without being computed at h/4. B 9.65 +- 0.05 (up to 9.70 < 9.72) is separated: A alone,
    its changes shrinking: certified at h/4; no level 3.
    Audit (D37): the best screened is 10, so E (6.0, >= 0.6 x 10) is the top stratum's only
    class and F (3.0) the middle one's: both are recomputed at h/2 and h/4. E 5.85 +- 0.05 and
    F 2.85 are far below 9.72 and both fell (rise 0): nothing re-admitted."""
    ref, calls = refine_by_table(
        scene, tmp_path, monkeypatch,
        screened={A: 10.0, B: 9.9, C: 9.5, D: 9.3, E: 6.0, F: 3.0},
        levels={1: {A: 9.8, B: 9.7, C: 9.6, D: 8.9, E: 5.9, F: 2.9},
                2: {A: 9.76, B: 9.65, E: 5.85, F: 2.85}},
        settings=RefineSettings(levels=3, bound=0.5, min_contenders=2))
    assert calls == {"1a": {"A", "B"}, "1b": {"C", "D"}, "2a": {"A"}, "2b": {"B"},
                     "a1-1": {"E", "F"}, "a1-2": {"E", "F"}}
    assert per_class(ref, ref.level) == dict(A=2, B=2, C=1, D=1, E=2, F=2)
    assert per_class(ref, ref.role) == dict(A=ROLE["best"], B=ROLE["eliminated"],
                                            C=ROLE["eliminated"], D=ROLE["eliminated"],
                                            E=ROLE["audited"], F=ROLE["audited"])
    value, error = per_class(ref, ref.value), per_class(ref, ref.error)
    assert [value[k] for k in "ABCDEF"] == pytest.approx([9.76, 9.65, 9.6, 8.9, 5.85, 2.85])
    assert [error[k] for k in "ABCDEF"] == pytest.approx([0.04, 0.05, 0.1, 0.4, 0.05, 0.05])
    assert ref.status[0] == STATUS["certified"] and ref.finest_level[0] == 2
    assert ref.margin[0] == pytest.approx(9.76 - 9.65)
    assert ref.bound_used[0] == pytest.approx(1 - 9.2 / 10.0)
    assert ref.n_contenders[0] == 4 and ref.bound_held[0]
    assert ref.widenings[0] == 0 and ref.n_readmitted[0] == 0 and not ref.readmitted.any()
    assert ref.bound_widened[0] == ref.bound_used[0]
    assert ref.audit_designs[0] == 2 and ref.audit_level[0] == 2 and ref.audit_rise[0] == 0.0
    assert ref.level_maps == [6, 4] and ref.widen_maps == 0


def test_collapsed_leader_re_admits_by_hand(scene, tmp_path, monkeypatch):
    """The case of configs/small.yaml at r = 0.8 in miniature: the leader's interval at h/2
    eliminates a class, then the leader collapses by far more than its error estimate.
    Level 1: floor {A, B}, D = 0.4, cut 6.6 - 1.2 = 5.4: C contends, D and E do not. A 6.6 +- 0.4
    (low 6.2): B (6.0 + 0.3) stays, C (5.5 + 0.25 = 5.75) is eliminated.
    Level 2: A 4.7, its change 1.9 larger than its last 0.4: +- 2.3 (low 2.4); B 4.3 +- 2.0,
    both stay. Level 3: A 4.2 +- 0.5 (low 3.7), B 3.65 +- 0.65 (up to 4.3): a near-tie {A, B}
    at the cap.
    Audit (best screened 7): D (5.2) and E (4.6) are the top stratum (>= 4.2), F (1.0) the
    bottom one: all three recomputed at h/2, h/4, h/8. D 4.35 (changes 0.3, 0.25, 0.3: not
    shrinking, +- 0.55) and E 3.3 (0.2, 0.6, 0.5: ratio 5/6, +- 2.5) reach A's low 3.7, and C,
    eliminated at h/2 with 5.5 + 0.25, does too: round 1 re-admits C, D, E and computes C at h/4
    and h/8. At h/8 C leads, 4.75 (changes 0.25, 0.6, 0.15: +- 0.15, low 4.6): A (4.2 + 0.5), D
    (4.9) and E (5.8) stay, B (4.3) is eliminated. Round 2: F 0.83 is far below 4.6."""
    ref, calls = refine_by_table(
        scene, tmp_path, monkeypatch,
        screened={A: 7.0, B: 6.3, C: 5.75, D: 5.2, E: 4.6, F: 1.0},
        levels={1: {A: 6.6, B: 6.0, C: 5.5, D: 4.9, E: 4.4, F: 0.9},
                2: {A: 4.7, B: 4.3, C: 4.9, D: 4.65, E: 3.8, F: 0.85},
                3: {A: 4.2, B: 3.65, C: 4.75, D: 4.35, E: 3.3, F: 0.83}},
        settings=RefineSettings(levels=3, bound=0.5, min_contenders=2))
    assert calls == {"1a": {"A", "B"}, "1b": {"C"}, "2a": {"A"}, "2b": {"B"}, "3a": {"A"},
                     "3b": {"B"}, "a1-1": {"D", "E", "F"}, "a1-2": {"D", "E", "F"},
                     "a1-3": {"D", "E", "F"}, "w1-2": {"C"}, "w1-3": {"C"}}
    assert per_class(ref, ref.role) == dict(A=ROLE["near_tie"], B=ROLE["eliminated"],
                                            C=ROLE["best"], D=ROLE["near_tie"],
                                            E=ROLE["near_tie"], F=ROLE["audited"])
    assert per_class(ref, ref.readmitted) == dict(A=False, B=False, C=True, D=True, E=True,
                                                  F=False)
    assert per_class(ref, ref.level) == dict(A=3, B=3, C=3, D=3, E=3, F=3)
    error = per_class(ref, ref.error)
    assert [error[k] for k in "ABCDE"] == pytest.approx([0.5, 0.65, 0.15, 0.55, 2.5])
    assert ref.status[0] == STATUS["near_tie"] and ref.finest_level[0] == 3
    assert ref.margin[0] == pytest.approx(4.75 - 4.35)
    assert ref.widenings[0] == 1 and ref.n_readmitted[0] == 3 and ref.n_contenders[0] == 5
    assert ref.bound_held[0] and ref.audit_designs[0] == 1
    assert ref.bound_used[0] == pytest.approx(1 - 5.4 / 7.0)
    # D and E came back by their own audited values: the contender cut did not move
    assert ref.bound_widened[0] == pytest.approx(ref.bound_used[0])
    assert ref.level_maps == [6, 6, 6] and ref.widen_maps == 2


def test_re_admitted_class_reopens_the_levels_by_hand(scene, tmp_path, monkeypatch):
    """A part certified at h/2 whose leader rose by more than the cap allows for: bound 0.1
    (cut 9.0) leaves C (8.8) out; A 11.5 +- 1.5 (low 10.0) eliminates B (8.0 + 1.5): certified
    at h/2. Audit (best screened 10): C and D (>= 6) and E, F (< 3) are recomputed at h/2; C
    10.5 +- 1.7 reaches 10.0 and is re-admitted, still in the running, so the part goes on
    below the cap, leader first: A 11.4 +- 0.1 (low 11.3) at h/4, C computed (its last interval
    reaches 12.2), 10.6 +- 0.1: eliminated, A certified at h/4. Round 2: the audit follows to
    h/4 (D, E, F); D 8.05 +- 0.05 and the others are far below 11.3, B (9.5) too: the bound
    holds."""
    ref, calls = refine_by_table(
        scene, tmp_path, monkeypatch,
        screened={A: 10.0, B: 9.5, C: 8.8, D: 8.0, E: 2.0, F: 1.0},
        levels={1: {A: 11.5, B: 8.0, C: 10.5, D: 8.1, E: 2.1, F: 1.05},
                2: {A: 11.4, C: 10.6, D: 8.05, E: 2.05, F: 1.02}},
        settings=RefineSettings(levels=3, bound=0.1, min_contenders=2))
    assert calls == {"1a": {"A", "B"}, "a1-1": {"C", "D", "E", "F"}, "w1-2a": {"A"},
                     "w1-2b": {"C"}, "a2-2": {"D", "E", "F"}}
    assert per_class(ref, ref.level) == dict(A=2, B=1, C=2, D=2, E=2, F=2)
    assert per_class(ref, ref.role) == dict(A=ROLE["best"], B=ROLE["eliminated"],
                                            C=ROLE["eliminated"], D=ROLE["audited"],
                                            E=ROLE["audited"], F=ROLE["audited"])
    assert ref.status[0] == STATUS["certified"] and ref.finest_level[0] == 2
    assert ref.margin[0] == pytest.approx(11.4 - 10.6)
    assert ref.widenings[0] == 1 and ref.n_readmitted[0] == 1 and ref.n_contenders[0] == 3
    assert ref.bound_used[0] == pytest.approx(0.1)
    assert ref.bound_widened[0] == pytest.approx(0.1)      # C came back audited
    assert ref.audit_designs[0] == 3 and ref.audit_level[0] == 2
    assert ref.level_maps == [6, 5] and ref.widen_maps == 2


def test_a_best_whose_changes_grow_goes_one_level_further_by_hand(scene, tmp_path, monkeypatch):
    """model-notes D37: a part is certified only when its best's changes shrink. Level 1: floor
    {A, B}, D = 1.0, cut 9.0 - 3.0 = 6.0 (C .. F do not contend). A 9.0 +- 1.0 (low 8.0), B
    7.5 +- 0.5 reaches 8.0 and stays. Level 2, leader first: A 10.5, its change 1.5 larger than
    its last 1.0: +- 2.5 (low 8.0); B's last interval reaches 8.0, so B is computed: 7.4, its
    change 0.1 at most half its last: +- 0.1, up to 7.5: eliminated. A is alone but its changes
    grew: the part goes on, A alone at h/8: 10.4 +- 0.1, certified there. The audit (C, D in
    [3, 6), E, F below) all fall: nothing re-admitted."""
    ref, calls = refine_by_table(
        scene, tmp_path, monkeypatch,
        screened={A: 10.0, B: 8.0, C: 5.0, D: 4.0, E: 2.0, F: 1.0},
        levels={1: {A: 9.0, B: 7.5, C: 4.9, D: 3.9, E: 1.9, F: 0.9},
                2: {A: 10.5, B: 7.4, C: 4.85, D: 3.85, E: 1.85, F: 0.85},
                3: {A: 10.4, C: 4.84, D: 3.84, E: 1.84, F: 0.84}},
        settings=RefineSettings(levels=3, bound=0.5, min_contenders=2))
    assert calls == {"1a": {"A", "B"}, "2a": {"A"}, "2b": {"B"}, "3a": {"A"},
                     "a1-1": {"C", "D", "E", "F"}, "a1-2": {"C", "D", "E", "F"},
                     "a1-3": {"C", "D", "E", "F"}}
    assert ref.status[0] == STATUS["certified"] and ref.finest_level[0] == 3
    error = per_class(ref, ref.error)
    assert error["A"] == pytest.approx(0.1) and error["B"] == pytest.approx(0.1)
    assert ref.audit_rise[0] == 0.0 and not ref.readmitted.any()
