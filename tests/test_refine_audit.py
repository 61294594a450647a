"""The refinement's certificate rests on computations of the designs it speaks about (model-notes
D37, step 4 of sweep/runs/refine.py): a part whose contenders the screening inflated more than a
design it left out.

The maps' caging areas are a synthetic table, not computed: `batch.caging_areas` is replaced by a
lookup. Each class d has a converged value T[d] and a screened value S[d]; at level k its value is
T[d] + (S[d] - T[d]) / 4**k (the error falls by 4 per halving). The three classes screened
highest (9.0, the winner's curse) converge to 5.0; a class screened at 6.5, below the contender
cut, converges to 6.0 and is the true best; the rest sit lower with mild biases of either sign.

The refinement before the audit bounded a left-out class's change by the largest change of a
contender (here a fall of about 3.75), so it left the 6.5 class out and certified a class whose
converged value is 5.0. With the audit, a sample of the left-out classes is recomputed; the true
best is either sampled or bounded by the sample's rise, re-admitted, and certified.
Checked by hand on main at 9ccc20e (`PYTHONPATH=<that tree> pytest tests/test_refine_audit.py`):
`test_the_design_left_out_is_found` fails there (the certified best is a class converging to 5.0).
"""
from __future__ import annotations

import numpy as np
import pytest
import yaml

from sweep.config.parse import load_scene
from sweep.config.scene import RefineSettings
from sweep.runs import refine as rf

#: 4 x 4 x 4 = 64 designs of distinct R (one class each), one part.
CONFIG = dict(
    name="audit-synthetic",
    designs=dict(l1=[1.4, 1.6, 1.8, 2.0], l2=[1.6], r1=[0.2],
                 r2=[0.02, 0.06, 0.1, 0.14], w=[0.0, 0.4, 0.8, 1.2]),
    parts=dict(r=[0.4], mu=[0.1]),
    grid=dict(h=0.2),
)
SETTINGS = RefineSettings(levels=3, bound=0.2, min_contenders=3)


def synthetic_part(n: int, seed: int = 3):
    """(screened S, converged T) of n classes: the first three inflated (9.0 -> 5.0), class 10
    left out and best (6.5 -> 6.0), the others spread below with biases within +-10 %."""
    rng = np.random.default_rng(seed)
    truth = rng.uniform(0.5, 5.4, n)
    screened = truth * rng.uniform(0.9, 1.1, n)
    screened[:3], truth[:3] = 9.0, 5.0
    screened[10], truth[10] = 6.5, 6.0
    return screened, truth


@pytest.fixture(scope="module")
def scene(tmp_path_factory):
    path = tmp_path_factory.mktemp("audit") / "audit.yaml"
    path.write_text(yaml.safe_dump(CONFIG))
    return load_scene(path)


def refine_synthetic(scene, tmp_path, monkeypatch, screened, truth):
    def table(scene_, designs, parts, keys, h):
        k = int(round(np.log2(scene.h / h)))
        d = keys[:, 1]
        return truth[d] + (screened[d] - truth[d]) / 4.0 ** k

    monkeypatch.setattr(rf, "caging_areas", table)
    return rf.refine_designs(scene, rf.design_table(scene), screened.reshape(-1, 1), SETTINGS,
                             tmp_path / "work")


def test_the_design_left_out_is_found(scene, tmp_path, monkeypatch):
    screened, truth = synthetic_part(64)
    ref = refine_synthetic(scene, tmp_path, monkeypatch, screened, truth)
    best = set(np.flatnonzero(ref.role[:, 0] == rf.ROLE["best"]).tolist())
    assert best == {10}, (best, truth[sorted(best)])


def test_the_audit_is_recorded(scene, tmp_path, monkeypatch):
    """The store's account of the certificate: how many left-out designs were recomputed, at
    which level, and their largest rise (here each sampled class's own (T - S) / max(S, 9/4))."""
    screened, truth = synthetic_part(64)
    ref = refine_synthetic(scene, tmp_path, monkeypatch, screened, truth)
    audited = np.flatnonzero(ref.role[:, 0] == rf.ROLE["audited"])
    readmitted = np.flatnonzero(ref.readmitted[:, 0])
    n_sampled = audited.size + np.intersect1d(readmitted, np.arange(3, 64)).size
    assert 0 < ref.audit_designs[0] <= n_sampled
    assert ref.audit_level[0] == ref.finest_level[0]
    k = int(ref.finest_level[0])
    at_k = truth[audited] + (screened[audited] - truth[audited]) / 4.0 ** k
    want = max(0.0, np.max((at_k - screened[audited]) / np.maximum(screened[audited], 9.0 / 4)))
    assert ref.audit_rise[0] >= want - 1e-12


def test_sample_is_stratified_and_seeded():
    """Each stratum gives its quota (all its classes where it has fewer), the draw depends only
    on the seed, and nothing outside the classes offered is drawn."""
    left_out = np.arange(100, 160)
    screened = np.zeros(200)
    screened[100:110] = np.linspace(6.5, 8.9, 10)     # >= 0.6 x 10: top stratum, 10 classes
    screened[110:113] = [3.5, 4.0, 5.0]               # [0.3, 0.6): 3 classes
    screened[113:160] = np.linspace(0.0, 2.9, 47)     # below 0.3
    from sweep.runs import certificate as cert

    a = cert.audit_sample(left_out, screened, 10.0, seed=7)
    b = cert.audit_sample(left_out, screened, 10.0, seed=7)
    assert np.array_equal(a, b)
    quotas = dict(cert.AUDIT_STRATA)
    assert np.sum((a >= 100) & (a < 110)) == quotas[0.6]
    assert set(range(110, 113)) <= set(a.tolist())
    assert np.sum(a >= 113) == quotas[0.0]
    assert set(a.tolist()) <= set(left_out.tolist())


@pytest.mark.parametrize("change, before, want", [
    (0.1, float("nan"), 0.1),      # one change: itself
    (0.1, 0.2, 0.1),               # halved: itself
    (0.15, 0.2, 0.45),             # ratio 3/4: 0.15 x 0.75 / 0.25
    (0.2, 0.2, 0.4),               # not shrinking: the sum of the two
    (0.3, 0.1, 0.4),
])
def test_error_estimate_by_hand(change, before, want):
    from sweep.runs import certificate as cert

    assert cert.error_estimate(change, before) == pytest.approx(want, rel=1e-12)


def test_a_design_left_out_and_unaudited_comes_back_by_the_audits_rise(scene, tmp_path,
                                                                      monkeypatch):
    """With a sample of one class per stratum the true best (class 10) is not audited; the
    audited classes' largest relative rise, applied to its screened 6.5, reaches the best's
    interval, so it is re-admitted by the bound, not by its own value (model-notes D37)."""
    from sweep.runs import certificate as cert

    monkeypatch.setattr(cert, "AUDIT_STRATA", ((0.6, 1), (0.3, 1), (0.0, 1)))
    monkeypatch.setattr(rf, "audit_sample", cert.audit_sample)
    screened, truth = synthetic_part(64)
    truth[3:] = np.where(np.arange(3, 64) == 10, truth[3:], screened[3:] * 1.2)   # all rise
    truth[10] = 9.5                                               # ... and 10 most
    ref = refine_synthetic(scene, tmp_path, monkeypatch, screened, truth)
    assert ref.role[10, 0] == rf.ROLE["best"] and ref.readmitted[10, 0]
    assert ref.audit_rise[0] > 0.0
