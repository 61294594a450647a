"""Brute force against `sweep optimize`: every design of a grid FACTOR times finer than the
store's in every parameter (the same box, parts and h), to check that none beats the
optimiser's x* beyond the error estimate (docs/optimisation.md, "Checked by brute force").

    .venv/bin/sweep run configs/small.yaml --out /tmp/small.h5
    .venv/bin/sweep optimize /tmp/small.h5 --out /tmp/small.optimize.h5
    .venv/bin/python scripts/optimize_bruteforce.py /tmp/small.h5 /tmp/small.optimize.h5

Per part of the results file: every fine-grid design's caging area at the search spacing h (the
store's config, the sweep's path; equal-R designs computed once), the best of them B, B and x*
at h/2 (their error estimates: the change from h to h/2), and the verdict: B beats x* beyond
the error when value(B) - value(x*) > error(B) + error(x*) at h/2 (the optimiser's and the
refinement's rule), and how many fine-grid designs score above x* at h at all.
"""
from __future__ import annotations

import argparse
import itertools
import time
from pathlib import Path

import numpy as np

from sweep.compute.threads import numba_threads
from sweep.config.parse import scene_from_frozen
from sweep.runs.evaluations import MapScores
from sweep.storage.optimized import read_optimization
from sweep.storage.store import read_store


def fine_grid(lower, upper, coarse_steps, factor: int) -> np.ndarray:
    """Every design of the grid `factor` times finer than the store's: (n, 5)."""
    axes = []
    for lo, hi, step in zip(lower, upper, coarse_steps):
        n = int(round((hi - lo) / (step / factor))) if hi > lo else 0
        axes.append(np.round(np.linspace(lo, hi, n + 1), 12))
    return np.array(list(itertools.product(*axes)))


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("store", type=Path)
    ap.add_argument("results", type=Path, help="the results file of `sweep optimize STORE`")
    ap.add_argument("--factor", type=int, default=4)
    ap.add_argument("--threads", type=int, default=1)
    args = ap.parse_args(argv)
    scene = scene_from_frozen(read_store(args.store).frozen)
    res = read_optimization(args.results)
    v, a = res["vars"], res["attrs"]
    lower, upper = np.asarray(a["box_lower"], float), np.asarray(a["box_upper"], float)
    steps = [float(np.min(np.diff(scene.values[k]))) for k in ("l1", "l2", "r1", "r2", "w")]
    designs = fine_grid(lower, upper, steps, args.factor)
    h = scene.h
    scores = MapScores(scene)
    print(f"{designs.shape[0]:,} designs ({args.factor}x finer than the store's grid in every "
          f"parameter) per part at h = {h:g}")
    with numba_threads(args.threads):
        for p in range(len(v["r"])):
            r, mu = float(v["r"][p]), float(v["mu"][p])
            t = time.perf_counter()
            values = np.array([scores.area(d, r, mu, h) for d in designs])
            seconds = time.perf_counter() - t
            b = int(np.argmax(values))
            x = v["x_star"][p]
            x_h, x_h2 = scores.area(x, r, mu, h), scores.area(x, r, mu, h / 2)
            b_h, b_h2 = values[b], scores.area(designs[b], r, mu, h / 2)
            ex, eb = abs(x_h2 - x_h), abs(b_h2 - b_h)
            d, u = b_h2 - x_h2, ex + eb
            above = int(np.sum(values > x_h))
            verdict = ("B BEATS x* beyond the error" if d > u else
                       "no fine-grid design beats x* beyond the error")
            print(f"part r={r:g} mu={mu:g}: x* {np.round(x, 4).tolist()} {x_h:.4g} at h, "
                  f"{x_h2:.4g} +- {ex:.2g} at h/2; fine-grid best B {designs[b].tolist()} "
                  f"{b_h:.4g} at h, {b_h2:.4g} +- {eb:.2g} at h/2; d = {d:.3g} +- {u:.2g}: "
                  f"{verdict}; {above} fine-grid designs above x* at h; {seconds:.1f} s")


if __name__ == "__main__":
    main()
