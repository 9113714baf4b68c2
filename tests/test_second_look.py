"""A second look: candidates one split finds promising but cannot prove are judged on folds of the training samples."""

import numpy as np
import pytest

from test_closed_loop import pendulum  # noqa: F401 (a fixture)

from sklearn_hybrid import HybridRegressor
from sklearn_hybrid.diagnosis import Candidates, Evidence, ScienceFit, physics_terms
from sklearn_hybrid.diagnosis.judge import training_folds
from sklearn_hybrid.diagnosis.loop import stepwise
from sklearn_hybrid.diagnosis.evidence import critical_value
from sklearn_hybrid.diagnosis.loop.report import format_table


def decay_f(v, k=0.5):
    """First-order decay of one state (one state or a batch)."""
    return -k * v


def _select(c: float, n_validation: int, second_look: int | None, seed: int = 0) -> dict:
    """forward_selection on 40 trajectories of dA/dt = -0.6 A - c A^2 (exact solution), judged by the last
    ``n_validation``: with 3, the threshold is Student's t for 2 degrees of freedom (19.2 at z = 3), which
    no real gain passes on three samples."""
    rng = np.random.default_rng(seed)
    dt, n_steps, n, k = 0.25, 12, 40, 0.6
    x0 = rng.uniform(0.3, 2.0, (n, 1))
    t = dt * np.arange(n_steps + 1)
    decay = np.exp(-k * t)[None, :, None]
    x = k * x0[:, None] * decay / (k + c * x0[:, None] * (1 - decay))
    y = x[:, 1:] + 0.01 * rng.standard_normal(x[:, 1:].shape)
    est = HybridRegressor(science=decay_f, dt=dt, max_iter=2, random_state=0).fit(x0, y)
    states = x.reshape(-1, 1)
    learned = -k * states - c * states**2
    splits = [(np.arange(n - n_validation), np.arange(n - n_validation, n))]
    return stepwise.forward_selection(decay_f, {"k": 0.5}, ScienceFit(est, x0, y), splits, ["A"], 1, [states],
                                      learned, [0], candidates=Candidates(terms=physics_terms(["A"], states)),
                                      evidence=Evidence(second_look=second_look))


def test_a_term_three_validation_samples_cannot_prove_is_accepted_on_the_training_folds():
    without = _select(0.5, 3, None)
    assert without["added"] == []
    first = [s for s in without["steps"] if s["term"] == "A^2"][0]
    assert first["gain"] > 0.5 and 2 < first["z"] < first["threshold"]  # promising, not proven

    sel = _select(0.5, 3, 4)
    assert [(t.component, t.name, t.second_look) for t in sel["added"]] == [(0, "A^2", True)]
    assert sel["added"][0].coef == pytest.approx(-0.5, rel=0.05)
    # the term chosen is no rival of itself (as a copy of the candidate tried, it was one before it was typed)
    instead = [r["cand"].name for r in sel["rivals"] if r["role"] == "instead"]
    assert instead and "A^2" not in instead
    assert sel["theta"]["k"] == pytest.approx(0.6, rel=0.05)
    looked = [s for s in sel["steps"] if s["step"] == "1, second look"]
    assert [s["term"] for s in looked if s["accepted"]] == ["A^2"]  # the one kept, though others passed too
    assert all(s["z"] > s["threshold"] for s in looked if s["accepted"])
    # 37 training samples in 4 folds: the threshold for 37 samples, far below the first look's 19.2
    assert looked[0]["threshold"] == pytest.approx(critical_value(3.0, 37))
    # the first look's own row still says it did not pass
    assert not [s for s in sel["steps"] if s["step"] == 1 and s["term"] == "A^2"][0]["accepted"]
    report = format_table([], [{**t.record(), "output": "g[A]"} for t in sel["added"]],
                          [{**s, "output": "g[A]"} for s in sel["steps"]], None, 3)
    assert "| 1, second look | g[A] | A^2 |" in report and "second look (rows 'second look')" in report
    assert "accepted on a second look" in report


def test_nothing_is_added_on_a_second_look_when_nothing_is_missing():
    sel = _select(0.0, 3, 4)
    assert sel["added"] == []


def test_second_look_needs_one_split_and_two_samples_a_fold():
    fit = object.__new__(ScienceFit)
    fit.y = np.zeros((10, 1))
    one_split = [(np.arange(7), np.arange(7, 10))]
    assert training_folds(fit, one_split, None, None) is None
    assert training_folds(fit, one_split + one_split, None, 4) is None  # every sample judges already
    assert training_folds(fit, [(np.arange(3), np.arange(3, 10))], None, 4) is None  # one fold only


@pytest.mark.parametrize("folds", [1, 2.0, True, "4"])
def test_a_bad_number_of_second_look_folds_is_named(folds):
    from sklearn_hybrid.diagnosis import close_the_loop

    X, y = np.ones((8, 1)), np.ones((8, 3, 1))
    with pytest.raises(ValueError, match="second_look must be None or a number of folds of at least 2"):
        close_the_loop(HybridRegressor(science=decay_f, dt=0.1), X, y, evidence=Evidence(second_look=folds))


def test_a_term_accepted_on_a_second_look_is_dropped_by_the_same_judge(pendulum):  # noqa: F811 (the fixture)
    """Drag v_dot|v_dot| stands in for linear damping until v_dot is in; accepted on a second look, its drop
    is judged on the training folds, and its row says so."""
    from dataclasses import replace

    from test_closed_loop import NAMES, _held_out_judge, _on_v_dot, pendulum_f

    from sklearn_hybrid.diagnosis.loop.candidates import augment_with

    judge = _held_out_judge(pendulum)
    fit = ScienceFit(pendulum[1], pendulum[0].X_train, pendulum[0].y_train)
    n = len(fit.y)
    recheck = training_folds(fit, [(np.arange(n - 12), np.arange(n - 12, n))], None, 4)
    placed = _on_v_dot(pendulum, ["v_dot|v_dot|", "v_dot"])
    full = augment_with(pendulum_f, placed, NAMES, 2, None)
    theta = judge.fit(full, {"omega": 0.6})
    added = [replace(p.with_fitted(full, theta, k), second_look=k == 0) for k, p in enumerate(placed)]
    steps = []
    _, kept, _, errors = stepwise._drop_dispensable(pendulum_f, full, added, theta, judge.errors(full, theta), judge,
                                                    NAMES, 2, None, Evidence(), steps, lambda s: None, None, recheck)
    assert [t.name for t in kept] == ["v_dot"]
    assert [(s["step"], s["term"]) for s in steps] == [("drop, second look", "v_dot|v_dot|")]
    assert steps[0]["threshold"] == pytest.approx(critical_value(3.0, n - 12))  # the folds' samples, not the 12
    assert len(errors) == 12  # the model kept is judged on the validation samples again
