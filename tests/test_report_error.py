"""The reports' numerical error of the screening (sweep/report/data.py, screening_error): read
from a refined store's screened and refined caging areas by the refinement's roles, on a
synthetic part worked by hand (docs/accuracy.md's rule: 5 % and 15 % relatively, or absolutely
against 1 % of the part's best refined value for values below it)."""
from __future__ import annotations

import math
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import xarray as xr

from sweep.report.data import StoreData, screening_error, screening_error_text
from sweep.storage.refined import ROLE

DIMS = ("l1", "l2", "r1", "r2", "w", "r", "mu")
COORDS = dict(l1=[2.0], l2=[1.6], r1=[0.2], r2=[0.1], w=[0.0, 0.4, 0.8, 1.2, 1.6], r=[0.4],
              mu=[0.1])
#: per width: role, screened caging area, refined caging area (NaN: not recomputed)
PART = (("best", 10.6, 10.0),          # 6 % above: within 15 % only
        ("audited", 2.05, 2.0),        # 2.5 %
        ("audited", 1.8, 2.0),         # 10 %: within 15 % only
        ("audited", 0.05, 0.02),       # below 1 % of the best (0.1): |0.03| < 0.1, within
        ("screened", 7.0, math.nan))   # not recomputed: not counted


def store(part=PART) -> StoreData:
    shape = tuple(len(COORDS[d]) for d in DIMS)
    role = np.array([ROLE[p[0]] for p in part], dtype=np.int8).reshape(shape)
    screened = np.array([p[1] for p in part]).reshape(shape)
    refined = np.array([p[2] for p in part]).reshape(shape)
    ds = xr.Dataset(dict(refine_role=(DIMS, role), caging_area=(DIMS, screened),
                         refined_caging_area=(DIMS, refined),
                         refine_status=(("r", "mu"), np.zeros((1, 1), dtype=np.int8))),
                    coords=COORDS)
    return StoreData(Path("synthetic.h5"), ds, SimpleNamespace(h=0.05), {}, manipulation=False)


def test_the_error_is_counted_by_role_with_the_rule_for_small_values():
    audited, contenders = screening_error(store())
    assert (audited["group"], audited["n"], audited["within5"], audited["within15"]) == \
        ("audited", 3, 2, 3)
    assert math.isclose(audited["median"], 0.1)        # of 0.025, 0.1 and 0.03 / 0.1
    assert (contenders["n"], contenders["within5"], contenders["within15"]) == (1, 0, 1)
    assert math.isclose(contenders["median"], 0.06)


def test_the_sentence_follows_the_store():
    before = screening_error_text(store())
    assert "audited: 2 of 3 within 5 %" in before and "contenders: 0 of 1 within 5 %" in before
    moved = list(PART)
    moved[2] = ("audited", 2.02, 2.0)                   # now 1 %: within 5 %
    after = screening_error_text(store(tuple(moved)))
    assert "audited: 3 of 3 within 5 %" in after


def test_a_store_that_is_not_refined_has_no_estimate():
    st = store()
    unrefined = StoreData(Path("x.h5"), st.ds.drop_vars("refine_status"), SimpleNamespace(h=0.05),
                          {}, manipulation=False)
    assert screening_error(unrefined) == [] and screening_error_text(unrefined) == ""
