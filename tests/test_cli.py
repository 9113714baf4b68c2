"""The command line: --version, --help without importing torch, one-line errors, --data-home."""

import subprocess
import sys

import numpy as np
import pytest

from sklearn_hybrid import __version__, cli


def test_version_and_help_do_not_import_torch():
    code = ("import sys\nfrom sklearn_hybrid import cli\n"
            "for argv in (['--version'], ['--help'], ['loop', '--help']):\n"
            "    try:\n        cli.main(argv)\n    except SystemExit:\n        pass\n"
            "print('torch' in sys.modules)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert f"sklearn-hybrid {__version__}" in out
    assert "--data-home" in out
    assert out.strip().splitlines()[-1] == "False"



def test_python_m_sklearn_hybrid_runs_the_command_line():
    # ``python -m sklearn_hybrid`` once said the package had no __main__
    done = subprocess.run([sys.executable, "-m", "sklearn_hybrid", "--help"], capture_output=True, text=True,
                          timeout=60)
    assert done.returncode == 0, done.stderr
    assert done.stdout.startswith("usage: ") and "{loop,demo}" in done.stdout
    bad = subprocess.run([sys.executable, "-m", "sklearn_hybrid", "loop", "nowhere"], capture_output=True,
                         text=True, timeout=60)
    assert bad.returncode == 2 and "invalid choice: 'nowhere'" in bad.stderr

def test_missing_data_says_where_to_put_it_and_get_it(tmp_path, capsys, monkeypatch):
    """No traceback, but the answer kept: the reason, then where the file goes and where it comes from."""
    import sklearn_hybrid.recipes as recipes
    from sklearn_hybrid.datasets._base import RemoteFile, _missing_message

    remote = RemoteFile("silverbox/SNLS80mV.csv", "https://example.invalid/SNLS80mV.csv", "0" * 64)

    def missing(*args, **kwargs):  # as fetch_silverbox reports an absent file offline
        raise FileNotFoundError(_missing_message(tmp_path / remote.filename, remote,
                                                 "Could not download silverbox/SNLS80mV.csv: no answer."))

    monkeypatch.setattr(recipes, "fetch_silverbox", missing)
    assert cli.main(["loop", "silverbox", "--fast", "--data-home", str(tmp_path)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err[0].startswith("sklearn-hybrid: error: Could not download silverbox/SNLS80mV.csv")
    assert str(tmp_path) in err[0] and "--data-home" in err[0]
    assert "Put the file at" in err and f"  {tmp_path / remote.filename}" in err
    assert "  https://example.invalid/SNLS80mV.csv" in err and not any("Traceback" in line for line in err)
    with pytest.raises(FileNotFoundError):
        cli.main(["--traceback", "loop", "silverbox", "--fast", "--data-home", str(tmp_path)])


def test_default_data_home_is_the_checkout_s_shared_data(tmp_path, capsys, monkeypatch):
    """Run from a source checkout without --data-home or SKLEARN_HYBRID_DATA, the CLI looks where the tests
    and the docs build find the measured files, ../shared/data beside the repository (it looked in
    ~/sklearn_hybrid_data), and its missing-file error names that folder."""
    import sklearn_hybrid.datasets._base as base

    monkeypatch.delenv("SKLEARN_HYBRID_DATA", raising=False)
    monkeypatch.setenv("HOME", str(tmp_path / "home"))
    (tmp_path / "repo").mkdir()
    (tmp_path / "repo" / "pyproject.toml").write_text("")
    shared = tmp_path / "shared" / "data"
    shared.mkdir(parents=True)
    monkeypatch.setattr(base, "__file__", str(tmp_path / "repo" / "sklearn_hybrid" / "datasets" / "_base.py"))
    monkeypatch.setattr(base, "_answering", lambda urls: set())  # offline, at once
    assert cli.main(["loop", "silverbox", "--fast"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert f"(data home: {shared.resolve()};" in err[0]
    assert f"  {shared / 'silverbox' / 'SNLS80mV.csv'}" in err and "Put the file at" in err
    assert any(line.startswith("  https://") for line in err) and not (tmp_path / "home").exists()


def test_a_bad_argument_is_one_line_on_stderr(capsys, monkeypatch):
    import sklearn_hybrid.recipes as recipes

    def bad(*args, **kwargs):
        raise ValueError("max_iter must be a positive integer, got -1.\n  details ...")

    monkeypatch.setattr(recipes, "run_case", bad)
    assert cli.main(["loop", "pendulum", "--fast"]) == 2
    err = capsys.readouterr().err.strip()
    assert err == "sklearn-hybrid: error: max_iter must be a positive integer, got -1."


def test_data_home_reaches_the_loader(tmp_path, monkeypatch):
    import sklearn_hybrid.recipes as recipes

    seen = {}

    def record(data_home=None):
        seen["data_home"] = data_home
        raise FileNotFoundError("stop here")

    monkeypatch.setattr(recipes, "fetch_silverbox", record)
    cli.main(["loop", "silverbox", "--fast", "--data-home", str(tmp_path)])
    assert seen["data_home"] == str(tmp_path)


def test_loop_shows_progress_by_default_and_quiet_hides_it(capsys):
    """The long fits of ``loop`` report as they go (stage lines, progress bars); --quiet prints the table only."""
    assert cli.main(["loop", "pendulum", "--fast", "--max-iter", "3"]) == 0
    out, err = capsys.readouterr()
    assert "fitting the hybrid model ..." in out
    assert "erm: 100%" in err  # the fit's progress bar (tqdm, on stderr)
    assert cli.main(["loop", "pendulum", "--fast", "--max-iter", "3", "--quiet"]) == 0
    out, err = capsys.readouterr()
    assert "fitting the hybrid model" not in out and "| before |" in out
    assert err == ""


def test_run_case_progress_times_the_free_run_scoring(monkeypatch, capsys):
    import sklearn_hybrid.recipes as recipes

    def toy_case(**kwargs):  # a synthetic case scored like the measured ones
        case = recipes.synthetic_case("pendulum", **kwargs)
        case.test_scorer = lambda fitted: {"test_rmse": 0.0}
        return case

    monkeypatch.setitem(recipes.CASES, "toy", toy_case)
    out = recipes.run_case("toy", fast=True, max_iter=2, progress=True)
    printed = capsys.readouterr().out
    assert "scoring: free-run simulations of the test records ..." in printed and "scoring done" in printed
    assert out.table[0]["test_rmse"] == 0.0
    recipes.run_case("toy", fast=True, max_iter=2)
    assert "scoring" not in capsys.readouterr().out


def test_run_case_takes_the_case_s_evidence_settings(monkeypatch):
    """cv="auto" and grouped=None are the case's choice; an explicit value wins; a case of independent
    trajectories has no groups to judge by."""
    import sklearn_hybrid.recipes as recipes

    seen = []
    monkeypatch.setattr(recipes, "close_the_loop", lambda *a, **kw: seen.append(kw) or {})

    def windowed(**kwargs):
        case = recipes.synthetic_case("pendulum", **kwargs)
        case.update(groups=np.arange(len(case.y)) // 2, grouped=True, cv=3)
        return case

    monkeypatch.setitem(recipes.CASES, "windowed", windowed)
    recipes.run_case("windowed", fast=True, max_iter=1)
    assert seen[-1]["evidence"].cv == 3 and seen[-1]["evidence"].groups is not None
    recipes.run_case("windowed", fast=True, max_iter=1, cv=None, grouped=False)
    assert seen[-1]["evidence"].cv is None and seen[-1]["evidence"].groups is None
    recipes.run_case("pendulum", fast=True, max_iter=1)
    assert seen[-1]["evidence"].cv is None and seen[-1]["evidence"].groups is None
    with pytest.raises(ValueError, match="has no groups"):
        recipes.run_case("pendulum", fast=True, max_iter=1, grouped=True)
    with pytest.raises(ValueError, match="max_iter must be a positive integer, got 0"):  # not "the default"
        recipes.run_case("pendulum", fast=True, max_iter=0)


def test_loop_json_lists_the_added_terms(tmp_path, capsys):
    import json

    path = tmp_path / "loop.json"
    assert cli.main(["loop", "pendulum", "--fast", "--quiet", "--json", str(path)]) == 0
    saved = json.loads(path.read_text())
    assert saved["dataset"] == "pendulum" and saved["table"][0]["stage"] == "before"
    assert all(set(t) == {"output", "term", "kind", "coef", "param"} for t in saved["added"])


def test_method_names_come_from_the_registry(monkeypatch, capsys):
    """--method takes any registered method (the CLI keeps no copy of the names) and refuses others."""
    from sklearn_hybrid.methods import METHODS, SAM

    monkeypatch.setitem(METHODS, "another-sam", SAM)
    assert cli._parser().parse_args(["loop", "pendulum", "--method", "another-sam"]).method == "another-sam"
    with pytest.raises(SystemExit) as exit_:
        cli._parser().parse_args(["loop", "pendulum", "--method", "adam"])
    assert exit_.value.code == 2
    err = capsys.readouterr().err
    assert "invalid choice: 'adam'" in err and "another-sam" in err and "fsam" in err
