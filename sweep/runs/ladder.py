"""The h-ladder of one case's schedules (MODEL 12; model-notes D35; `sweep.runs.schedule`
runs it): which settings each spacing computes (`contender_settings`), the best schedule of each
kind at the finest spacing with its areas and error estimate (`best_of_kind`), the verdict on
the best schedule's gain over the best fixed setting (`verdict`), and the third switch's
comparison (`Third`). Plain functions of the levels' values: no map is computed here.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ..compute.schedules import tie_key
from ..storage.refined import R_DIGITS
from ..storage.schedule import OBJECTIVES


@dataclass(frozen=True)
class Setting:
    """A setting of a chassis: the pulley pair standing for its equal-R class, a palm width."""

    r1: float
    r2: float
    w: float

    @property
    def R(self) -> float:
        return self.r2 / self.r1


def r_key(r1: float, r2: float) -> float:
    """R = r2/r1 to R_DIGITS significant digits: the equal-R class (as the refinement's)."""
    return float(f"{r2 / r1:.{R_DIGITS}g}")


@dataclass
class Level:
    """One spacing of a case: the settings computed there (indices into the setting table,
    ascending) and every schedule among them."""

    h: float
    settings: np.ndarray            # int64 (n,)
    caging: np.ndarray              # (n, n): caging area, row draws in, column holds
    tip: np.ndarray                 # (n, n): tip-prehension area
    seconds_maps: float = 0.0
    seconds_values: float = 0.0

    def values(self, objective: str) -> np.ndarray:
        return self.caging if objective == "caging" else self.tip


@dataclass
class CaseResult:
    """A case's levels (the spacings computed, coarse to fine) and its third switch."""

    case: object                    # sweep.runs.schedule.Case
    levels: list = field(default_factory=list)
    #: the third switch measured: objective -> Third
    three: dict = field(default_factory=dict)


def kind_mask(table: list, settings: np.ndarray, kind: str) -> np.ndarray:
    """Which pairs (draw, hold) of `settings` are schedules of a kind: (n, n) bool."""
    R = np.array([r_key(table[s].r1, table[s].r2) for s in settings])
    w = np.array([table[s].w for s in settings])
    same_r, same_w = R[:, None] == R[None, :], w[:, None] == w[None, :]
    diagonal = np.eye(len(settings), dtype=bool)
    return {"fixed": diagonal, "schedule": np.ones_like(diagonal), "switch": ~diagonal,
            "r_switch": same_w & ~same_r, "w_switch": same_r & ~same_w}[kind]


def ranked_pairs(values: np.ndarray, mask: np.ndarray) -> list[tuple[int, int]]:
    """The pairs of `mask`, largest value first (TIE_DIGITS; among ties a fixed setting, then
    the first pair in setting order)."""
    a, b = np.nonzero(mask)
    key = tie_key(values[a, b])
    order = np.lexsort((b, a, a != b, -key))
    return [(int(a[k]), int(b[k])) for k in order]


def best_pair(values: np.ndarray, mask: np.ndarray) -> tuple[int, int] | None:
    """The first of `ranked_pairs` (None: no pair of the kind)."""
    pairs = ranked_pairs(values, mask)
    return pairs[0] if pairs else None


def contender_settings(level: Level, table: list, k: int) -> np.ndarray:
    """The settings the next spacing computes: per objective the `k` best fixed settings and
    the `k` best switches (X != Y), the best R switch (w kept) and the best w switch (R kept),
    each where its area is positive (ties as `ranked_pairs`)."""
    keep: set = set()
    for objective in OBJECTIVES:
        v = level.values(objective)
        for kind, n in (("fixed", k), ("switch", k), ("r_switch", 1), ("w_switch", 1)):
            pairs = [(a, b) for a, b in ranked_pairs(v, kind_mask(table, level.settings, kind))
                     if v[a, b] > 0][:n]
            for a, b in pairs:
                keep.update((int(level.settings[a]), int(level.settings[b])))
    return np.array(sorted(keep), dtype=np.int64)


@dataclass
class Third:
    """The third switch measured (`sweep.runs.schedule`, step 6): the best three-setting
    schedule (setting indices; -1: none) and the best of at most two settings, both chosen at
    the ladder's second spacing (at level 0 with a single spacing), and their areas at level 0
    and there."""

    triple: tuple
    pair: tuple
    areas: list
    pair_areas: list

    def gain(self) -> tuple[float, float, bool]:
        """(d, u, adds) at the finest of the two spacings: d = three - two, u the sum of their
        changes from level 0 (NaN with one spacing); adds when d > u (with one spacing, when
        d > 0 at TIE_DIGITS)."""
        k = len(self.areas) - 1
        d = self.areas[k] - self.pair_areas[k]
        if tie_key(self.areas[k]) == tie_key(self.pair_areas[k]):
            d = 0.0
        if k == 0:
            return d, math.nan, d > 0
        u = abs(self.areas[1] - self.areas[0]) + abs(self.pair_areas[1] - self.pair_areas[0])
        return d, u, d > u


# ---------------------------------------------------------------------------------------------
# What a case says
# ---------------------------------------------------------------------------------------------
@dataclass
class Best:
    """The best schedule of one kind at the finest level: its settings (indices into the
    setting table; -1: no such schedule computed), its area per level (NaN where not computed)
    and its error estimate."""

    draw: int
    hold: int
    area: np.ndarray
    error: float


def finest(result: CaseResult) -> int:
    return len(result.levels) - 1


def value_at(level: Level, objective: str, draw: int, hold: int) -> float:
    """The area of schedule draw -> hold (setting indices) at a level (NaN: not computed)."""
    where = {int(s): i for i, s in enumerate(level.settings)}
    if draw not in where or hold not in where:
        return math.nan
    return float(level.values(objective)[where[draw], where[hold]])


def best_of_kind(result: CaseResult, table: list, objective: str, kind: str,
                 n_levels: int) -> Best:
    """Step 4's best of a kind at the finest level, with its areas per level and its error."""
    top = result.levels[finest(result)]
    pair = best_pair(top.values(objective), kind_mask(table, top.settings, kind))
    areas = np.full(n_levels, np.nan)
    if pair is None:
        return Best(-1, -1, areas, math.nan)
    draw, hold = int(top.settings[pair[0]]), int(top.settings[pair[1]])
    for k, level in enumerate(result.levels):
        areas[k] = value_at(level, objective, draw, hold)
    k = finest(result)
    error = abs(areas[k] - areas[k - 1]) if k >= 1 else math.nan
    return Best(draw, hold, areas, float(error))


def verdict(fixed: Best, schedule: Best, k: int) -> tuple[float, float, str]:
    """Step 5: (d, u, verdict) at the finest level k."""
    d = float(schedule.area[k] - fixed.area[k])
    if tie_key(schedule.area[k]) == tie_key(fixed.area[k]):
        d = 0.0
    u = fixed.error + schedule.error
    if k == 0:
        return d, math.nan, "unestimated" if d > 0 else "none"
    return d, float(u), "gain" if d > u else "none"


def screened_best(result: CaseResult, table: list, objective: str, kind: str) -> tuple:
    """The best of a kind at level 0, over every setting: (draw, hold, area)."""
    level = result.levels[0]
    pair = best_pair(level.values(objective), kind_mask(table, level.settings, kind))
    if pair is None:
        return -1, -1, math.nan
    return (int(level.settings[pair[0]]), int(level.settings[pair[1]]),
            float(level.values(objective)[pair]))



VERDICT_RULE = ("gain when d = area(best schedule) - area(best fixed) > u = error(best "
                "schedule) + error(best fixed) at the finest rung, each error the change from "
                "the rung before; none otherwise; unestimated with one rung")
LADDER_RULE = ("rung 0: every setting; each further rung: the settings of the previous rung's "
               "contenders per objective (the `contenders` best fixed settings and switches, "
               "the best R switch and w switch, those with a positive area); ties at "
               "tie_digits significant digits to a fixed setting, then the first pair")


