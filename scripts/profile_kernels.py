"""Where the sweep's time goes inside the kernels: `perf record` of the paper-sweep sample with
the jitted functions named (docs/performance-log.md, "Where the sweep's time goes").

    .venv/bin/python scripts/profile_kernels.py [--cells 64] [--collision] [--out perf.data]
    perf report -i perf.data --no-children --sort sym

perf cannot name code Numba compiled at run time; this script compiles the kernels in a private
empty cache (so each function's LLVM module is at hand: a cached kernel is loaded as object
code), writes /tmp/perf-PID.map (each defined function's address, its size up to the next
one), then records only the timed repeats (perf attaches to this process). Inlined callees are
counted in their caller. Needs Linux perf (`perf` on PATH) and about a minute to compile.
"""
from __future__ import annotations

import argparse
import gc
import os
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))


def perf_map_entries() -> list[tuple[int, str]]:
    """(address, name) of every function defined in every compiled kernel's library."""
    from numba.core.registry import CPUDispatcher

    entries = set()
    for obj in gc.get_objects():
        if not isinstance(obj, CPUDispatcher):
            continue
        for cres in obj.overloads.values():
            module = getattr(cres.library, "_final_module", None)
            if module is None:
                continue
            for fn in module.functions:
                if fn.is_declaration:
                    continue
                address = cres.library.get_pointer_to_function(fn.name)
                if address:
                    entries.add((address, fn.name))
    return sorted(entries)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--cells", type=int, default=64, help="paper cells in the sample [64]")
    parser.add_argument("--repeats", type=int, default=3, help="timed repeats recorded [3]")
    parser.add_argument("--collision", action="store_true", help="with finger_collision")
    parser.add_argument("--out", default="perf.data", help="perf's output file [perf.data]")
    args = parser.parse_args()
    if "NUMBA_CACHE_DIR" not in os.environ:  # (before numba is imported)
        os.environ["NUMBA_CACHE_DIR"] = tempfile.mkdtemp(prefix="profile-kernels-")

    import numba

    from benchmarks.workloads import paper_sample, paper_widths
    from sweep.compute.batch import summarize_cells
    from sweep.model import Accuracy, Command, Effects, Limits

    numba.set_num_threads(1)
    cells, widths = paper_sample(args.cells), paper_widths()
    effects = Effects(finger_collision=args.collision)
    accuracy = Accuracy(reconfig_step=0.05)   # the paper configs' step

    def sweep_sample(rows):
        summarize_cells(rows, widths, Command(), 0.05, Limits(), accuracy, effects)

    sweep_sample(cells[:2])   # compiles
    entries = perf_map_entries()
    if not entries:
        print("no compiled kernel found (loaded from a cache?): set NUMBA_CACHE_DIR to an empty "
              "folder", file=sys.stderr)
        return 1
    with open(f"/tmp/perf-{os.getpid()}.map", "w") as f:
        for k, (address, name) in enumerate(entries):
            size = entries[k + 1][0] - address if k + 1 < len(entries) else 4096
            f.write(f"{address:x} {size:x} {name}\n")
    perf = subprocess.Popen(["perf", "record", "-F", "999", "-o", args.out, "-p",
                             str(os.getpid())], stderr=subprocess.DEVNULL)
    time.sleep(1.5)   # perf attached
    started = time.perf_counter()
    for _ in range(args.repeats):
        sweep_sample(cells)
    seconds = time.perf_counter() - started
    perf.send_signal(signal.SIGINT)
    perf.wait()
    print(f"{len(entries)} functions named; {args.repeats} x {cells.shape[0]} cells x "
          f"{widths.size} widths in {seconds:.2f} s; perf report -i {args.out} --no-children "
          "--sort sym")
    return 0


if __name__ == "__main__":
    sys.exit(main())
