"""Schedules of settings (MODEL 12; model-notes D35): draw in with one setting X, then hold with
another Y, read from the two maps' trajectory ends.

*One lattice.* Every map of one chassis (l1, l2) and part has its grid points at x = i h,
y = r + j h (MODEL 8): the same rows, and columns -N .. N with N growing with the palm width.
`Lattice` is the widest of them; `on_lattice` places a map's ends on it (its end indices
renumbered, the points outside the map without an end: beyond its reach nothing touches the
part). A lattice point then means the same part position under every setting.

*A switch.* From a start s, X's trajectory ends at q. If that end is caged, tip prehension or
stalled (CONTINUING), the setting switches to Y with the part at q, and Y's trajectory from q
ends the start: Y's end state at q and Y's end point. Where q is not in Y's P_j, Y has no
trajectory from it and the start is lost, as a trajectory that leaves P_j is. A "switch" to the
same setting is none: the start ends where X's trajectory ends (a stable end stays put, and a
stall stays where it stalled).

*Values.* The caging area of X -> Y sums, over the starts whose final end is caged, the caging
score there (MODEL 8's S at the end where the part is finally held), times h^2; the
tip-prehension area counts the starts whose final end is tip prehension, times h^2. X -> X is the
fixed map's own: its Lambda summed as the kernels sum it, one start after another in flat order,
so that its caging area is the map's bit for bit. For X != Y the starts are grouped by X's end
(what Y does depends on q alone), so the sum runs in another order and may differ from a
start-by-start sum in the last bits: values are compared at TIE_DIGITS.

A schedule of three settings X -> Y -> Z switches twice (`best_of_three`); measured, not part of
the model's schedules (D35).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..model import END_CAGED, END_NONE, END_STALLED, END_TIP_PREHENSION, GRID_TOL

#: The end states a start goes on from when the setting switches (MODEL 12: every end but
#: ejection).
CONTINUING = (END_CAGED, END_TIP_PREHENSION, END_STALLED)
#: Significant digits at which two schedules' values tie: sums of the same scores in another
#: order differ in the last bits (the report compares caging areas so too).
TIE_DIGITS = 9


@dataclass(frozen=True)
class Lattice:
    """The part centres x = i h (|i| <= n), y = r + j h (0 <= j < ny) shared by the maps of one
    chassis and part; points numbered row by row (flat index j (2n + 1) + i + n)."""

    h: float
    r: float
    n: int
    ny: int

    @property
    def nx(self) -> int:
        return 2 * self.n + 1

    @property
    def size(self) -> int:
        return self.ny * self.nx

    @property
    def x(self) -> np.ndarray:
        return np.arange(-self.n, self.n + 1) * self.h

    @property
    def y(self) -> np.ndarray:
        return self.r + np.arange(self.ny) * self.h

    def columns(self, x: np.ndarray) -> np.ndarray:
        """The lattice columns of a map's x coordinates (each x = i h)."""
        i = np.rint(np.asarray(x, float) / self.h).astype(np.int64)
        if np.any(np.abs(i * self.h - x) > GRID_TOL * self.h) or np.any(np.abs(i) > self.n):
            raise ValueError("a map's columns are not points of the lattice")
        return i + self.n


def lattice_of(maps, h: float, r: float) -> Lattice:
    """The lattice of maps (each with `x` and `y`: one chassis and part, spacing h): the widest
    one's columns, their common rows (checked)."""
    maps = list(maps)
    if not maps:
        raise ValueError("no maps")
    ny = len(maps[0].y)
    n = 0
    for m in maps:
        y = np.asarray(m.y, float)
        if y.size != ny or np.any(np.abs(y - (r + np.arange(ny) * h)) > GRID_TOL * h):
            raise ValueError("the maps do not share their rows: one chassis, part and h")
        n = max(n, int(np.max(np.abs(np.rint(np.asarray(m.x, float) / h)))))
    return Lattice(float(h), float(r), n, ny)


@dataclass
class Ends:
    """One setting's trajectory ends on the lattice: per point the end state of the trajectory
    started there (`state`, END_NONE off the map or off its P_j), its end point (`end`, a lattice
    index, -1 where none) and the caging score (`score`, 0 off the map)."""

    state: np.ndarray       # int8 (size,)
    end: np.ndarray         # int64 (size,)
    score: np.ndarray       # float64 (size,)
    palm: int = 0           # the lattice points of the palm row (its first): half a cell each

    @property
    def start_weight(self) -> np.ndarray:
        """Per start, the area it stands for in cells: 1/2 on the palm row, else 1 (the
        kernels' trapezoid across the palm line, model-notes D36)."""
        w = np.ones(self.state.size)
        w[:self.palm] = 0.5
        return w

    @property
    def caged_value(self) -> np.ndarray:
        """Per point q: the caging score where this setting's trajectory from q ends, if it
        ends caged, else 0 (what a start brought to q is worth when this setting holds it)."""
        at = np.where(self.end >= 0, self.end, 0)
        return np.where(self.state == END_CAGED, self.score[at], 0.0)

    @property
    def tip(self) -> np.ndarray:
        """Per point q: 1 where this setting's trajectory from q ends in tip prehension."""
        return (self.state == END_TIP_PREHENSION).astype(np.int64)


def on_lattice(m, lat: Lattice) -> Ends:
    """The ends of map `m` (`x`, `y`, `end_state`, `end_index` into its own grid,
    `caging_score`; `chassis_maps.SettingMap` or an `EnergyMap`'s fields) on the lattice."""
    fields = getattr(m, "fields", None)
    get = (lambda k: fields[k]) if fields is not None else (lambda k: getattr(m, k))
    state = np.asarray(get("end_state"))
    index = np.asarray(get("end_index"), dtype=np.int64)
    score = np.asarray(get("caging_score"), dtype=np.float64)
    ny, nx = state.shape
    if ny != lat.ny:
        raise ValueError("the map's rows are not the lattice's")
    cols = lat.columns(m.x)
    where = (np.arange(ny)[:, None] * lat.nx + cols[None, :]).ravel()   # map flat -> lattice
    out = Ends(np.full(lat.size, END_NONE, dtype=np.int8), np.full(lat.size, -1, dtype=np.int64),
               np.zeros(lat.size), lat.nx)
    out.state[where] = state.ravel()
    flat = index.ravel()
    out.end[where] = np.where(flat >= 0, where[np.where(flat >= 0, flat, 0)], -1)
    out.score[where] = score.ravel()
    return out


# ---------------------------------------------------------------------------------------------
# One schedule, start by start
# ---------------------------------------------------------------------------------------------
def switched(first: Ends, then: Ends, same: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """Per start, the final end state and end point of the schedule first -> then (`same`:
    the two are one setting, no switch)."""
    return chained([first] if same else [first, then])


def chained(seq: list) -> tuple[np.ndarray, np.ndarray]:
    """Per start, the final end state and end point of the schedule through the settings `seq`
    in order (Ends on one lattice; consecutive settings differ: a switch to the same setting is
    none, and the caller leaves it out)."""
    state, end = seq[0].state.copy(), seq[0].end.copy()
    for then in seq[1:]:
        go = np.isin(state, CONTINUING)
        q = end[go]
        state[go] = then.state[q]
        end[go] = then.end[q]
    return state, end


def chained_areas(seq: list, h: float) -> tuple[float, float]:
    """(caging area, tip-prehension area) of the schedule through the settings `seq`
    (`chained`), summed start by start as the kernels sum a map's (`fixed_lambda`)."""
    state, end = chained(seq)
    done = Ends(state, end, seq[-1].score, seq[0].palm)
    return area(fixed_lambda(done), h), area(fixed_tip(done), h)


def fixed_lambda(e: Ends) -> float:
    """Lambda of the fixed setting with the palm row's starts at half a cell, summed as the
    kernels sum it (one start after another in flat order, np.cumsum adding sequentially, less
    half the palm row's sum), so its caging area is the map's bit for bit."""
    at = np.where(e.end >= 0, e.end, 0)
    terms = np.where(e.state == END_CAGED, e.score[at], 0.0)
    if not terms.size:
        return 0.0
    palm = float(np.cumsum(terms[:e.palm])[-1]) if e.palm else 0.0
    return float(np.cumsum(terms)[-1]) - 0.5 * palm


def fixed_tip(e: Ends) -> float:
    """The starts of the fixed setting that end in tip prehension, in cells (palm row: half)."""
    tip = e.state == END_TIP_PREHENSION
    return float(np.count_nonzero(tip)) - 0.5 * float(np.count_nonzero(tip[:e.palm]))


def area(lam: float, h: float) -> float:
    """A Lambda (or a count) as an area: times h^2, as the kernels write the caging area."""
    return lam * h * h


# ---------------------------------------------------------------------------------------------
# Every schedule of a set of settings
# ---------------------------------------------------------------------------------------------
def _continuing_ends(e: Ends) -> tuple[np.ndarray, np.ndarray]:
    """The distinct points where a setting's trajectories end and go on after a switch, and how
    many starts end at each (in cells: a palm-row start counts half)."""
    go = np.isin(e.state, CONTINUING)
    q, at = np.unique(e.end[go], return_inverse=True)
    return q, np.bincount(at.reshape(-1), weights=e.start_weight[go], minlength=q.size)


def schedule_values(ends: list, h: float) -> tuple[np.ndarray, np.ndarray]:
    """(caging area, tip-prehension area), each (S, S): row X draws in, column Y holds, for
    every pair of the S settings `ends` (Ends on one lattice, spacing h); the diagonal is each
    fixed setting's own."""
    from scipy.sparse import csr_matrix

    n = len(ends)
    if not n:
        return np.zeros((0, 0)), np.zeros((0, 0))
    size = ends[0].state.size
    rows, cols, counts = [], [], []
    for x, e in enumerate(ends):
        q, c = _continuing_ends(e)
        rows.append(np.full(q.size, x))
        cols.append(q)
        counts.append(c)
    # starts per (setting X, lattice point q where X's trajectory ends and goes on)
    reach = csr_matrix((np.concatenate(counts).astype(np.float64),
                        (np.concatenate(rows), np.concatenate(cols))), shape=(n, size))
    caged = np.ascontiguousarray(np.stack([e.caged_value for e in ends]).T)
    tip = np.ascontiguousarray(np.stack([e.tip for e in ends]).T.astype(np.float64))
    lam = np.asarray(reach @ caged)
    count = np.asarray(reach @ tip)   # whole and half numbers: exact below 2**52
    for x, e in enumerate(ends):
        lam[x, x] = fixed_lambda(e)
        count[x, x] = fixed_tip(e)
    return area(lam, h), area(count, h)


def best_of_three(ends: list, h: float, k: int = 1) -> dict:
    """The best schedules of three settings X -> Y -> Z (two switches: Y != X, Z != Y) for
    caging and for tip prehension, each X's best and of those the k largest (positive; ties at
    TIE_DIGITS to the first X): {"caging": [(area, (X, Y, Z)), ...], "tip_prehension": ...}."""
    from scipy.sparse import csr_matrix

    n = len(ends)
    lat_size = ends[0].state.size if n else 0
    caged_t = np.ascontiguousarray(np.stack([e.caged_value for e in ends]).T) if n else None
    tip_t = np.ascontiguousarray(np.stack([e.tip for e in ends]).T.astype(np.float64)) \
        if n else None
    go = [np.isin(e.state, CONTINUING) for e in ends]
    found: dict = {"caging": [], "tip_prehension": []}
    for x in range(n):
        q, c = _continuing_ends(ends[x])
        if not q.size:
            continue
        rows, cols, data = [], [], []
        for y in range(n):
            if y == x:
                continue
            on = go[y][q]
            rows.append(np.full(int(on.sum()), y))
            cols.append(ends[y].end[q[on]])
            data.append(c[on])
        if not rows:
            continue
        w = csr_matrix((np.concatenate(data), (np.concatenate(rows), np.concatenate(cols))),
                       shape=(n, lat_size))
        for name, values in (("caging", caged_t), ("tip_prehension", tip_t)):
            v = np.asarray(w @ values)             # (Y, Z)
            v[np.arange(n), np.arange(n)] = -np.inf    # Z = Y: no second switch
            v[x, :] = -np.inf                          # Y = X: no first switch
            y, z = np.unravel_index(int(np.argmax(v)), v.shape)
            if v[y, z] > 0:
                found[name].append((area(float(v[y, z]), h), (x, int(y), int(z))))
    return {name: sorted(f, key=lambda t: (-tie_key(t[0]), t[1]))[:k]
            for name, f in found.items()}


def tie_key(v) -> np.ndarray | float:
    """Values rounded to TIE_DIGITS significant digits (NaN as -inf): equal keys tie."""
    a = np.asarray(v, dtype=np.float64)
    out = np.array([float(f"{t:.{TIE_DIGITS}g}") for t in a.ravel()]).reshape(a.shape)
    out = np.where(np.isnan(out), -np.inf, out)
    return float(out) if out.ndim == 0 else out
