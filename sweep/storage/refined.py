"""What a refined store's variables mean, for its readers (`sweep top`, `sweep report`) and for
the refinement stage that writes them (`sweep.runs.refine`): equal-R classes of designs, the
refined ranking of a part, a part's outcome (certified design or near-tie set).
"""
from __future__ import annotations

import itertools
from dataclasses import dataclass

import numpy as np

from ..schema import DESIGN_KEYS, REFINE_ROLE_MEANINGS, REFINE_STATUS_MEANINGS

ROLE = {name: code for code, name in enumerate(REFINE_ROLE_MEANINGS)}
STATUS = {name: code for code, name in enumerate(REFINE_STATUS_MEANINGS)}
#: Significant digits of R = r2/r1 that decide equal-R classes (0.02/0.06 is 0.33333333333333337
#: in floating point, 0.06/0.18 is 0.3333333333333333).
R_DIGITS = 12


def equal_r_classes(designs: np.ndarray) -> np.ndarray:
    """Per design, the flat index of its class's representative: the first design in store
    order with the same l1, l2, w and R = r2/r1 (to R_DIGITS significant digits)."""
    rep: dict = {}
    out = np.empty(designs.shape[0], dtype=np.int64)
    for k, (l1, l2, r1, r2, w) in enumerate(designs):
        key = (l1, l2, w, float(f"{r2 / r1:.{R_DIGITS}g}"))
        out[k] = rep.setdefault(key, k)
    return out


def ranking(role: np.ndarray, value: np.ndarray, screened: np.ndarray) -> np.ndarray:
    """Flat design indices of one part, best first: the designs still in the running at the
    finest level (best, then the near-tie set), then the eliminated contenders, then the rest;
    inside each group by caging area at the finest level each design reached (the screened
    value for the rest), store order among equal values."""
    final = (role == ROLE["near_tie"]) | (role == ROLE["best"])
    group = np.where(final, 2, np.where(role == ROLE["eliminated"], 1, 0))
    v = np.where(np.isnan(value), screened, value)
    v = np.where(np.isnan(v), -np.inf, v)
    return np.lexsort((np.arange(v.size), -v, -group))


def designs_of_coords(coords: dict) -> np.ndarray:
    """The design table (as `design_table`) from a store's coordinates."""
    return np.array(list(itertools.product(*(coords[k] for k in DESIGN_KEYS))),
                    dtype=np.float64).reshape(-1, len(DESIGN_KEYS))


@dataclass
class PartOutcome:
    """One part's refined answer, as read from a store (`part_outcome`)."""

    status: str                 # REFINE_STATUS_MEANINGS
    finest_h: float
    margin: float               # lead of the best over the runner-up at the finest level
    best: int                   # flat design index: the first design of the best's class
    n_best: int                 # designs of the best's equal-R class (they tie exactly)
    members: list               # the final set, best first: [best] when certified
    value: np.ndarray           # per design: refined caging area (NaN: screened only)
    error: np.ndarray           # per design: its error estimate
    bound_held: bool = True     # the part's bound check (module docstring)
    widenings: int | None = 0   # rounds of re-admission (None: a store refined before them)
    n_readmitted: int = 0       # designs re-admitted by the bound check
    audit_designs: int | None = None   # designs the audit recomputed (None: no audit stored)
    audit_rise: float = float("nan")   # its largest relative rise from screening
    audit_h: float = float("nan")      # the spacing it recomputed them at

    @property
    def certified(self) -> bool:
        return self.status == "certified"

    def audit_label(self) -> str:
        """What the certificate rests on for the designs left out, in a few words."""
        if self.audit_designs is None:
            return "no audit (refined by an earlier version)"
        if not self.audit_designs:
            return "every design contended"
        return f"audit {self.audit_designs} at h={self.audit_h:g}, rise <= {self.audit_rise:.1%}"

    def audit_note(self) -> str:
        """What the certificate rests on for the designs left out, in words."""
        if self.audit_designs is None or not self.audit_designs:
            return self.audit_label()
        return (f"{self.audit_designs} design{'s' if self.audit_designs != 1 else ''} left out "
                f"recomputed at h = {self.audit_h:g} (a stratified random sample), their "
                f"largest rise from screening {self.audit_rise:.1%}; every other design left "
                f"out would have to rise more than all of them to reach the best")

    def bound_label(self) -> str:
        """`bound_note` in a few words, for a table cell ('' when the bound held at once)."""
        if self.widenings:
            return f"bound widened ({self.n_readmitted} re-admitted)"
        return "" if self.bound_held else "bound not confirmed (refine again)"

    def bound_note(self) -> str:
        """What the part's bound check did, in words ('' when it held at once)."""
        if self.widenings:
            rounds = f"{self.widenings} round{'s' if self.widenings != 1 else ''}"
            return (f"contender bound widened: {self.n_readmitted} "
                    f"design{'s' if self.n_readmitted != 1 else ''} that could win re-admitted "
                    f"and recomputed in {rounds}")
        if self.bound_held:
            return ""
        # Only a store refined before the refinement widened its own bound gets here.
        return ("contender bound not confirmed: a design left out could be the best (refined "
                "by an earlier version, which did not re-admit such designs; `sweep refine` on "
                "this store does)")


def part_outcome(reps: np.ndarray, role: np.ndarray, value: np.ndarray, error: np.ndarray,
                 status: int, finest_h: float, margin: float,
                 bound_held: bool = True, widenings: int | None = 0,
                 n_readmitted: int = 0, audit: tuple | None = None) -> PartOutcome:
    """A part's outcome from its refinement variables (per-design arrays flat in store order,
    per-part scalars). `reps`: `equal_r_classes` of the store's designs; `widenings` None for a
    store without `refine_widenings` (refined before the bound check re-admitted designs);
    `audit`: (designs audited, largest rise, spacing), None for a store without an audit."""
    alive = np.flatnonzero((role == ROLE["near_tie"]) | (role == ROLE["best"]))
    members = [int(d) for d in alive if reps[d] == d]
    members.sort(key=lambda d: (-value[d], d))
    best = int(np.flatnonzero(role == ROLE["best"])[0]) if (role == ROLE["best"]).any() else -1
    return PartOutcome(REFINE_STATUS_MEANINGS[int(status)], float(finest_h), float(margin), best,
                       int(np.sum(role == ROLE["best"])), members, value, error,
                       bool(bound_held), None if widenings is None else int(widenings),
                       int(n_readmitted),
                       *((int(audit[0]), float(audit[1]), float(audit[2])) if audit is not None
                         else ()))
