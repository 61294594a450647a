"""`sweep report A.h5 B.h5`: two scenes of one sweep in one report (issue P12): the tiny sweep
of tests/data/manipulation.yaml as the paper models it and with finger_collision.

Expected numbers are recomputed here from the stores with xarray and plain Python, not with
sweep.report's selection code.
"""
from __future__ import annotations

import itertools
from pathlib import Path

import numpy as np
import pytest
import xarray as xr
import yaml
from test_report import DATA, DESIGN, PNG_SIGNATURE, g, invoke, key, read_csv


def scene_config(tmp: Path, name: str, **changes) -> Path:
    raw = yaml.safe_load((DATA / "manipulation.yaml").read_text())
    raw["name"] = name
    for k, v in changes.items():
        raw[k] = {**raw.get(k, {}), **v}
    path = tmp / f"{name}.yaml"
    path.write_text(yaml.safe_dump(raw))
    return path


@pytest.fixture(scope="module")
def made(tmp_path_factory):
    root = tmp_path_factory.mktemp("compare")
    stores = []
    for name, effects in (("crossing", {}), ("collision", {"finger_collision": True})):
        cfg = scene_config(root, name, effects=effects)
        store = root / f"{name}.h5"
        res = invoke("run", cfg, "--out", store, "--no-progress")
        assert res.exit_code == 0, res.output
        stores.append(store)
    out = root / "rep"
    res = invoke("report", *stores, "--out", out)
    assert res.exit_code == 0, res.output
    dss = []
    for store in stores:
        with xr.open_dataset(store, engine="h5netcdf") as ds:
            dss.append(ds.load())
    return stores, out, dss, root


def test_every_file_is_written_and_readable(made):
    _, out, _, _ = made
    import matplotlib.image
    for name in ("best_designs.png", "caging_vs_tip.png", "manipulation.png",
                 "parameter_usage.png"):
        assert (out / name).read_bytes().startswith(PNG_SIGNATURE), name
        img = matplotlib.image.imread(out / name)
        assert img.shape[0] > 200 and img.shape[1] > 200
    for name in ("best_designs.csv", "caging_vs_tip.csv", "representative_designs.csv",
                 "manipulation.csv", "scenario_a_candidates.csv", "parameter_usage.csv"):
        assert read_csv(out / name), name


def first_best(ds, r, mu):
    """The first design in store order with the largest Lambda (9 significant digits)."""
    best, best_lam = None, -np.inf
    for d in itertools.product(*(list(ds[k].values) for k in DESIGN)):
        lam = ds["Lambda"].sel(dict(zip(DESIGN, d), r=r, mu=mu)).item()
        if key(lam) > key(best_lam):
            best, best_lam = d, lam
    return best, best_lam


def test_best_designs_of_both_scenes_and_what_changes(made):
    _, out, (ds1, ds2), _ = made
    rows = read_csv(out / "best_designs.csv")
    assert len(rows) == ds1.r.size * ds1.mu.size
    for row in rows:
        r, mu = float(row["r"]), float(row["mu"])
        (d1, lam1), (d2, lam2) = first_best(ds1, r, mu), first_best(ds2, r, mu)
        assert tuple(float(row[f"{k}_1"]) for k in DESIGN) == pytest.approx(d1)
        assert tuple(float(row[f"{k}_2"]) for k in DESIGN) == pytest.approx(d2)
        assert row["Lambda_1"] == g(lam1) and row["Lambda_2"] == g(lam2)
        same = (d1[0], d1[1], key(d1[3] / d1[2]), d1[4]) == (d2[0], d2[1], key(d2[3] / d2[2]),
                                                             d2[4])
        assert row["same_gripper"] == ("yes" if same else "no")
        assert row["Lambda_2_of_best_1"] == g(ds2["Lambda"].sel(dict(zip(DESIGN, d1), r=r,
                                                                     mu=mu)).item())
        assert row["Lambda_1_of_best_2"] == g(ds1["Lambda"].sel(dict(zip(DESIGN, d2), r=r,
                                                                     mu=mu)).item())
        assert int(row["n_caged_crossed_2"]) == 0  # fingers cannot cross under the effect


def test_caging_and_tip_counts_of_both_scenes_are_the_stores(made):
    _, out, (ds1, ds2), _ = made
    for row in read_csv(out / "caging_vs_tip.csv"):
        d = dict(zip(DESIGN, (float(row[k]) for k in DESIGN)), r=float(row["r"]),
                 mu=float(row["mu"]))
        for tag, ds in (("1", ds1), ("2", ds2)):
            assert int(row[f"n_caged_{tag}"]) == ds["n_caged"].sel(d).item()
            assert int(row[f"n_tip_prehension_{tag}"]) == ds["n_tip_prehension"].sel(d).item()


def test_manipulation_of_both_scenes_and_the_collision_rule(made):
    """Scenario B per part is each store's; under finger_collision it equals the paper
    scene's metric over uncrossed poses (model-notes D17)."""
    _, out, (ds1, ds2), _ = made
    for row in read_csv(out / "manipulation.csv"):
        sel = dict(r=float(row["r"]), mu=float(row["mu"]))
        assert row["b_1"] == g(ds1["manipulation_b"].sel(sel).item())
        assert row["b_2"] == g(ds2["manipulation_b"].sel(sel).item())
        assert row["b_uncrossed_1"] == g(ds1["manipulation_b_uncrossed"].sel(sel).item())
        assert ds2["manipulation_b"].sel(sel).item() == \
            ds1["manipulation_b_uncrossed"].sel(sel).item()
        assert float(row["b_1"]) > float(row["b_uncrossed_1"])  # crossed poses count there


def test_report_md_says_which_scene_to_trust_and_holds_the_tables(made):
    stores, out, _, _ = made
    text = (out / "report.md").read_text()
    assert "Trust scene 2 (collision: fingers cannot cross (finger_collision)) for hardware" \
        in text
    for name in ("best_designs.csv", "manipulation.csv", "parameter_usage.csv",
                 "representative_designs.csv"):
        for row in read_csv(out / name):
            assert "| " + " | ".join(row.values()) + " |" in text, (name, row)
    for store in stores:
        assert f"`{store}`" in text


def test_the_findings_against_the_paper_are_in_the_report(made):
    """Section 8 and against_paper.csv: one row per finding of sweep/report/paper.py, each
    scene's verdict one of the four; the tiny stores hold one part, so the findings about the
    paper's other parts are not testable, those about every part are (tests/test_report_paper.py
    changes a store and checks that each verdict follows)."""
    from sweep.report import paper

    _, out, _, _ = made
    rows = read_csv(out / "against_paper.csv")
    assert [row["key"] for row in rows] == [f.key for f in paper.FINDINGS]
    for row in rows:
        assert row["verdict_1"] in paper.VERDICTS and row["verdict_2"] in paper.VERDICTS
    by_key = {row["key"]: row for row in rows}
    assert by_key["palm_smallest"]["verdict_1"] == paper.NOT_TESTABLE      # one friction
    assert by_key["longest_links"]["verdict_1"] != paper.NOT_TESTABLE
    text = (out / "report.md").read_text()
    assert "## 8. Against the paper" in text
    for row in rows:
        assert f"| {row['verdict_1']} |" in text and row["claim"] in text


def test_rerun_is_a_no_op(made):
    stores, out, _, _ = made
    before = {p.name: p.stat().st_mtime_ns for p in out.iterdir()}
    res = invoke("report", *stores, "--out", out)
    assert res.exit_code == 0 and "nothing to do" in res.output
    assert {p.name: p.stat().st_mtime_ns for p in out.iterdir()} == before


@pytest.mark.parametrize("what, changes, word", [
    ("designs", {"designs": {"w": [0.0, 0.8]}}, "designs"),
    ("parts", {"parts": {"mu": [0.7]}}, "parts"),
    ("grid", {"grid": {"h": 0.1}}, "grids"),
])
def test_stores_of_other_designs_parts_or_grid_are_refused(made, tmp_path, what, changes, word):
    stores, _, _, _ = made
    cfg = scene_config(tmp_path, f"other-{what}", **changes)
    other = tmp_path / f"other-{what}.h5"
    assert invoke("run", cfg, "--out", other, "--no-progress").exit_code == 0
    res = invoke("report", stores[0], other, "--out", tmp_path / "rep")
    assert res.exit_code == 2, res.output
    lines = res.output.strip().splitlines()
    assert len(lines) == 1 and f"their {word} differ" in lines[0]
    assert not (tmp_path / "rep").exists()
    res = invoke("report", stores[0], stores[1], other, "--out", tmp_path / "rep")
    assert res.exit_code == 2 and "two to compare" in res.output


# The best designs' figure is rendered by a forked child (style.BackgroundPng). The test workers
# run threads (pytest-xdist), so there it renders in-process: a fresh single-threaded Python
# checks the child's bytes against the in-process rendering, and that a thread forbids the fork.
BACKGROUND_PNG = r"""
import threading
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from sweep.report.style import BackgroundPng, png
fig = Figure(figsize=(4, 3), dpi=80, layout="constrained")
FigureCanvasAgg(fig)
ax = fig.subplots()
ax.imshow([[0.0, 1.0], [2.0, 3.0]])
ax.set_title("a map")
forked = BackgroundPng(fig)
assert forked.pid is not None, "no child"
assert forked.result() == png(fig)
stop = threading.Event()
other = threading.Thread(target=stop.wait)
other.start()
here = BackgroundPng(fig)
stop.set()
other.join()
assert here.pid is None, "forked while another thread ran"
assert here.result() == png(fig)
print("ok")
"""


def test_the_forked_rendering_is_the_in_process_one():
    import subprocess
    import sys

    out = subprocess.run([sys.executable, "-c", BACKGROUND_PNG], capture_output=True, text=True,
                         cwd=Path(__file__).resolve().parents[1])
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == "ok"
