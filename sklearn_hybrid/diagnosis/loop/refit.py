"""The loop's refits after the selection: long records cut into windows, the RK4 steps a chosen model
needs, and the network-free estimator an engineer keeps."""

from __future__ import annotations

import copy
import math
from collections.abc import Callable, Mapping
from typing import Any

import numpy as np
import torch
from scipy.signal import savgol_coeffs, savgol_filter
from sklearn.base import clone

from ..._fitting import ode_structure
from ...datasets import make_windows
from ...residual import ZeroResidual
from ...science import read_signature
from ...structures import ODE_FLAT_SETTINGS, OdeStructure
from ..science_fit import ScienceFit

__all__ = ["windowable", "accurate_substeps", "cut_windows", "fixed_science", "inside_bounds", "START_SMOOTHING",
           "NARROWEST_SMOOTHING"]


def windowable(estimator: Any) -> bool:
    """Whether a long record of ``estimator``'s data can be cut into windows started from measured states:
    an unforced ODE that observes every state component."""
    structure = ode_structure(estimator)
    return structure is not None and structure.observed is None and not structure.n_inputs


def accurate_substeps(fit: ScienceFit, science: Callable, theta: Mapping[str, Any]) -> int | None:
    """With ``n_substeps="auto"``: the RK4 steps per interval that ``science`` at ``theta`` needs, where
    more than the fit's (an added term can be stiffer than the science the steps were chosen for: dry
    friction's ``tanh(v/w)`` with a small ``w``); None where the fit's suffice."""
    structure = fit.structure
    if not getattr(structure, "auto_substeps", False):
        return None
    probe = copy.copy(structure)
    values = {k: torch.as_tensor(np.asarray(v, dtype=float)) for k, v in theta.items()}
    probe.choose_substeps(lambda *args: science(*args, **values), fit.inputs[0], torch.as_tensor(fit.y))
    return probe.n_substeps if probe.n_substeps > structure.n_substeps else None


def step_error(before: Any, X: Any, y: Any, fit: ScienceFit, science: Callable, theta: Mapping[str, Any],
               bounds: Mapping, fit_initial_states: bool | str) -> dict[str, float]:
    """How far each entry of a network-free refit's ``theta`` can be from the value an exact integration
    would give: the refit again from ``theta`` with the RK4 step halved, its move times 16/15 (Richardson:
    for a fourth-order method the error at step h is about 16/15 of the move from h to h/2).

    An interval narrower than this error can miss the truth by the integration alone (drag_mass's k
    [3.1969, 3.1999] for 3.2).  Keys are the intervals' labels (``name`` or ``name[k]``); empty for a model
    that is not integrated.
    """
    structure = fit.structure
    if ode_structure(before) is None or not getattr(structure, "n_substeps", None):
        return {}
    finer = ScienceFit(before, X, y, fit_initial_states, n_substeps=2 * structure.n_substeps)
    finer.initial_states = fit.initial_states.copy()  # the states fitted at step h: a start, refitted too
    fine = finer.fit(science, theta, bounds)
    error = {}
    for name, value in theta.items():
        moved = np.abs(np.ravel(np.asarray(fine[name], dtype=float)) - np.ravel(np.asarray(value, dtype=float)))
        labels = [name] if np.ndim(value) == 0 else [f"{name}[{k}]" for k in range(moved.size)]
        error.update({label: float(16 / 15 * m) for label, m in zip(labels, moved)})
    return error


#: A window of a long record starts from the record smoothed there, a local cubic over one of these many
#: steps (Savitzky-Golay), chosen per record and state by generalised cross-validation. The measured start
#: carries its noise into every step of the window, and a candidate that damps more than the truth is
#: rewarded for removing it: an oscillator missing a linear damping was given a dry friction beside it on
#: windows started from the raw measurements.
START_SMOOTHING = (5, 7, 9, 11, 15, 21)
#: Where cross-validation prefers a narrower window than this, the record varies too fast for its sampling
#: to be smoothed without bias (a cubic over 15 steps of an oscillation sampled 16 times a period shrinks it
#: by a fifth): its windows start from the measurements, as they are.
NARROWEST_SMOOTHING = 9


def cut_windows(X: Any, y: Any, window: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Non-overlapping windows of ``window`` steps cut from fully observed ODE records
    (:func:`~sklearn_hybrid.datasets.make_windows` on each record, its initial state first).

    Parameters
    ----------
    X : array-like of shape (n_records, *state_shape)
        The initial states.
    y : array-like of shape (n_records, n_steps, *state_shape) or flattened per record
        The states at the output times.
    window : int
        Steps per window.

    Returns
    -------
    X_windows : ndarray of shape (n_windows, *state_shape)
        Each window's first state: ``X`` for the first window of a record (the start the whole
        record's fit takes), else the record at the step before the window, smoothed by a local cubic
        (a record that varies as a cubic there keeps its values) where the record is finely sampled enough
        for it (see ``START_SMOOTHING`` and ``NARROWEST_SMOOTHING``), else as measured.
    y_windows : ndarray of shape (n_windows, window, *state_shape)
        The measured states, as they are.
    record : ndarray of int, shape (n_windows,)
        The record each window was cut from (records in order, each record's windows in time order).
    """
    X = np.asarray(X, dtype=float)
    shape, size = X.shape[1:], math.prod(X.shape[1:])
    records = np.concatenate([X.reshape(len(X), 1, size), np.asarray(y, dtype=float).reshape(len(X), -1, size)], axis=1)
    cut = [make_windows(record, length=window, stride=window) for record in records]
    smoothed = _smoothed(records)
    starts = []
    for r, c in enumerate(cut):
        first = smoothed[r, c.starts]
        first[c.starts == 0] = records[r, 0]
        starts.append(first)
    return (np.concatenate(starts).reshape(-1, *shape),
            np.concatenate([c.y for c in cut]).reshape(-1, window, *shape),
            np.repeat(np.arange(len(X)), [len(c.X) for c in cut]))


def _smoothed(records: np.ndarray) -> np.ndarray:
    """Each record (axis 1 is time) and state smoothed by the local cubic of ``START_SMOOTHING`` steps that
    generalised cross-validation prefers (the residual's mean square over (1 - the centre weight)^2, the
    leave-one-out error of a linear smoother), where that is at least ``NARROWEST_SMOOTHING`` steps; every
    other one as it is."""
    out = records
    lengths = [n for n in START_SMOOTHING if n <= records.shape[1]]
    smooth = [savgol_filter(records, n, 3, axis=1, mode="interp") for n in lengths]
    score = [np.mean((records - s) ** 2, axis=1) / (1 - savgol_coeffs(n, 3)[n // 2]) ** 2
             for n, s in zip(lengths, smooth)]
    best = np.argmin(score, axis=0) if score else None  # (n_records, n_components)
    for i, n in enumerate(lengths):
        if n >= NARROWEST_SMOOTHING:
            out = np.where((best == i)[:, None, :], smooth[i], out)
    return out


def inside_bounds(theta: dict, bounds: Mapping | None) -> dict:
    """Keep values strictly inside their bounds (the reparametrisation needs it)."""
    out = dict(theta)
    for k, (low, high) in (bounds or {}).items():
        if k in out and np.ndim(out[k]) == 0:
            lo = -np.inf if low is None else low
            hi = np.inf if high is None else high
            span = (hi - lo) if np.isfinite(hi - lo) else 1.0
            out[k] = float(np.clip(out[k], lo + 1e-6 * span, hi - 1e-6 * span))
    return out


def fixed_science(before, science, theta, X, y, n_substeps=None):
    """An estimator holding ``science`` at ``theta``, no network: the model an engineer keeps.

    ``n_substeps``: the RK4 steps per interval its parameters were fitted with, taken instead of
    choosing them again where ``before`` chose them (``"auto"``: a fine free run of every record).
    """
    names = list(read_signature(science)[1])
    est = clone(before).set_params(science=science, residual=ZeroResidual(), method="erm", max_iter=1,
                                   theta_init=inside_bounds(theta, before.theta_bounds), theta_fixed=names,
                                   verbose=False)
    ode = ode_structure(before)
    if ode is not None:  # the ODE's options as one object (the estimator's flat copies are deprecated)
        options = ode.options()
        # the steps theta was fitted with, however the ODE was spelled ("ode" and flat options, or OdeStructure)
        if n_substeps is not None and options["n_substeps"] == "auto":
            options["n_substeps"] = int(n_substeps)
        est.set_params(structure=OdeStructure(**options), **ODE_FLAT_SETTINGS)
    return est.fit(X, y)
