"""Numba kernels. Only this package holds `@njit` code; the layers above call it.

In reading order (each module imports only those above it):

records          the parameter and result records every kernel takes and returns
finger_geometry  one finger's contact geometry and vertex strikes, closed form (MODEL 3, 4)
finger_statics   its statics in joint-torque space (MODEL 5.1-5.3), energy and forces (MODEL 6)
finger_paths     the edge and tip paths of a finger whose first contact cannot hold (MODEL 5.3)
finger           the configuration a finger reaches: closing sequence, then settling (MODEL 4, 5)
hand             the part between the fingers: equilibrium, containment, opening (MODEL 7, 8)
meeting          finger_collision's rule and reference search, own paths (MODEL 9, D14, D29)
meeting_roots    where a vertex first meets a segment of the other finger, closed form (D14)
meeting_search   finger_collision over a map: the reference's bits, found faster (D14)
outcome          one part position anywhere: class and energy (MODEL 4-8)
streamline       the continuous trajectories (MODEL 8, D12)
trajectories     from every point downhill to where the part stops (MODEL 8, D16)
one_map          one map: finger fields, outcomes, trajectories, summary
hull             exact 2-D convex hulls of forces per pose, mergeable (MODEL 10)
many_maps        many maps from one shared finger field, forces per pose (MODEL 10)

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
    from . import (  # noqa: E402,F401
        finger, finger_geometry, finger_paths, finger_statics, hand, hull, many_maps, meeting,
        meeting_roots, meeting_search, one_map, outcome, records, streamline, trajectories,
    )
finally:
    numba.config.CACHE_DIR = _user_cache_dir
