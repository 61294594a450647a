"""What every benchmark prints and how it times: the header (date, machine, command), side-by-side
timing in rounds whose order rotates, medians and ratios measured in one run."""
from __future__ import annotations

import math
import os
import platform
import shlex
import statistics
import sys
import time
from typing import Callable


def machine() -> str:
    cpu = "unknown cpu"
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                if line.startswith("model name"):
                    cpu = line.split(":", 1)[1].strip()
                    break
    except OSError:
        pass
    return (f"{platform.node()} | {cpu} | {os.cpu_count()} cores | "
            f"Python {platform.python_version()}")


def header(subcommand: str) -> None:
    """The first lines of every benchmark's output: what, when, where, the exact command."""
    threads = os.environ.get("NUMBA_NUM_THREADS", "all cores")
    print(f"# bench.py {subcommand}, {time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}")
    print(f"# machine: {machine()}; NUMBA_NUM_THREADS={threads}; "
          f"load average {' '.join(f'{x:.1f}' for x in os.getloadavg())}")
    print(f"# command: {shlex.join([os.path.relpath(sys.argv[0]), *sys.argv[1:]])}", flush=True)


def best_of(fn: Callable[[], object], repeat: int = 3) -> float:
    best = math.inf
    for _ in range(repeat):
        started = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - started)
    return best


def timed(fn: Callable[[], object]) -> tuple[float, float]:
    """(wall seconds, CPU seconds of this process over all its threads) of one call."""
    wall, cpu = time.perf_counter(), time.process_time()
    fn()
    return time.perf_counter() - wall, time.process_time() - cpu


def side_by_side(names: list[str], measure: Callable[[str], tuple[float, float]],
                 repeats: int) -> dict[str, list[tuple[float, float]]]:
    """`repeats` rounds, each measuring every name once; the order rotates every round (A B C,
    B C A, C A B, ...; for two names: swapped every round), so that the machine's drift affects
    all alike. `measure(name)` returns (wall, cpu) seconds."""
    times: dict[str, list[tuple[float, float]]] = {name: [] for name in names}
    for k in range(repeats):
        shift = k % len(names)
        for name in names[shift:] + names[:shift]:
            times[name].append(measure(name))
    return times


def medians(times: dict[str, list[tuple[float, float]]]) -> dict[str, tuple[float, float]]:
    return {name: (statistics.median(t[0] for t in ts), statistics.median(t[1] for t in ts))
            for name, ts in times.items()}


def print_side_by_side(label: str, times: dict[str, list[tuple[float, float]]]) -> None:
    """Medians (wall and CPU), every repeat's wall seconds, and each name's ratio to the first."""
    med = medians(times)
    first = next(iter(med))
    print(f"\n## {label}")
    for name, (wall, cpu) in med.items():
        print(f"- {name}: median {wall:.3f} s (cpu {cpu:.3f} s); all "
              + ", ".join(f"{t[0]:.3f}" for t in times[name]))
    for name, (wall, cpu) in list(med.items())[1:]:
        print(f"- ratio {name} / {first}: {wall / med[first][0]:.3f} "
              f"(cpu {cpu / med[first][1]:.3f})")
    sys.stdout.flush()
