"""Bad input found by machines (issue P13): a fuzz campaign over every way into the CLI.

Every command of the click tree (found by introspection, so new commands are covered without
changes here) is run in-process with generated inputs:

- every path argument and path option: each kind of `fuzz_cli.PATH_KINDS` (missing, a file
  where a directory is expected and the reverse, unreadable, unwritable, a map where a store is
  expected and the reverse, truncated or foreign HDF5, a symlink loop, ...);
- every option that takes a value, across and beyond its range (NaN, inf, signs, zero, huge and
  tiny numbers, text where a number is expected, unicode); `sweep map` gets its own generator
  (designs, parts, tensions, limits, accuracy, windows and ranges that leave nothing to compute,
  effects and outputs);
- configs: YAML trees derived from the schema with keys dropped, added and renamed, wrong
  types, special numbers, long lists, unicode, undecodable bytes, empty and binary files.

Each case ends in exit 0 with a meaningful result (every file it says it wrote exists; a map
with no point where a finger touches the part says so in a warning line), or in exit 2 with one
line that names the input, with nothing written or changed; never a traceback
(`fuzz_cli.check_outcome`).

Profiles: `make test` runs a bounded, derandomised profile (BOUNDED examples per test, about
half a minute in all with compiled kernels). `SWEEP_LONG_FUZZ=1` (`make test-long`,
tests/profiles.py) runs the long one: random examples,
SWEEP_LONG_FUZZ_CASES in all (default 23,000: commands with few path parameters exhaust their
cases early, and issue P13 asks for 20,000 run), shared across the tests in proportion to their
weights; the count of cases run is printed at the end (docs/sweeps.md, "Fuzz campaign").
"""
from __future__ import annotations

import itertools
import math
import os
import shutil
import subprocess
import sys
import re
import tempfile
import time
from collections import Counter
from pathlib import Path

import click
import click.types as click_types
import h5py
import numpy as np
import pytest
import yaml
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

import fuzz_cli as fz
from profiles import EXPLORE
from sweep.cli import main
from sweep.model import EFFECT_NAMES, OUTPUT_NAMES, ModelInputError
from sweep.config.parse import load_scene
from sweep.config.scene import grid_points

LONG = os.environ.get("SWEEP_LONG_FUZZ", "") not in ("", "0")
LONG_CASES = int(os.environ.get("SWEEP_LONG_FUZZ_CASES", "23000"))
COMMANDS = fz.commands(main)
#: Relative weight of each test in the long profile (cases = LONG_CASES * weight / total).
WEIGHTS = {"paths": 8, "options": 4, "map": 6, "config_load": 8, "config_cli": 3,
           "wrong_kinds": 2}
#: Examples per test in make test (derandomised); make test-long runs the long profile.
BOUNDED = {"paths": 6, "options": 3, "map": 40, "config_load": 60, "config_cli": 4,
           "wrong_kinds": 2}


def profile(test: str, commands: int = 1):
    """Settings of one test; `commands`: how many commands the test is parametrized over (its
    share of the long profile is split between them)."""
    if LONG:
        n = LONG_CASES * WEIGHTS[test] // sum(WEIGHTS.values()) // commands
        return settings(max_examples=max(n, 1), deadline=None, derandomize=not EXPLORE,
                        suppress_health_check=list(HealthCheck), database=None)
    return settings(max_examples=BOUNDED[test], deadline=None, derandomize=True,
                    suppress_health_check=list(HealthCheck), database=None)


OUTCOMES: Counter = Counter()


@pytest.fixture(scope="module", autouse=True)
def report_counts(request):
    yield
    total = sum(OUTCOMES.values())
    line = (f"fuzz campaign: {total:,} cases ("
            + ", ".join(f"{k} {v:,}" for k, v in sorted(OUTCOMES.items())) + ")")
    if not hasattr(request.config, "sweep_summary_lines"):
        request.config.sweep_summary_lines = []
    request.config.sweep_summary_lines.append(line)
    if os.environ.get("SWEEP_FUZZ_COUNT_FILE"):
        Path(os.environ["SWEEP_FUZZ_COUNT_FILE"]).write_text(line + "\n")


@pytest.fixture(scope="module")
def base():
    """A world-traversable folder (permission cases run as `nobody` when the tests run as
    root) holding the artefact library and one folder per case."""
    root = Path(tempfile.mkdtemp(prefix="sweep-fuzz-"))
    root.chmod(0o755)
    yield root
    fz.reset_modes(root)
    shutil.rmtree(root, ignore_errors=True)


@pytest.fixture(scope="module")
def lib(base):
    return fz.Library.build(main, base / "lib")


class CaseDirs:
    def __init__(self, base: Path):
        self.base = base
        self.n = 0

    def new(self) -> Path:
        self.n += 1
        d = self.base / f"case-{self.n}"
        d.mkdir()
        d.chmod(0o777)
        return d

    def done(self, d: Path) -> None:
        fz.reset_modes(d)
        shutil.rmtree(d, ignore_errors=True)


@pytest.fixture(scope="module")
def cases(base):
    return CaseDirs(base)


# ---------------------------------------------------------------------------------------------
# Baselines: path kinds that make each command succeed
# ---------------------------------------------------------------------------------------------
#: Values for required options that are not paths, by option name; else by type.
KNOWN_VALUES = {"l1": "0.8", "l2": "0.4", "r1": "0.12", "r2": "0.06", "w": "0.4", "r": "0.4",
                "mu": "0.4", "h": "0.2", "chunks": "1"}


def required_values(cmd: fz.Command) -> list[str]:
    out = []
    for p in cmd.options:
        if not p.required:
            continue
        if p.name in KNOWN_VALUES:
            value = KNOWN_VALUES[p.name]
        elif isinstance(p.type, click_types.IntRange) and p.type.min is not None:
            value = str(p.type.min)
        elif isinstance(p.type, click_types.IntParamType):
            value = "1"
        elif isinstance(p.type, click_types.FloatParamType):
            value = "1.0"
        else:
            value = "x"
        out += [fz.opt_name(p), value]
    return out


ARG_CANDIDATES = ("config", "store", "rundir", "map", "shard")
OPT_CANDIDATES = ("new-file", "new-dir", "new-png", "config", "store", "rundir")


def build_args(cmd: fz.Command, kinds: dict, case: Path, lib, extra=()) -> tuple[list, list]:
    """Command line for path kinds {param name: kind} (params absent from `kinds` are left
    out), plus `extra` option words; and the names an error line may use."""
    positional, options, names = [], [], []
    for p in cmd.paths:
        if p.name not in kinds:
            continue
        value = fz.make_path(kinds[p.name], case, lib, p.name)
        names += fz.names_of(value, p)
        if isinstance(p, click.Argument):
            positional.append(value)
        else:
            options += [fz.opt_name(p), value]
    return [*cmd.words, *positional, *required_values(cmd), *options, *extra], names


def search_baseline(cmd: fz.Command, lib, cases: CaseDirs) -> dict | None:
    """The first combination of candidate kinds for the required path parameters that
    succeeds (exit 0); None if none does."""
    import itertools

    required = [p for p in cmd.paths if p.required]
    pools = [ARG_CANDIDATES if not isinstance(p, click.Option) else OPT_CANDIDATES
             for p in required]
    for combo in itertools.product(*pools):
        kinds = {p.name: k for p, k in zip(required, combo)}
        case = cases.new()
        args, _ = build_args(cmd, kinds, case, lib, quiet_flags(cmd))
        res = fz.invoke(main, args, cwd=case)
        cases.done(case)
        if res.exit_code == 0:
            return kinds
    return None


def quiet_flags(cmd: fz.Command) -> list[str]:
    return ["--no-progress"] if any("--no-progress" in p.secondary_opts for p in cmd.flags) \
        else []


@pytest.fixture(scope="module")
def baselines(lib, cases):
    return {c.name: search_baseline(c, lib, cases) for c in COMMANDS}


def test_every_command_is_found_and_has_a_working_baseline(baselines):
    """Introspection finds the commands (and their path parameters), and each one has inputs
    it accepts: a fuzz case then changes one input at a time."""
    names = {c.name for c in COMMANDS}
    assert {"map", "run", "merge", "show", "status", "top", "report", "slurm"} <= names
    missing = [name for name, kinds in baselines.items() if kinds is None]
    assert not missing, f"no working baseline for {missing}"
    by_name = {c.name: c for c in COMMANDS}
    assert [p.name for p in by_name["merge"].paths] == ["directory", "out"]
    assert "config" in [p.name for p in by_name["run"].paths]


def run_case(cmd, kinds, extra, lib, cases, label, **check):
    case = cases.new()
    try:
        args, names = build_args(cmd, kinds, case, lib, extra)
        names += [w for w in extra if w.startswith("-")]
        needs_nobody = any(k in fz.PERMISSION_KINDS for k in kinds.values())
        before = fz.snapshot(case)
        with fz.unprivileged(case, needs_nobody):
            res = fz.invoke(main, args, cwd=case)
        after = fz.snapshot(case)
        outcome = fz.check_outcome(fz.Case(cmd, args, names, case), res, before, after, **check)
        OUTCOMES[f"{label}:{outcome}"] += 1
        return res, case, args
    finally:
        cases.done(case)


# ---------------------------------------------------------------------------------------------
# 1. Path arguments of every command
# ---------------------------------------------------------------------------------------------
@pytest.mark.parametrize("name", [c.name for c in COMMANDS])
def test_path_arguments(name, lib, cases, baselines):
    cmd = next(c for c in COMMANDS if c.name == name)
    if not cmd.paths:
        pytest.skip(f"{name} has no path arguments")
    base_kinds = baselines[name]

    @profile("paths", commands=len(COMMANDS))
    @given(data=st.data())
    def check(data):
        wild = data.draw(st.sampled_from(cmd.paths), label="wild parameter")
        kinds = dict(base_kinds)
        kinds[wild.name] = data.draw(st.sampled_from(fz.PATH_KINDS), label="kind")
        if len(cmd.paths) > 1 and data.draw(st.booleans(), label="second"):
            other = data.draw(st.sampled_from(cmd.paths))
            kinds[other.name] = data.draw(st.sampled_from(fz.PATH_KINDS))
        flags = [f for f in cmd.flags if data.draw(st.booleans(), label=f.name)
                 and f.name not in ("progress", "submit")]
        extra = [fz.positive_flag(f) for f in flags] + quiet_flags(cmd)
        res, _, _ = run_case(cmd, kinds, extra, lib, cases, f"paths:{name}")
        wrong = [p for p in cmd.paths if kinds.get(p.name) in fz.wrong_kinds(p)]
        changed = [p for p in cmd.paths if kinds.get(p.name) != base_kinds.get(p.name)]
        if len(wrong) == 1 and changed == wrong:    # one input of the wrong kind: named as such
            assert res.exit_code == 2 and fz.names_its_kind(res.output, kinds[wrong[0].name]), \
                (name, kinds, res.output)

    check()


# ---------------------------------------------------------------------------------------------
# 1b. A path of another kind than the parameter takes, for every parameter and artefact
# ---------------------------------------------------------------------------------------------
KIND_COMMANDS = [c.name for c in COMMANDS if any(fz.param_want(p) for p in c.paths)]


@pytest.mark.parametrize("name", KIND_COMMANDS)
def test_a_path_of_another_kind_is_named(name, lib, cases, baselines):
    """Each path parameter given each artefact of a kind it does not take (a store where a run
    directory is expected and the other way round, a config where a store is, a folder where a
    file is, a file where a folder is, ...), the other inputs at the baseline: exit 2, one line
    that names the input, says what the path is and which command takes it, nothing written.
    Every pair once, without flags; then (more in the long profile) pairs with random flags."""
    cmd = next(c for c in COMMANDS if c.name == name)
    pairs = [(p, kind) for p in cmd.paths for kind in fz.wrong_kinds(p)]
    assert pairs

    def case(p, kind, extra):
        kinds = {**baselines[name], p.name: kind}
        res, _, args = run_case(cmd, kinds, extra + quiet_flags(cmd), lib, cases,
                                f"wrong-kind:{name}")
        assert res.exit_code == 2 and fz.names_its_kind(res.output, kind), (args, res.output)

    for p, kind in pairs:
        case(p, kind, [])

    @profile("wrong_kinds", commands=len(KIND_COMMANDS))
    @given(data=st.data())
    def check(data):
        p, kind = data.draw(st.sampled_from(pairs), label="parameter and kind")
        flags = [f for f in cmd.flags if data.draw(st.booleans(), label=f.name)
                 and f.name not in ("progress", "submit")]
        case(p, kind, [fz.positive_flag(f) for f in flags])

    check()


# ---------------------------------------------------------------------------------------------
# 2. Every option that takes a value, across and beyond its range
# ---------------------------------------------------------------------------------------------
WILD_FLOATS = ("nan", "inf", "-inf", "0", "-0.0", "-1", "1e-300", "5e-324", "1e300", "1.7e308",
               "1e-9", "1e9", "-1e-9", "abc", "", "1,5", "0x10", " 1 ", "1e", "½")
WILD_INTS = ("0", "-1", "1", "2", "3", "1000000000", str(2**63), str(-2**63 - 1), "1.5", "abc",
             "", "1e3", "٣")
WILD_TEXT = ("", " ", "x", "none", "Lambda", "n_caged", "caging_area", "friction",
             "friction,tip_contact", "energy", "energy,equilibrium", "forces", "é✓名", "a\nb",
             "--", "-1", "K=V", "=", "qos=long", "\x00", "a" * 300, "01:00:00", "4G")


def wild_value(p: click.Option):
    t = p.type
    if isinstance(t, click_types.Tuple):
        return st.tuples(*(wild_value_of(s) for s in t.types))
    return wild_value_of(t)


def wild_value_of(t):
    if isinstance(t, click_types.FloatParamType):
        # moderate values too, but none that makes a legitimate request slow (a design 100x
        # the paper's at the default grid step is valid and takes minutes): `sweep map` has
        # its own generator for the ranges in between
        return st.one_of(st.sampled_from(WILD_FLOATS + ("0.5", "2", "-3", "1e-6")),
                         st.floats(-2.0, 2.0).map(repr))
    if isinstance(t, (click_types.IntParamType, click_types.IntRange)):
        return st.one_of(st.sampled_from(WILD_INTS), st.integers(-10, 100).map(str))
    if isinstance(t, click_types.Choice):
        return st.one_of(st.sampled_from(list(t.choices)), st.sampled_from(WILD_TEXT))
    return st.sampled_from(WILD_TEXT)


OPTION_COMMANDS = [c.name for c in COMMANDS if c.options]


@pytest.mark.parametrize("name", OPTION_COMMANDS)
def test_options(name, lib, cases, baselines):
    """One or two options of a command set to wild values, its paths at the baseline."""
    cmd = next(c for c in COMMANDS if c.name == name)

    @profile("options", commands=len(OPTION_COMMANDS))
    @given(data=st.data())
    def check(data):
        chosen = data.draw(st.lists(st.sampled_from(cmd.options), min_size=1, max_size=2,
                                    unique_by=lambda p: p.name), label="options")
        extra = []
        for p in chosen:
            value = data.draw(wild_value(p), label=p.name)
            extra += [fz.opt_name(p), *(value if isinstance(value, tuple) else (value,))]
        run_case(cmd, baselines[name], extra + quiet_flags(cmd), lib, cases,
                 f"options:{name}")

    check()


# ---------------------------------------------------------------------------------------------
# 3. `sweep map` across and beyond its validated ranges
# ---------------------------------------------------------------------------------------------
MAP_SANE = dict(l1=(0.2, 2.5), l2=(0.2, 2.0), r1=(0.02, 0.3), r2=(0.01, 0.3), w=(0.0, 2.5),
                r=(0.1, 2.0), mu=(0.0, 2.0))
#: Grid steps that are beyond the range but refused before any work (a fine h that is accepted
#: is a legitimate, slow request: not drawn).
WILD_H = ("nan", "inf", "-inf", "0", "-0.05", "1e-300", "1e-12", "1e300", "abc")


def number(lo, hi):
    return st.floats(lo, hi, allow_nan=False, allow_infinity=False)


@st.composite
def map_request(draw):
    """Arguments of one `sweep map`: valid values with, now and then, one beyond its range."""
    # about one option in twenty is wild (the first element is what Hypothesis tries first)
    wild = lambda: draw(st.sampled_from([False] * 19 + [True]))  # noqa: E731
    effects = ["friction"]
    if draw(st.booleans()):
        effects = draw(st.lists(st.sampled_from(EFFECT_NAMES), unique=True, max_size=4))
    v, args = {}, []
    for name, (lo, hi) in MAP_SANE.items():
        if name == "mu" and "friction" not in effects:
            lo = hi = 0.0
        v[name] = draw(st.sampled_from(WILD_FLOATS)) if wild() else repr(draw(number(lo, hi)))
        args += [f"--{name}", v[name]]
    try:
        reach = float(v["l1"]) + float(v["l2"]) + float(v["r"]) + float(v["w"]) / 2
    except ValueError:
        reach = 3.0
    reach = reach if math.isfinite(reach) and 0 < reach < 1e6 else 3.0
    if wild():
        args += ["--h", draw(st.sampled_from(WILD_H))]
    else:  # 2 to 12 steps across the reach: a few hundred points at most
        args += ["--h", repr(reach / draw(st.integers(2, 12)))]
    for name in ("xlim", "ylim"):
        kind = draw(st.sampled_from(["none"] * 8 + ["inside", "outside", "reversed", "point",
                                                     "below-palm", "huge"]))
        lo, hi = sorted(draw(number(-reach, reach)) for _ in range(2))
        window = {"none": None, "inside": (lo, hi), "outside": (2 * reach + lo, 3 * reach + hi),
                  "reversed": (hi + 0.1, lo), "point": (lo, lo), "below-palm": (-reach, -0.01),
                  "huge": (-1e12, 1e12)}[kind]
        if wild():
            window = (draw(st.sampled_from(WILD_FLOATS)), draw(st.sampled_from(WILD_FLOATS)))
        if window is not None:
            args += [f"--{name}", *map(str, window)]
    low = 0.05 if "joint_springs" in effects else 0.0    # springs need both tendons pulling
    for name in ("f-left", "f-right"):
        if draw(st.booleans()):
            args += [f"--{name}", draw(st.sampled_from(WILD_FLOATS)) if wild()
                     else repr(draw(number(max(low, 1e-3), 2.0)))]
    if draw(st.booleans()):
        lo = draw(number(-89.9, 0.0))
        hi = draw(number(lo + 0.1, 180.0))
        args += ["--theta2-min", draw(st.sampled_from(WILD_FLOATS)) if wild() else repr(lo),
                 "--theta2-max", draw(st.sampled_from(WILD_FLOATS)) if wild() else repr(hi)]
    if draw(st.booleans()):
        args += ["--reconfig-step", draw(st.sampled_from(("1e-7", "0.6", "nan", "-0.01", "0")))
                 if wild() else repr(10 ** draw(number(-3.0, math.log10(0.5))))]
    if draw(st.booleans()):
        args += ["--root-tol", draw(st.sampled_from(("1e-16", "0.2", "nan", "0", "-1e-9")))
                 if wild() else repr(10 ** draw(number(-15.0, -1.0)))]
    if draw(st.booleans()):
        args += ["--threads", draw(st.sampled_from(("0", "-1", "999", "x"))) if wild()
                 else draw(st.sampled_from(("1", "2")))]
    if effects != ["friction"] or wild():
        if wild():
            effects.append(draw(st.sampled_from(("none", "bogus", "", " "))))
        args += ["--effects", ",".join(effects) if effects else "none"]
    if "joint_springs" in effects or wild():
        for k in ("--K1", "--K2"):   # weaker than the tendon over the joint range (D13)
            args += [k, draw(st.sampled_from(WILD_FLOATS)) if wild()
                     else repr(draw(number(0.0, 1e-4)))]
    if draw(st.booleans()):
        names = ["energy"] + draw(st.lists(st.sampled_from(OUTPUT_NAMES[1:]), unique=True,
                                           max_size=3))
        if wild():
            names = draw(st.lists(st.sampled_from(OUTPUT_NAMES + ("bogus", "", " ")),
                                  max_size=4))
        args += ["--outputs", ",".join(names)]
    if draw(st.sampled_from([False] * 4 + [True])):
        args += ["--forces"]
    return args


def contact_points(path: Path) -> int:
    """Points of a written map where a finger touches the part (feasible, not unreached)."""
    with h5py.File(path, "r") as f:
        cls = f["point_class"][...]
        meanings = f["point_class"].attrs["flag_meanings"]
    meanings = (meanings.decode() if isinstance(meanings, bytes) else str(meanings)).split()
    empty = [meanings.index("infeasible"), meanings.index("unreached")]
    return int(np.isin(cls, empty, invert=True).sum())


def test_map_options(lib, cases):
    cmd = next(c for c in COMMANDS if c.name == "map")

    @profile("map")
    @given(args=map_request(), plot=st.sampled_from([False] * 9 + [True]))
    def check(args, plot):
        extra = list(args)
        kinds = {"out": "new-file"}
        if plot:
            kinds["plot"] = "new-png"
        res, case, argv = run_case_kept(cmd, kinds, extra, lib, cases, "map")
        try:
            if res.exit_code == 0:
                out = Path(argv[argv.index("--out") + 1])
                n = contact_points(out)
                assert n > 0 or "warning:" in res.output, (argv, res.output)
        finally:
            cases.done(case)

    check()


def run_case_kept(cmd, kinds, extra, lib, cases, label):
    """As run_case, but the case folder is left for the caller to inspect (and remove)."""
    case = cases.new()
    args, names = build_args(cmd, kinds, case, lib, extra)
    names += [w for w in extra if w.startswith("-")]
    before = fz.snapshot(case)
    res = fz.invoke(main, args, cwd=case)
    after = fz.snapshot(case)
    outcome = fz.check_outcome(fz.Case(cmd, args, names, case), res, before, after)
    OUTCOMES[f"{label}:{outcome}"] += 1
    return res, case, args


# ---------------------------------------------------------------------------------------------
# 4. Configs: trees derived from the schema, and text that is not a config at all
# ---------------------------------------------------------------------------------------------
#: A config with every section of the schema (docs/sweeps.md, "Config schema"), small and valid.
FULL_CONFIG = {
    "name": "fuzz",
    "designs": {"l1": {"lower": 0.8, "upper": 1.2, "step": 0.4}, "l2": [0.4],
                "r1": [0.12], "r2": 0.06, "w": [0.0, 0.5]},
    "parts": {"r": [0.4], "mu": {"lower": 0.1, "upper": 0.4, "step": 0.3}},
    "commands": [{"f_left": 1.0, "f_right": 1.0}],
    "grid": {"h": 0.25, "bounds": "reach"},
    "limits": {"theta2_min_deg": -5, "theta2_max_deg": 90},
    "accuracy": {"reconfig_step": 0.01, "root_tol": 1.0e-12, "trajectory": "discrete"},
    "effects": {"friction": True, "tip_contact": False, "joint_springs": False,
                "finger_collision": False},
    "outputs": {"energy": True, "equilibrium": True, "caging": True, "forces": False,
                "save_maps": [{"l1": 0.8, "l2": 0.4, "r1": 0.12, "r2": 0.06, "w": 0.0,
                               "r": 0.4, "mu": 0.1}],
                "manipulation": False, "scenario_a_top_k": 10},
    "run": {"sub_chunk_cells": 3},
}

WILD_VALUES = [None, True, False, 0, -1, 1, 0.0, -0.0, 1e-300, 5e-324, 1e300, 10**30, -10**30,
               math.nan, math.inf, -math.inf, "", "0.2", "abc", "é✓名", "\x00", [], {}, [[]],
               {"lower": 1}, [1, 1], [2, 1], [0.4, math.nan], list(range(1, 2000)),
               {"lower": 0.4, "upper": 2.0, "step": 1e-9}, {"lower": 2, "upper": 1, "step": 1},
               {"lower": 0.4, "upper": 2.0, "step": 0}, {"K1": 0.001, "K2": 0.001},
               {"K1": 10.0, "K2": 10.0}, {"f_left": 0, "f_right": 0}]


def paths_of(tree, prefix=()):
    """Every (path, value) of a YAML tree, mappings and lists walked."""
    yield prefix, tree
    if isinstance(tree, dict):
        for k, v in tree.items():
            yield from paths_of(v, prefix + (k,))
    elif isinstance(tree, list):
        for i, v in enumerate(tree):
            yield from paths_of(v, prefix + (i,))


def _parent(tree, path):
    for k in path[:-1]:
        tree = tree[k]
    return tree


@st.composite
def config_tree(draw):
    """FULL_CONFIG with 1-3 mutations: a key dropped, added or renamed, a value replaced."""
    import copy

    tree = copy.deepcopy(FULL_CONFIG)
    for _ in range(draw(st.integers(0, 3))):
        spots = [p for p, _ in paths_of(tree) if p]
        if not spots:
            break
        path = draw(st.sampled_from(spots))
        parent = _parent(tree, path)
        what = draw(st.sampled_from(["replace", "replace", "drop", "add", "rename", "number"]))
        if what == "drop":
            del parent[path[-1]]
        elif what == "add" and isinstance(parent, dict):
            parent[draw(st.sampled_from(["extra", "Name", "h", "l1", "é", "1", ""]))] = 1
        elif what == "rename" and isinstance(parent, dict):
            value = parent.pop(path[-1])
            parent[draw(st.sampled_from([str(path[-1]).upper(), f"{path[-1]}_", " " +
                                         str(path[-1]), f"{path[-1]}s"]))] = value
        elif what == "number":
            parent[path[-1]] = draw(st.floats() | st.integers(-10**20, 10**20))
        else:
            parent[path[-1]] = copy.deepcopy(draw(st.sampled_from(WILD_VALUES)))
    return tree


def to_yaml(tree) -> bytes:
    return yaml.safe_dump(tree, sort_keys=False, allow_unicode=True).encode()


NOT_CONFIGS = [b"", b"\x00\x01\x02", bytes(range(256)), b"\xef\xbb\xbfname: bom\n",
               b"\xff\xfe" + "name: utf16".encode("utf-16-le"), b"- a\n- b\n", b"42\n",
               b"~\n", b"name: [unclosed\n", b"a: b: c\n", b"\t- tab\n", b"[" * 5000 + b"]" * 5000,
               b"{" * 5000 + b"}" * 5000, b"a: &x [1]\nb: *x\n", b"!!python/object:os.system x",
               b"designs: !!binary aGVsbG8=\nparts: {}\n", b"name: a\nname: b\n",
               b"designs: *undefined\n", b"%YAML 9.9\n---\na: 1\n", b"---\n...\n---\n"]


@st.composite
def config_bytes(draw):
    """A config as bytes: a mutated tree, or text changed at random, or no config at all."""
    how = draw(st.sampled_from(["tree", "tree", "tree", "text", "not"]))
    if how == "not":
        return draw(st.sampled_from(NOT_CONFIGS))
    data = to_yaml(draw(config_tree()) if how == "tree" else FULL_CONFIG)
    if how == "text":
        pos = draw(st.integers(0, len(data)))
        change = draw(st.sampled_from(["cut", "insert", "bytes"]))
        if change == "cut":
            data = data[:pos]
        elif change == "insert":
            data = data[:pos] + draw(st.sampled_from([b":", b"-", b"\n  ", b"\t", b"&a", b"*a",
                                                       b"'", b"\"", b"#", b"{", b"]"])) + data[pos:]
        else:
            data = data[:pos] + draw(st.binary(min_size=1, max_size=8)) + data[pos:]
    return data


def test_configs_load_or_are_refused_with_one_line(tmp_path):
    """`load_scene` (what every command taking a config runs first) returns a Scene or raises
    SceneError with one line that names the file or the key; nothing else."""
    path = tmp_path / "c.yaml"

    @profile("config_load")
    @given(data=config_bytes())
    def check(data):
        path.write_bytes(data)
        try:
            scene = load_scene(path)
        except ModelInputError as exc:
            msg = str(exc)
            assert "\n" not in msg and msg.strip(), msg
            OUTCOMES["config_load:refused"] += 1
            return
        assert scene.n_maps >= 1 and scene.h > 0
        OUTCOMES["config_load:accepted"] += 1

    check()


CONFIG_COMMANDS = [c.name for c in COMMANDS
                   if any(isinstance(p.type, fz.SceneParam) for p in c.paths)]


@pytest.mark.parametrize("name", CONFIG_COMMANDS)
def test_configs_through_the_cli(name, lib, cases, baselines, tmp_path):
    """Configs through every command that takes one: exit 2 with one line naming the config
    file, nothing written; an accepted config is run (small ones only: the loading is the same
    code whatever the size)."""
    cmd = next(c for c in COMMANDS if c.name == name)
    param = next(p for p in cmd.paths if isinstance(p.type, fz.SceneParam))

    @profile("config_cli", commands=len(CONFIG_COMMANDS))
    @given(data=config_bytes())
    def check(data):
        probe = tmp_path / "probe.yaml"
        probe.write_bytes(data)
        try:
            scene = load_scene(probe)
            assume(scene.n_maps <= 8 and scene.h >= 0.2 and not scene.manipulation)
            # and maps of a small extent: `sweep accuracy` of a palm 39,861 wide (the long
            # profile, 2026-11-28) halves h down its ladder over 160,000 columns, minutes of work
            v = scene.values
            assume(max(grid_points(*g, scene.h) for g in itertools.product(
                v["l1"], v["l2"], v["w"], v["r"])) <= 10_000)
        except ModelInputError:
            pass
        kinds = dict(baselines[name])
        kinds[param.name] = "text-file"
        case = cases.new()
        try:
            args, names = build_args(cmd, kinds, case, lib, quiet_flags(cmd))
            config_path = Path(args[args.index(next(a for a in args if a.endswith("text.txt")))])
            config_path.write_bytes(data)
            before = fz.snapshot(case)
            res = fz.invoke(main, args, cwd=case)
            outcome = fz.check_outcome(fz.Case(cmd, args, names, case), res, before,
                                       fz.snapshot(case))
            OUTCOMES[f"config_cli:{name}:{outcome}"] += 1
        finally:
            cases.done(case)

    check()


# ---------------------------------------------------------------------------------------------
# 5. A real process: Ctrl-C at any moment of start-up, exit codes on the real streams
# ---------------------------------------------------------------------------------------------
SWEEP = Path(sys.executable).parent / "sweep"      # the installed command (pip's console script)
INTERRUPT_CASES = 200 if LONG else 6
#: A frame of the program's main function in a traceback, and the source line Python shows.
PROGRAM_MAIN = re.compile(r'File "[^"]*sweep/program\.py", line \d+, in main\n +(.*)')


def program_ran(err: str) -> bool:
    """Whether a traceback on stderr went through the program's main beyond its first line (a
    signal that lands as main is entered is raised at its `def` line, before its first
    statement, the `try` of its guard)."""
    return any(not line.startswith("def main(") for line in PROGRAM_MAIN.findall(err))


def test_ctrl_c_at_any_moment_of_start_up_is_one_line_or_before_the_program(lib, tmp_path):
    """SIGINT at random moments from the exec of `sweep run` to well into its work (the
    imports, the config, the kernels): once the program runs, the process ends with one line
    and exit code 130, or it had finished (a signal while Python shuts down ends the process
    silently, its store complete); before it runs (Python's start-up, the console script's
    imports), it ends the way Python ends it, and nothing is written. Never a half-written
    store."""
    import random
    import signal

    assert SWEEP.exists(), SWEEP
    rng = random.Random(None if EXPLORE else 20261125)
    outcomes = Counter()
    for k in range(INTERRUPT_CASES):
        out = tmp_path / f"o{k}.h5"
        proc = subprocess.Popen([str(SWEEP), "run", str(lib.files["config"]), "--out", str(out),
                                 "--no-progress"], stdout=subprocess.PIPE,
                                stderr=subprocess.PIPE, text=True, env=_clean_env(),
                                preexec_fn=_sigint_as_from_a_terminal)
        time.sleep(rng.uniform(0.0, 1.5) ** 2)   # dense early: the short start-up phases
        proc.send_signal(signal.SIGINT)
        _, err = proc.communicate(timeout=120)
        lines = [ln for ln in err.splitlines() if ln.strip()]
        if proc.returncode == 0:
            outcomes["finished"] += 1
            assert out.exists() and not lines, err
        elif proc.returncode == 130 and lines[:1] and lines[0].startswith("sweep: interrupted"):
            outcomes["interrupted"] += 1
            assert len(lines) == 1, err
            if out.exists():  # the signal came after the store was renamed into place
                outcomes["interrupted after the store was complete"] += 1
                from sweep.storage.store import read_store
                assert read_store(out).variables  # whole: a store is only written by a rename
        elif out.exists():
            # silently by the signal once Python, shutting down, has given SIGINT back to the
            # system: the command had finished
            outcomes["killed as Python ended, the store complete"] += 1
            assert proc.returncode == -signal.SIGINT and not lines, err
            from sweep.storage.store import read_store
            assert read_store(out).variables
        else:
            # Python's own ending: silently by the signal, its traceback, its fatal error
            outcomes["before the program ran"] += 1
            assert not program_ran(err), err
            assert not (tmp_path / f"o{k}.h5.parts").exists(), err
        assert not list(tmp_path.glob(f".o{k}.h5.tmp*"))
    OUTCOMES.update({f"ctrl-c:{k}": v for k, v in outcomes.items()})
    assert outcomes["interrupted"] > 0


def test_a_traceback_through_the_running_program_is_told_from_one_before_it():
    """The spray's rule above, on tracebacks of both kinds."""
    head = 'Traceback (most recent call last):\n  File "/v/bin/sweep", line 8, in <module>\n'
    entered = head + '    sys.exit(main())\n  File "/v/sweep/program.py", line 13, in main\n' \
        '    def main(argv=None) -> None:\nKeyboardInterrupt\n'
    running = head + '    sys.exit(main())\n  File "/v/sweep/program.py", line 22, in main\n' \
        '    cli(args=argv, prog_name="sweep")\n  File "/v/click/core.py", line 1, in f\n'
    importing = head + '    from sweep.program import main\n' \
        '  File "/v/sweep/interrupts.py", line 26, in <module>\n    import signal\n'
    assert not program_ran(entered) and not program_ran(importing) and program_ran(running)


@pytest.mark.parametrize("signame", ["SIGINT", "SIGTERM"])
def test_an_interrupt_in_a_weakref_callback_is_delivered_again_not_printed(signame):
    """A Ctrl-C (or SIGTERM) that lands in a weakref callback, where Python cannot raise it,
    printed "Exception ignored in: <function ...>" with a traceback and was then lost (found
    by the long profile's Ctrl-C spray: a callback of a cache cleared while modules load).
    The program's unraisable hook has it delivered again, to the code that runs next."""
    code = f"""
import signal, sys, time, weakref
import sweep.program as program
from sweep.interrupts import Terminated, deliver_again, raise_terminated
try:
    program.main(["--version"])                # installs the hook, then drops signals
except SystemExit:
    pass
assert sys.unraisablehook is deliver_again
signal.signal(signal.SIGINT, signal.default_int_handler)   # as while a command runs
signal.signal(signal.SIGTERM, raise_terminated)
class Cached:
    pass
def callback(ref):
    raise Terminated() if {signame!r} == "SIGTERM" else KeyboardInterrupt()
obj = Cached()
ref = weakref.ref(obj, callback)
try:
    del obj                                    # the callback runs and raises here
    for _ in range(500):
        time.sleep(0.01)
    print("lost")
except KeyboardInterrupt as exc:
    print("delivered again as", type(exc).__name__)
"""
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          env=_clean_env(), timeout=60)
    assert proc.stderr == "", proc.stderr
    expected = "Terminated" if signame == "SIGTERM" else "KeyboardInterrupt"
    assert proc.stdout.splitlines()[-1] == f"delivered again as {expected}"


def test_a_refusal_in_a_real_process_is_one_line_on_stderr_and_exit_2(tmp_path):
    proc = subprocess.run([str(SWEEP), "map", *fz.MAP_ARGS, "--h", "nan", "--out",
                           str(tmp_path / "m.h5")], capture_output=True, text=True,
                          env=_clean_env())
    assert proc.returncode == 2 and proc.stdout == ""
    assert proc.stderr.count("\n") == 1 and "Traceback" not in proc.stderr
    assert "h must be a positive number" in proc.stderr and not list(tmp_path.iterdir())


def _sigint_as_from_a_terminal() -> None:
    """SIGINT at its default in the child, as a command typed at a terminal has it: a test run
    started in the background (`make test &`, nohup) passes SIGINT on as ignored, and a program
    that ignores it runs to its end (every case of the Ctrl-C spray then "finished")."""
    import signal

    signal.signal(signal.SIGINT, signal.SIG_DFL)


def _clean_env() -> dict:
    return {k: v for k, v in os.environ.items() if k not in fz.CLEAN_ENV}


def test_an_interrupt_that_python_wraps_is_still_one_line_and_exit_130(capsys):
    """Python turns a KeyboardInterrupt raised in a dataclass field's __set_name__ (a module
    imported by a command, at Ctrl-C) into a RuntimeError caused by it: found by the Ctrl-C
    spray as a traceback."""
    from sweep.cli.common import user_errors

    with pytest.raises(SystemExit) as exc:
        with user_errors():
            try:
                raise KeyboardInterrupt
            except KeyboardInterrupt as interrupt:
                raise RuntimeError("Error calling __set_name__") from interrupt
    assert exc.value.code == 130
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("sweep: interrupted")


def test_an_interrupt_that_python_wraps_while_the_cli_is_imported_is_one_line_and_exit_130():
    """The long profile's Ctrl-C spray (2026-11-28): the Ctrl-C hit `platform`'s
    `cached_property.__set_name__` while click (so the CLI) was being imported; Python 3.11
    turned it into a RuntimeError caused by it, which the program's import guard let through as
    a traceback. A real class attribute whose __set_name__ is interrupted, in the module the
    program imports first."""
    code = """
import importlib.abc, importlib.util, sys
import sweep.program as program

class Interrupted:
    def __set_name__(self, owner, name):
        raise KeyboardInterrupt

class InterruptedCli(importlib.abc.MetaPathFinder, importlib.abc.Loader):
    def find_spec(self, name, path=None, target=None):
        if name == "sweep.cli":
            return importlib.util.spec_from_loader(name, self)
    def create_module(self, spec):
        return None
    def exec_module(self, module):
        class Uname:              # as platform.uname_result's cached_property
            processor = Interrupted()

sys.meta_path.insert(0, InterruptedCli())
program.main(["--version"])
print("not interrupted")
"""
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          env=_clean_env(), timeout=60)
    assert proc.returncode == 130, proc.stderr
    assert proc.stdout == ""
    assert proc.stderr == "sweep: interrupted; nothing was written\n", proc.stderr


@pytest.mark.parametrize("l2, r2, ok", [(5e-324, 0.25, False), (1e-13, 0.25, False),
                                        (1e-11, 0.25, True), (0.5, 1e-120, False)])
def test_lengths_of_one_scale_are_accepted_and_others_refused(l2, r2, ok):
    """The long fuzz profile's `sweep map --l1 1 --l2 5e-324` reached a kernel (SystemError):
    lengths must lie in LENGTH_RANGE and within LENGTH_SPAN of each other."""
    from sweep.model import (Accuracy, Command, Design, Limits, ModelInputError, Part,
                             validate_inputs)

    args = (Design(1.0, l2, 0.25, r2, 0.0), Part(0.125, 0.0), Command(), Limits(), Accuracy())
    if ok:
        validate_inputs(*args)
    else:
        with pytest.raises(ModelInputError):
            validate_inputs(*args)


@pytest.mark.parametrize("window", [["--xlim", "1.125", "1.125"], ["--ylim", "1.125", "1.13"]])
def test_a_window_between_grid_points_names_its_option(window, tmp_path):
    """The long profile's `sweep map ... --xlim 1.125 1.125` (h = 0.05: no column x = i h in
    it) was refused with "the grid window holds no grid point", naming no option."""
    res = fz.invoke(main, ["map", *fz.MAP_ARGS[:-2], "--h", "0.05", "--out",
                           str(tmp_path / "m.h5"), *window], cwd=tmp_path)
    assert res.exit_code == 2 and not list(tmp_path.iterdir())
    lines = res.output.strip().splitlines()
    assert len(lines) == 1 and window[0] in lines[0] and "change --h" in lines[0], res.output


def test_a_refused_plot_leaves_no_folder_of_the_map_behind(tmp_path):
    """Found by the long profile: `sweep map --out NEW/DEEPER/x.h5 --plot FILE/x.png` created
    NEW/DEEPER for the map, then refused the plot (a file in the way) with exit 2."""
    (tmp_path / "z-blocker").write_text("a file")   # claimed after the map (by path)
    out = tmp_path / "a-new" / "deeper" / "x.h5"
    res = fz.invoke(main, ["map", *fz.MAP_ARGS, "--out", str(out),
                           "--plot", str(tmp_path / "z-blocker" / "x.png")], cwd=tmp_path)
    assert res.exit_code == 2, res.output
    assert "z-blocker is a file, not a directory" in res.output
    assert sorted(p.name for p in tmp_path.iterdir()) == ["z-blocker"]
