"""sweep: design-space sweeps of underactuated two-finger grippers (friction-based potential
energy maps). The package's identity: its version."""
from __future__ import annotations

__version__ = "0.1.0"
