"""HybridRegressorCV: a sweep of rho / lam / seeds trained as one batched model."""

from __future__ import annotations

import dataclasses

import itertools
import math
import numbers
import warnings

import numpy as np
from sklearn.base import BaseEstimator, RegressorMixin, clone
from sklearn.metrics import check_scoring
from sklearn.utils.validation import check_is_fitted, validate_data

from .training.stacked import train_members, train_one_by_one
from ._estimator import HybridRegressor
from ._fitting import prepare_fit, store_fit
from .methods import FLAT_SETTINGS, SAM, ParameterRegularization, method_of, stackable_methods
from ._validation import check_n_jobs, set_feature_info, torch_threads, validate_into_copy
from .training.memory import check_fit_memory
from .metrics import make_flat_scorer
from .training.engine import DivergenceError

__all__ = ["HybridRegressorCV"]


def _values(name, values, default, kind=numbers.Real, positive=True):
    # the values themselves, not np.atleast_1d(...).tolist(), which would report 1.5 as 1.0
    values = [default] if values is None else list(values) if np.ndim(values) else [values]
    if not values:
        raise ValueError(f"{name} must hold at least one value.")
    for v in values:
        if not isinstance(v, kind) or isinstance(v, bool) or not math.isfinite(v) or (positive and not v > 0):
            what = "integers" if kind is numbers.Integral else "numbers"
            raise ValueError(f"{name} must hold {'positive ' if positive else ''}{what}, got {v!r}.")
    if len(set(values)) < len(values):  # a repeated seed would report a spread of 0 as if measured
        raise ValueError(f"{name} holds a value more than once: {values}.")
    return values


def member_estimator(estimator, params: dict):
    """A clone of ``estimator`` with one member's settings (``random_state`` and the swept keywords);
    a method given as an object gets those of its fields replaced in a copy (the estimator's own
    keywords are not read then)."""
    method = method_of(estimator.get_params(deep=False), fitted=True)
    return clone(estimator).set_params(random_state=params["random_state"], **FLAT_SETTINGS,
                                       method=method.for_members(**_configuration(params)))


def _configuration(params: dict) -> dict:
    """A member's swept keywords without its seed: members that share them differ by the seed only."""
    return {k: v for k, v in params.items() if k != "random_state"}


class HybridRegressorCV(RegressorMixin, BaseEstimator):
    """A sweep over rho, lam and seeds of one HybridRegressor, trained as one batched model.

    As scikit-learn's ``RidgeCV`` is to ``Ridge``: every
    combination of the given ``rhos``, ``lams`` and ``seeds`` is a *member*; the
    K members are trained at once as a single stacked model (each member's
    update is exactly the one a separate ``HybridRegressor`` fit with that
    configuration and seed makes, up to floating-point summation order), then
    scored, and the best member is kept.  The spread of theta across seeds
    at the chosen configuration is reported as an uncertainty.  Every member
    trains for ``max_iter`` iterations: early stopping (``tol``) applies to
    single fits only, as the members share one batched optimiser.

    Parameters
    ----------
    estimator : HybridRegressor
        The template; members take all its parameters except those swept.
    rhos : sequence of float, optional
        SAM radii to sweep (default: the estimator's ``rho``).
    lams : sequence of float, optional
        Penalty weights to sweep for ``method="p-reg"`` (default: its ``lam``).
    seeds : sequence of int, optional
        ``random_state`` of the members (default: the estimator's
        ``random_state``, or 0 when that is None).
    scoring : str, callable or None, default=None
        Scorer ``scorer(member, X_val, y_val)`` (greater is better), e.g.
        :func:`~sklearn_hybrid.make_theta_scorer` when the true parameters
        are known; None uses the members' ``score`` (R^2) on the validation
        samples; a scikit-learn scorer name (``"neg_mean_squared_error"``) is
        applied to targets flattened per sample (:func:`~sklearn_hybrid.make_flat_scorer`),
        since trajectories have more axes than scikit-learn's metrics take.
    validation_fraction : float or None, default=0.2
        Fraction of the samples held out for scoring (a fixed random subset,
        seeded by the first seed); None trains on all samples and scores on
        them.
    n_jobs : int or None, default=None
        Train the members in this many groups at once, each in its own worker
        process with one torch thread (None: one group in this process, with
        the estimator's ``n_threads``).  Groups share nothing, so each uses a
        core without the per-operation synchronisation of multi-threaded
        operations; the science function must then be picklable (a
        module-level function, or anything cloudpickle handles).  Negative
        values follow joblib: -1 gives one group per core.

    Notes
    -----
    With a ``theta_encoder`` (theta varying per sample) the members are
    trained one by one (in ``n_jobs`` worker processes), not stacked: the
    stacked model would have to vectorise the per-sample science calls over
    members too.  Each member's update is still that of a separate fit;
    ``theta_`` and ``theta_std_`` then describe the members' ``theta_`` (the
    mean of the per-sample theta over the training samples).

    Attributes
    ----------
    estimators_ : list of HybridRegressor
        The fitted members, in the order of ``cv_results_["params"]``.
    cv_results_ : dict of ndarray
        ``params`` (list of dicts), ``rho``, ``lam``, ``seed``, ``score``,
        ``diverged_at`` (-1 when training stayed finite), ``theta_<name>``.
    best_index_ : int
        Member with the highest score.
    best_estimator_ : HybridRegressor
        That member.
    best_params_ : dict
        Its swept parameters.
    theta_ : dict
        Its parameters theta.
    theta_std_ : dict
        Standard deviation of theta across the seeds of its configuration.
    n_features_in_ : int
        Number of features seen in ``fit``.
    """

    def __init__(self, estimator=None, *, rhos=None, lams=None, seeds=None, scoring=None,
                 validation_fraction=0.2, n_jobs=None):
        self.estimator = estimator
        self.rhos = rhos
        self.lams = lams
        self.seeds = seeds
        self.scoring = scoring
        self.validation_fraction = validation_fraction
        self.n_jobs = n_jobs

    def __sklearn_tags__(self):
        tags = super().__sklearn_tags__()
        tags.regressor_tags.poor_score = True
        tags.target_tags.multi_output = True
        return tags

    def _members(self):
        est = self.estimator
        if not isinstance(est, HybridRegressor):
            raise TypeError(
                f"estimator must be a HybridRegressor, got {type(est).__name__}; e.g. "
                "HybridRegressorCV(HybridRegressor(science=f), rhos=[0.01, 0.1])."
            )
        method = method_of(est.get_params(deep=False))
        if not method.stackable:
            raise ValueError(
                f"HybridRegressorCV trains methods {stackable_methods()}; for "
                f"{method.name!r} use GridSearchCV over HybridRegressor."
            )
        default_seed = 0 if est.random_state is None else est.random_state
        if not isinstance(default_seed, numbers.Integral):
            raise ValueError("With a RandomState as the estimator's random_state, give seeds=[...].")
        # a setting the method does not have is swept over its class default, and ignored
        rhos = _values("rhos", self.rhos, getattr(method, "rho", SAM.rho))
        lams = _values("lams", self.lams, getattr(method, "lam", ParameterRegularization.lam))
        seeds = _values("seeds", self.seeds, default_seed, kind=numbers.Integral, positive=False)
        if not all(0 <= s < 2**32 for s in seeds):  # numpy's seeding range
            raise ValueError(f"seeds must be integers in [0, 2**32 - 1], got {seeds}.")
        return [{"rho": r, "lam": lam, "random_state": s}
                for r, lam, s in itertools.product(rhos, lams, seeds)]

    def _n_groups(self):
        return check_n_jobs(self.n_jobs)

    def _split(self, n, seed):
        frac = self.validation_fraction
        if frac is None:
            return np.arange(n), np.arange(n)
        if not (isinstance(frac, numbers.Real) and 0 < frac < 1):
            raise ValueError(f"validation_fraction must be in (0, 1) or None, got {frac!r}.")
        n_val = int(round(frac * n))
        if n_val < 1 or n - n_val < 2:
            raise ValueError(f"validation_fraction={frac} leaves no usable split of {n} samples.")
        order = np.random.default_rng(seed).permutation(n)
        return np.sort(order[n_val:]), np.sort(order[:n_val])

    def fit(self, X, y):
        """Train every member at once, score them and keep the best.

        Parameters
        ----------
        X : array-like of shape (n_samples, ...)
            Inputs, as for :meth:`HybridRegressor.fit`.
        y : array-like of shape (n_samples, ...)
            Targets, as for :meth:`HybridRegressor.fit`.

        Returns
        -------
        self : HybridRegressorCV
        """
        params = self._members()
        self._n_groups()
        y_arr = np.asarray(y)
        # self changes only after training: a failed refit leaves the earlier fit whole
        _, features = validate_into_copy(
            self, X, np.reshape(y_arr, (len(y_arr), math.prod(y_arr.shape[1:]))),
            allow_nd=True, multi_output=True, y_numeric=True)
        X_arr = np.asarray(X)
        train_idx, val_idx = self._split(len(X_arr), params[0]["random_state"])
        members = [member_estimator(self.estimator, p) for p in params]
        setups = [prepare_fit(m, X_arr[train_idx], y_arr[train_idx]) for m in members]
        # the members share shapes: measure one, count those in memory at once (all of them
        # when stacked, one per worker when members with an encoder train one by one)
        together = (len(setups) if self.estimator.theta_encoder is None
                    else min(self._n_groups(), len(setups)))
        with torch_threads(self.estimator.n_threads):
            samples_per_pass = check_fit_memory(setups[0], n_models=together)
        for setup in setups:
            setup.samples_per_pass = samples_per_pass
        history = self._train(setups, params)
        diverged = history["diverged_at"]
        if (diverged >= 0).all():
            raise DivergenceError(
                f"The training loss of every member became non-finite (first at iteration "
                f"{diverged.min()}); lower lr or rho, check the data scale, or bound theta "
                "with theta_bounds."
            )
        scores = np.full(len(members), -np.inf)
        scorer = (make_flat_scorer(self.scoring) if isinstance(self.scoring, str)
                  else check_scoring(members[0], scoring=self.scoring))
        X_val, y_val = X_arr[val_idx], y_arr[val_idx]
        for k, (member, setup) in enumerate(zip(members, setups)):
            member_history = {"loss": history["loss"][:, k],
                              "theta": {n: v[:, k] for n, v in history["theta"].items()}}
            store_fit(member, setup, member_history)
            if diverged[k] < 0:
                scores[k] = scorer(member, X_val, y_val)
        best = self._best(scores, diverged, len(val_idx))
        self.estimators_, self.best_index_ = members, best
        set_feature_info(self, features)
        self.best_estimator_ = members[best]
        self.best_params_ = params[best]
        self.theta_ = self.best_estimator_.theta_
        self.cv_results_ = self._results(params, scores, diverged)
        same = [k for k, p in enumerate(params)
                if _configuration(p) == _configuration(params[best]) and diverged[k] < 0]
        self.theta_std_ = {}
        for name, value in self.theta_.items():
            spread = np.std([np.asarray(members[k].theta_[name]) for k in same], axis=0)
            self.theta_std_[name] = float(spread) if np.ndim(value) == 0 else spread
        return self

    def _best(self, scores, diverged, n_val):
        """Index of the best score; a NaN score (np.argmax would pick it) ranks last, with a warning."""
        nan = np.isnan(scores)
        if nan.all():
            raise ValueError(
                f"Every member's validation score is NaN ({self.scoring or 'R^2'} on {n_val} validation "
                "sample(s); R^2 needs at least two): raise validation_fraction, give more samples, or "
                "choose another scoring.")
        if nan.any():
            warnings.warn(f"The validation score of member(s) {np.flatnonzero(nan).tolist()} is NaN; "
                          "they rank last.", UserWarning, stacklevel=3)
        return int(np.argmax(np.where(nan, -np.inf, scores)))

    def _train(self, setups, params):
        """Train the members, in ``n_jobs`` groups at once (worker processes of one torch thread each)."""
        first = setups[0]
        n_jobs = self._n_groups()
        threads = self.estimator.n_threads if min(n_jobs, len(setups)) == 1 else 1
        if self.estimator.theta_encoder is not None:  # member by member (see Notes)
            history, models = train_one_by_one(
                [(s.model, s.method, s.inputs, s.y, s.config, s.seed) for s in setups], n_jobs=n_jobs,
                n_threads=self.estimator.n_threads if n_jobs == 1 else 1)
            for setup, model in zip(setups, models):
                setup.model = model
            return history
        # one value per member of each swept keyword; the method takes those it has fields for
        method = first.method.for_members(**{k: np.array([p[k] for p in params])
                                             for k in _configuration(params[0])})
        # every member trains max_iter steps, as the report says (no early stop of the stack)
        config = dataclasses.replace(first.config, tol=None)
        history, models = train_members([s.model for s in setups], method, first.inputs, first.y, config,
                                        [s.seed for s in setups], n_jobs=n_jobs, n_threads=threads)
        for setup, model in zip(setups, models):  # trained copies when they come from a worker
            setup.model = model
        return history

    def _results(self, params, scores, diverged):
        results = {"params": params, "score": scores, "diverged_at": diverged}
        for key in _configuration(params[0]):
            results[key] = np.array([p[key] for p in params], dtype=float)
        results["seed"] = np.array([p["random_state"] for p in params])
        for name in self.estimators_[0].theta_:
            results[f"theta_{name}"] = np.array([np.asarray(m.theta_[name]) for m in self.estimators_])
        return results

    def fit_report(self) -> str:
        """A text report: the chosen configuration, and theta with its spread across seeds.

        The uncertainty is the standard deviation of theta across the members
        that differ only in their seed (``theta_std_``): the spread between
        training runs, which a single fit's standard error (the best member's
        ``fit_report()``) does not see.  With one seed it is 0 and the report
        says so.

        Returns
        -------
        str
        """
        check_is_fitted(self)
        best = self.best_estimator_
        n_seeds = len(set(self.cv_results_["seed"].tolist()))  # of the fit, whatever set_params says since
        lines = [f"members: {len(self.estimators_)} (rho x lam x {n_seeds} seed(s)), "
                 f"{best.max_iter} iterations each",
                 f"best: {self.best_params_}, score {self.cv_results_['score'][self.best_index_]:.4g}"]
        how = (f"spread: standard deviation across the {n_seeds} seed(s) of the best configuration"
               + (" (one seed: no spread measured)" if n_seeds < 2 else "")
               + "; the spread between training runs, not an interval of theta: profile_theta says whether "
               "the data identify it")
        from ._fit_report import format_report

        return format_report("Hybrid sweep", lines, self.theta_, self.theta_std_, how,
                             std_label=f"spread across {n_seeds} seed(s)")

    def predict(self, X):
        """Predict with the best member.

        Parameters
        ----------
        X : array-like of shape (n_samples, ...)

        Returns
        -------
        ndarray of shape (n_samples, ...)
            Shaped as ``y`` in ``fit``.
        """
        X = self._fitted_X(X)  # first: NotFittedError before best_estimator_ is looked up
        return self.best_estimator_.predict(X)

    def predict_theta(self, X):
        """Each sample's theta according to the best member (see ``HybridRegressor.predict_theta``)."""
        X = self._fitted_X(X)
        return self.best_estimator_.predict_theta(X)

    def score(self, X, y, sample_weight=None):
        """R^2 of the best member (targets flattened per sample)."""
        X = self._fitted_X(X)
        return self.best_estimator_.score(X, y, sample_weight=sample_weight)

    def _fitted_X(self, X):
        """``X`` checked against the fit's feature names and count (the members were fitted on arrays)."""
        check_is_fitted(self)
        validate_data(self, X, reset=False, skip_check_array=True)
        return np.asarray(X)
