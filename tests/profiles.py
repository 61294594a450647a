"""The suite's two sizes: `make test` (bounded: every kind of check, in a few minutes) and
`make test-long` (the long profiles, every switch below set to 1).

- SWEEP_LONG_PROPERTIES: Hypothesis properties and random-design oracle comparisons with their
  large example counts (tests/test_accepted_space.py, test_stability.py, test_collision.py,
  test_hull.py, test_tip_contact.py, test_merge_stream.py).
- SWEEP_LONG_FUZZ: the fuzz campaign's random profile (tests/test_fuzz.py, docs/sweeps.md).
- SWEEP_LONG_ORACLES: the end-to-end oracle comparisons at their full sizes: the refinement
  against brute force on its whole test sweep (tests/test_refine.py), the manipulation store
  against the plain-Python reference on all 48 geometries of tests/data/manipulation.yaml
  (test_manipulation.py), `sweep accuracy` on every cell of configs/small.yaml
  (test_accuracy.py).
- SWEEP_LONG_RECIPE: the recipe's toy effect (tests/test_add_effect.py) compiled: its copy of
  the package gets its own kernel set (about 80 s on 2 cores); `make test` runs the same
  checks on the copy with the kernels interpreted.
- SWEEP_LONG_COMPILE: a cold compilation in a private cache (tests/test_compile_cold.py): one
  signature per kernel, and `make run`'s commands compile nothing beyond `ensure_compiled`.

A switch is on when its variable is set to anything but "" or "0".

The long profiles draw the same cases on every run (Hypothesis `derandomize`, fixed seeds), so
that "`make test-long` passes" says the same thing on every machine and every day. SWEEP_EXPLORE
draws fresh cases instead (Hypothesis seeded from the OS, the fuzz's interrupt timings too):
`make explore`, the long profiles as a random search; a case it finds becomes an explicit test
(docs/stability.md, docs/sweeps.md), and the fixed draws stay as they were.
"""
from __future__ import annotations

import os


def on(name: str) -> bool:
    return os.environ.get(name, "") not in ("", "0")


LONG_PROPERTIES = on("SWEEP_LONG_PROPERTIES")
LONG_FUZZ = on("SWEEP_LONG_FUZZ")
LONG_ORACLES = on("SWEEP_LONG_ORACLES")
LONG_RECIPE = on("SWEEP_LONG_RECIPE")
LONG_COMPILE = on("SWEEP_LONG_COMPILE")
EXPLORE = on("SWEEP_EXPLORE")
