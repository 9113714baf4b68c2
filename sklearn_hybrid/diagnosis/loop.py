"""Close the loop: fit a hybrid model, diagnose its residual, add the missing terms, refit, compare.

:func:`close_the_loop` is the one call; :func:`free_run` simulates a fitted hybrid ODE over any
horizon (test records are usually longer than the training windows) and
:func:`fit_initial_state` estimates a test record's initial state from its first samples.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Mapping, Sequence
from typing import Any

import numpy as np
import torch
from scipy.optimize import least_squares
from sklearn.base import clone
from sklearn.exceptions import NotFittedError
from sklearn.utils import Bunch
from sklearn.utils.validation import check_is_fitted
from torch import nn

from ..engine import DivergenceError
from ..residual import MLP
from .augment import augment_science
from .residual import ResidualDiagnosis, science_sensitivities, _rms

__all__ = ["close_the_loop", "free_run", "fit_initial_state", "MLPOn", "ZeroResidual", "prediction_metrics"]


class _Masked(nn.Module):
    """An MLP whose output is zero outside the chosen components."""

    def __init__(self, mlp: nn.Module, components: Sequence[int], out_shape: tuple):
        super().__init__()
        self.mlp, self.out_shape = mlp, tuple(out_shape)
        self.register_buffer("index", torch.as_tensor(list(components), dtype=torch.long))

    def forward(self, *inputs):
        part = self.mlp(*inputs)
        out = torch.zeros(len(part), math.prod(self.out_shape), dtype=part.dtype)
        return out.index_copy(1, self.index, part).reshape(len(part), *self.out_shape)


class MLPOn:
    """Residual factory: an MLP that acts on some state components only (zero on the others).

    Physics often fixes part of the right-hand side exactly (``d angle/dt = velocity``); letting
    the network change it would let it re-define the hidden state.

    Parameters
    ----------
    components : list of int
        Components of the (flattened) output the network may change.
    hidden : tuple of int, default=(64, 64)
        Hidden layer widths.
    activation : str, default="tanh"
        Activation (smooth activations give smooth residuals, easier to explain).
    zero_init : bool, default=True
        Start the last layer at zero, so that training starts from the science model alone rather
        than from a random force the optimiser must first undo.
    """

    def __init__(self, components: Sequence[int], hidden: Sequence[int] = (64, 64), activation: str = "tanh",
                 zero_init: bool = True):
        self.components, self.hidden, self.activation = list(components), tuple(hidden), activation
        self.zero_init = zero_init

    def __call__(self, in_shapes, out_shape) -> nn.Module:
        size = math.prod(out_shape)
        if not self.components or not all(0 <= c < size for c in self.components):
            raise ValueError(f"MLPOn components {self.components} must index an output of size {size}.")
        mlp = MLP(in_shapes, (len(self.components),), self.hidden, self.activation)
        if self.zero_init:
            with torch.no_grad():
                mlp.net[-1].weight.zero_()
                mlp.net[-1].bias.zero_()
        return _Masked(mlp, self.components, out_shape)

    def __repr__(self) -> str:
        return (f"MLPOn({self.components}, hidden={self.hidden}, activation={self.activation!r}, "
                f"zero_init={self.zero_init})")


class _Zero(nn.Module):
    """No network: zeros of the output shape (one unused parameter keeps the optimiser content)."""

    def __init__(self, out_shape):
        super().__init__()
        self.out_shape = tuple(out_shape)
        self.unused = nn.Parameter(torch.zeros(1))

    def forward(self, *inputs):
        return torch.zeros(len(inputs[0]), *self.out_shape, dtype=inputs[0].dtype)


class ZeroResidual:
    """Residual factory of a network that contributes nothing: fits the science model alone."""

    def __call__(self, in_shapes, out_shape) -> nn.Module:
        return _Zero(out_shape)

    def __repr__(self) -> str:
        return "ZeroResidual()"


def free_run(estimator: Any, x0: np.ndarray, u: np.ndarray | None = None, n_steps: int | None = None,
             use_residual: bool = True) -> np.ndarray:
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
    use_residual : bool, default=True
        False simulates the science part alone.

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


def prediction_metrics(y: np.ndarray, y_hybrid: np.ndarray, y_science: np.ndarray) -> dict[str, float]:
    """Test RMSE of the hybrid and of the science part alone, and the network's share of the prediction.

    The share is ``RMS(y_hybrid - y_science) / RMS(y_hybrid)``: how much of the prediction would
    change if the network were switched off.
    """
    def rms(a):
        return float(_rms(a, axis=None))

    return {"rmse": rms(y_hybrid - y), "rmse_science_only": rms(y_science - y),
            "network_share": rms(y_hybrid - y_science) / max(rms(y_hybrid), 1e-300)}


def _rhs_share(estimator: Any, X: Any) -> float:
    """Largest per-component RMS(g) / RMS(f + g) along the visited points (NaN if not defined)."""
    trace = estimator.residual_trace(X)
    args = [trace["points"]] + ([] if trace["inputs"] is None else [trace["inputs"]])
    g = trace["residual"].reshape(len(args[0]), -1)
    f = science_sensitivities(estimator, args, jacobian=False)[0]
    if f.shape != g.shape:
        return float("nan")
    total = np.sqrt(np.mean((f + g) ** 2, axis=0))
    return float(np.nanmax(np.sqrt(np.mean(g**2, axis=0)) / np.where(total > 0, total, np.nan)))


def _evaluate(est, X, X_test, y_test, test_scorer, theta_true) -> dict:
    row: dict[str, Any] = {}
    if test_scorer is not None:
        row.update(test_scorer(est))
    elif X_test is not None:
        y_test = np.asarray(y_test, float).reshape(len(X_test), -1)
        row.update(prediction_metrics(y_test, est.predict(X_test).reshape(len(y_test), -1),
                                      est.predict_science(X_test).reshape(len(y_test), -1)))
    row["network_share_rhs"] = _rhs_share(est, X)
    row["theta"] = {k: (float(v) if np.ndim(v) == 0 else np.asarray(v).tolist()) for k, v in est.theta_.items()}
    if theta_true:
        row["theta_error"] = {k: float(np.max(np.abs(np.asarray(est.theta_[k]) - np.asarray(v))
                                              / np.maximum(np.abs(v), 1e-12)))
                              for k, v in theta_true.items() if k in est.theta_}
    return row


def close_the_loop(estimator: Any, X: Any, y: Any, X_test: Any = None, y_test: Any = None, *,
                   diagnosis: ResidualDiagnosis | None = None, state_names: Sequence[str] | None = None,
                   input_names: Sequence[str] | None = None, units: Mapping[str, str] | None = None,
                   param_names: Mapping[str, str] | None = None, term_functions: Mapping[str, Callable] | None = None,
                   apply_theta_shift: bool = True, refit_params: Mapping[str, Any] | None = None,
                   theta_true: Mapping[str, Any] | None = None, test_scorer: Callable | None = None,
                   science_only: bool = False, verbose: bool = False) -> Bunch:
    """Fit (if needed), diagnose the residual, add the missing terms, refit, and compare.

    Parameters
    ----------
    estimator : HybridRegressor
        Fitted or not (then a clone is fitted on ``X, y``).
    X, y : array-like
        Training data, as for the estimator's ``fit``.
    X_test, y_test : array-like, optional
        Test data for the default metrics (:func:`prediction_metrics` of ``predict`` and
        ``predict_science``).
    diagnosis : ResidualDiagnosis, optional
        Diagnosis settings (library, regression...); default built from the names and units.
    state_names, input_names, units : optional
        Names of the states (or features) and inputs, and their units, for the default diagnosis.
    param_names : dict of str to str, optional
        Names of the new parameters by term, e.g. ``{"v^3": "k3"}``; default ``c_<term>``.
    term_functions : dict of str to callable, optional
        Torch versions of custom library terms (see :func:`~sklearn_hybrid.diagnosis.term_to_torch`).
    apply_theta_shift : bool, default=True
        Start the refit from theta corrected by the diagnosis' ``theta_shift_``.
    refit_params : dict, optional
        ``set_params`` overrides for the refit (e.g. more iterations).
    theta_true : dict, optional
        Known parameter values (of either model) for the theta error (max relative error).
    test_scorer : callable, optional
        ``test_scorer(estimator) -> dict`` of named metrics, used instead of the default metrics
        (e.g. free-run simulations of long test records, see :func:`free_run`).
    science_only : bool, default=False
        Also refit the augmented science model alone (network removed, ``method="erm"``), from the
        refit's theta: the model an engineer would keep, comparable with classical grey-box fits.
    verbose : bool, default=False
        Print progress and the report.

    Returns
    -------
    Bunch
        ``before``, ``after`` (fitted estimators; ``after`` is None when no term was found),
        ``diagnosis``, ``science`` (the augmented function or None), ``science_only`` (the
        network-free refit or None), ``table`` (list of row dicts: before, after, and with
        ``science_only`` "science only"), ``report`` (markdown text) and ``seconds``.
    """
    start = time.perf_counter()
    try:
        check_is_fitted(estimator, "model_")
        before = estimator
    except NotFittedError:
        if verbose:
            print("fitting the hybrid model ...")
        before = clone(estimator).fit(X, y)
    diag = clone_diagnosis(diagnosis, state_names, input_names, units)
    diag.fit(before, X)
    if verbose:
        print(diag.summary())
    rows = [{"stage": "before", "science": getattr(before.science, "__name__", "science"), "added": "",
             **_evaluate(before, X, X_test, y_test, test_scorer, theta_true)}]
    after, science = None, None
    new_terms = [dict(t, param=(param_names or {}).get(t["term"])) for t in diag.new_terms_]
    if new_terms:
        theta = dict(before.theta_)
        if apply_theta_shift:
            theta.update({k: theta[k] + v for k, v in diag.theta_shift_.items() if k in theta})
        n_states = len(diag.output_names_) if before.structure == "ode" else None
        science = augment_science(before.science, new_terms, diag.variable_names_, n_states=n_states,
                                  theta=_inside_bounds(theta, before.theta_bounds), term_functions=term_functions)
        after = clone(before).set_params(science=science, theta_init=None, **dict(refit_params or {}))
        if verbose:
            print(f"refitting with {science.__name__}: {science.equation}")
        try:
            after.fit(X, y)
        except DivergenceError as exc:  # reported, not raised: the diagnosis itself stays useful
            rows.append({"stage": "after", "science": science.__name__, "added": science.equation,
                         "theta": {}, "failed": f"refit diverged: {exc}"})
            after = None
        else:
            rows.append({"stage": "after", "science": science.__name__, "added": science.equation,
                         **_evaluate(after, X, X_test, y_test, test_scorer, theta_true)})
    alone = None
    if science_only and after is not None:
        alone = clone(after).set_params(residual=ZeroResidual(), method="erm",
                                        theta_init=_inside_bounds(after.theta_, after.theta_bounds))
        if verbose:
            print("refitting the augmented science model alone ...")
        alone.fit(X, y)
        rows.append({"stage": "science only", "science": science.__name__, "added": science.equation,
                     **_evaluate(alone, X, X_test, y_test, test_scorer, theta_true)})
    report = format_table(rows, diag)
    if verbose:
        print(report)
    return Bunch(before=before, after=after, diagnosis=diag, science=science, science_only=alone, table=rows,
                 report=report, seconds=time.perf_counter() - start)


def clone_diagnosis(diagnosis, state_names, input_names, units) -> ResidualDiagnosis:
    """The diagnosis to run: a copy of the given one, or a default from the names and units."""
    if diagnosis is None:
        return ResidualDiagnosis(state_names=state_names, input_names=input_names, units=units, random_state=0)
    if not isinstance(diagnosis, ResidualDiagnosis):
        raise TypeError(f"diagnosis must be a ResidualDiagnosis, got {type(diagnosis).__name__}.")
    return clone(diagnosis)


def _inside_bounds(theta: dict, bounds: Mapping | None) -> dict:
    """Keep shifted parameters strictly inside their bounds (the reparametrisation needs it)."""
    out = dict(theta)
    for k, (low, high) in (bounds or {}).items():
        if k in out and np.ndim(out[k]) == 0:
            lo = -np.inf if low is None else low
            hi = np.inf if high is None else high
            span = (hi - lo) if np.isfinite(hi - lo) else 1.0
            out[k] = float(np.clip(out[k], lo + 1e-6 * span, hi - 1e-6 * span))
    return out


def format_table(rows: list[dict], diagnosis: ResidualDiagnosis | None = None) -> str:
    """Markdown before/after table of :func:`close_the_loop` rows."""
    skip = ("stage", "science", "added", "theta", "theta_error", "failed")
    metrics = list(dict.fromkeys(k for r in rows for k in r if k not in skip))
    names = list(dict.fromkeys(k for r in rows for k in r["theta"]))
    head = ["stage", *metrics, *names]
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for r in rows:
        cells = [r["stage"]] + [f"{r.get(m, float('nan')):.4g}" for m in metrics]
        for n in names:
            v = r["theta"].get(n)
            text = "" if v is None else (f"{v:.5g}" if np.ndim(v) == 0 else str(np.round(v, 4).tolist()))
            err = r.get("theta_error", {}).get(n)
            cells.append(text + ("" if err is None else f" (err {err:.1%})"))
        lines.append("| " + " | ".join(cells) + " |")
    if diagnosis is not None:
        lines += ["", "Diagnosis: " + ("; ".join(diagnosis.equations()) or "no component to explain")]
        if len(rows) > 1:
            lines.append(f"Added: {rows[1]['added']}")
            if "failed" in rows[1]:
                lines.append(f"The refit failed ({rows[1]['failed']}); the after row is empty.")
        else:
            lines.append("No missing term found: nothing added, no refit.")
    return "\n".join(lines)
