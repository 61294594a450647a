"""Mutation testing: does the test suite notice a small wrong change of the kernels (or of the code
that stores, refines, optimises and reports their results)?

    .venv/bin/python scripts/mutants.py                 # every mutant of scripts/mutants.yaml
    .venv/bin/python scripts/mutants.py --only hull-coincide-tolerance path-tie-to-slip
    .venv/bin/python scripts/mutants.py --list          # the mutants, nothing run
    .venv/bin/python scripts/mutants.py --markdown out.md   # also the results as a table

The mutants are data (`scripts/mutants.yaml`): a kernel module (or, with a slash, a module of
`sweep/`, e.g. `runs/refine.py`), an exact piece of its text (which must occur exactly once), its
replacement, what it means, optionally the tests that must notice it (`tests:`, instead of the
fast kernel tests: the tests that watch that module's results) and, for a mutant that cannot
change any result, the proof (`equivalent:`). Add entries there when kernels change.

Each mutant runs in its own copy of the package and the tests (the working tree is never
touched), with a fresh Numba cache (NUMBA_CACHE_DIR set to a new empty folder, so every kernel
is compiled from the mutated source; a mutant outside the kernels' sources is given one cache of
the unmutated kernels, though Numba keys its cache directory by the sources' paths, so each copy
compiles anew all the same) and `pytest -x` on the fast kernel tests (FAST_TESTS). The
installed package is an editable install whose import hook would load the working tree's
`sweep`; the runner removes that hook so the copy is imported. A mutant is *killed* when a test
fails, errors or times out, and *survives* when the tests pass. The unmutated copy runs first
and must pass. Exit code: 0 when every survivor is marked equivalent, else 1.
"""
from __future__ import annotations

import argparse
import os
import re
import shutil
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

import yaml

ROOT = Path(__file__).resolve().parents[1]
KERNELS = "sweep/kernels"
MUTANTS_FILE = Path(__file__).with_name("mutants.yaml")
#: The fast kernel tests: kernels against independent references, analytic cases, invariants
#: and the accepted-space properties, quickest first (`-x` stops a killed mutant's run at its
#: first failure; each mutant compiles its kernels first).
FAST_TESTS = ("tests/test_kernel_edges.py", "tests/test_hull.py", "tests/test_analytic.py",
              "tests/test_reference.py", "tests/test_invariants.py", "tests/test_forces.py",
              "tests/test_golden.py", "tests/test_closing_bruteforce.py",
              "tests/test_trajectory_methods.py", "tests/test_sliding.py",
              "tests/test_tip_contact.py",
              "tests/test_collision.py", "tests/test_springs.py",
              "tests/test_naive_manipulation.py", "tests/test_manipulation.py",
              "tests/test_accepted_space.py", "tests/test_slide_memo.py")
#: What a mutant's run needs besides the package (tests read configs and docs; test_golden
#: imports scripts/golden.py).
COPIED = ("sweep", "tests", "configs", "docs", "scripts", "pyproject.toml")
TIMEOUT_SECONDS = 1800

# Run pytest with the copy's `sweep` importable: drop the editable install's import hook first.
BOOTSTRAP = """
import sys
sys.meta_path[:] = [f for f in sys.meta_path
                    if "editable" not in str(getattr(f, "__module__", "")).lower()]
sys.path.insert(0, sys.argv[1])
import pytest
import sweep
assert sweep.__file__.startswith(sys.argv[1]), sweep.__file__
sys.exit(pytest.main(sys.argv[2:]))
"""


@dataclass
class Mutant:
    name: str
    file: str           # module of sweep/kernels
    find: str           # exact text, occurring once
    replace: str
    note: str
    equivalent: str = ""  # why it cannot change any result (then a survivor is expected)
    tests: tuple = ()     # the tests that must notice it (default: FAST_TESTS)

    def __post_init__(self):
        self.tests = tuple(self.tests or ())

    @property
    def path(self) -> str:
        """A kernel module by its name; another module of the package by its path in sweep/."""
        return f"sweep/{self.file}" if "/" in self.file else f"{KERNELS}/{self.file}"


def load_mutants(path: Path = MUTANTS_FILE) -> list[Mutant]:
    entries = yaml.safe_load(path.read_text())
    out = [Mutant(**e) for e in entries]
    names = [m.name for m in out]
    dup = {n for n in names if names.count(n) > 1}
    if dup:
        raise SystemExit(f"{path}: duplicate mutant names {sorted(dup)}")
    return out


def check_applicable(m: Mutant, root: Path = ROOT) -> str | None:
    """None if the mutant applies to the current source, else why not."""
    text = (root / m.path).read_text()
    n = text.count(m.find)
    if n != 1:
        return f"its text occurs {n} times in {m.path} (must be once)"
    if m.find == m.replace:
        return "find and replace are the same"
    return None


def make_copy(dest: Path, mutant: Mutant | None) -> None:
    for name in COPIED:
        src = ROOT / name
        if src.is_dir():
            shutil.copytree(src, dest / name, ignore=shutil.ignore_patterns(
                "__pycache__", "*.nbi", "*.nbc", ".pytest_cache"))
        else:
            shutil.copy2(src, dest / name)
    if mutant is not None:
        target = dest / mutant.path
        text = target.read_text()
        target.write_text(text.replace(mutant.find, mutant.replace, 1))


def changes_kernels(m: Mutant) -> bool:
    """Whether a mutant changes a file the kernels' cache is keyed by (kernels/__init__.py):
    then its kernels compile anew; the others share one cache (their kernels are the same)."""
    return m.path.startswith(KERNELS) or m.path in ("sweep/model.py", "sweep/schema.py")


def run_tests(copy: Path, tests, timeout: int, cache: Path | None = None
              ) -> tuple[str, str, float]:
    """(outcome, detail, seconds): outcome 'passed', 'failed' or 'timeout'. `cache`: a Numba
    cache to share (default: a new empty one in the copy)."""
    cache = cache or Path(tempfile.mkdtemp(prefix="numba-cache-", dir=copy))
    env = {**os.environ, "NUMBA_CACHE_DIR": str(cache), "PYTHONDONTWRITEBYTECODE": "1"}
    env.pop("PYTHONPATH", None)
    args = [sys.executable, "-c", BOOTSTRAP, str(copy), "-x", "-q", "-p", "no:cacheprovider",
            "--no-header", "-rfE", *tests]
    started = time.perf_counter()
    try:
        res = subprocess.run(args, cwd=copy, env=env, capture_output=True, text=True,
                             timeout=timeout)
    except subprocess.TimeoutExpired:
        return "timeout", f"no result in {timeout} s", time.perf_counter() - started
    seconds = time.perf_counter() - started
    if res.returncode == 0:
        return "passed", "", seconds
    failed = re.findall(r"^(?:FAILED|ERROR) (\S+)", res.stdout, re.M)
    detail = failed[0] if failed else (res.stdout + res.stderr).strip().splitlines()[-1:]
    return "failed", detail if isinstance(detail, str) else " ".join(detail), seconds


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--only", nargs="*", default=None, help="mutant names to run, in this order")
    ap.add_argument("--list", action="store_true", help="list the mutants and exit")
    ap.add_argument("--tests", nargs="*", default=None, help="test files (default FAST_TESTS)")
    ap.add_argument("--timeout", type=int, default=TIMEOUT_SECONDS)
    ap.add_argument("--skip-baseline", action="store_true",
                    help="do not run the unmutated copy first")
    ap.add_argument("--markdown", type=Path, default=None, help="write the results table here")
    args = ap.parse_args(argv)

    mutants = load_mutants()
    if args.only:
        unknown = set(args.only) - {m.name for m in mutants}
        if unknown:
            raise SystemExit(f"unknown mutants: {sorted(unknown)}")
        by_name = {m.name: m for m in mutants}
        mutants = [by_name[n] for n in dict.fromkeys(args.only)]  # in the order given
    stale = [(m, why) for m in mutants if (why := check_applicable(m))]
    for m, why in stale:
        print(f"STALE {m.name}: {why}", file=sys.stderr)
    if stale:
        return 2
    modules = sorted({m.file for m in mutants})
    print(f"{len(mutants)} mutants over {len(modules)} modules: {', '.join(modules)}")
    if args.list:
        for m in mutants:
            print(f"  {m.name:<34} {m.file:<14} {m.note}")
        return 0
    default = args.tests or [t for t in FAST_TESTS if (ROOT / t).exists()]

    def tests_of(m: Mutant) -> list:
        return list(args.tests or m.tests or default)

    results = []
    with tempfile.TemporaryDirectory(prefix="sweep-mutants-") as work:
        work = Path(work)
        shared = work / "numba-cache-shared"   # the unmutated kernels, compiled once
        shared.mkdir()
        if not args.skip_baseline:
            copy = work / "baseline"
            copy.mkdir()
            make_copy(copy, None)
            every = list(dict.fromkeys(t for m in mutants for t in tests_of(m)))
            outcome, detail, seconds = run_tests(copy, every, args.timeout, shared)
            shutil.rmtree(copy, ignore_errors=True)
            print(f"baseline (no mutant): {outcome} in {seconds:.0f} s {detail}", flush=True)
            if outcome != "passed":
                return 2
        for k, m in enumerate(mutants, 1):
            copy = work / f"m{k:03d}"
            copy.mkdir()
            make_copy(copy, m)
            outcome, detail, seconds = run_tests(copy, tests_of(m), args.timeout,
                                                 None if changes_kernels(m) else shared)
            shutil.rmtree(copy, ignore_errors=True)
            status = "survived" if outcome == "passed" else "killed"
            results.append((m, status, detail, seconds))
            print(f"[{k}/{len(mutants)}] {m.name}: {status} ({outcome}, {seconds:.0f} s) {detail}",
                  flush=True)

    killed = sum(s == "killed" for _, s, _, _ in results)
    bad = [m for m, s, _, _ in results if s == "survived" and not m.equivalent]
    eq = [m for m, s, _, _ in results if s == "survived" and m.equivalent]
    print(f"\n{killed} killed, {len(results) - killed} survived ({len(eq)} equivalent, "
          f"{len(bad)} not) of {len(results)} mutants")
    for m in bad:
        print(f"  SURVIVED (needs a test): {m.name} ({m.path}): {m.note}")
    if args.markdown:
        lines = ["| mutant | module | change | result | killed by |", "|---|---|---|---|---|"]
        for m, s, detail, _ in results:
            note = m.note + (f" (equivalent: {m.equivalent})" if m.equivalent else "")
            lines.append(f"| `{m.name}` | `{m.file}` | {note} | {s} | "
                         f"{('`' + detail + '`') if s == 'killed' and detail else ''} |")
        args.markdown.write_text("\n".join(lines) + "\n")
    return 0 if not bad else 1


if __name__ == "__main__":
    sys.exit(main())
