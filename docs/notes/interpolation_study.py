"""Interpolation in energy map space, tested: hold out grid designs, predict each one's map
from its grid neighbours' maps, and score the prediction against the true map
(docs/optimisation.md, "The paper's suggestion tested: interpolation in energy map space").

    python docs/notes/interpolation_study.py configs/paper.yaml --per-part 75 \\
        --part 0.4,0.4 --part 0.8,1.0 --part 1.2,0.1 --part 1.6,0.7 --out study.csv

Per part (r, mu) of the config, `--per-part` designs drawn at random (`--seed`) from the grid
designs with a grid neighbour on both sides in every varied parameter (`--vary`, default all
five). For each held-out design x:

- its 2^k corner designs (one grid step either side of x in each varied parameter) and x itself
  are computed with `compute_map` (the config's command, limits, accuracy and effects) on one
  common grid per part: the whole reach of the config's largest design (maps of different l1,
  l2 and w have different whole-reach grids; on the common grid every point is computed by the
  model, so nothing is extrapolated and the caging area is the whole-reach one, which the
  script checks);
- the prediction: the corners' fields blended with multilinear weights
  (`interpolation.interpolate_fields`: energy averaged, classes and the caged
  flag by weighted majority);
- the caging answer of prediction and truth with the pipeline's trajectories on the fields
  alone (`caging_of_fields`, sliding off: a prediction has no model between its points to slide
  on); the truth's pipeline answer (sliding) is reported beside it;
- class agreement over P_j of either map: the fraction of points where the two maps give the
  same end (caged, tip prehension, ejection, stalled; or the same class outside P_j), and the
  fraction with the same caged-or-not end;
- the discretisation error of the true map: |caging area at h - at h/2| (the sweep's path,
  `MapScores`), the error estimate the refinement and `sweep optimize` use;
- per part, whether the predictions rank the held-out designs as the truth does (Spearman's
  rank correlation, the true top 5 among the predicted top 5, the predicted rank of the true
  best): what proposing candidates needs.

Writes one row per held-out design (CSV, `--out`, atomically) and prints the summary table.
"""
from __future__ import annotations

import argparse
import itertools
import time
from pathlib import Path

import numpy as np

from interpolation import (FIELDS, caging_of_fields, corner_offsets,
                                         corner_weights, ends_caged, interpolate_fields)
from sweep.compute.maps import compute_map
from sweep.compute.threads import numba_threads
from sweep.compute.warm import ensure_compiled
from sweep.config.parse import load_scene
from sweep.config.scene import DESIGN_KEYS
from sweep.files import text_bytes, write_bytes_atomic
from sweep.grid import reach
from sweep.model import REACHED, Design, Grid, Part
from sweep.runs.evaluations import MapScores

COLUMNS = ("r", "mu", "l1", "l2", "r1", "r2", "w", "area_true", "area_true_grid8",
           "area_pred", "area_h2", "error", "error_vs_pipeline", "discretisation",
           "agreement", "caged_agreement", "union_points", "seconds")


def interior_designs(scene, vary: tuple) -> list:
    """Every grid design with a neighbour on both sides in each varied parameter, as index
    tuples into the config's values."""
    axes = []
    for k in DESIGN_KEYS:
        n = len(scene.values[k])
        axes.append(range(1, n - 1) if k in vary else range(n))
    return list(itertools.product(*axes))


def common_grid(scene, r: float, mu: float) -> Grid:
    """The whole reach of the config's largest design for the part: one grid for every map."""
    big = Design(*(float(max(scene.values[k])) for k in DESIGN_KEYS))
    X, Y = reach(big, Part(r, mu))
    return Grid(h=scene.h, xlim=(-X, X), ylim=(r, Y))


def fields_of(scene, design, r, mu, grid):
    m = compute_map(Design(*design), Part(r, mu), scene.commands[0], grid, scene.limits,
                    scene.accuracy, scene.effects)
    return m, {k: m.fields[k] for k in FIELDS}


def end_codes(fields, end_state) -> np.ndarray:
    """Per point: the end of its trajectory in P_j, else 100 + its class."""
    pc = np.asarray(fields["point_class"])
    return np.where(pc == REACHED, np.asarray(end_state, np.int64), 100 + pc.astype(np.int64))


def study_design(scene, idx, vary, r, mu, grid, scores) -> dict:
    """One held-out design: prediction, truth, agreement, errors (module docstring)."""
    t0 = time.perf_counter()
    values = {k: scene.values[k] for k in DESIGN_KEYS}
    x = np.array([values[k][i] for k, i in zip(DESIGN_KEYS, idx)], float)
    varied = [DESIGN_KEYS.index(k) for k in DESIGN_KEYS if k in vary]
    lower, upper = x.copy(), x.copy()
    for p in varied:
        lower[p] = values[DESIGN_KEYS[p]][idx[p] - 1]
        upper[p] = values[DESIGN_KEYS[p]][idx[p] + 1]
    corners = []
    for off in corner_offsets(len(varied)):
        d = x.copy()
        for p, o in zip(varied, off):
            d[p] = upper[p] if o else lower[p]
        corners.append(fields_of(scene, d, r, mu, grid)[1])
    weights = corner_weights(x[varied], lower[varied], upper[varied])
    pred = interpolate_fields(corners, weights)
    true_map, true = fields_of(scene, x, r, mu, grid)
    design, part = Design(*x), Part(r, mu)
    settings = (scene.commands[0], scene.limits, scene.accuracy, scene.effects)
    a_true = float(true_map.attrs["caging_area"])                   # the pipeline (sliding)
    a_whole = scores.area(x, r, mu, scene.h)
    if not np.isclose(a_whole, a_true, rtol=1e-9, atol=1e-12):
        raise SystemExit(f"common grid and whole reach differ for {x.tolist()} r={r} mu={mu}: "
                         f"{a_true} against {a_whole}")
    a8, es_true, _ = caging_of_fields(true, true_map.x, true_map.y, scene.h, design, part,
                                      *settings, sliding=False)
    ap, es_pred, _ = caging_of_fields(pred, true_map.x, true_map.y, scene.h, design, part,
                                      *settings, sliding=False)
    union = (true["point_class"] == REACHED) | (pred["point_class"] == REACHED)
    n = int(union.sum())
    same = end_codes(true, es_true) == end_codes(pred, es_pred)
    same_caged = (ends_caged(es_true, true["point_class"])
                  == ends_caged(es_pred, pred["point_class"]))
    a_h2 = scores.area(x, r, mu, scene.h / 2)
    return dict(r=r, mu=mu, **dict(zip(DESIGN_KEYS, x.tolist())), area_true=a_true,
                area_true_grid8=a8, area_pred=ap, area_h2=a_h2, error=abs(ap - a8),
                error_vs_pipeline=abs(ap - a_true), discretisation=abs(a_true - a_h2),
                agreement=float(same[union].mean()) if n else 1.0,
                caged_agreement=float(same_caged[union].mean()) if n else 1.0,
                union_points=n, seconds=time.perf_counter() - t0)


def summary(rows: list) -> dict:
    """The study's numbers over `rows` (docs/optimisation.md's table)."""
    a = lambda k: np.array([row[k] for row in rows], float)  # noqa: E731
    err, disc = a("error"), a("discretisation")
    return dict(n=len(rows), caging=int(np.sum((a("area_true") > 0) | (a("area_pred") > 0))),
                agreement_median=float(np.median(a("agreement"))),
                agreement_min=float(np.min(a("agreement"))),
                caged_agreement_median=float(np.median(a("caged_agreement"))),
                caged_agreement_min=float(np.min(a("caged_agreement"))),
                error_median=float(np.median(err)), error_p90=float(np.percentile(err, 90)),
                error_vs_pipeline_median=float(np.median(a("error_vs_pipeline"))),
                discretisation_median=float(np.median(disc)),
                exceeds=float(np.mean(err > disc)),
                relative_error_median=float(np.median(
                    [e / t for e, t in zip(err, a("area_true_grid8")) if t > 0] or [np.nan])),
                **ranking(a("area_true"), a("area_pred")))


def ranking(true: np.ndarray, pred: np.ndarray, top: int = 5) -> dict:
    """Would the prediction propose the right candidates? Spearman's rank correlation of
    predicted and true caging areas, how many of the true `top` the predicted `top` hold, and
    the predicted rank of the true best (1: the prediction ranks it first)."""
    from scipy.stats import spearmanr

    order = np.argsort(-pred, kind="stable")
    rho = spearmanr(true, pred).statistic if np.ptp(true) > 0 and np.ptp(pred) > 0 else np.nan
    return dict(rank_correlation=float(rho),
                top_overlap=len(set(order[:top]) & set(np.argsort(-true, kind="stable")[:top])),
                best_rank=int(np.flatnonzero(order == int(np.argmax(true)))[0]) + 1)


def table_line(label: str, s: dict, pooled: bool = False) -> str:
    """A row of the summary table; a row pooling parts has no ranking (areas of different
    parts are not one ranking)."""
    rank = ("- | - | -" if pooled else f"{s['rank_correlation']:.2f} | {s['top_overlap']} of 5 "
            f"| {s['best_rank']}")
    return (f"| {label} | {s['n']} ({s['caging']} caging) | {s['agreement_median']:.3f} / "
            f"{s['agreement_min']:.3f} | {s['caged_agreement_median']:.3f} / "
            f"{s['caged_agreement_min']:.3f} | {s['error_median']:.3g} / {s['error_p90']:.3g} "
            f"| {s['relative_error_median']:.1%} | {s['discretisation_median']:.3g} | "
            f"{s['exceeds']:.0%} | {rank} |")


HEADER = ("| parts | n held out (caging) | class agreement median / min | caged-end agreement "
          "median / min | caging-area error median / p90 | relative error median (caging) | "
          "discretisation error median | error > discretisation | rank correlation | "
          "true top 5 in predicted top 5 | predicted rank of the true best |\n"
          "|---|---|---|---|---|---|---|---|---|---|---|")


def csv_text(rows: list) -> str:
    lines = [",".join(COLUMNS)]
    for row in rows:
        lines.append(",".join(f"{row[c]:.10g}" if isinstance(row[c], float) else str(row[c])
                              for c in COLUMNS))
    return "\n".join(lines) + "\n"


def part_value(text: str) -> tuple:
    r, mu = (float(v) for v in text.split(","))
    return r, mu


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                 formatter_class=argparse.RawDescriptionHelpFormatter,
                                 epilog=__doc__.split("\n\n", 1)[1])
    ap.add_argument("config", type=Path, help="the sweep's config (its design grid and settings)")
    ap.add_argument("--part", type=part_value, action="append", metavar="R,MU",
                    help="a part of the config (repeat; default: the smallest and the largest "
                         "r at the config's second mu)")
    ap.add_argument("--per-part", type=int, default=75, help="held-out designs per part")
    ap.add_argument("--vary", default=",".join(DESIGN_KEYS),
                    help="the parameters interpolated over (the others: the design's own)")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--threads", type=int, default=1)
    ap.add_argument("--out", type=Path, help="CSV of one row per held-out design")
    args = ap.parse_args(argv)
    scene = load_scene(args.config)
    vary = tuple(k.strip() for k in args.vary.split(",") if k.strip())
    if not vary or not set(vary) <= set(DESIGN_KEYS):
        ap.error(f"--vary takes names among {', '.join(DESIGN_KEYS)}")
    mus = scene.values["mu"]
    parts = args.part or [(min(scene.values["r"]), mus[min(1, len(mus) - 1)]),
                          (max(scene.values["r"]), mus[min(1, len(mus) - 1)])]
    for r, mu in parts:
        if r not in scene.values["r"] or mu not in mus:
            ap.error(f"part {r:g},{mu:g} is not a part of {args.config}")
    pool = interior_designs(scene, vary)
    if not pool:
        ap.error("no design of the config has neighbours on both sides in every varied "
                 "parameter")
    ensure_compiled()
    scores = MapScores(scene)
    rng = np.random.default_rng(args.seed)
    rows, started = [], time.perf_counter()
    with numba_threads(args.threads):
        for r, mu in parts:
            grid = common_grid(scene, r, mu)
            pick = rng.choice(len(pool), size=min(args.per_part, len(pool)), replace=False)
            part_rows = []
            for n, k in enumerate(sorted(pick)):
                part_rows.append(study_design(scene, pool[k], vary, r, mu, grid, scores))
                if (n + 1) % 25 == 0:
                    print(f"  r={r:g} mu={mu:g}: {n + 1}/{len(pick)} "
                          f"({time.perf_counter() - started:.0f} s)", flush=True)
            rows += part_rows
    if args.out:
        write_bytes_atomic(args.out, text_bytes(csv_text(rows)))
    print(f"\n{args.config}: h = {scene.h:g}, trajectories {scene.accuracy.trajectory} (the "
          f"truth's pipeline answer), varied {', '.join(vary)} (2^{len(vary)} corners), "
          f"{len(pool)} interior designs per part, seed {args.seed}, "
          f"{time.perf_counter() - started:.0f} s\n")
    print(HEADER)
    for r, mu in parts:
        print(table_line(f"r {r:g}, mu {mu:g}",
                         summary([x for x in rows if x["r"] == r and x["mu"] == mu])))
    print(table_line("all", summary(rows), pooled=True))
    caging = [x for x in rows if x["area_true"] > 0 or x["area_pred"] > 0]
    if caging:
        print(table_line("all, caging designs only", summary(caging), pooled=True))
    s = summary(rows)
    print(f"\nagainst the truth's pipeline answer (sliding): error median "
          f"{s['error_vs_pipeline_median']:.3g}")


if __name__ == "__main__":
    main()
