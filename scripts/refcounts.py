"""How many reference-count calls (NRT_incref, NRT_decref) the sweep's kernels make, and which
kernel makes them: every call counted, not sampled (docs/performance-log.md, 2026-11-27 night).

    .venv/bin/python scripts/refcounts.py [--cells 8] [--collision]

A worker process compiles the kernels in a private empty cache (so that each function's address
is known: a cached kernel is loaded as object code), then waits; gdb attaches to it with a
breakpoint on NRT_incref and NRT_decref that records the return address and goes on; the worker
runs the paper-sweep sample (the first `--cells` of profile_kernels' 64 cells of the paper's
table x its 6 widths, summaries, one thread) and exits; each call is then charged to the kernel
whose code holds its return address.
An array handed to a kernel that can fail (any call Numba does not inline) keeps a reference
count pair, and a record of arrays (a tuple) one pair per array: the table says where. Needs gdb;
about two minutes (the compilation), then a few seconds per thousand calls counted.
"""
from __future__ import annotations

import argparse
import bisect
import collections
import os
import re
import subprocess
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

GDB_SCRIPT = r'''
import collections, gdb
counts = collections.Counter()
class Count(gdb.Breakpoint):
    def __init__(self, address, name):
        super().__init__("*0x%x" % address, internal=True)
        self.name = name
    def stop(self):
        sp = int(gdb.parse_and_eval("$sp"))
        back = int.from_bytes(gdb.selected_inferior().read_memory(sp, 8).tobytes(), "little")
        counts[(self.name, back)] += 1
        return False
for line in open(MAP):
    address, name = line.split(maxsplit=1)
    if name.strip() in ("NRT_incref", "NRT_decref"):
        Count(int(address, 16), name.strip())
def done(event):
    with open(OUT, "w") as f:
        for (name, back), n in counts.items():
            f.write("%s %x %d\n" % (name, back, n))
gdb.events.exited.connect(done)
open(GO, "w").close()
gdb.execute("continue")
'''


def worker(args, folder: Path) -> int:
    os.environ["NUMBA_CACHE_DIR"] = str(folder / "numba-cache")
    import numba
    from benchmarks.workloads import paper_sample, paper_widths
    from profile_kernels import perf_map_entries
    from sweep.compute.batch import summarize_cells
    from sweep.model import Accuracy, Command, Effects, Limits

    numba.set_num_threads(1)
    cells, widths = paper_sample(64)[:args.cells], paper_widths()   # profile_kernels' sample
    effects = Effects(finger_collision=args.collision)
    accuracy = Accuracy(reconfig_step=0.05)   # the paper configs' step

    def sweep_sample(rows):
        summarize_cells(rows, widths, Command(), 0.05, Limits(), accuracy, effects)

    sweep_sample(cells[:1])   # compiles
    with open(folder / "map.txt", "w") as f:
        for address, name in perf_map_entries():
            f.write(f"{address:x} {name}\n")
    (folder / "ready").write_text(str(os.getpid()))
    while not (folder / "go").exists():   # gdb attached, breakpoints set
        time.sleep(0.2)
    sweep_sample(cells)
    return 0


def kernel_name(symbol: str) -> str:
    """`module.function` of a Numba symbol (_ZN5sweep7kernels4hand19part_in_equilibriumB...)."""
    if not symbol.startswith("_ZN"):
        return symbol[:60]
    rest, names = symbol[3:], []
    while (m := re.match(r"\d+", rest)):
        n, start = int(m.group()), len(m.group())
        names.append(rest[start:start + n])
        rest = rest[start + n:]
    return ".".join(names[2:] if names[:2] == ["sweep", "kernels"] else names) or symbol[:60]


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--cells", type=int, default=8, help="cells of the sample (at most 64) [8]")
    parser.add_argument("--collision", action="store_true", help="with finger_collision")
    parser.add_argument("--worker", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.worker:
        return worker(args, Path(args.worker))
    folder = Path(tempfile.mkdtemp(prefix="refcounts-"))
    argv = [sys.executable, __file__, "--worker", str(folder), "--cells", str(args.cells)]
    process = subprocess.Popen(argv + (["--collision"] if args.collision else []))
    while not (folder / "ready").exists():
        if process.poll() is not None:
            print("the worker stopped before it was ready", file=sys.stderr)
            return 1
        time.sleep(0.5)
    script = folder / "count.py"
    script.write_text(f"MAP = {str(folder / 'map.txt')!r}\nOUT = {str(folder / 'hits.txt')!r}\n"
                      f"GO = {str(folder / 'go')!r}\n" + GDB_SCRIPT)
    subprocess.run(["gdb", "-q", "-batch", "-p", str(process.pid), "-x", str(script)],
                   stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, check=False)
    process.wait()
    entries = sorted((int(a, 16), n.strip()) for a, n in
                     (line.split(maxsplit=1) for line in open(folder / "map.txt")))
    starts = [a for a, _ in entries]
    by_kernel: collections.Counter = collections.Counter()
    for line in open(folder / "hits.txt"):
        name, back, n = line.split()
        k = bisect.bisect_right(starts, int(back, 16)) - 1
        by_kernel[(kernel_name(entries[k][1]) if k >= 0 else "?", name)] += int(n)
    total = sum(by_kernel.values())
    maps = args.cells * 6
    print(f"{total:,} reference-count calls for {maps} maps ({total / maps:,.0f} per map), "
          f"{'finger_collision' if args.collision else 'base scene'}")
    for (kernel, name), n in by_kernel.most_common(20):
        print(f"{n:>10,}  {name:<11} {kernel}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
