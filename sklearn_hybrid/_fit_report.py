"""Uncertainty of theta after a fit, and the fit report (as lmfit's ``fit_report``).

A single fit's standard errors come from the Gauss-Newton (linearised least
squares) approximation of the data loss around the fitted theta, with the
network held at its fitted weights:

    J = d prediction / d theta        (every output value, central differences in float64)
    s^2 = sum_i w_i r_i^2 / (N - p)   (weighted residual variance, N output values of non-zero weight,
                                       p free parameters)
    cov(theta) = s^2 (J^T W J)^-1

This is the standard error lmfit and ``scipy.optimize.curve_fit`` report. It
measures what independent noise in ``y`` does to theta; it does not measure
noise in ``X`` carried along a trajectory, the bias that remains when the
network absorbs part of the physics, nor the spread between training runs
(``benchmarks/results/coverage.md``).  The report therefore prints it as the
noise-only part and builds no interval from it: intervals and the verdict
whether theta is identified come from :mod:`sklearn_hybrid.identifiability`.
"""

from __future__ import annotations

import copy

import numpy as np
import torch


__all__ = ["theta_uncertainty", "theta_jacobian", "format_report", "flat_predictions"]


def flat_predictions(model, inputs, chunk=None, use_residual=True) -> np.ndarray:
    """Predictions flattened per sample, without gradients, ``chunk`` samples per forward pass (all at
    once if None); ``use_residual=False``: the science part alone."""
    n = len(inputs[0])
    chunk = chunk or max(n, 1)
    with torch.no_grad():
        parts = [model(*(t[start:start + chunk] for t in inputs), use_residual=use_residual)[0]
                 for start in range(0, n, chunk)]
    return torch.cat(parts).reshape(n, -1).cpu().numpy()


def theta_jacobian(science, predict, entries, predict_many=None, base=None) -> np.ndarray:
    """Central differences of ``predict()`` by theta's entries, in theta's own units.

    Parameters
    ----------
    science : Science
        The module holding theta (modified in place during the call, restored
        after each entry).
    predict : callable
        Returns the predictions (an array) at the current theta.
    entries : list of (str, int)
        ``(name, flat index)`` of each entry to differentiate by, free or fixed.
    predict_many : callable, optional
        ``predict_many(raw) -> ndarray``: the predictions at a batch of raw
        (reparametrised) values, ``raw`` mapping each name to a tensor with a
        leading batch axis, in one vectorised pass (a small model's simulation
        costs its per-operation overhead, about the same for one theta as for
        several).  Used when its unmoved row reproduces ``base``; otherwise,
        or when it raises, ``predict()`` runs once per step.
    base : ndarray, optional
        ``predict()`` at the current theta, which ``predict_many`` is checked against.

    Returns
    -------
    ndarray of shape ``predict().shape + (len(entries),)``
        Each raw (reparametrised) entry is moved by +-h and the step in theta
        read back through its bounds' transform.
    """
    with torch.no_grad():
        raw = {name: science.raw[name].detach().clone() for name in science.names}
        moves = []  # (name, k, step) of every row after the unmoved one
        for name, k in entries:
            h = 1e-6 * max(abs(float(raw[name].view(-1)[k])), 1.0)
            moves += [(name, k, h), (name, k, -h)]
        rows = {name: value.expand(1 + len(moves), *value.shape).clone() for name, value in raw.items()}
        for i, (name, k, step) in enumerate(moves, start=1):
            rows[name][i].view(-1)[k] += step
        values = np.array([float(science.transforms[name](rows[name][i]).reshape(-1)[k])
                           for i, (name, k, _) in enumerate(moves, start=1)])
        preds = _batched(predict_many, rows, base)  # the moved rows' predictions
        if preds is None:  # one prediction per step
            preds = []
            for i, (name, _, _) in enumerate(moves, start=1):
                science.raw[name].data.copy_(rows[name][i])
                preds.append(predict())
                science.raw[name].data.copy_(raw[name])
    columns = [(preds[2 * j] - preds[2 * j + 1]) / (values[2 * j] - values[2 * j + 1]) for j in range(len(entries))]
    return np.stack(columns, axis=-1)


def _batched(predict_many, rows, base):
    """``predict_many(rows)`` of the moved rows (all but the first, unmoved one) as a list of arrays, or
    None where it cannot serve: not given, it raised (a science function with Python control flow on
    values cannot be vectorised), or its unmoved row differs from ``base``."""
    if predict_many is None or base is None:
        return None
    try:
        preds = np.asarray(predict_many(rows))
    except Exception:  # noqa: BLE001 -- any failure means: one prediction per step
        return None
    if preds.shape[1:] != np.shape(base) or not np.allclose(preds[0], base, rtol=1e-9, atol=1e-12, equal_nan=True):
        return None
    return list(preds[1:])


def theta_uncertainty(model, inputs, y, sample_weight=None, chunk=None) -> tuple[dict, np.ndarray, list]:
    """Standard errors and covariance of the free parameters of a fitted model.

    Parameters
    ----------
    model : HybridModule
        The fitted model (not modified: a float64 copy is differentiated).
    inputs : tuple of Tensor
        Structure inputs of the training samples.
    y : Tensor
        Their targets.
    sample_weight : Tensor of shape (n_samples,), optional
        The weights of the fit.
    chunk : int, optional
        Samples per forward pass (all at once if None); a fit passes the number that half the
        free memory holds in float64 (``check_fit_memory``): a model of image sequences over
        every training sample at once may not fit in memory.

    Returns
    -------
    std : dict
        name -> standard error (float, or array for vector parameters; 0 for
        fixed parameters; NaN where the data do not determine the parameter).
    cov : ndarray of shape (p, p)
        Covariance of the flattened free parameters.
    labels : list of str
        Names of the flattened free parameters (``name`` or ``name[k]``).
    """
    science = model.science
    if getattr(model, "encoder", None) is not None:  # theta is per sample: no shared theta to vary
        encoded = set(model.encoder.names)  # the others are fixed: known exactly, 0 as without an encoder
        value = {name: np.nan if name in encoded else 0.0 for name in science.names}
        std = {name: (value[name] if science.shapes[name] == () else np.full(science.shapes[name], value[name]))
               for name in science.names}
        return std, np.zeros((0, 0)), []
    model = copy.deepcopy(model).to(torch.float64).eval()
    inputs = tuple(t.to(torch.float64) for t in inputs)
    science = model.science
    y = y.reshape(len(y), -1).to(torch.float64).cpu().numpy()
    n = len(y)
    w = np.ones(n) if sample_weight is None else sample_weight.to(torch.float64).cpu().numpy()
    counted = w > 0  # a zero weight removes a sample, in the fit and here
    n_values = int(counted.sum()) * y.shape[1]
    w = np.repeat(w / w[counted].mean(), y.shape[1])  # one weight per output value, mean 1 where counted
    where = [(name, k) for name in science.names if science.raw[name].requires_grad
             for k in range(science.raw[name].numel())]
    labels = [name if science.shapes[name] == () else f"{name}[{k}]" for name, k in where]
    p = len(where)
    std = {name: (0.0 if science.shapes[name] == () else np.zeros(science.shapes[name]))
           for name in science.names}
    if p == 0:  # every parameter held: known exactly, and no prediction is needed to say so
        return std, np.zeros((0, 0)), labels
    base = flat_predictions(model, inputs, chunk).ravel()
    J = theta_jacobian(science, lambda: flat_predictions(model, inputs, chunk).ravel(), where)
    resid = y.ravel() - base
    dof = max(n_values - p, 1)
    s2 = float(np.sum(w * resid**2) / dof)
    JtWJ = J.T @ (w[:, None] * J)
    try:
        cov = s2 * np.linalg.inv(JtWJ)
    except np.linalg.LinAlgError:
        cov = np.full((p, p), np.nan)
    diag = np.sqrt(np.where(np.diag(cov) >= 0, np.diag(cov), np.nan))
    for (name, k), value in zip(where, diag):
        if science.shapes[name] == ():
            std[name] = float(value)
        else:
            std[name].reshape(-1)[k] = value
    return std, cov, labels


def _fmt(value) -> str:
    if np.ndim(value) == 0:
        return f"{float(value):.6g}"
    return np.array2string(np.asarray(value, float), precision=5, separator=", ")


def format_report(title: str, lines: list[str], theta: dict, std: dict | None, how: str, *,
                  std_label: str = "standard error", extra: dict | None = None,
                  verdicts: dict | None = None, notes_after: list[str] | None = None) -> str:
    """Text of a fit report: a header, key facts, and theta with what is known of its uncertainty.

    No interval is printed here from ``std``: an interval is printed only
    where a verdict (``verdicts``, from a profile whose coverage the
    benchmark measured) gives one.

    Parameters
    ----------
    title : str
        First line.
    lines : list of str
        ``key: value`` facts about the fit.
    theta, std : dict
        Values and a spread by name (``std`` None: none).
    how : str
        What the spread is (printed under the table).
    std_label : str
        Its name on each parameter's line.
    extra : dict, optional
        name -> note printed after a parameter (e.g. ``"(fixed)"``).
    verdicts : dict, optional
        name -> what a profile says of it (identified, with its interval, or not).
    notes_after : list of str, optional
        Lines printed after ``how``.
    """
    out = [f"[[{title}]]", *(f"    {line}" for line in lines), "[[Parameters]]"]
    for name, value in theta.items():
        parts = [f"{name}: {_fmt(value)}"]
        if verdicts and name in verdicts:
            parts.append(verdicts[name])
        if std is not None:
            parts.append(f"({std_label} {_fmt(std[name])})")
        if (extra or {}).get(name):
            parts.append(extra[name])
        out.append("    " + "  ".join(parts))
    out.append(f"    ({how})")
    out += [f"    {line}" for line in notes_after or ()]
    return "\n".join(out)
