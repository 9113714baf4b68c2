"""Every Python snippet of the README runs, in order, and prints what its output block shows."""

import re
from pathlib import Path

import matplotlib
import pytest

matplotlib.use("Agg")

README = Path(__file__).resolve().parents[1] / "README.md"
# a python block, optionally followed (after prose) by the text block that shows its output
BLOCK = re.compile(r"```python\n(.*?)```(?:(?:(?!```).)*?```text\n(.*?)```)?", re.S)
NUMBER = re.compile(r"-?\d+(?:\.\d+)?(?:e-?\d+)?")


def snippets():
    return [(code, output) for code, output in BLOCK.findall(README.read_text())]


def numbers(text):
    return [float(x) for x in NUMBER.findall(text)]


def test_readme_has_the_snippets_it_promises():
    found = snippets()
    assert len(found) >= 3  # quick start, sensitivity sweep, close the loop
    assert "est.fit_report()" in found[0][0] and "simulate(" in found[0][0]
    assert all(output for _, output in found)  # every snippet shows what it prints


def test_readme_snippets_run_and_print_their_documented_output(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    namespace = {"__name__": "__readme__"}
    for k, (code, documented) in enumerate(snippets()):
        exec(compile(code, f"README.md python block {k + 1}", "exec"), namespace)
        printed = capsys.readouterr().out
        got, want = numbers(printed), numbers(documented)
        assert len(got) == len(want), f"block {k + 1} printed\n{printed}\nthe README shows\n{documented}"
        for g, w in zip(got, want):
            # the same machine gives the same numbers; the tolerance absorbs rounding elsewhere
            assert g == pytest.approx(w, rel=0.02, abs=2e-3), \
                f"block {k + 1}: printed {g}, the README shows {w}\n{printed}"
