"""The maps and cells the benchmarks time, as plain numbers (no `sweep` import: a child process
of `bench.py trees` imports this module against whichever tree it measures).

Each sample is the one the measurements in docs/performance.md were taken with; where two
benchmarks drew different samples (seed, order) both are kept, so that their figures stay
reproducible.
"""
from __future__ import annotations

import itertools
import math

import numpy as np

# The paper's design table (l1, l2, r1, r2, w) and parts (r, mu): (lower, upper, step).
PAPER_AXES = dict(l1=(0.4, 2.0, 0.2), l2=(0.4, 1.6, 0.4), r1=(0.04, 0.20, 0.04),
                  r2=(0.02, 0.18, 0.04), w=(0.0, 2.0, 0.4), r=(0.4, 1.6, 0.4), mu=(0.1, 1.0, 0.3))

# Three maps of different size, (l1, l2, r1, r2, w), (r, mu): the issue's reference design and two
# contrasting ones. `baseline`, `effects` and `trees` time these.
THREE_MAPS = [((2.0, 1.6, 0.2, 0.14, 0.8), (0.4, 0.4)),
              ((1.0, 0.8, 0.04, 0.18, 1.2), (0.8, 0.1)),
              ((0.6, 0.4, 0.12, 0.1, 0.4), (1.2, 1.0))]

# The MODEL 8 crease map (model-notes D16).
CREASE_MAP = ((2.0, 1.6, 0.16, 0.06, 1.2), (0.4, 0.1))

# One cell (l1, l2, r1, r2, r, mu) for the time-versus-h table of `baseline`.
ONE_CELL = (1.2, 0.8, 0.12, 0.1, 0.8, 0.4)


def axis(lower: float, upper: float, step: float) -> list[float]:
    n = int(math.floor((upper - lower) / step + 1e-9))
    return [lower + i * step for i in range(n + 1)]


def paper_cells() -> tuple[np.ndarray, np.ndarray]:
    """All 900 cells (l1, l2, r1, r2, r, mu) of the paper's table and its 6 palm widths."""
    a = {k: axis(*v) for k, v in PAPER_AXES.items()}
    cells = np.array(list(itertools.product(a["l1"], a["l2"], a["r1"], a["r2"], a["r"], a["mu"])))
    return cells, np.array(a["w"])


def paper_sample(n_cells: int, seed: int = 1, in_table_order: bool = True) -> np.ndarray:
    """`n_cells` random cells of the paper's table. seed 1, table order: the sample of `baseline`,
    `collision` and `trees`; seed 0, drawn order: the sample of `trajectory`."""
    cells, _ = paper_cells()
    pick = np.random.default_rng(seed).choice(len(cells), size=min(n_cells, len(cells)),
                                              replace=False)
    return cells[np.sort(pick)] if in_table_order else cells[pick]


def issue_1200_groups() -> list[np.ndarray]:
    """The 1,200 maps of issues P10 and P12 (l1 = 2, l2 = 1.6, every r1, r2, mu; r in {0.4, 0.8};
    x the 6 widths) as the runner calls them: one geometry group (l1, l2, r) of 100 cells per
    kernel call, cells in table order (`collision`)."""
    a = {k: axis(*v) for k, v in PAPER_AXES.items()}
    return [np.array([(2.0, 1.6, r1, r2, r, mu) for r1 in a["r1"] for r2 in a["r2"]
                      for mu in a["mu"]]) for r in (0.4, 0.8)]


def issue_1200_flat() -> tuple[np.ndarray, np.ndarray]:
    """The same 200 cells and 6 widths in one kernel call, ordered (r, mu, r1, r2), values
    written as decimal literals rather than by `axis` (`trajectory`)."""
    r1 = (0.04, 0.08, 0.12, 0.16, 0.2)
    r2 = (0.02, 0.06, 0.1, 0.14, 0.18)
    cells = np.array([(2.0, 1.6, a, b, r, mu)
                      for r, mu in itertools.product((0.4, 0.8), (0.1, 0.4, 0.7, 1.0))
                      for a in r1 for b in r2])
    return cells, np.array([0.0, 0.4, 0.8, 1.2, 1.6, 2.0])


def paper_widths() -> np.ndarray:
    return np.array(axis(*PAPER_AXES["w"]))
