"""Where the screening's error sits, and a prototype that removes part of it
(docs/accuracy.md, "Where the screening's error sits").

    .venv/bin/python docs/notes/stall_windows.py CONFIG SCREENING_CSV [K] [W]

SCREENING_CSV: the sample `scripts/screening_accuracy.py` writes (each pair's caging area at the
config's h and at h = 0.00625). For every pair: the map at h; every distinct grid point where a
trajectory stalls resolved in a window of +-W h at h / K around it (a map of that window, whose
trajectories stay inside it); where the window's trajectory from the stall point ends caged, every
start that stalled there takes that end's score. Prints the pairs within 5 % of the fine value
before and after, and the windows' cost (seconds of compute_map, not of a kernel).
"""
import csv
import sys
import time

import numpy as np

from sweep.compute.maps import compute_map
from sweep.config.parse import load_scene
from sweep.report.data import within_error
from sweep.model import END_CAGED, END_STALLED, Design, Grid, Part


def main(argv):
    scene = load_scene(argv[0])
    rows = list(csv.DictReader(open(argv[1])))
    k = int(argv[2]) if len(argv) > 2 else 4
    half = float(argv[3]) if len(argv) > 3 else 2.0
    best = {}
    for r in rows:
        best[r["part"]] = max(best.get(r["part"], 0.0), float(r["caging_fine"]))
    h = scene.h
    n5 = n15 = n5_old = windows = 0
    t_win = t_map = 0.0
    for r in rows:
        f = float(r["caging_fine"])
        d = Design(*(float(r[x]) for x in ("l1", "l2", "r1", "r2", "w")))
        p = Part(float(r["r"]), float(r["mu"]))
        t0 = time.perf_counter()
        mc = compute_map(d, p, scene.commands[0], Grid(h=h), scene.limits, scene.accuracy,
                         scene.effects)
        t_map += time.perf_counter() - t0
        es = mc.fields["end_state"].reshape(-1)
        ei = mc.fields["end_index"].reshape(-1)
        cs = mc.fields["caging_score"].reshape(-1)
        nx = mc.x.size
        weight = np.ones(es.size)
        weight[:nx] = 0.5                      # the palm row counts half (D36)
        area = float(np.sum(np.where(es == END_CAGED, cs[np.clip(ei, 0, None)], 0.0)
                            * weight)) * h * h
        gain = 0.0
        t0 = time.perf_counter()
        for q in np.unique(ei[es == END_STALLED]):
            px, py = mc.x[q % nx], mc.y[q // nx]
            w = half * h
            mw = compute_map(d, p, scene.commands[0],
                             Grid(h=h / k, xlim=(px - w, px + w), ylim=(py - w, py + w)),
                             scene.limits, scene.accuracy, scene.effects)
            windows += 1
            i = int(round((px - mw.x[0]) / (h / k)))
            j = int(round((py - mw.y[0]) / (h / k)))
            if int(mw.fields["end_state"][j, i]) == END_CAGED:
                s = float(mw.fields["caging_score"].reshape(-1)[int(mw.fields["end_index"][j, i])])
                gain += s * float(np.sum(weight[(es == END_STALLED) & (ei == q)])) * h * h
        t_win += time.perf_counter() - t0
        b = best[r["part"]]
        n5 += bool(within_error(area + gain, f, b, 0.05))
        n15 += bool(within_error(area + gain, f, b, 0.15))
        n5_old += bool(within_error(area, f, b, 0.05))
    print(f"K {k}, W {half:g}: within 5 % {n5}/{len(rows)} (without the windows {n5_old}), "
          f"within 15 % {n15}; {windows} windows, {t_win:.1f} s against {t_map:.1f} s of maps")


if __name__ == "__main__":
    main(sys.argv[1:])
