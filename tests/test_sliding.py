"""The sliding trajectory rule (model-notes D16, MODEL 8 "Creases"): the kernels' map against the
slow reference (tests/naive.py, written from the D16 text), the D16 invariants, and the stall
that motivates the rule, pinned on the energies.

End states and end points are compared here (tests/test_reference.py compares every field), and
where each slide stops, off the grid (a stop can move while every end point stays the same);
every map below has grid stalls that slide, and each comparison asserts that sliding and grid8
really differ on it, so a kernel that silently fell back to grid8 fails; together the maps have
moves given by each of the three searches of D16's cascade. On the whole crease map, every place
where the kernel's trajectories stall is certified by a fine probe of the model, to the
resolution of the cascade (its smallest circle, h/4).
"""
from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import naive
from naive import naive_map, naive_point, naive_trajectory
from strategies import paper_table_designs

# The design of MODEL 8 "Creases": grid8 stalls there on most of the map as h shrinks.
CREASE_DESIGN = (2.0, 1.6, 0.16, 0.06, 1.2, 0.4, 0.1)      # l1, l2, r1, r2, w, r, mu
CREASE_H = 0.0125
CREASE_WINDOW = dict(h=CREASE_H, xlim=(-2.6, -2.3), ylim=(0.7, 1.1))
CREASE_POINT = (-2.5125, 0.8125)                          # all 8 neighbours uphill (MODEL 8)

# Maps with grid stalls that slide (design, commands, grid). Found with the reference; what each
# exercises is said beside it.
SLIDE_CASES = {
    # along the crease of MODEL 8, slide after slide, out through the window's top edge
    "crease-window": (CREASE_DESIGN, (1.0, 1.0), CREASE_WINDOW),
    # the same design at h = 0.025, a window over its upper creases (incl. two slides that stall)
    "crease-h0.025-window": (CREASE_DESIGN, (1.0, 1.0),
                             dict(h=0.025, xlim=(-1.6, 0.2), ylim=(1.0, 2.1))),
    # a slide rejoins at a STABLE corner above its start (D16: the first STABLE corner wins)
    "stable-corner": ((2.0, 0.8, 0.2, 0.1, 0.8, 1.6, 0.4), (1.0, 1.0), dict(h=0.1)),
    # w/2 not a multiple of h: the grid's offsets are not integers (D1)
    "w-off-grid": ((2.0, 0.8, 0.2, 0.1, 0.7, 1.6, 0.4), (1.0, 1.0), dict(h=0.1)),
    # unequal commands; most slides here stall (a true minimum off the grid); moves by the
    # cascade's (b), incl. at (-2.3, 1.5) where (c) would have gone lower (see the cascade test)
    "unequal-commands": ((2.0, 1.2, 0.04, 0.14, 2.0, 0.4, 0.4), (1.4, 0.6), dict(h=0.1)),
    # a move given by the cascade's (c), the thorough search, after (a) and (b) found nothing
    "thorough-search": ((1.2, 0.4, 0.04, 0.02, 0.0, 1.6, 0.7), (0.6, 1.4), dict(h=0.2)),
}


def kernel_map(design, commands=(1.0, 1.0), h=0.1, xlim=None, ylim=None, trajectory="sliding"):
    """compute_map with the default accuracy, except the trajectory method when asked."""
    from sweep.compute.maps import compute_map
    from sweep.model import Accuracy, Command, Design, Grid, Limits, Part
    l1, l2, r1, r2, w, r, mu = design
    accuracy = Accuracy() if trajectory == "sliding" else Accuracy(trajectory=trajectory)
    return compute_map(Design(l1, l2, r1, r2, w), Part(r, mu), Command(*commands),
                       Grid(h=h, xlim=xlim, ylim=ylim), Limits(), accuracy)


def reference_map(design, commands=(1.0, 1.0), h=0.1, xlim=None, ylim=None,
                  trajectory="sliding"):
    return naive_map(*design, f_left=commands[0], f_right=commands[1], h=h, xlim=xlim,
                     ylim=ylim, trajectory=trajectory)


def ends(m):
    """(end_state, end_index) of a kernel map or a reference map, as arrays."""
    if isinstance(m, dict):
        return m["end_state"], m["end_index"]
    return np.asarray(m.fields["end_state"]), np.asarray(m.fields["end_index"])


def assert_same_ends(kernel, ref):
    assert np.array_equal(kernel.x, ref["x"]) and np.array_equal(kernel.y, ref["y"])
    assert np.array_equal(np.asarray(kernel.fields["point_class"]), ref["point_class"])
    (ks, ki), (rs, ri) = ends(kernel), ends(ref)
    bad = np.argwhere((ks != rs) | (ki != ri))
    nx = len(ref["x"])
    problems = [f"x={ref['x'][i]!r}, y={ref['y'][j]!r}: "
                f"kernel ({ks[j, i]}, end (j, i) {divmod(int(ki[j, i]), nx)}), "
                f"reference ({rs[j, i]}, end (j, i) {divmod(int(ri[j, i]), nx)}), "
                f"slide here: {ref['slides'].get((j, i))}"
                for j, i in bad[:10]]
    assert not problems, f"{len(bad)} points differ:\n" + "\n".join(problems)
    for key in ("n_caged", "n_tip_prehension", "n_ejection", "n_stalled"):
        assert kernel.attrs[key] == ref[key], key
    assert abs(kernel.attrs["Lambda"] - ref["Lambda"]) <= 1e-9 * max(1.0, ref["Lambda"])


def differ(a, b):
    """Points whose trajectory ends differently (state or end point) under two maps."""
    (sa, ia), (sb, ib) = ends(a), ends(b)
    return (sa != sb) | (ia != ib)


@pytest.fixture(scope="module")
def maps():
    """Kernel and reference maps under both methods, computed once per case."""
    cache = {}

    def get(name, impl, trajectory="sliding"):
        key = (name, impl, trajectory)
        if key not in cache:
            design, commands, grid = SLIDE_CASES[name]
            make = kernel_map if impl == "kernel" else reference_map
            cache[key] = make(design, commands, trajectory=trajectory, **grid)
        return cache[key]

    return get


# ---------------------------------------------------------------------------------------------
# Kernel against reference, on maps where slides happen
# ---------------------------------------------------------------------------------------------
@pytest.mark.parametrize("name", list(SLIDE_CASES))
def test_sliding_ends_match_reference(maps, name):
    ref = maps(name, "reference")
    assert ref["slides"], "no grid stall slid on this map: the case tests nothing"
    assert_same_ends(maps(name, "kernel"), ref)
    # the slides change trajectories: sliding is not grid8 here (kernel and reference alike)
    assert differ(maps(name, "kernel"), maps(name, "kernel", "grid8")).any()
    assert differ(ref, maps(name, "reference", "grid8")).any()


@pytest.mark.parametrize("name", ["crease-window", "unequal-commands"])
def test_grid8_ends_match_reference(maps, name):
    """The paper-like rule stays available by name (D16, D7) and still matches its reference."""
    ref = maps(name, "reference", "grid8")
    assert not ref["slides"]
    assert_same_ends(maps(name, "kernel", "grid8"), ref)


def test_slide_outcomes_are_all_exercised(maps):
    """Across the cases, slides rejoin the grid, end EJECTION and stall: every exit of D16; and
    each of the cascade's three searches gives moves, so the comparisons above cover them all."""
    outcomes = {}
    moves = [0] * len(naive.SLIDE_CASCADE)
    for name in SLIDE_CASES:
        ref = maps(name, "reference")
        for outcome in ref["slides"].values():
            outcomes[outcome] = outcomes.get(outcome, 0) + 1
        moves = [a + b for a, b in zip(moves, ref["cascade_moves"])]
    assert set(outcomes) == {"rejoined", "ejection", "stalled"}, outcomes
    assert all(n > 0 for n in moves), moves


@pytest.mark.parametrize("name", list(SLIDE_CASES))
def test_sliding_only_changes_grid8_stalls(maps, name):
    """D16 step 1 is grid8's step; slides start only where grid8 stalls. So a trajectory that
    grid8 does not end stalled ends the same under sliding, and sliding stalls no more starts."""
    for impl in ("kernel", "reference"):
        sliding, grid8 = maps(name, impl), maps(name, impl, "grid8")
        g8_state, _ = ends(grid8)
        changed = differ(sliding, grid8)
        assert not (changed & (g8_state != naive.END_STALLED)).any(), impl
        sl_state, _ = ends(sliding)
        assert not ((sl_state == naive.END_STALLED) & (g8_state != naive.END_STALLED)).any(), impl


# ---------------------------------------------------------------------------------------------
# The stall rule, pinned (MODEL 8 "Creases")
# ---------------------------------------------------------------------------------------------
def test_crease_point_stalls_grid8_but_not_sliding(maps):
    """At (-2.5125, 0.8125), h = 0.0125, every neighbour is uphill, yet the step (+h, +2h) along
    the crease is downhill and (+2h, +4h) lower still: grid8 stalls there, sliding does not."""
    h = CREASE_H
    for impl in ("kernel", "reference"):
        m = maps("crease-window", impl)
        x, y = (m["x"], m["y"]) if impl == "reference" else (m.x, m.y)
        energy = m["energy"] if impl == "reference" else np.asarray(m.fields["energy"])
        cls = m["point_class"] if impl == "reference" else np.asarray(m.fields["point_class"])
        i = int(np.argmin(np.abs(x - CREASE_POINT[0])))
        j = int(np.argmin(np.abs(y - CREASE_POINT[1])))
        assert abs(x[i] - CREASE_POINT[0]) < 1e-12 and abs(y[j] - CREASE_POINT[1]) < 1e-12
        assert cls[j, i] == naive.REACHED
        e = energy[j, i]
        for di, dj in naive.NEIGHBOURS:
            assert energy[j + dj, i + di] > e, (impl, di, dj)
        slope = (energy[j + 2, i + 1] - e) / (h * math.sqrt(5.0))
        assert slope < -0.02, (impl, slope)                 # MODEL 8: -0.031
        assert energy[j + 4, i + 2] < energy[j + 2, i + 1], impl
        assert cls[j + 2, i + 1] == cls[j + 4, i + 2] == naive.REACHED

        nx = len(x)
        g8_state, g8_index = ends(maps("crease-window", impl, "grid8"))
        assert g8_state[j, i] == naive.END_STALLED and g8_index[j, i] == j * nx + i, impl
        sl_state, sl_index = ends(m)
        assert not (sl_state[j, i] == naive.END_STALLED and sl_index[j, i] == j * nx + i), impl
    assert maps("crease-window", "reference")["slides"][(j, i)] == "rejoined"


def test_crease_point_descends_off_the_grid():
    """The model off the grid (naive_point): on the circle of radius h about the crease point
    some direction descends although the 8 grid neighbours do not. At the point itself
    naive_point gives the map's energy."""
    h = CREASE_H
    x0, y0 = CREASE_POINT
    e0 = naive_point(x0, y0, *CREASE_DESIGN)
    ref = maps_point_energy(x0, y0)
    assert e0["point_class"] == naive.REACHED
    assert abs(e0["energy"] - ref) <= 1e-12 * abs(ref)
    angles = np.radians(np.arange(0.0, 360.0, 5.625))
    circle = [naive_point(x0 + h * math.cos(a), y0 + h * math.sin(a), *CREASE_DESIGN)["energy"]
              for a in angles]
    lowest = min(e for e in circle if e is not None)
    assert lowest < e0["energy"] - 1e-12 * abs(e0["energy"])
    # ... in the direction of the crease, (1, 2), within a few degrees
    best = float(np.degrees(angles[int(np.argmin([np.inf if e is None else e for e in circle]))]))
    assert abs(best - math.degrees(math.atan2(2.0, 1.0))) < 20.0


def maps_point_energy(px, py):
    """The reference grid energy of one point of the crease window."""
    m = naive_map(*CREASE_DESIGN, h=CREASE_H, xlim=(px - 1e-6, px + 1e-6),
                  ylim=(py - 1e-6, py + 1e-6))
    assert m["energy"].shape == (1, 1)
    return float(m["energy"][0, 0])


# ---------------------------------------------------------------------------------------------
# The search of D16, in the reference
# ---------------------------------------------------------------------------------------------
def test_slide_directions_are_32_mirror_exact_unit_vectors():
    """D16 "Directions": k 11.25 deg from E, E and N exact, 16 - k the exact mirror of k."""
    dirs = naive.SLIDE_DIRECTIONS
    assert len(dirs) == 32
    assert dirs[0] == (1.0, 0.0) and dirs[8] == (0.0, 1.0)
    for k, (c, s) in enumerate(dirs):
        a = math.radians(11.25 * k)
        assert abs(c - math.cos(a)) <= 1e-15 and abs(s - math.sin(a)) <= 1e-15, k
        assert dirs[(16 - k) % 32] == (-c, s), k
    assert naive.SLIDE_STEP_DIRECTIONS == (0, 4, 8, 12, 16, 20, 24, 28)   # E, NE, N, ..., SE


def test_slide_cascade_is_searched_in_order():
    """D16 "The cascade": (a) the step's search on the circle of h, (b) the step's search on the
    circle of h/4, (c) the thorough search on the circle of h."""
    assert naive.SLIDE_CASCADE == (("step", 1.0), ("step", 0.25), ("thorough", 1.0))


def test_thorough_search_finds_the_narrow_wedge():
    """D16's example: at (-0.822, 2.062) of the crease map, h = 0.025, the step's search (8
    directions, refined) finds nothing lower on the circle of h, nor on the circle of h/4, yet a
    narrow wedge between a wall at 0 deg (a jump into VERTEX_POINT) and the NE descends: the
    cascade's last search, the thorough search on the circle of h, finds it and gives the move;
    with a budget of two searches the part stalls there."""
    h, (x0, y0) = 0.025, (-0.822, 2.062)
    e0 = naive_point(x0, y0, *CREASE_DESIGN)["energy"]

    def energy(deg):
        a = math.radians(deg)
        p = naive_point(x0 + h * math.cos(a), y0 + h * math.sin(a), *CREASE_DESIGN)
        return p["energy"], p["point_class"]

    assert energy(0.0)[1] == naive.VERTEX_POINT and energy(0.0)[0] > e0 + 0.04     # the wall
    assert all(energy(45.0 * k)[0] > e0 for k in range(8))                         # 8 uphill
    assert energy(11.25)[0] < e0 - 1e-4 and energy(22.5)[0] > e0                   # the wedge
    grid = naive.ReferenceGrid(*CREASE_DESIGN, h=h)
    assert grid.step_search(x0, y0, h)[0] > e0        # (a): refinements toward W, still uphill
    assert grid.step_search(x0, y0, h / 4)[0] > e0    # (b): the same on the small circle
    thorough = grid.thorough_search(x0, y0, h)        # (c)
    assert naive.strictly_below(thorough[0], e0) and thorough[0] <= energy(11.25)[0]
    assert 0.0 < math.degrees(math.atan2(thorough[2] - y0, thorough[1] - x0)) < 22.5
    assert grid.slide_move(x0, y0, e0, 3)[:3] == (thorough, 3, 2)
    assert grid.slide_move(x0, y0, e0, 2)[:3] == (None, 2, None)   # budget spent: stalled (D16)


def test_the_first_search_that_descends_gives_the_move():
    """D16: the first search of the cascade that finds a lower point gives the move, even where a
    later one would find a lower point still. At the crease point (a) descends and (c) would
    descend further; at (-2.3, 1.5) of the unequal-commands map (a grid stall that slides) (a)
    finds nothing, (b) descends on the circle of h/4 and (c) would descend further on the circle
    of h (the previous scheme, thorough search before the small circle, moved there)."""
    # (a) before (c)
    x0, y0 = CREASE_POINT
    grid = naive.ReferenceGrid(*CREASE_DESIGN, **CREASE_WINDOW)
    e0 = naive_point(x0, y0, *CREASE_DESIGN)["energy"]
    a = grid.step_search(x0, y0, CREASE_H)
    assert naive.strictly_below(a[0], e0)
    assert grid.thorough_search(x0, y0, CREASE_H)[0] < a[0]
    assert grid.slide_move(x0, y0, e0, 3)[:3] == (a, 1, 0)

    # (b) before (c)
    design, commands, window = SLIDE_CASES["unequal-commands"]
    h, (x0, y0) = window["h"], (-2.3, 1.5)
    grid = naive.ReferenceGrid(*design, f_left=commands[0], f_right=commands[1], **window)
    jj = int(np.argmin(np.abs(grid.y - y0)))
    ii = int(np.argmin(np.abs(grid.x - x0)))
    assert abs(grid.x[ii] - x0) < 1e-12 and abs(grid.y[jj] - y0) < 1e-12
    assert grid.point(jj, ii)["point_class"] == naive.REACHED
    assert grid.successor(jj, ii) is None                 # a grid stall: the slide starts here
    x0, y0, e0 = grid.x[ii], grid.y[jj], grid.point(jj, ii)["energy"]
    assert grid.step_search(x0, y0, h)[0] > e0            # (a): nothing lower
    b = grid.step_search(x0, y0, h / 4)
    assert naive.strictly_below(b[0], e0)
    assert abs(math.hypot(b[1] - x0, b[2] - y0) - h / 4) < 1e-12
    c = grid.thorough_search(x0, y0, h)
    assert c[0] < b[0] - 1e-4                             # (c) would go clearly lower
    assert grid.slide_move(x0, y0, e0, 3)[:3] == (b, 2, 1)


# ---------------------------------------------------------------------------------------------
# Every stall of the whole crease map is certified
# ---------------------------------------------------------------------------------------------
# The probe: 720 directions (every 0.5 deg) on circles of h/4, h/2 and h about a stop; "lower" is
# D16's own test, E < E_stop - 1e-12 |E_stop|. No smaller circle: the cascade's smallest circle
# is h/4, so a stop is certified only to that resolution (the part is not followed closer than
# h/4 into a corner; the true minimum may lie a little deeper). Measured margin (2026-11-25,
# cascade (a) step h, (b) step h/4, (c) thorough h): the lowest probe point, on the circle of
# h/4, lies 2.5e-5 (side stops) and 7.8e-5 (top stop) ABOVE the stop.
PROBE_DIRECTIONS = 720
PROBE_RADII = (1 / 4, 1 / 2, 1.0)


def lowest_probe(px, py, h):
    """The lowest feasible point of the fine probe about (px, py): (energy, x, y) or None."""
    best = None
    for f in PROBE_RADII:
        for k in range(PROBE_DIRECTIONS):
            a = 2.0 * math.pi * k / PROBE_DIRECTIONS
            qx, qy = px + f * h * math.cos(a), py + f * h * math.sin(a)
            e = naive_point(qx, qy, *CREASE_DESIGN)["energy"]
            if e is not None and (best is None or e < best[0]):
                best = (e, qx, qy)
    return best


def test_every_stall_of_the_crease_map_is_a_true_stop():
    """The whole crease map at h = 0.0125 (116,829 reached starts, 58,203 stalled). For each
    distinct stalled end of the kernel, the reference follows the nearest and the farthest start
    ending there (same end state and end point as the kernel) to where the part stops, and the
    fine probe (720 directions on the circles of radii h/4, h/2 and h about the stop) finds no
    point lower than the stop. This certifies a stop only to the resolution of D16's cascade,
    which looks for a lower point on the circles of h and h/4 and no closer: nothing lower lies
    on those circles, but the part is not followed closer than h/4 into a corner, so the true
    minimum may lie a little deeper (hence no circle of h/8 or h/16 in the probe). MODEL 8's
    crease map stops only at corners of walls (jumps of +0.043 into VERTEX_POINT, where a
    finger's joint or tip strikes the part); there are 3 stops: (-0.65930, 1.64762) and its
    mirror (+0.65930, 1.64762), in the corner of the right (resp. left) finger's VERTEX wall,
    and (-0.00047, 1.98515), in the V where both fingers' VERTEX walls meet above the palm's
    centre (end grid points (-0.6625, 1.65), (0.6625, 1.65), (0, 1.9875))."""
    h = CREASE_H
    m = kernel_map(CREASE_DESIGN, h=h)
    state, index = ends(m)
    nx = len(m.x)
    stalled = state == naive.END_STALLED
    assert stalled.sum() > 1000                         # the rule is exercised on a large scale
    end_points = sorted(set(int(e) for e in index[stalled]))
    assert 1 <= len(end_points) <= 5, len(end_points)   # a handful (3, see the docstring)
    # the map is mirror symmetric (equal commands), and so is the set of its stalls
    mirrored = {divmod(e, nx)[0] * nx + (nx - 1 - divmod(e, nx)[1]) for e in end_points}
    assert mirrored == set(end_points)

    stops = {}
    for e in end_points:
        ej, ei = divmod(e, nx)
        js, iis = np.nonzero(stalled & (index == e))
        dist2 = (js - ej) ** 2 + (iis - ei) ** 2
        for k in (int(np.argmin(dist2)), int(np.argmax(dist2))):
            start = (m.x[iis[k]], m.y[js[k]])
            tr = naive_trajectory(start, *CREASE_DESIGN, h=h)
            assert (tr["end_state"], tr["end_index"]) == (naive.END_STALLED, e), start
            assert list(tr["slides"].values())[-1] == "stalled", start
            px, py, e_stop = tr["stop"]
            # D16: a stalled trajectory's end point is the grid point nearest to the stop
            assert (np.argmin(np.abs(m.y - py)), np.argmin(np.abs(m.x - px))) == (ej, ei)
            stops[(px, py)] = e_stop
    assert len(stops) <= 5, stops                        # the same handful of places

    for (px, py), e_stop in stops.items():
        lowest = lowest_probe(px, py, h)
        assert lowest is not None
        assert not naive.strictly_below(lowest[0], e_stop), (px, py, e_stop, lowest)


# ---------------------------------------------------------------------------------------------
# The reference's off-grid evaluator agrees with its own map on grid points
# ---------------------------------------------------------------------------------------------
@pytest.mark.parametrize("design,h", [(CREASE_DESIGN, 0.2), ((2.0, 0.8, 0.2, 0.1, 0.7, 1.6, 0.4),
                                                             0.2)])
def test_naive_point_equals_the_map_on_grid_points(design, h):
    m = naive_map(*design, h=h, trajectory="grid8")
    for jj in range(0, len(m["y"]), 3):
        for ii in range(0, len(m["x"]), 3):
            p = naive_point(m["x"][ii], m["y"][jj], *design)
            assert p["point_class"] == m["point_class"][jj, ii]
            if p["energy"] is None:
                assert np.isnan(m["energy"][jj, ii])
            else:
                assert abs(p["energy"] - m["energy"][jj, ii]) <= 1e-9


# ---------------------------------------------------------------------------------------------
# Random designs from the paper's table
# ---------------------------------------------------------------------------------------------
table_designs = paper_table_designs()


@settings(max_examples=30)
@given(table_designs, st.sampled_from([(1.0, 1.0), (0.6, 1.4)]))
def test_sliding_ends_match_reference_random_designs(design, commands):
    ref = reference_map(design, commands, h=0.2)
    assert_same_ends(kernel_map(design, commands, h=0.2), ref)


def test_circle_ties_go_to_the_first_direction_from_east():
    """On the symmetry axis of a symmetric map the circle's directions come in mirror pairs of
    exactly equal energy (the directions are exact mirror images, D16). At (0, 2.0) of the
    crease map, h = 0.05, the lowest of the step's search is the pair E / W: the first
    evaluated, E, is kept."""
    from sweep.kernels.outcome import point_outcome
    from sweep.kernels.records import Hand
    from sweep.kernels.trajectories import lowest_on_circle, new_memo, SLIDE_DIRECTIONS
    from sweep.kernels.meeting_search import no_slide_context
    from sweep.compute.layout import kernel_records
    from sweep.model import Accuracy, Design, Effects, Limits, Part

    design, part, h = Design(2.0, 1.6, 0.16, 0.06, 1.2), Part(0.4, 0.1), 0.05
    finger, solver, blocks = kernel_records(design, part, Limits(), Accuracy(), Effects())
    hand = Hand(design.w, 1.0, 1.0, h, finger.mu_s, finger.mu_s)
    e, _, ux, uy = lowest_on_circle(0.0, 2.0, h, False, np.empty(SLIDE_DIRECTIONS), finger,
                                    solver, blocks, hand, new_memo(0, False), no_slide_context())
    east = point_outcome(h, 2.0, finger, solver, blocks, hand)[1]
    west = point_outcome(-h, 2.0, finger, solver, blocks, hand)[1]
    assert east == west  # an exact tie
    assert (ux, uy) == (1.0, 0.0) and e == east


# ---------------------------------------------------------------------------------------------
# Where each slide stops, not only where its trajectory ends
# ---------------------------------------------------------------------------------------------


def kernel_slide_stops(m):
    """{(j, i): (outcome, x, y)} of every grid stall of a kernel map that slides: the kernel's
    own step (trajectories.successor, called as trajectory_ends calls it, with the map's memo
    and collision context) from every point, and, where it slid, the last position the slide
    records: where the part rejoined the grid, left P_j or the window, or stopped."""
    from sweep.compute.layout import finger_arrays_of, hand_record, kernel_records
    from sweep.kernels.trajectories import (
        GOES_ON,
        max_slide_points,
        memo_for_slide,
        new_memo,
        successor,
    )
    from sweep.kernels.meeting_search import slide_context

    f = m.fields
    energy = np.asarray(f["energy"], dtype=np.float64)
    point_class = np.asarray(f["point_class"])
    equilibrium = np.asarray(f["equilibrium"], dtype=bool)
    fingers = finger_arrays_of(f)
    x, y = np.asarray(m.x, float), np.asarray(m.y, float)
    ny, nx = energy.shape
    h = m.grid.h
    finger, solver, blocks = kernel_records(m.design, m.part, m.limits, m.accuracy, m.effects)
    hand = hand_record(m.design.w, m.command, h, finger)
    memo = new_memo(1, hand.f_left == hand.f_right)
    context = slide_context(finger, hand.w, blocks.finger_collision)
    path = np.empty((max_slide_points(ny, nx), 2))
    stops = {}
    kinds = {GOES_ON: "rejoined", naive.END_EJECTION: "ejection", naive.END_STALLED: "stalled"}
    for j in range(ny):
        for i in range(nx):
            if point_class[j, i] != naive.REACHED or equilibrium[j, i]:
                continue
            memo = memo_for_slide(memo)
            state, _, n = successor(energy, point_class, equilibrium, fingers, x, y, i, j, finger,
                                    solver, blocks, hand, True, path, memo, context)
            if n:
                stops[(j, i)] = (kinds[int(state)], path[n - 1, 0], path[n - 1, 1])
    return stops


def assert_same_slide_stops(kernel, ref):
    """Every slide of the reference (naive.py, D16) has the kernel's outcome and stops where the
    reference's does (to 1e-9 h: the two build their rotated directions in different orders),
    and the kernel slides from no other grid point."""
    got = kernel_slide_stops(kernel)
    assert set(got) == set(ref["slides"]), (sorted(got), sorted(ref["slides"]))
    h = kernel.grid.h
    problems = []
    for key, outcome in ref["slides"].items():
        px, py, _ = ref["slide_ends"][key]
        k_outcome, kx, ky = got[key]
        if k_outcome != outcome or math.hypot(kx - px, ky - py) > 1e-9 * h:
            problems.append(f"slide from (j, i) = {key}: kernel {k_outcome} at ({kx!r}, {ky!r}), "
                            f"reference {outcome} at ({px!r}, {py!r})")
    assert not problems, f"{len(problems)} slides stop elsewhere:\n" + "\n".join(problems[:10])


@pytest.mark.parametrize("name", list(SLIDE_CASES))
def test_slide_stop_positions_match_reference(maps, name):
    """Where each slide stops (rejoins, leaves P_j, stalls), against the reference: a slide's
    stop can move while every trajectory's end point (the nearest grid point) stays the same,
    which the end-state comparison above cannot see."""
    ref = maps(name, "reference")
    assert ref["slides"]
    assert_same_slide_stops(maps(name, "kernel"), ref)


@settings(max_examples=12)
@given(table_designs, st.sampled_from([(1.0, 1.0), (0.6, 1.4)]))
def test_slide_stop_positions_match_reference_random_designs(design, commands):
    ref = reference_map(design, commands, h=0.2)
    assert_same_slide_stops(kernel_map(design, commands, h=0.2), ref)


# A slide that meets a wall (model-notes D36, 4.): found by comparing the kernel's end states with
# and without the wall moves on the 208 maps of the screening sample (2026-12-05).
WALL_DESIGN = (2.0, 1.6, 0.2, 0.18, 1.2, 1.2, 0.4)          # l1, l2, r1, r2, w, r, mu
WALL_STARTS = ((-1.25, 1.65), (1.25, 1.65), (-1.3, 1.7))


def test_a_slide_along_a_wall_takes_the_references_small_moves(monkeypatch):
    """From these starts (h = 0.05, checked steps) a slide's move on the circle of h is blocked
    by a wall and the slide goes on along it with WALL_MOVES moves on the circle of h/4 before
    it tries h again. The kernel ends each where the reference does; the reference without the
    wall moves (WALL_MOVES = 0: the plain cascade at every position) ends elsewhere, so the case
    exercises the rule (a kernel without it ended at the other point, checked 2026-12-05)."""
    m = kernel_map(WALL_DESIGN, h=0.05)
    nx = m.x.size
    for x, y in WALL_STARTS:
        i, j = int(np.argmin(np.abs(m.x - x))), int(np.argmin(np.abs(m.y - y)))
        ref = naive_trajectory((x, y), *WALL_DESIGN, h=0.05)
        assert (int(m.fields["end_state"][j, i]), int(m.fields["end_index"][j, i])) == \
            (ref["end_state"], ref["end_index"]), (x, y)
        with monkeypatch.context() as patched:
            patched.setattr(naive, "WALL_MOVES", 0)
            plain = naive_trajectory((x, y), *WALL_DESIGN, h=0.05)
        assert plain["end_index"] != ref["end_index"], (x, y)
        assert ref["end_index"] // nx != j or ref["end_index"] % nx != i
