"""Every file of ``benchmarks/`` imports, as a script run by its path would import it, without running anything.

The benchmarks take minutes to hours and stay outside the test suite; this catches what the moves of a refactor
break in them (a gone module, a renamed helper, a path): each file is imported under its own name with
``benchmarks/`` on ``sys.path``, as its scripts put it there, and must not start work at import (a script's work
waits behind ``if __name__ == "__main__"``).
"""

import ast
import importlib.util
import subprocess
import sys
from pathlib import Path

import pytest

BENCHMARKS = Path(__file__).resolve().parents[1] / "benchmarks"
FILES = sorted(p for p in BENCHMARKS.rglob("*.py") if "results" not in p.relative_to(BENCHMARKS).parts)
GUARD = 'if __name__ == "__main__":'
# the scripts: what runs by its path; every other file is a module the scripts import
SCRIPTS = {p for p in FILES
           if p.name.startswith(("bench_", "check_", "why_"))
           or p.stem in {"table1", "gallery_figures", "choice_figure", "guide_figures", "results_figure",
                          "discovery_figure", "screenshot_pages"}}
# the top-level names the benchmarks import each other by, once benchmarks/ is on sys.path
OWN = {"helpers"} | {p.name for p in BENCHMARKS.iterdir() if (p / "__init__.py").exists()}
# optional dependencies of single benchmarks (the [bench] and [sindy] extras), not of the test environment
OPTIONAL = {"numba", "pysindy"}


def _name(path: Path) -> str:
    """The module name the benchmarks import a file by (``identification.systems``; a script's own name)."""
    parts = path.relative_to(BENCHMARKS).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


@pytest.fixture
def benchmarks_path(monkeypatch):
    """``benchmarks/`` first on ``sys.path`` and the benchmarks' modules imported afresh, both undone after."""
    def ours(name):
        return name.split(".")[0] in OWN or name.startswith("benchmark_")

    # a module elsewhere that bears one of these names is set aside meanwhile
    others = {name: sys.modules.pop(name) for name in list(sys.modules) if ours(name)}
    path = list(sys.path)
    monkeypatch.syspath_prepend(str(BENCHMARKS))
    yield
    sys.path[:] = path  # the scripts put benchmarks/ there too
    for name in [name for name in sys.modules if ours(name)]:  # not left for other tests
        del sys.modules[name]
    sys.modules.update(others)


def test_every_benchmark_file_is_found():
    names = {_name(p) for p in FILES}
    assert {"helpers", "identification.bench_identification", "identification.checks", "paper.table1",
            "uncertainty.bench_uncertainty", "speed.bench_speed", "measured.bench_closed_loop"} <= names
    assert len(FILES) > 40 and {"speed", "paper", "identification", "uncertainty", "measured"} <= OWN
    assert {p for p in FILES if GUARD in p.read_text()} == SCRIPTS  # the scripts, and only they, run as scripts


@pytest.mark.parametrize("path", FILES, ids=lambda p: p.relative_to(BENCHMARKS).as_posix())
def test_a_benchmark_file_imports_without_running(path, benchmarks_path):
    # a script runs as __main__, never imported by another file: a name of its own
    name = "benchmark_" + path.stem if path in SCRIPTS else _name(path)
    spec = importlib.util.spec_from_file_location(name, path)
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module
    try:
        spec.loader.exec_module(module)
    except ModuleNotFoundError as error:
        if error.name not in OPTIONAL:
            raise
        _check_own_imports(path)  # what it takes from the other benchmark files is there, at least
        pytest.skip(f"{path.name} needs {error.name} (an optional extra)")


def _check_own_imports(path: Path) -> None:
    """Every name a file imports from ``helpers`` or a study's module exists there."""
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.ImportFrom) and node.module and node.module.split(".")[0] in OWN:
            module = importlib.import_module(node.module)
            assert all(hasattr(module, alias.name) for alias in node.names), ast.unparse(node)


def _imports(path: Path) -> set[str]:
    """The modules a file imports at any depth (function bodies included)."""
    found = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            found |= {alias.name for alias in node.names}
        elif isinstance(node, ast.ImportFrom) and node.module and not node.level:
            found.add(node.module)
            found |= {f"{node.module}.{alias.name}" for alias in node.names}
    return found


def test_no_benchmark_script_imports_another_script():
    """What two scripts share lives in ``helpers.py`` or in their study's modules, never in one of them."""
    scripts = {_name(p) for p in SCRIPTS}
    stems = {name.rsplit(".", 1)[-1] for name in scripts}
    found = [(p.relative_to(BENCHMARKS).as_posix(), module) for p in FILES for module in _imports(p)
             if module in scripts or module in stems]
    assert found == []


def test_the_identification_benchmark_refuses_list_alone(benchmarks_path):
    """``--list`` belongs to ``--more-validation``: alone it once fell through to running every case."""
    bench = importlib.import_module("identification.bench_identification")
    with pytest.raises(SystemExit) as exit_:
        bench.main(["--list"])
    assert exit_.value.code == 2


def test_a_history_section_whose_records_were_made_again_has_no_empty_table(benchmarks_path):
    """Once a whole rerun has made every record of a past rerun again, its before/after table has no rows: a
    table head alone failed the docs build (docutils' list-table needs a body)."""
    bench = importlib.import_module("identification.bench_identification")
    assert bench._before_after([]) == []
    record = {"system": "s", "noise": 0.01, "rel_err": 0.02, "added": []}
    assert len(bench._before_after([(record, record)])) == 3


def test_first_fits_pickled_before_the_grouping_load(benchmarks_path, tmp_path):
    """A first fit stored while the systems lived in ``_identification_systems`` loads from ``identification.systems``."""
    import pickle

    systems = importlib.import_module("identification.systems")
    protocol = importlib.import_module("identification.protocol")
    old = pickle.dumps(systems.gyrating_f, protocol=0).replace(b"identification.systems", b"_identification_systems")
    path = tmp_path / "fit.pkl"
    path.write_bytes(old)
    with pytest.raises(ModuleNotFoundError):
        pickle.loads(old)
    assert protocol.load_fit(path) is systems.gyrating_f


# the scripts whose --help once ran the benchmark (no parser) or needed an optional extra (issue 63)
HELP_ANSWERED = ["measured/bench_greybox.py", "identification/bench_anchors_loop.py"]


@pytest.mark.parametrize("script", HELP_ANSWERED)
def test_help_answers_without_running_and_without_the_optional_extras(script):
    path = BENCHMARKS / script
    # numba and pysindy made unimportable, installed here or not: --help must need neither
    code = ("import runpy, sys\nsys.modules['numba'] = sys.modules['pysindy'] = None\n"
            f"sys.argv = [{str(path)!r}, '--help']\nrunpy.run_path(sys.argv[0], run_name='__main__')")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    first_line = ast.get_docstring(ast.parse(path.read_text())).splitlines()[0]
    assert done.stdout.startswith(f"usage: {path.name}") and first_line in " ".join(done.stdout.split())
