"""Time per map of each combination of effects and outputs, on the same maps, in one run.

Three maps of different size (the issue's reference design and two others, as in `bench.py
baseline`), at --h. Every combination is compiled or loaded from the cache first; then
--repeats rounds time every combination once (the order rotating every round). Prints a
Markdown table of the median milliseconds per map (sum over the three maps / 3), in brackets
the ratio to the base scene with the default outputs, then every repeat. "n/a": forces with
joint springs or tip contact are refused by the model.
"""
from __future__ import annotations

import statistics

from .timing import header, side_by_side, timed
from .workloads import THREE_MAPS

NAME = "effects"


def add_arguments(ap) -> None:
    ap.add_argument("--h", type=float, default=0.05, help="grid spacing [0.05]")
    ap.add_argument("--repeats", type=int, default=3, help="rounds [3]")


def run(args) -> int:
    from sweep.compute.maps import compute_map
    from sweep.model import Design, Effects, Grid, Outputs, Part

    springs = dict(joint_springs=True, spring_k1=0.005, spring_k2=0.005)  # < F r / range for all
    effects = {
        "base (friction)": Effects(),
        "frictionless": Effects(friction=False),
        "joint_springs": Effects(**springs),
        "finger_collision": Effects(finger_collision=True),
        "springs + collision": Effects(finger_collision=True, **springs),
        "tip_contact": Effects(tip_contact=True),
        "tip + collision": Effects(tip_contact=True, finger_collision=True),
        "tip + springs + collision": Effects(tip_contact=True, finger_collision=True, **springs),
    }
    outputs = {
        "energy": Outputs.from_names(["energy"]),
        "energy, equilibrium": Outputs.from_names(["energy", "equilibrium"]),
        "default (+ caging)": Outputs(),
        "+ forces": Outputs(forces=True),
    }
    maps = [(Design(*d), Part(*p)) for d, p in THREE_MAPS]

    def one_round(e, o, h):
        for design, part in maps:
            if not effects[e].friction:
                part = Part(part.r, 0.0)
            compute_map(design, part, grid=Grid(h=h), effects=effects[e], outputs=outputs[o])

    combos = [f"{e} | {o}" for e in effects for o in outputs  # forces with springs or tip: refused
              if not ((effects[e].joint_springs or effects[e].tip_contact) and outputs[o].forces)]
    header(NAME)
    for c in combos:  # compile or load every specialisation before timing
        one_round(*c.split(" | "), 0.5)
    times = side_by_side(combos, lambda c: timed(lambda: one_round(*c.split(" | "), args.h)),
                         args.repeats)
    per_map = {c: statistics.median(t[0] for t in ts) / len(maps) for c, ts in times.items()}
    base = per_map["base (friction) | default (+ caging)"]
    print(f"\nh = {args.h}, {args.repeats} repeats, median ms per map over {len(maps)} maps "
          "(ratio to the base scene, default outputs)\n")
    print("| effects | " + " | ".join(outputs) + " |")
    print("|---|" + "---|" * len(outputs))
    for e in effects:
        row = []
        for o in outputs:
            t = per_map.get(f"{e} | {o}")
            row.append("n/a" if t is None else f"{t * 1e3:.1f} ({t / base:.2f})")
        print(f"| {e} | " + " | ".join(row) + " |")
    print("\nall repeats (ms per map):")
    for c, ts in times.items():
        e, o = c.split(" | ")
        print(f"  {e:26s} {o:20s} " + " ".join(f"{t[0] / len(maps) * 1e3:.1f}" for t in ts))
    return 0
