"""Errors of estimated physical parameters, and scorers for scikit-learn's model selection."""

from __future__ import annotations

from typing import Mapping

import numpy as np
from sklearn.base import BaseEstimator, RegressorMixin
from sklearn.metrics import get_scorer

from ._validation import check_target_layout

__all__ = ["network_share", "rate_share", "theta_error", "make_theta_scorer", "ThetaScorer", "make_flat_scorer", "FlatScorer",
           "make_per_sample_theta_scorer", "PerSampleThetaScorer"]

_METRICS = ("rmse", "cosine")


def network_share(y_hybrid, y_science) -> float:
    """The network's share of a hybrid's prediction: ``RMS(y_hybrid - y_science) / RMS(y_hybrid)``.

    How much of the prediction would change if the network were switched off (0: the science
    alone makes it; near 1: the network does).

    Parameters
    ----------
    y_hybrid, y_science : array-like of the same shape
        Predictions of the hybrid and of its science part alone (``predict``, ``predict_science``).

    Returns
    -------
    float
    """
    y_hybrid, y_science = np.asarray(y_hybrid, dtype=float), np.asarray(y_science, dtype=float)
    if y_hybrid.shape != y_science.shape:
        raise ValueError(f"y_hybrid has shape {y_hybrid.shape} and y_science {y_science.shape}; they must match.")
    return float(np.sqrt(np.mean((y_hybrid - y_science) ** 2) / max(np.mean(y_hybrid ** 2), 1e-300)))


def rate_share(g, f) -> np.ndarray:
    """The network's share of a hybrid ODE's right-hand side ``f + g``, per component:
    ``RMS(g) / (RMS(f) + RMS(g))`` over the rows (visited states), between 0 and 1.

    Not ``RMS(g) / RMS(f + g)``, which exceeds 1 where the network cancels part of the science (a
    "share" of 261 %); this reads 0.5 where the network is as large as the science, whichever way it
    points, and NaN where both are zero.

    Parameters
    ----------
    g, f : array-like of shape (n_points, n_components)
        The network's and the science's rates at the same states.

    Returns
    -------
    ndarray of shape (n_components,)
    """
    g, f = np.asarray(g, dtype=float), np.asarray(f, dtype=float)
    if g.shape != f.shape:
        raise ValueError(f"g has shape {g.shape} and f {f.shape}; they must match.")
    g_size, f_size = np.sqrt(np.mean(g ** 2, axis=0)), np.sqrt(np.mean(f ** 2, axis=0))
    total = g_size + f_size
    return g_size / np.where(total > 0, total, np.nan)


def _stack(theta: Mapping, names, what: str) -> np.ndarray:
    missing = [n for n in names if n not in theta]
    if missing:
        raise KeyError(f"{what} has no value for {missing}; it has {sorted(theta)}.")
    return np.concatenate([np.ravel(np.asarray(theta[n], dtype=float)) for n in names])


def _check_pairs(theta: Mapping, theta_true: Mapping) -> None:
    """Each compared parameter must have its reference's shape: stacking alone would pair
    ``{"a": [1, 2], "b": 3}`` with ``{"a": 1, "b": [2, 3]}`` entry by entry."""
    for name in theta_true:
        est, true = np.shape(theta[name]), np.shape(theta_true[name])
        if est != true:
            raise ValueError(f"theta[{name!r}] has shape {est} and theta_true[{name!r}] {true}; they must match.")
        if not np.all(np.isfinite(np.asarray(theta_true[name], dtype=float))):
            raise ValueError(f"theta_true[{name!r}] is not finite.")


def theta_error(theta: Mapping, theta_true: Mapping, metric: str = "rmse") -> float:
    """Compare estimated parameters with reference values.

    Parameters
    ----------
    theta : dict
        Estimated values (e.g. a fitted estimator's ``theta_``).
    theta_true : dict
        Reference values; only these names are compared.
    metric : {"rmse", "cosine"}
        Root mean squared error over all compared entries (lower is better;
        for one scalar it is the absolute error), or cosine similarity of the
        stacked vectors (higher is better; for parameters known only up to
        scale, as in the light-tunnel task).

    Returns
    -------
    float
    """
    if metric not in _METRICS:
        raise ValueError(f"Unknown metric {metric!r}; choose one of {_METRICS}.")
    names = list(theta_true)
    if not names:
        raise ValueError("theta_true names no parameter to compare.")
    est, true = _stack(theta, names, "theta"), _stack(theta_true, names, "theta_true")
    _check_pairs(theta, theta_true)
    if metric == "rmse":
        return float(np.sqrt(np.mean((est - true) ** 2)))
    return float(est @ true / (np.linalg.norm(est) * np.linalg.norm(true) + 1e-300))


class ThetaScorer:
    """Scorer ``scorer(estimator, X, y)`` comparing ``estimator.theta_`` with references.

    Greater is better: it returns minus the RMSE, or the cosine similarity.
    Works on a fitted estimator or a pipeline whose last step has ``theta_``.
    """

    def __init__(self, theta_true: Mapping, metric: str = "rmse"):
        if metric not in _METRICS:
            raise ValueError(f"Unknown metric {metric!r}; choose one of {_METRICS}.")
        self.theta_true, self.metric = dict(theta_true), metric

    def __call__(self, estimator, X=None, y=None) -> float:
        final = estimator[-1] if hasattr(estimator, "steps") else estimator
        error = theta_error(final.theta_, self.theta_true, self.metric)
        return -error if self.metric == "rmse" else error

    def __repr__(self) -> str:
        return f"make_theta_scorer({self.theta_true!r}, metric={self.metric!r})"


def make_theta_scorer(theta_true: Mapping, metric: str = "rmse") -> ThetaScorer:
    """Make a scorer for ``GridSearchCV``, ``cross_validate`` or ``validation_curve``.

    Parameters
    ----------
    theta_true : dict
        Reference parameter values, e.g. ``{"omega": 2 / 3}``.
    metric : {"rmse", "cosine"}
        See :func:`theta_error`.

    Returns
    -------
    ThetaScorer
        A picklable callable ``scorer(estimator, X, y) -> float`` (greater is better).
    """
    return ThetaScorer(theta_true, metric)


class _FlatPredictions(RegressorMixin, BaseEstimator):
    """A fitted estimator whose predictions come back flattened per sample, checked against ``y``."""

    def __init__(self, estimator=None, y=None):
        self.estimator = estimator
        self.y = y

    def __sklearn_is_fitted__(self) -> bool:
        return True

    def predict(self, X):
        pred = np.asarray(self.estimator.predict(X))
        check_target_layout(self.y, pred)
        return pred.reshape(len(pred), -1)


class FlatScorer:
    """A scikit-learn scorer applied to targets and predictions flattened per sample.

    scikit-learn's metrics accept 1-D or 2-D targets; hybrid ODE targets are
    ``(n_samples, n_steps, n_observed)``.  Greater is better, as for the
    wrapped scorer.
    """

    def __init__(self, scoring):
        self.scoring = scoring
        self._scorer = get_scorer(scoring)

    def __call__(self, estimator, X, y) -> float:
        y = np.asarray(y)
        return self._scorer(_FlatPredictions(estimator, y), X, y.reshape(len(y), -1))

    def __repr__(self) -> str:
        return f"make_flat_scorer({self.scoring!r})"


def make_flat_scorer(scoring) -> FlatScorer:
    """Use a scikit-learn scorer on trajectory targets (flattened per sample).

    Parameters
    ----------
    scoring : str or callable
        A scorer name such as ``"neg_mean_squared_error"`` or a scorer object
        (see :func:`sklearn.metrics.get_scorer`).

    Returns
    -------
    FlatScorer
        A picklable callable ``scorer(estimator, X, y) -> float`` for
        ``GridSearchCV``, ``cross_validate`` or ``validation_curve``.

    Examples
    --------
    >>> from sklearn_hybrid.metrics import make_flat_scorer
    >>> make_flat_scorer("neg_mean_squared_error")
    make_flat_scorer('neg_mean_squared_error')
    """
    return FlatScorer(scoring)


class PerSampleThetaScorer:
    """Scorer comparing ``estimator.predict_theta(X)`` with each sample's reference theta.

    The reference of a sample is found by its row of ``X`` (exact match of
    the float64 values), so the scorer works on whatever subset a
    cross-validation split hands it.  Greater is better: minus the RMSE over
    all samples and entries, or the cosine similarity of the stacked vectors.
    """

    def __init__(self, X, theta_true: Mapping, metric: str = "rmse"):
        if metric not in _METRICS:
            raise ValueError(f"Unknown metric {metric!r}; choose one of {_METRICS}.")
        X = np.asarray(X, dtype=float)
        if X.ndim < 1 or len(X) == 0:
            raise ValueError("X must hold at least one sample.")
        self.theta_true = {}
        for name, values in dict(theta_true).items():
            values = np.asarray(values, dtype=float)
            if values.ndim == 0 or len(values) != len(X):
                raise ValueError(
                    f"theta_true[{name!r}] must hold one value per sample of X ({len(X)}), "
                    f"got shape {values.shape}."
                )
            self.theta_true[name] = values
        self.metric = metric
        self._rows = {row.tobytes(): i for i, row in enumerate(X.reshape(len(X), -1))}

    def __call__(self, estimator, X, y=None) -> float:
        X = np.asarray(X, dtype=float)
        idx = [self._rows.get(row.tobytes()) for row in X.reshape(len(X), -1)]
        missing = sum(i is None for i in idx)
        if missing:
            raise ValueError(
                f"{missing} of the {len(X)} samples to score are not rows of the X given to "
                "make_per_sample_theta_scorer, so their reference theta is unknown."
            )
        theta = estimator.predict_theta(X)
        truth = {name: values[idx] for name, values in self.theta_true.items()}
        error = theta_error(theta, truth, self.metric)
        return -error if self.metric == "rmse" else error

    def __repr__(self) -> str:
        return (f"make_per_sample_theta_scorer(X of {len(self._rows)} rows, "
                f"{sorted(self.theta_true)}, metric={self.metric!r})")


def make_per_sample_theta_scorer(X, theta_true: Mapping, metric: str = "rmse") -> PerSampleThetaScorer:
    """Make a scorer of per-sample theta (``theta_encoder``) for ``GridSearchCV`` and friends.

    Parameters
    ----------
    X : array-like of shape (n_samples, ...)
        The samples that will be scored (e.g. the whole ``X`` given to
        ``GridSearchCV.fit``); each sample's reference is looked up by its row.
    theta_true : dict
        ``name -> (n_samples, ...)`` reference values, in the order of ``X``
        (e.g. ``data.theta_train`` of the varying-parameter generators).
    metric : {"rmse", "cosine"}
        See :func:`theta_error`.

    Returns
    -------
    PerSampleThetaScorer
        A picklable callable ``scorer(estimator, X, y) -> float`` (greater is
        better) that calls ``estimator.predict_theta(X)``.
    """
    return PerSampleThetaScorer(X, theta_true, metric)
