"""Variable geometry during the grasp (MODEL 12; model-notes D35; docs/variable-geometry.md):
`sweep schedule STORE`.

A chassis (l1, l2) of a results store's config may switch its setting, a pulley ratio R and a
palm width w, once during the grasp: draw in with X, hold with Y (`compute.schedules`). Per
case, a chassis and a part:

1. *Cases.* Per part: its best chassis (the refined store's best design, certified or the first
   of its near-tie set; the screened best in a store not refined; none where no design cages it
   at the screening spacing) and every named chassis (default (2.0, 1.6)); one case per distinct
   (chassis, part).
2. *Settings.* The config's pulley pairs by equal-R class (the first pair in store order stands
   for its class, as in the refinement), R ascending, times every palm width, w fastest.
3. *Level 0* (the ladder's first spacing, by default the store's h): the maps of every setting,
   and every schedule's caging and tip-prehension areas.
4. *The ladder.* After each level, its contenders: per objective (caging, tip prehension) the
   `contenders` best fixed settings and the `contenders` best switches (X != Y), the best pure
   R switch (the same w) and the best pure palm switch (the same R), each only where its area is
   positive. The next spacing computes the maps of their settings only, and every schedule among
   them. At the finest level reached, per objective and kind (fixed; schedule, X -> X included;
   R switch; w switch) the best (largest area; ties at TIE_DIGITS to a fixed setting, then to
   the first pair in setting order), its area at every level and its error estimate: the change
   from the level before (the refinement's, model-notes D18).
5. *Verdict.* d = best schedule - best fixed, u = error(schedule) + error(fixed), both at the
   finest level: "gain" when d > u, else "none"; with a single spacing no error exists
   ("unestimated" when d > 0).
6. With `third_switch`: at level 0 each draw setting's best schedule of three settings (two
   switches), the `contenders` largest of those recomputed at the second spacing together with
   the settings the ladder carries there; their best against the best schedule of at most two
   of those settings at that spacing, each with its change from level 0 (D35: measured, not
   one of the schedules).

A case depends on its maps alone, and each level's settings on the level before, so the results
do not depend on interruptions: each finished case is saved atomically in the work directory
(`OUT.work/`), which a rerun reads. The results go into one HDF5 file (`storage.schedule`).
"""
from __future__ import annotations

import concurrent.futures
import hashlib
import io
import itertools
import math
import shutil
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .. import __version__
from ..compute.chassis_maps import settings_maps
from ..compute.schedules import (TIE_DIGITS, best_of_three, chained_areas, lattice_of,
                                 on_lattice, schedule_values, tie_key)
from ..compute.threads import numba_threads
from ..compute.warm import ensure_compiled
from ..config.parse import scene_from_frozen
from ..config.scene import DESIGN_KEYS, Scene
from ..files import (StoreError, claim_output, remove_stale_temporaries, write_bytes_atomic,
                     write_json_atomic)
from ..grid import check_memory, grid_index_bounds
from ..model import Design, Grid, Part
from ..schema import REFINE_ROLE_MEANINGS, REFINE_STATUS_MEANINGS
from ..storage.schedule import (KINDS, OBJECTIVES, SOURCES, STATUSES, VERDICTS, read_identity,
                                write_schedules)
from ..storage.store import read_store
from .ladder import (LADDER_RULE, VERDICT_RULE, CaseResult, Level, Setting, Third, best_of_kind,
                     best_pair, contender_settings, finest, kind_mask, r_key, screened_best,
                     value_at, verdict)
from .rundir import read_json

DEFAULT_CHASSIS = ((2.0, 1.6),)
WORK_MANIFEST = "manifest.json"


class ScheduleError(StoreError):
    """A store the command cannot use (CLI: one line, exit code 2)."""


@dataclass(frozen=True)
class ScheduleSettings:
    """How `sweep schedule` computes (module docstring)."""

    ladder: tuple = ()                   # spacings, coarse to fine (empty: h, h/2, h/4)
    contenders: int = 2                  # best fixed settings and switches carried per level
    chassis: tuple = DEFAULT_CHASSIS     # named chassis (l1, l2), besides each part's best
    third_switch: bool = False

    def resolved(self, h: float) -> "ScheduleSettings":
        ladder = tuple(float(v) for v in self.ladder) or (h, h / 2.0, h / 4.0)
        return ScheduleSettings(ladder, int(self.contenders),
                                tuple((float(a), float(b)) for a, b in self.chassis),
                                bool(self.third_switch))

    def as_dict(self) -> dict:
        return dict(ladder=list(self.ladder), contenders=self.contenders,
                    chassis=[list(c) for c in self.chassis], third_switch=self.third_switch)


# ---------------------------------------------------------------------------------------------
# Settings and cases
# ---------------------------------------------------------------------------------------------
def setting_table(scene: Scene) -> list[Setting]:
    """Every setting of the scene's chassis (module docstring, step 2)."""
    first: dict = {}
    for r1, r2 in itertools.product(scene.values["r1"], scene.values["r2"]):
        first.setdefault(r_key(float(r1), float(r2)), (float(r1), float(r2)))
    return [Setting(r1, r2, float(w)) for _, (r1, r2) in sorted(first.items())
            for w in scene.values["w"]]


@dataclass(frozen=True)
class Case:
    """A chassis and a part."""

    l1: float
    l2: float
    r: float
    mu: float
    source: str         # SOURCES
    status: str         # STATUSES: the part's refined answer for its best chassis

    def key(self) -> tuple:
        return (self.l1, self.l2, self.r, self.mu)


def _store_matrix(scene: Scene, values) -> np.ndarray:
    n_designs = math.prod(len(scene.values[k]) for k in DESIGN_KEYS)
    return np.asarray(values).reshape(n_designs, -1)


def part_best_design(view, scene: Scene, p: int) -> tuple[np.ndarray | None, str]:
    """The best design (l1 l2 r1 r2 w) of part column p (the store's part order) and the
    part's status: the refined best, else the screened best (first in store order among
    equal caging areas at TIE_DIGITS); None where no design cages the part."""
    designs = np.array(list(itertools.product(*(scene.values[k] for k in DESIGN_KEYS))),
                       dtype=np.float64)
    screened = _store_matrix(scene, view.variables["caging_area"])[:, p]
    ref = view.refine
    if ref and "refine_role" in ref:
        status = REFINE_STATUS_MEANINGS[int(np.asarray(ref["refine_status"]).reshape(-1)[p])]
        role = _store_matrix(scene, ref["refine_role"])[:, p]
        best = np.flatnonzero(role == REFINE_ROLE_MEANINGS.index("best"))
        if best.size:
            return designs[int(best[0])], status
    else:
        status = "screened"
    if not np.nanmax(screened) > 0:
        return None, status
    return designs[int(np.argmax(tie_key(screened)))], status


def cases_of(view, scene: Scene, parts: list, chassis) -> list[Case]:
    """The cases (module docstring, step 1) of `parts` ((r, mu) values of the store), part by
    part: the part's best chassis first, then the named ones not equal to it."""
    r_vals, mu_vals = list(scene.values["r"]), list(scene.values["mu"])
    out = []
    for r, mu in parts:
        p = r_vals.index(r) * len(mu_vals) + mu_vals.index(mu)
        design, status = part_best_design(view, scene, p)
        seen = set()
        if design is not None:
            out.append(Case(float(design[0]), float(design[1]), float(r), float(mu),
                            "part_best", status))
            seen.add((float(design[0]), float(design[1])))
        for l1, l2 in chassis:
            if (l1, l2) not in seen:
                seen.add((l1, l2))
                out.append(Case(l1, l2, float(r), float(mu), "named", "named"))
    return out


# ---------------------------------------------------------------------------------------------
# One case
# ---------------------------------------------------------------------------------------------
def case_level(case: Case, scene: Scene, table: list, chosen: np.ndarray, h: float) -> tuple:
    """The maps of the settings `chosen` at spacing h and every schedule among them: (Level,
    the settings' Ends on their lattice)."""
    t0 = time.perf_counter()
    maps = settings_maps(case.l1, case.l2, [(table[s].r1, table[s].r2, table[s].w)
                                            for s in chosen.tolist()],
                         Part(case.r, case.mu), scene.commands[0], h, scene.limits,
                         scene.accuracy, scene.effects)
    t1 = time.perf_counter()
    lat = lattice_of(maps, h, case.r)
    ends = [on_lattice(m, lat) for m in maps]
    caging, tip = schedule_values(ends, h)
    t2 = time.perf_counter()
    return Level(h, chosen.copy(), caging, tip, t1 - t0, t2 - t1), ends


def run_case(case: Case, scene: Scene, table: list, s: ScheduleSettings) -> CaseResult:
    """Steps 3, 4 and 6 for one case."""
    out = CaseResult(case)
    chosen = np.arange(len(table), dtype=np.int64)
    for k, h in enumerate(s.ladder):
        level, ends = case_level(case, scene, table, chosen, h)
        out.levels.append(level)
        if k == 0 and s.third_switch:
            t = time.perf_counter()
            out.three = third_switch(case, scene, table, level, ends, s)
            level.seconds_values += time.perf_counter() - t
        del ends
        if k + 1 < len(s.ladder):
            chosen = contender_settings(level, table, s.contenders)
            if not chosen.size:
                break
    return out


def third_switch(case: Case, scene: Scene, table: list, level: Level, ends: list,
                 s: ScheduleSettings) -> dict:
    """Step 6: per objective, the `contenders` best three-setting schedules at level 0 (each
    draw setting's best, the largest of those) recomputed at the ladder's second spacing with
    the settings the ladder carries there; the best of them against the best schedule of at
    most two of those settings, both at that spacing, each with its change from level 0:
    {objective: Third}."""
    three = best_of_three(ends, level.h, s.contenders)
    out = {}
    finer = fine_ends = None
    if len(s.ladder) > 1:
        carried = contender_settings(level, table, s.contenders)
        triples = {t for objective in OBJECTIVES for _, tr in three[objective] for t in tr}
        chosen = np.array(sorted(set(int(level.settings[i]) for i in triples)
                                 | set(carried.tolist())), dtype=np.int64)
        if chosen.size:
            finer, fine_ends = case_level(case, scene, table, chosen, s.ladder[1])
    for o, objective in enumerate(OBJECTIVES):
        v = level.values(objective)
        cands = [(value, tuple(int(level.settings[i]) for i in tr))
                 for value, tr in three[objective]]
        if finer is None:
            a, b = best_pair(v, kind_mask(table, level.settings, "schedule"))
            pair = (int(level.settings[a]), int(level.settings[b]))
            value, triple = cands[0] if cands else (0.0, (-1, -1, -1))
            out[objective] = Third(triple, pair, [value], [float(v[a, b])])
            continue
        at = {int(t): i for i, t in enumerate(finer.settings)}
        fine = [chained_areas([fine_ends[at[t]] for t in tr], finer.h)[o] for _, tr in cands]
        vf = finer.values(objective)
        a, b = best_pair(vf, kind_mask(table, finer.settings, "schedule"))
        pair = (int(finer.settings[a]), int(finer.settings[b]))
        pair_areas = [value_at(level, objective, *pair), float(vf[a, b])]
        if not cands:
            out[objective] = Third((-1, -1, -1), pair, [0.0, 0.0], pair_areas)
            continue
        best = max(range(len(cands)), key=lambda i: (tie_key(fine[i]), -i))
        out[objective] = Third(cands[best][1], pair, [cands[best][0], fine[best]], pair_areas)
    return out


# ---------------------------------------------------------------------------------------------
# The work directory
# ---------------------------------------------------------------------------------------------
def work_path(out: Path) -> Path:
    out = Path(out)
    return out.with_name(out.name + ".work")


def _case_file(work: Path, i: int) -> Path:
    return work / f"case-{i:04d}.npz"


def prepare_work(work: Path, identity: dict) -> None:
    """The work directory of this identity: kept (its dead writers' temporaries removed) when
    its manifest matches, else emptied and started anew."""
    manifest = work / WORK_MANIFEST
    if manifest.exists():
        try:
            have = read_json(manifest)
        except StoreError:
            have = None
        if have == identity:
            remove_stale_temporaries(work, owned=True)
            return
        print(f"sweep: discarding the schedule work of another store or settings in {work}",
              file=sys.stderr)
        shutil.rmtree(work)
    work.mkdir(parents=True, exist_ok=True)
    write_json_atomic(manifest, identity)


def save_case(path: Path, result: CaseResult) -> None:
    arrays = {"n_levels": np.array(len(result.levels))}
    for k, level in enumerate(result.levels):
        arrays[f"h_{k}"] = np.array(level.h)
        arrays[f"settings_{k}"] = level.settings
        arrays[f"caging_{k}"] = level.caging
        arrays[f"tip_{k}"] = level.tip
        arrays[f"seconds_{k}"] = np.array([level.seconds_maps, level.seconds_values])
    for objective, t in result.three.items():
        arrays[f"three_{objective}"] = np.array([*t.triple, *t.pair], dtype=np.int64)
        arrays[f"three_areas_{objective}"] = np.array([t.areas, t.pair_areas])
    buf = io.BytesIO()
    np.savez(buf, **arrays)
    write_bytes_atomic(path, buf.getvalue())


def load_case(path: Path, case: Case) -> CaseResult | None:
    """A finished case from the work directory (None: not there, or unreadable)."""
    try:
        with np.load(path) as z:
            out = CaseResult(case)
            for k in range(int(z["n_levels"])):
                sm, sv = z[f"seconds_{k}"]
                out.levels.append(Level(float(z[f"h_{k}"]), z[f"settings_{k}"],
                                        z[f"caging_{k}"], z[f"tip_{k}"], float(sm), float(sv)))
            for objective in OBJECTIVES:
                if f"three_{objective}" in z:
                    v, a = z[f"three_{objective}"], z[f"three_areas_{objective}"]
                    out.three[objective] = Third(tuple(int(t) for t in v[:3]),
                                                 tuple(int(t) for t in v[3:]),
                                                 [float(t) for t in a[0]],
                                                 [float(t) for t in a[1]])
            return out
    except (OSError, ValueError, KeyError):
        return None


# ---------------------------------------------------------------------------------------------
# A store
# ---------------------------------------------------------------------------------------------
@dataclass
class ScheduleResult:
    path: Path
    already_done: bool
    wall_seconds: float
    computed: int = 0


def identity(view, scene: Scene, cases: list, s: ScheduleSettings) -> dict:
    """What decides the results: the store (config, caging areas, refinement), the cases, the
    settings, the version. A results file or work directory of another identity is made anew."""
    digest = hashlib.sha256(np.ascontiguousarray(view.variables["caging_area"]).tobytes())
    for name in ("refine_role", "refine_status"):
        if name in view.refine:
            digest.update(np.ascontiguousarray(view.refine[name]).tobytes())
    return dict(config_hash=scene.config_hash, store_sha256=digest.hexdigest(),
                cases=[[c.l1, c.l2, c.r, c.mu, c.source] for c in cases],
                settings=s.as_dict(), sweep_version=__version__)


def check_cases(scene: Scene, cases: list, s: ScheduleSettings) -> None:
    """Refuse (ModelInputError) a ladder whose finest spacing the largest map of a case cannot
    hold in memory, before anything is computed or written."""
    h = min(s.ladder)
    w = max(scene.values["w"])
    seen = set()
    for c in cases:
        if (c.l1, c.l2, c.r) in seen:
            continue
        seen.add((c.l1, c.l2, c.r))
        i0, i1, j0, j1 = grid_index_bounds(Design(c.l1, c.l2, 1.0, 1.0, float(w)),
                                           Part(c.r, c.mu), Grid(h=h))
        check_memory((i1 - i0 + 1) * (j1 - j0 + 1), f"the map of chassis l1 = {c.l1:g}, "
                     f"l2 = {c.l2:g} for r = {c.r:g} at h = {h:g}")


def open_store(store: Path) -> tuple:
    """(view, scene) of a store the command can use; ScheduleError otherwise."""
    view = read_store(store)
    if "caging_area" not in view.variables:
        raise ScheduleError(f"{store}: no caging_area variable (a store with the caging output)")
    scene = scene_from_frozen(view.frozen)
    if len(scene.commands) != 1:
        raise ScheduleError(f"{store}: schedules need a store with one command (this one has "
                            f"{len(scene.commands)})")
    return view, scene


def schedule_store(store: Path, out: Path, parts: list, settings: ScheduleSettings,
                   threads: int | None = None, progress: bool = True,
                   restart: bool = False) -> ScheduleResult:
    """Schedules of the parts `parts` ((r, mu) values of the store) of `store`, into `out`
    (atomically; a file of the same identity is left alone), resuming from `out`.work/."""
    t0 = time.perf_counter()
    out = Path(out)
    view, scene = open_store(store)
    s = settings.resolved(scene.h)
    cases = cases_of(view, scene, parts, s.chassis)
    check_cases(scene, cases, s)
    table = setting_table(scene)
    ident = identity(view, scene, cases, s)
    with claim_output(out, overwrite=True):
        if out.exists() and read_identity(out) == ident:
            return ScheduleResult(out, True, time.perf_counter() - t0)
        work = work_path(out)
        if restart:
            shutil.rmtree(work, ignore_errors=True)
        prepare_work(work, ident)
        results = [load_case(_case_file(work, i), case) for i, case in enumerate(cases)]
        todo = [i for i, got in enumerate(results) if got is None]
        resumed = float(sum(lv.seconds_maps + lv.seconds_values
                            for got in results if got is not None for lv in got.levels))
        bar = _progress(len(cases), progress)
        bar.update(len(cases) - len(todo))
        started = time.perf_counter()
        try:
            with numba_threads(threads) as n_threads:
                if todo:
                    ensure_compiled()
                for i, got in run_cases([cases[i] for i in todo], scene, table, s, n_threads,
                                        [_case_file(work, i) for i in todo]):
                    results[todo[i]] = got
                    bar.update(1)
        finally:
            bar.close()
        computed = len(todo)
        data = tables(results, table, s)
        compute = time.perf_counter() - started + resumed
        screening = float(view.attrs.get("compute_seconds", math.nan))
        wall = time.perf_counter() - t0
        write_schedules(out, data, dict(
            title=f"sweep schedule: {scene.name}", store=str(store), store_name=scene.name,
            config_hash=scene.config_hash, store_config=view.frozen, grid_h=scene.h,
            effects_on=" ".join(scene.effects.names_on()),
            identity=ident, settings=s.as_dict(), ladder=list(s.ladder),
            contenders=s.contenders, chassis=[list(c) for c in s.chassis],
            third_switch=s.third_switch, switch_rule=SWITCH_RULE, verdict_rule=VERDICT_RULE,
            ladder_rule=LADDER_RULE, tie_digits=TIE_DIGITS, compute_seconds=compute,
            screening_compute_seconds=screening,
            fraction_of_screening=compute / screening if screening > 0 else math.nan,
            wall_seconds=wall, computed_cases=computed))
        shutil.rmtree(work, ignore_errors=True)
    return ScheduleResult(out, False, wall, computed)


SWITCH_RULE = ("draw in with one setting, hold with another (MODEL 12, model-notes D35): from "
               "each start the draw map's trajectory to its end q; a caged, tip-prehension or "
               "stalled end switches to the hold setting with the part at q, in the hold map's "
               "configuration there (closing from open: the switch's path dependence is not "
               "modelled), and the hold map's trajectory from q ends the start; q outside the "
               "hold map's P_j loses the start; draw = hold is no switch")
def tables(results: list, table: list, s: ScheduleSettings) -> dict:
    """The arrays of the results file (`storage.schedule.write_schedules`)."""
    n, n_s, n_l = len(results), len(table), len(s.ladder)
    d = dict(h=np.array(s.ladder), l1=[r.case.l1 for r in results],
             l2=[r.case.l2 for r in results], r=[r.case.r for r in results],
             mu=[r.case.mu for r in results],
             chassis_source=[SOURCES.index(r.case.source) for r in results],
             part_status=[STATUSES.index(r.case.status) for r in results],
             finest_level=[finest(r) for r in results],
             setting_r1=[t.r1 for t in table], setting_r2=[t.r2 for t in table],
             setting_R=[t.R for t in table], setting_w=[t.w for t in table],
             schedule_area=np.full((n, 2, n_l, n_s, n_s), np.nan),
             computed=np.zeros((n, n_l, n_s), np.int8),
             best_draw=np.full((n, 2, len(KINDS)), -1), best_hold=np.full((n, 2, len(KINDS)), -1),
             best_area=np.full((n, 2, len(KINDS), n_l), np.nan),
             best_error=np.full((n, 2, len(KINDS)), np.nan),
             screened_draw=np.full((n, 2, len(KINDS)), -1),
             screened_hold=np.full((n, 2, len(KINDS)), -1),
             screened_area=np.full((n, 2, len(KINDS)), np.nan),
             gain=np.full((n, 2), np.nan), gain_error=np.full((n, 2), np.nan),
             verdict=np.zeros((n, 2), np.int8), maps=np.zeros((n, n_l), np.int32),
             seconds_maps=np.zeros((n, n_l)), seconds_values=np.zeros((n, n_l)))
    if s.third_switch:
        d.update(third_area=np.full((n, 2, n_l), np.nan), third_settings=np.full((n, 2, 3), -1),
                 third_best_two=np.full((n, 2, n_l), np.nan),
                 third_two_settings=np.full((n, 2, 2), -1), third_gain=np.full((n, 2), np.nan),
                 third_error=np.full((n, 2), np.nan), third_adds=np.zeros((n, 2), np.int8))
    for c, res in enumerate(results):
        for k, level in enumerate(res.levels):
            ix = np.ix_(level.settings, level.settings)
            for o, objective in enumerate(OBJECTIVES):
                d["schedule_area"][c, o, k][ix] = level.values(objective)
            d["computed"][c, k, level.settings] = 1
            d["maps"][c, k] = level.settings.size
            d["seconds_maps"][c, k] = level.seconds_maps
            d["seconds_values"][c, k] = level.seconds_values
        top = finest(res)
        for o, objective in enumerate(OBJECTIVES):
            best = {kind: best_of_kind(res, table, objective, kind, n_l) for kind in KINDS}
            for i, kind in enumerate(KINDS):
                b = best[kind]
                d["best_draw"][c, o, i], d["best_hold"][c, o, i] = b.draw, b.hold
                d["best_area"][c, o, i] = b.area
                d["best_error"][c, o, i] = b.error
                sd, sh, sa = screened_best(res, table, objective, kind)
                d["screened_draw"][c, o, i], d["screened_hold"][c, o, i] = sd, sh
                d["screened_area"][c, o, i] = sa
            gain, u, v = verdict(best["fixed"], best["schedule"], top)
            d["gain"][c, o], d["gain_error"][c, o] = gain, u
            d["verdict"][c, o] = VERDICTS.index(v)
            if s.third_switch and objective in res.three:
                t = res.three[objective]
                d["third_area"][c, o, :len(t.areas)] = t.areas
                d["third_best_two"][c, o, :len(t.pair_areas)] = t.pair_areas
                d["third_settings"][c, o] = t.triple
                d["third_two_settings"][c, o] = t.pair
                gain, u, adds = t.gain()
                d["third_gain"][c, o], d["third_error"][c, o] = gain, u
                d["third_adds"][c, o] = int(adds)
    return d


def run_cases(cases: list, scene: Scene, table: list, s: ScheduleSettings, threads: int,
              paths: list):
    """Compute `cases`, each saved to its path when done; yield (index, CaseResult) as they
    finish. Several cases at once, each on its share of the threads: a case's maps at the finer
    spacings are few, and its schedules are read on one core, so cases side by side keep the
    cores busy (the kernels release the GIL). Ctrl-C: the cases running finish and are saved,
    the others do not start."""
    workers = max(1, min(threads, len(cases)))
    inner = max(1, threads // workers)

    def one(k):
        with numba_threads(inner):
            got = run_case(cases[k], scene, table, s)
        save_case(paths[k], got)
        return got

    if workers == 1:
        for k in range(len(cases)):
            yield k, one(k)
        return
    with concurrent.futures.ThreadPoolExecutor(max_workers=workers) as pool:
        futures = {pool.submit(one, k): k for k in range(len(cases))}
        try:
            for future in concurrent.futures.as_completed(futures):
                yield futures[future], future.result()
        except BaseException:
            for future in futures:
                future.cancel()
            raise


def _progress(total: int, enabled: bool):
    from tqdm import tqdm

    tty = sys.stderr.isatty()
    return tqdm(total=total, desc="schedule", unit="case", disable=not enabled,
                mininterval=0.5 if tty else 30.0, file=sys.stderr, dynamic_ncols=True)

