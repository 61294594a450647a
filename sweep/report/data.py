"""The store as the report reads it (`open_store` -> `StoreData`), and what every experiment
shares: design rankings, number formatting, CSV and markdown tables, a best map recomputed at the
store's own settings."""
from __future__ import annotations

import csv
import functools
import io
import json
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .. import __version__
from ..files import write_bytes_atomic
from ..storage.optimized import optimization_created
from ..storage.schedule import schedule_created
from ..storage.refined import ROLE, designs_of_coords, equal_r_classes, part_outcome, ranking
from ..storage.h5 import StoreError


DESIGN_DIMS = ("l1", "l2", "r1", "r2", "w")


CANDIDATE_DIMS = ("l1", "l2", "r1", "r2")


PARAMETERS = ("w", "l1", "l2", "r1", "r2")


MANIPULATION_VARIABLES = ("manipulation_a", "manipulation_a_area", "manipulation_b",
                          "manipulation_b_area", "manipulation_b_uncrossed",
                          "manipulation_b_poses", "parameter_usage",
                          "manipulation_b_pose_value")


#: The marker file of a report (one store, or two): what it was made from, and whether complete.
MARKER = "report.json"
#: Text format of every number of the report (tables, CSV and the reading alike).
NUMBER = "{:.6g}"


#: What a report holds: raised when a change of the code adds or changes its files or
#: sections, so that a report made before (same stores, same version) is redone, not kept.
REPORT_FORMAT = 2


#: Significant digits at which Lambda (and Scenario A sums) are compared: designs with the same
#: configurations (same R = r2/r1) sum the same scores in another order, which differs in the
#: last bits (seen: 2913.620282318659 against ...658), and must tie.
TIE_DIGITS = 9


class ReportError(StoreError):
    """A store the report cannot use (CLI: one line, exit code 2)."""


def tie_key(values) -> np.ndarray:
    """Values rounded to TIE_DIGITS significant digits (NaN as -inf): equal keys tie."""
    v = np.asarray(values, dtype=np.float64)
    out = np.array([float(f"{x:.{TIE_DIGITS}g}") for x in v.ravel()]).reshape(v.shape)
    return np.where(np.isnan(out), -np.inf, out)


def fmt(v) -> str:
    """One number as the report prints it."""
    if isinstance(v, (bool, np.bool_)):
        return "yes" if v else "no"
    if isinstance(v, (int, np.integer)):
        return str(int(v))
    if isinstance(v, (float, np.floating)):
        return "NaN" if math.isnan(v) else NUMBER.format(float(v))
    return str(v)


@dataclass
class StoreData:
    path: Path
    ds: object                  # xarray.Dataset, loaded into memory
    scene: object               # sweep.config.scene.Scene rebuilt from the frozen config
    attrs: dict
    manipulation: bool
    _reps: np.ndarray | None = None     # equal-R class of every design (refined stores)
    _designs: np.ndarray | None = None  # (designs, 5): every design's values, store order

    # (read once: each Dataset lookup costs tens of microseconds, and tables read these per row)
    @functools.cached_property
    def r(self) -> np.ndarray:
        return self.ds["r"].values

    @functools.cached_property
    def mu(self) -> np.ndarray:
        return self.ds["mu"].values

    def parts(self) -> list[tuple[int, int]]:
        """(r index, mu index) of every part, r-major (the order of every per-part table)."""
        return [(ri, mi) for ri in range(self.r.size) for mi in range(self.mu.size)]

    def per_design(self, name: str, ri: int, mi: int) -> np.ndarray:
        """A summary variable of one part over every design, flat in store order."""
        return self.ds[name].isel(r=ri, mu=mi).transpose(*DESIGN_DIMS).values.reshape(-1)

    def design(self, flat: int) -> dict:
        """The design of flat index `flat` (store order), as {l1: ..., ..., w: ...}."""
        if self._designs is None:   # (read once: a Dataset lookup per design took seconds)
            grids = np.meshgrid(*(self.ds[d].values for d in DESIGN_DIMS), indexing="ij")
            self._designs = np.stack([g.reshape(-1) for g in grids], axis=1)
        return dict(zip(DESIGN_DIMS, map(float, self._designs[flat])))

    @property
    def scenario_c(self) -> bool:
        """The store holds Scenario C, friction modulation (MODEL 10; `outputs.scenario_c`)."""
        return self.manipulation and "manipulation_c" in self.ds

    @property
    def mu_low(self) -> float:
        """Scenario C's low friction (NaN without it)."""
        return float(self.attrs.get("manipulation_scenario_c_mu_low", math.nan))

    @property
    def refined(self) -> bool:
        """The store holds the refinement stage's variables (`sweep.runs.refine`)."""
        return "refine_status" in self.ds

    def refinement(self, ri: int, mi: int):
        """The part's refined answer (`sweep.storage.refined.PartOutcome`), None if not refined."""
        if not self.refined:
            return None
        if self._reps is None:
            self._reps = equal_r_classes(designs_of_coords(
                {d: self.ds[d].values for d in DESIGN_DIMS}))
        widened = "refine_widenings" in self.ds
        audited = "refine_audit_designs" in self.ds
        names = ["refine_status", "refine_finest_h", "refine_margin", "refine_bound_held"]
        audit_names = ["refine_audit_designs", "refine_audit_rise", "refine_audit_h"]
        part = self.ds[names + (["refine_widenings", "refine_n_readmitted"] if widened
                                else []) + (audit_names if audited else [])].isel(r=ri, mu=mi)
        out = part_outcome(self._reps, self.per_design("refine_role", ri, mi),
                           self.per_design("refined_caging_area", ri, mi),
                           self.per_design("refined_error", ri, mi),
                           int(part["refine_status"]), float(part["refine_finest_h"]),
                           float(part["refine_margin"]), bool(part["refine_bound_held"]),
                           int(part["refine_widenings"]) if widened else None,
                           int(part["refine_n_readmitted"]) if widened else 0,
                           tuple(float(part[k]) for k in audit_names) if audited else None)
        return None if out.status == "not_refined" else out


def design_ranking(st: StoreData, ri: int, mi: int) -> np.ndarray:
    """Flat design indices of one part, best first: the refined ranking in a refined store
    (`sweep.storage.refined.ranking`), else by Lambda at TIE_DIGITS (store order among ties)."""
    if st.refinement(ri, mi) is not None:
        return ranking(st.per_design("refine_role", ri, mi),
                       st.per_design("refined_caging_area", ri, mi),
                       st.per_design("caging_area", ri, mi))
    return np.argsort(-tie_key(st.per_design("Lambda", ri, mi)), kind="stable")


def scenario_a_candidates(st: StoreData, top_k: int) -> list[tuple[int, ...]]:
    """(l1, l2, r1, r2) index tuples of the top-k caging designs of every part
    (`design_ranking`: refined where the store is), duplicates merged, in store order: Scenario
    A's candidates, and Scenario C's (MODEL 10)."""
    shape = tuple(st.ds[d].size for d in DESIGN_DIMS)
    found = set()
    for ri, mi in st.parts():
        for k in design_ranking(st, ri, mi)[:top_k]:
            found.add(tuple(int(i) for i in np.unravel_index(int(k), shape)[:4]))
    return sorted(found)


def candidate_metric_rows(st: StoreData, top_k: int, scenario: str) -> list[dict]:
    """Every candidate (`scenario_a_candidates`) with its Scenario `scenario` metric ("a" or
    "c": the store's `manipulation_a` or `manipulation_c`, and its `_area`) summed over all
    parts (`{scenario}_sum`, `{scenario}_area_sum`, `parts_positive`); the best one (largest
    sum, first in store order among ties at TIE_DIGITS) is flagged."""
    metric = st.ds[f"manipulation_{scenario}"].transpose(*CANDIDATE_DIMS, "r", "mu").values
    area = st.ds[f"manipulation_{scenario}_area"].transpose(*CANDIDATE_DIMS, "r", "mu").values
    rows = []
    for c in scenario_a_candidates(st, top_k):
        vals = {d: float(st.ds[d].values[i]) for d, i in zip(CANDIDATE_DIMS, c)}
        rows.append({**vals, "R": vals["r2"] / vals["r1"],
                     f"{scenario}_sum": float(np.nansum(metric[c])),
                     f"{scenario}_area_sum": float(np.nansum(area[c])),
                     "parts_positive": int(np.count_nonzero(metric[c] > 0)), "best": False,
                     "index": c})
    if rows:
        rows[int(np.argmax(tie_key([row[f"{scenario}_sum"] for row in rows])))]["best"] = True
    return rows


def best_design(st: StoreData, ri: int, mi: int) -> dict:
    """The best caging design of one part and what backs it: the one place the report reads
    it. In a refined store: the refined best (its refined caging area, error estimate, lead over
    the runner-up, finest h, "certified" or the near-tie set, `near_tie` listing each member);
    else the design of largest Lambda, first in store order among ties (`tie_key`)."""
    lam = st.per_design("Lambda", ri, mi)
    key = tie_key(lam)
    out = st.refinement(ri, mi)
    k = out.best if out is not None else int(np.argmax(key))
    d = st.design(k)
    row = dict(r=float(st.r[ri]), mu=float(st.mu[mi]), **d, R=d["r2"] / d["r1"],
               Lambda=float(lam[k]),
               caging_area=float(st.per_design("caging_area", ri, mi)[k]),
               n_caged=int(st.per_design("n_caged", ri, mi)[k]),
               n_tip_prehension=int(st.per_design("n_tip_prehension", ri, mi)[k]),
               n_caged_points=int(st.per_design("n_caged_points", ri, mi)[k]),
               n_caged_crossed=int(st.per_design("n_caged_crossed", ri, mi)[k]),
               n_tied=(out.n_best if out is not None else
                       int(np.count_nonzero(key == key[k]))), design_index=k)
    if st.refined:
        row.update(refined_caging_area=math.nan, refined_error=math.nan, margin=math.nan,
                   finest_h=float(st.scene.h), certification="not refined", near_tie=[])
    if out is not None:
        row.update(refined_caging_area=float(out.value[k]), refined_error=float(out.error[k]),
                   margin=out.margin, finest_h=out.finest_h,
                   certification=("certified" if out.certified else
                                  f"near-tie ({len(out.members)})")
                   + (f", {out.bound_label()}" if out.bound_label() else "")
                   + f"; {out.audit_label()}",
                   near_tie=[dict(r=row["r"], mu=row["mu"], status=out.status, **st.design(m),
                                  R=st.design(m)["r2"] / st.design(m)["r1"],
                                  refined_caging_area=float(out.value[m]),
                                  refined_error=float(out.error[m]), finest_h=out.finest_h,
                                  bound_held=out.bound_held)
                             for m in out.members])
    return row


def within_error(coarse, fine, largest, bound):
    """docs/accuracy.md's rule for a value against its converged one, elementwise: the relative
    change at most `bound`, or, where the converged value is below 1 % of `largest` (the part's
    largest), the absolute change below 1 % of `largest`."""
    coarse, fine, largest = np.asarray(coarse), np.asarray(fine), np.asarray(largest)
    change = np.abs(coarse - fine)
    return np.where(np.abs(fine) < 0.01 * largest, change < 0.01 * largest,
                    change <= bound * np.abs(fine))


#: The refinement's roles whose designs it recomputed at finer spacings, in two groups: the audit's
#: stratified random sample of the designs it left out (an estimate of the screening's error
#: on the many), and the contenders (the designs the screening ranked highest).
ERROR_GROUPS = (("audited", ("audited",)), ("contenders", ("eliminated", "near_tie", "best")))


def screening_error(st: StoreData) -> list[dict]:
    """How far the screening's caging areas are from the refinement's values (model-notes D37), over
    the designs the refinement recomputed, per ERROR_GROUPS: the group, the number of designs,
    how many are within 5 % and within 15 % (relatively, or, below 1 % of the part's best refined
    value, absolutely against 1 % of it: docs/accuracy.md's rule) and the median relative change.
    Empty for a store that is not refined."""
    if not st.refined:
        return []
    role = st.ds["refine_role"].values
    screened = st.ds["caging_area"].values
    refined = st.ds["refined_caging_area"].values
    # the part's best refined value, over the design axes (the part's are the last two)
    axes = tuple(range(refined.ndim - 2))
    best = np.nanmax(np.where(np.isfinite(refined), refined, -np.inf), axis=axes,
                     keepdims=True)
    best = np.broadcast_to(np.where(np.isfinite(best), best, 0.0), refined.shape)
    rows = []
    for group, names in ERROR_GROUPS:
        mask = np.isin(role, [ROLE[n] for n in names]) & np.isfinite(refined)
        s, f, b = screened[mask], refined[mask], best[mask]
        change = np.abs(s - f)
        rel = change / np.maximum(f, 0.01 * b + 1e-300)
        w5 = within_error(s, f, b, 0.05)
        w15 = within_error(s, f, b, 0.15)
        rows.append(dict(group=group, n=int(mask.sum()), within5=int(w5.sum()),
                         within15=int(w15.sum()),
                         median=float(np.median(rel)) if rel.size else math.nan))
    return rows


def screening_error_text(st: StoreData) -> str:
    """One sentence of screening_error for the reports ("" for a store that is not refined)."""
    rows = screening_error(st)
    if not rows:
        return ""
    parts = [f"{r['group']}: {r['within5']} of {r['n']} within 5 % and {r['within15']} within "
             f"15 % of their refined values, median change {r['median']:.1%}"
             for r in rows if r["n"]]
    return ("The screening's caging areas against the refinement's (the designs it recomputed at "
            "finer spacings; model-notes D37): " + "; ".join(parts) + ". The tip-prehension "
            "counts, Scenario A, B and the parameter usage are the screening's, not refined "
            "(each section states their error as h halves, measured on a slice).")


def representative_designs(caged: np.ndarray, tip: np.ndarray) -> dict[str, int]:
    """Flat design indices of the three representative designs of one part (rules in
    report.md): caging focused = most caged end points, fewer tip ones breaking ties; tip
    focused = most tip-prehension end points, fewer caged breaking ties; compromise = the
    largest min(caged / most caged, tip / most tip), then the largest sum of both fractions.
    Remaining ties: first in store order."""
    caged = np.asarray(caged, dtype=np.float64)
    tip = np.asarray(tip, dtype=np.float64)
    order = np.arange(caged.size)
    fc = caged / caged.max() if caged.max() > 0 else np.zeros_like(caged)
    ft = tip / tip.max() if tip.max() > 0 else np.zeros_like(tip)
    # np.lexsort: last key is primary; `order` last-but-first keeps store order among ties
    return {
        "caging focused": int(np.lexsort((order, tip, -caged))[0]),
        "tip focused": int(np.lexsort((order, caged, -tip))[0]),
        "compromise": int(np.lexsort((order, -(fc + ft), -np.minimum(fc, ft)))[0]),
    }


def csv_bytes(rows: list[dict], columns: list[str]) -> bytes:
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(columns)
    for row in rows:
        w.writerow([fmt(row[c]) for c in columns])
    return buf.getvalue().encode()


def md_table(rows: list[dict], columns: list[str], headers: list[str] | None = None) -> str:
    headers = headers or columns
    lines = ["| " + " | ".join(headers) + " |", "|" + "---|" * len(headers)]
    for row in rows:
        lines.append("| " + " | ".join(fmt(row[c]) for c in columns) + " |")
    return "\n".join(lines)


def design_text(d: dict) -> str:
    return (f"l1={d['l1']:g} l2={d['l2']:g} r1={d['r1']:g} r2={d['r2']:g} w={d['w']:g} "
            f"(R={fmt(d['r2'] / d['r1'])})")


def part_text(row) -> str:
    return f"r = {fmt(row['r'])}, mu = {fmt(row['mu'])}"


def spread(values) -> str:
    vals = sorted(set(fmt(v) for v in values), key=float)
    return f"{len(vals)} distinct value{'s' if len(vals) != 1 else ''} ({', '.join(vals)})"


# ---------------------------------------------------------------------------------------------
# A report's files: what it is made from, written one by one (one store, or two)
# ---------------------------------------------------------------------------------------------
def identity(st: StoreData, top_k: int | None) -> dict:
    """What a report is made from; equal identities make a rerun a no-op."""
    a = st.attrs
    return dict(store=str(st.path.resolve()), config_hash=a.get("config_hash"),
                store_created_utc=a.get("created_utc"),
                store_refined_utc=a.get("refine_created_utc"),
                store_optimized_utc=optimization_created(st.path),
                store_schedule_utc=schedule_created(st.path), top_k=top_k,
                manipulation=st.manipulation, report_version=__version__,
                report_format=REPORT_FORMAT)


def resolve_top_k(st: StoreData, top_k: int | None) -> int | None:
    if not st.manipulation:
        if top_k is not None:
            raise ReportError(f"{st.path}: --top-k needs the manipulation metric, which this "
                              "store lacks (config option outputs: {manipulation: true})")
        return None
    if top_k is None:
        top_k = int(st.attrs.get("manipulation_scenario_a_top_k", st.scene.scenario_a_top_k))
    if top_k < 1:
        raise ReportError(f"--top-k must be >= 1, got {top_k}")
    return top_k


def report_files(out_dir: Path, ident: dict, files: list[str]):
    """A report's files, written one by one and atomically: (write, finish). An incomplete
    marker is written first (a killed report is redone by a rerun, not taken as done);
    `write(name, data)` writes a file and lists it in `files`; `finish()` writes the complete
    marker, last."""
    def marker(complete: bool) -> bytes:
        extra = dict(files=sorted(files)) if complete else {}
        return json.dumps(dict(ident, complete=complete, **extra), indent=1,
                          sort_keys=True).encode()

    write_bytes_atomic(out_dir / MARKER, marker(False))

    def write(name: str, data: bytes):
        write_bytes_atomic(out_dir / name, data)
        files.append(name)

    return write, lambda: write_bytes_atomic(out_dir / MARKER, marker(True))


# ---------------------------------------------------------------------------------------------
# Two stores (the two-scene report)
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


def short_scene(st: StoreData) -> str:
    return "fingers may cross" if crossing(st) else "fingers cannot cross"


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
    friction_candidates: list[dict] = field(default_factory=list)
    friction_scenes: tuple = ()      # each scene's Scenario C rows (report.friction)
    friction: list[dict] = field(default_factory=list)       # both side by side
    modulation_scenes: tuple = ()    # each scene's caging-under-modulation rows
    modulation: list[dict] = field(default_factory=list)     # both side by side
    #: per scene whose store has been optimised: (scene tag, results file, its rows)
    optimized: list[tuple] = field(default_factory=list)
    #: per scene whose store has its schedules (`sweep schedule`): (tag, results file, rows)
    variable: list[tuple] = field(default_factory=list)
    #: every finding of the paper with both scenes' numbers and verdicts (report.paper)
    paper: list[dict] = field(default_factory=list)
    files: list[str] = field(default_factory=list)
