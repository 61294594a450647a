"""Cold compilation and warm cache load of the kernels a map and a sweep need.

Two fresh processes, one after the other, with NUMBA_CACHE_DIR pointing at a new empty folder:
the first compiles the kernels of one map (compute_map) and one sweep cell (summarize_cells),
base scene and default outputs, and writes them to the cache; the second does the same with
the cache warm. Prints the wall seconds of each process, imports included. Every other
subcommand keeps this time out of its figures (it compiles or loads first, untimed). --scene
adds the kernels of one effect (e.g. finger_collision) in both processes.
"""
from __future__ import annotations

import subprocess
import sys
import tempfile
import time

from .timing import header

NAME = "compile"

CHILD = r"""
import numpy as np
from sweep.compute.batch import summarize_cells
from sweep.compute.maps import compute_map
from sweep.model import Accuracy, Command, Design, Effects, Grid, Limits, Part
effects = Effects(**{{{scene!r}: True}}) if {scene!r} else Effects()
compute_map(Design(2.0, 1.6, 0.2, 0.14, 0.8), Part(0.4, 0.4), grid=Grid(h=0.4), effects=effects)
summarize_cells(np.array([[1.2, 0.8, 0.12, 0.1, 0.8, 0.4]]), np.array([0.0, 0.4]), Command(),
                0.4, Limits(), Accuracy(), effects)
"""


def add_arguments(ap) -> None:
    ap.add_argument("--scene", default="", metavar="EFFECT",
                    help="also an effect's kernels, e.g. finger_collision [base scene only]")


def run(args) -> int:
    import os

    header(NAME)
    code = CHILD.format(scene=args.scene)
    with tempfile.TemporaryDirectory(prefix="sweep-bench-compile-") as cache:
        env = dict(os.environ, NUMBA_CACHE_DIR=cache)
        for label in ("cold (empty cache, compiles)", "warm (cache written by the first)"):
            started = time.perf_counter()
            subprocess.run([sys.executable, "-c", code], env=env, check=True)
            print(f"- {label}: {time.perf_counter() - started:.2f} s", flush=True)
    return 0
