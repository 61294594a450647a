"""What the commands of the CLI share: the one place where errors reach the user, and the
parameter types and options of more than one command (CONFIG, PATH, FILE, WAIT, THREADS), and
the one check of a path's kind (`check_path`, `KindPath`: a store where a run directory is
expected, a config where a store is, a folder where a file is, ... named, exit code 2).

`user_errors()` turns what a user can cause or fix - bad input (`ModelInputError`, `SceneError`),
an unusable file or directory (`StoreError`, `OutputError`, any `OSError`) - into one line on
stderr and exit code 2, and Ctrl-C or SIGTERM into one line and exit code 130
(`sweep.interrupts`). Anything else is a bug and keeps its traceback. `SweepCommand` and
`SweepGroup` run every command (and the parsing of its arguments, where configs are loaded)
inside it, so no command handles errors itself.

Imports stay light (click only): the heavy modules load inside commands, where an interrupt is
already handled.
"""
from __future__ import annotations

import contextlib
import io
import os
import sys
from pathlib import Path

import click

from ..interrupts import (
    EXIT_INTERRUPTED, interrupt_cause, interrupted_message, sigterm_as_interrupt,
)


class UserError(click.ClickException):
    """Bad input or an unusable file/directory: one line, exit code 2."""

    exit_code = 2


def _user_error_types() -> tuple[type, ...]:
    # Imported here, not at the top: only modules already loaded can have raised these.
    types: list[type] = []
    for module, name in (("sweep.model", "ModelInputError"), ("sweep.storage.store", "StoreError"),
                         ("sweep.files", "OutputError")):
        mod = sys.modules.get(module)
        if mod is not None:
            types.append(getattr(mod, name))
    return tuple(types)


def one_line(exc: click.UsageError) -> UserError:
    """A usage error as one line (click prints usage, a hint and the message on three): the
    message and where the help is."""
    ctx = exc.ctx
    where = f" (see '{ctx.command_path} -h')" if ctx is not None else ""
    return UserError(exc.format_message() + where)


#: `sweep` without a command prints its help (exit 2 since click 8.2): that stays as it is.
_HELP_ERRORS = tuple(t for t in (getattr(click.exceptions, "NoArgsIsHelpError", None),) if t)


@contextlib.contextmanager
def user_errors():
    """Errors the user can fix -> one line, exit 2; Ctrl-C / SIGTERM -> one line, exit 130."""
    with sigterm_as_interrupt():
        try:
            yield
        except _HELP_ERRORS:
            raise
        except click.UsageError as exc:
            raise one_line(exc) from None
        except (click.exceptions.Exit, click.ClickException, click.Abort, SystemExit):
            raise
        except KeyboardInterrupt as exc:
            click.echo(interrupted_message(exc), err=True)
            sys.exit(EXIT_INTERRUPTED)
        except OSError as exc:
            if isinstance(exc, _user_error_types()):
                raise UserError(str(exc)) from None
            from ..files import os_error_message

            raise UserError(os_error_message(exc, exc.filename or "sweep", "failed")) from None
        except Exception as exc:
            if isinstance(exc, _user_error_types()):
                raise UserError(str(exc)) from None
            interrupt = interrupt_cause(exc)
            if interrupt is not None:
                click.echo(interrupted_message(interrupt), err=True)
                sys.exit(EXIT_INTERRUPTED)
            raise


def real_path(path) -> Path:
    """The path with every symlink followed; never raises (a symlink loop is left as it is,
    where Path.resolve raises RuntimeError)."""
    return Path(os.path.realpath(path))


class NonEmptyPath(click.Path):
    """click.Path that refuses an empty string (Path("") is the current directory, and a
    message about "." would not name what the user typed)."""

    def convert(self, value, param, ctx):
        if isinstance(value, str) and not value:
            self.fail("an empty path; give a file or folder name", param, ctx)
        return super().convert(value, param, ctx)


# ---------------------------------------------------------------------------------------------
# Paths of the wrong kind
# ---------------------------------------------------------------------------------------------
#: What a parameter of each kind of path takes: (what it names, in words; the path kinds of
#: `sweep.runs.rundir.path_kind` it lets through to the command). A missing or unreadable path
#: always goes through: the command's own message says what is wrong with it.
WANTS = {
    "config": ("a sweep config (YAML)", {"config", "file"}),
    "store": ("a results store", {"store", "hdf5", "file"}),
    "sweep-file": ("a sweep file (a results store, shard, part or map file)",
                   {"store", "shard", "part", "map", "hdf5", "file"}),
    "run-dir": ("a run directory", {"run-dir", "folder"}),
    "store-out": ("a results store file", {"store", "hdf5", "file"}),
    "run-dir-out": ("a run directory", {"run-dir", "folder"}),
    "store-or-run-out": ("a results store or a run directory",
                         {"store", "hdf5", "file", "run-dir", "folder"}),
    "folder-out": ("a folder", {"folder"}),
    "map-out": ("a map file", {"map", "hdf5", "file"}),
    "picture-out": ("a PNG picture", {"picture", "file"}),
}
#: Which command takes a path of each kind (none for kinds no command takes).
FITS = {
    "store": "`sweep top`, `show`, `report` or `refine` takes it",
    "run-dir": "`sweep status` or `sweep merge` takes it",
    "config": "`sweep run`, `slurm` or `accuracy` takes it",
    "shard": "`sweep show` describes it; `sweep merge {parent}` merges its run directory",
    "part": "`sweep show` describes it; rerunning the `sweep run` that wrote it resumes from it",
    "map": "`sweep show` describes it",
    "work-dir": "rerunning the command that made it resumes from it",
    "maps-dir": "`sweep show` describes each map in it",
}


def check_path(path, want: str, label: str) -> None:
    """Refuse (UserError: one line, exit code 2) a path of another kind than a parameter of kind
    `want` (WANTS) takes, saying what it is and which command takes it. `label`: the parameter
    as the user wrote it (`--out`, `STORE`)."""
    from ..runs.rundir import PATH_KINDS, path_kind

    wanted, takes = WANTS[want]
    kind = path_kind(path)
    if kind in ("missing", "unknown") or kind in takes:
        return
    fits = FITS.get(kind, "").format(parent=Path(path).parent)
    raise UserError(f"{label}: {path} is {PATH_KINDS[kind]}, not {wanted}"
                    + (f": {fits}" if fits else ""))


def param_label(param: click.Parameter | None) -> str:
    """A parameter as the user writes it: `--out` for an option, `STORE` for an argument."""
    if param is None:
        return "path"
    if isinstance(param, click.Option):
        return max(param.opts, key=len)
    return (param.metavar or param.name or "path").upper()


class KindPath(NonEmptyPath):
    """A path parameter that takes one kind of path (WANTS) and refuses the others by name
    (`check_path`), before the command does anything."""

    def __init__(self, want: str, **kwargs):
        super().__init__(path_type=Path, **kwargs)
        if want not in WANTS:
            raise ValueError(f"unknown kind of path {want!r}")
        self.want = want

    def convert(self, value, param, ctx):
        path = super().convert(value, param, ctx)
        check_path(path, self.want, param_label(param))
        return path


class SweepCommand(click.Command):
    """A command whose errors reach the user through `user_errors`; its path parameters
    refuse an empty path (`NonEmptyPath`)."""

    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        for p in self.params:
            if type(p.type) is click.Path:
                p.type.__class__ = NonEmptyPath   # same settings, one check more

    def invoke(self, ctx):
        with user_errors():
            return super().invoke(ctx)


class SweepGroup(click.Group):
    """The command group: parsing a command's arguments (a config is loaded then) runs inside
    `user_errors` too, and SIGTERM is handled from the start."""

    command_class = SweepCommand

    def invoke(self, ctx):
        with user_errors():
            return super().invoke(ctx)

    def parse_args(self, ctx, args):
        with user_errors():
            return super().parse_args(ctx, args)

    def main(self, *args, **kwargs):
        printable_paths()
        with sigterm_as_interrupt():
            return super().main(*args, **kwargs)


def printable_paths() -> None:
    """A file name with bytes that are not UTF-8 (held as surrogate escapes) is printed as those
    very bytes (in a UTF-8 locale Python's stdout would raise UnicodeEncodeError on it, after
    the file was written)."""
    for stream in (sys.stdout, sys.stderr):
        encoding = (getattr(stream, "encoding", "") or "").lower().replace("-", "")
        if encoding == "utf8" and hasattr(stream, "reconfigure"):
            with contextlib.suppress(ValueError, OSError, io.UnsupportedOperation):
                stream.reconfigure(errors="surrogateescape")


# ---------------------------------------------------------------------------------------------
# Parameter types and options shared by the commands
# ---------------------------------------------------------------------------------------------
class SceneParam(click.ParamType):
    """A YAML sweep config, loaded, validated and expanded into a `sweep.config.scene.Scene`."""

    name = "config"

    def convert(self, value, param, ctx):
        from ..model import ModelInputError
        from ..config.parse import load_scene
        from ..config.scene import Scene

        if isinstance(value, Scene):
            return value
        if isinstance(value, str) and value:
            check_path(value, "config", param_label(param))
        try:
            scene = load_scene(value)
        except ModelInputError as exc:
            # a bad config is not a usage mistake: one line naming the file and key, exit 2
            msg = str(exc)
            if not msg.startswith((str(value), Path(value).name)):
                msg = f"{value}: {msg}"
            raise UserError(msg) from None
        return scene


CONFIG = SceneParam()
PATH = click.Path(path_type=Path)
FILE = click.Path(dir_okay=False, path_type=Path)
#: Paths of one kind each (`KindPath`): a path of another kind is refused by name.
STORE = KindPath("store")
SWEEP_FILE = KindPath("sweep-file")
RUN_DIR = KindPath("run-dir")
STORE_OUT = KindPath("store-out")
RUN_DIR_OUT = KindPath("run-dir-out")
STORE_OR_RUN_OUT = KindPath("store-or-run-out")
FOLDER_OUT = KindPath("folder-out")
MAP_OUT = KindPath("map-out")
PICTURE_OUT = KindPath("picture-out")
WAIT = click.option("--wait", is_flag=True,
                    help="If another sweep is writing the same output, wait for it instead of "
                         "stopping at once.")
PROGRESS = click.option("--progress/--no-progress", default=True, show_default=True,
                        help="Progress bar on stderr (maps done, maps/s, ETA).")
THREADS = click.option("--threads", type=int, default=None,
                       help="Numba threads (default: SLURM_CPUS_PER_TASK, else every core).")
