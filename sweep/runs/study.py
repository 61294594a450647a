"""What the accuracy study is, apart from running it (`runs/accuracy.py`): its reference
settings, the cells and parts it samples from, one rung of its ladder (`Setting`) and its result
(`Study`), which the study's report (`report/accuracy.py`) reads. Plain Python: no map computed.
"""
from __future__ import annotations

import itertools
from dataclasses import dataclass, field

import numpy as np

from ..config.scene import Scene
from ..model import Accuracy

REFERENCE_STEP, REFERENCE_TOL = 0.002, 1e-12
# A setting replaces the config's own only when measured this much cheaper: timings of one
# setting vary by about 10% from run to run on a shared machine (docs/performance.md).
MIN_SAVING = 0.10
CELL_AXES = ("l1", "l2", "r1", "r2")


@dataclass(frozen=True)
class Setting:
    """One rung of the ladder: the axis it varies and the full accuracy it runs at."""

    axis: str          # "h", "reconfig_step", "root_tol", "trajectory", "reference" or
    #                    "reference/2" (the reference's settings one halving coarser)
    h: float
    accuracy: Accuracy

    @property
    def key(self) -> str:
        a = self.accuracy
        return (f"h{self.h:.6g}_s{a.reconfig_step:.6g}_t{a.root_tol:.3g}_{a.trajectory}")

    @property
    def label(self) -> str:
        a = self.accuracy
        return {"h": f"h = {self.h:g}", "reconfig_step": f"reconfig_step = {a.reconfig_step:g}",
                "root_tol": f"root_tol = {a.root_tol:g}", "trajectory": a.trajectory,
                "reference": f"reference (h = {self.h:g})",
                "reference/2": f"reference at h = {self.h:g}"}[self.axis]


def design_cells(scene: Scene) -> np.ndarray:
    """Every (l1, l2, r1, r2) of the config, in config order: float64 (n, 4)."""
    return np.array(list(itertools.product(*(scene.values[a] for a in CELL_AXES))),
                    dtype=np.float64).reshape(-1, 4)


def parts(scene: Scene) -> list[tuple[float, float, int]]:
    """Every part (r, mu) under every command, in config order."""
    return [(r, mu, c) for r in scene.values["r"] for mu in scene.values["mu"]
            for c in range(len(scene.commands))]


@dataclass
class Study:
    scene: Scene
    n_sample: int
    sample: np.ndarray          # indices into design_cells
    n_maps_sample: int
    rows: list                  # one dict per setting (the ladder, then the references)
    reference: Setting
    recommended: dict
    seconds_default_sweep: float
    seconds_steps: float        # compute time of every step, summed from the work files
    best: list                  # per part: (part, best design at config / recommended / reference)
    convergence: list = field(default_factory=list)  # one dict per (method, h): sample sums
    witnesses: list = field(default_factory=list)    # one dict per (witness map, method, h)
    n_maps_convergence: int = 0
    refinement: list = field(default_factory=list)   # per part: the refined answer vs reference
    refinement_cost: dict = field(default_factory=dict)
