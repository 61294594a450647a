"""The best design between the grid's points, certified against the grid's best
(docs/optimisation.md; `sweep optimize`).

Per part (r, mu), with the store's config (command, limits, accuracy, effects):

1. *Seeds.* The store's best design G (the refinement's certified design, else the first of its
   near-tie set; the screened best in a store not refined) and the next distinct grid designs of
   the part's ranking (equal-R classes once), `n_seeds` in all.
2. *Search at h* (the store's spacing): differential evolution over the free parameters of the
   stated box, the seeds in its initial population (`search.evolve`), for `de_share` of the
   part's `evaluations`; then a compass search (`search.pattern_search`) from each of `starts`
   starts (evolution's best, then the seeds in rank order) until its steps reach the noise
   (`min_steps`: the map's spacing h for lengths, an eighth of the grid's step for the pulley
   radii) or the evaluations are spent. Every map goes through `MapScores` (one computation
   per design class, part and h; journalled, so a killed run resumes).
3. *Fidelity ladder.* The distinct ends of the searches (the finalists) and G are recomputed at
   h/2, h/4, ... (`levels`) as the refinement recomputes its contenders: at level k a value's
   error estimate is its change from level k-1, and a finalist stays while its value plus error
   reaches the best's value minus the best's error (`refine.separated`); G and the best finalist
   are computed at every level. x* is the best finalist at the finest level.
4. *Verdict* at the finest level: d = value(x*) - value(G), u = error(x*) + error(G); "x* beats G
   by d +- u" when d > u (the refinement's separation), else "no design found beats G beyond the
   error".
5. *Constraints at x*:* each bound, fixed value or length budget x* is on, with the change of a
   step inwards (into the box) and of a step outwards (what relaxing it would give) at the
   finest level. A bound whose outward step gains more than x*'s error *binds*: the box, not the
   physics, limits this part ("box-limited").
6. *Robustness* (at h/2): the caging area over the manufacturing tolerance box (each of the five
   parameters +- `tolerance`: the 2^5 corners and the centre; min and median), and at friction
   mu +- `friction_change`, for x* and for G.

One gripper for several parts (`objective` 'worst' or 'mean'): the score of a design is the
worst (or mean) over the parts of its caging area relative to that part's own optimum x*'s, at
h; the same search (seeded with every part's x* and G), then each part's value at h/2 with its
error and its loss against its own optimum.
"""
from __future__ import annotations

import hashlib
import itertools
import math
import shutil
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .. import __version__
from ..compute.threads import numba_threads
from ..config.parse import scene_from_frozen
from ..config.scene import DESIGN_KEYS, Scene
from ..files import claim_output
from ..storage.optimized import (CONSTRAINTS, OptimizedPart, OneGripper, read_identity,
                                 write_optimization)
from ..storage.refined import equal_r_classes, ranking
from ..storage.store import read_store
from .evaluations import MapScores, class_key
from .refine import prepare_work_dir, screened_matrix, separated
from .search import PARAMS, Box, BudgetSpent, distinct, evolve, multi_start, pattern_search

OBJECTIVES = ("worst", "mean")


@dataclass(frozen=True)
class OptimizeSettings:
    """How `sweep optimize` searches and certifies (module docstring)."""

    evaluations: int = 1500          # maps per part at the search spacing h
    seed: int = 0
    n_seeds: int = 8                 # grid designs seeded: G and the next distinct ones
    starts: int = 4                  # compass searches (multi-start)
    popsize_per_parameter: int = 8   # differential evolution's population per free parameter
    de_share: float = 0.6            # of `evaluations` spent by differential evolution
    levels: int = 2                  # the ladder: h/2 .. h/2**levels
    tolerance: float = 0.01          # manufacturing tolerance of each parameter (model units)
    friction_change: float = 0.1     # robustness in mu: mu +- this
    objective: str | None = None     # 'worst' | 'mean': one gripper for every part
    joint_evaluations: int = 300     # designs scored by the one-gripper search (each: all parts)

    def as_dict(self) -> dict:
        return dict(self.__dict__)


def grid_steps(scene: Scene) -> np.ndarray:
    """Per parameter the grid's step (the smallest gap between its values; a tenth of the
    value for a parameter with one value): the compass search's first step."""
    out = []
    for k in DESIGN_KEYS:
        v = np.asarray(scene.values[k], float)
        out.append(float(np.min(np.diff(v))) if v.size > 1 else max(0.1 * abs(v[0]), 0.01))
    return np.array(out)


def min_steps(scene: Scene, box: Box) -> np.ndarray:
    """The compass search's smallest step per parameter, above the score's noise: a length
    moved by less than the map's spacing h moves the part's lattice by less than a grid point,
    so the map's spacing for l1, l2, w; an eighth of the grid's step for r1, r2 (they act
    through R); never below the box's resolution."""
    lengths = np.array([1.0, 1.0, 0.0, 0.0, 1.0]) * scene.h
    return np.maximum(np.maximum(lengths, grid_steps(scene) / 8 * (lengths == 0)),
                      box.resolution)


def default_box(scene: Scene, bounds: dict | None = None, fixed: dict | None = None,
                length_budget: float | None = None, resolution: float = 1e-3) -> Box:
    """The store's design box (each parameter from its smallest to its largest grid value),
    with `bounds` {name: (lower, upper)} replacing some, `fixed` {name: value}, a budget."""
    lo = [float(min(scene.values[k])) for k in DESIGN_KEYS]
    hi = [float(max(scene.values[k])) for k in DESIGN_KEYS]
    for k, (a, b) in (bounds or {}).items():
        i = PARAMS.index(k)
        lo[i], hi[i] = float(a), float(b)
    return Box(tuple(lo), tuple(hi), dict(fixed or {}), length_budget, resolution)


# ---------------------------------------------------------------------------------------------
# What the store says about a part
# ---------------------------------------------------------------------------------------------
@dataclass
class GridBest:
    """A part's best grid design and seeds, from the store."""

    design: np.ndarray           # G (5,)
    seeds: np.ndarray            # (k, 5): G first, then the next distinct grid designs
    value: float                 # G's refined caging area (the screened one if not refined)
    error: float                 # its error estimate (NaN if not refined)
    h: float                     # the spacing of that value
    status: str                  # certified | near_tie | not_refined | screened


def grid_best(view, scene: Scene, ri: int, mui: int, n_seeds: int) -> GridBest:
    """G and the seeds of part (r index, mu index), command 0 (module docstring, step 1)."""
    from ..schema import REFINE_STATUS_MEANINGS
    from .refine import design_table

    designs = design_table(scene)
    reps = equal_r_classes(designs)
    screened = screened_matrix(scene, view.variables["caging_area"])
    n_cmd = len(scene.commands)
    p = (ri * len(scene.values["mu"]) + mui) * n_cmd
    ref = view.refine
    if ref and "refine_role" in ref:
        per_design = {k: np.asarray(ref[k]).reshape(designs.shape[0], -1)[:, p]
                      for k in ("refine_role", "refined_caging_area", "refined_error",
                                "refined_level")}
        order = ranking(per_design["refine_role"], per_design["refined_caging_area"],
                        screened[:, p])
        b = int(order[0])
        status_code = int(np.asarray(ref["refine_status"]).reshape(-1)[p])
        status = REFINE_STATUS_MEANINGS[status_code]
        level = int(per_design["refined_level"][b])
        value = float(per_design["refined_caging_area"][b])
        if math.isnan(value):
            value, level = float(screened[b, p]), 0
        error = float(per_design["refined_error"][b])
        h = scene.h / 2.0 ** level
    else:
        order = np.argsort(-screened[:, p], kind="stable")
        b, status = int(order[0]), "screened"
        value, error, h = float(screened[b, p]), math.nan, scene.h
    seen, seeds = set(), []
    for d in order:
        if reps[d] in seen:
            continue
        seen.add(reps[d])
        seeds.append(designs[d])
        if len(seeds) >= n_seeds:
            break
    return GridBest(designs[b].copy(), np.array(seeds), value, error, h, status)


# ---------------------------------------------------------------------------------------------
# One part
# ---------------------------------------------------------------------------------------------
def level_h(h: float, k: int) -> float:
    return h / 2.0 ** k


def ladder(area, finalists: list, g: np.ndarray, h: float, levels: int):
    """Step 3: values (n+1, levels+1) of the finalists and G (last row) at h .. h/2**levels
    (NaN where not computed), the index of x* among the finalists, the finest level where x*
    and G were both computed."""
    designs = list(finalists) + [g]
    n = len(finalists)
    values = np.full((n + 1, levels + 1), np.nan)
    values[:, 0] = [area(d, h) for d in designs]
    alive = list(range(n + 1))
    leader = int(np.argmax(values[:n, 0]))
    for k in range(1, levels + 1):
        todo = sorted(set(alive) | {leader, n})
        for i in todo:
            values[i, k] = area(designs[i], level_h(h, k))
        idx = np.array(todo)
        err = np.abs(values[idx, k] - values[idx, k - 1])
        _, keep = separated(values[idx, k], err)
        alive = [int(i) for i in idx[keep]]
        search = [i for i in todo if i < n]
        leader = max(search, key=lambda i: (values[i, k], -i))
    return values, leader, levels


def _err(values: np.ndarray, k: int) -> float:
    return float(abs(values[k] - values[k - 1])) if k >= 1 else math.nan


def constraint_changes(area, box: Box, x: np.ndarray, steps: np.ndarray, h: float,
                       base: float) -> dict:
    """Step 5: per active constraint of x (CONSTRAINTS) its side and the changes of the caging
    area (at h) for a step inwards and a step outwards (NaN when the model does not accept the
    stepped design). {name: (side, inward, outward)}."""
    out = {}
    # rounded to the resolution, never clipped: a clip would move w = 0 (and its steps below
    # 0) to a small positive width, so every change at such an x* would be another design's
    loose = Box(tuple(np.full(5, -np.inf)), tuple(np.full(5, np.inf)), {}, None,
                box.resolution)
    for name, side in box.active(x).items():
        if name == "length_budget":
            s = steps[0]
            moves = [(-s / 2, -s / 2), (s / 2, s / 2)]
            stepped = []
            for a, b in moves:
                y = x.copy()
                y[0] += a
                y[1] += b
                stepped.append(y)
        else:
            i = PARAMS.index(name)
            sign = {"lower": 1.0, "upper": -1.0, "fixed": -1.0}[side]
            stepped = []
            for direction in (sign, -sign):
                y = x.copy()
                y[i] += direction * steps[i]
                stepped.append(y)
        changes = []
        for y in stepped:
            y = loose.feasible(y)
            ok = y[4] >= 0 and np.all(y[:4] > 0)
            changes.append(area(y, h) - base if ok else math.nan)
        out[name] = (side, changes[0], changes[1])
    return out


def tolerance_box(x: np.ndarray, tol: float) -> list:
    """The centre and the 2^5 corners of x +- tol, kept valid (radii positive, w >= 0)."""
    out = [x.copy()]
    for signs in itertools.product((-1.0, 1.0), repeat=5):
        y = x + tol * np.array(signs)
        y[:4] = np.maximum(y[:4], 1e-3)
        y[4] = max(y[4], 0.0)
        out.append(np.round(y, 12))
    return out


def optimise_part(scores: MapScores, scene: Scene, box: Box, r: float, mu: float,
                  best: GridBest, s: OptimizeSettings) -> OptimizedPart:
    """Steps 2-6 for one part."""
    h = scene.h
    used: set = set()        # every map the part asked for (computed now or before a kill)

    def area(d, hh=h, m=mu):
        used.add(class_key(d, r, m, hh))
        return scores.area(d, r, m, hh)

    budget = s.evaluations
    seen: set = set()        # the designs the search asked for (a rerun asks the same)

    def score(d):
        key = class_key(d, r, mu, h)
        if key not in seen:
            if len(seen) >= budget:
                raise BudgetSpent()
            seen.add(key)
        return area(d)

    free = box.free
    steps, smallest = grid_steps(scene), min_steps(scene, box)
    trace, ends = multi_start(score, box, best.seeds, s.seed,
                              s.popsize_per_parameter * max(len(free), 1),
                              lambda: len(seen) >= int(s.de_share * budget), s.starts, steps,
                              smallest)
    seeds = [box.feasible(d) for d in best.seeds]
    end_designs = np.array([t.best for t in ends])
    end_values = np.array([t.value for t in ends])
    candidates = sorted(ends, key=lambda t: -t.value)
    if trace.best is not None:
        candidates.append(trace)
    finalists = distinct([t.best for t in candidates if np.isfinite(t.value)])[:s.starts + 1]
    values, xi, top = ladder(area, finalists, best.design, h, s.levels)
    x = finalists[xi]
    vx, vg = values[xi], values[-1]
    ex, eg = _err(vx, top), _err(vg, top)
    d, u = float(vx[top] - vg[top]), ex + eg
    hf = level_h(h, top)
    active = constraint_changes(lambda y, hh: area(y, hh), box, x, smallest, hf, float(vx[top]))
    hr = level_h(h, min(1, s.levels))
    robust = {}
    for name, y in (("x_star", x), ("grid_best", best.design)):
        t = [area(c, hr) for c in tolerance_box(y, s.tolerance)]
        fr = []
        for dmu in (-s.friction_change, s.friction_change):
            m = mu + dmu
            fr.append(area(y, hr, m) if m >= 0 else math.nan)
        robust[name] = (float(np.min(t)), float(np.median(t)), t[0], fr)
    return OptimizedPart(
        r=r, mu=mu, x_star=x, grid_best=best.design, x_values=vx, g_values=vg, finest_level=top,
        x_error=ex, g_error=eg, difference=d, uncertainty=u, beats=bool(d > u),
        store_value=best.value, store_error=best.error, store_h=best.h, store_status=best.status,
        seeds=np.array(seeds), seed_values=np.array([area(sd) for sd in seeds]),
        start_designs=end_designs, start_values=end_values, de_value=trace.value,
        finalists=np.array(finalists), finalist_values=values[:-1],
        constraints={k: active.get(k, ("", math.nan, math.nan)) for k in CONSTRAINTS},
        steps=smallest, robust=robust, search_maps=len(seen),
        maps=len(used), seconds=float(sum(scores.seconds[k] for k in used)))


# ---------------------------------------------------------------------------------------------
# One gripper for several parts
# ---------------------------------------------------------------------------------------------
def optimise_joint(scores: MapScores, scene: Scene, box: Box, parts: list,
                   s: OptimizeSettings) -> OneGripper:
    """One design for every part of `parts` (OptimizedPart each): maximise the worst (or mean)
    caging area relative to each part's own optimum, at h (module docstring)."""
    h = scene.h
    own = np.array([scores.area(p.x_star, p.r, p.mu, h) for p in parts])
    use = own > 0
    seen: set = set()
    used: set = set()

    def area(d, p, hh):
        used.add(class_key(d, p.r, p.mu, hh))
        return scores.area(d, p.r, p.mu, hh)

    def relative(d, hh=h):
        return np.array([area(d, p, hh) for p in parts]) / np.where(use, own, 1)

    def combine(rel):
        rel = rel[use]
        if not rel.size:
            return 0.0
        return float(rel.min() if s.objective == "worst" else rel.mean())

    def score(d):
        key = tuple(np.round(d, 9))
        if key not in seen:
            if len(seen) >= s.joint_evaluations:
                raise BudgetSpent()
            seen.add(key)
        return combine(relative(d))

    seeds = [p.x_star for p in parts] + [p.grid_best for p in parts]
    free = box.free
    trace = evolve(score, box, np.array(seeds), s.seed, s.popsize_per_parameter * len(free),
                   lambda: len(seen) >= int(s.de_share * s.joint_evaluations))
    start = trace.best if trace.best is not None else box.feasible(seeds[0])
    end = pattern_search(score, box, start, grid_steps(scene), min_steps(scene, box))
    x = end.best
    h1 = level_h(h, 1)
    at_h = np.array([area(x, p, h) for p in parts])
    at_h1 = np.array([area(x, p, h1) for p in parts])
    own_h1 = np.array([area(p.x_star, p, h1) for p in parts])
    loss = np.where(own_h1 > 0, 1.0 - at_h1 / np.where(own_h1 > 0, own_h1, 1), np.nan)
    rel_h1 = np.where(own_h1 > 0, at_h1 / np.where(own_h1 > 0, own_h1, 1), np.nan)
    return OneGripper(objective=s.objective, design=x, score=end.value,
                      score_fine=combine(np.nan_to_num(rel_h1)), values=at_h, values_fine=at_h1,
                      errors=np.abs(at_h1 - at_h), own_fine=own_h1, loss=loss,
                      designs_scored=len(seen), maps=len(used),
                      seconds=float(sum(scores.seconds[k] for k in used)),
                      constraints=dict(box.active(x)))


# ---------------------------------------------------------------------------------------------
# A store
# ---------------------------------------------------------------------------------------------
def work_path(out: Path) -> Path:
    out = Path(out)
    return out.with_name(out.name + ".work")


@dataclass
class OptimizeResult:
    path: Path
    already_done: bool
    wall_seconds: float
    computed: int = 0
    parts: list = field(default_factory=list)


def identity(view, scene: Scene, box: Box, parts: list, s: OptimizeSettings) -> dict:
    """What decides the results: the store (its config and its refined values), the box, the
    parts, the settings, the version. A results file or work directory of another identity is
    made again."""
    ref = view.refine.get("refined_caging_area")
    digest = hashlib.sha256(np.ascontiguousarray(view.variables["caging_area"]).tobytes())
    if ref is not None:
        digest.update(np.ascontiguousarray(ref).tobytes())
    return dict(config_hash=scene.config_hash, store_sha256=digest.hexdigest(),
                box=dict(lower=list(box.lower), upper=list(box.upper), fixed=box.fixed,
                         length_budget=box.length_budget, resolution=box.resolution),
                parts=[[float(r), float(m)] for r, m in parts], settings=s.as_dict(),
                sweep_version=__version__)


def optimize_store(store: Path, out: Path, parts: list, box: Box, s: OptimizeSettings,
                   threads: int | None = None, progress: bool = True,
                   restart: bool = False) -> OptimizeResult:
    """Optimise the parts `parts` ((r, mu) values of the store) of `store`; results into `out`
    (atomically; a file of the same identity is left alone), resuming from `out`.work/."""
    t0 = time.perf_counter()
    out = Path(out)
    with claim_output(out, overwrite=True):
        view = read_store(store)
        scene = scene_from_frozen(view.frozen)
        ident = identity(view, scene, box, parts, s)
        if out.exists() and read_identity(out) == ident:
            return OptimizeResult(out, True, time.perf_counter() - t0)
        work = work_path(out)
        if restart:
            shutil.rmtree(work, ignore_errors=True)
        prepare_work_dir(work, ident)
        r_vals, mu_vals = list(scene.values["r"]), list(scene.values["mu"])
        bar = _progress(len(parts) * s.evaluations, progress)
        scores = MapScores(scene, work, on_compute=bar.update)
        results = []
        try:
            with numba_threads(threads):
                for r, mu in parts:
                    best = grid_best(view, scene, r_vals.index(r), mu_vals.index(mu), s.n_seeds)
                    bar.set_description(f"optimize r={r:g} mu={mu:g}")
                    results.append(optimise_part(scores, scene, box, r, mu, best, s))
                    scores.save()
                joint = None
                if s.objective and len(results) > 1:
                    bar.set_description(f"one gripper ({s.objective})")
                    joint = optimise_joint(scores, scene, box, results, s)
                    scores.save()
        finally:
            bar.close()
        wall = time.perf_counter() - t0
        write_optimization(out, store, scene, ident, box, s, results, joint, scores.table(),
                           dict(wall_seconds=wall, computed_maps=scores.computed))
        shutil.rmtree(work, ignore_errors=True)
    return OptimizeResult(out, False, wall, scores.computed, results)


def _progress(total: int, enabled: bool):
    from tqdm import tqdm

    tty = sys.stderr.isatty()
    return tqdm(total=total, desc="optimize", unit="map", disable=not enabled,
                mininterval=0.5 if tty else 30.0, file=sys.stderr, dynamic_ncols=True)

