"""sweep: design-space sweeps of underactuated two-finger grippers (friction-based potential
energy maps). The package's identity: its version and the exit code of an interrupted command
(read by `sweep.program` before anything else is imported, and by the CLI), and how to tell an
interrupt from an error."""
from __future__ import annotations

__version__ = "0.1.0"

#: Exit code of a command stopped by Ctrl-C or SIGTERM (128 + SIGINT, as a shell reports it)
EXIT_INTERRUPTED = 130


def interrupt_cause(exc: BaseException) -> KeyboardInterrupt | None:
    """The Ctrl-C / SIGTERM behind an exception, if any: Python (3.11) wraps an exception raised
    in some hooks (a class attribute's `__set_name__`, as `functools.cached_property`'s while
    `platform` is imported) in a RuntimeError whose cause is the KeyboardInterrupt."""
    seen = set()
    while exc is not None and id(exc) not in seen:
        if isinstance(exc, KeyboardInterrupt):
            return exc
        seen.add(id(exc))
        exc = exc.__cause__ or exc.__context__
    return None
