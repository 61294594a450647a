"""The numbers of docs/variable-geometry.md, printed from `sweep schedule`'s results files: per
file a compact table (each part's best fixed setting and best schedule with their errors, the
gain and its verdict, for caging and for tip prehension), the report's reading of the paper's
claim (`sweep.report.variable.reading`: the same words as report.md's section 7), the cost, and,
for a file made with --third-switch, what the third switch adds.

    .venv/bin/python scripts/schedule_tables.py results/paper.schedule.h5 \\
        results/paper-collision.schedule.h5
    .venv/bin/python scripts/schedule_tables.py results/paper.third-switch.h5 --cases all
"""
from __future__ import annotations

import argparse
import math
from pathlib import Path

from sweep.report.variable import reading, variable_rows
from sweep.storage.schedule import read_schedules


def g(v: float, digits: int = 3) -> str:
    return "NaN" if not math.isfinite(v) else f"{v:.{digits}g}"


def setting(row: dict, side: str) -> str:
    return f"{g(row[side + '_R'])}, {g(row[side + '_w'])}"


def cell(row: dict) -> list[str]:
    fixed = f"R, w = {setting(row, 'fixed')}: {g(row['fixed_area'])} ± {g(row['fixed_error'])}"
    if row["draw"] == row["hold"]:
        sched = "= fixed"
    else:
        sched = (f"{setting(row, 'draw')} → {setting(row, 'hold')}: "
                 f"{g(row['schedule_area'])} ± {g(row['schedule_error'])}")
    gain = f"{g(row['gain'])} ± {g(row['gain_error'])}" + (" **gain**" if row["verdict"] ==
                                                          "gain" else "")
    return [fixed, sched, gain]


def table(rows: list[dict], which: str) -> list[str]:
    keep = [r for r in rows if which == "all" or r["source"] == "part_best"]
    out = ["| part r, μ | chassis l1, l2 | caging: best fixed | best schedule (draw → hold) | "
           "gain ± error | tip: best fixed | best schedule | gain ± error |",
           "|---|---|---|---|---|---|---|---|"]
    cases = sorted({r["case"] for r in keep})
    for c in cases:
        cr = next(r for r in keep if r["case"] == c and r["objective"] == "caging")
        tr = next(r for r in keep if r["case"] == c and r["objective"] == "tip_prehension")
        out.append(f"| {g(cr['r'])}, {g(cr['mu'])} | {g(cr['l1'])}, {g(cr['l2'])} | "
                   + " | ".join(cell(cr) + cell(tr)) + " |")
    return out


def third(rows: list[dict], path: Path) -> list[str]:
    v = read_schedules(path)["vars"]
    if "third_gain" not in rows[0]:
        return []
    h = v["h"]
    adds = [r for r in rows if r["third_adds"]]
    positive = [r for r in rows if r["third_gain"] > 0]
    out = [f"Third switch ({len(rows)} case-objectives: {len(rows) // 2} cases, caging and tip "
           f"prehension; the best of three settings over every setting at h = {g(h[0])}, it and "
           f"the best of two recomputed at h = {g(h[min(1, len(h) - 1)])}): positive on "
           f"{len(positive)}, beyond the error on {len(adds)}.", ""]
    if adds:
        out += ["| part r, μ | chassis | objective | three settings (R, w) | three | two | adds ± "
                "error |", "|---|---|---|---|---|---|---|"]
        for r in adds:
            c, o = r["case"], 0 if r["objective"] == "caging" else 1
            t = v["third_settings"][c, o]
            trip = " → ".join(f"{g(v['setting_R'][i])}, {g(v['setting_w'][i])}" for i in t)
            out.append(f"| {g(r['r'])}, {g(r['mu'])} | {g(r['l1'])}, {g(r['l2'])} | "
                       f"{r['objective']} | {trip} | {g(v['third_area'][c, o, 1])} | "
                       f"{g(v['third_best_two'][c, o, 1])} | {g(r['third_gain'])} ± "
                       f"{g(r['third_error'])} |")
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("files", type=Path, nargs="+", help="results files of sweep schedule")
    ap.add_argument("--cases", choices=("part_best", "all"), default="part_best",
                    help="the parts' best chassis only, or every case [part_best]")
    args = ap.parse_args(argv)
    for path in args.files:
        rows = variable_rows(path)
        a = read_schedules(path)["attrs"]
        print(f"## {path.name} ({a.get('store_name')}; effects {a.get('effects_on')}; ladder "
              + ", ".join(g(h) for h in a.get("ladder", [])) + ")\n")
        print("\n".join(table(rows, args.cases)) + "\n")
        print("\n".join(reading(rows)) + "\n")
        print(f"Cost: {g(float(a['compute_seconds']))} s of computing for "
              f"{len({r['case'] for r in rows})} cases, {g(float(a['fraction_of_screening']))} "
              f"of the store's screening ({g(float(a['screening_compute_seconds']))} s; two "
              "runs, not side by side).\n")
        extra = third(rows, path)
        if extra:
            print("\n".join(extra) + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
