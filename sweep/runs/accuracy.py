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

import hashlib
import json
import math
import time
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from ..compute.batch import summarize_cells
from ..model import TRAJECTORY_METHODS, Accuracy, ModelInputError
from ..files import write_bytes_atomic
from ..config.scene import Scene
from ..schema import SUMMARY_FIELDS
from ..storage.refined import ROLE
from .study import (CELL_AXES, MIN_SAVING, REFERENCE_STEP, REFERENCE_TOL, Setting, Study,  # noqa: F401
                    design_cells, parts)

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
    from ..model import Command, Design, Limits, Part, validate_inputs

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


def run_study(scene: Scene, n_sample: int, work: Path, progress=None, witnesses=(),
              refine_designs=None) -> Study:
    """Run (or resume) the study; `progress(done, total, label)` is told after each step.
    `refine_designs` is the refinement stage (`sweep.runs.refine.refine_designs`), which a
    config with `refine:` needs; the caller passes it, so that the orchestration modules stay
    siblings that do not import each other (tests/test_layers.py)."""
    if scene.refine is not None and refine_designs is None:
        raise TypeError("run_study: a config with refine: needs refine_designs")
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
            work / f"refine-{default.key}-{sampled}", refine_designs)
        tell("refinement of the sample")
    seconds = float(full["seconds"]) + sum(float(v["seconds"]) for v in results.values())
    seconds += sum(r["seconds_per_map"] for r in convergence) * sum(len(g[1]) for g in groups)
    seconds += refine_cost.get("seconds", 0.0)
    return Study(scene, n_sample, sample, n_maps, rows, reference, rec, float(full["seconds"]),
                 seconds, best, convergence, witness_rows, sum(len(g[1]) for g in groups),
                 refined, refine_cost)


def refined_against_reference(scene: Scene, cells4: np.ndarray, screening: dict,
                              reference: np.ndarray, work: Path,
                              refine_designs) -> tuple[list, dict]:
    """The config's refinement stage (`refine:`) run on the sample's designs from the config's
    own screening of them, and its answer per part against the reference's best: *agrees*
    (certified, and the reference's best), *contains* (a near-tie set that holds it), or
    *differs*. Cost: the sample's screening and each refinement level, in seconds."""
    designs = np.array([[*c, w] for c in cells4 for w in scene.widths], dtype=np.float64)
    n_parts = len(parts(scene))
    screened = screening["caging_area"].reshape(-1, n_parts)
    ref = reference.reshape(-1, n_parts)
    out = refine_designs(scene, designs, screened, scene.refine, work)
    rows = []
    for k, part in enumerate(parts(scene)):
        role = out.role[:, k]
        final = np.flatnonzero((role == ROLE["near_tie"]) | (role == ROLE["best"]))
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
