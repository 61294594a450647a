"""Every derived variable of a results store, and every summary attribute of a map file, checked
against the identity that derives it from the quantities stored beside it.

A one-machine store and a merged one come from the same writer, so comparing them cannot see a
variable written with the wrong weight (an area metric times h instead of h^2, say). Here each
derived variable is recomputed from its source variables in the file, read with xarray, and the
rest (primary quantities) are held to the bounds their definitions imply. The store covers every
output a store can hold: caging (the summaries), the manipulation metric, a summary field of an
effect (finger_collision) and the refinement; both the one-machine and the merged store are
checked. `test_every_store_variable_is_checked` keeps the table complete: a new store variable
fails it until it is given its identity or its bounds here.
"""
from __future__ import annotations

import itertools
from pathlib import Path

import numpy as np
import pytest
import xarray as xr
import yaml
from click.testing import CliRunner

from sweep.cli import main as cli

DATA = Path(__file__).parent / "data"
DESIGN = ("l1", "l2", "r1", "r2", "w")
#: Sums of the same numbers in another order, products rounded in another order.
REL = 1e-12


def invoke(*args):
    return CliRunner().invoke(cli, [str(a) for a in args])


@pytest.fixture(scope="module")
def stores(tmp_path_factory):
    """The tiny manipulation sweep refined, on one machine and as two chunks merged (fingers may
    cross: Scenario A is positive, and B differs from B without crossed fingers), and with
    finger_collision (its summary field)."""
    root = tmp_path_factory.mktemp("derived")
    cfg = yaml.safe_load((DATA / "manipulation.yaml").read_text())
    cfg["refine"] = dict(levels=2, bound=0.5, min_contenders=2)
    config = root / "derived.yaml"
    config.write_text(yaml.safe_dump(cfg))
    cfg["effects"] = dict(friction=True, finger_collision=True)
    collision = root / "derived-collision.yaml"
    collision.write_text(yaml.safe_dump(cfg))
    for cfg_path, out in ((config, root / "one.h5"), (collision, root / "collision.h5")):
        res = invoke("run", cfg_path, "--out", out, "--no-progress")
        assert res.exit_code == 0, res.output
    for chunk in (0, 1):
        res = invoke("run", config, "--out", root / "run", "--chunks", 2, "--chunk", chunk,
                     "--no-progress")
        assert res.exit_code == 0, res.output
    res = invoke("merge", root / "run", "--out", root / "merged.h5")
    assert res.exit_code == 0, res.output
    out = {}
    for name in ("one", "merged", "collision"):
        with xr.open_dataset(root / f"{name}.h5", engine="h5netcdf") as ds:
            out[name] = ds.load()
    return out


def close(got, want, rel=REL, what=""):
    got, want = np.asarray(got, dtype=np.float64), np.asarray(want, dtype=np.float64)
    np.testing.assert_allclose(got, want, rtol=rel, atol=0.0, err_msg=what)


def h2(ds) -> float:
    h = float(ds.attrs["grid_h"])
    return h * h


def parts(ds):
    """(r index, mu index) of every part, and a reader of a per-design variable of one part
    (flat in store order, w fastest)."""
    keys = list(itertools.product(range(ds["r"].size), range(ds["mu"].size)))

    def per_design(name, ri, mi):
        return ds[name].isel(r=ri, mu=mi).transpose(*DESIGN).values.reshape(-1)

    return keys, per_design


# ---------------------------------------------------------------------------------------------
# Derived variables: recomputed from their sources
# ---------------------------------------------------------------------------------------------
def caging_area(ds):
    """The trapezoid across the palm line (model-notes D36): Lambda h^2 less half the palm
    row's share, which is at most half of Lambda and at most half a cell per palm-row point."""
    gap = (ds["Lambda"] * h2(ds) - ds["caging_area"]).values
    assert np.all(gap >= -1e-12 * ds["Lambda"].values * h2(ds))
    assert np.all(gap <= 0.5 * ds["Lambda"].values * h2(ds) * (1 + 1e-12))
    palm_points = (ds["n_points"] / (ds["n_points"] ** 0)).values   # a bound: every point
    assert np.all(gap <= 0.5 * palm_points * h2(ds))


def tip_prehension_area(ds):
    """n_tip_prehension h^2 less half a cell per palm-row start ending in tip prehension."""
    full = (ds["n_tip_prehension"] * h2(ds)).values
    got = ds["tip_prehension_area"].values
    assert np.all((got <= full * (1 + 1e-12)) & (got >= 0.5 * full * (1 - 1e-12)))


def manipulation_a_area(ds):
    close(ds["manipulation_a_area"], ds["manipulation_a"] * h2(ds),
          what="manipulation_a_area = manipulation_a h^2")


def manipulation_b_area(ds):
    close(ds["manipulation_b_area"], ds["manipulation_b"] * h2(ds),
          what="manipulation_b_area = manipulation_b h^2")


def manipulation_b(ds):
    close(ds["manipulation_b"], ds["manipulation_b_pose_value"].sum(("pose_row", "pose_column")),
          what="manipulation_b = the sum of its poses' values")


def manipulation_b_poses(ds):
    assert np.array_equal(ds["manipulation_b_poses"].values,
                          (ds["manipulation_b_pose_value"] > 0).sum(("pose_row", "pose_column"))
                          .values)


def n_points(ds):
    """The point classes partition the grid."""
    total = sum(ds[n] for n in ("n_infeasible", "n_unreached", "n_eject", "n_vertex",
                                "n_reached"))
    assert np.array_equal(ds["n_points"].values, total.values)


def refine_finest_h(ds):
    keys, per_design = parts(ds)
    h = float(ds.attrs["grid_h"])
    for ri, mi in keys:
        level = per_design("refined_level", ri, mi)
        want = h / 2.0 ** level.max() if level.max() > 0 else h
        assert float(ds["refine_finest_h"].isel(r=ri, mu=mi)) == want


def refine_n_contenders(ds):
    keys, per_design = parts(ds)
    for ri, mi in keys:
        role = per_design("refine_role", ri, mi)
        roles = ds["refine_role"].attrs["flag_meanings"].split()
        contender = np.isin(role, [roles.index(k) for k in ("eliminated", "near_tie", "best")])
        assert int(ds["refine_n_contenders"].isel(r=ri, mu=mi)) == int(contender.sum())
        # a contender or an audited design, and only those, was recomputed (model-notes D37)
        audited = role == roles.index("audited")
        assert int(ds["refine_audit_designs"].isel(r=ri, mu=mi)) == int(audited.sum())
        assert np.array_equal(contender | audited, per_design("refined_level", ri, mi) > 0)


def refine_n_readmitted(ds):
    keys, per_design = parts(ds)
    for ri, mi in keys:
        readmitted = per_design("refine_readmitted", ri, mi)
        assert int(ds["refine_n_readmitted"].isel(r=ri, mu=mi)) == int(readmitted.sum())
        assert (int(ds["refine_widenings"].isel(r=ri, mu=mi)) > 0) == bool(readmitted.any())
        assert np.all(per_design("refine_role", ri, mi)[readmitted] > 0)


def refine_status(ds):
    """certified: the final set is the best's equal-R class alone; not_refined: no contender."""
    keys, per_design = parts(ds)
    meanings = ds["refine_status"].attrs["flag_meanings"].split()
    roles = ds["refine_role"].attrs["flag_meanings"].split()
    for ri, mi in keys:
        role = per_design("refine_role", ri, mi)
        status = meanings[int(ds["refine_status"].isel(r=ri, mu=mi))]
        final = (role == roles.index("near_tie")) | (role == roles.index("best"))
        if status == "not_refined":
            assert not (role > 0).any()
        else:
            best = role == roles.index("best")
            assert best.any()
            assert (status == "certified") == bool(np.array_equal(final, best))


def refine_margin(ds):
    """The best's lead over the best other class computed at the finest level."""
    keys, per_design = parts(ds)
    best_code = ds["refine_role"].attrs["flag_meanings"].split().index("best")
    for ri, mi in keys:
        role = per_design("refine_role", ri, mi)
        if not (role > 0).any():
            continue
        level = per_design("refined_level", ri, mi)
        value = per_design("refined_caging_area", ri, mi)
        best = np.flatnonzero(role == best_code)
        others = (level == level.max()) & (role != best_code)
        margin = float(ds["refine_margin"].isel(r=ri, mu=mi))
        if others.any():
            close(margin, value[best[0]] - value[others].max(), what="refine_margin")
        else:   # the leader computed alone at its last level: its lead from the level before
            assert margin > 0.0


def refined_error(ds):
    """At level 1 the error estimate is the change from the screened value."""
    keys, per_design = parts(ds)
    for ri, mi in keys:
        first = per_design("refined_level", ri, mi) == 1
        close(per_design("refined_error", ri, mi)[first],
              np.abs(per_design("refined_caging_area", ri, mi)
                     - per_design("caging_area", ri, mi))[first], rel=1e-9)
        assert np.all(np.isnan(per_design("refined_error", ri, mi)
                               [per_design("refined_level", ri, mi) == 0]))


def refine_bound_widened(ds):
    """Every design whose screened value reaches the widened cut contended or was audited
    (model-notes D37: an audited design comes back by its own value, not by the cut)."""
    keys, per_design = parts(ds)
    for ri, mi in keys:
        screened = per_design("caging_area", ri, mi)
        widened = float(ds["refine_bound_widened"].isel(r=ri, mu=mi))
        if np.isnan(widened):
            continue
        assert widened >= float(ds["refine_bound_used"].isel(r=ri, mu=mi))
        cut = (1.0 - widened) * screened.max()
        assert np.all(per_design("refine_role", ri, mi)[screened >= cut * (1 + 1e-12)] > 0)


DERIVED = {f.__name__: f for f in (
    caging_area, tip_prehension_area, manipulation_a_area, manipulation_b_area, manipulation_b,
    manipulation_b_poses,
    n_points, refine_finest_h, refine_n_contenders, refine_n_readmitted, refine_status,
    refine_margin, refined_error, refine_bound_widened)}


# ---------------------------------------------------------------------------------------------
# Primary variables: the bounds their definitions imply
# ---------------------------------------------------------------------------------------------
def _at_most(small, large):
    def check(ds):
        assert np.all(ds[small].values <= ds[large].values), f"{small} <= {large}"
    return check


def _trajectory_ends(ds):
    """With the caging output every reached point's trajectory ends somewhere."""
    total = sum(ds[n] for n in ("n_caged", "n_tip_prehension", "n_ejection", "n_stalled"))
    assert np.array_equal(total.values, ds["n_reached"].values)


def _lambda(ds):
    """A sum of caging scores in (0, 1], one per trajectory that ends caged."""
    lam, caged = ds["Lambda"].values, ds["n_caged"].values
    assert np.all((lam > 0) == (caged > 0)) and np.all(lam <= caged + 1e-9)


def _feasible(name):
    def check(ds):
        assert np.all(ds[name].values <= (ds["n_points"] - ds["n_infeasible"]).values)
    return check


def _nonnegative(name):
    def check(ds):
        assert np.all(ds[name].values >= 0)
    return check


def _usage(ds):
    u = ds["parameter_usage"].values
    assert np.all(np.isnan(u) | ((u >= 0) & (u <= 1 + 1e-12)))


def _uncrossed(ds):
    """The hull of a subset of a pose's forces lies inside the hull of them all."""
    assert np.all(ds["manipulation_b_uncrossed"].values
                  <= ds["manipulation_b"].values * (1 + 1e-12))


def _refined(ds):
    """Refined values exactly where a design contended, at a level of the refinement."""
    level = ds["refined_level"].values
    assert np.array_equal(np.isnan(ds["refined_caging_area"].values), level == 0)
    assert level.max() <= int(ds.attrs["refine_levels"])


def _bound_held(ds):
    """The refinement re-admits what could win until its bound check holds."""
    assert bool(ds["refine_bound_held"].all())


def _bound_used(ds):
    used = ds["refine_bound_used"].values
    assert np.all(np.isnan(used) | ((used >= 0) & (used <= ds.attrs["refine_bound"] + 1e-12)))


def _nonnegative_or_nan(ds):
    v = ds["refine_audit_rise"].values
    assert np.all(np.isnan(v) | (v >= 0))


def _audit_h(ds):
    """The audit recomputes at the part's finest spacing (model-notes D37)."""
    got, finest = ds["refine_audit_h"].values, ds["refine_finest_h"].values
    status = ds["refine_status"].values
    refined = status != ds["refine_status"].attrs["flag_meanings"].split().index("not_refined")
    assert np.array_equal(got[refined], finest[refined])


PRIMARY = {
    "Lambda": _lambda, "n_caged": _trajectory_ends, "n_tip_prehension": _trajectory_ends,
    "n_ejection": _trajectory_ends, "n_stalled": _trajectory_ends,
    "n_reached": _at_most("n_reached", "n_points"),
    "n_equilibrium": _at_most("n_equilibrium", "n_reached"),
    "n_caged_points": _at_most("n_caged_points", "n_equilibrium"),
    "n_caged_crossed": _at_most("n_caged_crossed", "n_caged_points"),
    "n_vertex": _at_most("n_vertex", "n_points"),
    "n_infeasible": _at_most("n_infeasible", "n_points"),
    "n_unreached": _at_most("n_unreached", "n_points"),
    "n_eject": _at_most("n_eject", "n_points"),
    "n_tip_overlap": _feasible("n_tip_overlap"),
    "n_collision_changed": _feasible("n_collision_changed"),
    "manipulation_a": _nonnegative("manipulation_a"),
    "manipulation_b_pose_value": _nonnegative("manipulation_b_pose_value"),
    "manipulation_b_uncrossed": _uncrossed, "parameter_usage": _usage,
    "refined_caging_area": _refined, "refined_level": _refined, "refine_role": _refined,
    "refine_readmitted": refine_n_readmitted, "refine_widenings": refine_n_readmitted,
    "refine_bound_held": _bound_held, "refine_bound_used": _bound_used,
    "refine_audit_designs": refine_n_contenders, "refine_audit_rise": _nonnegative_or_nan,
    "refine_audit_h": _audit_h,
}


def test_every_store_variable_is_checked(stores):
    checked = set(DERIVED) | set(PRIMARY)
    seen = set()
    for name, ds in stores.items():
        have = set(ds.data_vars)
        assert have <= checked, (name, sorted(have - checked))
        seen |= have
    assert seen == checked, sorted(checked - seen)


def holding(stores, name) -> list:
    """The stores that hold variable `name` (at least one does)."""
    out = [ds for ds in stores.values() if name in ds]
    assert out, name
    return out


@pytest.mark.parametrize("name", sorted(DERIVED))
def test_derived_variable_has_its_identity(stores, name):
    for ds in holding(stores, name):
        DERIVED[name](ds)


@pytest.mark.parametrize("name", sorted(PRIMARY))
def test_primary_variable_keeps_its_bounds(stores, name):
    for ds in holding(stores, name):
        PRIMARY[name](ds)


def test_stores_exercise_every_identity(stores):
    """What the identities compare is not zero or equal by accident: refined designs, positive
    Scenario A and B metrics, B above B without crossed fingers, and poses of value 0 beside
    positive ones."""
    for ds in stores.values():
        assert (ds["refined_level"] > 0).any() and (ds["manipulation_b"] > 0).any()
    ds = stores["one"]
    assert (ds["manipulation_a"] > 0).any()
    assert (ds["manipulation_b_uncrossed"] < ds["manipulation_b"]).any()
    pose = ds["manipulation_b_pose_value"]
    assert ((pose > 0).sum() > 1) and (pose == 0).any()


# ---------------------------------------------------------------------------------------------
# A map file: its summary attributes from its own fields
# ---------------------------------------------------------------------------------------------
def test_map_file_summary_attributes_are_its_fields_counted(tmp_path):
    out = tmp_path / "m.h5"
    res = invoke("map", "--l1", 1.4, "--l2", 1.2, "--r1", 0.12, "--r2", 0.1, "--w", 0.8,
                 "--r", 0.4, "--mu", 0.4, "--h", 0.1, "--forces", "--out", out)
    assert res.exit_code == 0, res.output
    with xr.open_dataset(out, engine="h5netcdf") as m:
        m = m.load()
    a, h, r = m.attrs, float(m.attrs["h"]), 0.4
    cls = m["point_class"].values
    classes = m["point_class"].attrs["flag_meanings"].split()
    ends = m["end_state"].attrs["flag_meanings"].split()
    reached = cls == classes.index("reached")
    tips = reached & (m["end_state"].values == ends.index("tip_prehension"))
    assert m["y"].values[0] == pytest.approx(r)      # the first row lies on the palm line
    close(a["tip_prehension_area"], (tips.sum() - 0.5 * tips[0].sum()) * h * h,
          what="tip_prehension_area: the trapezoid across the palm line")
    gap = a["Lambda"] * h * h - a["caging_area"]     # half the palm row's share (D36)
    assert 0.0 <= gap <= 0.5 * cls.shape[1] * h * h
    assert a["n_points"] == cls.size
    for name in ("infeasible", "unreached", "eject", "vertex", "reached"):
        key = "n_vertex" if name == "vertex" else f"n_{name}"
        assert a[key] == int((cls == classes.index(name)).sum()), key
    for name, key in (("caged", "n_caged"), ("tip_prehension", "n_tip_prehension"),
                      ("ejection", "n_ejection"), ("stalled", "n_stalled")):
        assert a[key] == int((reached & (m["end_state"].values == ends.index(name))).sum()), key
    assert a["n_equilibrium"] == int((reached & m["equilibrium"].values.astype(bool)).sum())
    score = m["caging_score"].values
    caged = score > 0
    assert a["n_caged_points"] == int(caged.sum()) and a["n_caged"] > 0
    close(score[caged], 1.0 - m["l_open"].values[caged] / (2 * r), what="caging_score")
    feasible = cls != classes.index("infeasible")
    overlap = m["tip_overlap"].values.astype(bool).any(axis=0)
    assert a["n_tip_overlap"] == int((feasible & overlap).sum())
    assert 0 < a["Lambda"] <= a["n_caged"]
    # the forces output's S_geo: the caging score without the stability requirement
    geo = m["geometric_cage_score"].values
    inside = reached & m["contained"].values.astype(bool) & (m["l_open"].values < 2 * r)
    close(geo[inside], 1.0 - m["l_open"].values[inside] / (2 * r), what="geometric_cage_score")
    assert np.all(geo[reached & ~inside] == 0.0) and np.all(geo[caged] == score[caged])
