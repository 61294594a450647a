"""Per-point class changes an effect makes, on a random sample of the paper's maps.

Stores keep per-map counts only, so a sweep comparison (scripts/compare_effect_stores.py) shows
net changes. This script computes whole maps of a random sample of the paper table
(configs/paper.yaml's designs and parts, h = 0.05, default accuracy) without and with each
effect, and counts, point by point, how the class changes (a transition table) and how many
caged points change. Prints Markdown.

    .venv/bin/python docs/notes/effect_point_changes.py [--maps 40] [--seed 1]
"""
from __future__ import annotations

import argparse

import numpy as np

from sweep.compute.maps import compute_map
from sweep.model import POINT_CLASS_MEANINGS, Accuracy, Command, Design, Effects, Grid, Limits, Part

TABLE = dict(l1=np.round(np.arange(0.4, 2.01, 0.2), 10), l2=(0.4, 0.8, 1.2, 1.6),
             r1=(0.04, 0.08, 0.12, 0.16, 0.2), r2=(0.02, 0.06, 0.1, 0.14, 0.18),
             w=(0.0, 0.4, 0.8, 1.2, 1.6, 2.0), r=(0.4, 0.8, 1.2, 1.6), mu=(0.1, 0.4, 0.7, 1.0))
SCENES = {"tip_contact": Effects(tip_contact=True),
          "finger_collision": Effects(finger_collision=True),
          "both": Effects(tip_contact=True, finger_collision=True)}


def sample(n, seed):
    rng = np.random.default_rng(seed)
    keys = list(TABLE)
    for _ in range(n):
        v = {k: float(TABLE[k][rng.integers(len(TABLE[k]))]) for k in keys}
        yield Design(v["l1"], v["l2"], v["r1"], v["r2"], v["w"]), Part(v["r"], v["mu"])


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--maps", type=int, default=40)
    ap.add_argument("--seed", type=int, default=1)
    args = ap.parse_args()
    n_cls = len(POINT_CLASS_MEANINGS)
    trans = {s: np.zeros((n_cls, n_cls), dtype=np.int64) for s in SCENES}
    caged = {s: np.zeros(3, dtype=np.int64) for s in SCENES}  # lost, gained, kept
    lam = {s: [0.0, 0.0] for s in SCENES}
    n_points = 0
    for design, part in sample(args.maps, args.seed):
        base = compute_map(design, part, Command(), Grid(h=0.05), Limits(), Accuracy())
        cb = base.fields["point_class"]
        gb = base.fields["caging_score"] > 0
        n_points += cb.size
        for name, eff in SCENES.items():
            m = compute_map(design, part, Command(), Grid(h=0.05), Limits(), Accuracy(),
                            effects=eff)
            ce = m.fields["point_class"]
            np.add.at(trans[name], (cb.ravel(), ce.ravel()), 1)
            ge = m.fields["caging_score"] > 0
            caged[name] += [np.sum(gb & ~ge), np.sum(~gb & ge), np.sum(gb & ge)]
            lam[name][0] += base.attrs["Lambda"]
            lam[name][1] += m.attrs["Lambda"]
    print(f"{args.maps} random maps of the paper table (seed {args.seed}), h = 0.05, "
          f"{n_points:,} points\n")
    for name in SCENES:
        t = trans[name]
        changed = int(t.sum() - np.trace(t))
        print(f"**{name}**: {changed:,} points ({changed / n_points:.1%}) change class; caged "
              f"points lost {caged[name][0]:,}, gained {caged[name][1]:,}, kept "
              f"{caged[name][2]:,}; Lambda summed {lam[name][0]:,.0f} -> {lam[name][1]:,.0f}\n")
        print("| base class \\ with effect | " + " | ".join(POINT_CLASS_MEANINGS) + " |")
        print("|---" * (n_cls + 1) + "|")
        for a in range(n_cls):
            print(f"| {POINT_CLASS_MEANINGS[a]} | " + " | ".join(f"{t[a, k]:,}"
                                                            for k in range(n_cls)) + " |")
        print()


if __name__ == "__main__":
    main()
