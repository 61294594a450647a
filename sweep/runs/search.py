"""A derivative-free search of a box for a score that counts grid points (docs/optimisation.md).

The caging area is piecewise constant in the design and jumps by a grid cell's area where a
trajectory changes its end: gradients are zero or undefined, and differences below the map's
spacing are noise. So the search is global first, local second, and never finer than the noise:

1. `evolve`: scipy's differential evolution (it accepts a trial that is *as good as* its parent,
   so the population drifts across plateaus) with the seeds in its initial population and no
   gradient polish. scipy redraws out-of-box trial values at random, so optima on a bound would
   be reached only by chance: the box it searches is widened by `MARGIN` on each side and every
   point is made feasible inside the objective (`Box.feasible`: clipped, the length budget
   projected, fixed values set), so a trial beyond a bound evaluates the design on it.
2. `pattern_search`: a compass search from a start, polling +- one step in each free parameter,
   moving to the best strict improvement, halving the steps when none improves, and stopping
   when the steps reach `min_step` (chosen above the noise by the caller).

Both are deterministic for a seed; neither computes anything itself: `score(design) -> float`
(larger is better) is the caller's (`sweep.runs.optimize` evaluates maps through a memo).
"""
from __future__ import annotations

import inspect
import math
from dataclasses import dataclass, field

import numpy as np
from scipy.optimize import differential_evolution
from scipy.stats import qmc

#: The design's parameters, in store order.
PARAMS = ("l1", "l2", "r1", "r2", "w")
#: How far beyond each bound (a fraction of the box's width) differential evolution may try a
#: value; the objective clips it onto the bound.
MARGIN = 0.05


class BudgetSpent(Exception):
    """The score's evaluation budget is spent (raised by the caller's score)."""


@dataclass(frozen=True)
class Box:
    """The design space a designer states: bounds per parameter, fixed values, a budget on the
    finger length l1 + l2, and the resolution designs are made to (a design is rounded to it, so
    that designs closer than that are one design)."""

    lower: tuple
    upper: tuple
    fixed: dict = field(default_factory=dict)
    length_budget: float | None = None
    resolution: float = 1e-3

    def __post_init__(self):
        lo, hi = np.asarray(self.lower, float), np.asarray(self.upper, float)
        if lo.shape != (len(PARAMS),) or hi.shape != lo.shape:
            raise ValueError("a box needs a lower and an upper value per parameter")

    @property
    def lo(self) -> np.ndarray:
        return np.array([self.fixed.get(k, v) for k, v in zip(PARAMS, self.lower)], float)

    @property
    def hi(self) -> np.ndarray:
        return np.array([self.fixed.get(k, v) for k, v in zip(PARAMS, self.upper)], float)

    @property
    def free(self) -> list[int]:
        """Indices of the parameters the search moves (not fixed, lower < upper)."""
        lo, hi = self.lo, self.hi
        return [i for i, k in enumerate(PARAMS) if k not in self.fixed and hi[i] > lo[i]]

    def full(self, x_free) -> np.ndarray:
        """A design (5,) from the free parameters' values, the others at their (fixed) value."""
        d = self.lo.copy()
        d[self.free] = np.asarray(x_free, float)
        return d

    def feasible(self, design) -> np.ndarray:
        """The design made feasible: clipped into the box, l1 + l2 brought within the budget
        (the nearest such point: both lengths shortened by the same amount, as far as their
        bounds allow), rounded to the resolution (down where the budget binds)."""
        lo, hi = self.lo, self.hi
        d = np.clip(np.asarray(design, float), lo, hi)
        L = self.length_budget
        if L is not None and d[0] + d[1] > L:
            movable = [i for i in (0, 1) if i in self.free]
            excess = d[0] + d[1] - L
            for _ in range(2):
                if not movable or excess <= 0:
                    break
                share = excess / len(movable)
                for i in list(movable):
                    new = max(lo[i], d[i] - share)
                    excess -= d[i] - new
                    d[i] = new
                    if new <= lo[i]:
                        movable.remove(i)
        res = self.resolution
        q = np.round(d / res) * res
        if L is not None and q[0] + q[1] > L + 1e-9:
            for i in (1, 0):
                if i in self.free and q[0] + q[1] > L + 1e-9:
                    q[i] = math.floor((L - q[1 - i]) / res + 1e-9) * res
        return np.clip(np.round(q, 12), lo, hi)

    def active(self, design, tol: float | None = None) -> dict:
        """The stated constraints the design is on: {name: 'lower'|'upper'|'fixed'} per
        parameter, and 'length_budget' -> 'upper' when l1 + l2 is at the budget."""
        tol = self.resolution / 2 if tol is None else tol
        d, lo, hi = np.asarray(design, float), self.lo, self.hi
        out = {}
        for i, k in enumerate(PARAMS):
            if k in self.fixed:
                out[k] = "fixed"
            elif d[i] <= lo[i] + tol:
                out[k] = "lower"
            elif d[i] >= hi[i] - tol:
                out[k] = "upper"
        if self.length_budget is not None and d[0] + d[1] >= self.length_budget - 2 * tol:
            out["length_budget"] = "upper"
        return out


@dataclass
class Trace:
    """What a search did: its end point and score, and the points it scored."""

    best: np.ndarray
    value: float
    points: int = 0
    steps: list = field(default_factory=list)


def _rng_kw(function, seed: int) -> dict:
    # scipy >= 1.15 names it `rng`; earlier versions `seed`
    params = inspect.signature(function).parameters
    return {"rng": seed} if "rng" in params else {"seed": seed}


def initial_population(box: Box, seeds: np.ndarray, size: int, seed: int) -> np.ndarray:
    """The seeds (designs, (k, 5)) made feasible, then a scrambled Latin hypercube of the free
    box for the rest: (size, n_free), deterministic for `seed`."""
    free = box.free
    lo, hi = box.lo[free], box.hi[free]
    rows = [box.feasible(s)[free] for s in np.asarray(seeds, float).reshape(-1, len(PARAMS))]
    rows = rows[:size]
    n_more = max(size - len(rows), 0)
    if n_more:
        lhs = qmc.LatinHypercube(d=len(free), **_rng_kw(qmc.LatinHypercube, seed)).random(n_more)
        rows += list(lo + lhs * (hi - lo))
    return np.array(rows, float).reshape(-1, len(free))


def evolve(score, box: Box, seeds: np.ndarray, seed: int, popsize: int, stop) -> Trace:
    """Differential evolution of the free parameters maximising `score(design)`; the population
    starts from `seeds` and a Latin hypercube (`initial_population`); stops after a generation
    when `stop()` is true, or when `score` raises BudgetSpent. Deterministic for `seed`."""
    free = box.free
    lo, hi = box.lo[free], box.hi[free]
    pad = MARGIN * (hi - lo)
    best = {"x": None, "v": -math.inf}

    def objective(x):
        d = box.feasible(box.full(x))
        v = score(d)
        if v > best["v"]:
            best.update(x=d, v=v)
        return -v

    init = initial_population(box, seeds, max(popsize, 5), seed)
    try:
        res = differential_evolution(objective, list(zip(lo - pad, hi + pad)), init=init,
                                     polish=False, maxiter=100_000, tol=0.0, atol=0.0,
                                     updating="immediate", workers=1,
                                     callback=lambda *a, **k: bool(stop()),
                                     **_rng_kw(differential_evolution, seed))
        nfev = int(res.nfev)
    except BudgetSpent:
        nfev = -1
    return Trace(best["x"], float(best["v"]), nfev)


def pattern_search(score, box: Box, start, step: np.ndarray, min_step: np.ndarray) -> Trace:
    """Compass search from `start` (a design): poll +- step in each free parameter (in
    parameter order), move to the best strictly better feasible point, else halve the steps of
    the free parameters; stop when every step is below its `min_step` or `score` raises
    BudgetSpent. `step`, `min_step`: (5,) per parameter."""
    x = box.feasible(start)
    free = box.free
    try:
        v = score(x)
    except BudgetSpent:
        return Trace(x, -math.inf)
    step = np.asarray(step, float).copy()
    min_step = np.asarray(min_step, float)
    trace = Trace(x, v)
    try:
        while any(step[i] >= min_step[i] for i in free):
            polls = []
            for i in free:
                if step[i] < min_step[i]:
                    continue
                for sign in (1.0, -1.0):
                    y = x.copy()
                    y[i] += sign * step[i]
                    y = box.feasible(y)
                    if not np.array_equal(y, x):
                        polls.append(y)
            scored = [(score(y), k) for k, y in enumerate(polls)]
            trace.points += len(scored)
            better = [(s, k) for s, k in scored if s > v]
            if better:
                s, k = max(better, key=lambda t: (t[0], -t[1]))
                x, v = polls[k], s
                trace.steps.append(("move", x.copy(), v))
            else:
                step[free] /= 2.0
                trace.steps.append(("shrink", x.copy(), v))
    except BudgetSpent:
        pass
    trace.best, trace.value = x, v
    return trace


def distinct(designs: list) -> list:
    """The designs without repeats, in order."""
    out, seen = [], set()
    for d in designs:
        k = tuple(np.round(np.asarray(d, float), 9))
        if k not in seen:
            seen.add(k)
            out.append(np.asarray(d, float))
    return out


def multi_start(score, box: Box, seeds, seed: int, popsize: int, evolve_stop, starts: int,
                step, min_step) -> tuple[Trace, list]:
    """Differential evolution from `seeds` (until `evolve_stop()`), then a compass search from
    each of `starts` starts: evolution's best, then the seeds in order (distinct, feasible).
    Returns (evolution's trace, the compass searches' traces)."""
    trace = evolve(score, box, seeds, seed, popsize, evolve_stop)
    feasible = [box.feasible(d) for d in np.asarray(seeds, float).reshape(-1, len(PARAMS))]
    first = [trace.best] if trace.best is not None else []
    ends = [pattern_search(score, box, x0, step, min_step)
            for x0 in distinct(first + feasible)[:starts]]
    return trace, ends
