"""sweep: design-space sweeps of underactuated two-finger grippers (friction-based potential
energy maps). The package's identity: its version and the exit code of an interrupted command
(read by `sweep.program` before anything else is imported, and by the CLI)."""
__version__ = "0.1.0"

#: Exit code of a command stopped by Ctrl-C or SIGTERM (128 + SIGINT, as a shell reports it)
EXIT_INTERRUPTED = 130
