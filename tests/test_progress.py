"""Signs of life: by default a fit that runs past a few seconds shows its progress; a short one prints nothing."""

import numpy as np

import sklearn_hybrid.training.progress as progress
from sklearn_hybrid import HybridRegressor, OdeStructure

FAST = dict(max_iter=15, residual={"hidden": (8, 8)}, random_state=0)


def cooling_f(v, k=0.5):  # Newton's cooling of two bodies, each on its own
    return -k * v


def data():
    rng = np.random.default_rng(3)
    X = rng.uniform(1, 2, size=(5, 2))
    return X, X[:, None, :] * np.exp(-0.7 * 0.3 * np.arange(1, 5))[None, :, None]


def test_the_default_is_auto_and_a_short_fit_prints_nothing(capsys):
    assert HybridRegressor().verbose == "auto"
    HybridRegressor(science=cooling_f, structure=OdeStructure(dt=0.3), **FAST).fit(*data())
    assert capsys.readouterr().err == ""


def test_auto_shows_the_bar_once_the_fit_has_run_its_delay(capsys, monkeypatch):
    monkeypatch.setattr(progress, "AUTO_DELAY", 0.0)  # every fit is "long" now
    monkeypatch.setattr(progress, "is_interactive", lambda stream: True)  # as in a terminal
    HybridRegressor(science=cooling_f, structure=OdeStructure(dt=0.3), **FAST).fit(*data())
    err = capsys.readouterr().err
    assert "15/15" in err and "k=" in err and "it/s" in err


def test_auto_stays_out_of_logs_and_captured_output(capsys, monkeypatch):
    """A bar redrawn with carriage returns is noise in a log file or a documentation page."""
    monkeypatch.setattr(progress, "AUTO_DELAY", 0.0)
    HybridRegressor(science=cooling_f, structure=OdeStructure(dt=0.3), **FAST).fit(*data())  # pytest's capture is no terminal
    assert capsys.readouterr().err == ""
    assert not progress.is_interactive(None)

    class Closed:
        def isatty(self):
            raise ValueError("I/O operation on closed file")

    assert not progress.is_interactive(Closed())


def test_verbose_false_silences_it(capsys, monkeypatch):
    monkeypatch.setattr(progress, "AUTO_DELAY", 0.0)
    monkeypatch.setattr(progress, "is_interactive", lambda stream: True)
    HybridRegressor(science=cooling_f, structure=OdeStructure(dt=0.3), verbose=False, **FAST).fit(*data())
    assert capsys.readouterr().err == ""


def test_the_profile_and_the_loop_show_their_progress_in_a_terminal(capsys, monkeypatch):
    """The steps after a fit show signs of life by default too: the profile's members a bar, the loop its stages."""
    import sklearn_hybrid.diagnosis.loop.close as close
    import sklearn_hybrid.diagnosis.loop.stages as stages
    from sklearn_hybrid.diagnosis import Candidates
    from sklearn_hybrid.identifiability import profile_theta

    X, y = data()
    est = HybridRegressor(science=cooling_f, structure=OdeStructure(dt=0.3), verbose=False, **FAST).fit(X, y)
    profile_theta(est, X, y, n_points=3, refine=False, max_iter=5)  # captured output is no terminal: silent
    close.close_the_loop(est, X, y, candidates=Candidates(kinds=["polynomial"], max_terms=1))
    assert capsys.readouterr() == ("", "")
    monkeypatch.setattr(progress, "AUTO_DELAY", 0.0)
    monkeypatch.setattr(progress, "is_interactive", lambda stream: True)  # as in a terminal
    monkeypatch.setattr(stages, "is_interactive", lambda stream: True)
    profile_theta(est, X, y, n_points=3, refine=False, max_iter=5)
    assert "3 members" in capsys.readouterr().err  # two values of k and the free member
    close.close_the_loop(est, X, y, candidates=Candidates(kinds=["polynomial"], max_terms=1))
    out = capsys.readouterr().out
    assert "selecting terms" in out and "step 1:" not in out  # the stages, not every candidate
