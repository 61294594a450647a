"""The rules a refined answer rests on (docs/sweeps.md, "Refinement"; model-notes D18, D28,
D37): which classes contend, how a level separates them, a value's error estimate, and the
audit of the classes left out. Pure functions of the values measured; `sweep.runs.refine` runs
the maps they ask for.
"""
from __future__ import annotations

import math

import numpy as np

from ..config.scene import RefineSettings


def select_contenders(reps: np.ndarray, values: np.ndarray, settings: RefineSettings,
                      floor_only: bool = False) -> np.ndarray:
    """Representatives of the contending classes of one part (sorted, store order): every class
    whose screened value is at least (1 - bound) times the best, and the `min_contenders` best
    (store order among equal values); with `floor_only` those best only. Empty when the best
    value is not positive."""
    v = values[reps]
    best = float(v.max()) if v.size else 0.0
    if not best > 0.0:
        return np.zeros(0, dtype=np.int64)
    order = np.argsort(-v, kind="stable")
    keep = set(order[:settings.min_contenders].tolist())
    if not floor_only:
        keep.update(np.flatnonzero(v >= (1.0 - settings.bound) * best).tolist())
    return np.sort(reps[sorted(keep)])


#: Step 2: how many times the floor's largest change from screening to h/2 a class may be below
#: the floor's best at h/2 and still contend. A method whose error at least halves per level
#: changes a value by at most 2 D from screening to the limit (D + D/2 + ...), the best's by at
#: most D after h/2: a class below the best's h/2 value by more than 3 D cannot overtake it.
CHANGE_FACTOR = 3.0


def contender_cut(best0: float, now: np.ndarray, screened: np.ndarray, bound: float) -> float:
    """The screened caging area a class needs to contend in one part: the floor's best value at
    h/2 minus CHANGE_FACTOR times the floor's largest change from screening (`now` and
    `screened`: the floor's values), but never below (1 - bound) times the screened best."""
    change = float(np.max(np.abs(now - screened)))
    return max((1.0 - bound) * best0, float(np.max(now)) - CHANGE_FACTOR * change)


def error_estimate(change: float, before: float) -> float:
    """The error estimate of a value from its last change between levels, `change`, and the
    change before it, `before` (NaN where there is none: level 1). A method whose error at
    least halves per level has at most `change` left to go; where the changes shrink by a
    ratio q between 1/2 and 1, the geometric tail `change q / (1 - q)`; where they do not shrink
    the convergence is not established (the collision scene's creases converge non-
    monotonically), so the sum of the last two changes."""
    if not math.isfinite(before) or change <= 0.5 * before:
        return change
    if change < before:
        q = change / before
        return change * q / (1.0 - q)
    return change + before


def shrinking(change: float, before: float) -> bool:
    """Whether a value's changes between levels shrink (or it has changed once only)."""
    return not math.isfinite(before) or change < before


#: Step 4's audit: strata of a part's non-contenders by screened caging area, as fractions of
#: the part's best screened one (a stratum runs up to the one above it), and the classes each
#: gives. The top stratum, the designs nearest the contenders, is sampled most.
AUDIT_STRATA = ((0.6, 8), (0.3, 4), (0.0, 2))
#: A rise is relative to the screened value, but to no less than this fraction of the part's
#: best screened one (a design screened near 0 would otherwise make any rise infinite).
AUDIT_FLOOR = 0.25


def audit_sample(left_out: np.ndarray, screened: np.ndarray, best0: float,
                 seed: int) -> np.ndarray:
    """Step 4's sample of a part's non-contending classes `left_out` (representatives): in each
    stratum of AUDIT_STRATA, that many classes drawn at random (all if fewer), the draws
    seeded by `seed`. Sorted representatives."""
    rng = np.random.default_rng(seed)
    v = screened[left_out]
    picked: list = []
    upper = math.inf
    for low, n in AUDIT_STRATA:
        stratum = left_out[(v >= low * best0) & (v < upper * best0)]
        upper = low
        if stratum.size:
            picked.extend(rng.choice(stratum, min(n, stratum.size), replace=False).tolist())
    return np.sort(np.array(picked, dtype=np.int64))


def audit_rise(sample: np.ndarray, screened: np.ndarray, latest: np.ndarray,
               best0: float) -> float:
    """The largest relative rise of an audited class from its screened value to its latest
    (finest) one, against at least AUDIT_FLOOR of the part's best screened value; 0 where every
    audited class fell (or none was audited)."""
    if not sample.size:
        return 0.0
    base = np.maximum(screened[sample], AUDIT_FLOOR * best0)
    return max(0.0, float(np.max((latest[sample] - screened[sample]) / base)))


def could_win_unaudited(outside: np.ndarray, screened: np.ndarray, rise: float, best0: float,
                        best_low: float) -> np.ndarray:
    """The non-contending, unaudited classes of a part whose screened value raised by the
    audit's rise reaches `best_low` (the best's value minus its error)."""
    reach = screened[outside] + rise * np.maximum(screened[outside], AUDIT_FLOOR * best0)
    return outside[reach >= best_low]


def separate(now: np.ndarray, previous: np.ndarray) -> tuple[int, np.ndarray, np.ndarray]:
    """One level of one part: values `now` and the previous level's, per class in store order.
    Returns (position of the best, error estimates |now - previous|, mask of the classes still
    in the running: value + error >= best value - best error; the best always stays)."""
    err = np.abs(now - previous)
    b, keep = separated(now, err)
    return b, err, keep


def separated(now: np.ndarray, err: np.ndarray) -> tuple[int, np.ndarray]:
    """`separate` from the error estimates: (position of the best, mask of the classes still in
    the running)."""
    b = int(np.argmax(now))                    # first of the largest: store order
    keep = now + err >= now[b] - err[b]
    keep[b] = True
    return b, keep


def lead(now: np.ndarray, b: int) -> float:
    """The best value's lead over the runner-up among the classes computed at a level; NaN when
    the best was computed alone."""
    if now.size < 2:
        return math.nan
    return float(now[b] - np.max(np.delete(now, b)))
