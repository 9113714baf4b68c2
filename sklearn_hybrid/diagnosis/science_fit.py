"""Network-free refits of a science function on a fitted hybrid's data.

:class:`ScienceFit` simulates a science function (no network) on a fitted estimator's data
layout and fits its parameters by least squares (trust-region, bounded), warm-started from given
values: seconds, where retraining the hybrid takes minutes. :mod:`.evidence` judges two such refits
on held-out samples.
"""

from __future__ import annotations

import copy
import math
from collections.abc import Callable, Mapping, Sequence
from types import SimpleNamespace
from typing import Any

import numpy as np
import torch
from scipy import sparse
from scipy.optimize import least_squares

from .._fitting import fitted_data, ode_structure, structure_X
from ..science import read_signature

__all__ = ["ScienceFit", "fits_every_state"]


# The strings fit_initial_states may be, each with what it fits: ScienceFit takes "all", close_the_loop both
EVERY_STATE = {"all": "every initial state, the measured ones too",
               "final": "every initial state, in the final refit only"}


def fits_every_state(fit_initial_states: bool | str, choices: Sequence[str] = ("all",)) -> bool:
    """Whether ``fit_initial_states`` asks for every initial state (one of ``choices``), not the unmeasured ones
    or none.

    Parameters
    ----------
    fit_initial_states : bool or str
        ``ScienceFit``'s and ``close_the_loop``'s option.
    choices : sequence of str, default=("all",)
        The strings the caller takes, keys of ``EVERY_STATE`` (``close_the_loop`` also takes ``"final"``).

    Returns
    -------
    bool
        True for a string of ``choices``, False for True or False.

    Raises
    ------
    ValueError
        For any other string, naming the choices.
    """
    if isinstance(fit_initial_states, str) and fit_initial_states not in choices:
        named = ["True (the unmeasured initial states)"] + [f"'{c}' ({EVERY_STATE[c]})" for c in choices]
        raise ValueError(f"fit_initial_states must be False, {', '.join(named[:-1])} or {named[-1]}, got "
                         f"{fit_initial_states!r}.")
    return isinstance(fit_initial_states, str)


class ScienceFit:
    """Simulate and fit a science function alone, on samples of a fitted hybrid's data.

    Parameters
    ----------
    estimator : fitted HybridRegressor
        Supplies the structure (ODE grid, observed components, inputs), ``theta_bounds`` and
        ``theta_fixed`` (held at the values a fit starts from).
    X, y : array-like
        Samples, as for the estimator's ``fit``.
    fit_initial_states : bool or "all", default=False
        For a partially observed ODE: fit the initial values of the unobserved states of every
        sample (window) too, instead of taking them from ``X``. An estimate of an unobserved
        state made with the science model (a tank level from the balance of the next one) is
        wrong exactly where the science misses something, and would count against the term that
        mends it. ``"all"``: every initial state, measured ones too: a measured initial state
        carries the sensor's noise, and taken as exact it biases theta (errors in variables); fitted,
        each sample's state is read from its whole trajectory. :meth:`errors` then fits them on the
        judged samples too (they are states, not parameters of the model being judged), and
        ``initial_states`` holds the last values.
    n_steps : int, optional
        An ODE's horizon, when ``y`` holds windows shorter than the estimator's fit (default: the
        fit's).
    n_substeps : int, optional
        An ODE's RK4 steps per output interval (default: the fit's), for a model that needs more
        than the science the estimator was fitted with.

    Attributes
    ----------
    diverged : float
        A residual beyond this (1e3 times the RMS of ``y``, at least 1e3) or non-finite marks a
        diverged simulation: a fit sees it at this value, signed, and :meth:`errors` counts the
        sample as infinitely wrong.
    """

    def __init__(self, estimator: Any, X: Any, y: Any, fit_initial_states: bool = False,
                 n_steps: int | None = None, n_substeps: int | None = None) -> None:
        X, _ = fitted_data(estimator, X)
        self.structure = estimator.model_.structure
        if n_steps is not None or n_substeps is not None:  # windows of a long record; a stiffer model
            self.structure = copy.copy(self.structure)
            self.structure.n_steps = self.structure.n_steps if n_steps is None else int(n_steps)
            self.structure.n_substeps = self.structure.n_substeps if n_substeps is None else int(n_substeps)
        self.bounds = dict(estimator.theta_bounds or {})
        self.fixed = set(estimator.theta_fixed or ())  # held at the value a fit starts from
        with torch.no_grad():
            self.inputs = self.structure.tensors(structure_X(estimator, X), torch.float64)
        self.y = np.asarray(y, dtype=float).reshape(len(X), -1)
        self.latent: list[int] = []
        every = fits_every_state(fit_initial_states)
        if fit_initial_states:
            observed = getattr(self.structure, "observed", None)
            vector = ode_structure(estimator) is not None and len(self.structure.state_shape) == 1
            if every and not vector:
                raise ValueError("fit_initial_states='all' needs structure='ode' with a state vector.")
            if not every and (not vector or observed is None):
                raise ValueError("fit_initial_states needs structure='ode' with a state vector and `observed` "
                                 "naming the measured components: only unobserved initial states are fitted.")
            self.latent = [j for j in range(self.structure.state_shape[0]) if every or j not in observed]
        # fitted states whose X is a reading (fit_initial_states="all"): their anchor stays the reading
        self.measured = [j for j in self.latent if every and (observed is None or j in observed)]
        self.initial_states = self.inputs[0].numpy().copy()
        self.anchor = self.initial_states.copy()  # where every fit of the states starts
        # The data's own sizes: least_squares' gradient tolerance and the states' difference steps are
        # absolute, so residuals are measured in units of y's RMS and steps in units of each unobserved
        # state's (read from X, before any settling moves the anchor).
        self.y_scale = _rms_or_one(self.y)
        self.state_scale = {j: _rms_or_one(self.anchor[:, j]) for j in self.latent}
        # A residual beyond this counts as a diverged simulation (see _bounded).
        self.diverged = 1e3 * max(1.0, self.y_scale)

    def subset(self, rows: np.ndarray) -> "ScienceFit":
        """The same fit restricted to some samples (a train / validation split)."""
        out = object.__new__(ScienceFit)
        out.structure, out.bounds, out.y, out.latent = self.structure, self.bounds, self.y[rows], self.latent
        out.fixed, out.diverged = self.fixed, self.diverged
        out.y_scale, out.state_scale = self.y_scale, self.state_scale
        out.inputs = tuple(t[torch.as_tensor(rows)] for t in self.inputs)
        out.initial_states, out.anchor = self.initial_states[rows].copy(), self.anchor[rows].copy()
        out.measured = self.measured
        return out

    def predict(self, science: Callable, theta: Mapping[str, Any]) -> np.ndarray:
        """Science-only prediction, flattened per sample: ``(n_samples, n_outputs)``."""
        values = {k: torch.as_tensor(np.asarray(v, dtype=float)) for k, v in theta.items()}
        with torch.no_grad():
            return self._simulate(science, values).reshape(self.y.shape).numpy()

    def _simulate(self, science: Callable, values: Mapping[str, torch.Tensor],
                  initial_states: np.ndarray | None = None) -> torch.Tensor:
        """The structure's science-only forward pass with the parameters bound to ``values``."""
        model = SimpleNamespace(science=lambda *args: science(*args, **values), residual=None, reduction=None)
        x0 = self.initial_states if initial_states is None else initial_states
        inputs = (torch.as_tensor(x0, dtype=torch.float64),) + tuple(self.inputs[1:])
        return self.structure.forward(model, *inputs, use_residual=False)[0]

    def errors(self, science: Callable, theta: Mapping[str, Any]) -> np.ndarray:
        """Mean squared error of every sample; a sample whose simulation diverged (a residual
        non-finite or beyond ``diverged``) counts as infinite. A blown-up sample is a failure, not
        a large number: its error, finite but scattered over hundreds of orders of magnitude,
        weakened the test a backward drop makes (is the term significantly better?), which let a
        term go and left a model that diverged (seen on a radiating body)."""
        if self.latent:  # every model judged from the same start, the anchor
            self.fit_initial_states(science, theta)
        with np.errstate(over="ignore", invalid="ignore"):  # a diverging candidate: counted, not warned
            residual = self.predict(science, theta) - self.y
            err = np.mean(residual**2, axis=1)
            diverged = ~np.all(np.abs(residual) <= self.diverged, axis=1)  # NaN compares False: diverged
        return np.where(diverged, np.inf, err)

    def settle(self, science: Callable, theta: Mapping[str, Any]) -> None:
        """Start later fits of the states from those that fit ``science`` at ``theta`` (the model a
        selection step continues from), instead of from ``X``: every candidate of a step starts
        from the same states, and closer to its own than ``X`` is. Does nothing without
        ``fit_initial_states``.

        Parameters
        ----------
        science : callable
            The science function.
        theta : dict
            Its parameter values.
        """
        if self.latent:
            self.fit_initial_states(science, theta)
            self.anchor = self.initial_states.copy()
            # a measured state stays anchored at its reading: the states that fit a model lacking an effect take
            # up part of it, and a candidate screened from them could not show it (hill_kill lost its law so)
            self.anchor[:, self.measured] = self.inputs[0].numpy()[:, self.measured]  # X's initial states

    def fit_initial_states(self, science: Callable, theta: Mapping[str, Any], n_iter: int = 20) -> None:
        """Fit the unobserved initial states of every sample at fixed ``theta``, from ``anchor``
        (the result in ``initial_states``).

        Each sample's states move only its own trajectory, so one batched Gauss-Newton step
        (Levenberg-damped, kept per sample only where it lowers that sample's error) serves all
        samples at the cost of ``1 + n_latent`` simulations.

        Parameters
        ----------
        science : callable
            The science function.
        theta : dict
            Its parameter values, held fixed.
        n_iter : int, default=20
            Most Gauss-Newton steps (fewer once no sample's error moves in its 6th digit).
        """
        values = {k: torch.as_tensor(np.asarray(v, dtype=float)) for k, v in theta.items()}

        def residuals(x0):
            with torch.no_grad(), np.errstate(all="ignore"):
                r = self._simulate(science, values, x0).reshape(self.y.shape).numpy() - self.y
            return _bounded(r, self.diverged)

        x0, damping = self.anchor.copy(), np.full(len(self.y), 1e-3)
        r = residuals(x0)
        cost = np.sum(r**2, axis=1)
        for _ in range(n_iter):
            jac = self._state_derivatives(residuals, x0, r)
            jtj = np.einsum("ans,bns->nab", jac, jac)
            jtr = np.einsum("ans,ns->na", jac, r)
            diagonal = np.arange(len(self.latent))
            jtj[:, diagonal, diagonal] *= 1.0 + damping[:, None]  # Marquardt: each state damped by its curvature
            jtj[:, diagonal, diagonal] += 1e-12
            trial = x0.copy()
            trial[:, self.latent] -= np.linalg.solve(jtj, jtr[..., None])[..., 0]
            r_trial = residuals(trial)
            cost_trial = np.sum(r_trial**2, axis=1)
            better = cost_trial < cost
            settled = np.all(cost - np.where(better, cost_trial, cost) <= 1e-6 * cost)  # errors to 6 digits
            x0[better], r[better], cost[better] = trial[better], r_trial[better], cost_trial[better]
            damping = np.where(better, damping / 3, damping * 4)
            if settled:  # no sample's error moves any more
                break
        self.initial_states = x0

    def fit(self, science: Callable, theta: Mapping[str, Any],
            extra_bounds: Mapping[str, tuple[float, float]] | None = None, max_nfev: int = 100,
            fit_states: bool = True) -> dict:
        """Least-squares parameters of ``science``, started from ``theta`` (its defaults elsewhere).

        With fitted initial states, ``fit_states=False`` holds them at ``anchor`` (a screening fit:
        a third of the time, and the states of the model a step continues from are close).
        Returns the fitted parameter dict (scalars as float, vectors as arrays).
        """
        _, defaults = read_signature(science)
        start = {k: np.asarray(theta.get(k, v), dtype=float) for k, v in defaults.items()}
        held = {k: v for k, v in start.items() if k in self.fixed}  # the estimator's theta_fixed
        names = [k for k in start if k not in held]
        shapes = [start[k].shape for k in names]
        x0 = np.concatenate([start[k].ravel() for k in names])
        bounds = {**self.bounds, **dict(extra_bounds or {})}
        low = np.concatenate([np.broadcast_to(_side(bounds.get(k), 0, -np.inf), s).ravel()
                              for k, s in zip(names, shapes)])
        high = np.concatenate([np.broadcast_to(_side(bounds.get(k), 1, np.inf), s).ravel()
                               for k, s in zip(names, shapes)])
        span = np.where(np.isfinite(high - low), high - low, np.maximum(np.abs(x0), 1.0))
        x0 = np.clip(x0, low + 1e-9 * span, high - 1e-9 * span)

        def unpack(x):
            out, i = {}, 0
            for k, s in zip(names, shapes):
                size = math.prod(s)
                out[k] = x[i:i + size].reshape(s)
                i += size
            for k, v in held.items():  # as tensors inside a vectorised simulation
                out[k] = torch.as_tensor(v, dtype=x.dtype) if torch.is_tensor(x) else v
            return {k: out[k] for k in start}

        # In units of y's RMS: least_squares' gtol is absolute, and stopped refits early on data of
        # small size (states in thousandths); the cap keeps its old place relative to the residuals.
        scale, cap = 1.0 / (math.sqrt(self.y.size) * self.y_scale), self.diverged / self.y_scale

        def scaled(pred):  # residual vector(s) of predictions; diverged values steer the search away
            return _bounded((pred - self.y).reshape(*pred.shape[:-2], -1) * scale, cap)

        def residuals(x):
            return scaled(self.predict(science, unpack(x)))

        def jacobian(x):  # forward differences as least_squares takes them, all in one simulation
            steps = _difference_steps(x, high)
            r = scaled(self._predict_many(science, np.vstack([x, x + np.diag(steps)]), unpack))
            return ((r[1:] - r[0]) / steps[:, None]).T

        jac = jacobian if self._vmap_serves(science, x0, unpack) else "2-point"
        n_params, problem = len(x0), (residuals, jac, x0, low, high)
        self.initial_states = self.anchor.copy()
        if self.latent and fit_states:  # jointly: alternating with the parameters stalls where they trade
            problem = self._with_states(*problem)
        with np.errstate(all="ignore"):  # trial steps may overflow; they are rejected, not used
            x = least_squares(problem[0], problem[2], jac=problem[1], bounds=problem[3:], x_scale="jac",
                              max_nfev=max_nfev).x
        if self.latent and fit_states:
            problem[0](x)  # leaves the fitted states in initial_states
        return {k: (float(v) if v.ndim == 0 else v) for k, v in unpack(x[:n_params]).items()}

    def _with_states(self, residuals, jac, x0, low, high):
        """Residuals and Jacobian of (parameters, unobserved initial states of every sample), from the
        ``anchor`` states (``X``'s, or those :meth:`settle` left), so that no candidate starts from
        another candidate's states. A sample's states move only its own residuals: their columns
        cost one simulation per state component."""
        p, n, k, m = len(x0), len(self.y), len(self.latent), self.y.shape[1]
        given = self.anchor.copy()

        def place(z):
            self.initial_states = given.copy()
            self.initial_states[:, self.latent] = z[p:].reshape(n, k)

        def joint_residuals(z):
            place(z)
            return residuals(z[:p])

        def joint_jacobian(z):  # sparse: a state's column is nonzero on its own sample's rows only
            place(z)
            r = residuals(z[:p])
            dense = jac(z[:p]) if callable(jac) else _forward_differences(residuals, z[:p], r, high[:p])
            base = self.initial_states

            def at(states):  # the scaled residuals, per sample, from other initial states
                self.initial_states = states
                return residuals(z[:p]).reshape(n, m)

            derivatives = self._state_derivatives(at, base, r.reshape(n, m))
            self.initial_states = base
            rows = np.arange(n * m)
            blocks = [sparse.coo_matrix((derivatives[a].ravel(), (rows, np.repeat(np.arange(n) * k + a, m))),
                                        shape=(n * m, n * k)) for a in range(k)]
            return sparse.hstack([sparse.csr_matrix(dense), sum(blocks).tocsr()]).tocsr()

        start = np.concatenate([x0, given[:, self.latent].ravel()])
        return (joint_residuals, joint_jacobian, start, np.concatenate([low, np.full(n * k, -np.inf)]),
                np.concatenate([high, np.full(n * k, np.inf)]))

    def _state_derivatives(self, residuals: Callable, x0: np.ndarray, r: np.ndarray) -> np.ndarray:
        """Forward differences of every sample's residuals ``r`` (n, m) by each of its own unobserved
        initial states: ``(n_latent, n, m)``, one simulation of all samples per state component."""
        out = np.empty((len(self.latent), *r.shape))
        for a, j in enumerate(self.latent):
            step = 1e-6 * np.maximum(self.state_scale[j], np.abs(x0[:, j]))
            moved = x0.copy()
            moved[:, j] += step
            out[a] = (residuals(moved) - r) / step[:, None]
        return out

    def predict_many(self, science: Callable, theta: Mapping[str, Any], names: Sequence[str],
                     rows: np.ndarray) -> np.ndarray | None:
        """Science-only predictions at several values of some parameters, in one vectorised simulation.

        Parameters
        ----------
        science : callable
            The science function (an augmented one too).
        theta : dict
            Every parameter's value; those in ``names`` are replaced by each row.
        names : sequence of str
            The parameters that vary, one per column of ``rows``.
        rows : array of shape (n_rows, len(names))
            Their values, a row per prediction.

        Returns
        -------
        array of shape (n_rows, n_samples, n_outputs) or None
            None where the science cannot be vectorised (``torch.func.vmap``: Python control flow on
            values, ``.item()``): simulate one row at a time with :meth:`predict` instead.
        """
        held = {k: torch.as_tensor(np.asarray(v, dtype=float)) for k, v in theta.items() if k not in names}
        try:
            with np.errstate(all="ignore"):
                return self._predict_many(science, np.asarray(rows, dtype=float),
                                          lambda row: {**held, **{k: row[i] for i, k in enumerate(names)}})
        except Exception:  # noqa: BLE001 -- any failure means: simulate one row at a time
            return None

    def _predict_many(self, science: Callable, points: np.ndarray, unpack: Callable) -> np.ndarray:
        """Science-only predictions at several parameter vectors, one vectorised simulation
        (``torch.func.vmap``): a small model's simulation costs its per-operation overhead, the
        same for one parameter vector as for ten."""
        with torch.no_grad():
            out = torch.func.vmap(lambda vector: self._simulate(science, unpack(vector)))(
                torch.as_tensor(points, dtype=torch.float64))
        return out.reshape(len(points), *self.y.shape).numpy()

    def _vmap_serves(self, science: Callable, x0: np.ndarray, unpack: Callable) -> bool:
        """Whether the vectorised Jacobian gives what one simulation at a time gives (a science
        function with Python control flow on values, ``.item()`` or numpy calls cannot be vmapped)."""
        try:
            with np.errstate(all="ignore"):
                many = self._predict_many(science, np.vstack([x0, x0]), unpack)
                alone = self.predict(science, unpack(x0))
        except Exception:  # noqa: BLE001 -- any failure means: take the reference path
            return False
        return bool(np.allclose(many[0], alone, rtol=1e-9, atol=1e-12, equal_nan=True))


def _rms_or_one(values: np.ndarray) -> float:
    """Root mean square of the finite values, or 1 where they are all zero (no size to read)."""
    values = np.asarray(values, dtype=float)
    rms = float(np.sqrt(np.mean(values[np.isfinite(values)] ** 2))) if np.isfinite(values).any() else 0.0
    return rms if rms > 0 else 1.0


def _bounded(r: np.ndarray, cap: float) -> np.ndarray:
    """Residuals with a diverged simulation's values (NaN, infinite, or finite beyond ``cap``) at
    ``cap``, signed. Clipping the finite ones too matters: a start whose simulation grows to 1e200
    without overflowing has an infinite squared error and an infinite Jacobian, from which
    ``least_squares`` steps to NaN and raises, where it should merely find no way down."""
    return np.clip(np.nan_to_num(r, nan=cap, posinf=cap, neginf=-cap), -cap, cap)


def _difference_steps(x: np.ndarray, high: np.ndarray) -> np.ndarray:
    """Forward-difference steps as least_squares takes them, turned back inside the upper bounds."""
    steps = np.sqrt(np.finfo(float).eps) * np.maximum(1.0, np.abs(x))
    return np.where(x + steps > high, -steps, steps)


def _forward_differences(residuals, x, r, high):
    steps = _difference_steps(x, high)
    return np.column_stack([(residuals(x + step * np.eye(len(x))[i]) - r) / step for i, step in enumerate(steps)])


def _side(bounds: Any, i: int, default: float) -> float:
    if bounds is None or bounds[i] is None:
        return default
    return float(bounds[i])
