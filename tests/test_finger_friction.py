"""Per-finger friction (MODEL 10, Scenario C): each finger's contacts with the part have their own
friction coefficient, which decides that finger's configuration and forces and its cone in the
part's equilibrium (MODEL 7); the palm keeps the part's mu.

Checked against today's kernels (equal frictions: the same map, bit for bit), against the slow
reference tests/naive.py extended to per-finger friction, and by invariants: swapping the
fingers' frictions (and tensions) mirrors the map; the palm keeps mu."""
from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from naive import naive_map
from strategies import paper_table_designs
from sweep.compute.maps import compute_map
from sweep.model import (Accuracy, Command, Design, Effects, Grid, Limits, ModelInputError,
                         Outputs, Part)
from test_reference import assert_maps_equal

H = 0.2
DESIGN = Design(2.0, 1.6, 0.2, 0.14, 0.8)
PART = Part(0.4, 0.7)

#: scenes whose maps must not change when both fingers are given the part's own friction
SCENES = {
    "base": (Effects(), Outputs(forces=True)),
    "collision": (Effects(finger_collision=True), Outputs(forces=True)),
    "tip": (Effects(tip_contact=True), Outputs()),
    "tip+collision": (Effects(tip_contact=True, finger_collision=True), Outputs()),
    "springs": (Effects(joint_springs=True, spring_k1=0.01, spring_k2=0.01), Outputs()),
}

#: per-point fields that a mirror image in x maps onto themselves (end states follow the
#: trajectories' tie order, E first, which is not mirror-symmetric: test_invariants)
POINT_FIELDS = ("energy", "point_class", "equilibrium", "contained", "l_open", "caging_score",
                "geometric_cage_score")
FINGER_FIELDS = ("finger_mode", "theta1", "theta2", "k1", "k2", "tip_overlap",
                 "proximal_normal_force", "distal_normal_force", "distal_friction_multiplier",
                 "resultant_force_y", "forces_determined")


def a_map(design=DESIGN, part=PART, command=Command(), effects=Effects(), outputs=None,
          mu_left=None, mu_right=None, h=H):
    return compute_map(design, part, command, Grid(h=h), Limits(), Accuracy(), effects,
                       outputs=outputs, mu_left=mu_left, mu_right=mu_right)


@pytest.mark.parametrize("scene", SCENES)
def test_equal_finger_frictions_give_todays_map_bit_for_bit(scene):
    effects, outputs = SCENES[scene]
    today = a_map(effects=effects, outputs=outputs)
    same = a_map(effects=effects, outputs=outputs, mu_left=PART.mu, mu_right=PART.mu)
    assert set(today.fields) == set(same.fields)
    for name, value in today.fields.items():
        assert np.array_equal(value, same.fields[name], equal_nan=True), name
    for key, value in today.attrs.items():
        if not key.startswith("seconds_"):
            other = same.attrs[key]
            assert value == other or (math.isnan(value) and math.isnan(other)), key


PER_FINGER_CASES = [
    # l1,  l2,  r1,   r2,   w,   r,   mu,  mu_left, mu_right, f_left, f_right, h
    (2.0, 1.6, 0.20, 0.14, 0.8, 0.4, 0.4, 0.0, 0.4, 1.0, 1.0, 0.2),    # one finger switched
    (2.0, 1.6, 0.20, 0.14, 0.8, 0.4, 0.7, 0.0, 0.0, 1.0, 1.0, 0.1),    # both low, palm 0.7
    (2.0, 1.6, 0.16, 0.06, 1.2, 1.2, 1.0, 1.0, 0.1, 1.0, 1.0, 0.2),    # high left, low right
    (1.2, 0.8, 0.12, 0.10, 0.4, 0.8, 0.4, 0.4, 0.0, 0.6, 1.4, 0.2),    # unequal commands too
    (2.0, 1.6, 0.20, 0.14, 0.0, 0.4, 0.1, 0.7, 0.1, 1.0, 1.0, 0.1),    # w = 0: fingers share J
]


@pytest.mark.parametrize("case", PER_FINGER_CASES, ids=lambda c: "-".join(f"{v:g}" for v in c))
def test_per_finger_map_matches_the_reference(case):
    l1, l2, r1, r2, w, r, mu, mu_l, mu_r, f_l, f_r, h = case
    ref = naive_map(l1, l2, r1, r2, w, r, mu, f_l, f_r, h=h, mu_left=mu_l, mu_right=mu_r)
    fast = a_map(Design(l1, l2, r1, r2, w), Part(r, mu), Command(f_l, f_r), mu_left=mu_l,
                 mu_right=mu_r, h=h)
    assert_maps_equal(fast, ref)


FRICTIONS = st.integers(0, 4).map(lambda i: 0.0 + i * 0.25)


@settings(max_examples=25)
@given(paper_table_designs(), FRICTIONS, FRICTIONS)
def test_per_finger_map_matches_the_reference_random_designs(design, mu_l, mu_r):
    l1, l2, r1, r2, w, r, mu = design
    ref = naive_map(l1, l2, r1, r2, w, r, mu, h=0.25, mu_left=mu_l, mu_right=mu_r)
    fast = a_map(Design(l1, l2, r1, r2, w), Part(r, mu), mu_left=mu_l, mu_right=mu_r, h=0.25)
    assert_maps_equal(fast, ref)


@pytest.mark.parametrize("collision", [False, True], ids=["base", "collision"])
@settings(max_examples=12)
@given(design=paper_table_designs(), mu_l=FRICTIONS, mu_r=FRICTIONS,
       f_left=st.sampled_from([0.2, 1.0, 1.8]))
def test_swapping_the_fingers_frictions_mirrors_the_map(collision, design, mu_l, mu_r, f_left):
    """The left finger with (mu_l, F_left) and the right with (mu_r, F_right) is the mirror
    image of the left with (mu_r, F_right) and the right with (mu_l, F_left)."""
    l1, l2, r1, r2, w, r, mu = design
    effects = Effects(finger_collision=collision)
    args = dict(design=Design(l1, l2, r1, r2, w), part=Part(r, mu), effects=effects,
                outputs=Outputs(forces=True))
    m = a_map(command=Command(f_left, 2.0 - f_left), mu_left=mu_l, mu_right=mu_r, **args)
    s = a_map(command=Command(2.0 - f_left, f_left), mu_left=mu_r, mu_right=mu_l, **args)
    for name in POINT_FIELDS:
        assert np.array_equal(m.fields[name], s.fields[name][:, ::-1], equal_nan=True), name
    for name in FINGER_FIELDS:
        assert np.array_equal(m.fields[name], s.fields[name][::-1, :, ::-1],
                              equal_nan=True), name
    assert np.array_equal(m.fields["resultant_force_x"],
                          -s.fields["resultant_force_x"][::-1, :, ::-1], equal_nan=True)


@pytest.mark.parametrize("design", [Design(0.8, 0.4, 0.2, 0.02, 0.8),
                                    Design(0.8, 1.6, 0.04, 0.02, 2.0)])
def test_the_palm_keeps_the_parts_friction(design):
    """Both fingers at mu_low = 0 against the frictionless part: the same configurations,
    energies and forces everywhere; equilibrium differs only where the part rests on the palm,
    whose cone is the part's own (and there it can only be gained)."""
    part = Part(0.4, 1.0)
    low = a_map(design, part, mu_left=0.0, mu_right=0.0, outputs=Outputs(forces=True), h=0.1)
    frictionless = a_map(design, Part(0.4, 0.0), outputs=Outputs(forces=True), h=0.1)
    for name, value in low.fields.items():
        if name in ("equilibrium", "end_state", "end_index", "caging_score"):
            continue
        assert np.array_equal(value, frictionless.fields[name], equal_nan=True), name
    differ = low.fields["equilibrium"] != frictionless.fields["equilibrium"]
    on_palm = ((np.abs(low.y - part.r) <= 1e-9)[:, None]
               & (np.abs(low.x) <= 0.5 * design.w + 1e-9)[None, :])
    assert differ.any()
    assert not (differ & ~on_palm).any()
    assert not (frictionless.fields["equilibrium"] & ~low.fields["equilibrium"]).any()


@pytest.mark.parametrize("kwargs, message", [
    (dict(mu_left=-0.1), "mu_left must be >= 0"),
    (dict(mu_right=float("nan")), "mu_right must be >= 0"),
    (dict(mu_left=0.3, effects=Effects(friction=False)), "needs the friction effect"),
])
def test_bad_finger_frictions_are_refused(kwargs, message):
    with pytest.raises(ModelInputError, match=message):
        a_map(**kwargs)
