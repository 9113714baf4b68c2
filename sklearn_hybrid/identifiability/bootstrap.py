"""The bootstrap over samples together with seeds: fits of the same hybrid model on resampled data.

Each member is a fresh fit (a new seed for the network's start and the
mini-batches) on the samples drawn with replacement (a sample drawn twice
weighs 2 in the loss), all trained as one stacked model.  Their spread holds
what a single fit's standard error cannot see: the network trading with theta
differently from one training run and one data set to the next.  It does not
hold the bias of a regulariser that picks the same wrong value every time:
:func:`~sklearn_hybrid.identifiability.profile_theta` says whether the data
pin theta at all.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy import stats
from sklearn.base import clone

from ..training.stacked import train_members
from .._fitting import prepare_fit
from .._validation import check_n_jobs, torch_threads
from ._members import check_level, entry_values, fitted_problem, member_config, parameter_entries

__all__ = ["bootstrap_theta", "ThetaBootstrap"]


@dataclass
class ThetaBootstrap:
    """Theta of fits on resampled data with new seeds.

    Attributes
    ----------
    estimate : dict of str to float
        The fitted estimator's value of each entry (``name`` or ``name[k]``).
    samples : dict of str to ndarray
        Each member's value (NaN for a member whose training diverged).
    std : dict of str to float
        Standard deviation across the members.
    intervals : dict of str to tuple
        ``estimate +/- t * std`` (Student's t at ``level`` with members - 1 degrees of freedom).
    seeds : list of int
        Each member's ``random_state``.
    weights : ndarray of shape (n_resamples, n_samples)
        Each member's resample, as sample weights (how often each sample was drawn): member ``i`` is
        the fit ``clone(estimator).set_params(random_state=seeds[i]).fit(X, y, sample_weight=weights[i])``.
    """

    estimate: dict
    samples: dict
    std: dict
    intervals: dict
    level: float
    n_iter: int
    seeds: list = field(default_factory=list)
    weights: np.ndarray | None = None

    def report(self) -> str:
        n = len(next(iter(self.samples.values())))
        lines = [f"[[Bootstrap]]  ({n} fits on resampled samples with new seeds, {self.n_iter} iterations each)"]
        for label, (low, high) in self.intervals.items():
            lines.append(f"    {label}: {self.estimate[label]:.5g} +/- {self.std[label]:.3g} (spread), "
                         f"{100 * self.level:.0f} % interval [{low:.5g}, {high:.5g}]")
        return "\n".join(lines)

    def __str__(self) -> str:
        return self.report()


def bootstrap_theta(estimator, X, y, params=None, *, n_resamples=20, level=0.95, max_iter=None,
                    random_state=0, n_jobs=None, verbose="auto") -> ThetaBootstrap:
    """Refit a hybrid model on resampled samples with new seeds, as one stacked training.

    Parameters
    ----------
    estimator : HybridRegressor
        A fitted estimator (any stackable method).
    X, y : array-like
        The data it was fitted on.
    params : str or list of str, optional
        Parameters to report (default all free ones).
    n_resamples : int, default=20
        Number of members.
    level : float, default=0.95
        Confidence level of the intervals.
    max_iter : int, optional
        Iterations of every member (default: those of the fit, ``n_iter_``).
    random_state : int, default=0
        Seeds the resampling and the members' seeds.
    n_jobs : int, optional
        Train the members in this many worker processes (joblib, Dask-ready).
    verbose : bool or "auto", default="auto"
        A progress bar over the members' iterations: ``"auto"`` once they
        have trained 5 seconds, in a terminal or a notebook (as a fit's).

    Returns
    -------
    ThetaBootstrap
    """
    level = check_level(level)
    n_jobs = check_n_jobs(n_jobs)
    if not (isinstance(n_resamples, (int, np.integer)) and not isinstance(n_resamples, bool) and n_resamples >= 2):
        raise ValueError(f"n_resamples must be an integer of at least 2, got {n_resamples!r}.")
    problem = fitted_problem(estimator, X, y)
    entries = parameter_entries(problem.model.science, params)
    config = member_config(problem.fit, estimator.n_iter_ if max_iter is None else max_iter, None, verbose)
    rng = np.random.default_rng(random_state)
    seeds = [int(s) for s in rng.integers(0, 2**31 - 1, n_resamples)]
    n = problem.n_samples
    weights = rng.multinomial(n, np.full(n, 1 / n), size=n_resamples).astype(float)
    template = clone(estimator).set_params(**{k: v for k, v in problem.fit.items() if k != "random_state"})
    X_arr, y_arr = np.asarray(X), np.asarray(y)
    # each member in the scales of its own resample, as a fit of it alone would be
    setups = [prepare_fit(clone(template).set_params(random_state=s), X_arr, y_arr, w) for s, w in zip(seeds, weights)]
    n_threads = estimator.n_threads if n_jobs == 1 else 1
    with torch_threads(n_threads):
        history, models = train_members([s.model for s in setups], problem.method, setups[0].inputs, setups[0].y,
                                        config, seeds, sample_weight=weights, n_jobs=n_jobs, n_threads=n_threads)
    ok = history["diverged_at"] < 0
    t = stats.t.ppf(0.5 + level / 2, max(int(ok.sum()) - 1, 1))
    out = ThetaBootstrap(estimate={}, samples={}, std={}, intervals={}, level=level, n_iter=config.max_iter,
                         seeds=seeds, weights=weights)
    for name, k, label in entries:
        values = np.array([entry_values(m.science, name)[k] for m in models])
        values[~ok] = np.nan
        centre = float(np.ravel(estimator.theta_[name])[k])
        spread = float(np.nanstd(values, ddof=1)) if ok.sum() > 1 else float("nan")
        out.estimate[label], out.samples[label], out.std[label] = centre, values, spread
        out.intervals[label] = (centre - t * spread, centre + t * spread)
    return out
