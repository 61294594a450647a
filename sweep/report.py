"""The paper's four experiments from a results store (MODEL 10): tables, figures, markdown, CSV.

`build_report(store, out_dir, top_k=None, log=...)` reads a store written by `sweep run` and
writes into `out_dir`:

- `best_caging.png`, `best_caging.csv`: the best caging design of every part, its map (in a
  refined store the refined best, with its margin, finest h and certification, and
  `refinement.csv`: each part's certified design or near-tie set);
- `caging_vs_tip.png`, `caging_vs_tip.csv`, `representative_designs.csv`: caged versus
  tip-prehension end points per design for the smallest and the largest part at the highest
  friction, with three representative designs;
- `manipulation.png`, `manipulation.csv`, `scenario_a_candidates.csv`: Scenario A's best
  candidate against Scenario B for every part, and the per-pose values of one part;
- `parameter_usage.png`, `parameter_usage.csv`: Scenario B's parameter usage;
- `report.md`: every table, the rules used, the settings, the run time and a templated reading;
- `report.json`: what the report was made from (a rerun on the same store is a no-op).

A store without the manipulation variables (`outputs: {manipulation: true}` not set) gets the
caging parts only, with a note. Every number comes from the store (or from maps recomputed with
the store's own settings); nothing is typed in. Physics is the library's: `compute_map`,
`scenario_a_pose_values`; this module only selects, tabulates and draws.
"""
from __future__ import annotations

import csv
import io
import json
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from . import __version__
from .outputs import text_bytes, write_bytes_atomic
from .storage.store import StoreError, read_store, scene_from_frozen

DESIGN_DIMS = ("l1", "l2", "r1", "r2", "w")
CANDIDATE_DIMS = ("l1", "l2", "r1", "r2")
PARAMETERS = ("w", "l1", "l2", "r1", "r2")
MANIPULATION_VARIABLES = ("manipulation_a", "manipulation_a_area", "manipulation_b",
                          "manipulation_b_area", "manipulation_b_uncrossed",
                          "manipulation_b_poses", "parameter_usage",
                          "manipulation_b_pose_value")
CAGING_FILES = ("best_caging.png", "best_caging.csv", "caging_vs_tip.png", "caging_vs_tip.csv",
                "representative_designs.csv", "refinement.csv")
MANIPULATION_FILES = ("manipulation.png", "manipulation.csv", "scenario_a_candidates.csv",
                      "parameter_usage.png", "parameter_usage.csv")
MARKER = "report.json"
ALL_FILES = CAGING_FILES + MANIPULATION_FILES + ("report.md", MARKER)
#: Text format of every number of the report (tables, CSV and the reading alike).
NUMBER = "{:.6g}"
#: Significant digits at which Lambda (and Scenario A sums) are compared: designs with the same
#: configurations (same R = r2/r1) sum the same scores in another order, which differs in the
#: last bits (seen: 2913.620282318659 against ...658), and must tie.
TIE_DIGITS = 9
REPRESENTATIVE_COLOURS = {"caging focused": "#ff2d7a", "tip focused": "#ff9f1c",
                          "compromise": "#1f77b4"}


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


# ---------------------------------------------------------------------------------------------
# The store
# ---------------------------------------------------------------------------------------------
@dataclass
class StoreData:
    path: Path
    ds: object                  # xarray.Dataset, loaded into memory
    scene: object               # sweep.config.scene.Scene rebuilt from the frozen config
    attrs: dict
    manipulation: bool
    _reps: np.ndarray | None = None     # equal-R class of every design (refined stores)

    @property
    def r(self) -> np.ndarray:
        return self.ds["r"].values

    @property
    def mu(self) -> np.ndarray:
        return self.ds["mu"].values

    def parts(self) -> list[tuple[int, int]]:
        """(r index, mu index) of every part, r-major (the order of every per-part table)."""
        return [(ri, mi) for ri in range(self.r.size) for mi in range(self.mu.size)]

    def per_design(self, name: str, ri: int, mi: int) -> np.ndarray:
        """A summary variable of one part over every design, flat in store order."""
        return self.ds[name].isel(r=ri, mu=mi).transpose(*DESIGN_DIMS).values.reshape(-1)

    def design(self, flat: int) -> dict:
        idx = np.unravel_index(flat, tuple(self.ds[d].size for d in DESIGN_DIMS))
        return {d: float(self.ds[d].values[i]) for d, i in zip(DESIGN_DIMS, idx)}

    @property
    def refined(self) -> bool:
        """The store holds the refinement stage's variables (`sweep.runs.refine`)."""
        return "refine_status" in self.ds

    def refinement(self, ri: int, mi: int):
        """The part's refined answer (`sweep.runs.refine.PartOutcome`), None if not refined."""
        from .runs.refine import designs_of_coords, equal_r_classes, part_outcome

        if not self.refined:
            return None
        if self._reps is None:
            self._reps = equal_r_classes(designs_of_coords(
                {d: self.ds[d].values for d in DESIGN_DIMS}))
        part = self.ds[["refine_status", "refine_finest_h", "refine_margin",
                        "refine_bound_held"]].isel(r=ri, mu=mi)
        out = part_outcome(self._reps, self.per_design("refine_role", ri, mi),
                           self.per_design("refined_caging_area", ri, mi),
                           self.per_design("refined_error", ri, mi),
                           int(part["refine_status"]), float(part["refine_finest_h"]),
                           float(part["refine_margin"]), bool(part["refine_bound_held"]))
        return None if out.status == "not_refined" else out


def open_store(path: Path) -> StoreData:
    """Read a results store (ReportError / StoreError if it cannot be used)."""
    import xarray as xr

    view = read_store(path)                   # kind check, one-line StoreError otherwise
    if "command" in view.dims:
        raise ReportError(f"{path}: the report needs a store with one command "
                          f"(this one has {view.coords['command'].size}); the paper's "
                          "experiments use F_left = F_right = 1")
    try:
        with xr.open_dataset(path, engine="h5netcdf") as ds:
            ds = ds.load()
    except (OSError, ValueError) as exc:
        raise ReportError(f"{path}: cannot read with xarray ({exc})") from None
    scene = scene_from_frozen(view.frozen)
    have = [v for v in MANIPULATION_VARIABLES if v in ds]
    return StoreData(Path(path), ds, scene, view.attrs,
                     manipulation=len(have) == len(MANIPULATION_VARIABLES))


# ---------------------------------------------------------------------------------------------
# Tables (rows of plain values; CSV and markdown are made from them)
# ---------------------------------------------------------------------------------------------
def design_ranking(st: StoreData, ri: int, mi: int) -> np.ndarray:
    """Flat design indices of one part, best first: the refined ranking in a refined store
    (`sweep.runs.refine.ranking`), else by Lambda at TIE_DIGITS (store order among ties)."""
    if st.refinement(ri, mi) is not None:
        from .runs.refine import ranking

        return ranking(st.per_design("refine_role", ri, mi),
                       st.per_design("refined_caging_area", ri, mi),
                       st.per_design("caging_area", ri, mi))
    return np.argsort(-tie_key(st.per_design("Lambda", ri, mi)), kind="stable")


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
                   + ("" if out.bound_held else ", bound not confirmed"),
                   near_tie=[dict(r=row["r"], mu=row["mu"], status=out.status, **st.design(m),
                                  R=st.design(m)["r2"] / st.design(m)["r1"],
                                  refined_caging_area=float(out.value[m]),
                                  refined_error=float(out.error[m]), finest_h=out.finest_h,
                                  bound_held=out.bound_held)
                             for m in out.members])
    return row


def best_caging_rows(st: StoreData) -> list[dict]:
    """Per part: its best design (`best_design`)."""
    return [best_design(st, ri, mi) for ri, mi in st.parts()]


def caging_tip_parts(st: StoreData) -> list[tuple[int, int]]:
    """The smallest and the largest part at the highest friction (one part if they coincide)."""
    mi = int(np.argmax(st.mu))
    small, large = int(np.argmin(st.r)), int(np.argmax(st.r))
    return [(small, mi)] if small == large else [(small, mi), (large, mi)]


def caging_tip_rows(st: StoreData) -> list[dict]:
    """Every design's caged and tip-prehension counts for the caging-versus-tip parts."""
    rows = []
    for ri, mi in caging_tip_parts(st):
        caged = st.per_design("n_caged", ri, mi)
        tip = st.per_design("n_tip_prehension", ri, mi)
        lam = st.per_design("Lambda", ri, mi)
        for k in range(caged.size):
            rows.append(dict(r=float(st.r[ri]), mu=float(st.mu[mi]), **st.design(k),
                             n_caged=int(caged[k]), n_tip_prehension=int(tip[k]),
                             Lambda=float(lam[k])))
    return rows


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


def representative_rows(st: StoreData) -> list[dict]:
    rows = []
    for ri, mi in caging_tip_parts(st):
        caged = st.per_design("n_caged", ri, mi)
        tip = st.per_design("n_tip_prehension", ri, mi)
        lam = st.per_design("Lambda", ri, mi)
        for kind, k in representative_designs(caged, tip).items():
            d = st.design(k)
            rows.append(dict(r=float(st.r[ri]), mu=float(st.mu[mi]), kind=kind, **d,
                             R=d["r2"] / d["r1"], n_caged=int(caged[k]),
                             n_tip_prehension=int(tip[k]), Lambda=float(lam[k]),
                             design_index=k))
    return rows


def scenario_a_candidates(st: StoreData, top_k: int) -> list[tuple[int, ...]]:
    """(l1, l2, r1, r2) index tuples of the top-k caging designs of every part
    (`design_ranking`: refined where the store is), duplicates merged, in store order."""
    shape = tuple(st.ds[d].size for d in DESIGN_DIMS)
    found = set()
    for ri, mi in st.parts():
        for k in design_ranking(st, ri, mi)[:top_k]:
            found.add(tuple(int(i) for i in np.unravel_index(int(k), shape)[:4]))
    return sorted(found)


def candidate_rows(st: StoreData, top_k: int) -> list[dict]:
    """Every Scenario A candidate with its metric summed over all parts; the best one (largest
    sum, first in store order among ties) is flagged."""
    a = st.ds["manipulation_a"].transpose(*CANDIDATE_DIMS, "r", "mu").values
    a_area = st.ds["manipulation_a_area"].transpose(*CANDIDATE_DIMS, "r", "mu").values
    rows = []
    for c in scenario_a_candidates(st, top_k):
        vals = {d: float(st.ds[d].values[i]) for d, i in zip(CANDIDATE_DIMS, c)}
        rows.append(dict(**vals, R=vals["r2"] / vals["r1"], a_sum=float(np.nansum(a[c])),
                         a_area_sum=float(np.nansum(a_area[c])),
                         parts_positive=int(np.count_nonzero(a[c] > 0)), best=False, index=c))
    if rows:
        best = int(np.argmax(tie_key([row["a_sum"] for row in rows])))
        rows[best]["best"] = True
    return rows


def manipulation_rows(st: StoreData, best: dict) -> list[dict]:
    """Per part: the best candidate's Scenario A metric next to Scenario B's, and which wins."""
    a = st.ds["manipulation_a"].transpose(*CANDIDATE_DIMS, "r", "mu").values[best["index"]]
    a_area = st.ds["manipulation_a_area"].transpose(*CANDIDATE_DIMS, "r", "mu").values[
        best["index"]]
    rows = []
    for ri, mi in st.parts():
        va, vb = float(a[ri, mi]), float(st.ds["manipulation_b"].values[ri, mi])
        winner = "A" if va > vb else "B" if vb > va else "tie"
        rows.append(dict(r=float(st.r[ri]), mu=float(st.mu[mi]), a=va,
                         a_area=float(a_area[ri, mi]), b=vb,
                         b_area=float(st.ds["manipulation_b_area"].values[ri, mi]),
                         b_uncrossed=float(st.ds["manipulation_b_uncrossed"].values[ri, mi]),
                         b_poses=int(st.ds["manipulation_b_poses"].values[ri, mi]),
                         winner=winner))
    return rows


def usage_rows(st: StoreData) -> list[dict]:
    u = st.ds["parameter_usage"].transpose("r", "mu", "parameter")
    names = [str(p) for p in u["parameter"].values]
    rows = []
    for ri, mi in st.parts():
        vals = u.values[ri, mi]
        rows.append(dict(r=float(st.r[ri]), mu=float(st.mu[mi]),
                         **{p: float(vals[names.index(p)]) for p in PARAMETERS}))
    return rows


def pose_map_part(rows: list[dict]) -> int:
    """Row index of the part whose per-pose maps are drawn: the largest min(A, B), so that both
    maps show something; first in table order among ties."""
    return int(np.argmax([min(r["a"], r["b"]) for r in rows]))


# ---------------------------------------------------------------------------------------------
# CSV and markdown
# ---------------------------------------------------------------------------------------------
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


BEST_COLUMNS = ["r", "mu", "l1", "l2", "r1", "r2", "w", "R", "Lambda", "caging_area", "n_caged",
                "n_tip_prehension", "n_caged_points", "n_caged_crossed", "n_tied"]
#: Columns added to BEST_COLUMNS in a refined store.
REFINED_COLUMNS = ["refined_caging_area", "refined_error", "margin", "finest_h", "certification"]
#: refinement.csv: every member of each part's final set (the certified best, or the near-tie
#: set), each with its value and error estimate.
REFINEMENT_COLUMNS = ["r", "mu", "status", "l1", "l2", "r1", "r2", "w", "R",
                      "refined_caging_area", "refined_error", "finest_h", "bound_held"]


def best_columns(st: StoreData) -> list[str]:
    return BEST_COLUMNS + (REFINED_COLUMNS if st.refined else [])


def refinement_rows(best: list[dict]) -> list[dict]:
    """refinement.csv's rows: each part's final set, best first."""
    return [m for row in best for m in row["near_tie"]]
CT_COLUMNS = ["r", "mu", "l1", "l2", "r1", "r2", "w", "n_caged", "n_tip_prehension", "Lambda"]
REP_COLUMNS = ["r", "mu", "kind", "l1", "l2", "r1", "r2", "w", "R", "n_caged",
               "n_tip_prehension", "Lambda"]
CAND_COLUMNS = ["l1", "l2", "r1", "r2", "R", "a_sum", "a_area_sum", "parts_positive", "best"]
MANIP_COLUMNS = ["r", "mu", "a", "a_area", "b", "b_area", "b_uncrossed", "b_poses", "winner"]
USAGE_COLUMNS = ["r", "mu"] + list(PARAMETERS)


# ---------------------------------------------------------------------------------------------
# Figures
# ---------------------------------------------------------------------------------------------
def _png(fig: Figure) -> bytes:
    buf = io.BytesIO()
    fig.savefig(buf, format="png")
    return buf.getvalue()


def _compute_best_map(st: StoreData, design: dict, ri: int, mi: int):
    from .compute.maps import compute_map
    from .model import Design, Grid, Part

    sc = st.scene
    return compute_map(Design(**design), Part(r=float(st.r[ri]), mu=float(st.mu[mi])),
                       sc.commands[0], Grid(h=sc.h), sc.limits, sc.accuracy, sc.effects)


def _design_text(d: dict) -> str:
    return (f"l1={d['l1']:g} l2={d['l2']:g} r1={d['r1']:g} r2={d['r2']:g} w={d['w']:g} "
            f"(R={fmt(d['r2'] / d['r1'])})")


NOTE_UNITLESS = "all quantities unitless (model units)"


def best_caging_figure(st: StoreData, rows: list[dict], log) -> Figure:
    from .plot import draw_map_panel

    n_r, n_mu = st.r.size, st.mu.size
    fig = Figure(figsize=(5.0 * n_r + 0.5, 3.2 * n_mu + 1.0), dpi=100, layout="constrained")
    FigureCanvasAgg(fig)
    axes = np.atleast_2d(fig.subplots(n_mu, n_r, squeeze=False))
    by_part = {(row["r"], row["mu"]): row for row in rows}
    for k, (ri, mi) in enumerate(st.parts()):
        row = by_part[(float(st.r[ri]), float(st.mu[mi]))]
        log(f"best caging maps: {k + 1}/{len(rows)} (r = {row['r']:g}, mu = {row['mu']:g})")
        m = _compute_best_map(st, {d: row[d] for d in DESIGN_DIMS}, ri, mi)
        title = (f"part r={row['r']:g}, μ={row['mu']:g}\n{_design_text(row)}\n"
                 f"Λ={fmt(row['Lambda'])}, caging area={fmt(row['caging_area'])}, "
                 f"{row['n_tied']} tied")
        if "certification" in row:
            title += (f"\nrefined: {fmt(row['refined_caging_area'])} at h={fmt(row['finest_h'])}, "
                      f"{row['certification']}")
        draw_map_panel(axes[mi, ri], m, title=title, colorbar_label="energy V (unitless)")
    fig.suptitle("Best caging design of each part (largest Λ; columns: part radius r, rows: "
                 "friction μ)\nColour: energy V, each panel its own scale; white hatching: part "
                 "in equilibrium; pink outline: caged region; greys and tan: outside P_j "
                 "(not reached); "
                 "gripper and part drawn to scale at a representative caged pose; "
                 f"{NOTE_UNITLESS}", fontsize=11)
    return fig


def caging_tip_figure(st: StoreData, rep_rows: list[dict], log) -> Figure:
    from .plot import draw_map_panel

    parts = caging_tip_parts(st)
    fig = Figure(figsize=(20, 4.8 * len(parts) + 1.0), dpi=100, layout="constrained")
    FigureCanvasAgg(fig)
    axes = fig.subplots(len(parts), 4, squeeze=False,
                        gridspec_kw=dict(width_ratios=[1.25, 1, 1, 1]))
    markers = {"caging focused": "o", "tip focused": "D", "compromise": "s"}
    for p, (ri, mi) in enumerate(parts):
        r, mu = float(st.r[ri]), float(st.mu[mi])
        caged = st.per_design("n_caged", ri, mi)
        tip = st.per_design("n_tip_prehension", ri, mi)
        ax = axes[p, 0]
        # How many designs share each (caged, tip) point: colour, since many coincide.
        pts, counts = np.unique(np.column_stack([caged, tip]), axis=0, return_counts=True)
        sc = ax.scatter(pts[:, 0], pts[:, 1], c=counts, cmap="viridis", norm="log", s=10,
                        linewidths=0, vmin=1, vmax=max(counts.max(), 2))
        cb = fig.colorbar(sc, ax=ax, pad=0.01, aspect=30)
        cb.set_label("designs at this point", fontsize=8)
        mine = [row for row in rep_rows if row["r"] == r and row["mu"] == mu]
        for row in mine:
            ax.scatter([row["n_caged"]], [row["n_tip_prehension"]], s=110,
                       marker=markers[row["kind"]], facecolors="none",
                       edgecolors=REPRESENTATIVE_COLOURS[row["kind"]], linewidths=2.2,
                       label=f"{row['kind']}: caged {row['n_caged']}, tip "
                             f"{row['n_tip_prehension']}", zorder=5)
        ax.set_xlabel("grid points whose trajectory ends caged (n_caged)")
        ax.set_ylabel("grid points ending in tip prehension (n_tip_prehension)")
        ax.set_title(f"part r={r:g}, μ={mu:g}: {caged.size} designs, one point each",
                     fontsize=10)
        ax.legend(fontsize=8, loc="best")
        ax.grid(alpha=0.3)
        for q, row in enumerate(mine):
            log(f"caging versus tip maps: part r = {r:g}, {row['kind']}")
            m = _compute_best_map(st, {d: row[d] for d in DESIGN_DIMS}, ri, mi)
            a = axes[p, q + 1]
            draw_map_panel(a, m, title=f"{row['kind']} (r={r:g}, μ={mu:g})\n"
                                       f"{_design_text(row)}\ncaged {row['n_caged']}, tip "
                                       f"{row['n_tip_prehension']}, Λ={fmt(row['Lambda'])}",
                           fontsize=8)
            for spine in a.spines.values():
                spine.set_edgecolor(REPRESENTATIVE_COLOURS[row["kind"]])
                spine.set_linewidth(2.5)
    fig.suptitle("Caging versus tip prehension per design, smallest and largest part at the "
                 "highest friction; three representative designs (rules in report.md) marked "
                 f"and drawn\n(energy V; hatching: equilibrium; pink: caged region; greys and tan: "
                 "outside P_j); "
                 f"{NOTE_UNITLESS}", fontsize=11)
    return fig


def _lattice_edges(v: np.ndarray, h: float) -> np.ndarray:
    return np.concatenate([v - 0.5 * h, [v[-1] + 0.5 * h]])


def manipulation_figure(st: StoreData, rows: list[dict], best: dict, part_row: int,
                        log) -> Figure:
    from .compute.batch import scenario_a_pose_values

    fig = Figure(figsize=(16, 13), dpi=100, layout="constrained")
    FigureCanvasAgg(fig)
    top, bottom = fig.subfigures(2, 1, height_ratios=[1, 1.15])
    ax = top.subplots()
    n = len(rows)
    xs = np.arange(n)
    a = np.array([row["a"] for row in rows])
    b = np.array([row["b"] for row in rows])
    positive = np.concatenate([a[a > 0], b[b > 0]])
    floor = positive.min() / 3 if positive.size else 1e-3
    cand = (f"l1={best['l1']:g} l2={best['l2']:g} r1={best['r1']:g} r2={best['r2']:g}")
    for off, vals, colour, label in ((-0.2, a, "#1f77b4", f"Scenario A, best candidate ({cand}"
                                      "; w and F_left/F_right varied)"),
                                     (0.2, b, "#d62728", "Scenario B (every geometry, "
                                      "F_left = F_right = 1)")):
        ax.bar(xs + off, np.where(vals > 0, vals, np.nan), width=0.4, color=colour,
               label=label)
        for x, v in zip(xs + off, vals):
            ax.text(x, max(v, floor), fmt(v), rotation=90, ha="center", va="bottom",
                    fontsize=7.5)
    ax.set_yscale("log")
    ax.set_ylim(floor, (positive.max() if positive.size else 1.0) * 30)
    ax.set_xticks(xs, [f"r={row['r']:g}\nμ={row['mu']:g}\n{row['winner']} wins"
                       if row["winner"] != "tie" else f"r={row['r']:g}\nμ={row['mu']:g}\ntie"
                       for row in rows], fontsize=8)
    ax.set_ylabel("manipulation metric: sum over poses of the inscribed-circle radius\n"
                  "(unitless, forces per unit tension × S_geo; log scale; 0 not drawn)")
    ax.set_xlabel("part (radius r, friction μ); which scenario has the larger metric")
    ax.legend(fontsize=9, loc="upper right")
    ax.grid(axis="y", alpha=0.3)
    top.suptitle("In-hand manipulation metric per part: Scenario A's best candidate versus "
                 "Scenario B (values printed)", fontsize=12)

    row = rows[part_row]
    ri = int(np.flatnonzero(st.r == row["r"])[0])
    mi = int(np.flatnonzero(st.mu == row["mu"])[0])
    log(f"Scenario A per-pose values: part r = {row['r']:g}, mu = {row['mu']:g}")
    sc = st.scene
    cand = tuple(best[d] for d in CANDIDATE_DIMS)
    xa, ya, va, metric = scenario_a_pose_values(cand, (row["r"], row["mu"]), sc.widths, sc.h,
                                                sc.limits, sc.accuracy, sc.effects)
    h = sc.h
    pv = st.ds["manipulation_b_pose_value"].isel(r=ri, mu=mi)
    vb = pv.values
    xb = pv["pose_column"].values * h
    yb = row["r"] + pv["pose_row"].values * h
    vmax = max(float(va.max()), float(vb.max()), 1e-12)
    axs = bottom.subplots(1, 2, sharex=True, sharey=True)
    mesh = None
    for axp, (x, y, v, name, total) in zip(axs, (
            (xa, ya, va, "Scenario A, best candidate", metric),
            (xb, yb, vb, "Scenario B", row["b"]))):
        shown = np.ma.masked_where(v <= 0, v)
        mesh = axp.pcolormesh(_lattice_edges(x, h), _lattice_edges(y, h), shown,
                              cmap="magma_r", vmin=0.0, vmax=vmax, shading="flat")
        axp.set_aspect("equal")
        axp.set_facecolor("#eeeeee")
        axp.set_xlabel("part centre x")
        axp.set_title(f"{name}: metric {fmt(total)}, {int((v > 0).sum())} poses with a "
                      "positive value", fontsize=10)
    axs[0].set_ylabel("part centre y")
    ext = [np.r_[xa[(va > 0).any(0)], xb[(vb > 0).any(0)]],
           np.r_[ya[(va > 0).any(1)], yb[(vb > 0).any(1)]]]
    if ext[0].size:
        axs[0].set_xlim(ext[0].min() - 4 * h, ext[0].max() + 4 * h)
        axs[0].set_ylim(min(0.0, ext[1].min() - 4 * h), ext[1].max() + 4 * h)
    cb = bottom.colorbar(mesh, ax=list(axs), shrink=0.8, pad=0.01)
    cb.set_label("pose value: radius of the largest origin-centred circle in the force hull "
                 "(unitless)", fontsize=9)
    bottom.suptitle(f"Per-pose values for part r={row['r']:g}, μ={row['mu']:g} (the part with "
                    "the largest min(A, B)); grey: value 0 (origin not strictly inside the "
                    f"hull) or no pose; {NOTE_UNITLESS}", fontsize=11)
    return fig


def draw_usage(ax, vals: np.ndarray, none: str):
    """Parameter usage (parts x PARAMETERS, NaN: no positive pose, written `none`) as a
    heatmap with its values printed; returns the image."""
    ax.set_facecolor("#dddddd")
    im = ax.imshow(np.ma.masked_invalid(vals), cmap="viridis", vmin=0.0, vmax=1.0,
                   aspect="auto")
    for i in range(vals.shape[0]):
        for j in range(vals.shape[1]):
            v = vals[i, j]
            ax.text(j, i, none if np.isnan(v) else f"{v:.2f}", ha="center", va="center",
                    fontsize=8, color="black" if np.isnan(v) or v > 0.6 else "white")
    ax.set_xticks(range(len(PARAMETERS)), PARAMETERS)
    return im


def usage_figure(rows: list[dict]) -> Figure:
    vals = np.array([[row[p] for p in PARAMETERS] for row in rows])
    fig = Figure(figsize=(7.5, 0.42 * len(rows) + 2.2), dpi=110, layout="constrained")
    FigureCanvasAgg(fig)
    ax = fig.subplots()
    im = draw_usage(ax, vals, "no positive pose")
    ax.set_yticks(range(len(rows)), [f"r={row['r']:g}, μ={row['mu']:g}" for row in rows],
                  fontsize=8)
    ax.set_xlabel("design parameter")
    ax.set_ylabel("part (radius r, friction μ)")
    cb = fig.colorbar(im, ax=ax, pad=0.02)
    cb.set_label("usage: spread among hull-vertex geometries / search range\n"
                 "(averaged over poses with a positive value; unitless, 0..1)", fontsize=8)
    ax.set_title("Scenario B parameter usage per part", fontsize=11)
    return fig


# ---------------------------------------------------------------------------------------------
# The report
# ---------------------------------------------------------------------------------------------
@dataclass
class Report:
    """Tables of a report (rows of plain values), as written."""

    best: list[dict]
    caging_tip: list[dict]
    representatives: list[dict]
    top_k: int | None = None
    candidates: list[dict] = field(default_factory=list)
    manipulation: list[dict] = field(default_factory=list)
    usage: list[dict] = field(default_factory=list)
    pose_part: dict | None = None
    files: list[str] = field(default_factory=list)


def identity(st: StoreData, top_k: int | None) -> dict:
    """What a report is made from; equal identities make a rerun a no-op."""
    a = st.attrs
    return dict(store=str(st.path.resolve()), config_hash=a.get("config_hash"),
                store_created_utc=a.get("created_utc"),
                store_refined_utc=a.get("refine_created_utc"), top_k=top_k,
                manipulation=st.manipulation, report_version=__version__)


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


def make_tables(st: StoreData, top_k: int | None) -> Report:
    rep = Report(best=best_caging_rows(st), caging_tip=caging_tip_rows(st),
                 representatives=representative_rows(st), top_k=top_k)
    if st.manipulation:
        rep.candidates = candidate_rows(st, top_k)
        best = next(c for c in rep.candidates if c["best"])
        rep.manipulation = manipulation_rows(st, best)
        rep.usage = usage_rows(st)
        rep.pose_part = rep.manipulation[pose_map_part(rep.manipulation)]
    return rep


def build_report(store: Path, out_dir: Path, top_k: int | None = None, log=lambda s: None,
                 st: StoreData | None = None) -> Report:
    """Write every file of the report into `out_dir` (atomically, one by one; `report.json`
    last, so a complete marker means a complete report)."""
    st = st or open_store(Path(store))
    top_k = resolve_top_k(st, top_k)
    rep = make_tables(st, top_k)
    write, finish = report_files(Path(out_dir), identity(st, top_k), rep.files)

    write("best_caging.csv", csv_bytes(rep.best, best_columns(st)))
    if st.refined:
        write("refinement.csv", csv_bytes(refinement_rows(rep.best), REFINEMENT_COLUMNS))
    write("caging_vs_tip.csv", csv_bytes(rep.caging_tip, CT_COLUMNS))
    write("representative_designs.csv", csv_bytes(rep.representatives, REP_COLUMNS))
    if st.manipulation:
        write("scenario_a_candidates.csv", csv_bytes(rep.candidates, CAND_COLUMNS))
        write("manipulation.csv", csv_bytes(rep.manipulation, MANIP_COLUMNS))
        write("parameter_usage.csv", csv_bytes(rep.usage, USAGE_COLUMNS))
        write("parameter_usage.png", _png(usage_figure(rep.usage)))
        best = next(c for c in rep.candidates if c["best"])
        write("manipulation.png", _png(manipulation_figure(
            st, rep.manipulation, best, rep.manipulation.index(rep.pose_part), log)))
    write("best_caging.png", _png(best_caging_figure(st, rep.best, log)))
    write("caging_vs_tip.png", _png(caging_tip_figure(st, rep.representatives, log)))
    write("report.md", text_bytes(markdown(st, rep)))
    finish()
    return rep


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
# report.md
# ---------------------------------------------------------------------------------------------
def _part(row) -> str:
    return f"r = {fmt(row['r'])}, mu = {fmt(row['mu'])}"


def _spread(values) -> str:
    vals = sorted(set(fmt(v) for v in values), key=float)
    return f"{len(vals)} distinct value{'s' if len(vals) != 1 else ''} ({', '.join(vals)})"


def reading(st: StoreData, rep: Report) -> list[str]:
    """The templated reading: every number from the tables."""
    out = []
    best = rep.best
    hi = max(best, key=lambda r: r["Lambda"])
    lo = min(best, key=lambda r: r["Lambda"])
    out.append(f"- Caging: the best Λ over the {len(best)} parts ranges from {fmt(lo['Lambda'])} "
               f"({_part(lo)}) to {fmt(hi['Lambda'])} ({_part(hi)}). The best designs use "
               f"transmission ratio R = r2/r1 with {_spread(r['R'] for r in best)} and palm "
               f"width w with {_spread(r['w'] for r in best)}. Ties for the best Λ (at "
               f"{TIE_DIGITS} "
               "significant digits): "
               f"{sum(r['n_tied'] > 1 for r in best)} of {len(best)} parts have more than one "
               f"best design (at most {max(r['n_tied'] for r in best)}). Caged points with "
               "crossed fingers (the base model lets fingers pass through each other) in the "
               f"best designs: {sum(r['n_caged_crossed'] for r in best)} of "
               f"{sum(r['n_caged_points'] for r in best)} caged points over all parts.")
    zero = [r for r in best if not r["Lambda"] > 0]
    if zero:
        out.append(f"- {len(zero)} part(s) have no design with a positive Λ: "
                   + "; ".join(_part(r) for r in zero) + ".")
    for (ri, mi) in caging_tip_parts(st):
        r, mu = float(st.r[ri]), float(st.mu[mi])
        caged = st.per_design("n_caged", ri, mi)
        tip = st.per_design("n_tip_prehension", ri, mi)
        reps = {row["kind"]: row for row in rep.representatives
                if row["r"] == r and row["mu"] == mu}
        both = int(np.count_nonzero((caged > 0) & (tip > 0)))
        corr = (float(np.corrcoef(caged, tip)[0, 1]) if caged.std() > 0 and tip.std() > 0
                else float("nan"))
        out.append(
            f"- Caging versus tip prehension, part r = {fmt(r)}, mu = {fmt(mu)}: "
            f"{int(np.count_nonzero(caged > 0))} of {caged.size} designs end some points "
            f"caged, {int(np.count_nonzero(tip > 0))} end some in tip prehension, {both} do "
            f"both; the correlation of the two counts over designs is {fmt(corr)}. The "
            f"caging-focused design has R = {fmt(reps['caging focused']['R'])} (caged "
            f"{reps['caging focused']['n_caged']}, tip "
            f"{reps['caging focused']['n_tip_prehension']}), the tip-focused one R = "
            f"{fmt(reps['tip focused']['R'])} (caged {reps['tip focused']['n_caged']}, tip "
            f"{reps['tip focused']['n_tip_prehension']}).")
    if not st.manipulation:
        return out
    best_c = next(c for c in rep.candidates if c["best"])
    rows = rep.manipulation
    n_b = sum(r["winner"] == "B" for r in rows)
    n_a = sum(r["winner"] == "A" for r in rows)
    n_t = sum(r["winner"] == "tie" for r in rows)
    sum_a, sum_b = sum(r["a"] for r in rows), sum(r["b"] for r in rows)
    crossed = sum(r["b"] - r["b_uncrossed"] for r in rows)
    out.append(
        f"- Manipulation: the best Scenario A candidate of {len(rep.candidates)} (top "
        f"{rep.top_k} caging designs of every part, merged) is l1 = {fmt(best_c['l1'])}, "
        f"l2 = {fmt(best_c['l2'])}, r1 = {fmt(best_c['r1'])}, r2 = {fmt(best_c['r2'])} "
        f"(R = {fmt(best_c['R'])}) with metric {fmt(best_c['a_sum'])} summed over parts, "
        f"positive on {best_c['parts_positive']} of {len(rows)} parts. Scenario B has the "
        f"larger metric on {n_b} parts, Scenario A on {n_a}, ties on {n_t}; summed over parts "
        f"A = {fmt(sum_a)} and B = {fmt(sum_b)}. Of B's total, {fmt(crossed)} "
        f"({fmt(100 * crossed / sum_b if sum_b > 0 else float('nan'))} %) comes from poses "
        "with crossed fingers (the base model lets fingers pass through each other).")
    for who in ("A", "B"):
        won = [r for r in rows if r["winner"] == who]
        if won:
            rs = ", ".join(sorted(set(fmt(r["r"]) for r in won), key=float))
            mus = ", ".join(sorted(set(fmt(r["mu"]) for r in won), key=float))
            out.append(f"- {who} wins on {len(won)} parts, with r in {{{rs}}} and mu in "
                       f"{{{mus}}}: " + "; ".join(_part(r) for r in won) + ".")
    b_by_r = {}
    for r in rows:
        b_by_r.setdefault(r["r"], []).append(r["b"])
    out.append("- Scenario B's metric summed over friction values, by part radius: "
               + ", ".join(f"r = {fmt(k)}: {fmt(sum(v))}" for k, v in sorted(b_by_r.items()))
               + ".")
    u = np.array([[row[p] for p in PARAMETERS] for row in rep.usage])
    ok = ~np.isnan(u).any(axis=1)
    if ok.any():
        mean = u[ok].mean(axis=0)
        order = np.argsort(-mean, kind="stable")
        out.append(
            f"- Parameter usage (Scenario B), mean over the {int(ok.sum())} parts with a "
            "positive pose: " + ", ".join(f"{PARAMETERS[i]} {fmt(mean[i])}" for i in order)
            + f". Most used: {PARAMETERS[order[0]]}; least used: {PARAMETERS[order[-1]]}. "
            f"w's usage is at least {fmt(u[ok, 0].min())} on every such part.")
    if (~ok).any():
        out.append(f"- {int((~ok).sum())} part(s) have no pose with a positive Scenario B value "
                   "(usage NaN): " + "; ".join(_part(rep.usage[i])
                                                for i in np.flatnonzero(~ok)) + ".")
    return out


def comparison(st: StoreData, rep: Report) -> list[str]:
    """Where the numbers meet or differ from what the paper says (its methods file states its
    claims in the abstract; it has no tables of results to compare with)."""
    a = st.attrs
    out = [f"- Run time: the paper computed its 86,400 maps in about 10 hours on 256 cores; this "
           f"store's {int(a.get('n_maps', 0)):,} maps took "
           f"{fmt(a.get('compute_seconds', math.nan))}"
           f" s of compute ({fmt(a.get('wall_seconds', math.nan))} s wall) on "
           f"{a.get('threads', '?')} thread(s)."]
    best = rep.best
    n_r = len(set(fmt(r["R"]) for r in best))
    out.append(
        "- The paper (abstract): \"a variable transmission ratio ... is needed to draw parts "
        "into a cage or to maintain a tip prehension grasp\". Here the best caging designs "
        f"use {n_r} different R over {len(best)} parts"
        + (", so no single R is best for every part, in line with the claim."
           if n_r > 1 else ", so one R is best for every part: this does not support the claim "
           "for caging alone.")
        + " Caging-focused versus tip-focused R per part: "
        + "; ".join(
            f"r = {fmt(r)}: {fmt(c['R'])} versus {fmt(t['R'])}"
            for r, c, t in (
                (row["r"], row,
                 next(x for x in rep.representatives if x["r"] == row["r"]
                      and x["mu"] == row["mu"] and x["kind"] == "tip focused"))
                for row in rep.representatives if row["kind"] == "caging focused"))
        + ".")
    if st.manipulation:
        u = np.array([[row[p] for p in PARAMETERS] for row in rep.usage])
        ok = ~np.isnan(u).any(axis=1)
        if ok.any():
            mean = u[ok].mean(axis=0)
            rank = int(np.flatnonzero(np.argsort(-mean, kind="stable") == 0)[0]) + 1
            out.append(
                "- The paper (abstract): \"a variable palm width is needed to manipulate parts "
                f"of varying scales\". Here w's mean usage is {fmt(mean[0])}, rank {rank} of 5 "
                "parameters" + (" (the most used), in line with the claim."
                                if rank == 1 else "; used more: " + ", ".join(
                                    f"{PARAMETERS[i]} ({fmt(mean[i])})"
                                    for i in np.argsort(-mean, kind="stable")[:rank - 1])
                                + "."))
        rows = rep.manipulation
        n_b = sum(r["winner"] == "B" for r in rows)
        out.append(
            "- The paper compares Scenario A's best design with Scenario B for all sixteen "
            "parts but its methods file states no outcome. Here B (variable geometry, fixed "
            f"tension) wins on {n_b} of {len(rows)} parts. The paper's metric scales each force "
            "by the caging score; this model uses S_geo (the score without the stability "
            "requirement, MODEL 10), since S vanishes out of equilibrium: the two are not the "
            "same number.")
    return out


def markdown(st: StoreData, rep: Report) -> str:
    a = st.attrs
    sc = st.scene
    L = [f"# Report: {a.get('name')} ({st.path.name})", ""]
    L.append(f"Store `{st.path}`, config `{str(a.get('config_hash'))[:12]}`, written "
             f"{a.get('created_utc')} by sweep {a.get('sweep_version')}; report by sweep "
             f"{__version__}.")
    L.append("")
    L.append("## Settings")
    L.append("")
    L += ["- Designs: " + "; ".join(f"{d} = {', '.join(fmt(v) for v in st.ds[d].values)}"
                                     for d in DESIGN_DIMS),
          f"- Parts: r = {', '.join(fmt(v) for v in st.r)}; mu = "
          f"{', '.join(fmt(v) for v in st.mu)}",
          f"- Command: F_left = {fmt(sc.commands[0].f_left)}, F_right = "
          f"{fmt(sc.commands[0].f_right)}; grid h = {fmt(sc.h)} ({sc.bounds}); theta2 limits "
          f"[{fmt(sc.limits.theta2_min_deg)}, {fmt(sc.limits.theta2_max_deg)}] deg; "
          f"reconfig_step {fmt(sc.accuracy.reconfig_step)}, root_tol "
          f"{fmt(sc.accuracy.root_tol)}, trajectory {sc.accuracy.trajectory}",
          f"- Effects on: {a.get('effects_on')}",
          f"- Maps: {int(a.get('n_maps', 0)):,}; run time: compute "
          f"{fmt(a.get('compute_seconds', math.nan))} s, wall "
          f"{fmt(a.get('wall_seconds', math.nan))}"
          f" s, {a.get('threads', '?')} thread(s)",
          "- Manipulation metric: "
          + (f"yes; Scenario A top-k = {rep.top_k} (store attribute "
             f"manipulation_scenario_a_top_k = {a.get('manipulation_scenario_a_top_k')})"
             if st.manipulation else
             "**not in this store** (config option `outputs: {manipulation: true}` was not set):"
             " the manipulation and parameter-usage parts are skipped"),
          "- All quantities are unitless (model units: lengths, tensions and forces per unit "
          "tendon tension)."]
    if st.refined:
        counts = json.loads(a["refine_counts"]) if isinstance(a.get("refine_counts"), str) \
            else a.get("refine_counts", {})
        L.append(f"- Refinement: up to {a.get('refine_levels')} levels (h down to "
                 f"{fmt(sc.h / 2 ** int(a.get('refine_levels', 0)))}), contender bound per "
                 f"part at most {fmt(a.get('refine_bound'))} of the best screened caging area, "
                 f"at least {a.get('refine_min_contenders')} contenders; "
                 f"{counts.get('certified', 0)} "
                 f"parts certified, {counts.get('near_tie', 0)} near-tie sets, "
                 f"{counts.get('not_refined', 0)} not refined; compute "
                 f"{fmt(a.get('refine_compute_seconds', math.nan))} s "
                 f"({fmt(100 * a.get('refine_fraction_of_screening', math.nan))} % of the "
                 "screening's)")
    L += ["", "## Rules", ""]
    if st.refined:
        L += ["- Best caging design of a part (refined store): the screening ranks every design "
              "by its caging area at h; the contenders (the min_contenders best, and every "
              "design the change of those from h to h/2 says could still be the best, at most "
              "those within the bound of the part's best; equal-R designs, same l1, l2, w and "
              "R, give the same map and count once, `tied`) are "
              "recomputed at h/2, h/4, ..., and a contender leaves the running once its value "
              "plus its error estimate (its change from the level before) falls below the best's "
              "value minus the best's error estimate. **Certification:** a part is certified "
              "when the best design's lead over every other contender exceeds the change "
              "between the last two levels of both, so that a finer grid is not expected to "
              "change it; at the level cap the designs still in the running are the part's "
              "near-tie set, each reported with its value and error estimate.",
              "- *Bound not confirmed*: the contender bound is checked per part; it held when the "
              "best's refined value minus its error exceeds every other design's screened value "
              "plus the largest change any contender showed from screening to its finest level. "
              "Where it did not, a design left out by the bound could be the best (raise "
              "`refine.bound`)."]
    L += ["- Best caging design of a part" + (" that is not refined" if st.refined else "")
          + ": largest Λ over (l1, l2, r1, r2, w); ties are "
          "expected (configurations depend on the radii only through R = r2/r1), broken by the "
          "first design in store order (l1, l2, r1, r2, w, last fastest); `tied` counts the "
          f"designs with that Λ. Λ is compared at {TIE_DIGITS} significant digits: equal-R "
          "designs sum the same scores in another order, which changes the last bits.",
          "- Caging versus tip prehension: the smallest and the largest part radius at the "
          "highest friction. Representative designs: *caging focused* = most caged end points "
          "(n_caged), fewer tip-prehension end points breaking ties; *tip focused* = most "
          "tip-prehension end points, fewer caged breaking ties; *compromise* = largest "
          "min(n_caged / the part's largest n_caged, n_tip / the part's largest n_tip), then "
          "the largest sum of the two fractions; remaining ties by store order.",
          "- The maps drawn are recomputed with `compute_map` at the store's settings; the "
          "gripper is drawn at the caged end point that contributes most to Λ (else the "
          "stable point of lowest energy, else the centre of P_j)."]
    if st.manipulation:
        L += ["- Scenario A candidates: the (l1, l2, r1, r2) of the top-k caging designs (by Λ, "
              "store order among ties; in a refined store by the refined ranking: the final set, "
              "then the other contenders, then the rest, each by caging area at the finest h "
              "reached) of every part, duplicates merged. Best candidate: the "
              "largest Scenario A metric summed over all parts (first in store order among "
              f"ties; both compared at {TIE_DIGITS} significant digits). Per part, the "
              "scenario with the larger metric wins; equal metrics are a "
              "tie.",
              "- Per-pose maps: the part with the largest min(A, B) of the best candidate's A "
              "and B, so that both maps show something (first in table order among ties)."]
    L += ["", "## 1. Best caging design per part (`best_caging.png`, `best_caging.csv`)", "",
          md_table(rep.best, best_columns(st),
                   [{"n_tied": "tied"}.get(c, c) for c in best_columns(st)])]
    if st.refined:
        L += ["", "Columns Lambda to tied are the screening's (grid h above); refined_caging_area "
              "and refined_error are at finest_h; margin is the best's lead over the runner-up "
              "there. Each part's final set (`refinement.csv`: the certified design, or every "
              "member of the near-tie set with its value and error estimate):", ""]
        for row in rep.best:
            if row["certification"] == "not refined":
                L.append(f"- {_part(row)}: not refined (no design cages at the screening "
                         "spacing).")
                continue
            L.append(f"- {_part(row)}: {row['certification']} at h = {fmt(row['finest_h'])}: "
                     + "; ".join(f"{_design_text(m)} {fmt(m['refined_caging_area'])} ± "
                                 f"{fmt(m['refined_error'])}" for m in row["near_tie"]) + ".")
    L += ["", "## 2. Caging versus tip prehension (`caging_vs_tip.png`, "
          "`representative_designs.csv`; every design's counts in `caging_vs_tip.csv`)", "",
          md_table(rep.representatives, REP_COLUMNS)]
    if st.manipulation:
        best_c = next(c for c in rep.candidates if c["best"])
        L += ["", "## 3. In-hand manipulation (`manipulation.png`, `manipulation.csv`, "
              "`scenario_a_candidates.csv`)", "",
              f"Best Scenario A candidate of {len(rep.candidates)}: l1 = {fmt(best_c['l1'])}, "
              f"l2 = {fmt(best_c['l2'])}, r1 = {fmt(best_c['r1'])}, r2 = {fmt(best_c['r2'])}; "
              f"metric summed over parts {fmt(best_c['a_sum'])} (times h^2: "
              f"{fmt(best_c['a_area_sum'])}).", "",
              "A and B per part (a, b: metric; *_area: times h^2; b_uncrossed: B without "
              "crossed-finger poses; b_poses: poses with a positive B value):", "",
              md_table(rep.manipulation, MANIP_COLUMNS), "",
              f"Per-pose maps drawn for part {_part(rep.pose_part)}.", "",
              "Candidates, largest summed metric first (at most 20 here; all in the CSV):", "",
              md_table(sorted(rep.candidates, key=lambda c: -c["a_sum"])[:20], CAND_COLUMNS),
              "", "## 4. Parameter usage, Scenario B (`parameter_usage.png`, "
              "`parameter_usage.csv`)", "",
              md_table(rep.usage, USAGE_COLUMNS)]
    else:
        L += ["", "## 3, 4. Manipulation and parameter usage", "",
              "Skipped: this store has no manipulation variables. Rerun the sweep with "
              "`outputs: {manipulation: true}` in its config."]
    L += ["", "## Reading", ""] + reading(st, rep)
    L += ["", "## Compared with the paper", ""] + comparison(st, rep)
    L.append("")
    return "\n".join(L)
