"""`sweep optimize` (sweep.runs.optimize, sweep.runs.search): the search finds a known optimum on
a plateau-y synthetic score; on configs/small.yaml no design of a grid 4x finer beats x* beyond
the error (scripts/optimize_bruteforce.py runs the full check, docs/optimisation.md records it);
a killed run resumes to the same file; bad input is refused before anything is written.
"""
from __future__ import annotations

import math
import shutil
from pathlib import Path

import h5py
import numpy as np
import pytest
from click.testing import CliRunner

from sweep.cli import main
from sweep.runs import evaluations
from sweep.runs.search import Box, BudgetSpent, multi_start

ROOT = Path(__file__).resolve().parents[1]
SMALL = ROOT / "configs" / "small.yaml"

# ---------------------------------------------------------------------------------------------
# A synthetic score with a known optimum, plateaus and grid-scale jitter
# ---------------------------------------------------------------------------------------------
LOWER = (0.4, 0.4, 0.04, 0.02, 0.0)
UPPER = (2.0, 1.6, 0.20, 0.18, 2.0)
#: The quadratic's peak: l1 beyond its upper bound (the optimum sits on the bound), the rest
#: inside the box between the grid points of configs/paper.yaml.
PEAK = np.array([2.3, 1.1, 0.13, 0.07, 0.9])
SCALE = np.array([0.5, 0.5, 0.06, 0.06, 0.6])
PLATEAU = 0.05            # the score is counted in steps of this (a grid point's area)
STEPS = np.array([0.2, 0.4, 0.04, 0.04, 0.4])
MIN_STEPS = np.array([0.05, 0.05, 0.005, 0.005, 0.05])


def synthetic(d) -> float:
    """10 - |(d - PEAK) / SCALE|^2 counted in steps of PLATEAU, plus a jitter below one step
    that depends on the design only through its cell of a 0.01 lattice (grid-scale noise)."""
    z = (np.asarray(d) - PEAK) / SCALE
    smooth = 10.0 - float(z @ z)
    cell = np.floor(np.asarray(d) / 0.01).astype(np.int64)
    jitter = (int(np.sum(cell * np.array([7, 13, 31, 61, 127]))) % 5) * PLATEAU / 10
    return math.floor(smooth / PLATEAU) * PLATEAU + jitter


def known_optimum() -> np.ndarray:
    """The box's maximum of the separable quadratic: the peak clipped into the box."""
    return np.clip(PEAK, LOWER, UPPER)


def tolerance() -> np.ndarray:
    """Where the plateau of the optimum ends, per parameter: a step of PLATEAU plus the jitter
    (< PLATEAU/2) is |z|^2 < 1.5 PLATEAU around the optimum, in one coordinate at most
    sqrt(1.5 PLATEAU) x SCALE."""
    return np.sqrt(1.5 * PLATEAU) * SCALE


def run_search(seed: int, budget: int = 900):
    box = Box(LOWER, UPPER)
    seen: set = set()

    def score(d):
        k = tuple(np.round(d, 9))
        if k not in seen:
            if len(seen) >= budget:
                raise BudgetSpent()
            seen.add(k)
        return synthetic(d)

    # seeds: grid designs of the paper's config around (not at) the optimum
    seeds = np.array([[2.0, 1.2, 0.12, 0.06, 0.8], [1.8, 0.8, 0.16, 0.10, 1.2],
                      [1.6, 1.2, 0.12, 0.02, 0.4]])
    trace, ends = multi_start(score, box, seeds, seed, 40, lambda: len(seen) >= 0.6 * budget,
                              3, STEPS, MIN_STEPS)
    best = max(ends, key=lambda t: t.value)
    return best.best, best.value, len(seen)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_the_search_finds_a_known_optimum_on_a_plateau_landscape(seed):
    x, v, n = run_search(seed)
    opt = known_optimum()
    assert np.all(np.abs(x - opt) <= tolerance() + 1e-9), (x, opt, tolerance())
    assert v >= synthetic(opt) - PLATEAU
    assert n <= 900
    again = run_search(seed)                          # the same seeds: the same answer
    assert np.array_equal(again[0], x) and again[1] == v and again[2] == n


def test_box_feasible_clips_projects_the_budget_and_keeps_fixed_values():
    box = Box(LOWER, UPPER, {"w": 0.5}, length_budget=2.5, resolution=1e-3)
    d = box.feasible([2.4, 1.5, 0.3, 0.01, 1.7])
    assert d[4] == 0.5                                # fixed
    assert d[0] + d[1] <= 2.5 + 1e-12                 # budget
    assert d[0] == pytest.approx(1.5) and d[1] == pytest.approx(1.0)   # equal shortening
    assert d[2] == 0.2 and d[3] == 0.02               # clipped
    assert box.active(d) == {"r1": "upper", "r2": "lower", "w": "fixed",
                             "length_budget": "upper"}
    # one length at its lower bound: the other takes the rest of the shortening
    d = Box(LOWER, UPPER, {}, 1.0).feasible([0.45, 1.6, 0.1, 0.1, 1.0])
    assert d[0] == 0.4 and d[1] == pytest.approx(0.6)


# ---------------------------------------------------------------------------------------------
# On a store
# ---------------------------------------------------------------------------------------------
def invoke(*args):
    return CliRunner().invoke(main, [str(a) for a in args])


@pytest.fixture(scope="module")
def small_store(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("optimize") / "small.h5"
    res = invoke("run", SMALL, "--out", out, "--threads", 1, "--no-progress")
    assert res.exit_code == 0, res.output
    return out


OPTS = ("--part", "0.4,0.4", "--evaluations", 60, "--levels", 1, "--starts", 2, "--seeds", 3,
        "--threads", 1, "--no-progress")
#: Variables of a results file that time the run (they differ between a run and its resume).
TIMING_VARS = ("eval_seconds", "seconds")


def contents(path: Path) -> tuple[dict, dict]:
    """Every dataset (by path) and the root attributes that do not time the run."""
    from sweep.storage.optimized import RUN_ATTRS

    data = {}
    with h5py.File(path, "r") as f:
        def visit(name, obj):
            if isinstance(obj, h5py.Dataset) and name.split("/")[-1] not in TIMING_VARS:
                data[name] = obj[...]
        f.visititems(visit)
        attrs = {k: v for k, v in f.attrs.items() if k not in RUN_ATTRS}
    return data, attrs


def same_contents(a: Path, b: Path) -> None:
    (da, aa), (db, ab) = contents(a), contents(b)
    assert sorted(da) == sorted(db)
    for k in da:
        assert np.array_equal(da[k], db[k], equal_nan=da[k].dtype.kind == "f"), k
    assert set(aa) == set(ab)
    for k in aa:
        x, y = np.asarray(aa[k]), np.asarray(ab[k])
        assert np.array_equal(x, y, equal_nan=x.dtype.kind == "f"), k


def test_optimize_writes_a_self_describing_file_and_a_rerun_is_a_no_op(small_store, tmp_path):
    out = tmp_path / "opt.h5"
    res = invoke("optimize", small_store, *OPTS, "--out", out)
    assert res.exit_code == 0, res.output
    assert "verdict:" in res.output and "x*" in res.output
    assert not (tmp_path / "opt.h5.work").exists()
    import xarray as xr

    ds = xr.open_dataset(out, engine="h5netcdf")
    assert ds.x_star.dims == ("part", "param")
    assert ds.eval_caging_area.dims == ("evaluation",)
    assert ds.attrs["sweep_file_kind"] == "sweep-optimization"
    # the verdict is d > u from the stored values, and x* is the value the file says
    k = int(ds.finest_level[0])
    d = float(ds.x_star_area[0, k] - ds.grid_best_area[0, k])
    assert float(ds.difference[0]) == pytest.approx(d)
    assert bool(ds.beats[0]) == (d > float(ds.uncertainty[0]))
    ds.close()
    before = out.read_bytes()
    again = invoke("optimize", small_store, *OPTS, "--out", out)
    assert again.exit_code == 0 and "nothing computed" in again.output
    assert out.read_bytes() == before


def test_x_star_and_g_are_the_caging_areas_of_independent_maps(small_store, tmp_path):
    """The stored values of x* and G at h are those of `compute_map` on those designs."""
    from sweep.compute.maps import compute_map
    from sweep.config.parse import load_scene
    from sweep.model import Design, Grid, Part

    out = tmp_path / "opt.h5"
    assert invoke("optimize", small_store, *OPTS, "--out", out).exit_code == 0
    scene = load_scene(SMALL)
    with h5py.File(out, "r") as f:
        for name in ("x_star", "grid_best"):
            design = Design(*(float(v) for v in f[name][0]))
            m = compute_map(design, Part(0.4, 0.4), scene.commands[0], Grid(h=scene.h),
                            scene.limits, scene.accuracy, scene.effects)
            assert f[name + "_area"][0, 0] == m.attrs["caging_area"], name


def test_a_killed_run_resumes_to_the_same_results(small_store, tmp_path, monkeypatch):
    whole = tmp_path / "whole.h5"
    assert invoke("optimize", small_store, *OPTS, "--out", whole).exit_code == 0
    out = tmp_path / "killed.h5"
    monkeypatch.setattr(evaluations, "CHECKPOINT_SECONDS", 0.0)   # journal every map
    real = evaluations.MapScores.area
    calls = {"n": 0}

    def dies(self, design, r, mu, h):
        if not self.known(design, r, mu, h):
            calls["n"] += 1
            if calls["n"] > 25:
                raise KeyboardInterrupt         # a kill: nothing after the last journal save
        return real(self, design, r, mu, h)

    monkeypatch.setattr(evaluations.MapScores, "area", dies)
    res = invoke("optimize", small_store, *OPTS, "--out", out)
    assert res.exit_code == 130, res.output
    assert not out.exists()                              # atomic: no partial results file
    assert (tmp_path / "killed.h5.work" / evaluations.JOURNAL).exists()
    monkeypatch.setattr(evaluations.MapScores, "area", real)
    res = invoke("optimize", small_store, *OPTS, "--out", out)
    assert res.exit_code == 0, res.output
    assert not (tmp_path / "killed.h5.work").exists()
    same_contents(whole, out)
    with h5py.File(out, "r") as f:
        assert f.attrs["computed_maps"] < f["evaluation"].size     # the journal was used


@pytest.mark.parametrize("args, names", [
    (("--fix", "l3=2"), ("--fix", "l3")),
    (("--fix", "l1"), ("--fix",)),
    (("--fix", "w=-1"), ("w",)),
    (("--bounds", "l1=2:1"), ("--bounds", "l1")),
    (("--bounds", "l1=0.4"), ("--bounds",)),
    (("--part", "0.5,0.4"), ("--part", "0.5,0.4")),
    (("--part", "0.4"), ("--part",)),
    (("--part", "0.4,0.4", "--objective", "worst"), ("--objective",)),
    (("--length-budget", "1.0"), ("--length-budget",)),
    (("--fix", "l1=1.5", "--bounds", "l1=1:2"), ("--fix", "--bounds")),
    (("--evaluations", "5"), ("--evaluations",)),
    (("--fix", "l1=1", "--fix", "l2=1", "--fix", "r1=0.1", "--fix", "r2=0.1", "--fix", "w=1"),
     ("nothing to search",)),
])
def test_bad_input_is_refused_before_anything_is_written(small_store, tmp_path, args, names):
    out = tmp_path / "opt.h5"
    res = invoke("optimize", small_store, *args, "--out", out)
    assert res.exit_code == 2, res.output
    assert "Traceback" not in res.output
    lines = [ln for ln in res.output.splitlines() if ln.strip()]
    assert len(lines) == 1, res.output
    for name in names:
        assert name in lines[0], (name, lines[0])
    assert not out.exists() and not (tmp_path / "opt.h5.work").exists()


def test_a_config_is_not_a_store(tmp_path):
    shutil.copy(SMALL, tmp_path / "small.yaml")
    res = invoke("optimize", tmp_path / "small.yaml")
    assert res.exit_code == 2 and "not a results store" in res.output


def test_no_design_of_a_grid_4x_finer_beats_x_star_beyond_the_error(small_store, tmp_path):
    """Brute force (scripts/optimize_bruteforce.py's check): every design of a grid 4x finer
    than the store's in every parameter, same parts, same h; the best of them B against x* at
    h/2, each with its error estimate (its change from h)."""
    import sys

    sys.path.insert(0, str(ROOT / "scripts"))
    from optimize_bruteforce import fine_grid

    from sweep.config.parse import load_scene
    from sweep.runs.evaluations import MapScores

    out = tmp_path / "opt.h5"
    res = invoke("optimize", small_store, "--threads", 1, "--no-progress", "--out", out)
    assert res.exit_code == 0, res.output
    scene = load_scene(SMALL)
    designs = fine_grid([min(scene.values[k]) for k in ("l1", "l2", "r1", "r2", "w")],
                        [max(scene.values[k]) for k in ("l1", "l2", "r1", "r2", "w")],
                        [0.8, 0.8, 0.08, 0.08, 0.4], 4)
    assert designs.shape == (5 ** 5, 5)
    scores, h = MapScores(scene), scene.h
    with h5py.File(out, "r") as f:
        parts = list(zip(f["r"][...], f["mu"][...]))
        x_stars = f["x_star"][...]
    for (r, mu), x in zip(parts, x_stars):
        values = np.array([scores.area(d, r, mu, h) for d in designs])
        b = designs[int(np.argmax(values))]
        xb = [(scores.area(d, r, mu, h / 2), abs(scores.area(d, r, mu, h / 2)
                                               - scores.area(d, r, mu, h))) for d in (x, b)]
        (vx, ex), (vb, eb) = xb
        assert vb - vx <= ex + eb, (r, mu, x, b, xb)


def test_the_report_of_an_optimised_store_has_the_section(small_store, tmp_path):
    """`sweep report` adds optimization.csv/png and a section when STORE.optimize.h5 is beside
    the store; the table's numbers are the results file's (read here with h5py)."""
    import csv

    store = tmp_path / "small.h5"
    shutil.copy(small_store, store)
    assert invoke("optimize", store, *OPTS).exit_code == 0
    assert (tmp_path / "small.optimize.h5").exists()
    res = invoke("report", store, "--out", tmp_path / "report")
    assert res.exit_code == 0, res.output
    rows = list(csv.DictReader(open(tmp_path / "report" / "optimization.csv")))
    assert (tmp_path / "report" / "optimization.png").stat().st_size > 0
    assert "## 6. Beyond the grid" in (tmp_path / "report" / "report.md").read_text()
    with h5py.File(tmp_path / "small.optimize.h5", "r") as f:
        k = int(f["finest_level"][0])
        assert float(rows[0]["x_area"]) == pytest.approx(f["x_star_area"][0, k], rel=1e-5)
        assert float(rows[0]["g_area"]) == pytest.approx(f["grid_best_area"][0, k], rel=1e-5)
        assert float(rows[0]["x_l1"]) == pytest.approx(f["x_star"][0, 0], rel=1e-5)


def test_the_two_scene_report_has_the_section_of_the_optimised_scene(small_store, tmp_path):
    """`sweep report A B` (the two-scene report of `make run`) with B optimised: B's files
    (`optimization_2.*`) and section, none for A; the table's numbers are B's results file's."""
    import csv

    import yaml

    raw = yaml.safe_load(SMALL.read_text())
    raw["name"] = "small-collision"
    raw["effects"]["finger_collision"] = True
    config = tmp_path / "small-collision.yaml"
    config.write_text(yaml.safe_dump(raw))
    one, two = tmp_path / "small.h5", tmp_path / "small-collision.h5"
    shutil.copy(small_store, one)
    assert invoke("run", config, "--out", two, "--threads", 1, "--no-progress").exit_code == 0
    assert invoke("optimize", two, *OPTS).exit_code == 0
    out = tmp_path / "report"
    res = invoke("report", one, two, "--out", out)
    assert res.exit_code == 0, res.output
    assert not (out / "optimization_1.csv").exists() and not (out / "optimization_1.png").exists()
    assert (out / "optimization_2.png").stat().st_size > 0
    md = (out / "report.md").read_text()
    assert "## 6. Beyond the grid, `sweep optimize`, scene 2" in md
    assert "small-collision.optimize.h5" in md
    rows = list(csv.DictReader(open(out / "optimization_2.csv")))
    with h5py.File(tmp_path / "small-collision.optimize.h5", "r") as f:
        k = int(f["finest_level"][0])
        assert float(rows[0]["x_area"]) == pytest.approx(f["x_star_area"][0, k], rel=1e-5)
        assert float(rows[0]["g_l1"]) == pytest.approx(f["grid_best"][0, 0], rel=1e-5)
    # optimising scene 1 afterwards makes the report stale: redone with scene 1's section too
    assert invoke("optimize", one, *OPTS).exit_code == 0
    res = invoke("report", one, two, "--out", out)
    assert res.exit_code == 0 and "nothing to do" not in res.output, res.output
    assert (out / "optimization_1.csv").exists()
    assert "`sweep optimize`, scene 1" in (out / "report.md").read_text()


def test_the_figure_draws_g_and_x_star_grippers_on_x_stars_map(small_store, tmp_path):
    """Each map panel of optimization.png: x*'s gripper (solid) and G's (dashed, another
    colour), each palm and two fingers, named in the panel's legend; G's fingers are G's
    links (their polyline lengths l1 and l2), not x*'s."""
    from sweep.report.optimized import (G_GRIPPER, X_GRIPPER, optimization_figure,
                                        optimization_rows)
    from sweep.report.stores import open_store

    store = tmp_path / "small.h5"
    shutil.copy(small_store, store)
    assert invoke("optimize", store, *OPTS).exit_code == 0
    rows = optimization_rows(tmp_path / "small.optimize.h5")
    fig = optimization_figure(open_store(store), rows, lambda m: None)
    panels = [ax for ax in fig.axes if ax.get_legend() is not None
              and any(line.get_gid() for line in ax.lines)]
    assert len(panels) == min(len(rows), 4)
    for ax in panels:
        legend = [t.get_text() for t in ax.get_legend().get_texts()]
        assert legend == [X_GRIPPER, G_GRIPPER]
        gids = [line.get_gid() for line in ax.lines if line.get_gid()]
        for who in (X_GRIPPER, G_GRIPPER):
            assert gids.count(f"{who}:palm") == 1 and gids.count(f"{who}:finger") == 2, gids
        g_lines = [line for line in ax.lines if line.get_gid() == f"{G_GRIPPER}:finger"]
        x_lines = [line for line in ax.lines if line.get_gid() == f"{X_GRIPPER}:finger"]
        assert g_lines[0].get_color() != x_lines[0].get_color()
        assert g_lines[0].get_linestyle() == "--" and x_lines[0].get_linestyle() == "-"
        row = rows[0]
        for line in g_lines:
            pts = np.column_stack(line.get_data())
            links = np.hypot(*np.diff(pts, axis=0).T)
            assert links == pytest.approx([row["g_l1"], row["g_l2"]], abs=1e-9)
        palm = next(line for line in ax.lines if line.get_gid() == f"{G_GRIPPER}:palm")
        assert abs(np.diff(palm.get_xdata())[0]) == pytest.approx(row["g_w"], abs=1e-9)


@pytest.mark.parametrize("option", ["--tolerance", "--friction-change"])
def test_a_robustness_option_that_is_not_finite_is_refused(small_store, option):
    """nan passes click's FloatRange: the command refuses it, names the option, exit 2 (found
    by the long fuzz profile: a ValueError reached the user)."""
    res = invoke("optimize", small_store, option, "nan", "--no-progress")
    assert res.exit_code == 2, res.output
    assert option in res.output and "finite" in res.output
    assert not (small_store.parent / (small_store.name + ".optimize.h5")).exists()


@pytest.mark.parametrize("value", ["1e9", "1e300"])
def test_a_tolerance_larger_than_the_fingers_is_refused(small_store, value):
    """The long fuzz profile (2026-11-28): --tolerance 1e300 ended in an OverflowError
    traceback and 1e9 in an error about a grid that does not fit in memory, naming no option.
    A tolerance larger than the box's smallest length or radius is refused at the edge."""
    res = invoke("optimize", small_store, "--tolerance", value, "--no-progress")
    assert res.exit_code == 2, res.output
    lines = res.output.strip().splitlines()
    assert len(lines) == 1 and "--tolerance" in lines[0], res.output
    assert not (small_store.parent / (small_store.name + ".optimize.h5")).exists()
