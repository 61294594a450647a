"""The map file: one energy map as self-describing HDF5 (dimension scales, CF flags, provenance)."""
from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import numpy as np

from .h5 import atomic_file, provenance, set_root_attrs, write_coordinate, write_variable
from ..compute.layout import EnergyMap
from ..model import DEFAULT_OUTPUTS, FINGER_NAMES, effect_attributes
from ..schema import POINT_FIELDS


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
    # absent: the default outputs energy, equilibrium, caging (files written before outputs existed)
    if tuple(m.outputs) != DEFAULT_OUTPUTS:
        attrs["outputs_on"] = list(m.outputs)
    # absent: both fingers touch the part with its own mu (the paper's model)
    if m.mu_left is not None or m.mu_right is not None:
        attrs["finger_friction"] = finger_friction(m)
    attrs.update(effect_attributes(m.effects))
    for key, value in m.attrs.items():
        attrs[key] = value
    attrs.update(provenance())
    return attrs


def finger_friction(m: EnergyMap) -> dict:
    """Each finger's contact friction of a map (MODEL 10, Scenario C), the palm's being the
    part's mu."""
    return dict(left=m.part.mu if m.mu_left is None else m.mu_left,
                right=m.part.mu if m.mu_right is None else m.mu_right, palm=m.part.mu)


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
        for fld in POINT_FIELDS:  # the schema's order; only the outputs computed
            if fld.in_map_file and fld.name in m.fields:
                write_variable(f, fld.name, m.fields[fld.name], fld.dims,
                               fld.attrs(m.effects.names_on()))
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
    ]
    if "Lambda" in a:  # the caging output
        lines += [
            f"trajectories from reached points end: caged {a['n_caged']:,}, "
            f"tip prehension {a['n_tip_prehension']:,}, ejection {a['n_ejection']:,}, "
            f"stalled {a['n_stalled']:,}",
            f"Lambda = {a['Lambda']:.6g}, caging area = {a['caging_area']:.6g}; "
            f"caged points {a['n_caged_points']:,} ({a['n_caged_crossed']:,} with crossed "
            f"fingers); tip_overlap points {a['n_tip_overlap']:,}",
        ]
    else:
        lines.append(f"outputs: {', '.join(m.outputs)}; tip_overlap points "
                     f"{a['n_tip_overlap']:,}")
    if "n_collision_changed" in a:
        lines.append(f"finger_collision changed the configuration at "
                     f"{a['n_collision_changed']:,} points")
    if m.mu_left is not None or m.mu_right is not None:
        fr = finger_friction(m)
        lines.append(f"finger friction: left {fr['left']:g}, right {fr['right']:g} (palm "
                     f"{fr['palm']:g})")
    lines.append(f"computed in {a['seconds_total'] * 1e3:.1f} ms")
    if not math.isfinite(a.get("Lambda", 0.0)):
        lines.append("warning: non-finite Lambda")
    return "\n".join(lines)
