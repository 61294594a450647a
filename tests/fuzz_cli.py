"""The machinery of the CLI fuzz campaign (tests/test_fuzz.py, issue P13).

- `commands(group)`: every command of the click tree, found by introspection (nested groups
  included), with its path-like parameters (`click.Path` or the config type) and its other
  options. New commands are fuzzed without touching this file.
- `Library`: one set of real artefacts made once by the CLI itself (a config, a results store,
  a chunked run directory, a shard, a part file, a single map) plus broken ones (empty,
  binary, truncated and foreign HDF5, undecodable text).
- `PATH_KINDS`: every kind of path a user can hand a command: missing, under a missing folder,
  a file where a directory is expected and the reverse, unreadable, unwritable, each artefact
  where another is expected, a symlink loop, a dangling link, names too long or not decodable.
- `baseline(...)`: for each command, a set of path kinds that makes it succeed, found by trying
  the artefacts (no per-command table), so that a fuzz case can change one input at a time.
- `check_outcome(...)`: the property every case must have: exit 0 with a meaningful result, or
  exit 2 with one line naming the input, no traceback, nothing written or changed.

Permission cases (unreadable, unwritable) need an unprivileged user: as root the case runs with
the effective uid of `nobody` (root ignores file modes).
"""
from __future__ import annotations

import contextlib
import hashlib
import os
import re
import shutil
import signal
import stat
from dataclasses import dataclass, field
from pathlib import Path

import click
import h5py
import numpy as np
from click.testing import CliRunner

from sweep.cli.common import SceneParam

#: Exit codes a command may end with besides 0 and 2: `sweep status` says "incomplete" with 1.
#: (Documented in its help; any other command must end in 0 or 2.)
OTHER_EXIT_CODES = {"status": {1}}
#: Environment of every case: no array-job index, no thread count from a batch system.
CLEAN_ENV = {v: None for v in ("SLURM_ARRAY_TASK_ID", "PBS_ARRAY_INDEX", "SGE_TASK_ID",
                               "LSB_JOBINDEX", "SLURM_CPUS_PER_TASK")}

# ---------------------------------------------------------------------------------------------
# The command tree
# ---------------------------------------------------------------------------------------------


@dataclass
class Command:
    name: str                      # "map", "run", ... (space-separated for nested groups)
    command: click.Command
    paths: list[click.Parameter]   # path-like parameters, arguments first
    options: list[click.Option]    # every other option that takes a value
    flags: list[click.Option]      # boolean flags

    @property
    def words(self) -> list[str]:
        return self.name.split()


def is_path_param(p: click.Parameter) -> bool:
    return isinstance(p.type, (click.Path, SceneParam))


def commands(group: click.Group, prefix: str = "") -> list[Command]:
    """Every leaf command of the click tree under `group`, with its parameters classified."""
    out = []
    for name, cmd in sorted(group.commands.items()):
        full = f"{prefix} {name}".strip()
        if isinstance(cmd, click.Group):
            out.extend(commands(cmd, full))
            continue
        params = [p for p in cmd.params if p.expose_value and "help" not in p.name]
        paths = [p for p in params if is_path_param(p)]
        paths.sort(key=lambda p: not isinstance(p, click.Argument))
        flags = [p for p in params if isinstance(p, click.Option) and p.is_flag]
        options = [p for p in params if isinstance(p, click.Option) and not p.is_flag
                   and not is_path_param(p)]
        out.append(Command(full, cmd, paths, options, flags))
    return out


def opt_name(p: click.Parameter) -> str:
    """The spelling of an option on the command line ('--out'), or the argument's name."""
    if isinstance(p, click.Option):
        return max(p.opts, key=len)
    return p.name


def positive_flag(p: click.Option) -> str:
    return max(p.opts, key=len)


# ---------------------------------------------------------------------------------------------
# Artefacts
# ---------------------------------------------------------------------------------------------
#: The fuzz's config: 2 designs x 1 part at a coarse grid (each command that computes is fast).
FUZZ_CONFIG = """\
name: fuzz
designs:
  l1: [0.8, 1.2]
  l2: [0.4]
  r1: [0.12]
  r2: [0.06]
  w: [0.0]
parts:
  r: [0.4]
  mu: [0.4]
grid: {h: 0.25}
"""

#: Arguments of `sweep map` that make a small valid map (about 250 points).
MAP_ARGS = ["--l1", "0.8", "--l2", "0.4", "--r1", "0.12", "--r2", "0.06", "--w", "0.4",
            "--r", "0.4", "--mu", "0.4", "--h", "0.2"]


#: A case that runs longer than this is a hang (the largest legitimate case takes seconds).
CASE_TIMEOUT_SECONDS = 120


class CaseTimeout(Exception):
    """A case ran past CASE_TIMEOUT_SECONDS (raised by SIGALRM; not an interrupt, so the CLI
    does not report it as one and the case fails)."""


def _alarm(signum, frame):
    raise CaseTimeout(f"no result after {CASE_TIMEOUT_SECONDS} s")


def invoke(group, args, cwd: Path | None = None):
    """Run the CLI in-process in `cwd` (relative defaults such as results/ land there), with a
    time limit."""
    old = os.getcwd()
    if cwd is not None:
        os.chdir(cwd)
    previous = signal.signal(signal.SIGALRM, _alarm)
    signal.alarm(CASE_TIMEOUT_SECONDS)
    try:
        return CliRunner().invoke(group, [str(a) for a in args], env=CLEAN_ENV)
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, previous)
        os.chdir(old)


@dataclass
class Library:
    """Artefacts made once by the CLI; a case copies what it needs into its own folder."""

    root: Path
    files: dict = field(default_factory=dict)   # name -> Path

    @classmethod
    def build(cls, group, root: Path) -> "Library":
        lib = cls(root)
        root.mkdir(parents=True, exist_ok=True)
        cfg = root / "config.yaml"
        cfg.write_text(FUZZ_CONFIG)
        lib.files["config"] = cfg
        for args in (["run", cfg, "--out", root / "store.h5", "--no-progress", "--keep-parts"],
                     ["run", cfg, "--out", root / "rundir", "--chunks", "2", "--chunk", "0",
                      "--no-progress"],
                     ["run", cfg, "--out", root / "rundir", "--chunks", "2", "--chunk", "1",
                      "--no-progress"],
                     ["map", *MAP_ARGS, "--out", root / "map.h5", "--plot", root / "map.png"]):
            res = invoke(group, args)
            assert res.exit_code == 0, (args, res.output)
        # Load (or compile) the kernels a case may need here, as the user who owns the kernel
        # cache: cases with file modes run as `nobody` (unprivileged), who cannot read root's
        # cache, and a kernel first called in such a case failed on its cache file (the forces'
        # arrays, when test_fuzz.py ran alone).
        warm = root / "warm"
        warm.mkdir()
        res = invoke(group, ["map", *MAP_ARGS, "--forces", "--out", warm / "forces.h5"])
        assert res.exit_code == 0, res.output
        shutil.rmtree(warm)
        lib.files["store"] = root / "store.h5"
        lib.files["rundir"] = root / "rundir"
        lib.files["shard"] = sorted((root / "rundir").glob("shard-*.h5"))[0]
        lib.files["part"] = sorted((root / "store.h5.parts").glob("items-*.h5"))[0]
        lib.files["map"] = root / "map.h5"
        lib.files["png"] = root / "map.png"
        data = lib.files["store"].read_bytes()
        (root / "truncated.h5").write_bytes(data[: len(data) // 2])
        lib.files["truncated-h5"] = root / "truncated.h5"
        with h5py.File(root / "foreign.h5", "w") as f:
            f["x"] = np.arange(3.0)
            f.attrs["sweep_file_kind"] = "something else"
        lib.files["foreign-h5"] = root / "foreign.h5"
        with h5py.File(root / "attrs-only.h5", "w") as f:   # claims to be a store, holds nothing
            f.attrs["sweep_file_kind"] = h5py.File(lib.files["store"], "r").attrs[
                "sweep_file_kind"]
        lib.files["hollow-h5"] = root / "attrs-only.h5"
        (root / "empty").write_bytes(b"")
        lib.files["empty-file"] = root / "empty"
        (root / "binary").write_bytes(bytes(range(256)) * 4)
        lib.files["binary-file"] = root / "binary"
        (root / "undecodable.yaml").write_bytes(b"name: \xff\xfe\x80 caf\xe9\n")
        lib.files["undecodable-file"] = root / "undecodable.yaml"
        (root / "text.txt").write_text("not a sweep file\n")
        lib.files["text-file"] = root / "text.txt"
        return lib


# ---------------------------------------------------------------------------------------------
# Path kinds
# ---------------------------------------------------------------------------------------------
#: Kinds whose effect needs file modes to bind (an unprivileged user).
PERMISSION_KINDS = ("unreadable-file", "unreadable-dir", "unwritable-dir", "in-unwritable-dir")
ARTEFACT_KINDS = ("config", "store", "rundir", "shard", "part", "map", "png", "truncated-h5",
                  "foreign-h5", "hollow-h5", "empty-file", "binary-file", "undecodable-file",
                  "text-file")
PATH_KINDS = (("new-file", "new-dir", "new-png", "missing-parent", "under-file", "empty-dir",
               "incomplete-rundir", "symlink-loop", "dangling-symlink", "symlink-to-store",
               "long-name", "unicode-name", "undecodable-name", "empty-string")
              + ARTEFACT_KINDS + PERMISSION_KINDS)


#: Paths of the wrong kind: what a refusal must call each artefact, and a command it must name
#: as taking it (None: no command takes it). Written from what the artefacts are, apart from the
#: CLI's own table, so that the campaign checks the messages rather than repeating them.
ARTEFACT_WORDS = {
    "config": ("config", "sweep run"), "store": ("results store", "sweep top"),
    "rundir": ("run directory", "sweep merge"),
    "incomplete-rundir": ("run directory", "sweep status"),
    "shard": ("shard", "sweep merge"), "part": ("part file", "sweep show"),
    "map": ("map file", "sweep show"), "png": ("picture", None), "empty-dir": ("folder", None),
    "text-file": ("a file", None),
}
_RUN_DIRS = {"rundir", "incomplete-rundir", "empty-dir"}
#: Which of those artefacts a path parameter of each kind (`param_want`) takes: the others must
#: be refused by name.
TAKES = {
    "config": {"config", "text-file"},
    "store": {"store", "text-file"},
    "sweep-file": {"store", "shard", "part", "map", "text-file"},
    "run-dir": _RUN_DIRS,
    "store-out": {"store", "text-file"},
    "run-dir-out": _RUN_DIRS,
    "store-or-run-out": {"store", "text-file"} | _RUN_DIRS,
    "folder-out": {"empty-dir"},
    "map-out": {"map", "text-file"},
    "picture-out": {"png", "text-file"},
}


def param_want(p: click.Parameter) -> str | None:
    """The kind of path a parameter takes (its type's `want`; "config" for a config), or None."""
    if isinstance(p.type, SceneParam):
        return "config"
    return getattr(p.type, "want", None)


def wrong_kinds(p: click.Parameter) -> list[str]:
    """The artefacts of another kind than parameter `p` takes."""
    want = param_want(p)
    return [] if want is None else sorted(set(ARTEFACT_WORDS) - TAKES[want])


def names_its_kind(line: str, kind: str) -> bool:
    """Does a refusal say what the path of artefact `kind` is, and which command takes it?"""
    word, command = ARTEFACT_WORDS[kind]
    return word in line and (command is None or command in line)


def _copy(src: Path, dst: Path) -> Path:
    if src.is_dir():
        shutil.copytree(src, dst)
    else:
        shutil.copyfile(src, dst)
    return dst


def make_path(kind: str, case: Path, lib: Library, tag: str) -> str:
    """A path of `kind` inside the case folder `case` (created as needed); `tag` keeps the
    paths of one case's parameters apart."""
    p = case / tag
    if kind == "new-file":
        return str(p.with_suffix(".h5"))
    if kind == "new-dir":
        return str(p)
    if kind == "new-png":
        return str(p.with_suffix(".png"))
    if kind == "missing-parent":
        return str(case / f"{tag}-nowhere" / "deeper" / "x.h5")
    if kind == "under-file":
        blocker = case / f"{tag}-blocker"
        blocker.write_text("a file in the way")
        return str(blocker / "x.h5")
    if kind == "empty-dir":
        p.mkdir()
        return str(p)
    if kind == "incomplete-rundir":
        _copy(lib.files["rundir"], p)
        sorted(p.glob("shard-*.h5"))[-1].unlink()
        return str(p)
    if kind == "symlink-loop":
        a, b = case / f"{tag}-loop-a", case / f"{tag}-loop-b"
        a.symlink_to(b)
        b.symlink_to(a)
        return str(a)
    if kind == "dangling-symlink":
        p.symlink_to(case / f"{tag}-absent")
        return str(p)
    if kind == "symlink-to-store":
        target = _copy(lib.files["store"], case / f"{tag}-target.h5")
        p.symlink_to(target)
        return str(p)
    if kind == "long-name":
        return str(case / ("n" * 300 + ".h5"))
    if kind == "unicode-name":
        return str(case / f"{tag}-é✓名.h5")
    if kind == "undecodable-name":
        return str(case / os.fsdecode(tag.encode() + b"-\xff\xfe.h5"))
    if kind == "empty-string":
        return ""
    if kind in ARTEFACT_KINDS:
        src = lib.files[kind]
        return str(_copy(src, p.with_name(f"{tag}-{src.name}")))
    if kind == "unreadable-file":
        q = _copy(lib.files["store"], case / f"{tag}-unreadable.h5")
        q.chmod(0)
        return str(q)
    if kind == "unreadable-dir":
        q = _copy(lib.files["rundir"], p)
        q.chmod(0)
        return str(q)
    if kind == "unwritable-dir":
        p.mkdir()
        p.chmod(0o555)
        return str(p)
    if kind == "in-unwritable-dir":
        p.mkdir()
        p.chmod(0o555)
        return str(p / "x.h5")
    raise ValueError(kind)


@contextlib.contextmanager
def unprivileged(case: Path, needed: bool):
    """As root, run the block with the effective uid/gid of `nobody` so that file modes bind;
    the case folder is opened up for that user first."""
    if not needed or os.geteuid() != 0:
        yield
        return
    nobody = 65534
    for dirpath, dirnames, filenames in os.walk(case):
        for name in dirnames + filenames:
            q = Path(dirpath, name)
            if not q.is_symlink():
                os.chown(q, nobody, nobody)
        os.chown(dirpath, nobody, nobody)
    os.setegid(nobody)
    os.seteuid(nobody)
    try:
        yield
    finally:
        os.seteuid(0)
        os.setegid(0)


def snapshot(root: Path) -> dict:
    """Every entry under root: kind, mode, and bytes (files) or target (links)."""
    out = {}
    for dirpath, dirnames, filenames in os.walk(root):
        for name in dirnames + filenames:
            q = Path(dirpath, name)
            st = q.lstat()
            rel = str(q.relative_to(root))
            if stat.S_ISLNK(st.st_mode):
                out[rel] = ("link", os.readlink(q))
            elif stat.S_ISDIR(st.st_mode):
                out[rel] = ("dir", stat.S_IMODE(st.st_mode))
            else:
                with open(q, "rb") as f:
                    digest = hashlib.sha256(f.read()).hexdigest()
                out[rel] = ("file", stat.S_IMODE(st.st_mode), digest)
    return out


def reset_modes(root: Path) -> None:
    """Give root everything back so that the case folder can be removed."""
    for dirpath, dirnames, _ in os.walk(root):
        for name in dirnames:
            q = Path(dirpath, name)
            if not q.is_symlink():
                q.chmod(0o755)
    with contextlib.suppress(OSError):
        root.chmod(0o755)


# ---------------------------------------------------------------------------------------------
# The property
# ---------------------------------------------------------------------------------------------
TRACEBACK = re.compile(r"Traceback \(most recent call last\)|^\s+File \"", re.M)


@dataclass
class Case:
    cmd: Command
    args: list[str]
    names: list[str]            # what the error line may name: paths, their names, options
    case_dir: Path


def names_of(value: str, p: click.Parameter) -> list[str]:
    """Ways an error line can name a parameter's input: the value, its file name, the option."""
    out = [opt_name(p), p.name, p.name.upper()]
    if value:
        out += [value, os.path.basename(value.rstrip("/")) or value]
    return [n for n in out if n]


def check_outcome(case: Case, res, before: dict, after: dict, *, warn_if_empty=None) -> str:
    """The campaign's property; returns a short label of the outcome for statistics."""
    text = res.output
    codes = {0, 2} | OTHER_EXIT_CODES.get(case.cmd.name, set())
    exc = res.exception
    assert exc is None or isinstance(exc, SystemExit), (case.args, _short(repr(exc)),
                                                        _short(text))
    assert not TRACEBACK.search(text), (case.args, _short(text))
    assert res.exit_code in codes, (case.args, res.exit_code, _short(text))
    if res.exit_code == 2:
        lines = [ln for ln in text.splitlines() if ln.strip()]
        assert len(lines) == 1, (case.args, text)
        line = lines[0]
        assert names_input(line, case.names), (case.args, case.names, line)
        assert after == before, (case.args, line, _diff(before, after))
        return "refused"
    if res.exit_code == 0:
        assert text.strip(), (case.args, "exit 0 with no output at all")
        for line in text.splitlines():
            if not line.startswith("wrote "):
                continue
            # every path of the case the line names exists (the first word may be relative)
            named = re.findall(re.escape(str(case.case_dir)) + r"[^\s:]*", line)
            first = line.split()[1].rstrip(":")
            if first != "the" and not first.startswith("/"):
                named.append(str(case.case_dir / first))
            for written in named:
                assert _exists(written.rstrip("/")), (case.args, written, text)
        return "done"
    return f"exit {res.exit_code}"


def _exists(path: str) -> bool:
    """Does the path exist? (Bytes of a name that are not UTF-8 come back from the output as
    U+FFFD: any character matches there.)"""
    if "\ufffd" not in path:
        return Path(path).exists()
    candidates = [Path(path).anchor or "."]   # matched one component at a time (a folder's name
    for part in Path(path).parts[1 if Path(path).anchor else 0:]:   # may hold them too)
        if "\ufffd" not in part:
            candidates = [Path(c) / part for c in candidates if (Path(c) / part).exists()]
            continue
        pattern = re.compile(".+".join(re.escape(p) for p in re.split("\ufffd+", part)))
        candidates = [Path(c) / q.name for c in candidates if Path(c).is_dir()
                      for q in Path(c).iterdir() if pattern.fullmatch(q.name)]
    return bool(candidates)


def names_input(line: str, names) -> bool:
    """Does the error line name one of the inputs: a path or file name as given, an option as
    spelled ('--f-left'), or its name as a word ('f_left', 'l1')?"""
    for n in names:
        if n.startswith("-"):
            bare = n.lstrip("-")
            words = {bare, bare.replace("-", "_")}
            if n in line or any(re.search(rf"(?<![\w-]){re.escape(w)}(?![\w-])", line)
                                for w in words):
                return True
        elif n in line:
            return True
    return False


def _short(text: str, n: int = 600) -> str:
    return text if len(text) <= n else text[:n] + f"... ({len(text)} characters)"


def _diff(a: dict, b: dict) -> dict:
    keys = set(a) | set(b)
    return {k: (a.get(k), b.get(k)) for k in sorted(keys) if a.get(k) != b.get(k)}
