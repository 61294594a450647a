"""Against the paper: every finding of the paper's discussion and conclusion tested on a store
(`against_paper.csv`, report.md's section "Against the paper").

`FINDINGS` holds each finding once: the paper's claim in one line, the paper's own numbers, the
rule of the verdict, and the measure that reads the store's number(s) and verdict (`VERDICTS`):
reproduced; reproduced within the numerical error (it fails for some part's best design but
holds for some choice of designs the store cannot tell from the best: the refinement's near-tie
set, or a tie at TIE_DIGITS in a screened store; only findings about best designs can have it,
no other quantity carries an error estimate in a store); not reproduced; not testable (the store
lacks the parts or variables). Why a finding is not reproduced: docs/reproduction.md, with the
counterfactuals of `scripts/against_paper.py`.
"""
from __future__ import annotations

import functools
import itertools
import math
from dataclasses import dataclass
from typing import Callable

import numpy as np

from .data import (CANDIDATE_DIMS, DESIGN_DIMS, PARAMETERS, StoreData, TIE_DIGITS,
                   best_design, candidate_metric_rows, fmt, md_table, representative_designs,
                   tie_key)

REPRODUCED = "reproduced"
WITHIN_ERROR = "reproduced within the numerical error"
NOT_REPRODUCED = "not reproduced"
NOT_TESTABLE = "not testable"
VERDICTS = (REPRODUCED, WITHIN_ERROR, NOT_REPRODUCED, NOT_TESTABLE)

#: Readings of the paper's words, stated once: "full range" of a parameter's usage, "almost
#: every part", and "the upper three-fourths" of the proximal link's range.
FULL_RANGE = 0.9
ALMOST_EVERY = 0.8
UPPER_THREE_FOURTHS = 0.75

#: The tolerance at which a store's coordinate equals a value the paper gives.
SAME_VALUE = 1e-9

#: The paper's frictions (its parts: every radius at each of them).
PAPER_MU = (0.1, 0.4, 0.7, 1.0)

#: The paper's best palm widths by part radius (its figure of best designs, as its text gives
#: them): the widths it names for the four parts of each radius.
PAPER_PALM = {0.4: (0.4,), 0.8: (0.8, 1.2), 1.2: (2.0,), 1.6: (2.0,)}


# ---------------------------------------------------------------------------------------------
# The store as the findings read it
# ---------------------------------------------------------------------------------------------
class Evidence:
    """A store (`StoreData`) as the findings read it: each part's best caging design and the
    designs the store cannot tell from it, each computed once; `top_k`: Scenario A's."""

    def __init__(self, st: StoreData, top_k: int | None = None):
        self.st = st
        self.top_k = top_k
        self._best: dict = {}
        self._alternatives: dict = {}

    def best(self, part: tuple[int, int]) -> dict:
        """The part's best caging design (`data.best_design`: refined where the store is)."""
        if part not in self._best:
            self._best[part] = best_design(self.st, *part)
        return self._best[part]

    def alternatives(self, part: tuple[int, int]) -> list[dict]:
        """The designs the store cannot tell from the part's best, the best among them: its
        near-tie set in a refined store (one design per equal-R class), else the designs whose
        Lambda ties the best's at TIE_DIGITS."""
        if part not in self._alternatives:
            best = self.best(part)
            if best.get("near_tie"):
                found = list(best["near_tie"])
            else:
                key = tie_key(self.st.per_design("Lambda", *part))
                found = [self.st.design(int(k)) for k in
                         np.flatnonzero(key == key[best["design_index"]])]
                found = [dict(d, R=d["r2"] / d["r1"]) for d in found]
            self._alternatives[part] = found
        return self._alternatives[part]

    def part(self, r: float, mu: float) -> tuple[int, int] | None:
        """(r index, mu index) of the part (r, mu), None if the store lacks it."""
        ri = np.flatnonzero(np.abs(self.st.r - r) <= SAME_VALUE)
        mi = np.flatnonzero(np.abs(self.st.mu - mu) <= SAME_VALUE)
        return (int(ri[0]), int(mi[0])) if ri.size and mi.size else None

    def total(self, name: str, part: tuple[int, int]) -> int:
        """A summary count of the part summed over every design."""
        return int(np.sum(self.st.per_design(name, *part)))


@dataclass(frozen=True)
class Result:
    number: str     # the project's number(s), as the report prints them
    verdict: str    # one of VERDICTS


def untestable(why: str) -> Result:
    return Result(why, NOT_TESTABLE)


def verdict_if(holds: bool) -> str:
    return REPRODUCED if holds else NOT_REPRODUCED


def same(a: float, b: float) -> bool:
    return abs(a - b) <= SAME_VALUE


def part_name(st: StoreData, part: tuple[int, int]) -> str:
    return f"r = {fmt(st.r[part[0]])}, mu = {fmt(st.mu[part[1]])}"


# ---------------------------------------------------------------------------------------------
# Verdicts on best designs: the best, or a design the store cannot tell from it
# ---------------------------------------------------------------------------------------------
HOLDS, WITHIN, FAILS = "holds", "within", "fails"


def verdict_of(states: list[str]) -> str:
    """Every state HOLDS: reproduced; none FAILS: within the numerical error; else not."""
    if all(s == HOLDS for s in states):
        return REPRODUCED
    return WITHIN_ERROR if all(s != FAILS for s in states) else NOT_REPRODUCED


def per_part(ev: Evidence, parts, holds: Callable[[dict], bool]) -> list[str]:
    """Per part: HOLDS for its best design, WITHIN for a design the store cannot tell from it,
    FAILS otherwise."""
    return [HOLDS if holds(ev.best(p)) else WITHIN if any(holds(a) for a in ev.alternatives(p))
            else FAILS for p in parts]


def over_choices(ev: Evidence, parts, value: Callable[[dict], float],
                 holds: Callable[[list], bool]) -> str:
    """A claim about the parts' best designs together (a trend): HOLDS for the best designs'
    values, WITHIN for some choice of designs the store cannot tell from them, else FAILS."""
    if holds([value(ev.best(p)) for p in parts]):
        return HOLDS
    options = [sorted({value(a) for a in ev.alternatives(p)}) for p in parts]
    return WITHIN if any(holds(list(c)) for c in itertools.product(*options)) else FAILS


def listed(st: StoreData, parts, value: Callable[[dict], float], ev: Evidence) -> str:
    """The best designs' values part by part: "mu 0.1: 1.2; mu 0.4: 0.8" keyed by mu or r
    (whichever varies), the near-tie alternatives in brackets."""
    vary_mu = len({p[1] for p in parts}) > 1
    out = []
    for p in parts:
        label = f"mu {fmt(st.mu[p[1]])}" if vary_mu else f"r {fmt(st.r[p[0]])}"
        best = value(ev.best(p))
        others = sorted({value(a) for a in ev.alternatives(p)} - {best})
        out.append(f"{label}: {fmt(best)}" + (f" [{', '.join(fmt(v) for v in others)}]"
                                             if others else ""))
    return "; ".join(out)


def non_decreasing(values: list) -> bool:
    return all(b >= a - SAME_VALUE for a, b in zip(values, values[1:]))


def rises(values: list) -> bool:
    return non_decreasing(values) and values[-1] > values[0] + SAME_VALUE


# ---------------------------------------------------------------------------------------------
# Caging ability
# ---------------------------------------------------------------------------------------------
def longest_links(ev: Evidence) -> Result:
    st = ev.st
    top = {d: float(st.ds[d].values.max()) for d in ("l1", "l2")}
    parts = st.parts()
    states = per_part(ev, parts, lambda d: same(d["l1"], top["l1"]) and same(d["l2"], top["l2"]))
    misses = [f"{part_name(st, p)}: l1 = {fmt(ev.best(p)['l1'])}, l2 = {fmt(ev.best(p)['l2'])}"
              for p, s in zip(parts, states) if s != HOLDS]
    return Result(f"{states.count(HOLDS)} of {len(parts)} parts at l1 = {fmt(top['l1'])}, "
                  f"l2 = {fmt(top['l2'])}" + (f" (not: {'; '.join(misses)})" if misses else ""),
                  verdict_of(states))


def palm_widths(ev: Evidence, radii: tuple, allowed: tuple, target: float,
                at_least: int) -> Result:
    """The best palm width of the parts of these radii at the paper's frictions: each in
    `allowed`, and `target` at `at_least` of them."""
    parts = [ev.part(r, mu) for r in radii for mu in PAPER_MU]
    if None in parts:
        return untestable("the store lacks these parts")

    def holds(ws):
        return (all(any(same(w, a) for a in allowed) for w in ws)
                and sum(same(w, target) for w in ws) >= at_least)

    state = over_choices(ev, parts, lambda d: d["w"], holds)
    n = sum(same(ev.best(p)["w"], target) for p in parts)
    text = "; ".join(f"r = {fmt(r)}: "
                     + listed(ev.st, [ev.part(r, mu) for mu in PAPER_MU], lambda d: d["w"], ev)
                     for r in radii)
    return Result(f"w by mu: {text} ({n} of {len(parts)} at w = {fmt(target)})",
                  verdict_of([state]))


def trend(ev: Evidence, along: str, value: str, rule: Callable[[list], bool],
          words: str) -> Result:
    """At each friction (along "r") or each radius (along "mu"): the best designs' `value` in
    order of the other, held to `rule` (with the choices of `over_choices`)."""
    st = ev.st
    n, m = (st.r.size, st.mu.size) if along == "r" else (st.mu.size, st.r.size)
    if n < 2:
        return untestable(f"one value of {along}")
    states, text = [], []
    for k in range(m):
        parts = [(i, k) if along == "r" else (k, i) for i in range(n)]
        states.append(over_choices(ev, parts, lambda d: d[value], rule))
        fixed = f"mu = {fmt(st.mu[k])}" if along == "r" else f"r = {fmt(st.r[k])}"
        text.append(f"{fixed}: {listed(st, parts, lambda d: d[value], ev)}")
    return Result(f"best {value} by {along}: {'; '.join(text)} ({words} at "
                  f"{states.count(HOLDS)} of {m}, {states.count(WITHIN)} more within the error)",
                  verdict_of(states))


def smooth_in_design(ev: Evidence) -> Result:
    """The caging area of a design predicted from its two neighbours one grid step either side
    in one parameter, against the refinement's error estimate of the best designs."""
    st = ev.st
    area = st.ds["caging_area"].transpose(*DESIGN_DIMS, "r", "mu").values
    errors = []
    for axis in range(len(DESIGN_DIMS)):
        if area.shape[axis] < 3:
            continue
        mid = np.take(area, range(1, area.shape[axis] - 1), axis=axis)
        lo = np.take(area, range(0, area.shape[axis] - 2), axis=axis)
        hi = np.take(area, range(2, area.shape[axis]), axis=axis)
        cages = mid > 0
        errors.append(np.abs((lo + hi)[cages] / 2 - mid[cages]) / mid[cages])
    if not errors or not st.refined:
        return untestable("needs three values of a parameter and a refined store")
    errors = np.concatenate(errors)
    numerical = []
    for p in st.parts():
        best = ev.best(p)
        if best.get("refined_caging_area", 0) > 0:
            numerical.append(best["refined_error"] / best["refined_caging_area"])
    med, p90, num = (float(np.median(errors)), float(np.percentile(errors, 90)),
                     float(np.median(numerical)))
    return Result(f"caging area from its two neighbours: median error {fmt(100 * med)} % "
                  f"(90th percentile {fmt(100 * p90)} %) over {errors.size:,} designs x parts "
                  f"x parameters that cage; the refined best designs' error estimate: median "
                  f"{fmt(100 * num)} %; interpolation of maps: docs/optimisation.md",
                  verdict_if(med <= num))


# ---------------------------------------------------------------------------------------------
# Caging versus tip prehension
# ---------------------------------------------------------------------------------------------
def size_trend(ev: Evidence, small: tuple, large: tuple) -> Result:
    a, b = ev.part(*small), ev.part(*large)
    if a is None or b is None:
        return untestable("the store lacks these parts")
    ca, cb = ev.total("n_caged", a), ev.total("n_caged", b)
    ta, tb = ev.total("n_tip_prehension", a), ev.total("n_tip_prehension", b)
    return Result(f"end points summed over designs, r = {fmt(small[0])} -> {fmt(large[0])}: "
                  f"caged {fmt(ca)} -> {fmt(cb)}, tip prehension {fmt(ta)} -> {fmt(tb)}",
                  verdict_if(cb < ca and tb > ta))


def friction_trend(ev: Evidence, name: str, rule: Callable[[list], bool]) -> Result:
    """`name` summed over designs, friction by friction, at every radius."""
    st = ev.st
    if st.mu.size < 2:
        return untestable("one friction")
    text, ok = [], []
    for ri in range(st.r.size):
        values = [ev.total(name, (ri, mi)) for mi in range(st.mu.size)]
        ok.append(rule(values))
        text.append(f"r = {fmt(st.r[ri])}: " + " -> ".join(fmt(v) for v in values))
    return Result(f"{name} summed over designs, mu = {fmt(st.mu[0])} -> {fmt(st.mu[-1])}: "
                  + "; ".join(text) + f" (as claimed at {sum(ok)} of {len(ok)} radii)",
                  verdict_if(all(ok)))


def representative_traits(ev: Evidence, part: tuple) -> Result:
    p = ev.part(*part)
    if p is None:
        return untestable("the store lacks this part")
    st = ev.st
    reps = representative_designs(st.per_design("n_caged", *p),
                                  st.per_design("n_tip_prehension", *p))
    cage, tip = st.design(reps["caging focused"]), st.design(reps["tip focused"])
    for d in (cage, tip):
        d["R"] = d["r2"] / d["r1"]
    traits = ("R", "l1", "l2", "w")
    larger = [t for t in traits if cage[t] > tip[t] + SAME_VALUE]
    text = ", ".join(f"{t} {fmt(cage[t])} vs {fmt(tip[t])}" for t in traits)
    return Result(f"caging-focused vs tip-focused design: {text} (larger: "
                  f"{', '.join(larger) or 'none'}; {len(larger)} of {len(traits)})",
                  verdict_if(len(larger) == len(traits)))


# ---------------------------------------------------------------------------------------------
# In-hand manipulation
# ---------------------------------------------------------------------------------------------
def a_and_b(ev: Evidence) -> list[tuple]:
    """Per part: (part, A of the best candidate, B)."""
    best = next(c for c in candidate_metric_rows(ev.st, ev.top_k, "a") if c["best"])
    a = ev.st.ds["manipulation_a"].transpose(*CANDIDATE_DIMS, "r", "mu").values[best["index"]]
    b = ev.st.ds["manipulation_b"].transpose("r", "mu").values
    return [(p, float(a[p]), float(b[p])) for p in ev.st.parts()]


def needs_manipulation(measure):
    @functools.wraps(measure)
    def checked(ev: Evidence, *args) -> Result:
        if not ev.st.manipulation or ev.top_k is None:
            return untestable("no manipulation metric in the store")
        return measure(ev, *args)
    return checked


@needs_manipulation
def scenario_a_gripper(ev: Evidence, gripper: tuple) -> Result:
    st = ev.st
    rows = sorted(candidate_metric_rows(st, ev.top_k, "a"), key=lambda c: -c["a_sum"])
    best = next(c for c in rows if c["best"])
    text = (f"l1 = {fmt(best['l1'])}, l2 = {fmt(best['l2'])}, r1 = {fmt(best['r1'])}, "
            f"r2 = {fmt(best['r2'])} (A summed over parts {fmt(best['a_sum'])})")
    index = []
    for d, v in zip(CANDIDATE_DIMS, gripper):
        hit = np.flatnonzero(np.abs(st.ds[d].values - v) <= SAME_VALUE)
        index.append(int(hit[0]) if hit.size else None)
    mine = all(same(best[d], v) for d, v in zip(CANDIDATE_DIMS, gripper))
    if not mine and None not in index:
        a = st.ds["manipulation_a"].transpose(*CANDIDATE_DIMS, "r", "mu").values[tuple(index)]
        total = float(np.nansum(a))
        rank = next((k + 1 for k, c in enumerate(rows) if c["index"] == tuple(index)), None)
        text += (f"; the paper's gripper: {fmt(total)} ({fmt(100 * total / best['a_sum'])} % of "
                 "the best), " + (f"rank {rank} of {len(rows)} candidates" if rank
                                  else "not among the candidates"))
    return Result(text, verdict_if(mine))


@needs_manipulation
def b_wins_half(ev: Evidence) -> Result:
    rows = [(p, a, b) for p, a, b in a_and_b(ev) if not (a == 0 and b == 0)]
    n_b = sum(b > a for _, a, b in rows)
    n_a = sum(a > b for _, a, b in rows)
    half = len(rows) / 2
    return Result(f"B wins {n_b}, A wins {n_a} of the {len(rows)} parts where not both are 0",
                  verdict_if(math.floor(half) <= n_b <= math.ceil(half)))


@needs_manipulation
def a_wins_where(ev: Evidence) -> Result:
    st = ev.st
    rows = a_and_b(ev)
    wins = {w: [p for p, a, b in rows if (a > b if w == "A" else b > a)] for w in ("A", "B")}
    if not wins["A"] or not wins["B"]:
        return Result(f"A wins {len(wins['A'])}, B wins {len(wins['B'])} parts",
                      NOT_REPRODUCED)
    mean = {w: (float(np.mean([st.r[p[0]] for p in ps])), float(np.mean([st.mu[p[1]]
                                                                         for p in ps])))
            for w, ps in wins.items()}
    ok = mean["A"][0] < mean["B"][0] and mean["A"][1] < mean["B"][1]
    return Result(f"mean r, mu where A wins: {fmt(mean['A'][0])}, {fmt(mean['A'][1])} "
                  f"({len(wins['A'])} parts); where B wins: {fmt(mean['B'][0])}, "
                  f"{fmt(mean['B'][1])} ({len(wins['B'])} parts)",
                  verdict_if(ok))


@needs_manipulation
def both_zero(ev: Evidence, parts: tuple) -> Result:
    st = ev.st
    zero = [p for p, a, b in a_and_b(ev) if a == 0 and b == 0]
    claimed = [ev.part(*q) for q in parts]
    if None in claimed:
        return untestable("the store lacks these parts")
    b = st.ds["manipulation_b"].transpose("r", "mu").values
    poses = st.ds["manipulation_b_poses"].transpose("r", "mu").values
    others = "; ".join(f"{part_name(st, p)}: B = {fmt(b[p])} ({int(poses[p])} poses)"
                       for p in claimed if p not in zero)
    return Result("both 0 at " + ("; ".join(part_name(st, p) for p in zero) or "no part")
                  + (f" (not: {others})" if others else ""),
                  verdict_if(sorted(zero) == sorted(claimed)))


def usage_table(ev: Evidence) -> dict:
    """Scenario B's parameter usage per parameter: {name: (parts, values)} over the parts with
    a positive pose (NaN elsewhere)."""
    u = ev.st.ds["parameter_usage"].transpose("r", "mu", "parameter")
    names = [str(p) for p in u["parameter"].values]
    out = {}
    for name in PARAMETERS:
        vals = u.values[..., names.index(name)]
        parts = [p for p in ev.st.parts() if not np.isnan(vals[p])]
        out[name] = (parts, np.array([vals[p] for p in parts]))
    return out


@needs_manipulation
def usage_full(ev: Evidence, names: tuple) -> Result:
    table = usage_table(ev)
    text, ok = [], []
    for name in names:
        parts, vals = table[name]
        n = int(np.count_nonzero(vals >= FULL_RANGE))
        ok.append(bool(parts) and n >= ALMOST_EVERY * len(parts))
        text.append(f"{name}: {n} of {len(parts)} parts at >= {fmt(FULL_RANGE)} (mean "
                    f"{fmt(float(vals.mean()) if vals.size else math.nan)})")
    return Result("; ".join(text), verdict_if(all(ok)))


@needs_manipulation
def links_matter_less(ev: Evidence) -> Result:
    table = usage_table(ev)
    mean = {p: float(table[p][1].mean()) if table[p][1].size else math.nan for p in PARAMETERS}
    links, others = ("l1", "l2"), ("w", "r1", "r2")
    ok = all(mean[a] < mean[b] for a in links for b in others)
    return Result("mean usage: " + ", ".join(f"{p} {fmt(mean[p])}" for p in PARAMETERS),
                  verdict_if(ok))


@needs_manipulation
def links_narrow_with_size(ev: Evidence) -> Result:
    st = ev.st
    if st.r.size < 2:
        return untestable("one part size")
    table = usage_table(ev)
    text, ok = [], []
    for name in ("l1", "l2"):
        parts, vals = table[name]
        small = [v for p, v in zip(parts, vals) if p[0] == 0]
        large = [v for p, v in zip(parts, vals) if p[0] == st.r.size - 1]
        if not small or not large:
            return untestable("no positive pose at the smallest or largest part")
        s, b = float(np.mean(small)), float(np.mean(large))
        ok.append(b < s)
        text.append(f"{name} {fmt(s)} -> {fmt(b)}")
    return Result(f"mean usage, r = {fmt(st.r[0])} -> {fmt(st.r[-1])}: " + ", ".join(text),
                  verdict_if(all(ok)))


@needs_manipulation
def small_part_links(ev: Evidence, r: float) -> Result:
    table = usage_table(ev)
    l1 = [v for p, v in zip(*table["l1"]) if same(ev.st.r[p[0]], r)]
    l2 = [v for p, v in zip(*table["l2"]) if same(ev.st.r[p[0]], r)]
    if not l1:
        return untestable("no positive pose at this part size")
    ok = all(v >= FULL_RANGE for v in l2) and all(v <= UPPER_THREE_FOURTHS + SAME_VALUE
                                                  for v in l1)
    return Result(f"r = {fmt(r)} by mu: l2 " + ", ".join(fmt(v) for v in l2) + "; l1 "
                  + ", ".join(fmt(v) for v in l1), verdict_if(ok))


# ---------------------------------------------------------------------------------------------
# Takeaways
# ---------------------------------------------------------------------------------------------
def variable_palm(ev: Evidence) -> Result:
    st = ev.st
    if st.r.size < 2:
        return untestable("one part size")
    states = []
    for mi in range(st.mu.size):
        parts = [(0, mi), (st.r.size - 1, mi)]
        states.append(over_choices(ev, parts, lambda d: d["w"], lambda ws: not same(*ws)))
    text = (f"best w differs between r = {fmt(st.r[0])} and {fmt(st.r[-1])} at "
            f"{states.count(HOLDS)} of {len(states)} frictions")
    verdict = verdict_of(states)
    if st.manipulation:
        parts, vals = usage_table(ev)["w"]
        text += f"; Scenario B's usage of w: mean {fmt(float(vals.mean()))} over {len(parts)} parts"
        if not (vals.size and vals.mean() >= FULL_RANGE):
            verdict = NOT_REPRODUCED
    return Result(text, verdict)


def ratio_cage_versus_tip(ev: Evidence) -> Result:
    """Per part: the best caging design's R against the R of the design with the most
    tip-prehension end points (the tip-focused design)."""
    st = ev.st
    parts = st.parts()
    tip_r = {}
    for p in parts:
        k = representative_designs(st.per_design("n_caged", *p),
                                   st.per_design("n_tip_prehension", *p))["tip focused"]
        d = st.design(k)
        tip_r[p] = d["r2"] / d["r1"]
    states = [per_part(ev, [p], lambda d, p=p: d["R"] > tip_r[p] + SAME_VALUE)[0]
              for p in parts]
    misses = [f"{part_name(st, p)}: {fmt(ev.best(p)['R'])} vs {fmt(tip_r[p])}"
              for p, s in zip(parts, states) if s != HOLDS]
    return Result(f"best caging R above the tip-focused design's R at {states.count(HOLDS)} "
                  f"of {len(parts)} parts" + (f" (not: {'; '.join(misses)})" if misses else ""),
                  verdict_of(states))


# ---------------------------------------------------------------------------------------------
# The findings, once
# ---------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class Finding:
    key: str
    topic: str
    claim: str      # the paper's finding, in one line
    paper: str      # what the paper reports (its own numbers)
    rule: str       # how the verdict is decided
    measure: Callable[[Evidence], Result]


FINDINGS = (
    Finding("longest_links", "caging ability",
            "Every part's best caging design has the longest links of the search.",
            "l1 = 2.0, l2 = 1.6 for all 16 parts",
            "every part's best design at the store's largest l1 and l2", longest_links),
    Finding("palm_smallest", "caging ability",
            "For the smallest part the best palm width equals the part radius.",
            "r = 0.4: w = 0.4 at every friction",
            "best w = 0.4 at the four parts r = 0.4",
            lambda ev: palm_widths(ev, (0.4,), PAPER_PALM[0.4], 0.4, 4)),
    Finding("palm_second", "caging ability",
            "The palm widens with the part: 0.8 -> 1.2 at the second part size.",
            "r = 0.8: w = 1.2 at three of four frictions, 0.8 at the other (the text says "
            "'third column'; read as the second, the only reading consistent with '2.0 in "
            "the right two columns')",
            "best w in {0.8, 1.2} at each of the four parts r = 0.8, and w = 1.2 at three of "
            "them or more",
            lambda ev: palm_widths(ev, (0.8,), PAPER_PALM[0.8], 1.2, 3)),
    Finding("palm_large", "caging ability",
            "The two largest parts use the widest palm.",
            "r = 1.2 and 1.6: w = 2.0 at every friction",
            "best w = 2.0 at the eight parts r = 1.2, 1.6",
            lambda ev: palm_widths(ev, (1.2, 1.6), PAPER_PALM[1.6], 2.0, 8)),
    Finding("palm_grows", "caging ability",
            "As the part size increases so does the best palm width.",
            "w: 0.4 (r = 0.4) -> 0.8/1.2 -> 2.0 -> 2.0",
            "at every friction the best w never falls as r grows",
            lambda ev: trend(ev, "r", "w", non_decreasing, "never falls")),
    Finding("ratio_friction", "caging ability",
            "For a given part radius the best transmission ratio R rises with friction.",
            "qualitative (the figure of best designs)",
            "at every r the best R never falls as mu grows and ends higher than it starts",
            lambda ev: trend(ev, "mu", "R", rises, "rises")),
    Finding("smooth_maps", "caging ability",
            "Energy maps are smooth in the design: a sparser search with interpolation "
            "could find the optimal designs.", "qualitative (the figure of best designs)",
            "median error of the caging area predicted from its two neighbouring designs "
            "at most the refined best designs' median error estimate", smooth_in_design),
    Finding("size_trend", "caging versus tip prehension",
            "A larger part gives fewer caging and more tip-prehension end points.",
            "r = 0.4 against r = 1.6 at mu = 1.0 (the figure): caging drastically fewer, tip "
            "prehension more",
            "summed over designs: caged end points fewer and tip-prehension end points more "
            "at r = 1.6 than at r = 0.4, mu = 1.0",
            lambda ev: size_trend(ev, (0.4, 1.0), (1.6, 1.0))),
    Finding("tip_friction", "caging versus tip prehension",
            "More friction gives more tip-prehension end points.", "qualitative",
            "at every r the tip-prehension end points summed over designs never fall as mu "
            "grows and end higher",
            lambda ev: friction_trend(ev, "n_tip_prehension", rises)),
    Finding("caging_friction", "caging versus tip prehension",
            "More friction seems to give fewer caging end points.",
            "qualitative ('seemed to decrease')",
            "at every r fewer caged end points summed over designs at the highest mu than "
            "at the lowest",
            lambda ev: friction_trend(ev, "n_caged", lambda v: v[-1] < v[0])),
    Finding("representatives", "caging versus tip prehension",
            "The caging-focused design has a larger R, longer links and a wider palm than "
            "the tip-focused one.",
            "r = 0.4, mu = 1.0: designs A (caging) against C (tip prehension) of the figure",
            "the caging-focused design (most caged end points) larger than the tip-focused "
            "one (most tip-prehension end points) in R, l1, l2 and w",
            lambda ev: representative_traits(ev, (0.4, 1.0))),
    Finding("scenario_a_gripper", "manipulation",
            "Scenario A's best gripper over all parts.",
            "l1 = 2.0, l2 = 1.6, r1 = 0.2, r2 = 0.14",
            "the candidate with the largest A summed over parts is the paper's",
            lambda ev: scenario_a_gripper(ev, (2.0, 1.6, 0.2, 0.14))),
    Finding("b_wins_half", "manipulation",
            "Scenario B beats A on half of the parts where not both are zero.", "7 of 14",
            "B's wins are half of the parts not both zero (rounded either way)", b_wins_half),
    Finding("a_wins_small", "manipulation",
            "A is better for smaller parts and lower friction, B for higher friction.",
            "qualitative",
            "the parts A wins have a smaller mean r and a smaller mean mu than those B wins",
            a_wins_where),
    Finding("both_zero", "manipulation",
            "Both scenarios score zero for the largest part at the two highest frictions.",
            "r = 1.6, mu = 0.7 and 1.0 (and no other part)",
            "A and B are both 0 exactly at these two parts",
            lambda ev: both_zero(ev, ((1.6, 0.7), (1.6, 1.0)))),
    Finding("usage_palm", "manipulation",
            "The palm width uses its full range for almost every part.",
            "qualitative (the usage figure)",
            f"w's usage at least {FULL_RANGE} at {ALMOST_EVERY:.0%} of the parts with a "
            "positive pose or more",
            lambda ev: usage_full(ev, ("w",))),
    Finding("usage_pulleys", "manipulation",
            "The pulley radii use their full range for almost every part.",
            "qualitative (the usage figure)",
            f"r1's and r2's usage each at least {FULL_RANGE} at {ALMOST_EVERY:.0%} of the "
            "parts with a positive pose or more",
            lambda ev: usage_full(ev, ("r1", "r2"))),
    Finding("links_less", "manipulation",
            "Variable link lengths are less important than palm and pulleys.", "qualitative",
            "mean usage of l1 and of l2 below each of w's, r1's and r2's", links_matter_less),
    Finding("links_size", "manipulation",
            "As the part grows the links are pushed to their upper bounds.", "qualitative",
            "the mean usage of l1 and of l2 lower at the largest part than at the smallest",
            links_narrow_with_size),
    Finding("links_small", "manipulation",
            "For the smallest parts the distal link uses its full range, the proximal link "
            "mainly the upper three-fourths of its range.", "qualitative",
            f"at r = 0.4: l2's usage at least {FULL_RANGE}, l1's at most "
            f"{UPPER_THREE_FOURTHS}, at every friction",
            lambda ev: small_part_links(ev, 0.4)),
    Finding("take_palm", "takeaways",
            "A variable palm width is important (caging parts of different sizes, "
            "manipulation).", "abstract, takeaways and conclusion",
            "at every mu the best w of the smallest and the largest part differ, and w's mean "
            f"usage in Scenario B is at least {FULL_RANGE}", variable_palm),
    Finding("take_ratio", "takeaways",
            "A variable R is needed: a large R draws a part into a cage, a small R keeps a "
            "tip-prehension grasp.", "abstract, takeaways and conclusion",
            "at every part the best caging design's R above the R of the design with the most "
            "tip-prehension end points", ratio_cage_versus_tip),
    Finding("take_friction", "takeaways",
            "A large R is needed to draw in parts when friction is large.",
            "takeaways and conclusion",
            "at every r the best R at the highest mu above the best R at the lowest",
            lambda ev: trend(ev, "mu", "R", lambda v: v[-1] > v[0] + SAME_VALUE,
                             "higher at the highest mu")),
)


# ---------------------------------------------------------------------------------------------
# Tables and report.md
# ---------------------------------------------------------------------------------------------
def finding_rows(st: StoreData, top_k: int | None) -> list[dict]:
    """One row per finding: the paper's claim and numbers, the rule, the store's number(s) and
    the verdict."""
    ev = Evidence(st, top_k)
    rows = []
    for n, f in enumerate(FINDINGS, start=1):
        res = f.measure(ev)
        rows.append(dict(n=n, key=f.key, topic=f.topic, claim=f.claim, paper=f.paper,
                         rule=f.rule, number=res.number, verdict=res.verdict))
    return rows


def pair_rows(rows_1: list[dict], rows_2: list[dict]) -> list[dict]:
    """Two scenes' rows side by side (`number_1`, `verdict_1`, `number_2`, `verdict_2`)."""
    return [dict({k: x[k] for k in ("n", "key", "topic", "claim", "paper", "rule")},
                 number_1=x["number"], verdict_1=x["verdict"], number_2=y["number"],
                 verdict_2=y["verdict"]) for x, y in zip(rows_1, rows_2)]


COLUMNS = ["n", "key", "topic", "claim", "paper", "number", "verdict", "rule"]
PAIR_COLUMNS = ["n", "key", "topic", "claim", "paper", "number_1", "verdict_1", "number_2",
                "verdict_2", "rule"]


def tally(rows: list[dict], column: str = "verdict") -> str:
    return ", ".join(f"{sum(r[column] == v for r in rows)} {v}" for v in VERDICTS
                     if any(r[column] == v for r in rows))


def section(rows: list[dict], tags: tuple[str, ...] = ()) -> list[str]:
    """report.md's section: the rules, the tally per scene, then the table (one store: `rows`
    from finding_rows; two scenes: from pair_rows, `tags` naming their columns' scenes)."""
    L = ["Every finding of the paper's discussion and conclusion (`energy-map-paper-"
         "discussion.tex`), the project's number(s) read from the store and a verdict "
         "(`sweep/report/paper.py`: the finding, its number and its rule in one place). "
         "*Reproduced within the numerical error*: the claim fails for a part's best design "
         "but holds for a design the store cannot tell from it (the refinement's near-tie set, "
         f"or a tie at {TIE_DIGITS} significant digits); only findings about best designs can "
         "have it. Readings of the paper's words: 'full range' is a usage of at least "
         f"{FULL_RANGE}, 'almost every part' {ALMOST_EVERY:.0%} of them. Why each finding not "
         "reproduced differs, with the counterfactual that shows it: docs/reproduction.md; "
         "the interpolation claim is tested on maps in docs/optimisation.md.", ""]
    if tags:
        for i, tag in enumerate(tags, start=1):
            L.append(f"- Scene {i} ({tag}): {tally(rows, f'verdict_{i}')}.")
        L += ["", md_table(rows, [c for c in PAIR_COLUMNS if c != "rule"],
                           ["#", "key", "topic", "finding (the paper)", "the paper", "scene 1",
                            "verdict 1", "scene 2", "verdict 2"])]
    else:
        L += [f"- {tally(rows)}.", "",
              md_table(rows, [c for c in COLUMNS if c != "rule"],
                       ["#", "key", "topic", "finding (the paper)", "the paper", "this store",
                        "verdict"])]
    L += ["", "Rules of the verdicts (`against_paper.csv` has them beside every row):", ""]
    L += [f"- {r['n']}. {r['key']}: {r['rule']}." for r in rows]
    return L
