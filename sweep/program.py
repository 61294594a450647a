"""The `sweep` program (the console script, `python -m sweep`): the CLI with interrupts handled
from its first statement (`sweep.interrupts`).

Kept tiny and free of imports beyond the standard library, so that Ctrl-C or SIGTERM while the
CLI itself is still being imported (click, the first ~50 ms) is one line and exit code 130 as
well.
"""
from __future__ import annotations

from . import interrupts


def main(argv=None) -> None:
    try:
        interrupts.handle_from_now_on()
        from .cli import main as cli
    except BaseException as exc:
        interrupts.exit_if_interrupted(exc)
        raise
    try:
        cli(args=argv, prog_name="sweep")
    finally:
        interrupts.ignore_late_signals()


if __name__ == "__main__":  # pragma: no cover
    main()
