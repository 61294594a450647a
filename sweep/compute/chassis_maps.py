"""The maps of one chassis and part under many settings (MODEL 12): per setting, a pulley pair
(r1, r2) and a palm width w, the trajectory ends of its map, kept (the sweep keeps only the
summaries).

The maps are computed the sweep's way (`compute.batch`, `kernels.many_maps`): the maps of one
pulley pair share one right-finger field over every offset their widths need, mirrored and
shifted into both fingers of each width, and each map runs the one map pipeline
(`one_map.map_from_fingers`), so a map's fields and summary are bitwise `compute_map`'s. The
rows of the shared fields and then the maps run on threads (the kernels release the GIL). A palm
half-width that is not a whole number of grid steps has no shared field: that map is
`compute_map`'s own.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..grid import grid_index_bounds, palm_half_width_steps
from ..kernels import many_maps, one_map
from ..kernels.records import (new_finger_arrays, new_outcome_arrays, no_force_arrays,
                               no_settled_fingers)
from ..model import Accuracy, Command, Design, Effects, Grid, Limits, Part
from ..schema import SUMMARY_FIELDS, SUMMARY_INDEX
from .layout import hand_record, kernel_records
from .maps import compute_map
from .threads import over_ranges


@dataclass
class SettingMap:
    """What a schedule reads of one map: where the trajectory from each grid point ends
    (`end_state`, `end_index`: flat (y, x) index into this map's own grid, -1 where none) and
    the caging score of every point, on the map's grid `x`, `y`; and its summary's caging area
    and tip-prehension count."""

    design: Design
    x: np.ndarray
    y: np.ndarray
    end_state: np.ndarray       # int8 (ny, nx)
    end_index: np.ndarray       # int64 (ny, nx)
    caging_score: np.ndarray    # float64 (ny, nx)
    caging_area: float
    n_tip_prehension: int


@dataclass
class _SharedField:
    """One pulley pair's right-finger field (`many_maps.shared_finger_field`'s, row by row)."""

    finger: object
    solver: object
    blocks: object
    fingers: object
    m_lo: int
    ys: np.ndarray
    ny: int


def _shared_field(l1, l2, r1, r2, designs, part, h, limits, accuracy, effects) -> _SharedField:
    finger, solver, blocks = kernel_records(designs[0], part, limits, accuracy, effects)
    bounds = [grid_index_bounds(d, part, Grid(h=h)) for d in designs]
    steps = [palm_half_width_steps(d.w, h) for d in designs]
    # the offsets every width needs (many_maps.shared_field_extent)
    m_lo = min(0, min(-b[1] - s for b, s in zip(bounds, steps)))
    m_hi = max(0, max(b[1] - s for b, s in zip(bounds, steps)))
    ny = bounds[0][3] + 1
    dxs = (np.arange(m_hi - m_lo + 1, dtype=np.int64) + m_lo) * h
    ys = finger.r + np.arange(ny, dtype=np.int64) * h
    fingers = new_finger_arrays(np.int64(1), ny, dxs.size)

    def rows(first, last):
        one_map.finger_rows(first, last, dxs, ys, finger, solver, blocks, fingers,
                            one_map.SHARED)

    over_ranges(ny, rows)
    return _SharedField(finger, solver, blocks, fingers, m_lo, ys, ny)


def settings_maps(l1: float, l2: float, settings, part: Part, command: Command, h: float,
                  limits: Limits, accuracy: Accuracy, effects: Effects) -> list[SettingMap]:
    """The maps of the designs (l1, l2, r1, r2, w) for every (r1, r2, w) of `settings` and the
    part, on the whole-reach grid at spacing h, in the order of `settings`."""
    settings = [(float(r1), float(r2), float(w)) for r1, r2, w in settings]
    designs = [Design(l1, l2, r1, r2, w) for r1, r2, w in settings]
    out: list = [None] * len(settings)
    pairs: dict = {}
    for k, (r1, r2, w) in enumerate(settings):
        if palm_half_width_steps(w, h) is None:
            m = compute_map(designs[k], part, command, Grid(h=h), limits, accuracy, effects)
            out[k] = SettingMap(design=m.design, x=m.x, y=m.y, end_state=m.fields["end_state"],
                                end_index=m.fields["end_index"],
                                caging_score=m.fields["caging_score"],
                                caging_area=float(m.attrs["caging_area"]),
                                n_tip_prehension=int(m.attrs["n_tip_prehension"]))
        else:
            pairs.setdefault((r1, r2), []).append(k)
    fields = {pair: _shared_field(l1, l2, *pair, [designs[k] for k in members], part, h, limits,
                                  accuracy, effects) for pair, members in pairs.items()}
    todo = [(pair, k) for pair, members in pairs.items() for k in members]

    def maps(first, last):
        for pair, k in todo[first:last]:
            f, d = fields[pair], designs[k]
            step = palm_half_width_steps(d.w, h)
            ncol = grid_index_bounds(d, part, Grid(h=h))[1]
            xs, fingers = many_maps.gather_fingers(f.fingers, f.m_lo, step, ncol, f.ny, float(h))
            outs = new_outcome_arrays(f.ny, xs.shape[0])
            summary = np.empty(len(SUMMARY_FIELDS))
            one_map.map_from_fingers(
                xs=xs, ys=f.ys, finger=f.finger, solver=f.solver,
                hand=hand_record(d.w, command, h, f.finger), effects=f.blocks,
                fingers=fingers, outs=outs, forces=no_force_arrays(),
                stack=np.empty(f.ny * xs.shape[0], dtype=np.int64), summary=summary,
                every_point=one_map.EVERY_POINT, equilibrium=one_map.ALL_OUTPUTS,
                caging=one_map.ALL_OUTPUTS, settled=no_settled_fingers())
            out[k] = SettingMap(
                design=d, x=xs, y=f.ys, end_state=outs.end_state, end_index=outs.end_index,
                caging_score=outs.caging_score,
                caging_area=float(summary[SUMMARY_INDEX["caging_area"]]),
                n_tip_prehension=int(summary[SUMMARY_INDEX["n_tip_prehension"]]))

    # the largest maps first, each thread taking the next as it finishes one
    todo.sort(key=lambda t: -designs[t[1]].w)
    over_ranges(len(todo), maps, ranges_per_thread=max(len(todo), 1))
    return out
