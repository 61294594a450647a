"""Hard cases stay numerically stable (docs/stability.md): property tests per catalogue entry.

Each entry draws maps (Hypothesis) from its hard region and checks, through `compute_map` AND
the sweep path (`summarize_cells`, and `cell_map_fields` when the palm half-width is whole grid
steps): no exception; NaN only at infeasible points and no inf; categorical values in their
declared sets; counts that add up; MODEL 11 invariants (mirror symmetry under equal tensions,
linear scaling with tension, more friction never lowering the energy); and continuity of one
finger under a 1e-9 move of the part.

Examples per entry: STABILITY_EXAMPLES (default 10, about 15 s in all on 2 cores with warm
kernels). The long profile: SWEEP_LONG_PROPERTIES=1 (200 random examples per entry; `make
test-long` runs it, tests/profiles.py).
"""
import math
import os

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from kernel_calls import solve as solve_finger
from profiles import EXPLORE
from sweep.compute.batch import cell_map_fields, summarize_cells
from sweep.kernels.finger_statics import finger_energy
from sweep.compute.maps import compute_map
from sweep.grid import palm_half_width_steps
from sweep.model import (
    END_STATE_MEANINGS,
    FINGER_MODE_MEANINGS,
    INFEASIBLE,
    POINT_CLASS_MEANINGS,
    Accuracy,
    Command,
    Design,
    Grid,
    Limits,
    Part,
)
from sweep.schema import SUMMARY_FIELDS

LONG = os.environ.get("SWEEP_LONG_PROPERTIES", "") not in ("", "0")
EXAMPLES = 200 if LONG else int(os.environ.get("STABILITY_EXAMPLES", "10"))
PROFILE = settings(max_examples=EXAMPLES, deadline=None, derandomize=not EXPLORE,
                   suppress_health_check=[HealthCheck.too_slow, HealthCheck.filter_too_much])
CONTINUITY_MOVE = 1e-9
fl = dict(allow_nan=False, allow_infinity=False)


# ---------------------------------------------------------------------------------------------
# Cases: a base draw and one override per catalogue entry
# ---------------------------------------------------------------------------------------------
@st.composite
def base_case(draw):
    r1 = draw(st.floats(0.04, 0.2, **fl))
    return dict(l1=draw(st.floats(0.3, 2.0, **fl)), l2=draw(st.floats(0.2, 1.6, **fl)), r1=r1,
                r2=r1 * draw(st.floats(0.1, 0.9, **fl)), w=draw(st.sampled_from([0.0, 0.4, 0.8,
                                                                                  1.6])),
                r=draw(st.floats(0.2, 1.6, **fl)), mu=draw(st.sampled_from([0.0, 0.1, 0.4, 1.0])),
                f_left=1.0, f_right=1.0, th2min=-5.0, th2max=90.0)


ENTRIES = {
    "R-to-1": lambda d, c: c.update(r2=c["r1"] * (1 - d(st.sampled_from([1e-12, 1e-9, 1e-6])))),
    "R-equal-1": lambda d, c: c.update(r2=c["r1"]),
    "R-above-1": lambda d, c: c.update(r2=c["r1"] * d(st.floats(1.01, 3.0, **fl))),
    "R-tiny": lambda d, c: c.update(r2=c["r1"] * d(st.sampled_from([1e-6, 1e-3, 1e-2]))),
    "mu-zero": lambda d, c: c.update(mu=0.0),
    "mu-large": lambda d, c: c.update(mu=d(st.sampled_from([11.4, 12.0, 50.0, 1e3, 1e6]))),
    "w-zero": lambda d, c: c.update(w=0.0),
    "w-large": lambda d, c: c.update(w=d(st.floats(4.0, 10.0, **fl))),
    "part-tiny": lambda d, c: c.update(r=d(st.sampled_from([1e-3, 1e-2]))
                                       * min(c["l1"], c["l2"])),
    "part-huge": lambda d, c: c.update(r=d(st.floats(5.0, 20.0, **fl)) * (c["l1"] + c["l2"])),
    "tensions-unequal": lambda d, c: c.update(f_left=d(st.sampled_from([0.0, 1e-9, 1e-3])),
                                              f_right=1.0),
    "tensions-1e6": lambda d, c: c.update(f_left=1e6, f_right=1e6),
    "limits-extreme": lambda d, c: c.update(th2min=d(st.sampled_from([-89.999, -45.0, 0.0])),
                                            th2max=d(st.sampled_from([1e-6, 179.999, 180.0]))),
    "links-unequal": lambda d, c: c.update(l2=c["l1"] * d(st.sampled_from([1e-3, 1e2]))),
}


@st.composite
def hard_case(draw, entry):
    case = draw(base_case())
    ENTRIES[entry](draw, case)
    if case["th2max"] <= case["th2min"]:
        case["th2max"] = 90.0
    # about 8 grid rows over the reach; the palm half-width a whole number of steps (sweep path)
    h = (case["l1"] + case["l2"] + case["r"]) / 8
    if case["w"] > 0:
        h = case["w"] / (2 * max(1, round(case["w"] / (2 * h))))
    case["h"] = h
    case["seed"] = draw(st.integers(0, 2**31 - 1))
    return case


def objects(c, **over):
    c = {**c, **over}
    return (Design(c["l1"], c["l2"], c["r1"], c["r2"], c["w"]), Part(c["r"], c["mu"]),
            Command(c["f_left"], c["f_right"]), Grid(h=c["h"]),
            Limits(theta2_min_deg=c["th2min"], theta2_max_deg=c["th2max"]))


def run(c, **over):
    design, part, command, grid, limits = objects(c, **over)
    return compute_map(design, part, command, grid, limits, Accuracy())


# ---------------------------------------------------------------------------------------------
# Properties
# ---------------------------------------------------------------------------------------------
def check_values(fields, attrs):
    cls = fields["point_class"]
    infeasible = cls == INFEASIBLE
    assert set(np.unique(cls)) <= set(range(len(POINT_CLASS_MEANINGS)))
    assert set(np.unique(fields["finger_mode"])) <= set(range(-1, len(FINGER_MODE_MEANINGS)))
    assert set(np.unique(fields["end_state"])) <= set(range(len(END_STATE_MEANINGS)))
    for name in ("energy", "l_open", "caging_score"):
        v = fields[name]
        assert not np.isinf(v).any(), name
    assert np.isfinite(fields["energy"][~infeasible]).all()
    assert np.isnan(fields["energy"][infeasible]).all()
    assert np.isfinite(fields["caging_score"][~infeasible]).all()
    for name in ("theta1", "theta2", "k1", "k2"):
        assert np.isfinite(fields[name][:, ~infeasible]).all(), name
    for name in SUMMARY_FIELDS:  # effect-only fields are absent when the effect is off
        assert name not in attrs or math.isfinite(attrs[name]), name
    assert (attrs["n_infeasible"] + attrs["n_unreached"] + attrs["n_eject"] + attrs["n_vertex"]
            + attrs["n_reached"]) == attrs["n_points"] == cls.size
    assert (attrs["n_caged"] + attrs["n_tip_prehension"] + attrs["n_ejection"]
            + attrs["n_stalled"]) == attrs["n_reached"]
    assert 0.0 <= attrs["Lambda"] <= attrs["n_caged"] + 1e-9


def check_invariants(c, m):
    f = m.fields
    if c["f_left"] == c["f_right"]:  # mirror symmetry (MODEL 11)
        assert np.array_equal(f["point_class"], f["point_class"][:, ::-1])
        assert np.array_equal(f["finger_mode"][0], f["finger_mode"][1][:, ::-1])
        assert np.allclose(f["energy"], f["energy"][:, ::-1], rtol=1e-12, atol=0,
                           equal_nan=True)
    # linear scaling with tension: configurations unchanged, energy scaled
    scaled = run(c, f_left=3.0 * c["f_left"], f_right=3.0 * c["f_right"])
    for name in ("finger_mode", "theta1", "theta2", "point_class", "equilibrium"):
        assert np.array_equal(scaled.fields[name], f[name], equal_nan=True), name
    assert np.allclose(scaled.fields["energy"], 3.0 * f["energy"], rtol=1e-12, atol=1e-300,
                       equal_nan=True)
    # more friction never lowers the energy at a point feasible under both
    more = run(c, mu=2.0 * c["mu"] + 0.5)
    both = (f["point_class"] != INFEASIBLE) & (more.fields["point_class"] != INFEASIBLE)
    # Resolution of the energy: the stop is bracketed to root_tol (1e-12) in theta1, and near
    # the distal joint (k2 -> 0, where huge friction stops a contact: k2 ~ 1/mu) theta2 moves
    # as 1/k2 per unit theta1, so the energy is resolved to about root_tol * r2 / k2 there.
    tension = max(c["f_left"], c["f_right"])
    k2 = np.where(f["k2"] > 0, f["k2"], np.inf).min(axis=0)
    tol = tension * (1e-12 * 4.0 * (c["r1"] + c["r2"]) + 10 * 1e-12 * c["r2"] / k2)
    assert np.all(more.fields["energy"][both] >= f["energy"][both] - tol[both])


def check_sweep_path(c, m):
    design, part, command, grid, limits = objects(c)
    cell = (c["l1"], c["l2"], c["r1"], c["r2"], c["r"], c["mu"])
    rows = summarize_cells(np.array([cell]), np.array([c["w"]]), command, c["h"], limits,
                           Accuracy())
    attrs = dict(zip(SUMMARY_FIELDS, rows[0, 0]))
    for name in SUMMARY_FIELDS:  # effect-only fields are absent from the map when off
        assert attrs[name] == m.attrs.get(name, 0), name
    if palm_half_width_steps(c["w"], c["h"]) is not None:
        _, _, fields, sweep_attrs = cell_map_fields(cell, c["w"], command, c["h"], limits,
                                                    Accuracy())
        check_values(fields, sweep_attrs)
        for name in ("energy", "point_class", "end_state", "finger_mode"):
            assert np.array_equal(fields[name], m.fields[name], equal_nan=True), name


def check_continuity(c, n_points=40):
    """A 1e-9 move of the part changes one finger's energy by at most a small multiple of 1e-9
    unless the mode changes, at all but a small fraction of points (square-root behaviour at a
    grazing contact can amplify a move); the mode changes at a small fraction of points."""
    rng = np.random.default_rng(c["seed"])
    reach = c["l1"] + c["l2"] + c["r"]
    th2min, th2max = math.radians(c["th2min"]), math.radians(c["th2max"])
    scale = c["r1"] + c["r2"]
    mode_changes = jumps = 0
    for _ in range(n_points):
        dx = rng.uniform(-reach, reach)
        dy = c["r"] + rng.uniform(0.0, reach)
        ang = rng.uniform(0, 2 * math.pi)
        a = solve_finger(dx, dy, c["l1"], c["l2"], c["r1"], c["r2"], c["r"], c["mu"], th2min,
                         th2max, 0.01, 1e-12)
        b = solve_finger(dx + CONTINUITY_MOVE * math.cos(ang),
                         dy + CONTINUITY_MOVE * abs(math.sin(ang)), c["l1"], c["l2"], c["r1"],
                         c["r2"], c["r"], c["mu"], th2min, th2max, 0.01, 1e-12)
        assert (a[0] == -1) == (b[0] == -1) or abs(dx) < 2 * c["r"] or dy < c["r"] + 1e-8
        if a[0] != b[0]:
            mode_changes += 1
            continue
        if a[0] == -1:
            continue
        ea = finger_energy(a[1], a[2], c["r1"], c["r2"], 1.0, th2min)
        eb = finger_energy(b[1], b[2], c["r1"], c["r2"], 1.0, th2min)
        if abs(ea - eb) > 1e3 * CONTINUITY_MOVE * scale:
            jumps += 1
    assert mode_changes <= 0.1 * n_points
    assert jumps <= 0.1 * n_points


@pytest.mark.parametrize("entry", sorted(ENTRIES))
def test_hard_case_stays_stable(entry):
    @PROFILE
    @given(hard_case(entry))
    def check(c):
        m = run(c)
        check_values(m.fields, m.attrs)
        check_invariants(c, m)
        check_sweep_path(c, m)
        check_continuity(c)

    check()


def test_palm_row_is_on_the_grid_and_stable():
    """The palm row y = r (j = 0) is always a grid row; points on it are classified like any
    other and none is left NaN unless infeasible."""
    m = compute_map(Design(1.0, 0.8, 0.12, 0.08, 0.8), Part(0.4, 0.4), grid=Grid(h=0.1))
    assert m.y[0] == 0.4
    row = m.fields["point_class"][0]
    assert np.isfinite(m.fields["energy"][0][row != INFEASIBLE]).all()
    assert (row != INFEASIBLE).any()


def test_grid_exactly_on_the_reach_boundary():
    """X/h and (Y - r)/h whole numbers up to rounding: GRID_TOL keeps the last column and row
    (x = X, y = Y are grid points)."""
    # X = w/2 + l1 + l2 + r = 0.3 + 0.7 + 0.6 + 0.4 = 2.0, Y - r = 1.3 = 13 h at h = 0.1
    m = compute_map(Design(0.7, 0.6, 0.1, 0.05, 0.6), Part(0.4, 0.2), grid=Grid(h=0.1))
    assert m.x.size == 41 and m.y.size == 14
    assert m.x[-1] == pytest.approx(2.0) and m.y[-1] == pytest.approx(1.7)
