"""docs/model-notes.md's decisions can be followed: its sections D<n> in numeric order, its index
listing each one with its link, the numbers never used said so, and every decision that code,
tests, scripts and docs cite ("model-notes D14", "D31-D34") one that exists (`make lint`)."""
from __future__ import annotations

import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
NOTES = ROOT / "docs" / "model-notes.md"
SECTION = re.compile(r"^## D(\d+)\. (.+)$", re.M)
INDEX_ROW = re.compile(r"^\| \[D(\d+)\]\(#([^)]+)\) \| (.+) \|$", re.M)
NEVER_USED = re.compile(r"D(\d+)-D(\d+) were never used")
CITED = re.compile(r"\bD(\d+)\b")
#: Where decisions are cited: the package, tests, scripts, docs, the top-level pages, configs.
SOURCES = ("sweep/**/*.py", "tests/**/*.py", "scripts/**/*.py", "scripts/*.yaml", "docs/*.md",
           "*.md", "Makefile", "configs/*.yaml")


def anchor(heading: str) -> str:
    """The anchor a Markdown renderer (GitHub's rule) gives a heading."""
    return re.sub(r"[^\w\- ]", "", heading.strip().lower()).replace(" ", "-")


def sections() -> list[tuple[int, str]]:
    return [(int(n), title) for n, title in SECTION.findall(NOTES.read_text())]


def never_used() -> set[int]:
    found = NEVER_USED.findall(NOTES.read_text())
    assert len(found) <= 1, "say once which numbers were never used"
    return {n for a, b in found for n in range(int(a), int(b) + 1)}


def test_sections_are_in_numeric_order_and_every_number_is_used_or_said_unused():
    numbers = [n for n, _ in sections()]
    assert numbers == sorted(numbers) and len(set(numbers)) == len(numbers), numbers
    unused = never_used()
    assert not unused & set(numbers)
    assert set(numbers) | unused == set(range(1, max(numbers) + 1)), \
        "a number neither used nor said never used"


def test_the_index_lists_every_section_with_its_link():
    rows = INDEX_ROW.findall(NOTES.read_text())
    want = [(n, anchor(f"D{n}. {title}"), title) for n, title in sections()]
    assert [(int(n), a, t) for n, a, t in rows] == want


def test_links_to_a_decision_find_it():
    anchors = {anchor(f"D{n}. {title}") for n, title in sections()}
    broken = []
    for path in (ROOT / "docs").glob("*.md"):
        for target in re.findall(r"model-notes\.md#([\w-]+)", path.read_text()):
            if target.startswith("d") and target not in anchors:
                broken.append((path.name, target))
        if path == NOTES:
            broken += [(path.name, t) for t in re.findall(r"\]\(#(d\d+[\w-]*)\)", path.read_text())
                       if t not in anchors]
    assert not broken


def test_every_decision_cited_exists():
    exists = {n for n, _ in sections()}
    unused_line = NEVER_USED.pattern
    missing = []
    for pattern in SOURCES:
        for path in sorted(ROOT.glob(pattern)):
            if ".venv" in path.parts or path == Path(__file__):
                continue
            for k, line in enumerate(path.read_text(errors="replace").splitlines(), 1):
                if re.search(unused_line, line):
                    continue
                line = line.split("noqa:")[0]          # a linter's codes (D107) are not decisions
                missing += [(path.relative_to(ROOT).as_posix(), k, f"D{n}")
                            for n in CITED.findall(line) if int(n) not in exists]
    assert not missing, "cited decisions that docs/model-notes.md does not have"


def test_the_checker_finds_a_decision_that_does_not_exist():
    assert CITED.findall("model-notes D23, D31-D34 and MODEL 5.3") == ["23", "31", "34"]
    assert int(CITED.findall("as D23 says")[0]) not in {n for n, _ in sections()}
