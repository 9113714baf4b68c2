"""The command line: --version, --help without importing torch, one-line errors, --data-home."""

import subprocess
import sys

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


def test_missing_data_is_one_line_on_stderr(tmp_path, capsys, monkeypatch):
    import sklearn_hybrid.diagnosis.cases as cases

    def missing(*args, **kwargs):  # as fetch_silverbox reports an absent file offline
        raise FileNotFoundError("Could not download silverbox/SNLS80mV.csv:\n  details ...")

    monkeypatch.setattr(cases, "fetch_silverbox", missing)
    assert cli.main(["loop", "silverbox", "--fast", "--data-home", str(tmp_path)]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1
    assert err.startswith("sklearn-hybrid: error: Could not download silverbox/SNLS80mV.csv")
    assert str(tmp_path) in err and "--data-home" in err
    with pytest.raises(FileNotFoundError):
        cli.main(["--traceback", "loop", "silverbox", "--fast", "--data-home", str(tmp_path)])


def test_data_home_reaches_the_loader(tmp_path, monkeypatch):
    import sklearn_hybrid.diagnosis.cases as cases

    seen = {}

    def record(data_home=None):
        seen["data_home"] = data_home
        raise FileNotFoundError("stop here")

    monkeypatch.setattr(cases, "fetch_silverbox", record)
    cli.main(["loop", "silverbox", "--fast", "--data-home", str(tmp_path)])
    assert seen["data_home"] == str(tmp_path)
