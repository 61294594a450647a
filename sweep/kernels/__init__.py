"""Numba kernels. Only this package holds `@njit` code; the layers above call it.

finger     one finger's mechanics: contact geometry and vertex strikes (MODEL 3, 4), statics in
           joint-torque space (MODEL 5.1-5.3, tip_contact), the edge and tip paths of a finger
           that cannot hold, the closing sequence, energy and forces (MODEL 4-6)
hand       two fingers and the part: part equilibrium, containment, opening (MODEL 7, 8), and
           finger_collision, where the two closing fingers first meet (MODEL 9, D14)
records    the parameter and result records every kernel takes and returns
field      grids of points: one position anywhere, trajectories (MODEL 8), one map's finger
           fields, outcomes and summary, many maps at once from shared finger fields
streamline the continuous trajectories (MODEL 8, D12)
hull       exact 2-D convex hulls of forces per pose, mergeable (manipulation metric, MODEL 10)

Compiled kernels are cached on disk (`cache=True`). Numba checks only the file of the function it
loads, so a kernel that inlines a changed function from another file would load stale code: the
cache directory is therefore keyed by a hash of every kernel source (and of `model.py` and
`schema.py`, whose constants are frozen into them). It lives under $NUMBA_CACHE_DIR if set (on a
cluster, point it at node-local disk), else under $XDG_CACHE_HOME/sweep (default ~/.cache/sweep).
"""
import hashlib
import os
from pathlib import Path

import numba


def _kernel_source_digest() -> str:
    here = Path(__file__).resolve().parent
    digest = hashlib.sha256()
    for path in sorted([*here.glob("*.py"), here.parent / "model.py", here.parent / "schema.py"]):
        digest.update(path.name.encode())
        digest.update(path.read_bytes())
    return digest.hexdigest()[:16]


def _cache_root() -> Path:
    if os.environ.get("NUMBA_CACHE_DIR"):
        return Path(os.environ["NUMBA_CACHE_DIR"])
    return Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache") / "sweep"


def cache_directory() -> Path:
    """Where this kernel set (these sources) is cached."""
    return _CACHE_DIRECTORY


_CACHE_DIRECTORY = _cache_root() / f"kernels-{_kernel_source_digest()}"
# Numba picks a function's cache location when it is decorated, so set the directory, decorate
# every kernel (import the modules), then restore the setting for the user's own Numba code.
_user_cache_dir = numba.config.CACHE_DIR
numba.config.CACHE_DIR = str(_CACHE_DIRECTORY)
try:
    from . import field, finger, hand, hull, records, streamline  # noqa: E402,F401
finally:
    numba.config.CACHE_DIR = _user_cache_dir
