"""The `sweep` program (the console script): the CLI with interrupts handled from the start.

Kept tiny and free of imports beyond the standard library, so that Ctrl-C or SIGTERM while the
CLI itself is still being imported (click, the first ~50 ms) is one line and exit code 130 as
well; only Python's own start-up, before this module runs, is out of reach.
"""
from __future__ import annotations

import contextlib
import signal
import sys

EXIT_INTERRUPTED = 130


class _Terminated(KeyboardInterrupt):
    """SIGTERM while the CLI is imported."""


def _terminated(signum, frame):
    raise _Terminated()


def main(argv=None) -> None:
    with contextlib.suppress(ValueError):              # not the main thread
        signal.signal(signal.SIGTERM, _terminated)
    try:
        from .cli import main as cli
    except KeyboardInterrupt as exc:
        what = "terminated" if isinstance(exc, _Terminated) else "interrupted"
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
