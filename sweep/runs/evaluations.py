"""Caging areas of single designs for the optimiser, each computed once (docs/optimisation.md).

`MapScores.area(design, r, mu, h)` is the caging area of one map: the scene's command, limits,
accuracy and effects, the whole-reach grid at spacing h, the sweep's own path
(`compute.batch.summarize_cells`, bitwise the caging area `compute_map` gives; a palm half-width
off the sweep's grid is computed map by map, so w need not be a multiple of 2h).

*The memo.* Designs of one equal-R class (the same l1, l2, w and R = r2/r1) give the same map
(MODEL 10, 11; the refinement's classes, `storage.refined.equal_r_classes`), so a map is keyed by
(r, mu, h, l1, l2, w, R) and never computed twice.

*The journal.* Every map computed is a row (part, h, design, caging area, seconds) kept in
order and saved atomically into the work directory every `CHECKPOINT_SECONDS` of computing and
at the end of each stage. A rerun after a kill loads the rows into the memo and runs the same
deterministic search again: every map it had is looked up instead of computed, so the rerun's
results (and its list of rows) are those of a run that was never interrupted.
"""
from __future__ import annotations

import io
import time
from pathlib import Path

import numpy as np

from ..compute.batch import summarize_cells
from ..compute.warm import ensure_compiled
from ..config.scene import Scene
from ..files import write_bytes_atomic
from ..schema import SUMMARY_INDEX
from ..storage.refined import R_DIGITS

JOURNAL = "evaluations.npz"
#: Computing seconds between two saves of the journal: a kill loses at most this much work.
CHECKPOINT_SECONDS = 10.0
#: Columns of a journal row.
COLUMNS = ("r", "mu", "h", "l1", "l2", "r1", "r2", "w", "caging_area", "seconds")


def class_key(design, r: float, mu: float, h: float) -> tuple:
    """The memo key of a map: the part, the spacing and the design's equal-R class."""
    l1, l2, r1, r2, w = (float(v) for v in design)
    return (float(r), float(mu), float(h), l1, l2, w, float(f"{r2 / r1:.{R_DIGITS}g}"))


class MapScores:
    """The caging areas of single maps of a scene, memoised and journalled (module docstring).
    `work`: the work directory (None: no journal). `on_compute(n)`: called after each map
    computed (a progress bar)."""

    def __init__(self, scene: Scene, work: Path | None = None, on_compute=None):
        self.scene = scene
        self.work = None if work is None else Path(work)
        self.on_compute = on_compute
        self.memo: dict = {}
        self.counts: dict = {}             # (r, mu, h) -> maps in the memo
        self.seconds: dict = {}            # key -> computing seconds of the map
        self.rows: list = []
        self.computed = 0
        self.compute_seconds = 0.0
        self._unsaved = 0.0
        self._compiled = False
        if self.work is not None and (self.work / JOURNAL).exists():
            self._load(self.work / JOURNAL)

    # -- the journal ----------------------------------------------------------------------------
    def _load(self, path: Path) -> None:
        try:
            with np.load(path) as z:
                rows = z["rows"]
        except (OSError, ValueError, KeyError):
            return          # unreadable: its maps are computed again
        for row in rows.reshape(-1, len(COLUMNS)):
            r, mu, h, *design, value, seconds = (float(v) for v in row)
            self._add(design[:5], r, mu, h, value, seconds)

    def _add(self, design, r, mu, h, value, seconds) -> None:
        key = class_key(design, r, mu, h)
        if key in self.memo:
            return
        self.memo[key] = value
        self.seconds[key] = seconds
        self.counts[key[:3]] = self.counts.get(key[:3], 0) + 1
        self.rows.append((r, mu, h, *(float(v) for v in design), value, seconds))

    def save(self) -> None:
        """Write the journal (atomically); nothing without a work directory."""
        if self.work is None:
            return
        buf = io.BytesIO()
        np.savez(buf, rows=np.array(self.rows, dtype=np.float64).reshape(-1, len(COLUMNS)))
        write_bytes_atomic(self.work / JOURNAL, buf.getvalue())
        self._unsaved = 0.0

    # -- maps -----------------------------------------------------------------------------------
    def known(self, design, r: float, mu: float, h: float) -> bool:
        return class_key(design, r, mu, h) in self.memo

    def area(self, design, r: float, mu: float, h: float) -> float:
        """The caging area of the map (design, part (r, mu), spacing h): from the memo, else
        computed, recorded and journalled."""
        key = class_key(design, r, mu, h)
        hit = self.memo.get(key)
        if hit is not None:
            return hit
        if not self._compiled:
            ensure_compiled()
            self._compiled = True
        s = self.scene
        l1, l2, r1, r2, w = (float(v) for v in design)
        t = time.perf_counter()
        summary = summarize_cells(np.array([[l1, l2, r1, r2, r, mu]]), np.array([w]),
                                  s.commands[0], h, s.limits, s.accuracy, s.effects)
        dt = time.perf_counter() - t
        value = float(summary[0, 0, SUMMARY_INDEX["caging_area"]])
        self._add(design, r, mu, h, value, dt)
        self.computed += 1
        self.compute_seconds += dt
        self._unsaved += dt
        if self._unsaved >= CHECKPOINT_SECONDS:
            self.save()
        if self.on_compute is not None:
            self.on_compute(1)
        return value

    def count(self, r: float, mu: float, h: float) -> int:
        """Maps of the part (r, mu) at spacing h in the memo."""
        return self.counts.get((float(r), float(mu), float(h)), 0)

    def table(self) -> np.ndarray:
        """Every map, in the order first computed: float64 (n, len(COLUMNS))."""
        return np.array(self.rows, dtype=np.float64).reshape(-1, len(COLUMNS))
