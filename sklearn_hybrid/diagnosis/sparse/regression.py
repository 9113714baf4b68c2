"""Sparse regression of a residual onto named candidate terms.

:class:`SparseTermRegression` explains each residual component as a short sum of named terms.
Candidate supports come from the lasso path (LARS) and from backward elimination of the full
least-squares fit; the support is chosen among them by an information criterion or K-fold CV,
negligible terms are pruned, and the coefficients are refitted by ordinary least squares (no
shrinkage). A bootstrap repeats the whole selection to give each term an inclusion frequency.
Supports are scored from Gram matrices, so a resample (integer row weights) or a fold is cheap
(the selection itself: ``diagnosis/supports.py``).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
from sklearn.base import BaseEstimator, RegressorMixin
from sklearn.linear_model import LinearRegression
from sklearn.utils import check_random_state
from sklearn.utils.validation import check_is_fitted, validate_data
from threadpoolctl import threadpool_limits

from ..supports import select_support, support_shares, support_stats
from ..terms import Term

__all__ = ["SparseTermRegression"]

_CRITERIA = ("ebic", "bic", "aic", "cv")


class SparseTermRegression(RegressorMixin, BaseEstimator):
    """Explain a residual as a sparse, readable combination of named candidate terms.

    Parameters
    ----------
    criterion : {"ebic", "bic", "aic", "cv"}, default="ebic"
        How the support is chosen among the candidate supports (lasso path and backward elimination):
        an information criterion of the least-squares refit (extended BIC, which also pays for the
        number of candidate terms and so rarely admits noise; BIC; AIC), or contiguous K-fold
        cross-validation of the refit with the one-standard-error rule.
    max_terms : int, default=None
        Largest number of terms per output; ``None`` for no limit.
    min_explained : float, default=0.01
        Relevance floor applied after the criterion: while some selected term's removal (refitting the
        others) would lose less than this fraction of ``sum(r**2)``, the least useful one is dropped.
        ``0`` keeps whatever the criterion chose.
    n_bootstrap : int, default=50
        Number of bootstrap resamples (rows drawn with replacement) for ``inclusion_frequency_``;
        ``0`` skips the bootstrap.
    cv : int, default=5
        Number of contiguous folds when ``criterion="cv"``.
    random_state : int, RandomState instance or None, default=None
        Seeds the bootstrap; None draws from numpy's global RNG, as in scikit-learn.

    Attributes
    ----------
    coef_ : ndarray of shape (n_outputs, n_terms)
        Least-squares coefficients on the selected terms, zero elsewhere.
    support_ : ndarray of bool, shape (n_outputs, n_terms)
        Selected terms.
    inclusion_frequency_ : ndarray of shape (n_outputs, n_terms)
        Fraction of bootstrap resamples in which each term was selected (NaN if ``n_bootstrap=0``).
    explained_fraction_ : ndarray of shape (n_outputs, n_terms)
        Share of each output's mean square ``mean(r**2)`` explained by each selected term (exact
        Shapley decomposition of R^2 up to 10 selected terms, Pratt's ``beta_j * mean(theta_j r) /
        mean(r**2)`` beyond; zero for unselected terms). The reference is zero, not the mean, because
        the aim is to remove the residual entirely; a constant offset is the term ``"1"``.
    r2_ : ndarray of shape (n_outputs,)
        Total explained share ``1 - sum((r - r_hat)**2) / sum(r**2)`` per output on the fitted data
        (uncentred; :meth:`score` is scikit-learn's usual centred R^2, averaged over outputs).
    term_names_ : ndarray of str, shape (n_terms,)
        Names of the candidate terms.
    term_units_ : ndarray of str or None
        Units of the candidate terms, if given.
    output_names_ : ndarray of str, shape (n_outputs,)
        Names of the outputs (default ``g[0], g[1], ...``).
    n_features_in_ : int
        Number of candidate terms seen in :meth:`fit`.
    n_outputs_ : int
        Number of residual components.
    """

    def __init__(self, criterion: str = "ebic", max_terms: int | None = None, min_explained: float = 0.01,
                 n_bootstrap: int = 50, cv: int = 5, random_state: Any = None) -> None:
        self.criterion = criterion
        self.max_terms = max_terms
        self.min_explained = min_explained
        self.n_bootstrap = n_bootstrap
        self.cv = cv
        self.random_state = random_state

    def fit(
        self,
        X: Any,
        y: Any,
        feature_names: Sequence[str] | None = None,
        *,
        term_units: Sequence[str] | None = None,
        output_names: Sequence[str] | None = None,
    ) -> "SparseTermRegression":
        """Select and fit the terms that explain each residual component.

        Parameters
        ----------
        X : array-like of shape (n_samples, n_terms)
            Candidate terms ``Theta`` evaluated on the visited states (``CandidateLibrary.transform``).
        y : array-like of shape (n_samples,) or (n_samples, n_outputs)
            Residual ``r``, one column per component.
        feature_names : list of str or of Term, default=None
            Names of the terms; defaults to a DataFrame's columns, else ``theta0, theta1, ...``.
            The library's terms themselves (``CandidateLibrary.terms_``) give the names and the units.
        term_units : list of str, default=None
            Units of the terms (``CandidateLibrary.term_units_``), shown in :meth:`equations`.
        output_names : list of str, default=None
            Names of the residual components, default ``g[0], g[1], ...``.

        Returns
        -------
        self : SparseTermRegression
        """
        self._check_params()
        Theta, r = validate_data(self, X, y, multi_output=True, y_numeric=True, dtype=np.float64)
        n, p = Theta.shape
        self._single_output = r.ndim == 1
        R = r.reshape(n, -1)
        m = R.shape[1]
        if self.criterion == "cv" and n < self.cv:
            raise ValueError(f"criterion='cv' with cv={self.cv} needs at least {self.cv} samples, got n_samples={n}.")
        names = feature_names if feature_names is not None else getattr(self, "feature_names_in_", None)
        if names is not None and not isinstance(names, str) and all(isinstance(t, Term) for t in names):
            term_units = [t.unit or "1" for t in names] if term_units is None else term_units
            names = [t.name for t in names]
        self.term_names_ = _names(names, p, "theta", "feature_names")
        self.term_units_ = None if term_units is None else _names(term_units, p, "", "term_units", unique=False)
        self.output_names_ = _names(output_names, m, "g", "output_names", brackets=True)
        self.n_outputs_ = m

        # Unit-RMS columns make the lasso path and the conditioning independent of the terms' units.
        scale = np.sqrt(np.mean(Theta**2, axis=0))
        usable = np.flatnonzero(scale > 0)  # an identically-zero term cannot be identified
        Xs = Theta[:, usable] / scale[usable]
        fold_of = np.arange(n) * self.cv // n if self.criterion == "cv" else None
        # Hundreds of tiny solves: BLAS threads only add overhead (and stall on a busy machine).
        with threadpool_limits(limits=1, user_api="blas"):
            supports = self._select_all(Xs, R, np.ones(n), fold_of)
            total = support_stats(Xs, R, np.ones(n))
            self.coef_, self.explained_fraction_ = np.zeros((m, p)), np.zeros((m, p))
            self.support_ = np.zeros((m, p), dtype=bool)
            for j, S in enumerate(supports):
                cols = usable[list(S)]
                self.support_[j, cols] = True
                if S:  # the unbiased refit, on the unit-RMS columns too: LinearRegression's rank cut-off
                    # would drop a column a million times smaller than another (x in mm beside v in m/s)
                    refit = LinearRegression(fit_intercept=False).fit(Xs[:, list(S)], R[:, j])
                    self.coef_[j, cols] = refit.coef_ / scale[cols]
                    self.explained_fraction_[j, cols] = support_shares(total.G, total.B[:, j], float(total.yy[j]), S)
            fitted = Theta @ self.coef_.T
            yy = np.sum(R**2, axis=0)
            self.r2_ = np.where(yy > 0, 1.0 - np.sum((R - fitted) ** 2, axis=0) / np.where(yy > 0, yy, 1.0), 0.0)

            self.inclusion_frequency_ = np.full((m, p), np.nan)
            if self.n_bootstrap:
                rng = check_random_state(self.random_state)
                counts = np.zeros((m, p))
                for _ in range(self.n_bootstrap):
                    w = np.bincount(rng.randint(n, size=n), minlength=n).astype(np.float64)
                    for j, S in enumerate(self._select_all(Xs, R, w, fold_of)):
                        counts[j, usable[list(S)]] += 1
                self.inclusion_frequency_ = counts / self.n_bootstrap
        self._plot_data = (R, fitted)
        return self

    def __sklearn_tags__(self):
        tags = super().__sklearn_tags__()
        tags.target_tags.multi_output = True  # one column per residual component
        return tags

    def _select_all(self, Xs: np.ndarray, R: np.ndarray, w: np.ndarray, fold_of: np.ndarray | None) -> list[tuple]:
        """Selected support (indices into ``Xs``'s columns) of every output, rows weighted by ``w``."""
        folds = []
        if fold_of is not None:
            folds = [support_stats(Xs[fold_of == f], R[fold_of == f], w[fold_of == f]) for f in np.unique(fold_of)]
            folds = [f for f in folds if f.n > 0]
        total = support_stats(Xs, R, w)
        params = {"criterion": self.criterion, "max_terms": self.max_terms, "min_explained": self.min_explained}
        return [select_support(total, folds, j, params) for j in range(R.shape[1])]

    def predict(self, X: Any) -> np.ndarray:
        """Residual predicted by the sparse model.

        Parameters
        ----------
        X : array-like of shape (n_samples, n_terms)
            Candidate terms ``Theta``, columns as in :meth:`fit`.

        Returns
        -------
        r_hat : ndarray of shape (n_samples,) or (n_samples, n_outputs)
        """
        check_is_fitted(self, "coef_")
        out = validate_data(self, X, reset=False, dtype=np.float64) @ self.coef_.T
        return out[:, 0] if self._single_output else out

    def equations(self, precision: int = 3) -> list[str]:
        """Readable equations, one per output, e.g. ``"g[1] = -0.498 v_dot"``.

        Parameters
        ----------
        precision : int, default=3
            Significant digits of the coefficients.

        Returns
        -------
        equations : list of str
            Term units, when known, follow each term in brackets.
        """
        check_is_fitted(self, "coef_")
        lines = []
        for j, name in enumerate(self.output_names_):
            parts = []
            for i in np.flatnonzero(self.support_[j]):
                c = self.coef_[j, i]
                term = self.term_names_[i]
                text = f"{abs(c):.{precision}g}" + ("" if term == "1" else f" {term}")
                unit = None if self.term_units_ is None else self.term_units_[i]
                if unit and unit != "1":
                    text += f" [{unit}]"
                parts.append(("- " if c < 0 else "+ ") + text)
            rhs = " ".join(parts) if parts else "0"
            rhs = rhs[2:] if rhs.startswith("+ ") else ("-" + rhs[2:] if rhs.startswith("- ") else rhs)
            lines.append(f"{name} = {rhs}")
        return lines

    def summary(self) -> str:
        """Text table: per output, R^2, then each selected (``*``) or bootstrap-frequent term.

        Returns
        -------
        table : str
        """
        check_is_fitted(self, "coef_")
        width = max(12, *(len(t) for t in self.term_names_)) if len(self.term_names_) else 12
        lines = [f"SparseTermRegression(criterion={self.criterion!r}, n_bootstrap={self.n_bootstrap})"]
        for j, name in enumerate(self.output_names_):
            lines.append(f"{name}: R^2 = {self.r2_[j]:.4f}, {int(self.support_[j].sum())} term(s) selected")
            lines.append(f"  {'term':<{width}} {'coef':>12} {'explained':>10} {'inclusion':>10}")
            freq = self.inclusion_frequency_[j]
            shown = self.support_[j] | (np.nan_to_num(freq) >= 0.1)
            order = sorted(np.flatnonzero(shown), key=lambda i: (-self.explained_fraction_[j, i],
                                                                  -np.nan_to_num(freq[i])))
            for i in order:
                mark = "*" if self.support_[j, i] else " "
                incl = "n/a" if np.isnan(freq[i]) else f"{freq[i]:.2f}"
                lines.append(f"{mark} {self.term_names_[i]:<{width}} {self.coef_[j, i]:>12.4g} "
                             f"{self.explained_fraction_[j, i]:>10.3f} {incl:>10}")
        return "\n".join(lines)

    def plot(self, ax: Any = None) -> np.ndarray:
        """Scatter the residual against the sparse model's prediction, one panel per output.

        Parameters
        ----------
        ax : matplotlib Axes or array of Axes, default=None
            One Axes per output; a new figure when ``None``.

        Returns
        -------
        axes : ndarray of matplotlib Axes
        """
        check_is_fitted(self, "coef_")
        import matplotlib.pyplot as plt  # lazily: matplotlib is an optional dependency

        if ax is None:
            _, ax = plt.subplots(1, self.n_outputs_, figsize=(4 * self.n_outputs_, 4), squeeze=False)
        axes = np.atleast_1d(np.asarray(ax, dtype=object)).ravel()
        if axes.size != self.n_outputs_:
            raise ValueError(f"ax has {axes.size} Axes but the model has {self.n_outputs_} outputs.")
        R, R_hat = self._plot_data
        for j, a in enumerate(axes):
            a.scatter(R_hat[:, j], R[:, j], s=4, alpha=0.5)
            lo, hi = float(min(R[:, j].min(), R_hat[:, j].min())), float(max(R[:, j].max(), R_hat[:, j].max()))
            a.plot([lo, hi], [lo, hi], "k--", lw=1)
            a.set_xlabel(self.equations()[j])
            a.set_ylabel(f"{self.output_names_[j]} (residual)")
            a.set_title(f"R^2 = {self.r2_[j]:.3f}")
        return axes

    def _check_params(self) -> None:
        if self.criterion not in _CRITERIA:
            raise ValueError(f"criterion must be one of {_CRITERIA}, got {self.criterion!r}.")
        if self.max_terms is not None and (not _is_int(self.max_terms) or self.max_terms < 1):
            raise ValueError(f"max_terms must be None or a positive integer, got {self.max_terms!r}.")
        if not (isinstance(self.min_explained, (int, float)) and 0 <= self.min_explained < 1):
            raise ValueError(f"min_explained must be in [0, 1), got {self.min_explained!r}.")
        if not _is_int(self.n_bootstrap) or self.n_bootstrap < 0:
            raise ValueError(f"n_bootstrap must be a non-negative integer, got {self.n_bootstrap!r}.")
        if not _is_int(self.cv) or self.cv < 2:
            raise ValueError(f"cv must be an integer >= 2, got {self.cv!r}.")


def _is_int(value: Any) -> bool:
    return isinstance(value, (int, np.integer)) and not isinstance(value, bool)


def _names(names: Any, size: int, prefix: str, label: str, unique: bool = True, brackets: bool = False) -> np.ndarray:
    """Validate a list of names of the given length, or build default ones."""
    if names is None:
        return np.asarray([f"{prefix}[{i}]" if brackets else f"{prefix}{i}" for i in range(size)], dtype=object)
    names = [names] if isinstance(names, str) else [str(n) if not isinstance(n, str) else n for n in names]
    if len(names) != size:
        raise ValueError(f"{label} has {len(names)} entries; expected {size}.")
    if unique and len(set(names)) != len(names):
        raise ValueError(f"{label} must be unique, got {names}.")
    return np.asarray(names, dtype=object)
