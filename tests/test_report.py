"""`sweep report`: the paper's experiments from a store (the tiny sweep of
tests/data/manipulation.yaml).

Every expected number is recomputed here from the store with xarray and plain Python (loops over
the coordinates), not with sweep.report's own selection code.
"""
from __future__ import annotations

import csv
import itertools
import shutil
from pathlib import Path

import numpy as np
import pytest
import xarray as xr
import yaml
from click.testing import CliRunner

from sweep.cli import main as cli

DATA = Path(__file__).parent / "data"
DESIGN = ("l1", "l2", "r1", "r2", "w")
PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"


def invoke(*args):
    return CliRunner().invoke(cli, [str(a) for a in args])


def g(v) -> str:
    """How a number appears in the report's CSV and markdown (6 significant digits)."""
    return f"{float(v):.6g}"


@pytest.fixture(scope="module")
def made(tmp_path_factory, manipulation_store):
    """The store of tests/data/manipulation.yaml (the session's, conftest.py; a copy, written
    beside here) and its report."""
    root = tmp_path_factory.mktemp("report")
    store = Path(shutil.copy2(manipulation_store, root / "tiny.h5"))
    out = root / "rep"
    res = invoke("report", store, "--out", out)
    assert res.exit_code == 0, res.output
    with xr.open_dataset(store, engine="h5netcdf") as ds:
        ds = ds.load()
    return store, out, ds


def read_csv(path: Path) -> list[dict]:
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def designs_in_store_order(ds):
    """Every (l1, l2, r1, r2, w) of the store, last dimension fastest."""
    return list(itertools.product(*(list(ds[d].values) for d in DESIGN)))


def key(v: float) -> float:
    """Lambda as compared for ties: 9 significant digits (equal-R designs differ in last bits)."""
    return float(f"{v:.9g}")


def value(ds, name, design, r, mu):
    return ds[name].sel(dict(zip(DESIGN, design), r=r, mu=mu)).item()


def test_every_file_is_written_and_readable(made):
    _, out, _ = made
    for name in ("best_caging.png", "caging_vs_tip.png", "manipulation.png",
                 "parameter_usage.png"):
        data = (out / name).read_bytes()
        assert data.startswith(PNG_SIGNATURE), name
        import matplotlib.image
        img = matplotlib.image.imread(out / name)
        assert img.shape[0] > 200 and img.shape[1] > 200
    for name in ("best_caging.csv", "caging_vs_tip.csv", "representative_designs.csv",
                 "manipulation.csv", "scenario_a_candidates.csv", "parameter_usage.csv"):
        rows = read_csv(out / name)
        assert rows, name
    assert not [p for p in out.iterdir() if ".tmp." in p.name or p.name.endswith(".lock")]


def test_best_caging_table_is_the_first_largest_lambda(made):
    _, out, ds = made
    rows = read_csv(out / "best_caging.csv")
    assert len(rows) == ds.r.size * ds.mu.size
    for row in rows:
        r, mu = float(row["r"]), float(row["mu"])
        best, best_lam, ties = None, -np.inf, 0
        for d in designs_in_store_order(ds):
            lam = value(ds, "Lambda", d, r, mu)
            if key(lam) > key(best_lam):
                best, best_lam, ties = d, lam, 1
            elif key(lam) == key(best_lam):
                ties += 1
        assert tuple(float(row[k]) for k in DESIGN) == pytest.approx(best)
        assert row["Lambda"] == g(best_lam)
        assert row["caging_area"] == g(value(ds, "caging_area", best, r, mu))
        assert int(row["n_caged"]) == value(ds, "n_caged", best, r, mu)
        assert int(row["n_tip_prehension"]) == value(ds, "n_tip_prehension", best, r, mu)
        assert int(row["n_caged_crossed"]) == value(ds, "n_caged_crossed", best, r, mu)
        assert int(row["n_tied"]) == ties


def test_caging_and_tip_counts_are_the_stores(made):
    _, out, ds = made
    rows = read_csv(out / "caging_vs_tip.csv")
    # smallest and largest part at the highest friction (one part in the tiny sweep)
    parts = {(float(ds.r.min()), float(ds.mu.max())), (float(ds.r.max()), float(ds.mu.max()))}
    assert {(float(r["r"]), float(r["mu"])) for r in rows} == parts
    assert len(rows) == len(parts) * len(designs_in_store_order(ds))
    for row in rows:
        d = tuple(float(row[k]) for k in DESIGN)
        r, mu = float(row["r"]), float(row["mu"])
        assert int(row["n_caged"]) == value(ds, "n_caged", d, r, mu)
        assert int(row["n_tip_prehension"]) == value(ds, "n_tip_prehension", d, r, mu)


def test_representative_designs_follow_their_rules(made):
    _, out, ds = made
    reps = {r["kind"]: r for r in read_csv(out / "representative_designs.csv")}
    rows = read_csv(out / "caging_vs_tip.csv")
    caged = [int(r["n_caged"]) for r in rows]
    tip = [int(r["n_tip_prehension"]) for r in rows]
    c = reps["caging focused"]
    assert int(c["n_caged"]) == max(caged)
    assert int(c["n_tip_prehension"]) == min(t for n, t in zip(caged, tip) if n == max(caged))
    t = reps["tip focused"]
    assert int(t["n_tip_prehension"]) == max(tip)
    assert int(t["n_caged"]) == min(n for n, x in zip(caged, tip) if x == max(tip))
    balance = [min(n / max(caged), x / max(tip)) for n, x in zip(caged, tip)]
    m = reps["compromise"]
    assert min(int(m["n_caged"]) / max(caged),
               int(m["n_tip_prehension"]) / max(tip)) == pytest.approx(max(balance))


def test_best_scenario_a_candidate_rule(made):
    _, out, ds = made
    k = int(ds.attrs["manipulation_scenario_a_top_k"])
    designs = designs_in_store_order(ds)
    expected = set()
    for r, mu in itertools.product(ds.r.values, ds.mu.values):
        lams = [value(ds, "Lambda", d, r, mu) for d in designs]
        order = sorted(range(len(designs)), key=lambda i: (-key(lams[i]), i))
        expected |= {designs[i][:4] for i in order[:k]}
    rows = read_csv(out / "scenario_a_candidates.csv")
    got = {tuple(float(r[c]) for c in ("l1", "l2", "r1", "r2")) for r in rows}
    assert got == {tuple(map(float, e)) for e in expected}
    totals = {}
    for cand in expected:
        sel = dict(zip(("l1", "l2", "r1", "r2"), cand))
        totals[cand] = float(ds["manipulation_a"].sel(sel).sum())
    best_rows = [r for r in rows if r["best"] == "yes"]
    assert len(best_rows) == 1
    best = tuple(float(best_rows[0][c]) for c in ("l1", "l2", "r1", "r2"))
    assert key(totals[best]) == max(key(t) for t in totals.values())
    assert best_rows[0]["a_sum"] == g(totals[best])

    # A per part is the best candidate's, B the store's; the larger wins.
    sel = dict(zip(("l1", "l2", "r1", "r2"), best))
    for row in read_csv(out / "manipulation.csv"):
        r, mu = float(row["r"]), float(row["mu"])
        a = float(ds["manipulation_a"].sel(dict(sel, r=r, mu=mu)))
        b = float(ds["manipulation_b"].sel(r=r, mu=mu))
        assert row["a"] == g(a) and row["b"] == g(b)
        assert row["b_uncrossed"] == g(float(ds["manipulation_b_uncrossed"].sel(r=r, mu=mu)))
        assert row["winner"] == ("A" if a > b else "B" if b > a else "tie")


def test_parameter_usage_table_is_the_stores(made):
    _, out, ds = made
    for row in read_csv(out / "parameter_usage.csv"):
        for p in ("w", "l1", "l2", "r1", "r2"):
            v = float(ds["parameter_usage"].sel(r=float(row["r"]), mu=float(row["mu"]),
                                                parameter=p))
            assert row[p] == ("NaN" if np.isnan(v) else g(v))


def test_report_md_holds_the_numbers(made):
    store, out, ds = made
    text = (out / "report.md").read_text()
    for name in ("best_caging.csv", "manipulation.csv", "parameter_usage.csv",
                 "representative_designs.csv"):
        for row in read_csv(out / name):
            line = "| " + " | ".join(row.values()) + " |"
            assert line in text, (name, line)
    best = next(r for r in read_csv(out / "scenario_a_candidates.csv") if r["best"] == "yes")
    assert f"metric summed over parts {best['a_sum']}" in text
    assert f"compute {g(ds.attrs['compute_seconds'])} s" in text
    assert f"Scenario A top-k = {int(ds.attrs['manipulation_scenario_a_top_k'])}" in text
    assert "Effects on: friction" in text


def test_rerun_is_a_no_op_and_another_stores_report_needs_overwrite(made):
    store, out, _ = made
    before = {p.name: p.stat().st_mtime_ns for p in out.iterdir()}
    res = invoke("report", store, "--out", out)
    assert res.exit_code == 0 and "nothing to do" in res.output
    assert {p.name: p.stat().st_mtime_ns for p in out.iterdir()} == before
    other = store.with_name("other.h5")
    other.write_bytes(store.read_bytes())
    res = invoke("report", other, "--out", out)
    assert res.exit_code == 2 and "--overwrite" in res.output
    assert {p.name: p.stat().st_mtime_ns for p in out.iterdir()} == before


def test_user_errors_are_one_line_and_write_nothing(made, tmp_path):
    store, _, _ = made
    res = invoke("report", store, "--out", tmp_path / "a", "--top-k", 0)
    assert res.exit_code == 2 and "--top-k" in res.output
    assert not (tmp_path / "a").exists()
    bogus = tmp_path / "bogus.h5"
    bogus.write_bytes(b"not hdf5")
    res = invoke("report", bogus, "--out", tmp_path / "b")
    assert res.exit_code == 2 and len(res.output.strip().splitlines()) == 1
    assert not (tmp_path / "b").exists()


def test_store_without_manipulation_gets_the_caging_parts(tmp_path):
    raw = yaml.safe_load((DATA / "manipulation.yaml").read_text())
    raw.pop("outputs")
    raw["designs"]["l1"] = [1.4]          # 8 designs: a fast sweep
    cfg = tmp_path / "caging.yaml"
    cfg.write_text(yaml.safe_dump(raw))
    store = tmp_path / "caging.h5"
    assert invoke("run", cfg, "--out", store, "--no-progress").exit_code == 0
    res = invoke("report", store, "--out", tmp_path / "x", "--top-k", 3)
    assert res.exit_code == 2 and "outputs: {manipulation: true}" in res.output
    assert not (tmp_path / "x").exists()
    res = invoke("report", store, "--out", tmp_path / "rep")
    assert res.exit_code == 0, res.output
    names = {p.name for p in (tmp_path / "rep").iterdir()}
    assert {"best_caging.png", "caging_vs_tip.png", "report.md", "best_caging.csv"} <= names
    assert not names & {"manipulation.png", "parameter_usage.png", "manipulation.csv"}
    assert "outputs: {manipulation: true}" in (tmp_path / "rep" / "report.md").read_text()
