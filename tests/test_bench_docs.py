"""The benchmark entry point and the docs agree (docs/performance.md, "How to benchmark"): every
subcommand of scripts/bench.py answers --help and is documented; every script a doc, the
Makefile, a config or a test names exists; no doc names a machine's own paths."""
from __future__ import annotations

import importlib.util
import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
_spec = importlib.util.spec_from_file_location("bench", ROOT / "scripts" / "bench.py")
bench = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(bench)

DOCS = sorted((ROOT / "docs").glob("*.md")) + [ROOT / "README.md"]


@pytest.mark.parametrize("module", bench.SUBCOMMANDS, ids=lambda m: m.NAME)
def test_every_subcommand_answers_help_and_is_in_performance_md(module, capsys):
    with pytest.raises(SystemExit) as stop:
        bench.parser().parse_args([module.NAME, "--help"])
    assert stop.value.code == 0
    assert module.__doc__.strip().splitlines()[0] in " ".join(capsys.readouterr().out.split())
    table = (ROOT / "docs" / "performance.md").read_text()
    assert f"| `{module.NAME}` |" in table, f"{module.NAME} missing from the subcommand table"


def test_every_script_named_exists():
    named = set()
    for path in [*DOCS, ROOT / "Makefile", *ROOT.glob("configs/*.yaml"), *ROOT.glob("tests/*.py"),
                 *ROOT.glob("*.md")]:
        named |= {(path.name, m) for m in re.findall(r"(?:scripts|docs/notes)/[\w-]+\.py",
                                                     path.read_text())}
    missing = sorted((where, m) for where, m in named if not (ROOT / m).is_file())
    assert not missing


def test_no_machine_specific_paths_in_docs():
    pattern = re.compile(r"(?<![\w$}.])(/tmp|/work|/home|/root|/Users|~)/")
    found = [(path.name, n, line.strip()) for path in DOCS
             for n, line in enumerate(path.read_text().splitlines(), 1) if pattern.search(line)]
    assert not found


def test_every_tool_in_scripts_is_in_contributings_table():
    """scripts/ holds tools, each listed with its purpose in CONTRIBUTING.md's table; finished
    investigations live in docs/notes/, beside the docs that report them."""
    table = (ROOT / "CONTRIBUTING.md").read_text()
    tools = [p for p in sorted((ROOT / "scripts").iterdir()) if p.is_file()]
    assert tools and not [p.name for p in tools if f"| `scripts/{p.name}` |" not in table]
    notes = [p.name for p in sorted((ROOT / "docs" / "notes").glob("*.py"))]
    assert notes and not [n for n in notes if f"`{n}`" not in table]
