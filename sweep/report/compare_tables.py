"""The two-scene report's tables (`compare.py` writes them): the two stores checked comparable,
and every experiment's rows for scene 1 beside scene 2."""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .caging import best_caging_rows
from .data import DESIGN_DIMS, PARAMETERS, TIE_DIGITS, ReportError, StoreData, fmt
from .manipulation import candidate_rows, manipulation_rows
from .tip import caging_tip_parts, representative_rows
from .usage import usage_rows


# ---------------------------------------------------------------------------------------------
# Two stores
# ---------------------------------------------------------------------------------------------
def crossing(st: StoreData) -> bool:
    """The scene lets the fingers pass through each other (no finger_collision)."""
    return "finger_collision" not in str(st.attrs.get("effects_on", "")).split()


def scene_label(st: StoreData) -> str:
    """What a store's scene is, from the effects it records (`effects_on`)."""
    on = str(st.attrs.get("effects_on", "")).split()
    label = ("fingers may cross (the paper's model)" if crossing(st)
             else "fingers cannot cross (finger_collision)")
    others = [e for e in on if e not in ("friction", "finger_collision")]
    return label + ("; also " + ", ".join(others) if others else "")


def scene_name(st: StoreData) -> str:
    return str(st.attrs.get("name") or st.path.stem)


def _values(st: StoreData, d: str) -> np.ndarray:
    return np.asarray(st.ds[d].values, dtype=np.float64)


def check_comparable(a: StoreData, b: StoreData) -> None:
    """Refuse (ReportError, one line) two stores whose designs, parts, grid or command differ:
    their scenes are compared point for point."""
    def refuse(what: str, x, y):
        raise ReportError(f"cannot compare {a.path} with {b.path}: their {what} differ "
                          f"({x} against {y})")

    for group, dims in (("designs", DESIGN_DIMS), ("parts", ("r", "mu"))):
        for d in dims:
            x, y = _values(a, d), _values(b, d)
            if x.shape != y.shape or not np.array_equal(x, y):
                refuse(group, f"{d} = {', '.join(fmt(v) for v in x)}",
                       f"{d} = {', '.join(fmt(v) for v in y)}")
    sa, sb = a.scene, b.scene
    if (sa.h, sa.bounds) != (sb.h, sb.bounds):
        refuse("grids", f"h = {fmt(sa.h)} ({sa.bounds})", f"h = {fmt(sb.h)} ({sb.bounds})")
    ca, cb = sa.commands[0], sb.commands[0]
    if (ca.f_left, ca.f_right) != (cb.f_left, cb.f_right):
        refuse("commands", f"F = {fmt(ca.f_left)}/{fmt(ca.f_right)}",
               f"F = {fmt(cb.f_left)}/{fmt(cb.f_right)}")
    if a.manipulation != b.manipulation:
        with_m, without = (a, b) if a.manipulation else (b, a)
        raise ReportError(f"cannot compare {a.path} with {b.path}: {with_m.path} has the "
                          f"manipulation metric and {without.path} not (config option outputs: "
                          "{manipulation: true} in both, or in neither)")


# ---------------------------------------------------------------------------------------------
# Tables
# ---------------------------------------------------------------------------------------------
def best_designs(st: StoreData) -> list[dict]:
    """A scene's best caging design per part (the one place the comparison reads it)."""
    return best_caging_rows(st)


def gripper(row: dict) -> tuple:
    """What makes a design a gripper: configurations depend on r1, r2 only through R (MODEL
    11), so designs with the same l1, l2, R, w are the same gripper and tie."""
    return (row["l1"], row["l2"], float(f"{row['R']:.{TIE_DIGITS}g}"), row["w"])


def best_rows(st1: StoreData, st2: StoreData) -> list[dict]:
    """Per part: each scene's best design, whether they are the same gripper, and what each
    scene's best design scores in the other scene."""
    b1, b2 = best_designs(st1), best_designs(st2)
    rows = []
    for (ri, mi), x, y in zip(st1.parts(), b1, b2):
        row = dict(r=x["r"], mu=x["mu"])
        for s, best in (("1", x), ("2", y)):
            row.update({f"{k}_{s}": best[k] for k in DESIGN_DIMS + ("R", "Lambda", "n_tied")})
            row[f"n_caged_crossed_{s}"] = best["n_caged_crossed"]
            row[f"n_caged_points_{s}"] = best["n_caged_points"]
            for k in REFINED_KEYS:  # a refined store: the refined best and what backs it
                if k in best:
                    row[f"{k}_{s}"] = best[k]
            row[f"near_tie_{s}"] = best.get("near_tie", [])
        row["same_gripper"] = gripper(x) == gripper(y)
        row["Lambda_2_of_best_1"] = float(st2.per_design("Lambda", ri, mi)[x["design_index"]])
        row["Lambda_1_of_best_2"] = float(st1.per_design("Lambda", ri, mi)[y["design_index"]])
        rows.append(row)
    return rows


REFINED_KEYS = ("refined_caging_area", "refined_error", "margin", "finest_h", "certification")


def best_columns(st1: StoreData, st2: StoreData) -> list[str]:
    """BEST_COLUMNS, with each refined store's refinement columns after its Lambda."""
    cols = list(BEST_COLUMNS)
    for s, st in (("2", st2), ("1", st1)):
        if st.refined:
            at = cols.index(f"Lambda_{s}") + 1
            cols[at:at] = [f"{k}_{s}" for k in REFINED_KEYS]
    return cols


def caging_tip_rows(st1: StoreData, st2: StoreData) -> list[dict]:
    """Every design's caged and tip-prehension counts in both scenes, for the caging-versus-tip
    parts (MODEL 10)."""
    rows = []
    for ri, mi in caging_tip_parts(st1):
        c = [st.per_design("n_caged", ri, mi) for st in (st1, st2)]
        t = [st.per_design("n_tip_prehension", ri, mi) for st in (st1, st2)]
        for k in range(c[0].size):
            rows.append(dict(r=float(st1.r[ri]), mu=float(st1.mu[mi]), **st1.design(k),
                             n_caged_1=int(c[0][k]), n_tip_prehension_1=int(t[0][k]),
                             n_caged_2=int(c[1][k]), n_tip_prehension_2=int(t[1][k])))
    return rows


def representatives(st1: StoreData, st2: StoreData) -> list[dict]:
    """Each scene's three representative designs of the caging-versus-tip parts (the rules of
    `sweep.report.tip.representative_designs`)."""
    rows = []
    for s, st in (("1", st1), ("2", st2)):
        for row in representative_rows(st):
            rows.append(dict(scene=s, **row))
    return rows


def caging_tip_summary(st1: StoreData, st2: StoreData) -> list[dict]:
    rows = []
    for ri, mi in caging_tip_parts(st1):
        for s, st in (("1", st1), ("2", st2)):
            caged = st.per_design("n_caged", ri, mi)
            tip = st.per_design("n_tip_prehension", ri, mi)
            corr = (float(np.corrcoef(caged, tip)[0, 1]) if caged.std() > 0 and tip.std() > 0
                    else float("nan"))
            rows.append(dict(r=float(st.r[ri]), mu=float(st.mu[mi]), scene=s,
                             designs_caging=int(np.count_nonzero(caged > 0)),
                             designs_tip=int(np.count_nonzero(tip > 0)),
                             designs_both=int(np.count_nonzero((caged > 0) & (tip > 0))),
                             caged_sum=int(caged.sum()), tip_sum=int(tip.sum()),
                             correlation=corr))
    return rows


def manip_rows(st1: StoreData, st2: StoreData, best1: dict, best2: dict) -> list[dict]:
    """Per part: Scenario A (each scene's best candidate) and Scenario B under each scene."""
    m1, m2 = manipulation_rows(st1, best1), manipulation_rows(st2, best2)
    rows = []
    for x, y in zip(m1, m2):
        rows.append(dict(r=x["r"], mu=x["mu"], a_1=x["a"], b_1=x["b"],
                         b_uncrossed_1=x["b_uncrossed"], winner_1=x["winner"], a_2=y["a"],
                         b_2=y["b"], b_uncrossed_2=y["b_uncrossed"], winner_2=y["winner"]))
    return rows


def usage_pair_rows(st1: StoreData, st2: StoreData) -> list[dict]:
    rows = []
    for x, y in zip(usage_rows(st1), usage_rows(st2)):
        rows.append(dict(r=x["r"], mu=x["mu"], **{f"{p}_1": x[p] for p in PARAMETERS},
                         **{f"{p}_2": y[p] for p in PARAMETERS}))
    return rows


BEST_COLUMNS = (["r", "mu"] + [f"{k}_1" for k in DESIGN_DIMS + ("R", "Lambda")]
                + [f"{k}_2" for k in DESIGN_DIMS + ("R", "Lambda")]
                + ["same_gripper", "Lambda_2_of_best_1", "Lambda_1_of_best_2", "n_tied_1",
                   "n_tied_2", "n_caged_crossed_1", "n_caged_crossed_2"])
CT_COLUMNS = ["r", "mu"] + list(DESIGN_DIMS) + ["n_caged_1", "n_tip_prehension_1", "n_caged_2",
                                                "n_tip_prehension_2"]
CT_SUMMARY_COLUMNS = ["r", "mu", "scene", "designs_caging", "designs_tip", "designs_both",
                      "caged_sum", "tip_sum", "correlation"]
REP_COLUMNS = ["scene", "r", "mu", "kind", "l1", "l2", "r1", "r2", "w", "R", "n_caged",
               "n_tip_prehension", "Lambda"]
CAND_COLUMNS = ["scene", "l1", "l2", "r1", "r2", "R", "a_sum", "parts_positive", "best"]
MANIP_COLUMNS = ["r", "mu", "a_1", "b_1", "b_uncrossed_1", "winner_1", "a_2", "b_2",
                 "b_uncrossed_2", "winner_2"]
USAGE_COLUMNS = (["r", "mu"] + [f"{p}_1" for p in PARAMETERS] + [f"{p}_2" for p in PARAMETERS])


@dataclass
class Comparison:
    """Tables of a two-scene report (rows of plain values), as written."""

    best: list[dict]
    caging_tip: list[dict]
    caging_tip_summary: list[dict]
    representatives: list[dict]
    top_k: int | None = None
    candidates: list[dict] = field(default_factory=list)
    best_candidates: tuple = ()
    manipulation: list[dict] = field(default_factory=list)
    usage: list[dict] = field(default_factory=list)
    files: list[str] = field(default_factory=list)


def make_tables(st1: StoreData, st2: StoreData, top_k: int | None) -> Comparison:
    rep = Comparison(best=best_rows(st1, st2), caging_tip=caging_tip_rows(st1, st2),
                     caging_tip_summary=caging_tip_summary(st1, st2),
                     representatives=representatives(st1, st2), top_k=top_k)
    if st1.manipulation:
        c1, c2 = candidate_rows(st1, top_k), candidate_rows(st2, top_k)
        rep.candidates = ([dict(scene="1", **c) for c in c1]
                          + [dict(scene="2", **c) for c in c2])
        best1 = next(c for c in c1 if c["best"])
        best2 = next(c for c in c2 if c["best"])
        rep.best_candidates = (best1, best2)
        rep.manipulation = manip_rows(st1, st2, best1, best2)
        rep.usage = usage_pair_rows(st1, st2)
    return rep
