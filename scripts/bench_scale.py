"""Scale: memory stays flat and time grows linearly as a sweep grows (issue P13).

    setsid -w sh -c 'echo -10 > /proc/self/autogroup; exec nice -n -10 \\
        .venv/bin/python scripts/bench_scale.py configs/paper.yaml 4 configs/paper-4x.yaml 16 \\
        --work <scratch>'

Runs each config in chunks on this machine, one process per chunk (`sweep run CONFIG --out DIR
--chunks N --chunk k`, k = 0..N-1, one after the other), then `sweep merge`, and measures every
process's peak resident memory (os.wait4's ru_maxrss) and wall time. Give the larger config
proportionally more chunks (same chunk size): then its chunk processes should need what the
smaller config's need, and its compute time should grow with its maps. Prints one table (markdown)
and the ratios; also checks that the maps both configs share have bitwise the same summaries.

`--first-chunks K` measures a fraction: the first K chunks of the first config and the first
K * chunks_b / chunks_a of the second, the same share of each sweep's cost (chunks are cut by
cost), so the second's should hold chunks_b / chunks_a times the maps; no merge, no comparison
of shared maps.
"""
from __future__ import annotations

import argparse
import os
import subprocess
import sys
import time
from pathlib import Path

import h5py
import numpy as np

from sweep.rundir import RunDir, read_json

SWEEP = Path(sys.executable).parent / "sweep"


def measured(args: list[str]) -> tuple[float, float]:
    """(wall seconds, peak resident MiB) of one `sweep` process."""
    started = time.perf_counter()
    proc = subprocess.Popen([str(SWEEP), *args], stdout=subprocess.DEVNULL)
    _, status, usage = os.wait4(proc.pid, 0)
    wall = time.perf_counter() - started
    if os.waitstatus_to_exitcode(status) != 0:
        raise SystemExit(f"sweep {' '.join(args)} failed ({status})")
    return wall, usage.ru_maxrss / 1024.0


def run_config(config: str, chunks: int, work: Path, first: int | None = None) -> dict:
    name = Path(config).stem
    rundir, store = work / name, work / f"{name}.h5"
    chunk_wall, chunk_peak = [], []
    for k in range(chunks if first is None else first):
        wall, peak = measured(["run", config, "--out", str(rundir), "--chunks", str(chunks),
                               "--chunk", str(k), "--no-progress"])
        chunk_wall.append(wall)
        chunk_peak.append(peak)
        print(f"  {name} chunk {k}/{chunks}: {wall:.1f} s, peak {peak:.0f} MiB", flush=True)
    if first is not None:
        return chunks_run(name, rundir, chunks, first, chunk_wall, chunk_peak)
    merge_wall, merge_peak = measured(["merge", str(rundir), "--out", str(store),
                                      "--no-refine"])  # the sweep, not the refinement stage
    print(f"  {name} merge: {merge_wall:.1f} s, peak {merge_peak:.0f} MiB", flush=True)
    with h5py.File(store, "r") as f:
        n_maps = int(f.attrs["n_maps"])
        compute = float(f.attrs["compute_seconds"])
    return dict(name=name, store=store, chunks=chunks, maps=n_maps, compute=compute,
                wall=sum(chunk_wall) + merge_wall, chunk_peak=max(chunk_peak),
                chunk_peak_median=float(np.median(chunk_peak)), merge_peak=merge_peak,
                merge_wall=merge_wall)


def chunks_run(name, rundir, chunks, first, chunk_wall, chunk_peak) -> dict:
    """The figures of the first chunks of a run directory (maps from the manifest's chunk
    ranges, compute seconds from the shards)."""
    rd = RunDir(rundir)
    manifest = read_json(rd.manifest)
    maps_per_item = manifest["n_maps"] // manifest["n_items"]
    n_maps = sum((b - a) * maps_per_item for a, b in manifest["chunk_ranges"][:first])
    compute = 0.0
    for k in range(first):
        with h5py.File(rd.shard(k, chunks), "r") as f:
            compute += float(f.attrs["compute_seconds"])
    return dict(name=f"{name} (chunks 0-{first - 1} of {chunks})", store=None, chunks=first,
                maps=n_maps, compute=compute, wall=sum(chunk_wall), chunk_peak=max(chunk_peak),
                chunk_peak_median=float(np.median(chunk_peak)), merge_peak=float("nan"),
                merge_wall=float("nan"))


def shared_maps_equal(a: Path, b: Path) -> tuple[int, bool]:
    """The summaries of the maps both stores hold (coordinates in both) are bitwise equal."""
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
            va = fa[name][np.ix_(*pick_a)]
            vb = fb[name][np.ix_(*pick_b)]
            same &= bool(np.array_equal(va, vb, equal_nan=True))
    return n, same


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("config_a")
    ap.add_argument("chunks_a", type=int)
    ap.add_argument("config_b")
    ap.add_argument("chunks_b", type=int)
    ap.add_argument("--work", type=Path, required=True, help="scratch folder (must be empty)")
    ap.add_argument("--first-chunks", type=int, default=None,
                    help="measure only the first K chunks of config_a (and the same share of "
                         "config_b's)")
    args = ap.parse_args(argv)
    args.work.mkdir(parents=True, exist_ok=True)
    rows = []
    first = args.first_chunks
    for config, chunks in ((args.config_a, args.chunks_a), (args.config_b, args.chunks_b)):
        share = None if first is None else first * chunks // args.chunks_a
        print(f"{config}: {chunks} chunks" + ("" if share is None else f", the first {share}"),
              flush=True)
        rows.append(run_config(config, chunks, args.work, share))
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
    if first is not None:
        return 0
    n, same = shared_maps_equal(a["store"], b["store"])
    print(f"maps in both stores: {n:,}, summaries bitwise equal: {same}")
    return 0 if same else 1


if __name__ == "__main__":
    sys.exit(main())
