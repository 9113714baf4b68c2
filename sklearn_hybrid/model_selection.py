"""Hyperparameter sensitivity as in the paper: theta error and test error against rho or lambda.

Unlike :func:`sklearn.model_selection.validation_curve`, which cross-validates
a score, a sensitivity sweep trains on the training set for each value and
seed, and reports how far theta lands from its reference and how well the
test set is predicted, the two numbers a hybrid modeller trades off.
"""

from __future__ import annotations

from typing import Mapping, Sequence

import numpy as np
from joblib import Parallel, delayed
from sklearn.base import clone
from sklearn.utils import Bunch

from ._validation import check_target_layout
from .metrics import theta_error

__all__ = ["sensitivity_curve", "plot_sensitivity"]


def _fit_one(estimator, param_name, value, seed, X, y, X_test, y_test, theta_true, metric):
    est = clone(estimator).set_params(**{param_name: value, "random_state": seed}).fit(X, y)
    pred = est.predict(X_test)
    y_err = float(np.sqrt(np.mean((pred - check_target_layout(y_test, pred, "y_test")) ** 2)))
    return theta_error(est.theta_, theta_true, metric), y_err, est.theta_


def sensitivity_curve(estimator, param_name: str, param_range: Sequence, X, y, X_test, y_test,
                      *, theta_true: Mapping, seeds: Sequence[int] = (0, 1, 2),
                      metric: str = "rmse", n_jobs: int | None = None) -> Bunch:
    """Train for every value of one hyperparameter and every seed; report both errors.

    Parameters
    ----------
    estimator : HybridRegressor
        Unfitted template (cloned for every fit).
    param_name : str
        Hyperparameter to vary, by its ``set_params`` name: a method object's setting as
        ``"method__rho"`` (``HybridRegressor(method=FisherSAM())``), a network's as
        ``"residual__hidden"``.
    param_range : sequence
        Its values.
    X, y : array-like
        Training data.
    X_test, y_test : array-like
        Held-out data for the prediction error (RMSE over all values).
    theta_true : dict
        Reference parameters for the theta error.
    seeds : sequence of int, default=(0, 1, 2)
        ``random_state`` of the repeated fits.
    metric : {"rmse", "cosine"}, default="rmse"
        Theta comparison (see :func:`~sklearn_hybrid.theta_error`).
    n_jobs : int or None
        Parallel fits (joblib); each fit keeps the estimator's ``n_threads``.

    Returns
    -------
    Bunch
        ``param_name``, ``param_range``, ``seeds``, ``theta_error`` and
        ``y_error`` of shape (n_values, n_seeds), and ``theta`` (list of lists
        of the fitted ``theta_`` dicts).
    """
    if len(param_range) == 0 or len(seeds) == 0:
        raise ValueError("param_range and seeds must not be empty.")
    if param_name == "random_state":
        raise ValueError("random_state is what seeds sets for every fit; sweep it with seeds=[...].")
    try:  # set_params knows nested names (residual__hidden), as GridSearchCV uses them
        clone(estimator).set_params(**{param_name: param_range[0]})
    except ValueError as exc:
        raise ValueError(f"{type(estimator).__name__} has no parameter {param_name!r}: {exc}") from exc
    jobs = [(v, s) for v in param_range for s in seeds]
    out = Parallel(n_jobs=n_jobs)(
        delayed(_fit_one)(estimator, param_name, v, s, X, y, X_test, y_test, theta_true, metric)
        for v, s in jobs)
    shape = (len(param_range), len(seeds))
    return Bunch(param_name=param_name, param_range=list(param_range), seeds=list(seeds),
                 theta_error=np.array([o[0] for o in out]).reshape(shape),
                 y_error=np.array([o[1] for o in out]).reshape(shape),
                 theta=[[out[i * len(seeds) + j][2] for j in range(len(seeds))]
                        for i in range(len(param_range))])


def plot_sensitivity(result: Bunch, reference: Bunch | None = None, axes=None):
    """Plot theta error and y error (mean and spread over seeds) against the hyperparameter.

    Parameters
    ----------
    result : Bunch
        Output of :func:`sensitivity_curve`.
    reference : Bunch, optional
        A baseline (e.g. erm) drawn as dashed horizontal lines, as in the paper.
    axes : pair of matplotlib Axes, optional
        Where to draw; new ones are made otherwise.

    Returns
    -------
    axes : pair of matplotlib Axes
    """
    import matplotlib.pyplot as plt

    if axes is None:
        _, axes = plt.subplots(1, 2, figsize=(8, 3), constrained_layout=True)
    x = np.asarray(result.param_range, dtype=float)
    for ax, key, label in zip(axes, ("theta_error", "y_error"), ("theta error", "test y error")):
        values = result[key]
        ax.errorbar(x, values.mean(1), yerr=values.std(1), marker="o", capsize=3)
        if reference is not None:
            ax.axhline(reference[key].mean(), ls="--", color="grey", label="reference")
            ax.legend()
        ax.set(xscale="log", xlabel=result.param_name.rsplit("__", 1)[-1], ylabel=label)  # method__rho: rho
    return axes
