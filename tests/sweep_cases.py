"""Tiny sweep configs and a deterministic stand-in for the kernels, shared by the sweep tests."""
from __future__ import annotations

import copy
from pathlib import Path

import numpy as np
import yaml

from sweep.compute.batch import SUMMARY_FIELDS

# 2 x 2 x 1 x 2 x 2 = 16 designs x 2 parts = 32 maps = 16 work items (cells x all widths) in
# 4 geometry groups (l1, l2, r) of 4 items; sub-chunks of 3 items leave an uneven last one.
# h = 0.25 keeps each map at a few hundred points: the real kernels run it in well under a second.
TINY = {
    "name": "tiny",
    "designs": {"l1": [0.8, 1.2], "l2": [0.4, 0.8], "r1": [0.12], "r2": [0.06, 0.1],
                "w": {"lower": 0.0, "upper": 0.5, "step": 0.5}},
    "parts": {"r": [0.4], "mu": [0.1, 0.7]},
    "commands": [{"f_left": 1.0, "f_right": 1.0}],
    "grid": {"h": 0.25, "bounds": "reach"},
    "limits": {"theta2_min_deg": -5, "theta2_max_deg": 90},
    "accuracy": {"reconfig_step": 0.01, "root_tol": 1.0e-12, "trajectory": "sliding"},
    "effects": {"friction": True, "tip_contact": False, "joint_springs": False,
                "finger_collision": False},
    "run": {"sub_chunk_cells": 3},
}


def tiny(**changes) -> dict:
    """A copy of TINY with top-level sections replaced or (for dicts) updated."""
    cfg = copy.deepcopy(TINY)
    for key, value in changes.items():
        if isinstance(value, dict) and isinstance(cfg.get(key), dict):
            cfg[key].update(value)
        else:
            cfg[key] = value
    return cfg


def write_config(path: Path, cfg: dict) -> Path:
    path = Path(path)
    path.write_text(yaml.safe_dump(cfg, sort_keys=False))
    return path


def fake_summaries(cells, widths, command, h, limits, accuracy, effects=None):
    """Deterministic per-item values that encode the cell and width (integral counts, a
    non-trivial float in Lambda): a stand-in where the test is about bookkeeping, not physics."""
    cells = np.asarray(cells, dtype=np.float64)
    widths = np.asarray(widths, dtype=np.float64)
    code = np.rint(cells @ np.array([1e5, 1e4, 1e3, 1e2, 1e1, 1.0]) * 100)
    out = np.empty((cells.shape[0], widths.size, len(SUMMARY_FIELDS)))
    for k, w in enumerate(widths):
        out[:, k, :] = code[:, None] + np.rint(w * 1000) + np.arange(len(SUMMARY_FIELDS))
    out[:, :, 0] = out[:, :, 0] / 7.0 + command.f_left
    return out


def fake_items(scene, start, stop):
    """`fake_summaries` of items [start, stop) of a scene, (n, n_w, n_fields) in item order."""
    cells, cmd = scene.cells(start, stop)
    out = np.empty((stop - start, len(scene.values["w"]), len(SUMMARY_FIELDS)))
    for c in np.unique(cmd):
        sel = cmd == c
        out[sel] = fake_summaries(cells[sel], scene.widths, scene.commands[c], scene.h,
                                  scene.limits, scene.accuracy)
    return out


def item_file_in_memory(scene, items, start=0):
    """Summaries of items [start, start + len(items)) as an item file held in memory (no file)."""
    from sweep import __version__
    from sweep.storage.itemfile import KIND_PART, ItemFile

    return ItemFile(path=None, kind=KIND_PART, start=start, stop=start + len(items),
                 config_hash=scene.config_hash, version=__version__, frozen=scene.frozen(),
                 compute_seconds=0.0, data=items)
