"""Measure what the refinement stage's contender bound must be, and what each bound costs
(docs/sweeps.md, "Refinement"; model-notes D18). Rerun it whenever the trajectory method or the
screening spacing changes: the figures hold for the method they were measured with.

    .venv/bin/sweep run configs/paper-caging.yaml --out results/paper-caging.h5
    .venv/bin/python scripts/refine_bound.py results/paper-caging.h5 --top 60 --levels 3

Per part of a screened store (r, mu, command), the `--top` best equal-R classes by screened
caging area are recomputed at h/2, ..., h/2**levels (the store's own accuracy settings, so its
trajectory method). Printed, per part and level: the best class among them, its rank in the
screening and its *screening gap*, (best screened - its screened) / best screened. A contender
bound of at least the largest gap would have kept every part's fine best design among the
contenders; the gaps of the last level are the ones that matter. Also printed: the best's value
per level (does it converge?), the lead over the runner-up, and, for each candidate bound, what
the refinement stage (sweep.runs.refine's rule, min_contenders as given) would conclude and how many
grid points it would compute, relative to the screening's.

The recomputed values are cached in `--work` (one file per level), so a rerun with more levels
or another bound list only computes what is new.
"""
from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

from sweep.compute.batch import caging_areas
from sweep.runs.refine import (
    design_table, equal_r_classes, part_table, screened_matrix, select_contenders,
    separate,
)
from sweep.config.scene import RefineSettings, grid_points
from sweep.config.parse import scene_from_frozen
from sweep.storage.store import read_store


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("store", type=Path)
    ap.add_argument("--top", type=int, default=60, help="classes per part recomputed")
    ap.add_argument("--levels", type=int, default=3)
    ap.add_argument("--bounds", default="0.02,0.05,0.1,0.15,0.2,0.3")
    ap.add_argument("--min-contenders", type=int, default=RefineSettings().min_contenders)
    ap.add_argument("--work", type=Path, default=None,
                    help="cache directory [default: STORE.bound/]")
    args = ap.parse_args(argv)

    view = read_store(args.store)
    scene = scene_from_frozen(view.frozen)
    designs, parts = design_table(scene), part_table(scene)
    reps = equal_r_classes(designs)
    classes = np.unique(reps)
    screened = screened_matrix(scene, view.variables["caging_area"])
    n_parts = parts.shape[0]
    top = {p: classes[np.argsort(-screened[classes, p], kind="stable")[:args.top]]
           for p in range(n_parts)}
    work = args.work or args.store.with_name(args.store.name + ".bound")
    work.mkdir(parents=True, exist_ok=True)
    keys = np.array([(p, d) for p in range(n_parts) for d in top[p]], dtype=np.int64)
    values = {0: screened}
    seconds = {}
    for k in range(1, args.levels + 1):
        h = scene.h / 2.0 ** k
        cache = work / f"top{args.top}-level{k}-{scene.config_hash[:12]}.npz"
        if cache.exists():
            with np.load(cache) as z:
                got, seconds[k] = z["values"], float(z["seconds"])
        else:
            t = time.perf_counter()
            got = caging_areas(scene, designs, parts, keys, h)
            seconds[k] = time.perf_counter() - t
            np.savez(cache, keys=keys, values=got, seconds=seconds[k])
        v = np.full_like(screened, np.nan)
        v[keys[:, 1], keys[:, 0]] = got
        values[k] = v
        print(f"level {k}: h = {h:g}, {len(keys)} maps in {seconds[k]:.1f} s")
    r_vals, mu_vals = scene.values["r"], scene.values["mu"]

    def points(p, d, k):
        return grid_points(designs[d][0], designs[d][1], designs[d][4], r_vals[parts[p, 0]],
                           scene.h / 2.0 ** k)

    # seconds per grid point of each level, from the maps just computed (or cached)
    per_point = {k: seconds[k] / sum(points(p, d, k) for p, d in keys)
                 for k in range(1, args.levels + 1)}

    print(f"\nconfig {scene.name} ({scene.config_hash[:12]}), screening h = {scene.h:g}, "
          f"trajectory {scene.accuracy.trajectory}; top {args.top} classes per part\n")
    print("| part | level | h | best (l1 l2 r1 r2 w) | screened rank | screening gap | "
          "best value | lead over runner-up |")
    print("|---|---|---|---|---|---|---|---|")
    worst = {k: 0.0 for k in range(1, args.levels + 1)}
    for p in range(n_parts):
        ri, mi, ci = parts[p]
        c = top[p]
        best0 = screened[c[0], p]
        for k in range(1, args.levels + 1):
            v = values[k][c, p]
            b = int(np.argmax(v))
            gap = (best0 - screened[c[b], p]) / best0 if best0 > 0 else 0.0
            worst[k] = max(worst[k], gap)
            runner = float(np.max(np.delete(v, b))) if v.size > 1 else np.nan
            d = designs[c[b]]
            print(f"| r={r_vals[ri]:g} mu={mu_vals[mi]:g} c{ci} | {k} | {scene.h / 2 ** k:g} | "
                  f"{' '.join(f'{x:g}' for x in d)} | {b + 1} | {gap:.4f} | {v[b]:.5g} | "
                  f"{v[b] - runner:.3g} ({(v[b] - runner) / v[b]:.2%}) |")
    print("\nlargest screening gap per level: "
          + ", ".join(f"level {k}: {g:.4f}" for k, g in worst.items()))

    # What the stage would do with each bound (sweep.runs.refine's rule, on the cached values).
    screening = float(view.attrs.get("compute_seconds", np.nan))
    print(f"\nscreening: {scene.n_maps:,} maps, {screening:.1f} s of compute (store); "
          "estimated seconds of a bound = its grid points per level x the seconds per point "
          "measured above\n")
    print("| bound | contenders (classes, max per part) | certified | near-tie | "
          "maps per level | estimated seconds | / screening | parts whose contenders exceed "
          "--top |")
    print("|---|---|---|---|---|---|---|---|")
    for bound in (float(b) for b in args.bounds.split(",")):
        settings = RefineSettings(levels=args.levels, bound=bound,
                                  min_contenders=args.min_contenders)
        n_cert = n_tie = over = 0
        maps = [0] * args.levels
        cost = 0.0
        most = 0
        for p in range(n_parts):
            alive = select_contenders(top[p], screened[:, p], settings)  # reps, store order
            if not alive.size:
                continue
            over += len(alive) >= args.top
            most = max(most, len(alive))
            prev = screened[alive, p]
            certified = False
            for k in range(1, args.levels + 1):
                maps[k - 1] += len(alive)
                cost += per_point[k] * sum(points(p, d, k) for d in alive)
                now = values[k][alive, p]
                _, _, keep = separate(now, prev)
                alive, prev = alive[keep], now[keep]
                if alive.size == 1:
                    certified = True
                    break
            n_cert += certified
            n_tie += not certified
        print(f"| {bound:g} | max {most} | {n_cert} | {n_tie} | {maps} | {cost:.1f} | "
              f"{cost / screening:.3f} | {over} |")


if __name__ == "__main__":
    main()
