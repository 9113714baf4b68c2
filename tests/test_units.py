"""When units are the problem, the errors say so: a theta that diverged is named (not the science function, which
a NaN theta makes return NaN), and the advice after a training that went bad prints the data's scales."""

import warnings

import numpy as np
import pytest
import torch
from sklearn.exceptions import ConvergenceWarning

from sklearn_hybrid import HybridRegressor
from sklearn_hybrid.integrate import integrate
from sklearn_hybrid.training.engine import DivergenceError


def decay_f(v, k=0.3):
    """A first-order decay of two states into each other: k per time unit."""
    return torch.stack([-k * v[:, 0] + 0.2 * k * v[:, 1], k * v[:, 0] - k * v[:, 1]], dim=-1)


def _data(T=1.0, S=1.0, n=12, n_steps=10, dt=0.3):
    """Trajectories of dv/dt = decay at k = 0.5 minus a missing -0.4 v0^2, in units time x T, states x S."""
    rng = np.random.default_rng(0)
    X = rng.uniform(0.5, 1.5, size=(n, 2))

    def rhs(v, u=None):
        return decay_f(v, k=0.5) - 0.4 * torch.stack([v[:, 0] ** 2, 0 * v[:, 1]], dim=-1)

    with torch.no_grad():
        y = integrate(rhs, torch.as_tensor(X), n_steps, dt, n_substeps=8).numpy()
    y = y + 0.01 * rng.standard_normal(y.shape)
    return (X * S).astype(np.float32), (y * S).astype(np.float32), dt * T


def test_a_theta_that_diverges_is_named_not_the_science():
    """A theta thrown to 1e35 makes any science return NaN: the error says theta diverged, from where, and
    prints the data's scales."""
    X, y, dt = _data()
    with pytest.raises(DivergenceError) as info:
        HybridRegressor(science=decay_f, dt=dt, random_state=0, lr_theta=1e37, max_iter=50, tol=None).fit(X, y)
    message = str(info.value)
    assert "theta diverged: k became" in message and "from {'k': 0.3" in message
    assert "the science function is not the cause" in message and "returned [nan" not in message
    assert "The data's scales: state spread 0.292, 0.258; horizon 3 time units" in message


def test_a_divergence_without_dt_says_dt_was_not_given():
    X, y, _ = _data()
    with pytest.warns(UserWarning, match="dt was not given"), pytest.raises(DivergenceError) as info:
        HybridRegressor(science=decay_f, random_state=0, lr_theta=1e37, max_iter=50, tol=None).fit(X, y)
    assert "dt was not given, so one time unit was taken between outputs" in str(info.value)


def test_a_fit_that_is_not_usable_prints_the_data_scales():
    X, y, dt = _data()
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        HybridRegressor(science=decay_f, dt=dt, random_state=0, lr=1e-12, max_iter=30, tol=None).fit(X, y)
    messages = [str(w.message) for w in caught if issubclass(w.category, ConvergenceWarning)]
    assert messages and "The data's scales: state spread" in messages[0], messages
