"""What the friction report (Scenario C, caging under modulation) claims, each against an
expectation worked out here from its definition (model-notes D33, D34), never against the code's
own output: "draw in, then hold" on two maps whose trajectories are written by hand, the
per-part verdicts and recovered shares of rows chosen here (B gaining over A, C beating B, C
below A, ties at 9 significant digits), the share over all parts with each part's recovery capped
at its own gain, and every count, list and share the reading prints, for one scene and two.

Each test was checked against the bug its docstring names: the bug applied by hand, the test
seen to fail, the change reverted (scripts/mutants.yaml keeps them as mutants).
"""
from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np
import pytest
import xarray as xr

from sweep.compute.maps import draw_in_then_hold
from sweep.model import END_CAGED, END_EJECTION, END_TIP_PREHENSION
from sweep.report import friction


# ---------------------------------------------------------------------------------------------
# Draw in, then hold
# ---------------------------------------------------------------------------------------------
def trajectories(end_state, end_index, caging_score=None):
    """A map as draw_in_then_hold reads it: a 2 x 3 grid, per start point where its trajectory
    ends (flat index) and how, and the caging score of each point."""
    shape = (2, 3)
    fields = dict(end_state=np.array(end_state, np.int8).reshape(shape),
                  end_index=np.array(end_index, np.int64).reshape(shape))
    if caging_score is not None:
        fields["caging_score"] = np.array(caging_score, float).reshape(shape)
    return SimpleNamespace(x=np.array([-0.2, 0.0, 0.2]), y=np.array([0.4, 0.6]), fields=fields)


def test_draw_in_then_hold_scores_where_the_hold_ends():
    """D33: a start counts when its trajectory on the low-friction map ends CAGED at q and the
    trajectory from q on the part's-friction map ends CAGED too; its score is the caging score
    where that second trajectory ends. Written by hand: starts 0 and 5 are drawn in to q = 2,
    and the hold from 2 moves the part on to 5 (score 0.5 there, 0.25 at q); starts 1 and 3 are
    drawn to q = 3, from where the hold ejects the part; start 2 ends in tip prehension, start 4
    is ejected. Lambda = 0.5 + 0.5 from 2 starts. Checked: the score taken at q (where the draw
    ended) instead of where the hold ends fails here (0.5)."""
    c, t, e = END_CAGED, END_TIP_PREHENSION, END_EJECTION
    draw = trajectories([c, c, t, c, e, c], [2, 3, 2, 3, 4, 2])
    hold = trajectories([e, e, c, e, e, c], [0, 1, 5, 4, 4, 5], [0, 0, 0.25, 0, 0, 0.5])
    assert draw_in_then_hold(draw, hold) == (1.0, 2)


# ---------------------------------------------------------------------------------------------
# Per part: A, C, B, the verdict and the recovered share
# ---------------------------------------------------------------------------------------------
#: Per part (one r, mu = 0.1 ... 1.0): A of A's best candidate, C of C's best candidate, B; and C
#: of A's best candidate. The verdict and recovered share each worked by hand from D34.
PARTS = [
    # a,   c,             b,   c of A's best, verdict,           recovered
    (1.0, 1.5, 3.0, 1.25, "C recovers part", 0.25),
    (1.0, 5.0, 2.0, 1.0, "C beats B", 4.0),
    (2.0, 4.0, 4.0, 2.5, "C matches B", 1.0),
    (3.0, 3.0, 4.0, 3.0, "C adds nothing", 0.0),
    (1.0, 1.0000000001, 3.0, 1.0, "C adds nothing", 0.5e-10),    # C = A at 9 digits
    (2.0, 1.0, 3.0, 2.0, "C adds nothing", -1.0),       # C's best gripper below A's here
    (2.0, 3.0, 2.0, 2.5, "C gains, B not", math.nan),
    (2.0, 2.0, 1.0, 2.0, "neither gains", math.nan),
    (2.0, 1.0, 2.0000000001, 2.0, "neither gains", math.nan),  # B = A at 9 digits, C below
    (2.0, 1.0, 1.0, 2.0, "neither gains", math.nan),     # C below A, B no gain
]
MU = [0.1 * (k + 1) for k in range(len(PARTS))]
#: Shares of B's gain recovered, capped per part at its own gain, over the 6 parts where B gains:
#: (0.5 + min(4, 1) + 2 + 0 + 1e-10 + max(-1, 0)) / (2 + 1 + 2 + 1 + 2 + 1).
SHARE = (0.5 + 1.0 + 2.0 + 0.0 + 1e-10 + 0.0) / 9.0


def fake_store(effects_on="friction", name="chosen"):
    """What friction_rows and the reading read of a store: two candidates (l1 = 1.2: A's best,
    l1 = 1.6: C's best), one r, the parts' mu; manipulation_a, _c per candidate and part, _b per
    part, from PARTS."""
    shape = (2, 1, 1, 1, 1, len(PARTS))
    a, c = np.zeros(shape), np.zeros(shape)
    for k, (va, vc, _, vca, _, _) in enumerate(PARTS):
        a[0, 0, 0, 0, 0, k] = va
        a[1, 0, 0, 0, 0, k] = 0.5 * va
        c[0, 0, 0, 0, 0, k] = vca
        c[1, 0, 0, 0, 0, k] = vc
    dims = ("l1", "l2", "r1", "r2", "r", "mu")
    ds = xr.Dataset({"manipulation_a": (dims, a), "manipulation_c": (dims, c),
                     "manipulation_b": (("r", "mu"), np.array([[p[2] for p in PARTS]]))},
                    coords=dict(l1=[1.2, 1.6], l2=[0.8], r1=[0.1], r2=[0.1], r=[1.0], mu=MU))
    return SimpleNamespace(ds=ds, r=ds.r.values, mu=ds.mu.values, mu_low=0.0,
                           parts=lambda: [(0, k) for k in range(len(PARTS))],
                           attrs=dict(effects_on=effects_on, name=name))


A_BEST = dict(index=(0, 0, 0, 0), l1=1.2, l2=0.8, r1=0.1, r2=0.1, R=1.0, best=True)
C_BEST = dict(index=(1, 0, 0, 0), l1=1.6, l2=0.8, r1=0.1, r2=0.1, R=1.0, best=True)


def test_each_part_gets_its_verdict_and_recovered_share():
    """D34, per part: B gains over A when B > A; then C matches B (C = B), beats it (C > B),
    recovers part (A < C < B) or adds nothing (C = A, and C below A: C's best candidate is
    another gripper, which here does worse than A's; no share of B's gain is recovered); where B
    does not gain, C gains (C > A) or neither does. Equality at 9 significant digits.
    recovered = (C - A) / (B - A) where B gains, NaN elsewhere. Checked: C below A called a
    partial recovery, or a gain where B does not gain (the verdict before it was fixed), B's
    gain tested without the tie rule, and the recovered share taken over (C - A) / B each fail
    here."""
    rows = friction.friction_rows(fake_store(), A_BEST, C_BEST)
    assert [(r["mu"], r["a"], r["c"], r["b"], r["c_of_a_best"]) for r in rows] == [
        (mu, a, c, b, ca) for mu, (a, c, b, ca, _, _) in zip(MU, PARTS)]
    for row, (a, c, b, _, verdict, recovered) in zip(rows, PARTS):
        assert row["verdict"] == verdict, (row, verdict)
        assert row["c_gain"] == c - a and row["b_gain"] == b - a
        if math.isnan(recovered):
            assert math.isnan(row["recovered"])
        else:
            assert row["recovered"] == pytest.approx(recovered, rel=1e-6, abs=1e-15)


def test_the_share_over_parts_caps_each_part_at_its_own_gain():
    """D34: over the parts where B gains, the sum of min(max(C - A, 0), B - A) over the sum of
    B - A: a part where C beats B (4 against a gain of 1) covers no other, and one where C's
    best is below A (-1) takes nothing away. Worked by hand: 3.5 / 9. Checked: no cap
    (6.5 / 9), no floor at 0 (2.5 / 9), and the parts where B does not gain counted in the
    denominator each fail here."""
    rows = friction.friction_rows(fake_store(), A_BEST, C_BEST)
    assert friction.recovered_share(rows) == pytest.approx(SHARE, rel=1e-12)
    assert friction.share_text(rows) == "C recovers 38.8889 % of B's gain over A"
    none = [r for r in rows if r["verdict"] in friction.WHERE_B_DOES_NOT]
    assert math.isnan(friction.recovered_share(none))
    assert friction.share_text(none) == "B gains over A on no part (nothing to recover)"


# ---------------------------------------------------------------------------------------------
# The reading, one scene and two
# ---------------------------------------------------------------------------------------------
#: Caging under modulation per part (areas): draw in then hold above holding on mu on parts 1
#: and 2, below on part 3, the same on the rest; reaching the part's best area on parts 2 and 4.
CAGING = [dict(area_s=1.0, area_low=0.5, area_dh=1.5, best_area=2.0),
          dict(area_s=1.0, area_low=0.25, area_dh=2.0, best_area=2.0),
          dict(area_s=1.0, area_low=0.0, area_dh=0.5, best_area=2.0),
          dict(area_s=3.0, area_low=0.0, area_dh=3.0, best_area=3.0000000001)]


def report_of(st):
    rows = friction.friction_rows(st, A_BEST, C_BEST)
    caging = [dict(r=1.0, mu=mu, **c) for mu, c in zip(MU, CAGING)]
    return SimpleNamespace(friction=rows, modulation=caging, friction_candidates=[C_BEST],
                           candidates=[A_BEST])


def test_the_reading_counts_lists_and_shares_each_kind_of_part():
    """The reading of experiment 5 on the chosen parts: the sums of A, C and B; B gains on 6
    parts, of which C reaches or passes B on 2 (mu = 0.2, 0.3), recovers part on 1 (0.1, 25 %),
    adds nothing on 3; where B does not gain (4 parts) C adds on 1 (0.7); the crossed-fingers
    note in a scene whose fingers may cross only; caging under modulation better on 2, worse on
    1, reaching the best area on 2 (0.2, and 0.4 at 9 digits), with the four sums. Every
    number worked by hand. Checked: the partial recoveries listed from the parts where C beats
    B, the "less" list drawn from the "more" one, and the share uncapped each fail here."""
    st = fake_store()
    text = "\n".join(friction.reading(st, report_of(st)))
    sums = [sum(p[k] for p in PARTS) for k in range(3)]
    assert (f"Summed over the 10 parts: A = {sums[0]:.6g}, C = {sums[1]:.6g}, B = "
            f"{sums[2]:.6g}.") in text
    assert ("Variable geometry (B) gains over one gripper (A) on 6 parts; switching friction "
            "recovers 38.8889 % of that gain (each part's share capped at its own gain).") in text
    assert ("- Switching friction is an alternative to variable geometry for 2 of those 6 parts,"
            " where C reaches or passes B: r = 1, mu = 0.3; r = 1, mu = 0.2. It is a partial "
            "one for 1: r = 1, mu = 0.1 (25 %). It is no alternative for 3, where it adds "
            "nothing to A: r = 1, mu = 0.4; r = 1, mu = 0.5; r = 1, mu = 0.6.") in text
    assert "- Where B does not gain over A (4 parts), switching friction adds on 1: r = 1, " \
           "mu = 0.7." in text
    assert "poses with crossed fingers count with S_geo = 1" in text
    assert ("cages more than holding on μ throughout on 2 of 4 parts (r = 1, mu = 0.1; r = 1, "
            "mu = 0.2), less on 1 (r = 1, mu = 0.3); it reaches the largest caging area of any "
            "geometry on 2 parts (r = 1, mu = 0.2; r = 1, mu = 0.4). Caging areas summed over "
            "parts: on μ 6, on μ_low 0.75, draw in then hold 7, the largest of any geometry per "
            "part 9.") in text
    st = fake_store(effects_on="friction finger_collision")
    assert "crossed fingers" not in "\n".join(friction.reading(st, report_of(st)))


def test_the_two_scene_reading_names_each_scenes_kinds_and_the_parts_that_differ():
    """pair_reading: per scene its share, the parts where C is an alternative (matches or beats
    B), a partial one, none; draw in then hold against holding on μ summed; then the parts whose
    verdict differs between the scenes. Scene 2 here is scene 1 with B raised on the first part
    (3 -> 9: still a partial recovery, share lower) and lowered on the second (2 -> 0.5: B no
    longer gains there, C gains). Checked: the differing parts counted from equal verdicts fails
    here."""
    st1 = fake_store(name="one")
    st2 = fake_store(effects_on="friction finger_collision", name="two")
    st2.ds["manipulation_b"][0, 0] = 9.0
    st2.ds["manipulation_b"][0, 1] = 0.5
    rep1, rep2 = report_of(st1), report_of(st2)
    assert [r["verdict"] for r in rep2.friction[:2]] == ["C recovers part", "C gains, B not"]
    rep = SimpleNamespace(friction_scenes=(rep1.friction, rep2.friction),
                          modulation_scenes=(rep1.modulation, rep2.modulation),
                          friction=friction.pair_rows(rep1.friction, rep2.friction))
    lines = friction.pair_reading(st1, st2, rep)
    share2 = (0.5 + 2.0 + 1e-10) / (8.0 + 2.0 + 1.0 + 2.0 + 1.0)
    assert lines[0].startswith("- Friction modulation, scene 1 (one): C recovers 38.8889 % of "
                               "B's gain over A; an alternative to variable geometry on 2 parts "
                               "(r = 1, mu = 0.2; r = 1, mu = 0.3), partly on 1 (r = 1, "
                               "mu = 0.1), not at all on 3")
    assert lines[1].startswith(f"- Friction modulation, scene 2 (two): C recovers "
                               f"{100 * share2:.6g} % of B's gain over A; an alternative to "
                               f"variable geometry on 1 parts (r = 1, mu = 0.3), partly on 1")
    assert "draw in then hold cages 7 against 6 on μ (summed caging areas)." in lines[0]
    assert lines[2] == "- The verdict differs between the scenes on 1 of 10 parts: r = 1, mu = 0.2."


def test_the_reading_where_variable_geometry_gains_nowhere():
    """Only the parts where B does not gain and C adds nothing (the last three of PARTS): no
    share is claimed, no list of alternatives, and "adds on 0" names no part. Checked: the
    share sentence printed with no part gaining fails here."""
    st = fake_store()
    rep = report_of(st)
    rep.friction = [r for r in rep.friction if r["verdict"] == "neither gains"]
    text = "\n".join(friction.reading(st, rep))
    assert "Variable geometry (B) gains over one gripper (A) on 0 parts." in text
    assert "recovers" not in text and "alternative" not in text
    assert "- Where B does not gain over A (3 parts), switching friction adds on 0." in text


def test_the_reading_where_variable_geometry_gains_on_every_part():
    """Only the six parts where B gains: the share and the kinds as before, and no sentence on
    parts where B does not gain."""
    st = fake_store()
    rep = report_of(st)
    rep.friction = [r for r in rep.friction if r["verdict"] in friction.WHERE_B_GAINS]
    text = "\n".join(friction.reading(st, rep))
    assert ("gains over one gripper (A) on 6 parts; switching friction recovers 38.8889 % of "
            "that gain") in text
    assert "Where B does not gain" not in text
