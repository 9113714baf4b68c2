"""What a fit means after it: reports, sweeps, weights, solvers and scorers that read the fit
itself, not parameters set since, and that refuse data they would misread.

Each test reproduces a defect found by a user audit (see the git log of this file).
"""

import warnings

import numpy as np
import pandas as pd
import pytest
from sklearn.metrics import r2_score

from sklearn_hybrid import HybridRegressor, HybridRegressorCV, make_flat_scorer, theta_error
from sklearn_hybrid.methods import FunctionalRegularization
from sklearn_hybrid.datasets import make_pendulum
from sklearn_hybrid.models import pendulum_f

FAST = dict(dt=0.2, max_iter=10, residual={"hidden": (8,)}, random_state=0)


@pytest.fixture(scope="module")
def data():
    return make_pendulum(n_train=10, n_val=2, n_test=4, n_steps=4, random_state=0)


def test_fit_report_describes_the_fit_not_later_set_params(data):
    est = HybridRegressor(science=pendulum_f, **FAST).fit(data.X_train, data.y_train)
    report = est.fit_report()
    est.set_params(max_iter=5000, method="erm", theta_fixed=["omega"])
    assert est.fit_report() == report
    assert "method: fsam" in report and "max_iter=10" in report and "(fixed)" not in report


def test_theta_encoder_changed_after_fit_is_named(data):
    est = HybridRegressor(science=pendulum_f, **FAST).fit(data.X_train, data.y_train)
    est.set_params(theta_encoder={"hidden": (4,)})
    with pytest.raises(ValueError, match="theta_encoder=None -> .* was changed after fit"):
        est.predict(data.X_test)


def test_simulate_refuses_reordered_state_columns(data):
    columns = ["angle", "velocity"]
    est = HybridRegressor(science=pendulum_f, **FAST).fit(pd.DataFrame(data.X_train, columns=columns),
                                                          data.y_train)
    x0 = pd.DataFrame(data.X_test, columns=columns)
    np.testing.assert_array_equal(est.simulate(x0, n_steps=3), est.simulate(data.X_test, n_steps=3))
    with pytest.raises(ValueError, match=r"x0 has columns \['velocity', 'angle'\]"):
        est.simulate(x0[columns[::-1]], n_steps=3)


@pytest.mark.parametrize("solver", ["euler", "midpoint"])
def test_fixed_grid_solvers_take_n_substeps(data, solver):
    """They took one step per output interval whatever n_substeps said."""
    def science_only(n_substeps, solver):
        est = HybridRegressor(science=pendulum_f, solver=solver, n_substeps=n_substeps, method="erm",
                              dtype="float64", **{**FAST, "max_iter": 1, "lr": 1e-12}).fit(data.X_train, data.y_train)
        return est.predict_science(data.X_test)

    reference = science_only(16, "rk4")
    coarse = np.abs(science_only(1, solver) - reference).max()
    fine = np.abs(science_only(16, solver) - reference).max()
    assert fine < coarse / 10


def test_zero_weight_samples_change_neither_theta_nor_its_standard_error(data):
    X, y = data.X_train, data.y_train
    weights = np.r_[np.ones(6), np.zeros(4)]
    for method in ("erm", "f-reg"):
        est = dict(science=pendulum_f, method=method, dtype="float64", **FAST)
        weighted = HybridRegressor(**est).fit(X, y, sample_weight=weights)
        kept = HybridRegressor(**est).fit(X[:6], y[:6])
        assert weighted.theta_["omega"] == pytest.approx(kept.theta_["omega"], rel=1e-9)
        assert weighted.theta_std_["omega"] == pytest.approx(kept.theta_std_["omega"], rel=1e-6)


def test_f_reg_penalty_weighs_samples_like_the_data_loss(data):
    """A weight of 2 equals a repeated sample for f-reg too (its penalty was an unweighted mean)."""
    X, y = data.X_train[:5], data.y_train[:5]
    est = dict(science=pendulum_f, method=FunctionalRegularization(lam=1.0), dtype="float64", validation_fraction=None,
               **FAST)
    weighted = HybridRegressor(**est).fit(X, y, sample_weight=[2, 1, 1, 1, 1])
    repeated = HybridRegressor(**est).fit(np.r_[X[:1], X], np.r_[y[:1], y])
    np.testing.assert_allclose(weighted.predict(X), repeated.predict(X), atol=1e-10)


def test_targets_in_another_layout_are_refused(data):
    est = HybridRegressor(science=pendulum_f, **FAST).fit(data.X_train, data.y_train)
    X, y = data.X_test, data.y_test
    flat = y.reshape(len(y), -1)
    assert est.score(X, flat) == pytest.approx(r2_score(flat, est.predict(X).reshape(len(y), -1)))
    transposed = np.swapaxes(y, 1, 2)  # same size: a reshape would score it without a word
    with pytest.raises(ValueError, match="y has shape"):
        est.score(X, transposed)
    with pytest.raises(ValueError, match="y has shape"):
        make_flat_scorer("neg_mean_squared_error")(est, X, transposed)


def test_theta_error_pairs_parameters_by_shape():
    with pytest.raises(ValueError, match=r"theta\['a'\] has shape \(2,\) and theta_true\['a'\] \(\)"):
        theta_error({"a": [1.0, 2.0], "b": 3.0}, {"a": 1.0, "b": [2.0, 3.0]})
    with pytest.raises(ValueError, match="names no parameter"):
        theta_error({"a": 1.0}, {})
    with pytest.raises(ValueError, match="is not finite"):
        theta_error({"a": 1.0}, {"a": np.nan})
    assert theta_error({"a": [1.0, 2.0]}, {"a": [1.0, 4.0]}) == pytest.approx(np.sqrt(2))


def test_sweep_with_nan_scores_is_refused_not_decided_by_order(data):
    """R^2 on one validation sample is NaN; np.argmax picked the first member listed."""
    sweep = HybridRegressorCV(HybridRegressor(science=pendulum_f, method="erm", **FAST), rhos=[0.01, 0.5],
                              validation_fraction=0.2)
    from sklearn.exceptions import UndefinedMetricWarning

    with warnings.catch_warnings(record=True) as seen:
        warnings.simplefilter("always")
        with pytest.raises(ValueError, match="Every member's validation score is NaN"):
            sweep.fit(data.X_train[:5], data.y_train[:5])
    assert any(issubclass(w.category, UndefinedMetricWarning) for w in seen)  # scikit-learn's word on the NaN


def test_sweep_checks_feature_names_and_reports_its_own_seeds(data):
    columns = ["angle", "velocity"]
    sweep = HybridRegressorCV(HybridRegressor(science=pendulum_f, method="sam", **FAST), rhos=[0.01, 0.1],
                              seeds=[0, 1]).fit(pd.DataFrame(data.X_train, columns=columns), data.y_train)
    X = pd.DataFrame(data.X_test, columns=columns)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no "fitted without feature names" warning from the members
        np.testing.assert_array_equal(sweep.predict(X), sweep.best_estimator_.predict(data.X_test))
    with pytest.raises(ValueError, match="feature names should match"):
        sweep.predict(X[columns[::-1]])
    sweep.set_params(seeds=[0])
    assert "across the 2 seed(s)" in sweep.fit_report()


def test_sweep_takes_a_scorer_name_on_trajectory_targets(data):
    """scikit-learn's metrics take at most 2-D targets; a name is applied per sample, flattened."""
    base = HybridRegressor(science=pendulum_f, method="sam", **FAST)
    sweep = HybridRegressorCV(base, rhos=[0.01, 0.1], scoring="neg_mean_squared_error")
    sweep.fit(data.X_train, data.y_train)
    flat = make_flat_scorer("neg_mean_squared_error")
    validation = sweep._split(len(data.X_train), 0)[1]
    scores = [flat(m, data.X_train[validation], data.y_train[validation]) for m in sweep.estimators_]
    np.testing.assert_allclose(sweep.cv_results_["score"], scores)


def test_fits_pickled_before_the_snapshot_still_report_and_check(data):
    """The benchmarks reuse pickled fits that carry the older ``_fitted_structure`` instead."""
    est = HybridRegressor(science=pendulum_f, **FAST).fit(data.X_train, data.y_train)
    snapshot = est.__dict__.pop("_fitted_params")
    est._fitted_structure = {k: snapshot[k] for k in ("structure", "dt", "n_substeps", "solver", "observed",
                                                       "n_inputs", "input_interp")}
    assert "method: fsam" in est.fit_report()
    with pytest.raises(ValueError, match="dt=0.2 -> 0.1 was changed after fit"):
        est.set_params(dt=0.1).predict(data.X_test)
