"""One limit for the trajectories (model-notes D38): where sliding, grid8 and
continuous disagree, the model's trajectory (MODEL 8, followed here on the true energy with
small steps, a slow reference written for this test) ends as sliding does. The case: a part that
slides down onto a crease whose other side is held by friction (the edge of a stable region)
ends there, caged; grid8 and continuous stall there, the limits they converge to elsewhere."""
from __future__ import annotations

import math

import numpy as np

from sweep.compute.layout import kernel_records
from sweep.compute.maps import compute_map
from sweep.kernels.outcome import point_outcome
from sweep.kernels.records import Hand
from sweep.model import (END_CAGED, END_STALLED, REACHED, Accuracy, Design, Effects, Grid, Limits,
                         Part)

DESIGN, PART, H = Design(2.0, 1.6, 0.04, 0.02, 0.0), Part(0.4, 0.1), 0.0125
START = (-1.3625, 0.6125)       # a start where the methods disagree (docs/accuracy.md)
RHO, DIRECTIONS = 0.002, 128


def energy_at():
    finger, solver, blocks = kernel_records(DESIGN, PART, Limits(), Accuracy(), Effects())
    hand = Hand(DESIGN.w, 1.0, 1.0, H, finger.mu_s, finger.mu_s)

    def at(x, y):
        c, e = point_outcome(x, y, finger, solver, blocks, hand)
        return int(c), float(e)
    return at


def steepest_descent(x, y, at, steps=2000):
    """The part moved by RHO towards the lowest of DIRECTIONS points around it while that is
    lower (MODEL 8's 'follow the energy downhill'); returns where no direction descends."""
    angles = 2 * math.pi * np.arange(DIRECTIONS) / DIRECTIONS
    c, e = at(x, y)
    for _ in range(steps):
        assert c == REACHED
        around = [at(x + RHO * math.cos(a), y + RHO * math.sin(a)) for a in angles]
        k = int(np.argmin([v[1] for v in around]))
        if not around[k][1] < e - 1e-12 * abs(e):
            return x, y, e
        x, y = x + RHO * math.cos(angles[k]), y + RHO * math.sin(angles[k])
        c, e = around[k]
    raise AssertionError("no end within the step budget")


def test_a_part_that_slides_onto_the_edge_of_a_region_held_by_friction_ends_caged():
    at = energy_at()
    x, y, e = steepest_descent(*START, at)
    # the stable region begins within 2 RHO of where it stops: the part has arrived where it is
    # held (the crease it reached is the edge of a region in equilibrium)
    near = compute_map(DESIGN, PART, grid=Grid(h=RHO / 2, xlim=(x - 2 * RHO, x + 2 * RHO),
                                               ylim=(y - 2 * RHO, y + 2 * RHO)))
    stable = near.fields["equilibrium"] & (near.fields["point_class"] == REACHED)
    assert stable.any() and (near.fields["caging_score"][stable] > 0).all()
    # and not at the stop itself on the coarse grid: an end test at the nearest grid point alone
    # would stall here (the reference of D38's first attempt did)
    assert not stable.all()
    ends = {}
    for method in ("sliding", "grid8", "continuous"):
        m = compute_map(DESIGN, PART, grid=Grid(h=H), accuracy=Accuracy(trajectory=method))
        i = int(round((START[0] - m.x[0]) / H))
        j = int(round((START[1] - m.y[0]) / H))
        ends[method] = int(m.fields["end_state"][j, i])
    assert ends["sliding"] == END_CAGED
    assert ends["grid8"] == END_STALLED and ends["continuous"] == END_STALLED
