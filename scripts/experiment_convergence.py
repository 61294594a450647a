#!/usr/bin/env python3
"""How far each experiment's numbers at the screening spacing are from a finer grid's: a slice of
a config (every part, a subset of the designs) swept with the manipulation metric at each spacing
of a ladder, and per output the change from each spacing to the finest (docs/accuracy.md,
"Each experiment's outputs as h halves").

    .venv/bin/python scripts/experiment_convergence.py configs/paper.yaml --work /tmp/conv

Outputs compared, as the experiments read them (those the config's scene has): the caging and
tip-prehension areas of every design and part (best caging designs, caging versus tip
prehension), Scenario A's area of every candidate and part (`scenario_a_top_k` is raised so that
every candidate of the slice is one at every spacing), Scenario B's area per part (A against B)
and its parameter usage per part and parameter. A value counts as within 5 % when its relative
change is at most 5 %, or (a value of the finest grid below 1 % of the output's largest for that
part) its absolute change is below 1 % of that largest. The slice: `l1` in {1.2, 2.0}, `l2` in
{0.8, 1.6}, `r1` and `r2` at their ends and middle, every `w`: 216 designs x 16 parts. Each
spacing's store is kept in --work, so a rerun only reads them (and a killed one resumes). A scene
with `tip_contact` has no manipulation metric: its tables have the two areas only. With --table,
the coarsest spacing's rows go into the table the reports print each experiment's error from
(sweep/report/experiment_error.csv; rows of the same scene, spacing and output replaced).
"""
from __future__ import annotations

import argparse
import subprocess
import sys
import time
from pathlib import Path

import h5py
import numpy as np
import yaml

from sweep.config.parse import load_scene
from sweep.report.data import within_error
from sweep.report.experiment_error import EXPERIMENT_ERROR_TABLE, OUTPUTS, scene_key, write_rows

SLICE = {"l1": [1.2, 2.0], "l2": [0.8, 1.6], "r1": [0.04, 0.12, 0.2], "r2": [0.02, 0.1, 0.18]}
def slice_config(config: Path, h: float, out: Path) -> Path:
    """The config's slice at spacing h, without refinement, with every candidate in Scenario A
    where the config has the manipulation metric (a scene with `tip_contact` has none)."""
    cfg = yaml.safe_load(config.read_text())
    for name, values in SLICE.items():
        cfg["designs"][name] = list(values)
    cfg["grid"]["h"] = h
    cfg.pop("refine", None)
    if cfg.get("outputs", {}).get("manipulation"):
        cfg["outputs"]["scenario_a_top_k"] = 10_000
    cfg["name"] = f"{cfg.get('name', 'sweep')}-conv-{h:g}"
    out.write_text(yaml.safe_dump(cfg, sort_keys=False))
    return out


def part_axes(name: str, ndim: int) -> tuple[int, ...]:
    """The axes of a variable that are not the part's (r, mu): the designs, or the parameter."""
    if name == "manipulation_b_area":
        return ()
    if name == "parameter_usage":
        return ()            # (r, mu, parameter): each parameter is its own value
    return tuple(range(ndim - 2))


def compare(name: str, coarse: np.ndarray, fine: np.ndarray) -> dict:
    """Statistics of coarse against fine for one output (NaN where either is undefined)."""
    ok = np.isfinite(coarse) & np.isfinite(fine)
    axes = part_axes(name, fine.ndim)
    largest = np.nanmax(np.where(ok, np.abs(fine), np.nan), axis=axes, keepdims=True) \
        if axes else np.abs(fine)
    largest = np.where(np.isfinite(largest), largest, 0.0)
    rel = np.abs(coarse - fine) / np.maximum(np.abs(fine), 0.01 * largest + 1e-300)
    w5 = within_error(coarse, fine, largest, 0.05)[ok]
    w15 = within_error(coarse, fine, largest, 0.15)[ok]
    r = rel[ok]
    return dict(n=int(ok.sum()), median=float(np.median(r)) if r.size else float("nan"),
                p90=float(np.percentile(r, 90)) if r.size else float("nan"),
                worst=float(r.max()) if r.size else float("nan"),
                within5=float(w5.mean()) if w5.size else float("nan"),
                within15=float(w15.mean()) if w15.size else float("nan"))


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("config", type=Path)
    ap.add_argument("--h", type=float, nargs="+", default=[0.05, 0.025, 0.0125],
                    help="the ladder, coarsest first; the last is the reference "
                    "[0.05 0.025 0.0125]")
    ap.add_argument("--work", type=Path, required=True, help="folder for the configs and stores")
    ap.add_argument("--sweep", default=str(Path(sys.executable).with_name("sweep")),
                    help="the sweep command [the one beside this Python]")
    ap.add_argument("--table", nargs="?", type=Path, const=EXPERIMENT_ERROR_TABLE, default=None,
                    help="also write the coarsest spacing's rows into this table [with no "
                    "value: the one the reports read]")
    args = ap.parse_args(argv)
    args.work.mkdir(parents=True, exist_ok=True)
    stores = []
    for h in args.h:
        cfg = slice_config(args.config, h, args.work / f"{args.config.stem}-{h:g}.yaml")
        store = args.work / f"{args.config.stem}-{h:g}.h5"
        t0 = time.perf_counter()
        subprocess.run([args.sweep, "run", str(cfg), "--out", str(store), "--no-progress"],
                       check=True, stdout=subprocess.DEVNULL)
        print(f"# h = {h:g}: {store} ({time.perf_counter() - t0:.0f} s)", file=sys.stderr)
        stores.append(store)
    values = []
    for store in stores:
        with h5py.File(store, "r") as f:
            values.append({name: f[name][...].astype(float) for name, _ in OUTPUTS
                           if name in f})
    ref_h = args.h[-1]
    designs = int(np.prod([len(v) for v in SLICE.values()]))
    with h5py.File(stores[0], "r") as f:
        effects_on = str(f.attrs.get("effects_on", ""))
        widths = int(f["w"].size)
        parts = int(f["r"].size * f["mu"].size)
    accuracy = load_scene(args.work / f"{args.config.stem}-{args.h[0]:g}.yaml").accuracy
    table_rows = []
    print(f"### {args.config.name}: the slice's outputs at each spacing against h = {ref_h:g}\n")
    print("| output | read by | h | values | median change | 90th percentile | worst "
          "| within 5 % | within 15 % |")
    print("|---|---|---|---|---|---|---|---|---|")
    for name, reader in OUTPUTS:
        if name not in values[-1]:
            continue
        for h, v in zip(args.h[:-1], values[:-1]):
            s = compare(name, v[name], values[-1][name])
            print(f"| `{name}` | {reader} | {h:g} | {s['n']} | {s['median']:.2%} | "
                  f"{s['p90']:.2%} | {s['worst']:.2%} | {s['within5']:.1%} | "
                  f"{s['within15']:.1%} |")
            if h == args.h[0]:
                table_rows.append(dict(
                    scene=scene_key(effects_on, accuracy.trajectory, accuracy.step_resolution),
                    h=f"{h:g}", reference_h=f"{ref_h:g}", output=name,
                    slice=f"a slice of {designs * widths} designs x {parts} parts",
                    command=f"scripts/experiment_convergence.py configs/{args.config.name}",
                    **{k: f"{s[k]:.6g}" for k in ("n", "median", "p90", "worst", "within5",
                                                  "within15")}))
    if args.table is not None:
        write_rows(table_rows, args.table)
        print(f"# wrote {len(table_rows)} rows into {args.table}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
