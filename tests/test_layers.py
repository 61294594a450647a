"""The layers of the package (docs/architecture.md) as its imports obey them.

Every `import` of a `sweep` module, at the top of a file or inside a function, is an edge of the
import graph, read from the source with `ast` (nothing is imported). The checks:
- an edge never points up the layers (a lower layer imports nothing from a higher one);
- the graph has no cycle;
- the command modules of `sweep/cli/` do not import each other (only the CLI's shared module);
- no module outside `sweep/kernels/` (nor a test or script) uses a kernel compiled without a
  Python wrapper (`kernels/jit.py`: `inner`), which would crash the interpreter.
The checker itself is shown to catch a wrong-way import, a command importing another, a cycle
and a use of an inner kernel on small synthetic sources.

(No limit on the length of import chains: it made one kernel module hold four ideas.)
"""
from __future__ import annotations

import ast
from pathlib import Path

PACKAGE = Path(__file__).resolve().parent.parent / "sweep"

#: The layers, lowest first: (name, module prefixes). A module belongs to the layer of its
#: longest matching prefix; `sweep` itself is the package's `__init__` (its version). The config
#: (a scene: what a run is) needs the vocabulary alone, so it sits below the computation: sizing
#: a run in memory or checking a grid never reaches into kernels.
LAYERS = (
    ("vocabulary", ("sweep", "sweep.model", "sweep.schema", "sweep.grid", "sweep.files",
                    "sweep.interrupts")),
    ("config", ("sweep.config",)),
    ("kernels", ("sweep.kernels",)),
    ("one map / a batch of maps", ("sweep.compute",)),
    ("storage", ("sweep.storage",)),
    ("orchestration", ("sweep.runs", "sweep.report")),
    ("CLI", ("sweep.cli",)),
    ("program", ("sweep.program", "sweep.__main__", "sweep.cli.__main__")),
)
#: The CLI's shared module (options, parameter types, error handling), which every command
#: module may import; the package `sweep.cli` itself assembles the commands.
CLI_PACKAGE = "sweep.cli"
CLI_SHARED = ("sweep.cli.common",)


def module_names(root: Path = PACKAGE) -> dict[str, Path]:
    """Dotted module name -> source file, for every module of the package."""
    names = {}
    for path in sorted(root.rglob("*.py")):
        parts = list(path.relative_to(root.parent).with_suffix("").parts)
        if parts[-1] == "__init__":
            parts.pop()
        names[".".join(parts)] = path
    return names


def imports_of(name: str, source: str, is_package: bool, known) -> set[str]:
    """The package's modules that module `name` imports anywhere in `source`."""
    package = name if is_package else name.rpartition(".")[0]
    found = set()
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.Import):
            targets = [alias.name for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")[:len(package.split(".")) - node.level + 1]
                module = ".".join(base + ([node.module] if node.module else []))
            else:
                module = node.module or ""
            # `from package import submodule` imports the submodule
            targets = [f"{module}.{a.name}" if f"{module}.{a.name}" in known else module
                       for a in node.names]
        else:
            continue
        for target in targets:
            while target and target not in known:       # `import sweep.a.b` -> its module
                target = target.rpartition(".")[0]
            if target and target != name:
                found.add(target)
    return found


def import_graph(root: Path = PACKAGE) -> dict[str, set[str]]:
    names = module_names(root)
    return {name: imports_of(name, path.read_text(), path.name == "__init__.py", names)
            for name, path in names.items()}


def layer_of(module: str, layers=LAYERS) -> int:
    best, rank = -1, None
    for i, (_, prefixes) in enumerate(layers):
        for prefix in prefixes:
            if (module == prefix or module.startswith(prefix + ".")) and len(prefix) > best:
                best, rank = len(prefix), i
    if rank is None:
        raise AssertionError(f"{module} belongs to no layer: add it to LAYERS in {__file__}")
    return rank


def violations(graph: dict[str, set[str]], layers=LAYERS, cli_package=CLI_PACKAGE,
               cli_shared=CLI_SHARED) -> list[str]:
    """Every wrong-way import, command-to-command import and cycle of `graph`, one line each."""
    found = []
    for module, targets in sorted(graph.items()):
        for target in sorted(targets):
            lo, hi = layer_of(module, layers), layer_of(target, layers)
            if hi > lo:
                found.append(f"{module} ({layers[lo][0]}) imports {target} ({layers[hi][0]})")
            if (module.startswith(cli_package + ".") and target.startswith(cli_package + ".")
                    and module not in cli_shared and target not in cli_shared
                    and layer_of(module, layers) == layer_of(target, layers)):
                found.append(f"command module {module} imports command module {target}")
    state = {}

    def visit(module, path):
        state[module] = "open"
        for target in sorted(graph.get(module, ())):
            if state.get(target) == "open":
                found.append("cycle: " + " -> ".join(path[path.index(target):] + [target]))
            elif target not in state:
                visit(target, path + [target])
        state[module] = "done"

    for module in sorted(graph):
        if module not in state:
            visit(module, [module])
    return found


def test_the_package_obeys_its_layers():
    assert violations(import_graph()) == []


def test_a_wrong_way_import_in_the_package_fails():
    graph = import_graph()
    wrong = {**graph, "sweep.model": graph["sweep.model"] | {"sweep.cli.map"}}
    assert "sweep.model (vocabulary) imports sweep.cli.map (CLI)" in violations(wrong)


def test_every_module_is_in_a_layer():
    for module in import_graph():
        layer_of(module)


def test_the_checker_catches_a_wrong_way_import_a_command_import_and_a_cycle():
    clean = {"sweep.model": set(), "sweep.kernels.finger": {"sweep.model"},
             "sweep.compute.maps": {"sweep.kernels.finger", "sweep.model"},
             "sweep.config.scene": {"sweep.model"},
             "sweep.cli.common": set(), "sweep.cli.run": {"sweep.cli.common", "sweep.config.scene"},
             "sweep.cli.map": {"sweep.cli.common", "sweep.compute.maps"},
             "sweep.cli": {"sweep.cli.run", "sweep.cli.map"}}
    assert violations(clean) == []
    # the config layer reaching up into a map's computation (the scene -> maps)
    wrong = {**clean, "sweep.config.scene": {"sweep.model", "sweep.compute.maps"}}
    assert violations(wrong) == [
        "sweep.config.scene (config) imports sweep.compute.maps "
        "(one map / a batch of maps)"]
    # the vocabulary reaching into the kernels
    wrong = {**clean, "sweep.model": {"sweep.kernels.finger"}}
    found = violations(wrong)
    assert "sweep.model (vocabulary) imports sweep.kernels.finger (kernels)" in found
    assert any(line.startswith("cycle: ") for line in found)
    # one command importing another for a shared option
    wrong = {**clean, "sweep.cli.map": {"sweep.cli.common", "sweep.cli.run"}}
    assert violations(wrong) == ["command module sweep.cli.map imports command module "
                                 "sweep.cli.run"]
    # a cycle inside one layer
    wrong = {**clean, "sweep.compute.batch": {"sweep.compute.maps"},
             "sweep.compute.maps": {"sweep.compute.batch"}}
    assert violations(wrong) == ["cycle: sweep.compute.maps -> sweep.compute.batch -> "
                                 "sweep.compute.maps"]


def test_the_graph_reader_sees_every_form_of_import(tmp_path):
    pkg = tmp_path / "sweep"
    for name in ("model", "grid", "compute/maps", "compute/batch", "compute/__init__",
                 "__init__"):
        (pkg / name).parent.mkdir(parents=True, exist_ok=True)
        (pkg / f"{name}.py").write_text("")
    (pkg / "compute" / "batch.py").write_text(
        "from . import maps\nfrom ..grid import x\n"
        "def f():\n    import sweep.model\n    from .. import __version__\n")
    graph = import_graph(pkg)
    assert graph["sweep.compute.batch"] == {"sweep.compute.maps", "sweep.grid", "sweep.model",
                                           "sweep"}


def renames_outside(allowed: str = "sweep.files", root: Path = PACKAGE) -> list[str]:
    """Modules other than `allowed` that rename files into place (`os.replace`, `os.rename`,
    `shutil.move`): every file is written through the one atomic writer, `sweep/files.py`."""
    found = []
    for name, path in module_names(root).items():
        for node in ast.walk(ast.parse(path.read_text())):
            if (isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute)
                    and isinstance(node.func.value, ast.Name)
                    and (node.func.value.id, node.func.attr) in {("os", "replace"),
                                                                 ("os", "rename"),
                                                                 ("shutil", "move")}
                    and name != allowed):
                found.append(f"{name}:{node.lineno}")
    return found


def test_one_atomic_writer(tmp_path):
    assert renames_outside() == []
    pkg = tmp_path / "sweep"
    pkg.mkdir()
    (pkg / "__init__.py").write_text("")
    (pkg / "files.py").write_text("import os\ndef w(a, b):\n    os.replace(a, b)\n")
    (pkg / "mine.py").write_text("import os\ndef w(a, b):\n    os.replace(a, b)\n")
    assert renames_outside(root=pkg) == ["sweep.mine:3"]


# ---------------------------------------------------------------------------------------------
# Inner kernels (no Python wrapper) are called by kernels only
# ---------------------------------------------------------------------------------------------
ROOT = PACKAGE.parent


def inner_kernels(kernels: Path = PACKAGE / "kernels") -> set[tuple[str, str]]:
    """(module, function) of every kernel decorated `@inner` or `@inner(...)`."""
    def is_inner(d):
        d = d.func if isinstance(d, ast.Call) else d
        return isinstance(d, ast.Name) and d.id == "inner"
    found = set()
    for path in kernels.glob("*.py"):
        for node in ast.parse(path.read_text()).body:
            if isinstance(node, ast.FunctionDef) and any(map(is_inner, node.decorator_list)):
                found.add((path.stem, node.name))
    return found


def is_njit(node: ast.AST) -> bool:
    """A function compiled by Numba (`@numba.njit(...)`, `@njit`): it may call inner kernels."""
    def name(d):
        d = d.func if isinstance(d, ast.Call) else d
        return d.attr if isinstance(d, ast.Attribute) else getattr(d, "id", "")
    return isinstance(node, ast.FunctionDef) and any(name(d) == "njit"
                                                     for d in node.decorator_list)


def kernel_names_used(source: str) -> set[tuple[str, str]]:
    """(kernel module, name) of every name a source outside the kernels takes from them and
    uses from Python: `f` after `from ...kernels.field import f`, and `field.f` after
    `from ...kernels import field` or `import sweep.kernels.field as field`. Uses inside a
    Numba kernel of the source itself (`@numba.njit`: tests' own kernels) do not count."""
    tree = ast.parse(source)
    names, modules = {}, {}
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom) and node.module and "kernels" in node.module.split("."):
            rest = node.module.split(".")[node.module.split(".").index("kernels") + 1:]
            for alias in node.names:
                if rest:
                    names[alias.asname or alias.name] = (rest[0], alias.name)
                else:
                    modules[alias.asname or alias.name] = alias.name
        elif isinstance(node, ast.Import):
            for alias in node.names:
                parts = alias.name.split(".")
                if "kernels" in parts[:-1]:
                    modules[alias.asname or alias.name] = parts[-1]
    in_kernels = {id(n) for f in ast.walk(tree) if is_njit(f) for n in ast.walk(f)}
    used = set()
    for node in ast.walk(tree):
        if id(node) in in_kernels:
            continue
        if isinstance(node, ast.Name) and node.id in names:
            used.add(names[node.id])
        elif isinstance(node, ast.Attribute) and isinstance(node.value, ast.Name) \
                and node.value.id in modules:
            used.add((modules[node.value.id], node.attr))
    return used


def inner_kernels_used_outside(root: Path = ROOT) -> list[str]:
    inner = inner_kernels(root / "sweep" / "kernels")
    found = []
    paths = [path for folder in ("sweep", "tests", "scripts", "docs/notes")
             for path in root.joinpath(folder).rglob("*.py")]
    for path in sorted(paths):
        if path.parent == root / "sweep" / "kernels":
            continue
        for module, name in sorted(kernel_names_used(path.read_text()) & inner):
            found.append(f"{path.relative_to(root)} uses the inner kernel {module}.{name}")
    return found


def test_inner_kernels_are_called_by_kernels_only():
    assert inner_kernels_used_outside() == []


def test_the_checker_catches_an_inner_kernel_used_outside(tmp_path):
    kernels = tmp_path / "sweep" / "kernels"
    kernels.mkdir(parents=True)
    (kernels / "field.py").write_text("@inner\ndef f():\n    pass\n\n@entry\ndef g():\n"
                                      "    pass\n\n@inner(inline='always')\ndef h():\n"
                                      "    pass\n")
    (tmp_path / "sweep" / "maps.py").write_text("from .kernels.field import g\n")
    assert inner_kernels_used_outside(tmp_path) == []
    (tmp_path / "sweep" / "maps.py").write_text("from .kernels.field import h\nh()\n")
    assert inner_kernels_used_outside(tmp_path) == ["sweep/maps.py uses the inner kernel field.h"]
    (tmp_path / "sweep" / "maps.py").write_text("from .kernels.field import g\n")
    (tmp_path / "tests").mkdir()
    (tmp_path / "tests" / "t.py").write_text("from sweep.kernels import field as k\nk.f()\n")
    assert inner_kernels_used_outside(tmp_path) == ["tests/t.py uses the inner kernel field.f"]
    # a test's own Numba kernel may call it; the same name called from Python may not
    (tmp_path / "tests" / "t.py").write_text(
        "import numba\nfrom sweep.kernels.field import f\n\n@numba.njit(cache=True)\n"
        "def k():\n    return f()\n")
    assert inner_kernels_used_outside(tmp_path) == []
    (tmp_path / "tests" / "t.py").write_text(
        "import numba\nfrom sweep.kernels.field import f\n\n@numba.njit\ndef k():\n"
        "    return f()\n\nf()\n")
    assert inner_kernels_used_outside(tmp_path) == ["tests/t.py uses the inner kernel field.f"]


# ---------------------------------------------------------------------------------------------
# Every package the code imports is a run-time dependency (`pip install .` is enough)
# ---------------------------------------------------------------------------------------------
#: Import name -> distribution name, where they differ.
DISTRIBUTIONS = {"yaml": "pyyaml"}


def third_party_imports(root: Path = PACKAGE) -> set[str]:
    """Top-level names of the modules outside the standard library and the package that any
    module of `root` imports (at the top of a file or inside a function)."""
    import sys

    found = set()
    for path in root.rglob("*.py"):
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.Import):
                names = [alias.name for alias in node.names]
            elif isinstance(node, ast.ImportFrom) and not node.level and node.module:
                names = [node.module]
            else:
                continue
            for name in names:
                top = name.split(".")[0]
                if top != root.name and top not in sys.stdlib_module_names:
                    found.add(top)
    return found


def runtime_dependencies(pyproject: Path = PACKAGE.parent / "pyproject.toml") -> set[str]:
    import re
    import tomllib

    deps = tomllib.loads(pyproject.read_text())["project"]["dependencies"]
    return {re.split(r"[<>=!~ \[;]", d, maxsplit=1)[0].lower() for d in deps}


def test_every_imported_package_is_a_runtime_dependency():
    missing = {DISTRIBUTIONS.get(name, name) for name in third_party_imports()} \
        - runtime_dependencies()
    assert not missing, f"imported by sweep/ but not in [project] dependencies: {missing}"


def test_the_dependency_check_sees_an_import_inside_a_function(tmp_path):
    pkg = tmp_path / "sweep"
    pkg.mkdir()
    (pkg / "a.py").write_text("import os\nimport numpy as np\n"
                              "def f():\n    import xarray.core\n    from yaml import x\n")
    assert third_party_imports(pkg) == {"numpy", "xarray", "yaml"}


#: A module a reader can hold in mind: its own docstring says what it holds, and the kernels
#: are split by idea (docs/architecture.md, "Layers") rather than merged to meet this number.
MAX_MODULE_LINES = 700


def long_modules(package: Path, limit: int = MAX_MODULE_LINES) -> dict[str, int]:
    return {path.relative_to(package.parent).as_posix(): n for path in sorted(package.rglob("*.py"))
            if (n := len(path.read_text().splitlines())) > limit}


def test_no_module_is_longer_than_a_reader_holds():
    assert long_modules(PACKAGE) == {}


def test_every_kernel_module_says_what_it_holds():
    """Each module's docstring opens with what it holds (a reader checks it against the code)."""
    import ast

    for path in sorted((PACKAGE / "kernels").glob("*.py")):
        doc = ast.get_docstring(ast.parse(path.read_text()))
        assert doc and len(doc.split()) >= 8, f"{path.name}: no docstring saying what it holds"


def test_the_length_check_sees_a_long_module(tmp_path):
    pkg = tmp_path / "sweep"
    (pkg / "kernels").mkdir(parents=True)
    (pkg / "kernels" / "long.py").write_text("x = 1\n" * 11)
    (pkg / "short.py").write_text("x = 1\n" * 10)
    assert long_modules(pkg, limit=10) == {"sweep/kernels/long.py": 11}
