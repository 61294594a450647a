"""What accuracy costs in time, judged against a converged reference (MODEL 8,
docs/accuracy.md).

The study, in order:

1. *Default sweep.* Every map of the config at its own settings (the sweep's shared-field path),
   to find each part's best design (largest caging area, ties to the first design in config
   order).
2. *Sample* (deterministic): the cells (l1, l2, r1, r2) of a Halton sequence over the four
   axes' value indices (bases 2, 3, 5, 7; points 1..N; every cell when N is at least the number
   of cells), plus the cell of every part's best design; each sampled cell with every palm width
   and every part.
3. *Ladder*: one axis varied at a time from the config's setting: h in {2h, h, h/2, h/4};
   reconfig_step from 0.2 to 0.002 rad; root_tol from 1e-3 to 1e-12; every trajectory method.
   *Reference*: one halving finer than the finest rung, h/8, with reconfig_step 0.002,
   root_tol 1e-12 and the default trajectory method. *The reference's own convergence*: the same
   settings at h/4 (one halving coarser) against the reference: caging-area error and top-1.
4. *Metrics* per setting, against the reference: seconds per map (and projected for the whole
   config), caging-area error (median, worst), top-1 agreement, top-5 overlap, Kendall tau.
   Caging area (Lambda h^2), not Lambda, is compared: Lambda grows as 1/h^2.
5. *Convergence* of each trajectory method as h halves (h, h/2, h/4, h/8 at the config's other
   settings) on a smaller fixed sample: each part's best cell at the config's setting with every
   palm width, plus any maps named with `--map`: the caging area summed over the sample, its
   change from the previous h, and the stalled share (stalled starts / reached points).

Ties: under equal tensions only R = r2/r1 matters, so designs that differ only in the scale of
(r1, r2) tie exactly. Two scores tie when they differ by at most TIE_REL times the larger. A
part's top-1 agrees when some design tied for best under the setting is also tied for best in
the reference. Top-5 overlap counts the setting's five best designs whose reference score
reaches the reference's fifth-best score (minus the tie tolerance).

Resumable: each finished step is written to its own file in the work directory (temporary name,
then renamed); a rerun with the same config and sample skips them.
"""
from __future__ import annotations

import csv
import hashlib
import itertools
import json
import math
import os
import time
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from .batch import summarize_cells
from .model import TRAJECTORY_METHODS, Accuracy, ModelInputError
from .outputs import write_bytes_atomic, write_text_atomic
from .scene import Scene
from .schema import SUMMARY_FIELDS

CAGING_AREA = SUMMARY_FIELDS.index("caging_area")
# Summary columns the convergence study keeps per map.
CONVERGENCE_FIELDS = ("caging_area", "n_stalled", "n_reached", "n_caged")
CONVERGENCE_COLUMNS = [SUMMARY_FIELDS.index(k) for k in CONVERGENCE_FIELDS]
# Halvings of h in the convergence study: h, h/2, h/4, h/8.
CONVERGENCE_HALVINGS = 4
TIE_REL = 1e-9
DEFAULT_SAMPLE = 24
HALTON_BASES = (2, 3, 5, 7)
RECONFIG_LADDER = (0.2, 0.1, 0.05, 0.02, 0.01, 0.005, 0.002)
ROOT_TOL_LADDER = (1e-3, 1e-6, 1e-9, 1e-12)
REFERENCE_STEP, REFERENCE_TOL = 0.002, 1e-12
# A setting replaces the config's own only when measured this much cheaper: timings of one
# setting vary by about 10% from run to run on a shared machine (docs/performance.md).
MIN_SAVING = 0.10
CELL_AXES = ("l1", "l2", "r1", "r2")


@dataclass(frozen=True)
class Setting:
    """One rung of the ladder: the axis it varies and the full accuracy it runs at."""

    axis: str          # "h", "reconfig_step", "root_tol", "trajectory", "reference" or
    #                    "reference/2" (the reference's settings one halving coarser)
    h: float
    accuracy: Accuracy

    @property
    def key(self) -> str:
        a = self.accuracy
        return (f"h{self.h:.6g}_s{a.reconfig_step:.6g}_t{a.root_tol:.3g}_{a.trajectory}")

    @property
    def label(self) -> str:
        a = self.accuracy
        return {"h": f"h = {self.h:g}", "reconfig_step": f"reconfig_step = {a.reconfig_step:g}",
                "root_tol": f"root_tol = {a.root_tol:g}", "trajectory": a.trajectory,
                "reference": f"reference (h = {self.h:g})",
                "reference/2": f"reference at h = {self.h:g}"}[self.axis]


def halton(index: int, base: int) -> float:
    """The index-th element (index >= 1) of the van der Corput sequence in `base`."""
    f, x = 1.0, 0.0
    while index > 0:
        f /= base
        x += f * (index % base)
        index //= base
    return x


def ladder(scene: Scene) -> tuple[list[Setting], Setting]:
    """The settings of the study (one axis at a time from the config's) and the reference."""
    h0, a0 = scene.h, scene.accuracy
    out: list[Setting] = []
    for h in (2 * h0, h0, h0 / 2, h0 / 4):
        out.append(Setting("h", h, a0))
    for s in RECONFIG_LADDER:
        out.append(Setting("reconfig_step", h0, replace(a0, reconfig_step=s)))
    for t in ROOT_TOL_LADDER:
        out.append(Setting("root_tol", h0, replace(a0, root_tol=t)))
    for m in TRAJECTORY_METHODS:
        out.append(Setting("trajectory", h0, replace(a0, trajectory=m)))
    reference, _ = references(scene)
    return out, reference


def references(scene: Scene) -> tuple[Setting, Setting]:
    """The reference, one halving finer than the finest rung of the ladder (h/8), and the same
    settings one halving coarser (h/4), which shows whether the reference has converged."""
    acc = Accuracy(REFERENCE_STEP, REFERENCE_TOL, Accuracy.trajectory)
    return (Setting("reference", scene.h / 8, acc), Setting("reference/2", scene.h / 4, acc))


def is_default(setting: Setting, scene: Scene) -> bool:
    return setting.h == scene.h and setting.accuracy == scene.accuracy


# ---------------------------------------------------------------------------------------------
# Maps of a set of cells at one setting
# ---------------------------------------------------------------------------------------------
def design_cells(scene: Scene) -> np.ndarray:
    """Every (l1, l2, r1, r2) of the config, in config order: float64 (n, 4)."""
    return np.array(list(itertools.product(*(scene.values[a] for a in CELL_AXES))),
                    dtype=np.float64).reshape(-1, 4)


def parts(scene: Scene) -> list[tuple[float, float, int]]:
    """Every part (r, mu) under every command, in config order."""
    return [(r, mu, c) for r in scene.values["r"] for mu in scene.values["mu"]
            for c in range(len(scene.commands))]


def caging_areas(scene: Scene, cells4: np.ndarray, h: float, accuracy: Accuracy) -> np.ndarray:
    """Caging area of every map (cell, width, part): float64 (n_cells, n_w, n_parts)."""
    ps = parts(scene)
    out = np.empty((cells4.shape[0], scene.widths.size, len(ps)))
    for k, (r, mu, c) in enumerate(ps):
        cells = np.column_stack([cells4, np.full(len(cells4), r), np.full(len(cells4), mu)])
        rows = summarize_cells(cells, scene.widths, scene.commands[c], h, scene.limits, accuracy,
                               scene.effects)
        out[:, :, k] = rows[:, :, CAGING_AREA]
    return out


def save_atomic(path: Path, **arrays) -> None:
    import io

    buf = io.BytesIO()
    np.savez(buf, **arrays)
    write_bytes_atomic(path, buf.getvalue())


def cached(path: Path, compute) -> dict:
    """The arrays in `path`, or compute them (a dict), save them atomically and return them."""
    if path.exists():
        with np.load(path) as z:
            return {k: z[k] for k in z.files}
    arrays = compute()
    save_atomic(path, **arrays)
    return arrays


def timed_areas(scene: Scene, cells4: np.ndarray, setting: Setting) -> dict:
    # one cell first, untimed: loads (or compiles) the kernels this setting's path needs
    caging_areas(scene, cells4[:1], setting.h, setting.accuracy)
    started = time.perf_counter()
    areas = caging_areas(scene, cells4, setting.h, setting.accuracy)
    return dict(caging_area=areas, seconds=np.array(time.perf_counter() - started))


# ---------------------------------------------------------------------------------------------
# Sample
# ---------------------------------------------------------------------------------------------
def best_designs(areas: np.ndarray) -> np.ndarray:
    """Per part, the flat (cell, width) index of the best design (first of the tied ones)."""
    flat = areas.reshape(-1, areas.shape[-1])
    return np.array([tied_best(flat[:, k])[0] for k in range(flat.shape[1])], dtype=np.int64)


def sample_cells(scene: Scene, n_sample: int, default_areas: np.ndarray) -> np.ndarray:
    """Indices into design_cells(scene) of the sample: Halton points 1..n_sample over the four
    axes' value indices, then each part's default best cell; sorted, without repeats. A sample
    at least as large as the config's cells is every cell (without walking n_sample points)."""
    lens = [len(scene.values[a]) for a in CELL_AXES]
    if n_sample >= int(np.prod(lens)):
        return np.arange(int(np.prod(lens)), dtype=np.int64)
    chosen = []
    for n in range(1, n_sample + 1):
        idx = [min(int(halton(n, b) * m), m - 1) for b, m in zip(HALTON_BASES, lens)]
        chosen.append(int(np.ravel_multi_index(idx, lens)))
    n_w = scene.widths.size
    chosen += [int(b) // n_w for b in best_designs(default_areas)]
    return np.array(sorted(set(chosen)), dtype=np.int64)


# ---------------------------------------------------------------------------------------------
# Metrics
# ---------------------------------------------------------------------------------------------
def tie_tol(values: np.ndarray) -> float:
    return TIE_REL * max(1.0, float(np.max(np.abs(values)))) if values.size else 0.0


def tied_best(values: np.ndarray) -> np.ndarray:
    """Indices tied for the largest value (TIE_REL), in order."""
    return np.flatnonzero(values >= values.max() - tie_tol(values))


def top1_agrees(values: np.ndarray, reference: np.ndarray) -> bool:
    return bool(np.intersect1d(tied_best(values), tied_best(reference)).size)


def top5_overlap(values: np.ndarray, reference: np.ndarray, k: int = 5) -> float:
    k = min(k, values.size)
    mine = np.argsort(-values, kind="stable")[:k]
    kth = np.sort(reference)[::-1][k - 1]
    return float(np.sum(reference[mine] >= kth - tie_tol(reference))) / k


def kendall_tau(values: np.ndarray, reference: np.ndarray) -> float:
    """Kendall tau-b; 1 when both rankings are all ties (they agree), NaN-free."""
    from scipy.stats import kendalltau

    if np.ptp(values) == 0 and np.ptp(reference) == 0:
        return 1.0
    tau = kendalltau(values, reference).statistic
    return float(tau) if math.isfinite(tau) else 0.0


def metrics(areas: np.ndarray, reference: np.ndarray) -> dict:
    """Errors and ranking agreement of a setting's caging areas against the reference's, both
    (cells, widths, parts)."""
    err = np.abs(areas - reference).ravel()
    n_parts = areas.shape[-1]
    a = areas.reshape(-1, n_parts)
    r = reference.reshape(-1, n_parts)
    top1 = [top1_agrees(a[:, k], r[:, k]) for k in range(n_parts)]
    return dict(median_error=float(np.median(err)), worst_error=float(np.max(err)),
                top1_agreement=float(np.mean(top1)), n_parts_agree=int(np.sum(top1)),
                top5_overlap=float(np.mean([top5_overlap(a[:, k], r[:, k])
                                            for k in range(n_parts)])),
                kendall_tau=float(np.mean([kendall_tau(a[:, k], r[:, k])
                                           for k in range(n_parts)])))


# ---------------------------------------------------------------------------------------------
# The study
# ---------------------------------------------------------------------------------------------
@dataclass
class Study:
    scene: Scene
    n_sample: int
    sample: np.ndarray          # indices into design_cells
    n_maps_sample: int
    rows: list                  # one dict per setting (the ladder, then the references)
    reference: Setting
    recommended: dict
    seconds_default_sweep: float
    seconds_steps: float        # compute time of every step, summed from the work files
    best: list                  # per part: (part, best design at config / recommended / reference)
    convergence: list = field(default_factory=list)  # one dict per (method, h): sample sums
    witnesses: list = field(default_factory=list)    # one dict per (witness map, method, h)
    n_maps_convergence: int = 0
    refinement: list = field(default_factory=list)   # per part: the refined answer vs reference
    refinement_cost: dict = field(default_factory=dict)


@dataclass(frozen=True)
class Witness:
    """A map named on the command line (`--map`): its convergence is shown on its own."""

    l1: float
    l2: float
    r1: float
    r2: float
    w: float
    r: float
    mu: float

    @property
    def label(self) -> str:
        return (f"l1={self.l1:g} l2={self.l2:g} r1={self.r1:g} r2={self.r2:g} w={self.w:g}, "
                f"r={self.r:g} mu={self.mu:g}")


def check_sample(n_sample) -> None:
    if not (isinstance(n_sample, int) and n_sample >= 1):
        raise ModelInputError(f"--sample must be a whole number >= 1, got {n_sample!r}")


def parse_witness(text: str) -> Witness:
    """'L1,L2,R1,R2,W,R,MU' -> Witness, validated like any map's inputs (ModelInputError)."""
    from .model import Command, Design, Limits, Part, validate_inputs

    try:
        values = [float(v) for v in text.split(",")]
    except ValueError:
        values = []
    if len(values) != 7:
        raise ModelInputError(f"--map takes seven numbers L1,L2,R1,R2,W,R,MU, got {text!r}")
    wit = Witness(*values)
    validate_inputs(Design(wit.l1, wit.l2, wit.r1, wit.r2, wit.w), Part(wit.r, wit.mu),
                    Command(), Limits(), Accuracy())
    return wit


def work_dir_key(scene: Scene, n_sample: int) -> str:
    """Work files belong to one problem (the resolved config without its accuracy settings) and
    one sample size. Every file in it names the settings it ran at (`Setting.key`) and, where
    it depends on the sample, the sample (`sample_key`): a study rerun after a change of the
    config's accuracy settings alone recomputes only what those settings change (the reference
    and the ladder's other rungs are reused)."""
    problem = {k: v for k, v in scene.resolved().items() if k != "accuracy"}
    text = json.dumps(problem, sort_keys=True, separators=(",", ":"))
    return hashlib.sha256(f"{text}:{n_sample}".encode()).hexdigest()[:16]


def sample_key(sample: np.ndarray) -> str:
    """The sample's identity in its work files' names (the sample follows from the default
    sweep, hence from the config's accuracy settings)."""
    return hashlib.sha256(np.asarray(sample, dtype=np.int64).tobytes()).hexdigest()[:12]


def convergence_groups(scene: Scene, default_areas: np.ndarray, witnesses) -> list:
    """The convergence sample as groups of maps that share a cell and a part: each part's best
    cell at the config's setting with every palm width, then every witness (its own width).
    Each group: (cell (l1, l2, r1, r2), widths, r, mu, command index, witness or None)."""
    cells = design_cells(scene)
    n_w = scene.widths.size
    groups = []
    for k, (r, mu, c) in enumerate(parts(scene)):
        cell = cells[int(best_designs(default_areas)[k]) // n_w]
        groups.append((tuple(cell), tuple(scene.widths), r, mu, c, None))
    for wit in witnesses:
        groups.append(((wit.l1, wit.l2, wit.r1, wit.r2), (wit.w,), wit.r, wit.mu, 0, wit))
    return groups


def convergence_summaries(scene: Scene, groups: list, h: float, accuracy: Accuracy) -> dict:
    """CONVERGENCE_FIELDS of every map of the groups at one setting: (n_maps, 4), in order."""
    def run(sel):
        out = []
        for cell, widths, r, mu, c, _ in sel:
            rows = summarize_cells(np.array([[*cell, r, mu]]), np.array(widths),
                                   scene.commands[c], h, scene.limits, accuracy, scene.effects)
            out.append(rows[0][:, CONVERGENCE_COLUMNS])
        return np.concatenate(out)

    run(groups[:1])  # loads (or compiles) the kernels of this setting: untimed
    started = time.perf_counter()
    values = run(groups)
    return dict(values=values, seconds=np.array(time.perf_counter() - started))


def run_convergence(scene: Scene, groups: list, work: Path, progress=None) -> tuple[list, list]:
    """Per trajectory method and h (CONVERGENCE_HALVINGS halvings of the config's h): the sample
    sums (caging area, its change from the previous h, stalled and caged shares) and the same
    per witness map."""
    key = hashlib.sha256(repr([g[:5] for g in groups]).encode()).hexdigest()[:12]
    n_maps = sum(len(g[1]) for g in groups)
    witness_rows = [n for n, g in enumerate(groups) if g[5] is not None]
    # each witness group holds one map, the last maps of the sample
    first_witness = n_maps - len(witness_rows)
    rows, wit_rows = [], []
    for method in TRAJECTORY_METHODS:
        previous = None
        for n in range(CONVERGENCE_HALVINGS):
            h = scene.h / 2 ** n
            acc = replace(scene.accuracy, trajectory=method)
            res = cached(work / f"convergence-{key}-{Setting('h', h, acc).key}.npz",
                         lambda h=h, acc=acc: convergence_summaries(scene, groups, h, acc))
            v = res["values"]
            area, stalled, reached, caged = (float(v[:, i].sum()) for i in range(4))
            rows.append(dict(method=method, h=h, caging_area=area,
                             change=None if previous is None else abs(area - previous),
                             stalled_share=stalled / reached if reached else 0.0,
                             caged_share=caged / reached if reached else 0.0,
                             seconds_per_map=float(res["seconds"]) / n_maps))
            previous = area
            for m, g in enumerate(groups[len(groups) - len(witness_rows):]):
                a, st, re, ca = v[first_witness + m]
                wit_rows.append(dict(witness=g[5].label, method=method, h=h,
                                     caging_area=float(a), stalled=int(st), reached=int(re),
                                     stalled_share=float(st / re) if re else 0.0))
            if progress:
                progress(f"convergence {method} h = {h:g}")
    return rows, wit_rows


def run_study(scene: Scene, n_sample: int, work: Path, progress=None, witnesses=()) -> Study:
    """Run (or resume) the study; `progress(done, total, label)` is told after each step."""
    check_sample(n_sample)
    work.mkdir(parents=True, exist_ok=True)
    settings, _ = ladder(scene)
    reference, reference_coarse = references(scene)
    total = (len(settings) + 3 + len(TRAJECTORY_METHODS) * CONVERGENCE_HALVINGS
             + (scene.refine is not None))
    all_cells = design_cells(scene)
    default = Setting("default", scene.h, scene.accuracy)
    full = cached(work / f"default_sweep-{default.key}.npz",
                  lambda: timed_areas(scene, all_cells, default))
    done = [1]

    def tell(label):
        done[0] += 1
        if progress:
            progress(done[0], total, label)

    if progress:
        progress(1, total, "default sweep")
    sample = sample_cells(scene, n_sample, full["caging_area"])
    cells4 = all_cells[sample]
    sampled = sample_key(sample)
    n_maps = cells4.shape[0] * scene.widths.size * len(parts(scene))
    results = {}
    for s in [reference, reference_coarse] + settings:
        results[s.key] = cached(work / f"{s.key}-{sampled}.npz",
                                lambda s=s: timed_areas(scene, cells4, s))
        tell(s.label)
    ref = results[reference.key]["caging_area"]
    rows = []
    for s in settings + [reference_coarse, reference]:
        res = results[s.key]
        per_map = float(res["seconds"]) / n_maps
        row = dict(axis=s.axis, setting=s.label, h=s.h,
                   reconfig_step=s.accuracy.reconfig_step, root_tol=s.accuracy.root_tol,
                   trajectory=s.accuracy.trajectory, default=is_default(s, scene),
                   seconds_per_map=per_map, projected_seconds=per_map * scene.n_maps)
        row.update(metrics(res["caging_area"], ref))
        rows.append(row)
    rec = recommend(rows)
    rec_setting = next(s for s in settings + [reference_coarse, reference]
                       if s.label == rec["setting"] and s.axis == rec["axis"])
    cells_w = [(tuple(c), w) for c in cells4 for w in scene.widths]
    best = []
    for k, part in enumerate(parts(scene)):
        picks = []
        for s in (default, rec_setting, reference):
            key = Setting("h", scene.h, scene.accuracy).key if s is default else s.key
            flat = results[key]["caging_area"].reshape(-1, len(parts(scene)))[:, k]
            picks.append(cells_w[int(tied_best(flat)[0])])
        best.append((part, *picks))
    groups = convergence_groups(scene, full["caging_area"], witnesses)
    convergence, witness_rows = run_convergence(scene, groups, work, tell)
    refined, refine_cost = [], {}
    if scene.refine is not None:
        config_rung = results[Setting("h", scene.h, scene.accuracy).key]
        refined, refine_cost = refined_against_reference(
            scene, cells4, config_rung, results[reference.key]["caging_area"],
            work / f"refine-{default.key}-{sampled}")
        tell("refinement of the sample")
    seconds = float(full["seconds"]) + sum(float(v["seconds"]) for v in results.values())
    seconds += sum(r["seconds_per_map"] for r in convergence) * sum(len(g[1]) for g in groups)
    seconds += refine_cost.get("seconds", 0.0)
    return Study(scene, n_sample, sample, n_maps, rows, reference, rec, float(full["seconds"]),
                 seconds, best, convergence, witness_rows, sum(len(g[1]) for g in groups),
                 refined, refine_cost)


def refined_against_reference(scene: Scene, cells4: np.ndarray, screening: dict,
                              reference: np.ndarray, work: Path) -> tuple[list, dict]:
    """The config's refinement stage (`refine:`) run on the sample's designs from the config's
    own screening of them, and its answer per part against the reference's best: *agrees*
    (certified, and the reference's best), *contains* (a near-tie set that holds it), or
    *differs*. Cost: the sample's screening and each refinement level, in seconds."""
    from .refine import ROLE, refine_designs

    designs = np.array([[*c, w] for c in cells4 for w in scene.widths], dtype=np.float64)
    n_parts = len(parts(scene))
    screened = screening["caging_area"].reshape(-1, n_parts)
    ref = reference.reshape(-1, n_parts)
    out = refine_designs(scene, designs, screened, scene.refine, work)
    rows = []
    for k, part in enumerate(parts(scene)):
        role = out.role[:, k]
        final = np.flatnonzero(role >= ROLE["near_tie"])
        best = np.flatnonzero(role == ROLE["best"])
        truth = tied_best(ref[:, k])
        certified = bool(out.status[k] == 1)
        if not final.size:
            verdict = "not refined"
        elif np.intersect1d(best if certified else final, truth).size:
            verdict = "agrees" if certified else "contains"
        else:
            verdict = "differs"
        rows.append(dict(part=part, status="certified" if certified else
                         (f"near-tie ({len(np.unique(out.reps[final]))})" if final.size
                          else "not refined"),
                         finest_h=float(out.finest_h()[k]),
                         best=tuple(designs[best[0]]) if best.size else None,
                         reference=tuple(designs[truth[0]]), verdict=verdict))
    cost = dict(screening_seconds=float(screening["seconds"]),
                level_maps=list(out.level_maps), level_seconds=list(out.level_seconds),
                seconds=out.seconds)
    return rows, cost


def recommend(rows: list) -> dict:
    """The cheapest setting whose best design equals the reference's for every part sampled;
    the config's own setting unless another is at least MIN_SAVING cheaper. Where no setting
    cheaper than the reference agrees, the reference itself."""
    agreeing = [r for r in rows if r["axis"] != "reference" and r["top1_agreement"] == 1.0]
    if not agreeing:
        return next(r for r in rows if r["axis"] == "reference")
    default = next(r for r in rows if r["default"])
    cheapest = min(agreeing, key=lambda r: r["seconds_per_map"])
    if default in agreeing and cheapest["seconds_per_map"] > (1 - MIN_SAVING) * \
            default["seconds_per_map"]:
        return default
    return cheapest


# ---------------------------------------------------------------------------------------------
# Outputs: CSV, markdown, plot
# ---------------------------------------------------------------------------------------------
COLUMNS = ("axis", "setting", "h", "reconfig_step", "root_tol", "trajectory", "default",
           "seconds_per_map", "projected_seconds", "median_error", "worst_error",
           "top1_agreement", "n_parts_agree", "top5_overlap", "kendall_tau")


def csv_text(study: Study) -> str:
    import io

    buf = io.StringIO()
    w = csv.DictWriter(buf, fieldnames=COLUMNS + ("recommended",), lineterminator="\n")
    w.writeheader()
    for r in study.rows:
        w.writerow({**{k: r[k] for k in COLUMNS}, "recommended": r is study.recommended})
    return buf.getvalue()


def _duration(seconds: float) -> str:
    return f"{seconds:.1f} s" if seconds < 120 else f"{seconds / 60:.1f} min"


def _fmt_change(value) -> str:
    return "" if value is None else f"{value:.4g}"


def convergence_lines(study: Study) -> list[str]:
    """The convergence section: per trajectory method, the sample's caging area and stalled
    share as h halves; then the witness maps."""
    if not study.convergence:
        return []
    lines = [
        "## Convergence as h halves",
        "",
        f"Sample: each part's best cell at the config's setting with every palm width"
        f"{' plus the maps named with --map' if study.witnesses else ''} = "
        f"{study.n_maps_convergence} maps; every trajectory method at the config's other "
        "settings. Caging area summed over the sample; change = |area - area at 2h|; stalled "
        "share = stalled starts / reached points.",
        "",
        "| method | h | caging area (sum) | change from 2h | stalled share | caged share | s/map |",
        "|---|---|---|---|---|---|---|",
    ]
    for r in study.convergence:
        lines.append(f"| {r['method']} | {r['h']:g} | {r['caging_area']:.4f} | "
                     f"{_fmt_change(r['change'])} | {r['stalled_share']:.4f} | "
                     f"{r['caged_share']:.4f} | {r['seconds_per_map'] * 1e3:.2f} ms |")
    if study.witnesses:
        lines += ["", "Maps named with `--map`:", "",
                  "| map | method | h | caging area | stalled / reached |", "|---|---|---|---|---|"]
        for w in study.witnesses:
            lines.append(f"| {w['witness']} | {w['method']} | {w['h']:g} | "
                         f"{w['caging_area']:.4f} | {w['stalled']} / {w['reached']} "
                         f"({w['stalled_share']:.4f}) |")
    lines += ["", "![caging area and stalled share versus h](convergence.png)", ""]
    return lines


def markdown(study: Study, command_line: str, wall_seconds: float) -> str:
    sc = study.scene
    rec = study.recommended
    n_parts = len(parts(sc))
    lines = [
        f"# Accuracy versus time: `{sc.name}`",
        "",
        f"Generated by `{command_line}`: its steps took {_duration(study.seconds_steps)} of "
        f"wall time in all (summed from the work files, so a resumed study counts every run "
        f"that contributed); this invocation {_duration(wall_seconds)}. Config hash "
        f"{sc.config_hash[:12]}, {os.cpu_count()} cores.",
        "",
        f"Sample: {len(study.sample)} cells (l1, l2, r1, r2) = {study.n_sample} Halton points "
        f"plus each part's best cell at the config's setting, x {sc.widths.size} palm widths x "
        f"{n_parts} parts = {study.n_maps_sample} maps per setting (of {sc.n_maps:,} in the "
        f"config). The config's setting ran on all its maps in "
        f"{_duration(study.seconds_default_sweep)} to find each part's best design.",
        "",
        f"Reference: h = {study.reference.h:g} (one halving finer than the finest rung), "
        f"reconfig_step = {REFERENCE_STEP:g}, root_tol = {REFERENCE_TOL:g}, "
        f"{study.reference.accuracy.trajectory}. {reference_convergence(study)} Errors are "
        "absolute caging-area errors "
        "(Lambda h^2) against it; top-1 is the fraction of parts whose best design agrees "
        "(ties count as agreement); top-5 the mean overlap of the five best; tau the mean Kendall "
        "tau-b over parts. Time per map is this machine's wall time (shared with other jobs: "
        "pessimistic); projected = time per map x maps in the config.",
        "",
        "| axis | setting | s/map | projected | median err | worst err | top-1 | top-5 | tau |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for r in study.rows:
        name = r["setting"] + (" (config)" if r["default"] else "")
        if r is rec:
            name = f"**{name} (recommended)**"
        lines.append(
            f"| {r['axis']} | {name} | {r['seconds_per_map'] * 1e3:.2f} ms | "
            f"{_duration(r['projected_seconds'])} | {r['median_error']:.3g} | "
            f"{r['worst_error']:.3g} | {r['n_parts_agree']}/{n_parts} | {r['top5_overlap']:.2f} | "
            f"{r['kendall_tau']:.3f} |")

    def design(cw):
        (l1, l2, r1, r2), w = cw
        return f"l1={l1:g} l2={l2:g} r1={r1:g} r2={r2:g} w={w:g}"

    lines += ["", "Best design per part in the sample (first of the tied ones, config order):",
              "", "| r | mu | command | config's setting | recommended | reference |",
              "|---|---|---|---|---|---|"]
    for (r, mu, c), at_default, at_rec, at_ref in study.best:
        lines.append(f"| {r:g} | {mu:g} | {c} | {design(at_default)} | {design(at_rec)} | "
                     f"{design(at_ref)} |")
    lines += [
        "",
        f"**Recommended**: {rec['setting']} (h = {rec['h']:g}, reconfig_step = "
        f"{rec['reconfig_step']:g}, root_tol = {rec['root_tol']:g}, {rec['trajectory']}): the "
        "cheapest setting whose best design equals the reference's for every part sampled (the "
        f"config's own setting is kept unless another is at least {MIN_SAVING:.0%} cheaper; "
        "where no cheaper setting agrees, the reference's own)."
        + (" No setting cheaper than the reference agrees with it on every part."
           if rec["axis"] == "reference" else ""),
        "",
        "![error and top-1 agreement versus time](accuracy.png)",
        "",
    ]
    lines += convergence_lines(study)
    lines += refinement_lines(study)
    return "\n".join(lines)


def refinement_lines(study: Study) -> list[str]:
    """The config's refinement stage on the sample, against the reference."""
    if not study.refinement:
        return []
    sc, cost = study.scene, study.refinement_cost
    ref = sc.refine

    def design(d):
        return "-" if d is None else " ".join(
            f"{k}={v:g}" for k, v in zip(("l1", "l2", "r1", "r2", "w"), d))

    lines = [
        "## The refinement stage on the sample",
        "",
        f"The config's `refine:` (levels {ref.levels}, bound {ref.bound:g}, min_contenders "
        f"{ref.min_contenders}; docs/sweeps.md, \"Refinement\") run on the sample's "
        f"{study.n_maps_sample // len(parts(sc))} designs from the config's own screening of "
        "them, its answer per part against the reference's best design: *agrees* (certified, "
        "and the reference's best), *contains* (a near-tie set that holds the reference's "
        "best), *differs*.",
        "",
        "| r | mu | command | refined answer | finest h | refined best | reference best | "
        "verdict |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for row in study.refinement:
        r, mu, c = row["part"]
        lines.append(f"| {r:g} | {mu:g} | {c} | {row['status']} | {row['finest_h']:g} | "
                     f"{design(row['best'])} | {design(row['reference'])} | {row['verdict']} |")
    verdicts = [row["verdict"] for row in study.refinement]
    per_level = ", ".join(f"level {k + 1} (h = {sc.h / 2 ** (k + 1):g}): {n} maps, "
                          f"{_duration(t)}" for k, (n, t) in
                          enumerate(zip(cost["level_maps"], cost["level_seconds"])))
    lines += [
        "",
        f"{verdicts.count('agrees')} parts agree, {verdicts.count('contains')} are near-tie "
        f"sets that contain the reference's best, {verdicts.count('differs')} differ. Cost on "
        f"the sample: screening {_duration(cost['screening_seconds'])}; refinement "
        f"{_duration(cost['seconds'])} ({per_level}), "
        f"{cost['seconds'] / max(cost['screening_seconds'], 1e-12):.0%} of the screening. "
        "(The whole config's figures, where the screening covers every design: "
        "docs/performance.md.)",
        "",
    ]
    return lines


def reference_convergence(study: Study) -> str:
    """One sentence: the reference against its own settings one halving coarser."""
    coarse = next((r for r in study.rows if r["axis"] == "reference/2"), None)
    if coarse is None:
        return ""
    n_parts = len(parts(study.scene))
    return (f"Has the reference converged? The same settings one halving coarser "
            f"(h = {coarse['h']:g}) agree with it on the best design of "
            f"{coarse['n_parts_agree']}/{n_parts} parts, with caging-area errors of "
            f"{coarse['median_error']:.3g} (median) and {coarse['worst_error']:.3g} (worst).")


def plot(study: Study, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.ticker
    import matplotlib.pyplot as plt

    rows = [r for r in study.rows if not r["axis"].startswith("reference")]
    fig, (ax1, ax2) = plt.subplots(2, 1, figsize=(7, 7), sharex=True)
    markers = {"h": "o", "reconfig_step": "s", "root_tol": "^", "trajectory": "D"}
    floor = 1e-16  # zero errors drawn at the floor of the log axis
    for axis, marker in markers.items():
        sel = [r for r in rows if r["axis"] == axis]
        t = [r["seconds_per_map"] for r in sel]
        ax1.scatter(t, [max(r["median_error"], floor) for r in sel], marker=marker, label=axis)
        ax2.scatter(t, [r["top1_agreement"] for r in sel], marker=marker, label=axis)
    rec = study.recommended
    for ax, y in ((ax1, max(rec["median_error"], floor)), (ax2, rec["top1_agreement"])):
        ax.scatter([rec["seconds_per_map"]], [y], s=250, facecolors="none", edgecolors="red",
                   linewidths=2, label="recommended")
    ax1.set_xscale("log")
    ax2.xaxis.set_minor_formatter(matplotlib.ticker.NullFormatter())  # overlapping labels
    ax1.set_yscale("log")
    ax2.set_ylim(-0.05, 1.05)
    ax1.set_ylabel("median caging-area error")
    ax2.set_ylabel("top-1 agreement (fraction of parts)")
    ax2.set_xlabel("seconds per map")
    ax1.legend(fontsize=8)
    ax1.set_title(f"Accuracy versus time: {study.scene.name}")
    fig.tight_layout()
    save_figure(fig, path)


def save_figure(fig, path: Path) -> None:
    import io

    import matplotlib.pyplot as plt

    buf = io.BytesIO()
    fig.savefig(buf, dpi=110, format="png")
    plt.close(fig)
    write_bytes_atomic(path, buf.getvalue())


def plot_convergence(study: Study, path: Path) -> None:
    """Caging area (sample sum) and stalled share versus h, one line per trajectory method."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (ax1, ax2) = plt.subplots(2, 1, figsize=(7, 7), sharex=True)
    for method in TRAJECTORY_METHODS:
        sel = [r for r in study.convergence if r["method"] == method]
        hs = [r["h"] for r in sel]
        ax1.plot(hs, [r["caging_area"] for r in sel], marker="o", label=method)
        ax2.plot(hs, [r["stalled_share"] for r in sel], marker="o", label=method)
    ax1.set_xscale("log")
    ax1.invert_xaxis()  # finer to the right
    ax1.set_ylabel("caging area, summed over the sample")
    ax2.set_ylabel("stalled share (stalled / reached)")
    ax2.set_xlabel("grid spacing h")
    ax1.legend(fontsize=8)
    ax1.set_title(f"Convergence as h halves: {study.scene.name} "
                  f"({study.n_maps_convergence} maps)")
    fig.tight_layout()
    save_figure(fig, path)


def write_outputs(study: Study, out: Path, command_line: str, wall_seconds: float) -> list[Path]:
    out.mkdir(parents=True, exist_ok=True)
    md, cs, png = out / "accuracy.md", out / "accuracy.csv", out / "accuracy.png"
    write_text_atomic(md, markdown(study, command_line, wall_seconds))
    write_text_atomic(cs, csv_text(study))
    plot(study, png)
    written = [md, cs, png]
    if study.convergence:
        plot_convergence(study, out / "convergence.png")
        write_text_atomic(out / "convergence.csv", convergence_csv(study))
        written += [out / "convergence.png", out / "convergence.csv"]
    write_text_atomic(out / "sample.json", json.dumps(
        dict(config_hash=study.scene.config_hash, n_sample=study.n_sample,
             cells=design_cells(study.scene)[study.sample].tolist()), indent=1))
    return written


def convergence_csv(study: Study) -> str:
    import io

    buf = io.StringIO()
    cols = ("method", "h", "caging_area", "change", "stalled_share", "caged_share",
            "seconds_per_map")
    w = csv.DictWriter(buf, fieldnames=cols, lineterminator="\n")
    w.writeheader()
    for r in study.convergence:
        w.writerow({k: ("" if r[k] is None else r[k]) for k in cols})
    return buf.getvalue()
