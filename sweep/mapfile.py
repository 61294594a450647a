"""The map file: one energy map as self-describing HDF5 (dimension scales, CF flags, provenance)."""
from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import numpy as np

from .h5 import (atomic_file, flag_attrs, provenance, set_root_attrs, write_coordinate,
                 write_variable)
from .maps import MAP_FIELDS_2D, MAP_FIELDS_FINGER, EnergyMap
from .model import (END_STATE_MEANINGS, FINGER_MODE_MEANINGS, FINGER_NAMES,
                    POINT_CLASS_MEANINGS)

VARIABLE_ATTRS = {
    "energy": dict(long_name="system potential energy V_left + V_right (MODEL 6)",
                   units="tension x length (unitless)"),
    "point_class": flag_attrs(POINT_CLASS_MEANINGS, "class of the grid point (MODEL 8)"),
    "end_state": flag_attrs(END_STATE_MEANINGS,
                            "end of the steepest-descent trajectory started here (MODEL 8)"),
    "equilibrium": dict(long_name="part in force equilibrium (cone hull, MODEL 7); "
                                  "computed for reached points only", units="1"),
    "contained": dict(long_name="part centre inside J_L B_L T_L T_R B_R J_R (even-odd)",
                      units="1"),
    "l_open": dict(long_name="L_open: largest part that could escape between the fingers",
                   units="length (unitless)"),
    "caging_score": dict(long_name="caging score S = 1 - L_open/(2r) where caged, else 0",
                         units="1"),
    "finger_mode": dict(flag_attrs(FINGER_MODE_MEANINGS,
                                   "contact mode the finger ends in (MODEL 4, 5)"),
                        _FillValue=np.int8(-1), comment="-1 where the point is infeasible"),
    "theta1": dict(long_name="proximal joint angle, finger's own (mirrored) frame",
                   units="rad"),
    "theta2": dict(long_name="distal joint angle, finger's own (mirrored) frame", units="rad"),
    "k1": dict(long_name="contact distance from the proximal joint on the proximal link; "
                         "0 without a proximal contact", units="length (unitless)"),
    "k2": dict(long_name="contact distance from the distal joint on the distal link; "
                         "0 without a distal contact", units="length (unitless)"),
    "tip_overlap": dict(long_name="the distal link passed through the part on its way to its "
                                  "limit (paper's answer kept, MODEL 4.3)", units="1"),
}


def map_root_attrs(m: EnergyMap) -> dict:
    attrs = dict(
        title="friction-based potential energy map (sweep)",
        Conventions="CF-1.8",
        design=dataclasses.asdict(m.design),
        part=dataclasses.asdict(m.part),
        command=dataclasses.asdict(m.command),
        grid=dict(h=m.grid.h, xlim=m.grid.xlim, ylim=m.grid.ylim,
                  x_range=[float(m.x[0]), float(m.x[-1])],
                  y_range=[float(m.y[0]), float(m.y[-1])]),
        limits=dataclasses.asdict(m.limits),
        accuracy=dataclasses.asdict(m.accuracy),
        effects_on=m.effects.names_on(),
        h=m.grid.h,
    )
    for key, value in m.attrs.items():
        attrs[key] = value
    attrs.update(provenance())
    return attrs


def write_map(path: str | Path, m: EnergyMap, extra_attrs: dict | None = None) -> Path:
    """Write `m` to `path` atomically; xarray.open_dataset(path, engine="h5netcdf") opens it.

    `extra_attrs` are added to the root attributes (e.g. the sweep's config_hash).
    """
    path = Path(path)
    with atomic_file(path) as f:
        write_coordinate(f, "x", m.x, dict(long_name="part centre x (palm centre origin)",
                                           units="length (unitless)", axis="X"))
        write_coordinate(f, "y", m.y, dict(long_name="part centre y (away from the palm)",
                                           units="length (unitless)", axis="Y"))
        write_coordinate(f, "finger", np.array(FINGER_NAMES), dict(long_name="finger"))
        for name in MAP_FIELDS_2D:
            write_variable(f, name, m.fields[name], ("y", "x"), VARIABLE_ATTRS[name])
        for name in MAP_FIELDS_FINGER:
            write_variable(f, name, m.fields[name], ("finger", "y", "x"), VARIABLE_ATTRS[name])
        set_root_attrs(f, {**map_root_attrs(m), **(extra_attrs or {})})
    return path


def describe(m: EnergyMap) -> str:
    """A few human lines about a map (for the CLI)."""
    a = m.attrs
    ny, nx = m.fields["energy"].shape
    lines = [
        f"{ny} x {nx} = {a['n_points']:,} points at h = {m.grid.h:g}; "
        f"reached {a['n_reached']:,}, eject {a['n_eject']:,}, vertex {a['n_vertex']:,}, "
        f"unreached {a['n_unreached']:,}, infeasible {a['n_infeasible']:,}",
        f"trajectories from reached points end: caged {a['n_caged']:,}, "
        f"tip prehension {a['n_tip_prehension']:,}, ejection {a['n_ejection']:,}, "
        f"stalled {a['n_stalled']:,}",
        f"Lambda = {a['Lambda']:.6g}, caging area = {a['caging_area']:.6g}; "
        f"caged points {a['n_caged_points']:,} ({a['n_caged_crossed']:,} with crossed fingers); "
        f"tip_overlap points {a['n_tip_overlap']:,}",
        f"computed in {a['seconds_total'] * 1e3:.1f} ms",
    ]
    if not math.isfinite(a["Lambda"]):
        lines.append("warning: non-finite Lambda")
    return "\n".join(lines)
