"""The house rules that hold by themselves: no module reaches into another's private names, and no
import circle joins the package's modules."""

import ast
import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PACKAGE = ROOT / "sklearn_hybrid"
BENCHMARKS = ROOT / "benchmarks"


def _is_private(name: str) -> bool:
    return name.startswith("_") and not name.startswith("__")


def _package_modules() -> dict[str, Path]:
    """Dotted name -> file of every package module; a package is named by its ``__init__``."""
    modules = {}
    for path in PACKAGE.rglob("*.py"):
        parts = path.relative_to(ROOT).with_suffix("").parts
        modules[".".join(parts[:-1] if parts[-1] == "__init__" else parts)] = path
    return modules


def _benchmark_modules() -> dict[str, Path]:
    """The benchmarks' files by the names they import each other by: their path from ``benchmarks/`` (which
    every script puts on ``sys.path``), as ``helpers`` or ``identification.systems``."""
    modules = {}
    for path in BENCHMARKS.rglob("*.py"):
        parts = path.relative_to(BENCHMARKS).with_suffix("").parts
        if "results" not in parts:
            modules[".".join(parts[:-1] if parts[-1] == "__init__" else parts)] = path
    return modules


def _imports(path: Path, here: str, is_package: bool):
    """``(source module, imported name or None, line)`` for every import of a file, wherever it is made
    (inside functions too); relative imports resolved to dotted names."""
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            for alias in node.names:
                yield alias.name, None, node.lineno
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = here.split(".") if is_package else here.split(".")[:-1]
                base = base[:len(base) - (node.level - 1)]
                source = ".".join(base + ([node.module] if node.module else []))
            else:
                source = node.module
            for alias in node.names:
                yield source, alias.name, node.lineno


def _private_imports(files: dict[str, Path], modules: set[str]):
    """``(module, imported name)`` for every private name (not a private module) a file imports from a
    module in ``modules``: what one module needs of another gets a public name."""
    found = []
    for here, path in sorted(files.items()):
        for source, name, _ in _imports(path, here, path.name == "__init__.py"):
            if (name is not None and _is_private(name) and source in modules
                    and f"{source}.{name}" not in modules):
                found.append((here, f"{source}:{name}"))
    return found


def test_no_module_imports_another_modules_private_names():
    modules = _package_modules()
    assert _private_imports(modules, set(modules)) == []


def test_no_benchmark_imports_a_private_name():
    """The benchmarks use the package, and each other, through public names only."""
    files = _benchmark_modules()
    assert _private_imports(files, set(_package_modules()) | set(files)) == []


def _estimator_private_uses():
    """``(module, line, name)`` wherever a module other than the estimator's own two touches a private member of
    HybridRegressor on another object than ``self``: what the package's modules need of a fit goes through
    the estimator's module functions (``prepare_fit``, ``store_fit``, ``fitted_data``, ``fitted_settings``,
    ``structure_X``, ``ode_structure``)."""
    from sklearn_hybrid import HybridRegressor

    private = {n for cls in HybridRegressor.__mro__ if cls.__module__.startswith("sklearn_hybrid")
               for n in vars(cls) if n.startswith("_") and not n.startswith("__")}
    private |= {"_fitted_params", "_not_usable", "_samples_per_pass", "_standard_error_samples"}
    found = []
    for path in sorted(PACKAGE.rglob("*.py")):
        here = path.relative_to(PACKAGE).as_posix()
        if here in ("_estimator.py", "_fitting.py"):  # the estimator and what builds and stores its fit
            continue
        for node in ast.walk(ast.parse(path.read_text())):
            if (isinstance(node, ast.Attribute) and node.attr in private
                    and not (isinstance(node.value, ast.Name) and node.value.id == "self")):
                found.append((here, node.lineno, node.attr))
    return found


def _module_names(tree: ast.AST, modules: set[str]) -> set[str]:
    """The names a file binds to a module of ``modules`` (``import a.b as c``, ``from a import b``,
    ``c = importlib.import_module("a.b")``)."""
    names = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            names |= {alias.asname for alias in node.names if alias.asname and alias.name in modules}
        elif isinstance(node, ast.ImportFrom) and node.module:
            names |= {alias.asname or alias.name for alias in node.names if f"{node.module}.{alias.name}" in modules}
        elif (isinstance(node, ast.Assign) and isinstance(node.value, ast.Call)
              and ast.unparse(node.value.func) == "importlib.import_module" and node.value.args
              and isinstance(node.value.args[0], ast.Constant) and node.value.args[0].value in modules):
            names |= {target.id for target in node.targets if isinstance(target, ast.Name)}
    return names


def _private_module_attributes(files: dict[str, Path], modules: set[str]):
    """``(file, line, name)`` for every ``other_module._private_name`` a file reads (a module named by its
    own name, as ``stepwise._screen``, or by the name it was imported as)."""
    stems = {name.rsplit(".", 1)[-1] for name in modules}
    found = []
    for here, path in sorted(files.items()):
        tree = ast.parse(path.read_text())
        names = stems | _module_names(tree, modules)
        for node in ast.walk(tree):
            if (isinstance(node, ast.Attribute) and isinstance(node.value, ast.Name) and node.value.id in names
                    and _is_private(node.attr)):
                found.append((here, node.lineno, f"{node.value.id}.{node.attr}"))
    return found


def test_no_module_reads_another_modules_private_names():
    modules = _package_modules()
    assert _private_module_attributes(modules, set(modules)) == []


def test_no_benchmark_reads_a_private_name():
    files = _benchmark_modules()
    assert _private_module_attributes(files, set(_package_modules()) | set(files)) == []


def import_graph() -> dict[str, set[str]]:
    """Module -> the package modules it imports, counting imports made inside functions.

    An import of ``a.b.c`` is an edge to ``a.b.c`` (a package means its ``__init__``) and to each package
    above it that does not hold the importer, since Python runs those ``__init__`` first; ``from a.b import
    c`` is an edge to ``a.b.c`` where that is a module, to ``a.b`` otherwise.
    """
    modules = _package_modules()
    graph = {}
    for here, path in modules.items():
        edges = set()
        for source, name, _ in _imports(path, here, path.name == "__init__.py"):
            target = f"{source}.{name}" if f"{source}.{name}" in modules else source
            while target and target not in modules:  # ``import a.b.c`` of a name that is no module
                target = target.rpartition(".")[0]
            if not target:
                continue  # outside the package
            parts = target.split(".")
            edges |= {".".join(parts[:k]) for k in range(2, len(parts) + 1)
                      if not (here + ".").startswith(".".join(parts[:k]) + ".")}
        graph[here] = edges - {here}
    return graph


def find_cycle(graph: dict[str, set[str]]) -> list[str]:
    """One import circle of ``graph`` as ``[a, b, ..., a]``, or ``[]`` where there is none (a depth-first
    search: an edge back to a module still on the path closes a circle)."""
    state: dict[str, str] = {}  # "open" while on the path, "done" once every module below it is searched
    path: list[str] = []

    def visit(module: str) -> list[str]:
        state[module] = "open"
        path.append(module)
        for target in sorted(graph.get(module, ())):
            if state.get(target) == "open":
                return path[path.index(target):] + [target]
            if target not in state and (cycle := visit(target)):
                return cycle
        state[module] = "done"
        path.pop()
        return []

    for module in sorted(graph):
        if module not in state and (cycle := visit(module)):
            return cycle
    return []


@pytest.mark.parametrize("graph, cycle", [
    ({"a": {"b"}, "b": {"c"}, "c": set()}, []),
    ({"a": {"b"}, "b": {"c"}, "c": {"a"}}, ["a", "b", "c", "a"]),
    ({"a": {"b"}, "b": {"b2", "c"}, "b2": set(), "c": {"b"}}, ["b", "c", "b"]),
])
def test_find_cycle_finds_a_circle(graph, cycle):
    assert find_cycle(graph) == cycle


def test_the_import_graph_sees_imports_inside_functions():
    graph = import_graph()
    assert "sklearn_hybrid._fitting" in graph["sklearn_hybrid.diagnosis.science_fit"]
    # the package's lazy names aside, its __init__ imports nothing; a subpackage's __init__ is an edge
    assert "sklearn_hybrid.diagnosis" in graph["sklearn_hybrid.recipes"]
    assert "sklearn_hybrid.training" in graph["sklearn_hybrid.identifiability.profile"]


def test_no_import_circle_in_the_package():
    """No module imports, even inside a function, one that imports it back, directly or around a circle:
    an import made inside a function hides a circle from Python, not from the design."""
    cycle = find_cycle(import_graph())
    assert not cycle, "import circle: " + " -> ".join(cycle)


def test_no_module_reaches_into_a_fitted_estimator():
    assert _estimator_private_uses() == []


def test_every_module_and_benchmark_file_is_on_the_architecture_map():
    """doc/architecture.rst draws the package and the benchmarks as they are: every module of the package
    (a package by its folder's name) and every Python file of benchmarks/ is named on it."""
    text = (ROOT / "doc" / "architecture.rst").read_text()
    words = set(re.findall(r"[A-Za-z_][A-Za-z0-9_]*", text))
    missing = []
    for folder in ("sklearn_hybrid", "benchmarks"):
        for path in sorted((ROOT / folder).rglob("*.py")):
            if "results" in path.parts:
                continue
            name = path.parent.name if path.name == "__init__.py" else path.stem
            if name not in words:
                missing.append(str(path.relative_to(ROOT)))
    assert not missing, f"not on doc/architecture.rst's map: {missing}"
