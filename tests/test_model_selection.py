"""Sensitivity sweeps (theta error and test error against a hyperparameter)."""

import matplotlib

matplotlib.use("Agg")

import numpy as np
import pytest

from sklearn_hybrid import HybridRegressor, theta_error
from sklearn_hybrid.datasets import make_pendulum
from sklearn_hybrid.methods import FisherSAM
from sklearn_hybrid.model_selection import plot_sensitivity, sensitivity_curve
from sklearn_hybrid.models import pendulum_f


def test_sensitivity_curve_matches_separate_fits():
    d = make_pendulum(n_train=6, n_val=2, n_test=4, n_steps=3, random_state=0)
    est = HybridRegressor(science=pendulum_f, method=FisherSAM(), dt=0.2, max_iter=8, residual={"hidden": (8,)})
    res = sensitivity_curve(est, "method__rho", [0.01, 0.5], d.X_train, d.y_train, d.X_test, d.y_test,
                            theta_true=d.theta_true, seeds=[0, 1])
    assert res.theta_error.shape == res.y_error.shape == (2, 2)
    single = est.set_params(method__rho=0.5, random_state=1).fit(d.X_train, d.y_train)
    assert res.theta_error[1, 1] == pytest.approx(theta_error(single.theta_, d.theta_true))
    assert res.theta[1][1] == single.theta_
    rmse = np.sqrt(np.mean((single.predict(d.X_test) - d.y_test) ** 2))
    assert res.y_error[1, 1] == pytest.approx(rmse)
    axes = plot_sensitivity(res, reference=res)
    assert axes[0].get_xlabel() == "rho"  # the setting's own name
    with pytest.raises(ValueError, match="no parameter 'gamma'"):
        sensitivity_curve(est, "gamma", [1], d.X_train, d.y_train, d.X_test, d.y_test,
                          theta_true=d.theta_true)


def test_sensitivity_curve_takes_nested_names_as_grid_search_does():
    d = make_pendulum(n_train=6, n_val=2, n_test=4, n_steps=3, random_state=0)
    est = HybridRegressor(science=pendulum_f, dt=0.2, max_iter=3, residual={"hidden": (8,)})
    res = sensitivity_curve(est, "residual__hidden", [(4,), (8,)], d.X_train, d.y_train, d.X_test, d.y_test,
                            theta_true=d.theta_true, seeds=[0])
    single = est.set_params(residual__hidden=(4,), random_state=0).fit(d.X_train, d.y_train)
    assert res.theta[0][0] == single.theta_
    with pytest.raises(ValueError, match="sweep it with seeds"):  # seeds would overwrite it silently
        sensitivity_curve(est, "random_state", [1, 2], d.X_train, d.y_train, d.X_test, d.y_test,
                          theta_true=d.theta_true)
