"""What `sweep optimize` claims, each against an expectation worked out here, never against the
code's own output (docs/optimisation.md): the binding-constraint outputs, the changes of a step
inwards and outwards worked by hand.
"""
from __future__ import annotations

import math

import numpy as np

from sweep.runs.optimize import constraint_changes
from sweep.runs.search import Box

# ---------------------------------------------------------------------------------------------
# The binding-constraint outputs
# ---------------------------------------------------------------------------------------------
#: x* on five constraints: l1 on its upper bound, r1 on its lower, r2 fixed, w on its lower
#: bound 0, l1 + l2 on the budget (l2 free inside its bounds).
BOX = Box((1.0, 1.0, 0.1, 0.1, 0.0), (2.0, 2.0, 0.2, 0.2, 1.0), {"r2": 0.15}, 3.5)
X = np.array([2.0, 1.5, 0.1, 0.15, 0.0])
STEPS = np.array([0.05, 0.05, 0.0125, 0.0125, 0.05])
#: The change of the caging area when one parameter moves up (+) or down (-) from X; a design
#: with several parameters moved gains their sum. Dyadic, so every sum is exact.
GAINS = {0: (0.25, -0.5), 1: (0.125, -0.0625), 2: (0.375, 0.75), 3: (0.5, -0.25),
         4: (-0.125, 1.0)}
BASE = 5.0


def stepped_area(y, h):
    total = BASE
    for i, (up, down) in GAINS.items():
        if y[i] > X[i] + 1e-12:
            total += up
        elif y[i] < X[i] - 1e-12:
            total += down
    return total


#: {constraint: (side, inward, outward)} worked by hand from GAINS: a bound's inward step moves
#: into the box, its outward step beyond the bound; a fixed value's first change is the step
#: down, the second the step up; the budget's steps move l1 and l2 by half a step each. w
#: below its bound 0 is no design (the model needs w >= 0): NaN.
EXPECTED = {"l1": ("upper", -0.5, 0.25), "r1": ("lower", 0.375, 0.75),
            "r2": ("fixed", -0.25, 0.5), "w": ("lower", -0.125, math.nan),
            "length_budget": ("upper", -0.5 - 0.0625, 0.25 + 0.125)}


def same(a, b) -> bool:
    return a == b or (isinstance(a, float) and isinstance(b, float) and math.isnan(a)
                      and math.isnan(b))


def test_constraint_changes_are_the_steps_inwards_and_outwards():
    """Step 5 (docs/optimisation.md): per constraint x* is on, the change of the caging area for
    a step inwards (into the box) and outwards (relaxing it), NaN where the stepped design is
    none the model accepts. Checked: inward and outward swapped, a fixed value stepped one way
    only, the budget's steps moving one length, and w stepped below 0 read as w = 0.001 (a step
    *into* the box, whose change was reported as the outward one) each fail here."""
    got = constraint_changes(lambda y, h: stepped_area(y, h), BOX, X, STEPS, 0.05, BASE)
    assert set(got) == set(EXPECTED)
    for name, want in EXPECTED.items():
        assert all(same(float(a), float(b)) if not isinstance(a, str) else a == b
                   for a, b in zip(got[name], want)), (name, got[name], want)
