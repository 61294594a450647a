"""How a kernel is compiled: two decorators, by who calls it.

`entry`: a kernel that Python code calls (the compute layer, the report's pictures, tests).
`inner`: a kernel that only other kernels call. It is compiled without the Python and C
wrappers, which takes a fifth less time to compile (docs/performance.md, cold compilation);
calling it from Python would crash the interpreter, so nothing outside `sweep/kernels/` may
import it (tests/test_layers.py reads every import and checks).

Both cache the compiled code on disk (kernels/__init__.py keys the cache by the sources).
"""
from numba import njit


def entry(fn=None, **options):
    """A kernel called from Python; `options`: Numba's (nogil, parallel)."""
    if fn is None:
        return lambda f: njit(cache=True, **options)(f)
    return njit(cache=True, **options)(fn)


def inner(fn=None, **options):
    """A kernel called only by other kernels (no Python wrapper). `options`: Numba's; only
    `inline="always"`, and only on a small leaf with one or two callers that hold arrays: a
    call of a kernel that can fail keeps the caller's reference counts on its arrays (the error
    path skips the decrement, so LLVM's pruning cannot pair them); inlined, there is no such
    path (docs/performance.md)."""
    if fn is None:
        return lambda f: inner(f, **options)
    return njit(cache=True, no_cpython_wrapper=True, no_cfunc_wrapper=True, **options)(fn)
