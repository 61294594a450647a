"""Write the golden files of tests/test_golden.py: maps and a store as this version writes them.

The files in tests/data/golden/ were written by the code *before* a refactoring; the test
checks that every later version writes the same bytes in every variable and the same attributes
(timings, dates and library versions excepted). Rerun this only when a change of results is
intended, and say so in the commit.

    .venv/bin/python scripts/golden.py [OUT_DIR]
"""
from __future__ import annotations

import subprocess
import sys
from pathlib import Path

from sweep.storage.mapfile import write_map
from sweep.compute.maps import compute_map
from sweep.model import Accuracy, Command, Design, Grid, Part

# (file name, design, part, command, grid, accuracy): reference design, R > 1, a large part, a
# palm half-width off the grid with unequal commands and no friction in a user window, R = 1,
# the MODEL 8 crease map (slides happen), and the reference design under the grid8 rule.
GOLDEN_MAPS = (
    ("map_reference.h5", Design(2.0, 1.6, 0.2, 0.14, 0.8), Part(0.4, 0.4), Command(), Grid(h=0.1),
     Accuracy()),
    ("map_r_above_1.h5", Design(1.0, 0.8, 0.04, 0.18, 1.2), Part(0.8, 0.1), Command(),
     Grid(h=0.1), Accuracy()),
    ("map_large_part.h5", Design(0.6, 0.4, 0.12, 0.1, 0.4), Part(1.2, 1.0), Command(),
     Grid(h=0.1), Accuracy()),
    ("map_offgrid_window.h5", Design(1.4, 1.2, 0.16, 0.06, 0.75), Part(0.4, 0.0),
     Command(0.4, 1.6), Grid(h=0.1, xlim=(-2.0, 2.5), ylim=(0.4, 2.8)), Accuracy()),
    ("map_equal_radii.h5", Design(1.6, 0.8, 0.12, 0.12, 0.0), Part(0.8, 0.7), Command(),
     Grid(h=0.1), Accuracy()),
    ("map_crease.h5", Design(2.0, 1.6, 0.16, 0.06, 1.2), Part(0.4, 0.1), Command(),
     Grid(h=0.025, xlim=(-1.0, 0.2), ylim=(1.4, 2.1)), Accuracy()),
    ("map_reference_grid8.h5", Design(2.0, 1.6, 0.2, 0.14, 0.8), Part(0.4, 0.4), Command(),
     Grid(h=0.1), Accuracy(trajectory="grid8")),
)


def main(out: Path) -> None:
    out.mkdir(parents=True, exist_ok=True)
    for name, design, part, command, grid, accuracy in GOLDEN_MAPS:
        write_map(out / name, compute_map(design, part, command, grid, accuracy=accuracy))
    store = out / "store_small.h5"
    store.unlink(missing_ok=True)
    subprocess.run([sys.executable, "-m", "sweep.cli", "run", "configs/small.yaml", "--out",
                    str(store), "--no-progress"], check=True)


if __name__ == "__main__":
    main(Path(sys.argv[1]) if len(sys.argv) > 1 else Path("tests/data/golden"))
