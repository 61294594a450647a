"""The kernels compiled before the first computation (sweep/compute/warm.py): one line says so
only when this kernel set is not in the cache, both kernel sets compile (the second in another
process), and the marker makes the next start quiet. The compilation itself is replaced by
fakes here (a cold compilation takes a minute; `make test-long` checks one for real)."""
from __future__ import annotations

import subprocess

import pytest

from sweep import kernels
from sweep.compute import warm


@pytest.fixture
def cold(tmp_path, monkeypatch):
    """An empty kernel cache, and fakes that record what would compile."""
    done = []
    monkeypatch.setattr(kernels, "_CACHE_DIRECTORY", tmp_path / "kernels-x")
    monkeypatch.setattr(warm, "compile_maps", lambda: done.append("maps"))
    monkeypatch.setattr(warm, "compile_summaries", lambda: done.append("summaries"))

    class Second:
        def __init__(self, args, **kw):
            self.args = args
            done.append("process: " + " ".join(args[1:]))

        def wait(self):
            return 0

    monkeypatch.setattr(subprocess, "Popen", Second)
    return done


def test_a_cold_cache_compiles_both_sets_says_so_once_and_leaves_its_marker(cold):
    said = []
    assert not warm.is_compiled()
    warm.ensure_compiled(said.append)
    assert said == [f"compiling kernels (first run only, about {warm.COLD_SECONDS} s)"]
    assert cold == ["process: -m sweep.compute.warm summaries", "maps"]
    assert warm.is_compiled()
    warm.ensure_compiled(said.append)   # the next start: nothing said, nothing compiled
    assert len(said) == 1 and len(cold) == 2


def test_the_second_set_compiles_here_when_the_second_process_fails(cold, monkeypatch):
    class Failing:
        def __init__(self, args, **kw):
            pass

        def wait(self):
            return 1

    monkeypatch.setattr(subprocess, "Popen", Failing)
    warm.ensure_compiled(lambda _: None)
    assert cold == ["maps", "summaries"] and warm.is_compiled()


def test_an_interrupted_compilation_leaves_no_marker(cold, monkeypatch):
    def interrupted():
        raise KeyboardInterrupt

    monkeypatch.setattr(warm, "compile_maps", interrupted)
    with pytest.raises(KeyboardInterrupt):
        warm.ensure_compiled(lambda _: None)
    assert not warm.is_compiled()
