"""README.md is short and its commands work on a fresh clone: at most 150 lines of at most 120
characters; every command of its code blocks that takes seconds runs, in order, in an empty
folder with the repository's configs (as after `make run`'s install: `.venv/bin/sweep`), and its
Python snippet runs on what they wrote; the long ones (the paper's configs, a cluster's `sbatch`)
name files that exist; every `make` target and `sweep` command it names exists."""
from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
README = ROOT / "README.md"
BLOCK = re.compile(r"^```(\w+)\n(.*?)^```$", re.M | re.S)
#: Commands the test does not run: the paper's whole sweep (minutes), a real cluster.
LONG = re.compile(r"configs/paper|^sbatch |--submit")


def commands(block: str) -> list[str]:
    """The shell commands of a block: continuation lines joined, comments dropped."""
    out = []
    for line in block.replace("\\\n", " ").splitlines():
        line = re.sub(r"\s+#.*$", "", line).strip()
        if line and not line.startswith("#"):
            out.append(line)
    return out


def blocks() -> list[tuple[str, str]]:
    return BLOCK.findall(README.read_text())


def make_targets() -> set[str]:
    return set(re.findall(r"^([\w-]+):", (ROOT / "Makefile").read_text(), re.M))


def test_readme_is_short():
    lines = README.read_text().splitlines()
    assert len(lines) <= 150
    assert not [k for k, line in enumerate(lines, 1) if len(line) > 120]


def test_every_make_target_and_sweep_command_named_exists():
    from sweep.cli import main

    text = README.read_text()
    assert not set(re.findall(r"\bmake ([a-z][\w-]*)", text)) - make_targets()
    named = set(re.findall(r"(?:`|bin/)sweep ([a-z]+)\b", text))     # a command, not prose
    assert named and not named - set(main.commands)


def test_long_commands_name_files_that_exist():
    long = [c for lang, b in blocks() if lang == "sh" for c in commands(b) if LONG.search(c)]
    assert long
    for command in long:
        for path in re.findall(r"configs/[\w.-]+", command):
            assert (ROOT / path).is_file(), command


@pytest.mark.slow
def test_quick_commands_run_on_a_fresh_clone(tmp_path):
    (tmp_path / "configs").symlink_to(ROOT / "configs")
    (tmp_path / ".venv" / "bin").mkdir(parents=True)
    (tmp_path / ".venv" / "bin" / "sweep").symlink_to(Path(sys.executable).parent / "sweep")
    ran = []
    for lang, block in blocks():
        if lang == "python":
            run = [sys.executable, "-c", block]
        else:
            assert lang == "sh", lang
            quick = [c for c in commands(block) if not LONG.search(c)]
            for command in quick:
                if command.startswith("make "):
                    assert command.split()[1] in make_targets(), command
                    continue
                res = subprocess.run(["bash", "-c", command], cwd=tmp_path, capture_output=True,
                                     text=True, timeout=600)
                assert res.returncode == 0, (command, res.stderr[-2000:])
                ran.append(command)
            continue
        res = subprocess.run(run, cwd=tmp_path, capture_output=True, text=True, timeout=600)
        assert res.returncode == 0, res.stderr[-2000:]
        ran.append("python")
    assert len(ran) >= 8 and "python" in ran
    assert (tmp_path / "report" / "report.md").is_file() and (tmp_path / "two.h5").is_file()


def test_every_page_it_links_exists():
    text = README.read_text()
    pages = set(re.findall(r"\]\(([^)#\s]+)\)", text)) | set(re.findall(r"docs/[\w-]+\.md", text))
    assert pages and not [p for p in pages if not (ROOT / p).exists()]
