"""Support selection behind :class:`~sklearn_hybrid.diagnosis.SparseTermRegression`.

Candidate supports come from the lasso path (LARS) and from backward elimination of the full
least-squares fit; one is chosen by an information criterion or K-fold CV and negligible terms are
pruned. Everything is computed from Gram matrices (:func:`support_stats`), so a bootstrap resample
(integer row weights) or a fold costs a few small matrix products, not a pass over the data.
"""

from __future__ import annotations

import warnings
from itertools import combinations
from math import factorial
from typing import NamedTuple

import numpy as np
from scipy.linalg import cho_factor, cho_solve
from scipy.special import gammaln
from sklearn.linear_model import lars_path_gram

_EXACT_FIT = 1e-10  # RSS below this fraction of sum(r^2) counts as an exact fit (round-off level)
_MAX_SHAPLEY = 10  # exact Shapley shares up to this many terms (2^k least-squares fits)


class _Stats(NamedTuple):
    """Weighted sufficient statistics: Gram matrix, cross-products, sum of squares, sample count."""

    G: np.ndarray  # (p, p)
    B: np.ndarray  # (p, m)
    yy: np.ndarray  # (m,)
    n: float

    def __sub__(self, other: "_Stats") -> "_Stats":
        return _Stats(self.G - other.G, self.B - other.B, self.yy - other.yy, self.n - other.n)


def support_stats(X: np.ndarray, Y: np.ndarray, w: np.ndarray) -> _Stats:
    Xw = X * w[:, None]
    return _Stats(X.T @ Xw, Xw.T @ Y, (w[:, None] * Y**2).sum(axis=0), float(w.sum()))


def _ls(G: np.ndarray, b: np.ndarray, S: tuple[int, ...]) -> np.ndarray:
    """Least-squares coefficients on support ``S`` from the normal equations (robust to collinearity)."""
    if not S:
        return np.zeros(0)
    idx = list(S)
    A = G[np.ix_(idx, idx)]
    try:
        # Cholesky is ~10x faster than an SVD; the tiny jitter only matters for collinear supports.
        return cho_solve(cho_factor(A + 1e-12 * np.trace(A) / len(idx) * np.eye(len(idx)), check_finite=False),
                         b[idx], check_finite=False)
    except np.linalg.LinAlgError:
        return np.linalg.lstsq(A, b[idx], rcond=1e-12)[0]


def _rss(G: np.ndarray, b: np.ndarray, yy: float, S: tuple[int, ...]) -> float:
    return max(yy - float(_ls(G, b, S) @ b[list(S)]), 0.0) if S else yy


def _drop_costs(G: np.ndarray, b: np.ndarray, S: tuple[int, ...]) -> np.ndarray:
    """RSS increase when each term of ``S`` is removed and the rest refitted: beta_j^2 / (G_S^-1)_jj."""
    idx = list(S)
    inv = np.linalg.pinv(G[np.ix_(idx, idx)], hermitian=True)
    return (inv @ b[idx]) ** 2 / np.maximum(np.diag(inv), 1e-300)


def _candidate_supports(G: np.ndarray, b: np.ndarray, n: float, max_terms: int | None) -> list[tuple]:
    """Supports visited by the lasso path and by backward elimination, plus the empty one."""
    p = G.shape[0]
    supports = {()}
    with warnings.catch_warnings():
        # LARS warns when collinear terms enter together; the path is still a valid candidate list.
        warnings.simplefilter("ignore")
        _, _, coefs = lars_path_gram(b.copy(), G.copy(), n_samples=int(round(n)), method="lasso",
                                     max_iter=4 * p)
    for column in np.atleast_2d(coefs.T):
        supports.add(tuple(np.flatnonzero(column)))
    S = tuple(range(p))
    while S:
        supports.add(S)
        weakest = int(np.argmin(_drop_costs(G, b, S)))
        S = S[:weakest] + S[weakest + 1:]
    ordered = sorted(supports, key=lambda s: (len(s), s))
    return [s for s in ordered if max_terms is None or len(s) <= max_terms]


def support_shares(G: np.ndarray, b: np.ndarray, yy: float, S: tuple[int, ...]) -> np.ndarray:
    """Fraction of ``sum(r^2)`` each term of ``S`` explains; they add up to the support's R^2.

    Exact Shapley values (the LMG decomposition) for up to ``_MAX_SHAPLEY`` terms, otherwise Pratt's
    product measure ``beta_j * b_j / yy``, which also adds up to R^2 but can be negative.
    """
    k = len(S)
    if k == 0 or yy <= 0:
        return np.zeros(k)
    if k > _MAX_SHAPLEY:
        return _ls(G, b, S) * b[list(S)] / yy
    r2 = {}
    for size in range(k + 1):
        for sub in combinations(range(k), size):
            r2[sub] = 1.0 - _rss(G, b, yy, tuple(S[i] for i in sub)) / yy
    shares = np.zeros(k)
    for sub, value in r2.items():
        weight = factorial(len(sub)) * factorial(k - len(sub) - 1) / factorial(k) if len(sub) < k else 0.0
        for j in set(range(k)) - set(sub):
            shares[j] += weight * (r2[tuple(sorted(sub + (j,)))] - value)
    return shares


def _score_cv(total: _Stats, folds: list[_Stats], j: int, candidates: list[tuple]) -> int:
    """Index of the candidate chosen by K-fold CV with the one-standard-error rule."""
    errors = np.zeros((len(candidates), len(folds)))
    for f, fold in enumerate(folds):
        train = total - fold
        for c, S in enumerate(candidates):
            idx = list(S)
            beta = _ls(train.G, train.B[:, j], S)
            sse = fold.yy[j] - 2 * beta @ fold.B[idx, j] + beta @ fold.G[np.ix_(idx, idx)] @ beta
            errors[c, f] = max(sse, 0.0) / fold.n
    mean = errors.mean(axis=1)
    se = errors.std(axis=1, ddof=1) / np.sqrt(len(folds)) if len(folds) > 1 else np.zeros(len(mean))
    best = int(np.argmin(mean))
    # Candidates are sorted by size, so the first one within one SE of the best is the sparsest.
    return int(np.flatnonzero(mean <= mean[best] + se[best])[0])


def _penalty(criterion: str, k: int, n: float, p: int) -> float:
    """Complexity penalty of a k-term support out of p candidates.

    The extended BIC (Chen & Chen, 2008, gamma=1) adds 2 log C(p, k): the support is searched among
    many candidates, and plain BIC then too often admits a term that merely fits the noise.
    """
    if criterion == "aic":
        return 2.0 * k
    if criterion == "bic":
        return k * np.log(n)
    return k * np.log(n) + 2.0 * (gammaln(p + 1) - gammaln(k + 1) - gammaln(p - k + 1))


def select_support(total: _Stats, folds: list[_Stats], j: int, params: dict) -> tuple[int, ...]:
    """Support chosen for output ``j``: criterion over the candidate supports, then relevance pruning."""
    G, b, yy, n = total.G, total.B[:, j], float(total.yy[j]), total.n
    if yy <= 0:
        return ()
    candidates = _candidate_supports(G, b, n, params["max_terms"])
    if params["criterion"] == "cv":
        S = candidates[_score_cv(total, folds, j, candidates)]
    else:
        scores = [n * np.log(max(_rss(G, b, yy, S), _EXACT_FIT * yy) / n)
                  + _penalty(params["criterion"], len(S), n, len(b)) for S in candidates]
        S = candidates[int(np.argmin(scores))]
    # A statistically detectable term can still be physically negligible (the network's residual is
    # nearly noise-free, so tiny systematic errors are "significant"). Drop, one at a time, the term
    # whose removal (refitting the others) loses the least, while that loss is below min_explained.
    # The unique loss, not the Shapley share, is used: a collinear copy of a true term has a large
    # share but no unique contribution.
    while S:
        losses = _drop_costs(G, b, S)
        weakest = int(np.argmin(losses))
        if losses[weakest] >= params["min_explained"] * yy:
            break
        S = S[:weakest] + S[weakest + 1:]
    return S
