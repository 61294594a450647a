"""The refinement stage: best designs that the grid cannot change (docs/sweeps.md, "Refinement";
model-notes D18).

The screening sweep ranks every design at the config's spacing `h`; only a few designs per part
can be the best, so only they are recomputed on finer grids. Per part (r, mu) and command:

1. *Classes.* Designs with the same l1, l2, w and R = r2/r1 give the same map (MODEL 10, 11:
   configurations depend on the pulley radii only through R; energies scale with r1, which
   changes no descent): they form one class, computed once, through its *representative*, the
   first of its designs in store order.
2. *Contenders*, measured in the run: first the *floor*, the `min_contenders` best classes by
   screened caging area, is computed at h/2; D, the largest change of a floor class from its
   screened value, says how far the screening is off for this part. Then every class whose
   screened caging area is at least the floor's best h/2 value minus CHANGE_FACTOR x D
   contends too, but never one below (1 - bound) times the part's best screened caging area:
   `bound` (the config's) caps the part's bound (stored: `refine_bound_used`). A part whose best
   screened caging area is 0 is not refined (status `not_refined`).
3. *Levels.* The contenders still in the running are recomputed at h/2, h/4, ..., h/2**levels
   with the config's accuracy settings otherwise unchanged (trajectory method included). At
   level k a class's value is its caging area there and its *error estimate* comes from its
   changes between levels (`error_estimate`): the change from level k-1 (the screened value
   for k = 1) where that change is at most half the one before, larger where the changes
   shrink more slowly (the geometric tail of their ratio), the sum of the last two where they
   do not shrink. Let b be the class of largest value (first in store order among equal
   values). A class stays in the running while its value plus its error
   reaches b's value minus b's error; the others are *eliminated* (separated from the best).
   The part is *certified* when b alone is left and b's own changes shrink (or it has only
   one): its lead over every other contender exceeds the error estimates of both. Where b's
   changes do not shrink the part goes one level further. At the level cap the classes left
   are the part's *near-tie set*, each with its value and error estimate.
   *Leader first* (levels 2 and up): the best of level k-1 is computed at level k before the
   others, and a class whose level-(k-1) value plus error is already below the leader's new
   value minus its new error is eliminated without being computed at level k (the test above,
   with the class's last interval; model-notes D28).
4. *Audit and bound check, repaired.* The contender bound and the eliminations are
   assumptions about how far a value can still move; each part checks them against
   computations of the designs they are about (model-notes D37). The *audit*: a stratified
   random sample of the part's non-contenders (`audit_sample`: by screened value, seeded by the
   config and the part, the same on every run) is computed at every level up to the part's
   finest; the largest relative rise of a sampled class from screening to the finest level
   (`audit_rise`) bounds the others'. A class outside the part's final set *could win* when it
   is a sampled class whose value plus error reaches the best's value minus its error, a
   non-contender whose screened value raised by the audit's rise reaches it, or a contender
   eliminated at an earlier level whose value plus error there reaches it (the leader-first
   test, with the final best's interval). Such classes are *re-admitted*: they contend, are
   recomputed at every level up to the part's finest, and that level is separated again
   (levels go on below the cap if several classes are left; the sample then follows to the new
   level); repeated until nothing could win (`refine_widenings`, `refine_readmitted`). Every
   round re-admits a class below the finest level or outside the contenders, so it ends, at
   worst with every class computed at the finest level, and the stored `refine_bound_held` is
   true. The contenders' own changes are never used to bound the others': they are the designs
   the screening inflated most (chosen for being high), so they fall most.

Every map's caging area depends on that map alone, and the plan of each level is a pure function
of the screened values and the earlier levels' values, so the result does not depend on how the
work was cut or interrupted. Work files: each batch of maps of a level is written atomically into
a work directory beside the store (`STORE.refine/`, `sweep.runs.rundir.refine_dir`); a rerun loads
the finished batches and computes the rest. The refined values are then added to the store
(`sweep.storage.store.add_refinement`), which is rewritten atomically.

Imports: scene, batch (the caging areas of a level's maps, `batch.caging_areas`), store,
rundir, outputs. `sweep run` and `sweep merge` call `refine_store` after writing their store.
"""
from __future__ import annotations

import contextlib
import hashlib
import io
import itertools
import math
import shutil
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .. import __version__
from ..compute.batch import caging_areas, commanded_cell_of_maps
from ..compute.threads import numba_threads
from ..compute.warm import ensure_compiled
from ..files import claim_output, remove_stale_temporaries, write_bytes_atomic
from .rundir import read_json, refine_dir

from ..config.scene import DESIGN_KEYS, RefineSettings, Scene, grid_points
from .certificate import (audit_rise, audit_sample, contender_cut, could_win_unaudited,
                          error_estimate, lead, select_contenders, separated, shrinking)
from ..storage.refined import ROLE, STATUS, equal_r_classes
from ..config.parse import scene_from_frozen
from ..storage.store import StoreError, add_refinement, read_store

#: Grid points per work file (the maps of a level, whole cells): a few seconds of compute on two
#: cores, so a kill loses little.
BATCH_POINTS = 10_000_000
WORK_MANIFEST = "manifest.json"


class RefineError(StoreError):
    """A store that cannot be refined (CLI: one line, exit code 2)."""


# ---------------------------------------------------------------------------------------------
# Designs, parts, classes
# ---------------------------------------------------------------------------------------------
def design_table(scene: Scene) -> np.ndarray:
    """Every design (l1, l2, r1, r2, w) in store order (w fastest): float64 (n_designs, 5)."""
    return np.array(list(itertools.product(*(scene.values[k] for k in DESIGN_KEYS))),
                    dtype=np.float64).reshape(-1, len(DESIGN_KEYS))


def part_table(scene: Scene) -> np.ndarray:
    """Every part (r index, mu index, command index) in store order: int64 (n_parts, 3)."""
    return np.array(list(itertools.product(range(len(scene.values["r"])),
                                           range(len(scene.values["mu"])),
                                           range(len(scene.commands)))),
                    dtype=np.int64).reshape(-1, 3)


def screened_matrix(scene: Scene, caging_area: np.ndarray) -> np.ndarray:
    """The store's caging_area (store dims) as (n_designs, n_parts), parts as `part_table`."""
    n_designs = math.prod(len(scene.values[k]) for k in DESIGN_KEYS)
    return np.asarray(caging_area, dtype=np.float64).reshape(n_designs, -1)


def _keys(classes, parts) -> np.ndarray:
    """(part, representative) of every class of `classes[p]` for p in parts: int64 (n, 2)."""
    return np.array([(p, int(d)) for p in parts for d in classes[p]],
                    dtype=np.int64).reshape(-1, 2)


# ---------------------------------------------------------------------------------------------
# Maps at a level
# ---------------------------------------------------------------------------------------------
def level_batches(scene: Scene, designs: np.ndarray, parts: np.ndarray, keys: np.ndarray,
                  h: float) -> list[np.ndarray]:
    """A level's maps in a fixed order, cut into batches of whole cells (all their maps of the
    level) of at most BATCH_POINTS grid points (at least one cell each). Cells with the same
    widths are consecutive (`compute_maps` makes one kernel call of them), largest first."""
    cells, which = np.unique(commanded_cell_of_maps(designs, parts, keys), axis=0,
                             return_inverse=True)
    which = which.reshape(-1)
    r_vals = scene.values["r"]
    cost = np.zeros(cells.shape[0], dtype=np.int64)
    widths = np.zeros(cells.shape[0], dtype=np.int64)   # bit mask of the cell's widths
    for c, (_, d) in zip(which, keys):
        l1, l2, _, _, w = designs[d]
        cost[c] += grid_points(l1, l2, w, r_vals[int(cells[c, 5])], h)
        widths[c] |= 1 << int(d % scene.widths.size)
    # cells with the same widths together (one kernel call for them), largest first
    order = np.lexsort((np.arange(cells.shape[0]), -cost, widths, cells[:, 0]))
    batches, current, points = [], [], 0
    for c in order:
        if current and points + cost[c] > BATCH_POINTS:
            batches.append(current)
            current, points = [], 0
        current.append(c)
        points += int(cost[c])
    if current:
        batches.append(current)
    out = []
    for b in batches:
        rank = {c: i for i, c in enumerate(b)}
        rows = [i for i in np.flatnonzero(np.isin(which, b))]
        rows.sort(key=lambda i: (rank[which[i]], keys[i, 1], keys[i, 0]))
        out.append(keys[rows])
    return out


# ---------------------------------------------------------------------------------------------
# Work directory: one file per finished batch
# ---------------------------------------------------------------------------------------------
def refine_identity(scene: Scene, settings: RefineSettings, designs=None) -> dict:
    """What decides the refined values: the config (its hash), the refinement settings, the
    sweep version (and the designs, when they are not the config's own). A store refined under
    another identity is refined again."""
    out = dict(config_hash=scene.config_hash, sweep_version=__version__,
               refine=settings.as_dict())
    if designs is not None:
        out["designs_sha256"] = hashlib.sha256(np.ascontiguousarray(designs).tobytes()
                                               ).hexdigest()
    return out


def batch_path(work: Path, label: str, index: int) -> Path:
    return work / f"level-{label}-batch-{index:05d}.npz"


def _save_batch(path: Path, keys: np.ndarray, values: np.ndarray, seconds: float) -> None:
    buf = io.BytesIO()
    np.savez(buf, keys=keys, values=values, seconds=np.float64(seconds))
    write_bytes_atomic(path, buf.getvalue())


def _load_batch(path: Path, keys: np.ndarray):
    """(values, seconds) of a finished batch file holding exactly `keys`, else None."""
    try:
        with np.load(path) as z:
            if z["keys"].shape == keys.shape and np.array_equal(z["keys"], keys):
                return z["values"].copy(), float(z["seconds"])
    except (OSError, ValueError, KeyError):
        pass
    return None


def prepare_work_dir(work: Path, identity: dict) -> None:
    """Create the work directory, or empty it when it holds another refinement's files. The
    caller holds the store's lock, so every temporary in it is a killed writer's."""
    from ..files import write_json_atomic

    manifest = work / WORK_MANIFEST
    if manifest.exists():
        try:
            have = read_json(manifest)
        except StoreError:
            have = None
        if have == identity:
            remove_stale_temporaries(work, owned=True)
            return
        print(f"sweep: discarding the refinement work of another config or settings in {work}",
              file=sys.stderr)
        shutil.rmtree(work)
    write_json_atomic(manifest, identity)


# ---------------------------------------------------------------------------------------------
# The stage
# ---------------------------------------------------------------------------------------------
@dataclass
class Refinement:
    """The refined answer of every part (arrays in `part_table` / store design order)."""

    settings: RefineSettings
    h: float                            # screening spacing
    reps: np.ndarray                    # (n_designs,) representative of each design's class
    value: np.ndarray                   # (n_designs, n_parts) caging area at the finest level
    level: np.ndarray                   # (n_designs, n_parts) int8: that level (0: screened)
    error: np.ndarray                   # (n_designs, n_parts) error estimate there, NaN if none
    role: np.ndarray                    # (n_designs, n_parts) int8, REFINE_ROLE_MEANINGS
    status: np.ndarray                  # (n_parts,) int8, REFINE_STATUS_MEANINGS
    finest_level: np.ndarray            # (n_parts,) int8
    margin: np.ndarray                  # (n_parts,) lead of the best at the finest level
    n_contenders: np.ndarray            # (n_parts,) int32: contending designs (all class members)
    bound_held: np.ndarray              # (n_parts,) bool: the bound check (module docstring)
    bound_used: np.ndarray              # (n_parts,) the part's contender bound (step 2)
    readmitted: np.ndarray = None       # (n_designs, n_parts) bool: re-admitted by step 4
    widenings: np.ndarray = None        # (n_parts,) int32: rounds of step 4 (0: held at once)
    n_readmitted: np.ndarray = None     # (n_parts,) int32: designs re-admitted (class members)
    bound_widened: np.ndarray = None    # (n_parts,) the contender bound after step 4
    audit_designs: np.ndarray = None    # (n_parts,) int32: designs audited (class members)
    audit_rise: np.ndarray = None       # (n_parts,) the audit's largest relative rise
    audit_level: np.ndarray = None      # (n_parts,) int8: the level the audit reached
    level_maps: list = field(default_factory=list)      # maps computed per level (1..)
    level_seconds: list = field(default_factory=list)   # compute seconds per level
    widen_maps: int = 0                 # of those, maps computed by step 4
    computed_maps: int = 0              # maps computed by this invocation

    def __post_init__(self):
        n_designs, n_parts = self.value.shape
        if self.readmitted is None:
            self.readmitted = np.zeros((n_designs, n_parts), dtype=bool)
        for name, dtype in (("widenings", np.int32), ("n_readmitted", np.int32)):
            if getattr(self, name) is None:
                setattr(self, name, np.zeros(n_parts, dtype=dtype))
        if self.bound_widened is None:
            self.bound_widened = self.bound_used.copy()
        if self.audit_designs is None:
            self.audit_designs = np.zeros(n_parts, dtype=np.int32)
        if self.audit_rise is None:
            self.audit_rise = np.full(n_parts, np.nan)
        if self.audit_level is None:
            self.audit_level = np.zeros(n_parts, dtype=np.int8)

    @property
    def seconds(self) -> float:
        return float(sum(self.level_seconds))

    def finest_h(self) -> np.ndarray:
        return np.where(self.finest_level > 0, self.h / 2.0 ** self.finest_level.astype(float),
                        self.h)

    def counts(self) -> dict:
        return {name: int(np.sum(self.status == code)) for name, code in STATUS.items()}


def refine_scene(scene: Scene, screened: np.ndarray, settings: RefineSettings, work: Path,
                 progress: bool = False) -> Refinement:
    """Run (or resume) the refinement of every part from the screened caging areas
    (n_designs, n_parts); work files in `work` (created; the caller holds the store's lock)."""
    return refine_designs(scene, design_table(scene), screened, settings, work, progress,
                          identity=refine_identity(scene, settings), seed=scene.config_hash)


def refine_designs(scene: Scene, designs: np.ndarray, screened: np.ndarray,
                   settings: RefineSettings, work: Path, progress: bool = False,
                   identity: dict | None = None, seed: str | None = None) -> Refinement:
    """The refinement of a set of designs (n_designs, 5: l1 l2 r1 r2 w, in the store's order
    with w fastest and the scene's widths; the scene's parts) from their screened caging areas:
    `refine_scene` for a whole config, `sweep accuracy` for its sample. `seed`: what seeds the
    audit's draws (default: the config's hash and the designs)."""
    parts = part_table(scene)
    n_designs, n_parts = screened.shape
    if n_designs != designs.shape[0] or n_parts != parts.shape[0]:
        raise RefineError(f"screened values of shape {screened.shape} for {designs.shape[0]} "
                          f"designs and {parts.shape[0]} parts")
    prepare_work_dir(work, identity or refine_identity(scene, settings, designs))
    if seed is None:
        seed = scene.config_hash + hashlib.sha256(np.ascontiguousarray(designs).tobytes()
                                                  ).hexdigest()
    stage = _Stage(scene, designs, parts, screened, settings, work, progress, seed)
    todo = stage.level_one()
    if todo:
        stage.advance(todo)
    stage.widen()
    return stage.finish()


class _Stage:
    """The state of one refinement while it runs (`refine_designs`): per part its contenders,
    the classes still in the running, its leader and finest level; per class its latest value
    and level. Every map goes through `compute` (work files, cost per level)."""

    def __init__(self, scene, designs, parts, screened, settings, work, progress, seed):
        self.scene, self.designs, self.parts = scene, designs, parts
        self.screened, self.settings = screened, settings
        self.work, self.progress, self.seed = work, progress, seed
        n_designs, n_parts = screened.shape
        self.reps = equal_r_classes(designs)
        self.class_reps = np.unique(self.reps)
        self.latest = screened.copy()      # per representative: value at its latest level
        self.change = np.full(screened.shape, np.nan)   # its change from the level before
        self.change_before = np.full(screened.shape, np.nan)   # and that level's change
        self.sample: dict = {}             # per part: the audit's classes (step 4)
        empty = np.zeros(0, dtype=np.int64)
        self.contenders = [empty] * n_parts
        self.alive = [empty] * n_parts     # the classes still in the running
        self.leader = {}                   # per part: the best of its finest level
        self.cut = np.full(n_parts, np.nan)    # screened value a class needed to contend
        self.out = Refinement(
            settings, scene.h, self.reps, np.full((n_designs, n_parts), np.nan),
            np.zeros((n_designs, n_parts), dtype=np.int8), np.full((n_designs, n_parts), np.nan),
            np.full((n_designs, n_parts), ROLE["screened"], dtype=np.int8),
            np.zeros(n_parts, dtype=np.int8), np.zeros(n_parts, dtype=np.int8),
            np.full(n_parts, np.nan), np.zeros(n_parts, dtype=np.int32),
            np.zeros(n_parts, dtype=bool), np.full(n_parts, np.nan),
            level_maps=[0] * settings.levels, level_seconds=[0.0] * settings.levels)

    # -- maps -----------------------------------------------------------------------------------
    def compute(self, keys: np.ndarray, k: int, label: str) -> None:
        """The maps `keys` (part, representative) at level k, recorded: each class's value there
        and its error estimate, the change from its level before."""
        got, seconds, computed = _run_level(self.scene, self.designs, self.parts, keys,
                                            self.settings.level_h(self.scene.h, k), label,
                                            self.work, self.progress)
        out = self.out
        out.level_maps[k - 1] += int(keys.shape[0])
        out.level_seconds[k - 1] += seconds
        out.computed_maps += computed
        for p, d in keys.tolist():
            now = got[(p, d)]
            members = self.reps == d
            change = abs(now - self.latest[d, p])
            before = self.change[d, p] if k > 1 else math.nan
            out.value[members, p] = now
            out.level[members, p] = k
            out.error[members, p] = error_estimate(change, before)
            self.change_before[d, p] = before
            self.change[d, p] = change
            self.latest[d, p] = now

    # -- step 2 and level 1 ----------------------------------------------------------------------
    def level_one(self) -> dict:
        """Level 1 in two passes (step 2): the floor, then the classes its changes call for.
        Returns {part: 2} for the parts that go on."""
        s, out, screened = self.settings, self.out, self.screened
        n_parts = screened.shape[1]
        floor = [select_contenders(self.class_reps, screened[:, p], s, floor_only=True)
                 for p in range(n_parts)]
        self.compute(_keys(floor, range(n_parts)), 1, "1a")
        for p in range(n_parts):
            c = floor[p]
            if c.size:
                best0 = float(screened[c, p].max())
                cut = contender_cut(best0, self.latest[c, p], screened[c, p], s.bound)
                out.bound_used[p] = 1.0 - cut / best0
                self.cut[p] = cut
                c = np.union1d(c, self.class_reps[screened[self.class_reps, p] >= cut])
            self.contenders[p] = c
            out.status[p] = STATUS["near_tie"] if c.size else STATUS["not_refined"]
        rest = [np.setdiff1d(self.contenders[p], floor[p]) for p in range(n_parts)]
        self.compute(_keys(rest, range(n_parts)), 1, "1b")
        todo = {}
        for p in range(n_parts):
            if self.contenders[p].size:
                self.conclude(p, 1)
                if self.alive[p].size > 1 and s.levels > 1:
                    todo[p] = 2
        return todo

    def settled(self, p: int) -> bool:
        """Part p's classes are separated and its best's changes shrink (step 3)."""
        d = self.leader[p]
        return self.alive[p].size == 1 and shrinking(self.change[d, p], self.change_before[d, p])

    def conclude(self, p: int, k: int) -> None:
        """Step 3 at level k of part p: the classes computed there are separated; the best is the
        leader of the next level; one class left whose changes shrink certifies the part."""
        c = self.class_reps[self.out.level[self.class_reps, p] == k]
        now = self.latest[c, p]
        b, keep = separated(now, self.out.error[c, p])
        self.out.finest_level[p] = k
        if c.size > 1:    # else the leader was computed alone: its lead stays the last one
            self.out.margin[p] = lead(now, b)
        self.leader[p] = int(c[b])
        self.alive[p] = c[keep]
        self.out.status[p] = STATUS["certified" if self.alive[p].size == 1 else "near_tie"]

    def goes_on(self, p: int, k: int) -> bool:
        """Part p needs level k + 1: below the cap, several classes left or the best's changes
        not shrinking (step 3)."""
        return k < self.settings.levels and not self.settled(p)

    # -- levels 2 and up, leader first -----------------------------------------------------------
    def advance(self, todo: dict, prefix: str = "") -> None:
        """Levels from todo[p] up to the cap for the parts of `todo`, until each is certified."""
        active: list = []
        for k in range(min(todo.values()), self.settings.levels + 1):
            active = sorted(set(active) | {p for p, k0 in todo.items() if k0 == k})
            if not active:
                continue
            self.leader_first(active, k, prefix)
            for p in active:
                self.conclude(p, k)
            active = [p for p in active if self.goes_on(p, k)]

    def leader_first(self, active: list, k: int, prefix: str) -> None:
        """Level k of the parts `active` (model-notes D28): each part's leader first, then the
        classes still in the running whose last value plus error reaches the leader's new value
        minus its new error; the others are eliminated without being computed at level k."""
        lead_keys = np.array([(p, self.leader[p]) for p in active], dtype=np.int64).reshape(-1, 2)
        self.compute(lead_keys, k, f"{prefix}{k}a")
        rest = []
        for p in active:
            d = self.leader[p]
            low = self.latest[d, p] - self.out.error[d, p]
            c = self.alive[p]
            c = c[c != d]
            rest.append(c[self.latest[c, p] + self.out.error[c, p] >= low])
        self.compute(_keys(dict(zip(active, rest)), active), k, f"{prefix}{k}b")

    # -- step 4: the audit and the bound check, repaired ----------------------------------------
    def audit(self, label: str) -> None:
        """Step 4's audit: each part's sample of non-contenders (drawn once, from the classes
        that did not contend then) computed at every level up to the part's finest."""
        out, n_parts = self.out, self.screened.shape[1]
        parts = [p for p in range(n_parts) if self.alive[p].size]
        for p in parts:
            if p not in self.sample:
                left_out = np.setdiff1d(self.class_reps, self.contenders[p])
                best0 = float(self.screened[self.class_reps, p].max())
                seed = int(hashlib.sha256(f"{self.seed}:{p}".encode()).hexdigest()[:16], 16)
                self.sample[p] = audit_sample(left_out, self.screened[:, p], best0, seed)
        top = max((int(out.finest_level[p]) for p in parts), default=0)
        for k in range(1, top + 1):
            keys = {p: self.sample[p][out.level[self.sample[p], p] < k]
                    if k <= out.finest_level[p] else self.sample[p][:0] for p in parts}
            self.compute(_keys(keys, parts), k, f"{label}{k}")
        for p in parts:
            out.audit_level[p] = out.finest_level[p]

    def left_out(self, p: int) -> np.ndarray:
        """Representatives of part p that are not in its final set and could still be its best
        (step 4): empty when the bound held. The audit's classes must be computed at the part's
        finest level (`audit`)."""
        best = self.leader[p]
        best_low = self.latest[best, p] - self.out.error[best, p]
        best0 = float(self.screened[self.class_reps, p].max())
        c = self.contenders[p]
        sample = np.setdiff1d(self.sample.get(p, c[:0]), c)
        rise = audit_rise(sample, self.screened[:, p], self.latest[:, p], best0)
        self.out.audit_rise[p] = rise
        outside = np.setdiff1d(np.setdiff1d(self.class_reps, c), sample)
        unaudited = could_win_unaudited(outside, self.screened[:, p], rise, best0, best_low)
        audited = sample[self.latest[sample, p] + self.out.error[sample, p] >= best_low]
        gone = np.setdiff1d(c, self.alive[p])
        gone = gone[self.out.level[gone, p] < self.out.finest_level[p]]
        back = gone[self.latest[gone, p] + self.out.error[gone, p] >= best_low]
        return np.union1d(np.union1d(unaudited, audited), back)

    def widen(self) -> None:
        """Step 4: audit, re-admit what could win, recompute it at the levels the part reached,
        separate again (and go on to the next levels if that leaves several classes below the
        cap); repeat until nothing could win in any part."""
        out, n_parts = self.out, self.screened.shape[1]
        for rounds in itertools.count(1):
            self.audit(f"a{rounds}-")
            back = {p: self.left_out(p) for p in range(n_parts) if self.alive[p].size}
            back = {p: c for p, c in back.items() if c.size}
            if not back:
                break
            prefix = f"w{rounds}-"
            maps_before = sum(out.level_maps)
            for p, c in back.items():
                # the cut moves down only for re-admissions by the audit's rise: an audited
                # class comes back by its own value, whatever its screened one
                outside = np.setdiff1d(np.setdiff1d(c, self.contenders[p]),
                                       self.sample.get(p, c[:0]))
                if outside.size:
                    self.cut[p] = min(self.cut[p], float(self.screened[outside, p].min()))
                self.contenders[p] = np.union1d(self.contenders[p], c)
                out.readmitted[np.isin(self.reps, c), p] = True
                out.widenings[p] += 1
            reached = {p: int(out.finest_level[p]) for p in back}
            for k in range(1, max(reached.values()) + 1):
                keys = {p: c[out.level[c, p] < k] if k <= reached[p] else c[:0]
                        for p, c in back.items()}
                self.compute(_keys(keys, sorted(back)), k, f"{prefix}{k}")
            todo = {}
            for p in sorted(back):
                self.conclude(p, reached[p])
                if self.goes_on(p, reached[p]):
                    todo[p] = reached[p] + 1
            if todo:
                self.advance(todo, prefix)
            out.widen_maps += sum(out.level_maps) - maps_before

    def finish(self) -> Refinement:
        out, reps, screened = self.out, self.reps, self.screened
        for p in range(screened.shape[1]):
            c = self.contenders[p]
            out.n_contenders[p] = int(np.isin(reps, c).sum())
            out.n_readmitted[p] = int(out.readmitted[:, p].sum())
            audited = np.setdiff1d(self.sample.get(p, c[:0]), c)
            out.role[np.isin(reps, audited), p] = ROLE["audited"]
            out.audit_designs[p] = int(np.isin(reps, audited).sum())
            out.role[np.isin(reps, c), p] = ROLE["eliminated"]
            if not self.alive[p].size:
                continue
            out.role[np.isin(reps, self.alive[p]), p] = ROLE["near_tie"]
            best = self.leader[p]
            out.role[reps == best, p] = ROLE["best"]
            out.bound_held[p] = not self.left_out(p).size
            best0 = float(screened[self.class_reps, p].max())
            out.bound_widened[p] = 1.0 - self.cut[p] / best0
        while out.level_maps and not out.level_maps[-1]:   # levels no part reached
            out.level_maps.pop()
            out.level_seconds.pop()
        return out


def _run_level(scene, designs, parts, keys, h, label, work, progress):
    """The maps `keys` of a level (`label`: "1a", "1b", "2a", "2b", ...): finished batches
    loaded, the rest computed and saved. Returns ({(part, design): caging area}, compute
    seconds of every batch, maps computed now)."""
    if not keys.shape[0]:
        return {}, 0.0, 0
    batches = level_batches(scene, designs, parts, keys, h)
    got: dict = {}
    seconds, computed = 0.0, 0
    todo = []
    for b, bk in enumerate(batches):
        found = _load_batch(batch_path(work, label, b), bk)
        if found is None:
            todo.append(b)
            continue
        got.update(zip(map(tuple, bk.tolist()), found[0].tolist()))
        seconds += found[1]
    if todo:  # (before the progress bar: its rate and ETA are the computation's alone)
        ensure_compiled()
    bar = _progress(len(keys), len(keys) - sum(len(batches[b]) for b in todo),
                    f"refine h={h:g}", progress)
    try:
        for b in todo:
            bk = batches[b]
            t = time.perf_counter()
            v = caging_areas(scene, designs, parts, bk, h)
            dt = time.perf_counter() - t
            _save_batch(batch_path(work, label, b), bk, v, dt)
            got.update(zip(map(tuple, bk.tolist()), v.tolist()))
            seconds += dt
            computed += len(bk)
            bar.update(len(bk))
    finally:
        bar.close()
    return got, seconds, computed


def _progress(total: int, initial: int, desc: str, enabled: bool):
    from tqdm import tqdm

    tty = sys.stderr.isatty()
    return tqdm(total=total, initial=initial, desc=desc, unit="map", disable=not enabled,
                mininterval=0.5 if tty else 30.0, file=sys.stderr, dynamic_ncols=True)


# ---------------------------------------------------------------------------------------------
# A store
# ---------------------------------------------------------------------------------------------
@dataclass
class RefineResult:
    path: Path
    refinement: Refinement | None   # None when the store was already refined
    wall_seconds: float
    screening_seconds: float        # the store's compute_seconds

    @property
    def already_done(self) -> bool:
        return self.refinement is None


def store_settings(view) -> RefineSettings | None:
    """The refinement settings a store was refined with (None: not refined)."""
    a = view.attrs
    if "refine_levels" not in a:
        return None
    return RefineSettings(levels=int(a["refine_levels"]), bound=float(a["refine_bound"]),
                          min_contenders=int(a["refine_min_contenders"]))


def is_refined(view, scene: Scene, settings: RefineSettings) -> bool:
    """The store holds the refinement of this config under these settings (by a version that
    audits the designs left out: `refine_audit_designs` present)."""
    return (view.attrs.get("config_hash") == scene.config_hash and view.refine and
            "refine_audit_designs" in view.refine and
            view.attrs.get("refine_sweep_version") == __version__ and
            store_settings(view) == settings)


def refine_store(path: Path, settings: RefineSettings | None = None, threads: int | None = None,
                 progress: bool = True, restart: bool = False, wait: bool = False,
                 locked: bool = False, force: bool = False) -> RefineResult:
    """Refine the results store `path` in place (rewritten atomically) with `settings` (default:
    the store's config's `refine:`, else RefineSettings()); resumes from `STORE.refine/`. A store
    already refined with these settings is left alone unless `force`. `locked`: the caller holds
    the store's lock."""
    path = Path(path)
    t0 = time.perf_counter()
    lock = contextlib.nullcontext() if locked else claim_output(path, overwrite=True, wait=wait)
    with lock:
        view = read_store(path)
        scene = scene_from_frozen(view.frozen)
        settings = settings or scene.refine or RefineSettings()
        screening = float(view.attrs.get("compute_seconds", math.nan))
        work = refine_dir(path)
        if not force and is_refined(view, scene, settings):
            shutil.rmtree(work, ignore_errors=True)
            return RefineResult(path, None, time.perf_counter() - t0, screening)
        if "caging_area" not in view.variables:
            raise RefineError(f"{path}: no caging_area variable to refine")
        if restart:
            shutil.rmtree(work, ignore_errors=True)
        screened = screened_matrix(scene, view.variables["caging_area"])
        with numba_threads(threads):
            ref = refine_scene(scene, screened, settings, work, progress)
        wall = time.perf_counter() - t0
        add_refinement(path, scene, ref, dict(
            refine_sweep_version=__version__, refine_wall_seconds=wall,
            refine_compute_seconds=ref.seconds,
            refine_fraction_of_screening=(ref.seconds / screening if screening > 0 else
                                          math.nan)))
        shutil.rmtree(work, ignore_errors=True)
    return RefineResult(path, ref, wall, screening)


