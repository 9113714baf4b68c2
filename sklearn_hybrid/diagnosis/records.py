"""Measured records beyond the training windows: free runs of a fitted hybrid ODE over a whole
test record (usually longer than the training windows) and the record's initial state fitted to
its first samples; the recipes score Silverbox, tanks and the real pendulum with them.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
from scipy.optimize import least_squares
from sklearn.utils.validation import check_is_fitted

__all__ = ["free_run", "fit_initial_state"]


def free_run(estimator: Any, x0: np.ndarray, u: np.ndarray | None = None, n_steps: int | None = None,
             use_residual: bool | np.ndarray = True) -> np.ndarray:
    """Simulate a fitted hybrid ODE from ``x0`` over any number of output steps.

    A shorthand of :meth:`HybridRegressor.simulate <sklearn_hybrid.HybridRegressor.simulate>`
    that also accepts one record's inputs as ``(n_steps + 1,)`` or ``(n_steps + 1, n_inputs)``.

    Parameters
    ----------
    estimator : fitted HybridRegressor with structure ``"ode"``
    x0 : ndarray of shape (n, n_states) or (n_states,)
        Initial states.
    u : ndarray of shape (n, n_steps + 1, n_inputs) or (n_steps + 1,), optional
        Inputs on the output grid (forced systems); fixes ``n_steps``.
    n_steps : int, optional
        Number of outputs (autonomous systems).
    use_residual : bool or array of bool of shape (n,), default=True
        False simulates the science part alone; one flag per initial state mixes both in one batch.

    Returns
    -------
    ndarray of shape (n, n_steps + 1, n_states)
        States at times 0, dt, ..., n_steps dt (all components, observed or not).
    """
    check_is_fitted(estimator, "model_")
    x0 = np.atleast_2d(np.asarray(x0, dtype=float))
    if u is not None:  # the shorthands of a single record: (n_steps + 1,) or (n_steps + 1, n_inputs)
        u = np.asarray(u, dtype=float)
        u = u.reshape(1, -1, 1) if u.ndim == 1 else (u[None] if u.ndim == 2 and len(x0) == 1 else u)
    return estimator.simulate(x0, None if u is not None else n_steps, u=u, use_residual=use_residual)


def fit_initial_state(estimator: Any, y_head: np.ndarray, x0_guess: np.ndarray, u_head: np.ndarray | None = None,
                      observed: Sequence[int] | None = None, use_residual: bool = True,
                      free: Sequence[int] | None = None) -> np.ndarray:
    """Initial state that best reproduces the first samples of a record (least squares).

    Parameters
    ----------
    estimator : fitted HybridRegressor with structure ``"ode"``
    y_head : ndarray of shape (n_head,) or (n_head, n_observed)
        The record's first observations, at times 0, dt, ...
    x0_guess : ndarray of shape (n_states,)
        Starting point (e.g. the observation and a finite-difference derivative).
    u_head : ndarray of shape (n_head,) or (n_head, n_inputs), optional
        Inputs over the same samples.
    observed : list of int, optional
        State components observed in ``y_head``; default the estimator's.
    use_residual : bool, default=True
        Simulate with the network (False: science part alone).
    free : list of int, optional
        Components to estimate (default all); the others keep ``x0_guess``.

    Returns
    -------
    ndarray of shape (n_states,)
    """
    observed = list(observed if observed is not None else (estimator.observed or range(len(x0_guess))))
    y_head = np.asarray(y_head, float).reshape(len(y_head), -1)
    guess = np.asarray(x0_guess, float)
    free = list(range(len(guess))) if free is None else list(free)
    u = None if u_head is None else np.asarray(u_head, float).reshape(1, len(y_head), -1)

    def resid(z):
        x0 = guess.copy()
        x0[free] = z
        states = free_run(estimator, x0, u=u, n_steps=len(y_head) - 1, use_residual=use_residual)[0]
        return (states[:, observed] - y_head).ravel()

    scale = np.maximum(np.abs(guess[free]), 1e-3)
    # Steps of 1e-3 (relative): the simulation may run in float32, too coarse for the default.
    return _put(guess, free, least_squares(resid, guess[free], x_scale=scale, diff_step=1e-3).x)


def _put(x: np.ndarray, idx: list[int], values: np.ndarray) -> np.ndarray:
    out = x.copy()
    out[idx] = values
    return out
