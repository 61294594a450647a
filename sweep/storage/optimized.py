"""The results of `sweep optimize` (sweep.runs.optimize): one self-describing HDF5 file beside the
store (`STORE.optimize.h5`), written atomically.

Dimensions (HDF5 dimension scales): `part` (with `r`, `mu` on it), `param` (l1 l2 r1 r2 w),
`level` (with `h`: the search spacing, then h/2, h/4, ...), `constraint` (the five parameters and
`length_budget`), `seed`, `start`, `finalist`, `corner` (none: the robustness summaries are
stored), `friction_change` (-df, +df), `evaluation` (every map computed, in order). Per part: x*
and the grid's best G side by side (designs, caging area per level, error estimates, the
verdict), the seeds, the ends of the multi-start searches, the finalists, the constraints x* is
on with the changes of a step inwards and outwards, the robustness summaries, counts and
seconds. The one-gripper design, when asked for, is the group `one_gripper`. Root attributes:
the store, its config hash, the identity (box, parts, settings, version: what a rerun compares),
provenance and timings.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

import h5py
import numpy as np

from ..schema import DESIGN_KEYS
from .h5 import (atomic_file, flag_attrs, iter_names, provenance, read_json_attr,
                 set_root_attrs, write_coordinate, write_variable)

KIND_OPTIMIZATION = "sweep-optimization"
CONSTRAINTS = tuple(DESIGN_KEYS) + ("length_budget",)
#: How x* sits on a constraint (`constraint_side`).
SIDE_MEANINGS = ("free", "lower", "upper", "fixed")
AREA = "length^2 (model units)"
LENGTH = "length (model units)"
#: Root attributes that say how and when the file was made, not what it holds.
RUN_ATTRS = ("created_utc", "wall_seconds", "compute_seconds", "computed_maps", "platform")


@dataclass
class OptimizedPart:
    """One part's answer (sweep.runs.optimize.optimise_part)."""

    r: float
    mu: float
    x_star: np.ndarray
    grid_best: np.ndarray
    x_values: np.ndarray          # (levels+1,) caging area at h/2**k (NaN: not computed)
    g_values: np.ndarray
    finest_level: int             # where both were computed last
    x_error: float
    g_error: float
    difference: float             # d = x* - G at the finest level
    uncertainty: float            # u = error(x*) + error(G)
    beats: bool                   # d > u
    store_value: float            # G's value in the store (refined, else screened)
    store_error: float
    store_h: float
    store_status: str
    seeds: np.ndarray             # (k, 5)
    seed_values: np.ndarray       # (k,) at h
    start_designs: np.ndarray     # (starts, 5) ends of the compass searches
    start_values: np.ndarray      # (starts,) at h
    de_value: float               # differential evolution's best at h
    finalists: np.ndarray         # (n, 5)
    finalist_values: np.ndarray   # (n, levels+1)
    constraints: dict             # name -> (side or '', inward change, outward change)
    steps: np.ndarray             # (5,) the step of those changes
    robust: dict                  # 'x_star'/'grid_best' -> (min, median, centre, [mu-, mu+])
    search_maps: int = 0
    maps: int = 0
    seconds: float = 0.0

    @property
    def spread(self) -> float:
        v = self.start_values[np.isfinite(self.start_values)]
        return float(v.max() - v.min()) if v.size else math.nan

    def box_limited(self) -> list:
        """The constraints that bind: a step outwards gains more than x*'s error."""
        err = self.x_error if math.isfinite(self.x_error) else 0.0
        return [k for k, (side, _, outward) in self.constraints.items()
                if side and side != "fixed" and math.isfinite(outward) and outward > err] + \
               [k for k, (side, inward, outward) in self.constraints.items()
                if side == "fixed" and max(np.nan_to_num([inward, outward], nan=-np.inf)) > err]


@dataclass
class OneGripper:
    """One design for several parts (sweep.runs.optimize.optimise_joint)."""

    objective: str
    design: np.ndarray
    score: float                  # at h
    score_fine: float             # at h/2
    values: np.ndarray            # (parts,) caging area at h
    values_fine: np.ndarray       # at h/2
    errors: np.ndarray            # |h/2 - h|
    own_fine: np.ndarray          # each part's own optimum x* at h/2
    loss: np.ndarray              # 1 - values_fine / own_fine
    designs_scored: int = 0
    maps: int = 0
    seconds: float = 0.0
    constraints: dict = field(default_factory=dict)


def optimization_path(store: Path) -> Path:
    """Where `sweep optimize STORE` writes by default: beside STORE, its name + .optimize.h5."""
    store = Path(store)
    return store.with_name(store.stem + ".optimize.h5")


def _var(f, name, data, dims, long_name, units=None, **extra):
    attrs = dict(long_name=long_name, **({"units": units} if units else {}), **extra)
    write_variable(f, name, np.asarray(data), dims, attrs, compression=False)


def _pad(arrays: list, width: int, tail: tuple = ()) -> np.ndarray:
    out = np.full((len(arrays), width) + tail, np.nan)
    for i, a in enumerate(arrays):
        a = np.asarray(a, float).reshape((-1,) + tail)
        out[i, :a.shape[0]] = a
    return out


def write_optimization(path: Path, store: Path, scene, identity: dict, box, settings,
                       parts: list, joint: OneGripper | None, table: np.ndarray,
                       timings: dict) -> None:
    """The results file (module docstring), atomically."""
    n_levels = settings.levels + 1
    with atomic_file(path) as f:
        write_coordinate(f, "part", np.arange(len(parts), dtype=np.int32),
                         dict(long_name="part index (the parts optimised, in order)"))
        write_coordinate(f, "param", np.array(DESIGN_KEYS, dtype=object),
                         dict(long_name="design parameter"))
        write_coordinate(f, "level", np.arange(n_levels, dtype=np.int32),
                         dict(long_name="fidelity level: grid spacing h / 2**level"))
        write_coordinate(f, "constraint", np.array(CONSTRAINTS, dtype=object),
                         dict(long_name="stated constraint: a parameter's bounds or fixed value, "
                                        "or the finger-length budget l1 + l2 <= L"))
        write_coordinate(f, "friction_change",
                         np.array([-settings.friction_change, settings.friction_change]),
                         dict(long_name="change of the part's friction mu"))
        _var(f, "h", [scene.h / 2.0 ** k for k in range(n_levels)], ("level",),
             "grid spacing of the level", LENGTH)
        _var(f, "r", [p.r for p in parts], ("part",), "part radius", LENGTH)
        _var(f, "mu", [p.mu for p in parts], ("part",), "part friction coefficient", "1")
        if parts:
            _write_parts(f, parts, n_levels)
        _write_evaluations(f, table)
        if joint is not None:
            _write_joint(f.create_group("one_gripper"), joint, parts)
        set_root_attrs(f, dict(
            title=f"sweep optimize: {scene.name}", sweep_file_kind=KIND_OPTIMIZATION,
            store=str(store), store_name=scene.name, config_hash=scene.config_hash,
            identity=identity, grid_h=scene.h, levels=settings.levels,
            settings=settings.as_dict(),
            box_lower=list(box.lower), box_upper=list(box.upper), box_fixed=box.fixed or "none",
            length_budget=box.length_budget if box.length_budget is not None else math.nan,
            resolution=box.resolution,
            verdict_rule="x* beats G when d = value(x*) - value(G) > u = error(x*) + error(G) "
                         "at the finest level both reached (the refinement's separation)",
            compute_seconds=float(table[:, -1].sum()) if table.size else 0.0,
            **{k: v for k, v in timings.items()}, **provenance()))


def _write_parts(f, parts: list, n_levels: int) -> None:
    P = ("part",)
    _var(f, "x_star", [p.x_star for p in parts], ("part", "param"),
         "x*: the best design the search found (the best finalist at the finest level)")
    _var(f, "grid_best", [p.grid_best for p in parts], ("part", "param"),
         "G: the store's best grid design (the refinement's certified best or first of its "
         "near-tie set)")
    _var(f, "x_star_area", [p.x_values for p in parts], ("part", "level"),
         "caging area of x* at each level (NaN: not computed)", AREA)
    _var(f, "grid_best_area", [p.g_values for p in parts], ("part", "level"),
         "caging area of G at each level", AREA)
    _var(f, "finest_level", [p.finest_level for p in parts], P,
         "finest level where x* and G were both computed (verdict there)")
    _var(f, "x_star_error", [p.x_error for p in parts], P,
         "error estimate of x*'s caging area at the finest level: change from the level before",
         AREA)
    _var(f, "grid_best_error", [p.g_error for p in parts], P,
         "error estimate of G's caging area at the finest level", AREA)
    _var(f, "difference", [p.difference for p in parts], P,
         "d: caging area of x* minus G's at the finest level", AREA)
    _var(f, "uncertainty", [p.uncertainty for p in parts], P,
         "u: error(x*) + error(G) at the finest level", AREA)
    _var(f, "beats", np.array([p.beats for p in parts], dtype=np.int8), P,
         "verdict: 1 when x* beats G beyond the error (d > u), 0: no design found beats G "
         "beyond the error")
    _var(f, "store_best_area", [p.store_value for p in parts], P,
         "G's caging area as the store holds it (refined at store_best_h)", AREA)
    _var(f, "store_best_error", [p.store_error for p in parts], P,
         "its error estimate in the store", AREA)
    _var(f, "store_best_h", [p.store_h for p in parts], P, "spacing of store_best_area", LENGTH)
    f.attrs["store_status"] = " ".join(p.store_status for p in parts)
    n_seed = max(len(p.seeds) for p in parts)
    write_coordinate(f, "seed", np.arange(n_seed, dtype=np.int32),
                     dict(long_name="seed: G first, then the next distinct grid designs"))
    _var(f, "seed_design", _pad([p.seeds for p in parts], n_seed, (5,)),
         ("part", "seed", "param"), "seeds of the search (NaN: fewer seeds)")
    _var(f, "seed_area", _pad([p.seed_values for p in parts], n_seed), ("part", "seed"),
         "caging area of each seed at h", AREA)
    n_start = max(len(p.start_values) for p in parts)
    write_coordinate(f, "start", np.arange(n_start, dtype=np.int32),
                     dict(long_name="multi-start: differential evolution's best, then seeds"))
    _var(f, "start_end_design", _pad([p.start_designs for p in parts], n_start, (5,)),
         ("part", "start", "param"), "where each compass search ended")
    _var(f, "start_end_area", _pad([p.start_values for p in parts], n_start),
         ("part", "start"), "caging area at h where each compass search ended", AREA)
    _var(f, "start_spread", [p.spread for p in parts], P,
         "spread (max - min) of the multi-start ends' caging areas at h", AREA)
    _var(f, "evolution_best_area", [p.de_value for p in parts], P,
         "differential evolution's best caging area at h", AREA)
    n_fin = max(len(p.finalists) for p in parts)
    write_coordinate(f, "finalist", np.arange(n_fin, dtype=np.int32),
                     dict(long_name="finalist promoted to the fidelity ladder"))
    _var(f, "finalist_design", _pad([p.finalists for p in parts], n_fin, (5,)),
         ("part", "finalist", "param"), "the finalists")
    _var(f, "finalist_area", _pad([p.finalist_values for p in parts], n_fin, (n_levels,)),
         ("part", "finalist", "level"), "caging area of each finalist per level", AREA)
    side = np.array([[SIDE_MEANINGS.index(p.constraints[k][0] or "free") for k in CONSTRAINTS]
                     for p in parts], dtype=np.int8)
    write_variable(f, "constraint_side", side, ("part", "constraint"),
                   flag_attrs(SIDE_MEANINGS, "how x* sits on the constraint"), compression=False)
    _var(f, "inward_change", [[p.constraints[k][1] for k in CONSTRAINTS] for p in parts],
         ("part", "constraint"), "change of x*'s caging area at the finest level for a step "
         "inwards (into the box; for a fixed value, one way)", AREA)
    _var(f, "outward_change", [[p.constraints[k][2] for k in CONSTRAINTS] for p in parts],
         ("part", "constraint"), "change of x*'s caging area at the finest level for a step "
         "outwards (relaxing the constraint; for a fixed value, the other way)", AREA)
    _var(f, "binds", np.array([[k in p.box_limited() for k in CONSTRAINTS] for p in parts],
                              dtype=np.int8), ("part", "constraint"),
         "the constraint binds: relaxing it by a step gains more than x*'s error (box-limited)")
    _var(f, "step", [p.steps for p in parts], ("part", "param"),
         "step of the constraint changes (the compass search's smallest step)", LENGTH)
    for who in ("x_star", "grid_best"):
        rb = [p.robust[who] for p in parts]
        _var(f, f"{who}_tolerance_min", [t[0] for t in rb], P,
             f"smallest caging area of {who} over the tolerance box (2^5 corners and centre) "
             "at h/2", AREA)
        _var(f, f"{who}_tolerance_median", [t[1] for t in rb], P,
             f"median caging area of {who} over the tolerance box at h/2", AREA)
        _var(f, f"{who}_friction_area", [t[3] for t in rb], ("part", "friction_change"),
             f"caging area of {who} at h/2 with the part's mu changed", AREA)
    _var(f, "search_maps", [p.search_maps for p in parts], P,
         "designs the search scored at h (distinct equal-R classes)")
    _var(f, "maps", [p.maps for p in parts], P, "maps the part used, every h (each computed once)")
    _var(f, "seconds", [p.seconds for p in parts], P, "computing seconds of those maps", "s")


def _write_evaluations(f, table: np.ndarray) -> None:
    n = table.shape[0]
    write_coordinate(f, "evaluation", np.arange(n, dtype=np.int64),
                     dict(long_name="map computed, in order (one per design class, part, h)"))
    E = ("evaluation",)
    _var(f, "eval_r", table[:, 0], E, "part radius", LENGTH)
    _var(f, "eval_mu", table[:, 1], E, "part friction", "1")
    _var(f, "eval_h", table[:, 2], E, "grid spacing", LENGTH)
    _var(f, "eval_design", table[:, 3:8], ("evaluation", "param"), "design")
    _var(f, "eval_caging_area", table[:, 8], E, "caging area of the map", AREA)
    _var(f, "eval_error", evaluation_errors(table), E,
         "error estimate: change from the same design class at 2h (NaN: not computed there)",
         AREA)
    _var(f, "eval_seconds", table[:, 9], E, "computing seconds", "s")


def evaluation_errors(table: np.ndarray) -> np.ndarray:
    """Per row, |value - value of the same part and design class at twice the spacing|."""
    def key(row, h):
        l1, l2, r1, r2, w = row[3:8]
        return (row[0], row[1], round(h, 12), l1, l2, w, round(r2 / r1, 12))

    at = {key(row, row[2]): row[8] for row in table}
    return np.array([abs(row[8] - at[key(row, 2 * row[2])]) if key(row, 2 * row[2]) in at
                     else np.nan for row in table])


def _write_joint(g, joint: OneGripper, parts: list) -> None:
    g.attrs["objective"] = joint.objective
    g.attrs["long_name"] = ("one gripper for every part: maximises the " + joint.objective +
                            " part's caging area relative to its own optimum x*, at h")
    g.attrs["score"] = joint.score
    g.attrs["score_half_h"] = joint.score_fine
    g.attrs["designs_scored"] = joint.designs_scored
    g.attrs["maps"] = joint.maps
    g.attrs["seconds"] = joint.seconds
    g.attrs["constraints"] = " ".join(f"{k}:{v}" for k, v in joint.constraints.items()) or "none"
    g.create_dataset("design", data=joint.design)
    for name, data, text in (
            ("area", joint.values, "caging area of each part at h"),
            ("area_half_h", joint.values_fine, "caging area of each part at h/2"),
            ("error", joint.errors, "error estimate at h/2: change from h"),
            ("own_optimum_half_h", joint.own_fine, "each part's own x* at h/2"),
            ("loss", joint.loss, "loss against the part's own optimum at h/2: 1 - area/own")):
        ds = g.create_dataset(name, data=np.asarray(data, float))
        ds.attrs["long_name"] = text
        ds.dims[0].attach_scale(g.file["part"])


def read_identity(path: Path):
    """The identity a results file was made under (None: not such a file)."""
    try:
        with h5py.File(path, "r") as f:
            if f.attrs.get("sweep_file_kind") != KIND_OPTIMIZATION:
                return None
            return read_json_attr(f, "identity")
    except (OSError, KeyError, ValueError):
        return None


def optimization_created(store: Path) -> str | None:
    """When the optimisation results beside `store` were written (None: there are none)."""
    path = optimization_path(store)
    try:
        with h5py.File(path, "r") as f:
            if f.attrs.get("sweep_file_kind") != KIND_OPTIMIZATION:
                return None
            v = f.attrs.get("created_utc")
            return v.decode() if isinstance(v, bytes) else str(v)
    except (OSError, KeyError, ValueError):
        return None


def read_optimization(path: Path) -> dict:
    """Every variable and attribute of a results file: {'attrs', 'vars', 'one_gripper'}."""
    with h5py.File(path, "r") as f:
        out = dict(attrs={k: (v.decode() if isinstance(v, bytes) else v)
                          for k, v in f.attrs.items()},
                   vars={k: (iter_names(f[k][...]) if f[k].dtype.kind == "O" else f[k][...])
                         for k in f if isinstance(f[k], h5py.Dataset)})
        if "one_gripper" in f:
            g = f["one_gripper"]
            out["one_gripper"] = dict(attrs=dict(g.attrs), vars={k: g[k][...] for k in g})
    return out
