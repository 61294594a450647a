"""The one place where errors reach the user, for every command of the CLI.

`user_errors()` turns what a user can cause or fix - bad input (`ModelInputError`, `SceneError`),
an unusable file or directory (`StoreError`, `OutputError`, any `OSError`) - into one line on
stderr and exit code 2, and Ctrl-C or SIGTERM into one line and exit code 130. Anything else is a
bug and keeps its traceback. `SweepCommand` and `SweepGroup` run every command (and the parsing
of its arguments, where configs are loaded) inside it, so no command handles errors itself.

Imports stay light (click only): the heavy modules load inside commands, where an interrupt is
already handled.
"""
from __future__ import annotations

import contextlib
import signal
import sys

import click

EXIT_INTERRUPTED = 130


class UserError(click.ClickException):
    """Bad input or an unusable file/directory: one line, exit code 2."""

    exit_code = 2


class Terminated(KeyboardInterrupt):
    """SIGTERM (a batch system's time limit or `kill`) handled like Ctrl-C."""


@contextlib.contextmanager
def sigterm_as_interrupt():
    """Raise `Terminated` in the main thread on SIGTERM for the duration of the block."""
    def handler(signum, frame):
        raise Terminated()

    try:
        previous = signal.signal(signal.SIGTERM, handler)
    except ValueError:          # not the main thread
        yield
        return
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, previous)


def _user_error_types() -> tuple[type, ...]:
    # Imported here, not at the top: only modules already loaded can have raised these.
    types: list[type] = []
    for module, name in (("sweep.model", "ModelInputError"), ("sweep.store", "StoreError"),
                         ("sweep.outputs", "OutputError")):
        mod = sys.modules.get(module)
        if mod is not None:
            types.append(getattr(mod, name))
    return tuple(types)


def interrupted_message(exc: KeyboardInterrupt, hint: str = "") -> str:
    what = "terminated" if isinstance(exc, Terminated) else "interrupted"
    return f"sweep: {what}" + (f"; {hint}" if hint else "; nothing was written")


@contextlib.contextmanager
def user_errors():
    """Errors the user can fix -> one line, exit 2; Ctrl-C / SIGTERM -> one line, exit 130."""
    with sigterm_as_interrupt():
        try:
            yield
        except (click.exceptions.Exit, click.ClickException, click.Abort, SystemExit):
            raise
        except KeyboardInterrupt as exc:
            click.echo(interrupted_message(exc), err=True)
            sys.exit(EXIT_INTERRUPTED)
        except OSError as exc:
            if isinstance(exc, _user_error_types()):
                raise UserError(str(exc)) from None
            from .outputs import os_error_message

            raise UserError(os_error_message(exc, exc.filename or "sweep", "failed")) from None
        except Exception as exc:
            if isinstance(exc, _user_error_types()):
                raise UserError(str(exc)) from None
            raise


class SweepCommand(click.Command):
    """A command whose errors reach the user through `user_errors`."""

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

    def main(self, *args, **kwargs):
        with sigterm_as_interrupt():
            return super().main(*args, **kwargs)
