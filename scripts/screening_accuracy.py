#!/usr/bin/env python3
"""How far the screening's caging areas are from converged: a stratified random sample of a
store's design-part pairs, each map computed at the store's spacing h and at a reference spacing
(default h = 0.00625) with the store's own config (effects, accuracy, trajectory method), and the
share within 5 % and 15 % (docs/accuracy.md, "The screening against converged").

    .venv/bin/python scripts/screening_accuracy.py results/paper.h5 --out results/accuracy-paper.csv

The sample is the script's, not the user's: per part, 3 designs from the top 1 % by screened
caging area, 4 from the rest of the top 10 % and the others from the rest, drawn with --seed.
A pair counts as within when its relative error is at most the bound, or when its converged
caging area is below 1 % of the part's best (in the sample) and its absolute error is below 1 % of
that best. The tip-prehension area (the caging-versus-tip experiment's other half) is reported
beside it the same way.
"""
from __future__ import annotations

import argparse
import csv
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from sweep.compute.maps import compute_map  # noqa: E402
from sweep.config.parse import scene_from_frozen  # noqa: E402
from sweep.model import Design, Grid, Part  # noqa: E402
from sweep.report.data import within_error  # noqa: E402
from sweep.runs.refine import design_table, part_table, screened_matrix  # noqa: E402
from sweep.storage.store import read_store  # noqa: E402

#: (share of the ranking the stratum covers, designs drawn from it) per part; the last takes the
#: rest of the pairs asked for.
STRATA = ((0.01, 3), (0.10, 4))


def sample(screened: np.ndarray, per_part: int, seed: int) -> list[tuple[int, int]]:
    """(part, design) pairs: per part the strata of STRATA by screened caging area, then the
    rest of the ranking for the remaining pairs; one generator, seeded, parts in store order."""
    rng = np.random.default_rng(seed)
    pairs = []
    for p in range(screened.shape[1]):
        order = np.argsort(-screened[:, p], kind="stable")
        n, lo, picked = order.size, 0, []
        for share, k in STRATA:
            hi = max(lo + k, int(round(share * n)))
            picked += rng.choice(order[lo:hi], k, replace=False).tolist()
            lo = hi
        picked += rng.choice(order[lo:], per_part - len(picked), replace=False).tolist()
        pairs += [(p, int(d)) for d in picked]
    return pairs


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("store", type=Path)
    ap.add_argument("--per-part", type=int, default=13, help="pairs per part [13: 208 in all]")
    ap.add_argument("--seed", type=int, default=20261204)
    ap.add_argument("--reference-h", type=float, default=0.00625)
    ap.add_argument("--out", type=Path, help="CSV of every pair")
    args = ap.parse_args(argv)
    view = read_store(args.store)
    scene = scene_from_frozen(view.frozen)
    designs, parts = design_table(scene), part_table(scene)
    screened = screened_matrix(scene, view.variables["caging_area"])
    pairs = sample(screened, args.per_part, args.seed)
    rows, t0 = [], time.perf_counter()
    for n, (p, d) in enumerate(pairs):
        ri, mi, ci = parts[p]
        design = Design(*map(float, designs[d]))
        part = Part(r=float(scene.values["r"][ri]), mu=float(scene.values["mu"][mi]))
        got = {}
        for name, h in (("coarse", scene.h), ("fine", args.reference_h)):
            m = compute_map(design, part, scene.commands[ci], Grid(h=h), scene.limits,
                            scene.accuracy, scene.effects)
            got[name] = (float(m.attrs["caging_area"]), float(m.attrs["tip_prehension_area"]))
        rows.append(dict(part=p, r=part.r, mu=part.mu, **dict(zip(("l1", "l2", "r1", "r2", "w"),
                                                                    designs[d].tolist())),
                         caging_coarse=got["coarse"][0], caging_fine=got["fine"][0],
                         tip_coarse=got["coarse"][1], tip_fine=got["fine"][1]))
        if (n + 1) % 20 == 0:
            print(f"{n + 1}/{len(pairs)} pairs, {time.perf_counter() - t0:.0f} s",
                  file=sys.stderr)
    print(f"# {args.store}: {len(rows)} pairs ({args.per_part} per part, seed {args.seed}), "
          f"h = {scene.h:g} against h = {args.reference_h:g}, "
          f"{time.perf_counter() - t0:.0f} s")
    for what in ("caging", "tip"):
        best = {}
        for r in rows:
            best[r["part"]] = max(best.get(r["part"], 0.0), r[f"{what}_fine"])
        ok5 = sum(bool(within_error(r[f"{what}_coarse"], r[f"{what}_fine"], best[r["part"]],
                                    0.05))
                  for r in rows)
        ok15 = sum(bool(within_error(r[f"{what}_coarse"], r[f"{what}_fine"], best[r["part"]],
                                     0.15))
                   for r in rows)
        print(f"{what} area: within 5 %: {ok5}/{len(rows)} ({ok5 / len(rows):.1%}); "
              f"within 15 %: {ok15}/{len(rows)} ({ok15 / len(rows):.1%})")
        worst = sorted(rows, key=lambda r: -abs(r[f"{what}_coarse"] - r[f"{what}_fine"])
                       / max(r[f"{what}_fine"], 0.01 * best[r["part"]], 1e-300))[:5]
        for r in worst:
            print(f"  r={r['r']:g} mu={r['mu']:g} l1={r['l1']:g} l2={r['l2']:g} "
                  f"r1={r['r1']:g} r2={r['r2']:g} w={r['w']:g}: "
                  f"{r[f'{what}_coarse']:.4g} against {r[f'{what}_fine']:.4g}")
    if args.out:
        with open(args.out, "w", newline="") as f:
            w = csv.DictWriter(f, fieldnames=list(rows[0]))
            w.writeheader()
            w.writerows(rows)
    return 0


if __name__ == "__main__":
    sys.exit(main())
