"""Every gallery example runs end to end in fast mode (SKLEARN_HYBRID_FAST=1)."""

import runpy
from pathlib import Path

import matplotlib
import pytest

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"
TASKS = ["pendulum", "duffing", "reaction_diffusion", "pendulum_images", "wind_tunnel",
         "light_tunnel", "varying_theta"]


def _run_example(path, monkeypatch, tmp_path):
    """Run one example in fast mode from ``tmp_path``; its namespace and the figures it made."""
    monkeypatch.setenv("SKLEARN_HYBRID_FAST", "1")
    monkeypatch.chdir(tmp_path)
    plt.close("all")  # figures other tests left open are not this example's
    try:
        namespace = runpy.run_path(str(EXAMPLES / path), run_name="__main__")
        return namespace, len(plt.get_fignums())
    finally:
        plt.close("all")


def test_gallery_has_one_example_per_task():
    found = sorted({p.parent.name for p in EXAMPLES.glob("*/plot_*.py")})
    assert found == sorted(TASKS + ["closed_loop", "getting_started"])
    assert (EXAMPLES / "README.txt").is_file()
    assert all((EXAMPLES / t / "README.txt").is_file() for t in found)


def test_quick_start_example_draws_the_fit_and_the_profile(monkeypatch, tmp_path, capsys):
    """The gallery's Quick start: plot_fit's figure, the report with a verdict, the profile's figure."""
    namespace, n_figures = _run_example("getting_started/plot_quick_start.py", monkeypatch, tmp_path)
    out = capsys.readouterr().out
    assert "FAST MODE" in out and "[[Parameters]]" in out and "(profiles:" in out
    assert namespace["est"].n_iter_ == 20 and set(namespace["profile"].verdicts) == {"omega"}
    assert n_figures == 2


def test_closed_loop_example_runs_in_fast_mode(monkeypatch, tmp_path, capsys, shared_data):
    """The Silverbox loop example on the measured data (found through the shared data home)."""
    _, n_figures = _run_example("closed_loop/plot_silverbox_loop.py", monkeypatch, tmp_path)
    out = capsys.readouterr().out
    # fast mode checks the pipeline (fit, diagnosis, table); finding the cubic needs a full run
    assert "| before |" in out and ("Added to g[y_dot]" in out or "Nothing added" in out)
    assert n_figures >= 1


def test_hare_lynx_example_runs_and_says_what_it_found(monkeypatch, tmp_path, capsys, shared_data):
    """The measured pelt counts through the recipe: the report, the free runs and the unexplained part."""
    namespace, n_figures = _run_example("closed_loop/plot_hare_lynx.py", monkeypatch, tmp_path)
    out = capsys.readouterr().out
    assert "| before |" in out and ("Nothing added" in out or "Added to" in out)
    assert {name: run.shape for name, run in namespace["runs"].items()} == {"hybrid": (7, 2), "science only": (7, 2)}
    assert n_figures == 2


def test_sensor_offset_example_finds_the_gauge_offset(monkeypatch, tmp_path, capsys):
    """Simulated readings of a gauge 0.3 m high: the declared offset is accepted and fitted."""
    namespace, n_figures = _run_example("closed_loop/plot_sensor_offset.py", monkeypatch, tmp_path)
    assert "Added a sensor offset: h is measured as h +" in capsys.readouterr().out
    assert namespace["out"].science_theta["offset_h"] == pytest.approx(0.3, abs=0.01)
    assert n_figures == 1


@pytest.mark.parametrize("task", TASKS)
def test_example_runs_in_fast_mode(task, monkeypatch, tmp_path, capsys):
    monkeypatch.setenv("SKLEARN_HYBRID_DATA", str(tmp_path))  # no measured data: stand-ins
    namespace, n_figures = _run_example(f"{task}/plot_{task}.py", monkeypatch, tmp_path)
    out = capsys.readouterr().out
    estimators = namespace["estimators"]
    assert set(estimators) == {"erm", "fsam"}
    for method, est in estimators.items():
        assert est.n_iter_ == est.max_iter and hasattr(est, "theta_")
        assert method in out
    assert "FAST MODE (SKLEARN_HYBRID_FAST=1)" in out  # the page says its numbers are not results
    assert "theta error" in out or "cosine similarity" in out
    assert "y error" in out
    assert n_figures >= 1
    if task in ("wind_tunnel", "light_tunnel"):
        assert "SIMULATED" in out  # the stand-in is announced as such


def test_closed_loop_example_skips_with_a_note_without_data(monkeypatch, tmp_path, capsys):
    """A documentation build without the measured data still builds the page, which says why it is empty."""
    import sklearn_hybrid.datasets as datasets

    def missing(*args, **kwargs):
        raise FileNotFoundError("silverbox/SNLS80mV.csv not found")

    monkeypatch.setattr(datasets, "fetch_silverbox", missing)
    monkeypatch.setenv("SKLEARN_HYBRID_DATA", str(tmp_path))
    _run_example("closed_loop/plot_silverbox_loop.py", monkeypatch, tmp_path)
    out = capsys.readouterr().out
    assert "SKIPPED: the measured Silverbox records are not in" in out and "| before |" not in out
    monkeypatch.setattr(datasets, "fetch_hare_lynx", missing)
    _run_example("closed_loop/plot_hare_lynx.py", monkeypatch, tmp_path)
    out = capsys.readouterr().out
    assert "SKIPPED: the pelt counts are not in" in out and "| before |" not in out
