"""Scale: memory stays flat and time grows linearly as a sweep grows (issue P13).

Runs each of two configs in chunks, one `sweep` process per chunk (`sweep run CONFIG --out DIR
--chunks N --chunk k`, k = 0..N-1, one after the other), then `sweep merge --no-refine` (the
sweep, not the refinement stage), and measures every process's peak resident memory
(os.wait4's ru_maxrss) and wall time. Give the larger config proportionally more chunks (same
chunk size): then its chunk processes should need what the smaller config's need, and its
compute time should grow with its maps. Prints one Markdown table and the ratios; also checks
that the maps both configs share have bitwise the same summaries (exit code 1 if not). Long:
two whole sweeps (configs/paper.yaml and configs/paper-4x.yaml: 86,400 + 345,600 maps).

With --merge-trees NAME=TREE ..., the same shards of both configs are then merged again by each
of those source trees (`python -m sweep merge` with PYTHONPATH=TREE, e.g. before=<old tree>
after=.), trees rotating, each tree's kernels warmed first by an untimed merge: the merge's
peak memory of old and new code side by side in one run, and whether each tree's stores hold
the same content as the first tree's (every dataset and attribute but timings and provenance).
"""
from __future__ import annotations

import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

from .timing import header

NAME = "scale"
SWEEP = Path(sys.executable).parent / "sweep"


def add_arguments(ap) -> None:
    ap.add_argument("config_a")
    ap.add_argument("chunks_a", type=int)
    ap.add_argument("config_b")
    ap.add_argument("chunks_b", type=int)
    ap.add_argument("--work", type=Path, required=True, help="scratch folder (must be empty)")
    ap.add_argument("--merge-trees", nargs="+", metavar="NAME=TREE", default=[],
                    help="then merge both configs' shards again with each of these source trees "
                         "(the folders holding sweep/), e.g. before=<old tree> after=.")


def measured(args: list[str], tree: Path | None = None) -> tuple[float, float]:
    """(wall seconds, peak resident MiB) of one `sweep` process (of `tree`'s sweep if given)."""
    started = time.perf_counter()
    if tree is None:
        proc = subprocess.Popen([str(SWEEP), *args], stdout=subprocess.DEVNULL)
    else:
        proc = subprocess.Popen([sys.executable, "-m", "sweep", *args], stdout=subprocess.DEVNULL,
                                env=dict(os.environ, PYTHONPATH=str(tree.resolve())),
                                cwd=str(tree))
    _, status, usage = os.wait4(proc.pid, 0)
    wall = time.perf_counter() - started
    if os.waitstatus_to_exitcode(status) != 0:
        raise SystemExit(f"sweep {' '.join(args)} failed ({status})")
    return wall, usage.ru_maxrss / 1024.0


def run_config(config: str, chunks: int, work: Path) -> dict:
    import h5py

    name = Path(config).stem
    rundir, store = work / name, work / f"{name}.h5"
    chunk_wall, chunk_peak = [], []
    for k in range(chunks):
        wall, peak = measured(["run", config, "--out", str(rundir), "--chunks", str(chunks),
                               "--chunk", str(k), "--no-progress"])
        chunk_wall.append(wall)
        chunk_peak.append(peak)
        print(f"  {name} chunk {k}/{chunks}: {wall:.1f} s, peak {peak:.0f} MiB", flush=True)
    merge_wall, merge_peak = measured(["merge", str(rundir), "--out", str(store),
                                      "--no-refine"])  # the sweep, not the refinement stage
    print(f"  {name} merge: {merge_wall:.1f} s, peak {merge_peak:.0f} MiB", flush=True)
    with h5py.File(store, "r") as f:
        n_maps = int(f.attrs["n_maps"])
        compute = float(f.attrs["compute_seconds"])
    return dict(name=name, store=store, rundir=rundir, chunks=chunks, maps=n_maps, compute=compute,
                wall=sum(chunk_wall) + merge_wall, chunk_peak=max(chunk_peak),
                chunk_peak_median=float(np.median(chunk_peak)), merge_peak=merge_peak,
                merge_wall=merge_wall)


def shared_maps_equal(a: Path, b: Path) -> tuple[int, bool]:
    """The summaries of the maps both stores hold (coordinates in both) are bitwise equal."""
    import h5py

    with h5py.File(a, "r") as fa, h5py.File(b, "r") as fb:
        dims = ("l1", "l2", "r1", "r2", "w", "r", "mu")
        pick_a, pick_b = [], []
        for d in dims:
            ca, cb = fa[d][...], fb[d][...]
            common = np.intersect1d(ca, cb)
            pick_a.append(np.flatnonzero(np.isin(ca, common)))
            pick_b.append(np.flatnonzero(np.isin(cb, common)))
        n = int(np.prod([p.size for p in pick_a]))
        same = True
        for name in ("Lambda", "caging_area", "n_caged", "n_reached", "n_equilibrium"):
            # h5py indexes one axis by a list at a time: read whole (summaries are small)
            va = fa[name][...][np.ix_(*pick_a)]
            vb = fb[name][...][np.ix_(*pick_b)]
            same &= bool(np.array_equal(va, vb, equal_nan=True))
    return n, same


def run(args) -> int:
    args.work = args.work.resolve()              # the merges of --merge-trees run in each tree
    args.work.mkdir(parents=True, exist_ok=True)
    header(NAME)
    rows = []
    for config, chunks in ((args.config_a, args.chunks_a), (args.config_b, args.chunks_b)):
        print(f"{config}: {chunks} chunks", flush=True)
        rows.append(run_config(config, chunks, args.work))
    a, b = rows
    print("\n| config | maps | chunks | compute s | wall s | maps/s of compute | "
          "peak MiB per chunk (max / median) | merge: peak MiB, wall s |")
    print("|---|---|---|---|---|---|---|---|")
    for r in rows:
        print(f"| {r['name']} | {r['maps']:,} | {r['chunks']} | {r['compute']:.1f} | "
              f"{r['wall']:.1f} | {r['maps'] / r['compute']:.0f} | {r['chunk_peak']:.0f} / "
              f"{r['chunk_peak_median']:.0f} | {r['merge_peak']:.0f}, {r['merge_wall']:.1f} |")
    print(f"\nmaps x{b['maps'] / a['maps']:.2f}; compute x{b['compute'] / a['compute']:.2f}; "
          f"wall x{b['wall'] / a['wall']:.2f}; "
          f"peak per chunk x{b['chunk_peak'] / a['chunk_peak']:.3f}; "
          f"merge peak x{b['merge_peak'] / a['merge_peak']:.3f}")
    n, same = shared_maps_equal(a["store"], b["store"])
    print(f"maps in both stores: {n:,}, summaries bitwise equal: {same}")
    if args.merge_trees:
        same &= merge_with_trees(args.merge_trees, rows, args.work)
    return 0 if same else 1


def merge_with_trees(specs: list[str], rows: list[dict], work: Path) -> bool:
    """Merge each config's shards with each tree (rotating), print peak and wall side by side;
    True if every tree's stores hold the first tree's content."""
    from sweep.storage.store import store_differences

    trees = [(name, Path(tree)) for name, _, tree in (spec.partition("=") for spec in specs)]
    for name, tree in trees:                     # warm each tree's kernel cache (untimed)
        measured(["merge", str(rows[0]["rundir"]), "--out", str(work / f"warm-{name}.h5"),
                  "--no-refine"], tree)
    result = {}
    for k, r in enumerate(rows):
        order = trees[k % len(trees):] + trees[:k % len(trees)]
        for name, tree in order:
            out = work / f"{r['name']}-{name}.h5"
            result[r["name"], name] = measured(["merge", str(r["rundir"]), "--out", str(out),
                                                "--no-refine"], tree) + (out,)
            print(f"  {r['name']} merge by {name}: {result[r['name'], name][0]:.1f} s, peak "
                  f"{result[r['name'], name][1]:.0f} MiB", flush=True)
    print("\n| config | tree | merge peak MiB | merge wall s | same content as "
          f"{trees[0][0]}'s store |")
    print("|---|---|---|---|---|")
    all_same = True
    for r in rows:
        for name, _ in trees:
            wall, peak, out = result[r["name"], name]
            diff = store_differences(result[r["name"], trees[0][0]][2], out)
            all_same &= not diff
            print(f"| {r['name']} | {name} | {peak:.0f} | {wall:.1f} | "
                  f"{'yes' if not diff else '; '.join(diff[:3])} |")
    a, b = rows
    for name, _ in trees:
        print(f"{name}: merge peak {b['name']} / {a['name']} x"
              f"{result[b['name'], name][1] / result[a['name'], name][1]:.3f}")
    return all_same
