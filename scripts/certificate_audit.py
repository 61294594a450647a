#!/usr/bin/env python3
"""Does any design beat a refined store's answer beyond its error? Per part of the store: every
design of the best's chassis (l1, l2), and a random stratified sample of the other designs,
computed at the part's finest spacing with the store's config; prints each design whose caging
area exceeds the best's (the near-tie set's best for a near-tie) by more than the best's error
estimate, and the time it took (docs/accuracy.md, "The certificates audited").

    .venv/bin/python scripts/certificate_audit.py results/paper.h5

Equal-R designs (same l1, l2, w and r2/r1) give the same map: each class is computed once.
"""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from sweep.compute.batch import caging_areas  # noqa: E402
from sweep.config.parse import scene_from_frozen  # noqa: E402
from sweep.runs.refine import design_table, part_table, screened_matrix  # noqa: E402
from sweep.storage.refined import ROLE, STATUS, equal_r_classes  # noqa: E402
from sweep.storage.store import read_store  # noqa: E402


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("store", type=Path)
    ap.add_argument("--sample", type=int, default=48,
                    help="designs outside the best's chassis per part, stratified by screened "
                         "caging area (quarters of the ranking) [48]")
    ap.add_argument("--seed", type=int, default=1204)
    args = ap.parse_args(argv)
    view = read_store(args.store)
    if not view.refine:
        print(f"{args.store}: not refined", file=sys.stderr)
        return 2
    scene = scene_from_frozen(view.frozen)
    designs, parts = design_table(scene), part_table(scene)
    n_parts = parts.shape[0]
    per_part = lambda name: np.asarray(view.refine[name]).reshape(n_parts)  # noqa: E731
    per_design = lambda name: np.asarray(view.refine[name]).reshape(-1, n_parts)  # noqa: E731
    role, value, error = (per_design(k) for k in ("refine_role", "refined_caging_area",
                                                  "refined_error"))
    status, finest_h = per_part("refine_status"), per_part("refine_finest_h")
    screened = screened_matrix(scene, view.variables["caging_area"])
    reps = equal_r_classes(designs)
    rng = np.random.default_rng(args.seed)
    beaten, checked, t0 = 0, 0, time.perf_counter()
    print(f"# {args.store}: per part, the best's chassis and {args.sample} other designs at the "
          f"part's finest h")
    for p in range(n_parts):
        if status[p] == STATUS["not_refined"]:
            continue
        best = int(np.flatnonzero(role[:, p] == ROLE["best"])[0])
        chassis = np.flatnonzero((designs[:, 0] == designs[best, 0])
                                 & (designs[:, 1] == designs[best, 1]))
        others = np.setdiff1d(np.argsort(-screened[:, p], kind="stable"), chassis,
                              assume_unique=True)
        others = others[np.argsort(-screened[others, p], kind="stable")]
        quarters = np.array_split(others, 4)
        drawn = np.concatenate([rng.choice(q, min(args.sample // 4, q.size), replace=False)
                                for q in quarters if q.size])
        classes = np.unique(reps[np.concatenate([chassis, drawn])])
        h = float(finest_h[p])
        t = time.perf_counter()
        got = caging_areas(scene, designs, parts,
                           np.column_stack([np.full(classes.size, p), classes]), h)
        top, err = float(value[best, p]), float(error[best, p])
        over = classes[got > top + err]
        checked += classes.size
        ri, mi, _ = parts[p]
        tag = "certified" if status[p] == STATUS["certified"] else "near-tie"
        print(f"r={scene.values['r'][ri]:g} mu={scene.values['mu'][mi]:g}: {tag} best "
              f"{_text(designs[best])} {top:.5g} +- {err:.2g} at h = {h:g}; {classes.size} "
              f"classes, largest {got.max():.5g}; beaten by {over.size} "
              f"({time.perf_counter() - t:.1f} s)")
        for d in over:
            print(f"    BEATS: {_text(designs[d])} {got[classes == d][0]:.5g}")
        beaten += over.size
    print(f"# {checked} classes checked, {beaten} beat a best beyond its error, "
          f"{time.perf_counter() - t0:.0f} s")
    return 1 if beaten else 0


def _text(d) -> str:
    return " ".join(f"{k}={v:g}" for k, v in zip(("l1", "l2", "r1", "r2", "w"), d))


if __name__ == "__main__":
    sys.exit(main())
