"""Checks shared by the estimators: validation that keeps an earlier fit whole, positive
numbers, and torch's thread count for the duration of a fit or a prediction."""

from __future__ import annotations

import copy
import math
import numbers
from contextlib import contextmanager

import numpy as np
import torch
from sklearn.utils.validation import validate_data

__all__ = ["torch_threads", "validate_into_copy", "set_feature_info", "check_positive", "check_target_layout",
           "check_dtype_range", "check_not_nested"]


@contextmanager
def torch_threads(n_threads):
    """Run with ``n_threads`` intra-op threads, restoring the caller's setting."""
    previous = torch.get_num_threads()
    if n_threads is not None:
        torch.set_num_threads(n_threads)
    try:
        yield
    finally:
        torch.set_num_threads(previous)


def validate_into_copy(estimator, *args, **kwargs):
    """``validate_data`` on a shallow copy of ``estimator``; returns its output and the feature info.

    ``validate_data`` records ``n_features_in_`` / ``feature_names_in_`` on the
    estimator it is given; doing that on a copy keeps an earlier fit whole
    until the new one succeeds (then :func:`set_feature_info` stores them).
    """
    checked = copy.copy(estimator)
    out = validate_data(checked, *args, **kwargs)
    return out, {k: getattr(checked, k) for k in ("n_features_in_", "feature_names_in_")
                 if hasattr(checked, k)}


def set_feature_info(estimator, features: dict) -> None:
    """Store what :func:`validate_into_copy` recorded, dropping stale feature names."""
    if "feature_names_in_" not in features and hasattr(estimator, "feature_names_in_"):
        del estimator.feature_names_in_
    for name, value in features.items():
        setattr(estimator, name, value)


#: The default of an estimator's deprecated flat setting: not given.
DEPRECATED = "deprecated"


def given_settings(settings, names, none_unset=()) -> dict:
    """Of ``names``, the deprecated flat settings given in ``settings`` (an estimator's ``get_params()``):
    those neither ``DEPRECATED`` nor, for the names in ``none_unset``, None (their "not given" before)."""
    values = {name: settings.get(name, DEPRECATED) for name in names}
    return {name: v for name, v in values.items()
            if not (isinstance(v, str) and v == DEPRECATED or v is None and name in none_unset)}


def check_positive(name, value, integer=False, allow_none=False):
    """Raise a ValueError naming ``name`` unless ``value`` is a positive finite number (or integer)."""
    if value is None and allow_none:
        return
    kind = numbers.Integral if integer else numbers.Real
    if not isinstance(value, kind) or isinstance(value, bool) or not 0 < value < math.inf:
        raise ValueError(f"{name} must be a positive {'integer' if integer else 'number'}, got {value!r}"
                         + (" (finite values only)." if value == math.inf else "."))


def check_target_layout(y, pred: np.ndarray, name: str = "y") -> np.ndarray:
    """``y`` as floats shaped like ``pred``; it may come flattened per sample, not in another layout.

    A plain reshape would score ``(n, n_outputs, n_steps)`` targets against
    ``(n, n_steps, n_outputs)`` predictions without a word.
    """
    y = np.asarray(y, dtype=float)
    flat = (len(pred), math.prod(pred.shape[1:]))
    if y.shape != pred.shape and y.shape != flat:
        raise ValueError(f"{name} has shape {y.shape}; the model predicts {pred.shape} for these X "
                         f"({flat} flattened per sample is accepted too).")
    return y.reshape(pred.shape)


def check_not_nested(a, name: str = "y"):
    """``a`` as an array, refusing one whose entries are arrays (a pandas Series of arrays).

    numpy makes such a column an object array of shape ``(n,)``; scikit-learn's NaN check then
    compares arrays and fails with "The truth value of an array ... is ambiguous", which names
    neither ``y`` nor the fix.
    """
    a = np.asarray(a)
    if a.dtype == object and a.size and isinstance(a.flat[0], (np.ndarray, list, tuple)):
        shape = np.shape(a.flat[0])
        raise ValueError(f"{name} holds one array per sample ({type(a.flat[0]).__name__} of shape {shape} in an "
                         f"object array of shape {a.shape}, as a pandas Series of arrays gives): stack them into one "
                         f"array, {name} = np.stack({name}), of shape {(len(a), *shape)}.")
    return a


def check_dtype_range(dtype: torch.dtype, X, y) -> None:
    """Refuse data that the fit's floating point type cannot hold (X, y), nor square (y).

    A value beyond ``finfo.max`` becomes infinite on conversion, and a target
    beyond ``sqrt(finfo.max)`` (1.8e19 in float32) makes the squared errors
    of the loss infinite at once; either used to surface as a non-finite
    training loss at iteration 0, blamed on the learning rate or the science
    function.
    """
    info = torch.finfo(dtype)
    name = str(dtype).removeprefix("torch.")
    for what, a, limit in (("X", X, info.max), ("y", y, math.sqrt(info.max))):
        largest = float(np.max(np.abs(a))) if np.size(a) else 0.0
        if largest <= limit:
            continue
        how = (f"overflow {name} (largest number {info.max:.3g})" if largest > info.max else
               f"make the squared errors of the loss overflow {name} (beyond {limit:.2g})")
        wide = torch.finfo(torch.float64).max
        wider = wide if what == "X" else math.sqrt(wide)  # the same limit in float64
        fix = "Fit with dtype='float64', or rescale" if dtype != torch.float64 and largest <= wider else "Rescale"
        raise ValueError(
            f"{what} holds values up to {largest:.3g}, which {how}. {fix} {what} (divide it by a "
            "typical magnitude and express theta in the matching units).")


def check_n_jobs(n_jobs) -> int:
    """The number of worker groups ``n_jobs`` asks for (None: 1; negative values as joblib reads them)."""
    from joblib import effective_n_jobs

    n_jobs = 1 if n_jobs is None else n_jobs
    if not (isinstance(n_jobs, numbers.Integral) and not isinstance(n_jobs, bool) and n_jobs != 0):
        raise ValueError(f"n_jobs must be a non-zero integer or None (-1: one group per core), got {n_jobs!r}.")
    return effective_n_jobs(n_jobs)
