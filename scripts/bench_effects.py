"""Time per map for each combination of effects and outputs, on the same maps, in one run.

    .venv/bin/python scripts/bench_effects.py [--h 0.05] [--repeats 3]

Three maps of different size (the issue's reference design and two others). Every combination
is compiled / loaded from the cache first; then the combinations are timed in rounds (A B C ...
A B C ...) so that the machine's drift affects all alike. Prints a Markdown table of the median
milliseconds per map (sum over the three maps / 3) and the ratio to the base scene.
"""
from __future__ import annotations

import argparse
import os
import platform
import statistics
import time

from sweep.maps import compute_map
from sweep.model import Design, Effects, Grid, Outputs, Part

MAPS = [(Design(2.0, 1.6, 0.2, 0.14, 0.8), Part(0.4, 0.4)),
        (Design(1.0, 0.8, 0.04, 0.18, 1.2), Part(0.8, 0.1)),
        (Design(0.6, 0.4, 0.12, 0.1, 0.4), Part(1.2, 1.0))]

SPRINGS = dict(joint_springs=True, spring_k1=0.005, spring_k2=0.005)  # < F r / range for all
EFFECTS = {
    "base (friction)": Effects(),
    "frictionless": Effects(friction=False),
    "joint_springs": Effects(**SPRINGS),
    "finger_collision": Effects(finger_collision=True),
    "springs + collision": Effects(finger_collision=True, **SPRINGS),
    "tip_contact": Effects(tip_contact=True),
    "tip + collision": Effects(tip_contact=True, finger_collision=True),
    "tip + springs + collision": Effects(tip_contact=True, finger_collision=True, **SPRINGS),
}
OUTPUTS = {
    "energy": Outputs.from_names(["energy"]),
    "energy, equilibrium": Outputs.from_names(["energy", "equilibrium"]),
    "default (+ caging)": Outputs(),
    "+ forces": Outputs(forces=True),
}


def run_one(effects, outputs, h):
    started = time.perf_counter()
    for design, part in MAPS:
        if not effects.friction:
            part = Part(part.r, 0.0)
        compute_map(design, part, grid=Grid(h=h), effects=effects, outputs=outputs)
    return (time.perf_counter() - started) / len(MAPS)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--h", type=float, default=0.05)
    ap.add_argument("--repeats", type=int, default=3)
    args = ap.parse_args()
    combos = [(e, o) for e in EFFECTS for o in OUTPUTS  # forces with springs or tip: refused
              if not ((EFFECTS[e].joint_springs or EFFECTS[e].tip_contact) and OUTPUTS[o].forces)]
    for e, o in combos:  # compile or load every specialisation before timing
        run_one(EFFECTS[e], OUTPUTS[o], 0.5)
    times = {c: [] for c in combos}
    for _ in range(args.repeats):
        for e, o in combos:
            times[(e, o)].append(run_one(EFFECTS[e], OUTPUTS[o], args.h))
    base = statistics.median(times[("base (friction)", "default (+ caging)")])
    print(f"h = {args.h}, {args.repeats} repeats, median ms per map over {len(MAPS)} maps; "
          f"{platform.processor() or platform.machine()}, {os.cpu_count()} cores, "
          f"NUMBA_NUM_THREADS={os.environ.get('NUMBA_NUM_THREADS', 'all')}\n")
    print("| effects | " + " | ".join(OUTPUTS) + " |")
    print("|---|" + "---|" * len(OUTPUTS))
    for e in EFFECTS:
        cells = []
        for o in OUTPUTS:
            if (e, o) not in times:
                cells.append("n/a")
                continue
            t = statistics.median(times[(e, o)])
            cells.append(f"{t * 1e3:.1f} ({t / base:.2f})")
        print(f"| {e} | " + " | ".join(cells) + " |")
    print("\nall repeats (ms):")
    for c, ts in times.items():
        print(f"  {c[0]:22s} {c[1]:22s} " + " ".join(f"{t * 1e3:.1f}" for t in ts))


if __name__ == "__main__":
    main()
