"""What the friction report (Scenario C) claims per part, against its definition (model-notes
D34), never against the code's own output: the verdicts and recovered shares of rows chosen here
(B gaining over A, C beating B, C below A, ties at 9 significant digits).
"""
from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np
import pytest
import xarray as xr

from sweep.report import friction


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
