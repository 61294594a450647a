"""The `sweep` program (the console script): the CLI with interrupts handled from the start.

Kept tiny and free of imports beyond the standard library, so that Ctrl-C or SIGTERM while the
CLI itself is still being imported (click, the first ~50 ms) is one line and exit code 130 as
well; only Python's own start-up, before this module runs, is out of reach.
"""
from __future__ import annotations

import _thread
import contextlib
import signal
import sys

from . import EXIT_INTERRUPTED, interrupt_cause


class _Terminated(KeyboardInterrupt):
    """SIGTERM while the CLI is imported."""

    signum = signal.SIGTERM


def _unraisable(unraisable) -> None:
    """`sys.unraisablehook`: an interrupt that hit a finalizer or a weakref callback (Numba's
    and the standard library's caches clear themselves through these while modules load) is
    delivered again instead of printed.

    Python cannot raise an exception there: it prints "Exception ignored in: <function ...>"
    with the KeyboardInterrupt's traceback and goes on as if Ctrl-C had not been pressed. A
    short-lived thread delivers the same signal to the main thread again
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


def _terminated(signum, frame):
    raise _Terminated()


def main(argv=None) -> None:
    sys.unraisablehook = _unraisable
    with contextlib.suppress(ValueError):              # not the main thread
        signal.signal(signal.SIGTERM, _terminated)
    try:
        from .cli import main as cli
    except BaseException as exc:
        # a Ctrl-C in a class's __set_name__ while a module loads comes wrapped in a RuntimeError
        interrupt = interrupt_cause(exc)
        if interrupt is None:
            raise
        what = "terminated" if isinstance(interrupt, _Terminated) else "interrupted"
        sys.stderr.write(f"sweep: {what}; nothing was written\n")
        sys.exit(EXIT_INTERRUPTED)
    try:
        cli(args=argv, prog_name="sweep")
    finally:
        # The command has finished (its result written or its error reported): a late signal
        # must not turn it into a traceback or a death by signal while the interpreter shuts
        # down. The handlers become a Python no-op (with SIG_IGN a signal already pending would
        # print "Signal 2 ignored due to race condition"); the switch itself is inside the try,
        # so a signal that arrives just before it is dropped and the command's status stands.
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


if __name__ == "__main__":  # pragma: no cover
    main()
