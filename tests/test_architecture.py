"""The house rules that hold by themselves: no module reaches into another's private names."""

import ast
from pathlib import Path

PACKAGE = Path(__file__).resolve().parents[1] / "sklearn_hybrid"


def _private_imports():
    """``(module, imported name)`` for every private name (not a private module) one package module
    imports from another: what one module needs of another gets a public name."""
    modules = {p.relative_to(PACKAGE).with_suffix("").as_posix() for p in PACKAGE.rglob("*.py")}
    found = []
    for path in sorted(PACKAGE.rglob("*.py")):
        here = path.relative_to(PACKAGE).with_suffix("").as_posix()
        package = here.rsplit("/", 1)[0] if "/" in here else ""
        for node in ast.walk(ast.parse(path.read_text())):
            if not isinstance(node, ast.ImportFrom) or node.level == 0:
                continue
            base = package.split("/") if package else []
            base = base[:len(base) - (node.level - 1)] if node.level > 1 else base
            source = "/".join(base + (node.module.split(".") if node.module else []))
            for alias in node.names:
                name = alias.name
                is_module = f"{source}/{name}".lstrip("/") in modules or f"{source}/{name}/__init__".lstrip("/") in modules
                if name.startswith("_") and not name.startswith("__") and not is_module:
                    found.append((here, f"{source or '.'}:{name}"))
    return found


def test_no_module_imports_another_modules_private_names():
    assert _private_imports() == []


def _estimator_private_uses():
    """``(module, line, name)`` wherever a module other than the estimator's own touches a private member of
    HybridRegressor on another object than ``self``: what the package's modules need of a fit goes through
    the estimator's module functions (``prepare_fit``, ``store_fit``, ``fitted_data``, ``fitted_settings``,
    ``structure_X``)."""
    from sklearn_hybrid import HybridRegressor

    private = {n for cls in HybridRegressor.__mro__ if cls.__module__.startswith("sklearn_hybrid")
               for n in vars(cls) if n.startswith("_") and not n.startswith("__")}
    private |= {"_fitted_params", "_not_usable", "_samples_per_pass", "_standard_error_samples"}
    found = []
    for path in sorted(PACKAGE.rglob("*.py")):
        here = path.relative_to(PACKAGE).as_posix()
        if here == "_estimator.py":
            continue
        for node in ast.walk(ast.parse(path.read_text())):
            if (isinstance(node, ast.Attribute) and node.attr in private
                    and not (isinstance(node.value, ast.Name) and node.value.id == "self")):
                found.append((here, node.lineno, node.attr))
    return found


def _private_module_attributes():
    """``(module, line, name)`` for every ``other_module._private_name`` a package module reads."""
    modules = {p.stem for p in PACKAGE.rglob("*.py")}
    found = []
    for path in sorted(PACKAGE.rglob("*.py")):
        for node in ast.walk(ast.parse(path.read_text())):
            if (isinstance(node, ast.Attribute) and isinstance(node.value, ast.Name) and node.value.id in modules
                    and node.attr.startswith("_") and not node.attr.startswith("__")):
                found.append((path.relative_to(PACKAGE).as_posix(), node.lineno, f"{node.value.id}.{node.attr}"))
    return found


def test_no_module_reads_another_modules_private_names():
    assert _private_module_attributes() == []


def test_no_module_reaches_into_a_fitted_estimator():
    assert _estimator_private_uses() == []
