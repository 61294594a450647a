"""`sweep report` with Scenario C (friction modulation, MODEL 10), on the tiny sweep of
tests/data/scenario_c.yaml (and its finger_collision twin for the two-scene report).

The tables' numbers are recomputed here from the store with xarray and plain Python (the
candidates from Lambda, the best candidates from the sums, the verdicts from their rule), the
caging under modulation from maps (`compute_map`, and for "draw in, then hold" the slow
reference's maps walked in plain Python)."""
from __future__ import annotations

import csv
import itertools
from pathlib import Path

import numpy as np
import pytest
import xarray as xr
import yaml
from click.testing import CliRunner

from naive import naive_map
from sweep.cli import main as cli
from sweep.compute.maps import compute_map, draw_in_then_hold
from sweep.model import END_CAGED, Design, Grid, Part

DATA = Path(__file__).parent / "data"
DESIGN = ("l1", "l2", "r1", "r2", "w")
CANDIDATE = ("l1", "l2", "r1", "r2")


def invoke(*args):
    return CliRunner().invoke(cli, [str(a) for a in args])


def g(v) -> str:
    return f"{float(v):.6g}"


def key(v: float) -> float:
    return float(f"{v:.9g}")


def read_csv(path: Path) -> list[dict]:
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


@pytest.fixture(scope="module")
def stores(tmp_path_factory):
    root = tmp_path_factory.mktemp("friction")
    cfg = yaml.safe_load((DATA / "scenario_c.yaml").read_text())
    cfg.update(name="tiny-scenario-c-collision", effects={"finger_collision": True})
    (root / "collision.yaml").write_text(yaml.safe_dump(cfg))
    out = []
    for config, name in ((DATA / "scenario_c.yaml", "base.h5"),
                         (root / "collision.yaml", "collision.h5")):
        res = invoke("run", config, "--out", root / name, "--no-progress")
        assert res.exit_code == 0, res.output
        out.append(root / name)
    return root, out


@pytest.fixture(scope="module")
def made(stores):
    root, (store, _) = stores
    res = invoke("report", store, "--out", root / "rep")
    assert res.exit_code == 0, res.output
    with xr.open_dataset(store, engine="h5netcdf") as ds:
        ds = ds.load()
    return store, root / "rep", ds


def candidates(ds, top_k):
    """Scenario A's (and C's) candidates from Lambda: every part's top-k designs (store order
    among ties), without w, merged."""
    found = set()
    designs = list(itertools.product(*(list(ds[d].values) for d in DESIGN)))
    for r in ds.r.values:
        for mu in ds.mu.values:
            lam = [ds["Lambda"].sel(dict(zip(DESIGN, d), r=r, mu=mu)).item() for d in designs]
            order = sorted(range(len(designs)), key=lambda k: (-key(lam[k]), k))
            found |= {tuple(float(v) for v in designs[k][:4]) for k in order[:top_k]}
    return sorted(found)


def metric(ds, name, cand, r, mu):
    return ds[name].sel(dict(zip(CANDIDATE, cand), r=r, mu=mu)).item()


def best_by(ds, name, cands):
    sums = [sum(metric(ds, name, c, r, mu) for r in ds.r.values for mu in ds.mu.values)
            for c in cands]
    return cands[max(range(len(cands)), key=lambda k: (key(sums[k]), -k))]


def test_the_friction_files_are_written(made):
    _, out, _ = made
    for name in ("friction.csv", "friction_candidates.csv", "caging_modulation.csv"):
        assert read_csv(out / name), name
    assert (out / "friction.png").read_bytes().startswith(b"\x89PNG")
    md = (out / "report.md").read_text()
    assert "## 5. Friction modulation, Scenario C" in md
    assert "Scenario C (friction modulation) with μ_low = 0" in md
    assert "- Friction modulation (Scenario C, μ_low = 0)" in md


def test_a_c_and_b_per_part_are_the_stores(made):
    _, out, ds = made
    top_k = int(ds.attrs["manipulation_scenario_a_top_k"])
    cands = candidates(ds, top_k)
    a_best, c_best = best_by(ds, "manipulation_a", cands), best_by(ds, "manipulation_c", cands)
    rows = read_csv(out / "friction.csv")
    assert len(rows) == ds.r.size * ds.mu.size
    for row in rows:
        r, mu = float(row["r"]), float(row["mu"])
        a = metric(ds, "manipulation_a", a_best, r, mu)
        c = metric(ds, "manipulation_c", c_best, r, mu)
        b = ds["manipulation_b"].sel(r=r, mu=mu).item()
        assert (row["a"], row["c"], row["b"]) == (g(a), g(c), g(b))
        assert row["c_of_a_best"] == g(metric(ds, "manipulation_c", a_best, r, mu))
        gains = key(b) > key(a)
        expected = (("C matches B" if key(c) == key(b) else "C beats B" if c > b
                     else "C recovers part" if key(c) > key(a) else "C adds nothing")
                    if gains else ("C gains, B not" if key(c) > key(a) else "neither gains"))
        assert row["verdict"] == expected
        assert row["recovered"] == (g((c - a) / (b - a)) if gains else "NaN")
    table = read_csv(out / "friction_candidates.csv")
    assert [tuple(float(t[k]) for k in CANDIDATE) for t in table] == cands
    assert [t["best"] for t in table] == ["yes" if c == c_best else "no" for c in cands]


def test_caging_under_modulation_of_the_best_a_candidate(made):
    store, out, ds = made
    top_k = int(ds.attrs["manipulation_scenario_a_top_k"])
    a_best = best_by(ds, "manipulation_a", candidates(ds, top_k))
    h = float(ds.attrs["grid_h"])
    rows = read_csv(out / "caging_modulation.csv")
    for row in rows:
        r, mu = float(row["r"]), float(row["mu"])
        assert float(row["mu_low"]) == 0.0
        lam = {"s": [], "low": [], "dh": []}
        for w in ds.w.values:
            design = Design(*a_best, float(w))
            hold = compute_map(design, Part(r, mu), grid=Grid(h=h))
            draw = compute_map(design, Part(r, mu), grid=Grid(h=h), mu_left=0.0, mu_right=0.0)
            lam["s"].append(hold.attrs["Lambda"])
            lam["low"].append(draw.attrs["Lambda"])
            lam["dh"].append(draw_in_then_hold(draw, hold)[0])
        for k, values in lam.items():
            best = max(range(len(values)), key=lambda i: (key(values[i]), -i))
            assert float(row[f"w_{k}"]) == float(ds.w.values[best])
            assert row[f"lambda_{k}"] == g(values[best])
        # the map on the part's own friction is the sweep's
        stored = ds["Lambda"].sel(dict(zip(DESIGN, (*a_best, float(row["w_s"]))), r=r,
                                       mu=mu)).item()
        assert row["lambda_s"] == g(stored)
        assert row["best_area"] == g(ds["caging_area"].sel(r=r, mu=mu).max().item())


@pytest.mark.parametrize("design, part, mu_low", [
    (Design(1.6, 0.8, 0.16, 0.06, 0.0), Part(0.4, 0.4), 0.0),
    (Design(2.0, 1.6, 0.2, 0.14, 0.8), Part(0.4, 0.7), 0.1),
])
def test_draw_in_then_hold_against_the_reference(design, part, mu_low):
    """Both maps of the slow reference (tests/naive.py: the fingers on mu_low with the palm on
    mu, and all on mu), their trajectories walked in plain Python."""
    args = (design.l1, design.l2, design.r1, design.r2, design.w, part.r, part.mu)
    draw_ref = naive_map(*args, h=0.2, mu_left=mu_low, mu_right=mu_low)
    hold_ref = naive_map(*args, h=0.2)
    total, n = 0.0, 0
    for j, i in np.argwhere(draw_ref["end_state"] == END_CAGED):
        q = np.unravel_index(draw_ref["end_index"][j, i], draw_ref["end_state"].shape)
        if hold_ref["end_state"][q] == END_CAGED:
            end = np.unravel_index(hold_ref["end_index"][q], hold_ref["end_state"].shape)
            total += hold_ref["caging_score"][end]
            n += 1
    draw = compute_map(design, part, grid=Grid(h=0.2), mu_left=mu_low, mu_right=mu_low)
    hold = compute_map(design, part, grid=Grid(h=0.2))
    lam, count = draw_in_then_hold(draw, hold)
    assert n > 0
    assert count == n
    assert lam == pytest.approx(total, rel=1e-9)


def test_draw_in_then_hold_needs_one_grid():
    a = compute_map(Design(1.2, 0.8, 0.16, 0.06, 0.0), Part(0.4, 0.4), grid=Grid(h=0.2))
    b = compute_map(Design(1.2, 0.8, 0.16, 0.06, 0.4), Part(0.4, 0.4), grid=Grid(h=0.2))
    with pytest.raises(ValueError, match="share one grid"):
        draw_in_then_hold(a, b)


def test_the_two_scene_report_puts_both_scenarios_c_side_by_side(stores, made):
    root, (base, collision) = stores
    res = invoke("report", base, collision, "--out", root / "pair")
    assert res.exit_code == 0, res.output
    out = root / "pair"
    rows = read_csv(out / "friction.csv")
    single = read_csv(made[1] / "friction.csv")
    assert len(rows) == 2
    with xr.open_dataset(collision, engine="h5netcdf") as ds:
        top_k = int(ds.attrs["manipulation_scenario_a_top_k"])
        cands = candidates(ds, top_k)
        c_best = best_by(ds, "manipulation_c", cands)
        for row in rows:
            assert row["c_2"] == g(metric(ds, "manipulation_c", c_best, float(row["r"]),
                                          float(row["mu"])))
    assert [x["c"] for x in single] == [row["c_1"] for row in rows]
    assert read_csv(out / "caging_modulation.csv")
    assert (out / "friction.png").read_bytes().startswith(b"\x89PNG")
    md = (out / "report.md").read_text()
    assert "## 5. Friction modulation, Scenario C" in md
    assert "- The verdict differs between the scenes on" in md


def test_a_store_without_scenario_c_says_so(tmp_path):
    cfg = yaml.safe_load((DATA / "scenario_c.yaml").read_text())
    cfg["outputs"].pop("scenario_c")
    cfg["designs"]["r1"] = [0.16]
    (tmp_path / "no-c.yaml").write_text(yaml.safe_dump(cfg))
    res = invoke("run", tmp_path / "no-c.yaml", "--out", tmp_path / "s.h5", "--no-progress")
    assert res.exit_code == 0, res.output
    res = invoke("report", tmp_path / "s.h5", "--out", tmp_path / "rep")
    assert res.exit_code == 0, res.output
    md = (tmp_path / "rep" / "report.md").read_text()
    assert "Skipped: this store has no Scenario C" in md
    assert not (tmp_path / "rep" / "friction.csv").exists()
