"""Interrupts, in one place: Ctrl-C and SIGTERM end a command with one line and exit code 130.

What a user is promised: once the program runs (`sweep.program.main`), an interrupt - Ctrl-C,
or SIGTERM from `kill` or a batch system's time limit - ends it with one line on stderr ("sweep:
interrupted; ...") and exit code 130, whether it lands while the CLI is imported, while a command
runs or while it writes; and it never leaves a half-written file (every file is written under a
temporary name and renamed into place when complete, `sweep.files`). Python's own start-up,
before the program runs, is Python's: an interrupt there ends the way Python ends it.

Three ways an interrupt could otherwise escape, and what this module does about each:

- Python (3.11) wraps a KeyboardInterrupt raised in some hooks (a class attribute's
  `__set_name__`, as `functools.cached_property`'s while `platform` is imported) in a
  RuntimeError caused by it: `interrupt_cause` follows an exception's causes to it.
- An interrupt that lands in a weakref callback or a finalizer cannot be raised there: Python
  prints "Exception ignored in: ..." and carries on as if it had not come. `deliver_again`
  (the program's `sys.unraisablehook`) has the same signal delivered again to the code that
  runs next.
- A signal that comes after the command has finished must not turn its result into a traceback
  or a death by signal while the interpreter shuts down: `ignore_late_signals`.

Standard library only: the program imports this before the CLI, so that an interrupt while the
CLI is imported is handled too.
"""
from __future__ import annotations

import _thread
import contextlib
import signal
import sys

#: Exit code of a command stopped by Ctrl-C or SIGTERM (128 + SIGINT, as a shell reports it).
EXIT_INTERRUPTED = 130


class Terminated(KeyboardInterrupt):
    """SIGTERM (a batch system's time limit or `kill`) handled like Ctrl-C."""

    signum = signal.SIGTERM     # the signal to deliver again (`deliver_again`)


def raise_terminated(signum, frame):
    """A SIGTERM handler: raise `Terminated` where the main thread is."""
    raise Terminated()


@contextlib.contextmanager
def sigterm_as_interrupt():
    """Raise `Terminated` in the main thread on SIGTERM for the duration of the block."""
    try:
        previous = signal.signal(signal.SIGTERM, raise_terminated)
    except ValueError:          # not the main thread
        yield
        return
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, previous)


def interrupt_cause(exc: BaseException) -> KeyboardInterrupt | None:
    """The Ctrl-C / SIGTERM behind an exception, if any: the exception itself or one of its
    causes (see the module docstring)."""
    seen = set()
    while exc is not None and id(exc) not in seen:
        if isinstance(exc, KeyboardInterrupt):
            return exc
        seen.add(id(exc))
        exc = exc.__cause__ or exc.__context__
    return None


def interrupted_message(exc: KeyboardInterrupt, hint: str = "") -> str:
    """The one line an interrupted command prints: what stopped it, and what was kept (`hint`)
    or that nothing was written."""
    what = "terminated" if isinstance(exc, Terminated) else "interrupted"
    return f"sweep: {what}" + (f"; {hint}" if hint else "; nothing was written")


def exit_if_interrupted(exc: BaseException) -> None:
    """One line and exit code 130 if an interrupt is behind `exc`; else return (the caller
    raises `exc` again)."""
    interrupt = interrupt_cause(exc)
    if interrupt is not None:
        sys.stderr.write(interrupted_message(interrupt) + "\n")
        sys.exit(EXIT_INTERRUPTED)


def deliver_again(unraisable) -> None:
    """`sys.unraisablehook`: an interrupt that hit a finalizer or a weakref callback (Numba's
    and the standard library's caches clear themselves through these while modules load) is
    delivered again instead of printed.

    A short-lived thread delivers the same signal to the main thread again
    (`_thread.interrupt_main`); it lands after this hook has returned, in the code that runs
    next, whose handling makes it one line and exit 130. From this hook itself the signal's
    handler would run before the hook returns, and raise in it."""
    if not (isinstance(unraisable.exc_type, type)
            and issubclass(unraisable.exc_type, KeyboardInterrupt)):
        sys.__unraisablehook__(unraisable)
        return
    signum = getattr(unraisable.exc_value, "signum", signal.SIGINT)
    try:
        _thread.start_new_thread(_thread.interrupt_main, (signum,))
    except (KeyboardInterrupt, RuntimeError):
        # Interrupted here (the thread is started: the interrupt is on its way), or the
        # interpreter is shutting down (nothing left to interrupt).
        pass


def handle_from_now_on() -> None:
    """What the program does first: interrupts that land in finalizers are delivered again, and
    SIGTERM is raised as `Terminated` (Python raises Ctrl-C as KeyboardInterrupt itself)."""
    sys.unraisablehook = deliver_again
    with contextlib.suppress(ValueError):              # not the main thread
        signal.signal(signal.SIGTERM, raise_terminated)


def ignore_late_signals() -> None:
    """After the command has finished (its result written or its error reported): SIGINT and
    SIGTERM become a Python no-op, so that the command's status stands.

    Not SIG_IGN: with it a signal already pending would print "Signal 2 ignored due to race
    condition". The switch itself is retried, so a signal that arrives just before it is
    dropped."""
    while True:
        try:
            signal.signal(signal.SIGINT, _dropped)
            signal.signal(signal.SIGTERM, _dropped)
            break
        except KeyboardInterrupt:
            continue
        except ValueError:              # not the main thread
            break


def _dropped(signum, frame):
    """A signal after the command has finished: nothing left to interrupt."""
