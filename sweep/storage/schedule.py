"""The results of `sweep schedule` (sweep.runs.schedule; MODEL 12, model-notes D35): one
self-describing HDF5 file beside the store (`STORE.schedule.h5`), written atomically.

Dimensions (HDF5 dimension scales, which xarray reads as coordinates): `case` (a chassis and a
part: `l1`, `l2`, `r`, `mu` on it), `setting` (a pulley pair standing for its equal-R class and
a palm width: `setting_r1`, `setting_r2`, `setting_R`, `setting_w`), `draw` and `hold` (the
setting a schedule draws in with and the one it holds with: indices into `setting`), `level`
(`h`: the ladder's spacings), `objective` (caging, tip_prehension), `kind` (fixed, schedule,
r_switch, w_switch) and, with the third switch measured, `stage`.

`schedule_area(case, objective, level, draw, hold)` holds every schedule computed (NaN: not at
that level); its diagonal is the fixed settings'. Per case and objective: the best of each kind
at the finest level (`best_draw`, `best_hold`, `best_area` per level, `best_error`), the best of
each kind over every setting at level 0 (`screened_*`), the gain of the best schedule over the
best fixed setting with its error and the verdict; the cost per level. Root attributes: the
store and its config, the identity (what a rerun compares), the settings, the rules, the
timings (against the store's screening) and provenance. Categorical codes carry CF
`flag_values` / `flag_meanings`.
"""
from __future__ import annotations

from pathlib import Path

import h5py
import numpy as np

from ..schema import REFINE_STATUS_MEANINGS
from .h5 import (atomic_file, flag_attrs, iter_names, provenance, read_json_attr,
                 set_root_attrs, write_coordinate, write_variable)

KIND_SCHEDULE = "sweep-schedule"
OBJECTIVES = ("caging", "tip_prehension")
#: fixed: one setting; schedule: any X -> Y (X -> X included); r_switch: R changes, w kept;
#: w_switch: w changes, R kept.
KINDS = ("fixed", "schedule", "r_switch", "w_switch")
#: none: no schedule beats the best fixed setting beyond the error; gain: one does; unestimated:
#: one spacing only, no error estimate (and a positive difference).
VERDICTS = ("none", "gain", "unestimated")
#: Where a case's chassis comes from: the part's best design, or named (default (2.0, 1.6)).
SOURCES = ("part_best", "named")
#: The part's answer in the store, for a case on the part's best chassis.
STATUSES = REFINE_STATUS_MEANINGS + ("screened", "named")
STAGES = ("first", "second", "third")
AREA = "length^2 (model units)"
LENGTH = "length (model units)"
#: Root attributes that say how and when the file was made, not what it holds.
RUN_ATTRS = ("created_utc", "wall_seconds", "compute_seconds", "computed_cases", "platform",
             "fraction_of_screening")


def schedule_path(store: Path) -> Path:
    """Where `sweep schedule STORE` writes by default: beside STORE, its name + .schedule.h5."""
    store = Path(store)
    return store.with_name(store.stem + ".schedule.h5")


def _var(f, name, data, dims, long_name, units=None, compression=True, **extra):
    attrs = dict(long_name=long_name, **({"units": units} if units else {}), **extra)
    write_variable(f, name, np.asarray(data), dims, attrs, compression=compression)


def write_schedules(path: Path, data: dict, attrs: dict) -> None:
    """The results file (module docstring), atomically. `data`: the arrays named below (from
    `sweep.runs.schedule.tables`); `attrs`: root attributes."""
    n_settings = len(data["setting_w"])
    n_levels = len(data["h"])
    with atomic_file(path) as f:
        write_coordinate(f, "case", np.arange(len(data["l1"]), dtype=np.int32),
                         dict(long_name="case: a chassis (l1, l2) and a part (r, mu)"))
        write_coordinate(f, "setting", np.arange(n_settings, dtype=np.int32),
                         dict(long_name="setting of the chassis: a pulley pair (standing for its "
                                        "equal-R class) and a palm width; R ascending, w "
                                        "fastest"))
        for dim, what in (("draw", "draws the part in"), ("hold", "holds it")):
            write_coordinate(f, dim, np.arange(n_settings, dtype=np.int32),
                             dict(long_name=f"the setting that {what} (index into setting)"))
        write_coordinate(f, "level", np.arange(n_levels, dtype=np.int32),
                         dict(long_name="rung of the h-ladder (0: the first spacing)"))
        write_coordinate(f, "objective", np.array(OBJECTIVES, dtype=object),
                         dict(long_name="what a start's final end counts for: caged (scored by "
                                        "MODEL 8's S there) or tip prehension (counted)"))
        write_coordinate(f, "kind", np.array(KINDS, dtype=object),
                         dict(long_name="fixed: one setting; schedule: any draw -> hold "
                                        "(draw = hold included); r_switch: R changes, w kept; "
                                        "w_switch: w changes, R kept"))
        _var(f, "h", data["h"], ("level",), "grid spacing of the rung", LENGTH, False)
        C = ("case",)
        for name, text in (("l1", "proximal link length of the chassis"),
                           ("l2", "distal link length of the chassis"),
                           ("r", "part radius")):
            _var(f, name, data[name], C, text, LENGTH, False)
        _var(f, "mu", data["mu"], C, "part friction coefficient", "1", False)
        write_variable(f, "chassis_source", np.asarray(data["chassis_source"], np.int8), C,
                       flag_attrs(SOURCES, "where the case's chassis comes from: the part's "
                                           "best design in the store, or named"),
                       compression=False)
        write_variable(f, "part_status", np.asarray(data["part_status"], np.int8), C,
                       flag_attrs(STATUSES, "the part's answer in the store (for a case on "
                                            "its best chassis): certified, near-tie set (its "
                                            "first), not refined, screened (a store not "
                                            "refined); named: another chassis"),
                       compression=False)
        _var(f, "finest_level", np.asarray(data["finest_level"], np.int8), C,
             "finest rung computed (the ladder stops where no schedule is positive)",
             compression=False)
        S = ("setting",)
        _var(f, "setting_r1", data["setting_r1"], S, "proximal pulley radius (the pair that "
             "stands for the equal-R class: the first in store order)", LENGTH, False)
        _var(f, "setting_r2", data["setting_r2"], S, "distal pulley radius", LENGTH, False)
        _var(f, "setting_R", data["setting_R"], S, "transmission ratio R = r2/r1", "1", False)
        _var(f, "setting_w", data["setting_w"], S, "palm width", LENGTH, False)
        _var(f, "schedule_area", data["schedule_area"],
             ("case", "objective", "level", "draw", "hold"),
             "area of the schedule draw -> hold at the rung's h: caging area (sum of S at the "
             "caged final ends, times h^2) or tip-prehension area (final ends in tip "
             "prehension, times h^2); draw = hold: the fixed setting's own; NaN: not computed",
             AREA)
        _var(f, "computed", np.asarray(data["computed"], np.int8), ("case", "level", "setting"),
             "1 where the setting's map was computed at the rung")
        CO = ("case", "objective")
        COK = ("case", "objective", "kind")
        _var(f, "best_draw", np.asarray(data["best_draw"], np.int16), COK,
             "the best schedule of the kind at the finest rung: its draw setting (index into "
             "setting; -1: none)", compression=False)
        _var(f, "best_hold", np.asarray(data["best_hold"], np.int16), COK,
             "its hold setting (index into setting; the draw setting for a fixed one)",
             compression=False)
        _var(f, "best_area", data["best_area"], COK + ("level",),
             "that schedule's area at every rung (NaN: not computed)", AREA)
        _var(f, "best_error", data["best_error"], COK,
             "its error estimate: the change of its area from the rung before the finest "
             "(NaN with one rung)", AREA)
        _var(f, "screened_draw", np.asarray(data["screened_draw"], np.int16), COK,
             "the best schedule of the kind at rung 0 over every setting: its draw setting",
             compression=False)
        _var(f, "screened_hold", np.asarray(data["screened_hold"], np.int16), COK,
             "its hold setting", compression=False)
        _var(f, "screened_area", data["screened_area"], COK, "its area at rung 0", AREA)
        _var(f, "gain", data["gain"], CO,
             "d: the best schedule's area minus the best fixed setting's, at the finest rung",
             AREA)
        _var(f, "gain_error", data["gain_error"], CO,
             "u: the error of the best schedule plus the best fixed setting's (NaN: one rung)",
             AREA)
        write_variable(f, "verdict", np.asarray(data["verdict"], np.int8), CO,
                       flag_attrs(VERDICTS, "gain when d > u: a schedule beats the best fixed "
                                            "setting beyond the error; none otherwise (d <= u, "
                                            "d = 0 when the best schedule is a fixed setting); "
                                            "unestimated: one rung, no error estimate"),
                       compression=False)
        CL = ("case", "level")
        _var(f, "maps", np.asarray(data["maps"], np.int32), CL, "maps computed at the rung",
             compression=False)
        _var(f, "seconds_maps", data["seconds_maps"], CL, "wall seconds computing them", "s",
             compression=False)
        _var(f, "seconds_values", data["seconds_values"], CL,
             "wall seconds reading every schedule off their ends (and, at rung 0, the third "
             "switch when measured)", "s", compression=False)
        if "third_area" in data:
            write_coordinate(f, "stage", np.array(STAGES, dtype=object),
                             dict(long_name="the settings of a three-setting schedule, in "
                                            "order"))
            write_coordinate(f, "pair_stage", np.array(STAGES[:2], dtype=object),
                             dict(long_name="the settings of a two-setting schedule, in order"))
            _var(f, "third_settings", np.asarray(data["third_settings"], np.int16),
                 CO + ("stage",), "the best schedule of three settings (two switches): each "
                 "draw setting's best at rung 0, the `contenders` largest recomputed at rung 1 "
                 "and the best there (rung 0 with one rung); its settings (indices into "
                 "setting; -1: none)", compression=False)
            _var(f, "third_area", data["third_area"], CO + ("level",),
                 "its area at rung 0 and at rung 1 (NaN beyond)", AREA)
            _var(f, "third_two_settings", np.asarray(data["third_two_settings"], np.int16),
                 CO + ("pair_stage",), "the best schedule of at most two settings among those "
                 "computed at rung 1 (the triples' and the ladder's; rung 0 with one rung)",
                 compression=False)
            _var(f, "third_best_two", data["third_best_two"], CO + ("level",),
                 "its area at rung 0 and at rung 1 (NaN beyond)", AREA)
            _var(f, "third_gain", data["third_gain"], CO,
                 "what the third switch adds: third_area - third_best_two at the finer of the "
                 "two rungs (0 where they tie at 9 significant digits)", AREA)
            _var(f, "third_error", data["third_error"], CO,
                 "its error: the sum of both areas' changes from rung 0 to rung 1 (NaN: one "
                 "rung)", AREA)
            _var(f, "third_adds", np.asarray(data["third_adds"], np.int8), CO,
                 "1 where the third switch adds beyond the error (third_gain > third_error; "
                 "with one rung, third_gain > 0)", compression=False)
        set_root_attrs(f, dict(sweep_file_kind=KIND_SCHEDULE, **attrs, **provenance()))


def read_identity(path: Path):
    """The identity a results file was made under (None: not such a file)."""
    try:
        with h5py.File(path, "r") as f:
            if f.attrs.get("sweep_file_kind") != KIND_SCHEDULE:
                return None
            return read_json_attr(f, "identity")
    except (OSError, KeyError, ValueError):
        return None


def schedule_created(store: Path) -> str | None:
    """When the schedules beside `store` were written (None: there are none)."""
    try:
        with h5py.File(schedule_path(store), "r") as f:
            if f.attrs.get("sweep_file_kind") != KIND_SCHEDULE:
                return None
            v = f.attrs.get("created_utc")
            return v.decode() if isinstance(v, bytes) else str(v)
    except (OSError, KeyError, ValueError):
        return None


def read_schedules(path: Path) -> dict:
    """Every variable and root attribute of a results file: {'attrs', 'vars'}."""
    with h5py.File(path, "r") as f:
        if f.attrs.get("sweep_file_kind") != KIND_SCHEDULE:
            raise ValueError(f"{path}: not a sweep schedule file")
        return dict(attrs={k: (v.decode() if isinstance(v, bytes) else v)
                           for k, v in f.attrs.items()},
                    vars={k: (iter_names(f[k][...]) if f[k].dtype.kind == "O" else f[k][...])
                          for k in f if isinstance(f[k], h5py.Dataset)})
