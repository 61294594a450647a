"""Points/s of the paper-style baseline alone, on one map (scripts/paper_baseline.py).

Solves the map's grid points the way the paper's Methods describe (least_squares on the vector
loops, per point and finger, row by row from the palm up), at most --max-points of them, and
prints points/s and the count of each point class. Slow: about 10-20 points/s.
"""
from __future__ import annotations

import sys
from pathlib import Path

from .timing import header

NAME = "baseline-map"


def add_arguments(ap) -> None:
    for name, default in (("l1", 2.0), ("l2", 1.6), ("r1", 0.2), ("r2", 0.14), ("w", 0.8),
                          ("r", 0.4), ("mu", 0.4), ("h", 0.2)):
        ap.add_argument(f"--{name}", type=float, default=default, help=f"[{default}]")
    ap.add_argument("--max-points", type=int, default=None,
                    help="solve at most this many grid points [all]")
    ap.add_argument("--reconfig-step", type=float, default=0.01, help="rad [0.01]")
    ap.add_argument("--root-tol", type=float, default=1e-9, help="[1e-9]")


def run(a) -> int:
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
    import paper_baseline  # scripts/paper_baseline.py, the reference (not a package)

    from sweep import model as M

    header(NAME)
    res = paper_baseline.baseline_map(a.l1, a.l2, a.r1, a.r2, a.w, a.r, a.mu, h=a.h,
                                      max_points=a.max_points, reconfig_step=a.reconfig_step,
                                      root_tol=a.root_tol)
    pc = res["point_class"]
    counts = {name: int((pc == code).sum()) for code, name in enumerate(M.POINT_CLASS_MEANINGS)}
    n, sec = res["n_points_solved"], res["seconds"]
    print(f"design l1={a.l1} l2={a.l2} r1={a.r1} r2={a.r2} w={a.w}  part r={a.r} mu={a.mu}  "
          f"h={a.h}")
    print(f"grid {pc.shape[0]} x {pc.shape[1]}, solved {n} points in {sec:.2f} s: "
          f"{n / sec:.1f} points/s")
    print("classes:", counts)
    return 0
