"""The compiled-kernel cache is keyed by the kernel sources, so no stale code is ever loaded."""
import os
import subprocess
import sys
from pathlib import Path

import numba

import sweep.kernels as kernels


def test_cache_directory_is_keyed_by_the_kernel_sources():
    from sweep.kernels.one_map import finger_rows
    from sweep.kernels.many_maps import summarize_cells

    key = f"kernels-{kernels._kernel_source_digest()}"
    for dispatcher in (finger_rows, summarize_cells):
        assert key in dispatcher._cache._cache_path
    # the user's own Numba setting is left as it was
    assert key not in (numba.config.CACHE_DIR or "")


def test_digest_changes_with_any_kernel_source(tmp_path, monkeypatch):
    fake = tmp_path / "sweep"
    (fake / "kernels").mkdir(parents=True)
    for path in Path(kernels.__file__).parent.glob("*.py"):
        (fake / "kernels" / path.name).write_bytes(path.read_bytes())
    for name in ("model.py", "schema.py"):
        (fake / name).write_bytes((Path(kernels.__file__).parent.parent / name).read_bytes())
    monkeypatch.setattr(kernels, "__file__", str(fake / "kernels" / "__init__.py"))
    before = kernels._kernel_source_digest()
    part = fake / "kernels" / "hand.py"
    part.write_text(part.read_text() + "\n# changed\n")
    after_kernel = kernels._kernel_source_digest()
    assert after_kernel != before
    # the schema's summary positions are frozen into the kernels too
    schema = fake / "schema.py"
    schema.write_text(schema.read_text() + "\n# changed\n")
    assert kernels._kernel_source_digest() != after_kernel


def test_numba_cache_dir_is_respected(tmp_path):
    # one small kernel is enough to show where the cache goes (compiling them all takes long)
    code = ("from sweep.kernels.finger import distal_tangency; "
            "assert distal_tangency(2.0, 1.0, 0.5, 1.0, 0.4)[1] > 0.0")
    env = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path))
    subprocess.run([sys.executable, "-c", code], check=True, env=env)
    caches = list(tmp_path.glob("kernels-*/**/*.nbi"))
    assert caches, "no cache index written under NUMBA_CACHE_DIR"
