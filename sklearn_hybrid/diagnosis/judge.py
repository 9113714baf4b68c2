"""Held-out errors of network-free science models: what the selection's evidence compares.

:class:`Judge` refits a science model (:class:`~sklearn_hybrid.diagnosis.science_fit.ScienceFit`)
on training samples and returns its errors on held-out ones: one split, or contiguous folds where
every sample judges. :func:`training_folds` builds the judge of a second look, folds of one split's
training samples. :func:`~sklearn_hybrid.diagnosis.evidence.evidence` turns two models' errors into
a verdict; :mod:`~sklearn_hybrid.diagnosis.loop.stepwise` decides what to compare. :func:`judge_terms` holds
the terms a :class:`~sklearn_hybrid.diagnosis.ResidualDiagnosis` reads off the residual to the same test.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from ..science import read_signature
from .augment import augment_science
from .evidence import evidence, group_means, held_out_splits
from .science_fit import ScienceFit

# Iterations of a candidate's screening refit. Most converge in under 20; a shape parameter that
# drifts along a flat direction (a saturation's K growing towards the linear limit) would use the
# default 100, a third of the Silverbox selection's time. An unconverged screen only understates
# the candidate's gain, and the accepted model is refitted to convergence afterwards.
SCREENING_NFEV = 40
# Training samples of a candidate's screening refit and of the ranking by fit: a few parameters
# are fitted as well from 256 windows as from 762 (Silverbox), at a third of the time; an
# accepted term is refitted on every training sample before the next step.
SCREENING_SAMPLES = 256


class Judge:
    """Held-out errors of science models: one split (fitted on the training rows, errors of the
    validation rows) or contiguous folds (each block's errors from a fit on the other rows, so that
    every sample judges: the evidence a single short record can give).

    ``fit`` gives the parameters a step continues from (on the training rows, or on every row with
    folds); ``errors`` the per-sample held-out errors, in the same sample order for every model.
    ``screening``: at most ``SCREENING_SAMPLES`` evenly spaced fitting rows and ``SCREENING_NFEV``,
    and fitted initial states held where :meth:`settle` left them. ``groups`` (every row's group
    code): ``errors`` gives one mean error per group instead of one per row.
    """

    def __init__(self, fit: ScienceFit, splits: Sequence[tuple[np.ndarray, np.ndarray]],
                 groups: np.ndarray | None = None):
        # the rows a step's model is fitted on: the training rows of one split, or every judged row
        rows = splits[0][0] if len(splits) == 1 else np.unique(np.concatenate([te for _, te in splits]))
        self.train, self.screen = fit.subset(rows), fit.subset(evenly_spaced(rows, SCREENING_SAMPLES))
        self.folds = [(fit.subset(tr), fit.subset(evenly_spaced(tr, SCREENING_SAMPLES)), fit.subset(te))
                      for tr, te in splits]
        # the judged rows' groups, in the order errors() returns them
        self.judged_groups = None if groups is None else np.unique(
            np.concatenate([groups[te] for _, te in splits]), return_inverse=True)[1]

    def settle(self, science, theta) -> None:
        """With fitted initial states: later fits start from the states that fit this model."""
        for part in [self.train, self.screen, *(f for fold in self.folds for f in fold)]:
            part.settle(science, theta)

    def fit(self, science, start, bounds=None, screening=False) -> dict:
        """The parameters fitted on the training (or, ``screening``, the screening) rows."""
        return _fit_on(self.screen if screening else self.train, science, start, bounds, screening)

    def training_error(self, science, theta) -> float:
        """Mean squared error on the screening rows, from the states the screening fit holds."""
        with np.errstate(all="ignore"):
            error = float(np.mean((self.screen.predict(science, theta) - self.screen.y) ** 2))
        return error if np.isfinite(error) else np.inf

    def errors(self, science, theta, bounds=None, screening=False) -> np.ndarray:
        """Held-out errors, one per judged sample (or group); with folds, each from a refit without it."""
        if len(self.folds) == 1:  # the validation rows were not fitted: no refit needed
            errors = self.folds[0][2].errors(science, theta)
        else:
            errors = np.concatenate([test.errors(science, _fit_on(screen if screening else train, science,
                                                                  theta, bounds, screening))
                                     for train, screen, test in self.folds])
        return group_means(errors, self.judged_groups)


# What a candidate's refit raises when the term breaks the simulation or least squares: the candidate failed.
FIT_FAILURES = (RuntimeError, ValueError, FloatingPointError)


def _fit_on(fit: ScienceFit, science, start, bounds, screening) -> dict:
    if screening:  # fewer evaluations, and fitted initial states held where the current model put them
        return fit.fit(science, start, bounds, max_nfev=SCREENING_NFEV, fit_states=False)
    return fit.fit(science, start, bounds)


def training_folds(fit: ScienceFit, splits, groups, folds: int | None) -> Judge | None:
    """The judge of a second look: ``folds`` contiguous folds of one split's training samples (or
    groups), fewer where there are not two to a fold; None with several splits (every sample
    judges already) or without ``folds``."""
    if folds is None or len(splits) != 1:
        return None
    train = splits[0][0]
    local = None if groups is None else groups[train]
    n = len(train) if local is None else len(np.unique(local))
    if min(folds, n // 2) < 2:
        return None
    inner, _ = held_out_splits(len(train), 0.25, min(folds, n // 2), local)
    return Judge(fit, [(train[a], train[b]) for a, b in inner], groups)


def evenly_spaced(rows: np.ndarray, n: int) -> np.ndarray:
    """At most ``n`` of ``rows``, evenly spaced (windows of one record: every part of it)."""
    return rows if len(rows) <= n else rows[np.unique(np.linspace(0, len(rows) - 1, n).round().astype(int))]


def judge_terms(estimator, X, y, terms: Sequence[dict], variables: Sequence[str], n_states: int, *,
                validation_fraction: float = 0.25, z: float = 3.0, min_gain: float = 0.05) -> list[dict]:
    """Each of ``terms`` judged as :func:`~sklearn_hybrid.diagnosis.close_the_loop` judges a term.

    The terms are tried one at a time, in the order given, each added to the science model with
    the terms kept before it; the model is refitted without the network on the training samples
    and kept only when its held-out error is lower by ``min_gain`` and by more than ``z``
    standard errors (:func:`~sklearn_hybrid.diagnosis.evidence`). A term that a network trained
    on noise carries passes no such test: the complete science refitted alone predicts as well.

    Parameters
    ----------
    estimator : fitted HybridRegressor
        Supplies the science function, theta and the data layout.
    X, y : array-like
        Its data, as for its ``fit``; the last ``validation_fraction`` of the samples judge.
    terms : list of dict
        Each with ``component``, ``term`` and ``coef`` (as ``ResidualDiagnosis.new_terms_``).
    variables : list of str
        Names of the states, then the inputs (the terms' variables).
    n_states : int
        Number of state columns.
    validation_fraction, z, min_gain : float
        The split and the evidence asked for (as in ``close_the_loop``).

    Returns
    -------
    list of dict
        Per term, in the order given: :func:`evidence`'s verdict (``gain``, ``z``,
        ``threshold``, ``accepted``), or ``failed`` with the reason where the refit failed.
    """
    splits, _ = held_out_splits(len(y), validation_fraction)
    judge = Judge(ScienceFit(estimator, X, y), splits)
    science, original = estimator.science, list(estimator.theta_)
    theta = judge.fit(science, estimator.theta_)
    errors = judge.errors(science, theta)
    kept: list[dict] = []
    verdicts = []
    for term in terms:
        placed = kept + [dict(term)]
        try:
            candidate = augment_science(science, placed, variables, n_states=n_states,
                                        theta={k: theta[k] for k in original})
            start = {**read_signature(candidate)[1], **{k: theta[k] for k in original}}
            fitted = judge.fit(candidate, start)
            after = judge.errors(candidate, fitted)
        except FIT_FAILURES as exc:  # a term that breaks the simulation is not supported
            verdicts.append({"accepted": False, "failed": repr(exc)})
            continue
        verdict = evidence(errors, after, z=z, min_gain=min_gain)
        verdicts.append(verdict)
        if verdict["accepted"]:
            kept = [{**t, "coef": float(fitted[param])} for t, (_, _, param) in zip(placed, candidate.terms)]
            theta, errors = fitted, after
    return verdicts
