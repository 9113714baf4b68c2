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

from ._fitting import ode_structure

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
        Inputs on the output grid (forced systems); they set ``n_steps``.
    n_steps : int, optional
        Number of outputs; with ``u`` it must agree with the inputs' length (or be left out).
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
    # n_steps goes along with u too: simulate refuses the two when they disagree
    return estimator.simulate(x0, n_steps, u=u, use_residual=use_residual)


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

    Raises
    ------
    ValueError
        For a non-finite guess or record, a ``y_head`` whose width is not the number of observed
        components, ``u_head`` over other samples than ``y_head``, or ``observed`` / ``free``
        indices outside the state.
    """
    guess = np.asarray(x0_guess, float).ravel()
    n_states = len(guess)
    ode = ode_structure(estimator)
    declared = None if ode is None else ode.observed
    observed = _indices("observed", observed if observed is not None else declared, n_states)
    free = _indices("free", free, n_states)
    if not np.all(np.isfinite(guess)):
        raise ValueError(f"x0_guess holds NaN or infinite values: {guess}.")
    y_head = np.asarray(y_head, float)
    y_head = y_head.reshape(len(y_head), -1)
    if y_head.shape[1] != len(observed) or len(y_head) < 2:
        raise ValueError(f"y_head must hold the {len(observed)} observed component(s) {observed} at 2 or more "
                         f"times, shape (n_head, {len(observed)}); got shape {y_head.shape}.")
    if not np.all(np.isfinite(y_head)):
        raise ValueError("y_head holds NaN or infinite values.")
    u = None
    if u_head is not None:
        u = np.asarray(u_head, float)
        if len(u) != len(y_head):
            raise ValueError(f"u_head has {len(u)} samples and y_head {len(y_head)}: give the inputs over the "
                             "same samples.")
        u = u.reshape(1, len(y_head), -1)

    def errors(z):  # the observation errors of one free run per row of z, as one batch
        x0 = np.repeat(guess[None], len(z), axis=0)
        x0[:, free] = z
        inputs = None if u is None else np.repeat(u, len(z), axis=0)
        states = free_run(estimator, x0, u=inputs, n_steps=len(y_head) - 1, use_residual=use_residual)
        return (states[:, :, observed] - y_head).reshape(len(z), -1)

    # Forward differences with steps of 1e-3 of each component's size, or of the record's where the
    # component is near 0: scipy's relative diff_step turns into 1.5e-8 at 0 (an unknown velocity
    # guessed at 0), below what a float32 simulation resolves, and that component never moved.
    typical = max(float(np.abs(guess).max()), float(np.sqrt(np.mean(y_head**2))), 1e-12)

    def jacobian(z):
        steps = 1e-3 * np.maximum(np.abs(z), typical)
        out = errors(np.vstack([z, z + np.diag(steps)]))
        return ((out[1:] - out[0]) / steps[:, None]).T

    fit = least_squares(lambda z: errors(z[None])[0], guess[free], jac=jacobian, x_scale="jac")
    return _put(guess, free, fit.x)


def _indices(name: str, values: Any, n_states: int) -> list[int]:
    """State indices (all of them for None), checked against the number of states."""
    if values is None:
        return list(range(n_states))
    out = np.atleast_1d(np.asarray(values))
    if out.dtype.kind not in "iu" or out.ndim != 1 or len(out) == 0 or out.min() < 0 or out.max() >= n_states:
        raise ValueError(f"{name} must list state indices in [0, {n_states - 1}] (x0_guess has {n_states} "
                         f"states), got {values!r}.")
    return out.tolist()


def _put(x: np.ndarray, idx: list[int], values: np.ndarray) -> np.ndarray:
    out = x.copy()
    out[idx] = values
    return out
