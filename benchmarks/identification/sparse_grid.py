"""The threshold grid of the sparse regressions and its cross-validated choice.

``bench_sparse_regression.py`` measures pysindy's optimizers with them against our ``SparseTermRegression``;
``bench_anchors_loop.py`` chooses pysindy's threshold the same way in its UDE + SINDy anchor.
"""

from __future__ import annotations

import numpy as np
from sklearn.model_selection import KFold

GRID = np.logspace(-3, 0, 16)  # thresholds relative to RMS(r), on unit-RMS columns


def cv_choice(make, Xs: np.ndarray, r: np.ndarray, values: np.ndarray, one_se: bool) -> float:
    """Grid value by 5-fold CV error (shuffled folds: the rows are independent draws)."""
    errors = np.zeros((len(values), 5))
    for f, (train, test) in enumerate(KFold(5, shuffle=True, random_state=0).split(Xs)):
        for i, v in enumerate(values):
            coef = make(v).fit(Xs[train], r[train]).coef_.ravel()
            errors[i, f] = np.mean((r[test] - Xs[test] @ coef) ** 2)
    mean, se = errors.mean(axis=1), errors.std(axis=1, ddof=1) / np.sqrt(5)
    best = int(np.argmin(mean))
    if not one_se:
        return values[best]
    return values[max(i for i in range(len(values)) if mean[i] <= mean[best] + se[best])]  # largest = sparsest
