"""What `sweep schedule` (variable geometry in the grasp, MODEL 12) costs against the screening of
the same scene.

In one process, the order rotating every round: the screening of the store's scene (its config's
every work item, as `sweep run` computes them: `runner.run_range` into a fresh work directory,
the manipulation metric included when the config has it; no refinement, no store written) and
`sweep schedule STORE` with its defaults (or --ladder, --chassis; a fresh results file and work
directory each round). The store must be refined for the parts' best chassis (`make run`
writes results/paper.h5 and results/paper-collision.h5 so). Kernels are compiled or loaded
first. Prints every repeat, the medians and the ratio schedule / screening: `make run` takes the
schedules in only at 0.2x or less (issue P22).
"""
from __future__ import annotations

import shutil
import tempfile
from pathlib import Path

from .timing import header, print_side_by_side, side_by_side, timed

NAME = "schedule"
ROOT = Path(__file__).resolve().parents[2]


def add_arguments(ap) -> None:
    ap.add_argument("store", type=Path, nargs="?", default=ROOT / "results" / "paper.h5",
                    help="a refined results store [results/paper.h5]")
    ap.add_argument("--repeats", type=int, default=1, help="rounds [1]")
    ap.add_argument("--ladder", default=None, help="sweep schedule's --ladder [its default]")
    ap.add_argument("--chassis", action="append", default=None, metavar="L1,L2",
                    help="sweep schedule's --chassis (repeatable) [its default]")


def run(args) -> int:
    from sweep.compute.warm import ensure_compiled
    from sweep.config.parse import scene_from_frozen
    from sweep.runs.runner import run_range
    from sweep.runs.schedule import DEFAULT_CHASSIS, ScheduleSettings, schedule_store
    from sweep.storage.store import read_store

    view = read_store(args.store)
    scene = scene_from_frozen(view.frozen)
    parts = [(float(r), float(m)) for r in view.coords["r"] for m in view.coords["mu"]]
    ladder = tuple(float(v) for v in args.ladder.split(",")) if args.ladder else ()
    chassis = (tuple(tuple(float(v) for v in c.split(",")) for c in args.chassis)
               if args.chassis else DEFAULT_CHASSIS)
    settings = ScheduleSettings(ladder, 2, chassis, False)
    header(NAME)
    ensure_compiled()
    work = Path(tempfile.mkdtemp(prefix="bench-schedule-"))
    try:
        def screening():
            parts_dir = work / "screening.parts"
            shutil.rmtree(parts_dir, ignore_errors=True)
            run_range(scene, 0, scene.n_items, parts_dir, progress=False)

        def schedules():
            out = work / "bench.schedule.h5"
            out.unlink(missing_ok=True)
            schedule_store(args.store, out, parts, settings, progress=False, restart=True)

        measure = {"screening": screening, "sweep schedule": schedules}
        times = side_by_side(list(measure), lambda name: timed(measure[name]), args.repeats)
    finally:
        shutil.rmtree(work, ignore_errors=True)
    ladder = ", ".join(f"{h:g}" for h in settings.resolved(scene.h).ladder)
    named = ", ".join(f"{a:g},{b:g}" for a, b in chassis)
    print_side_by_side(f"the screening of {args.store.name} ({scene.name}: {scene.n_maps:,} "
                       f"maps at h = {scene.h:g}) and sweep schedule ({len(parts)} parts on "
                       f"their best chassis and {named}, ladder {ladder})", times)
    return 0
