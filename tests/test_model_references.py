"""docs/model.md's references to the code are true: each module it names exists, each function it
names is defined where it says, each test it names exists, and each kernel function it names is
one the pipeline calls (reached from a command), not a twin only tests call while the pipeline
computes the formula another way (MODEL 8's `mouth_opening` was one).

"Reached" is read from the source, by name: from every command function (sweep/cli/) and the
module-level code of the layers above the kernels, follow every name a function mentions to the
functions of that name. Over-approximate (two functions of one name are both reached), so a
failure is real: nothing in production mentions the function at all.
"""
from __future__ import annotations

import ast
import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
MODEL_MD = ROOT / "docs" / "model.md"

SPAN = re.compile(r"`([^`\n]+)`")
MODULE_REF = re.compile(r"^(?:sweep/)?(kernels/\w+\.py|[\w/]+\.py)(?::\s*(\w+))?$")
IDENTIFIER = re.compile(r"^[a-z][a-z0-9_]*$")


def functions_by_module(package: Path) -> dict[str, dict[str, ast.FunctionDef]]:
    """{path relative to the package's parent: {function name: node}} (top-level functions)."""
    out = {}
    for path in sorted(package.rglob("*.py")):
        tree = ast.parse(path.read_text())
        out[path.relative_to(package.parent).as_posix()] = {
            n.name: n for n in tree.body if isinstance(n, ast.FunctionDef)}
    return out


def names_in(node: ast.AST) -> set[str]:
    found = set()
    for n in ast.walk(node):
        if isinstance(n, ast.Name):
            found.add(n.id)
        elif isinstance(n, ast.Attribute):
            found.add(n.attr)
    return found


def reached_functions(package: Path, roots: tuple[str, ...]) -> set[str]:
    """Names of the functions reached from the command functions and the module-level code of
    the modules under `roots` (folders or files relative to the package)."""
    defs: dict[str, list[ast.FunctionDef]] = {}
    start: set[str] = set()
    for path in sorted(package.rglob("*.py")):
        tree = ast.parse(path.read_text())
        rel = path.relative_to(package).as_posix()
        is_root = any(rel == r or rel.startswith(r.rstrip("/") + "/") for r in roots)
        for node in tree.body:
            if isinstance(node, ast.FunctionDef):
                defs.setdefault(node.name, []).append(node)
                if is_root and rel.startswith("cli/"):
                    start.add(node.name)
            elif is_root:
                start |= names_in(node)
    reached, todo = set(), [n for n in start if n in defs]
    while todo:
        name = todo.pop()
        if name in reached:
            continue
        reached.add(name)
        for node in defs[name]:
            todo.extend(n for n in names_in(node) if n in defs and n not in reached)
    return reached


def defined_tests(tests: Path) -> set[str]:
    return {n.name for p in tests.glob("test_*.py") for n in ast.walk(ast.parse(p.read_text()))
            if isinstance(n, ast.FunctionDef) and n.name.startswith("test_")}


#: The layers above the kernels: a kernel function is production code if these reach it.
PRODUCTION = ("cli/", "runs/", "compute/", "storage/", "report/", "config/", "program.py")


def check(doc: str, package: Path, tests: Path) -> list[str]:
    """Every false reference of `doc` to the code under `package` and `tests`, as messages."""
    modules = functions_by_module(package)
    defined = {name: mod for mod, fns in modules.items() for name in fns}
    kernels = {name for mod, fns in modules.items() if mod.startswith(f"{package.name}/kernels/")
               for name in fns}
    reached = reached_functions(package, PRODUCTION)
    tested = defined_tests(tests)
    problems = []
    for span in sorted(set(SPAN.findall(doc))):
        ref = MODULE_REF.match(span)
        if ref:
            module, name = ref.groups()
            path = f"{package.name}/{module}"
            if module.startswith("tests/"):
                if not (tests.parent / module).exists():
                    problems.append(f"`{span}`: no such file")
            elif path not in modules:
                problems.append(f"`{span}`: no module {path}")
            elif name and name not in modules[path]:
                problems.append(f"`{span}`: {path} defines no function {name}")
            continue
        if not IDENTIFIER.match(span):
            continue
        if span.startswith("test_"):
            if span not in tested:
                problems.append(f"`{span}`: no such test in {tests.name}/")
        elif span in kernels and span not in reached:
            problems.append(f"`{span}` ({defined[span]}): the pipeline never calls it")
    return problems


def test_model_md_references_are_true():
    problems = check(MODEL_MD.read_text(), ROOT / "sweep", ROOT / "tests")
    assert not problems, "docs/model.md:\n" + "\n".join(problems)


def test_model_md_names_kernel_functions():
    """The check has something to check: model.md names kernel functions of several modules."""
    modules = functions_by_module(ROOT / "sweep")
    named = {mod for mod, fns in modules.items() if mod.startswith("sweep/kernels/")
             for name in fns if f"`{name}`" in MODEL_MD.read_text()}
    assert len(named) >= 5, named


def test_check_finds_each_kind_of_false_reference(tmp_path):
    package = tmp_path / "sweep"
    (package / "kernels").mkdir(parents=True)
    (package / "cli").mkdir()
    (package / "kernels" / "hand.py").write_text(
        "def opening(a):\n    return a\n\n\ndef opening_twin(a):\n    return a\n")
    (package / "cli" / "run.py").write_text(
        "from ..kernels.hand import opening\n\n\ndef run():\n    return opening(1)\n")
    tests = tmp_path / "tests"
    tests.mkdir()
    (tests / "test_x.py").write_text("def test_opening():\n    pass\n")
    doc = ("`opening` `kernels/hand.py: opening` `test_opening` `tests/test_x.py` "
           "`opening_twin` `kernels/meeting.py` `kernels/hand.py: closing` `test_gone`")
    problems = check(doc, package, tests)
    assert problems == [
        "`kernels/hand.py: closing`: sweep/kernels/hand.py defines no function closing",
        "`kernels/meeting.py`: no module sweep/kernels/meeting.py",
        "`opening_twin` (sweep/kernels/hand.py): the pipeline never calls it",
        "`test_gone`: no such test in tests/",
    ]
