"""The maps of one chassis and part under many settings (MODEL 12): per setting, a pulley pair
(r1, r2) and a palm width w, the trajectory ends of its map, kept (the sweep keeps only the
summaries).

The maps are computed the sweep's way (`compute.batch`): the maps of one pulley pair share one
right-finger field, mirrored and shifted into both fingers of every width, and each map runs
the one map pipeline (`one_map.map_from_fingers`), so a map's fields and summary are bitwise
`compute_map`'s. The widths of a pair run on threads. A palm half-width that is not a whole
number of grid steps has no shared field: that map is `compute_map`'s own.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..grid import grid_index_bounds, palm_half_width_steps
from ..kernels import many_maps, one_map
from ..kernels.records import new_outcome_arrays, no_force_arrays, no_settled_fingers
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


def _setting_map(design, x, y, outs, summary) -> SettingMap:
    return SettingMap(design=design, x=np.asarray(x), y=np.asarray(y),
                      end_state=np.asarray(outs.end_state), end_index=np.asarray(outs.end_index),
                      caging_score=np.asarray(outs.caging_score),
                      caging_area=float(summary[SUMMARY_INDEX["caging_area"]]),
                      n_tip_prehension=int(summary[SUMMARY_INDEX["n_tip_prehension"]]))


def pulley_pair_maps(l1: float, l2: float, r1: float, r2: float, widths, part: Part,
                     command: Command, h: float, limits: Limits, accuracy: Accuracy,
                     effects: Effects) -> list[SettingMap]:
    """The maps of the designs (l1, l2, r1, r2, w) for every w of `widths` and the part, on the
    whole-reach grid at spacing h, in the order of `widths`."""
    widths = [float(w) for w in widths]
    steps = [palm_half_width_steps(w, h) for w in widths]
    if any(s is None for s in steps):
        out = []
        for w in widths:
            m = compute_map(Design(l1, l2, r1, r2, w), part, command, Grid(h=h), limits,
                            accuracy, effects)
            out.append(SettingMap(design=m.design, x=m.x, y=m.y,
                                  end_state=m.fields["end_state"],
                                  end_index=m.fields["end_index"],
                                  caging_score=m.fields["caging_score"],
                                  caging_area=float(m.attrs["caging_area"]),
                                  n_tip_prehension=int(m.attrs["n_tip_prehension"])))
        return out
    designs = [Design(l1, l2, r1, r2, w) for w in widths]
    finger, solver, blocks = kernel_records(designs[0], part, limits, accuracy, effects)
    ncols = np.array([grid_index_bounds(d, part, Grid(h=h))[1] for d in designs],
                     dtype=np.int64)
    ny = grid_index_bounds(designs[0], part, Grid(h=h))[3] + 1
    steps = np.array(steps, dtype=np.int64)
    shared, m_lo, ys = many_maps.shared_finger_field(finger, solver, blocks, steps, ncols, ny,
                                                     float(h))
    out: list = [None] * len(widths)

    def maps(first, last):
        for k in range(first, last):
            xs, fingers = many_maps.gather_fingers(shared, m_lo, steps[k], ncols[k], ny, float(h))
            outs = new_outcome_arrays(ny, xs.shape[0])
            summary = np.empty(len(SUMMARY_FIELDS))
            one_map.map_from_fingers(
                xs=xs, ys=ys, finger=finger, solver=solver,
                hand=hand_record(widths[k], command, h, finger), effects=blocks,
                fingers=fingers, outs=outs, forces=no_force_arrays(),
                stack=np.empty(ny * xs.shape[0], dtype=np.int64), summary=summary,
                every_point=one_map.EVERY_POINT, equilibrium=one_map.ALL_OUTPUTS,
                caging=one_map.ALL_OUTPUTS, settled=no_settled_fingers())
            out[k] = _setting_map(designs[k], xs, ys, outs, summary)

    over_ranges(len(widths), maps, ranges_per_thread=len(widths))
    return out
