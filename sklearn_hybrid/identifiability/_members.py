"""What profiles and the bootstrap train: members made from a fitted estimator, and their data."""

from __future__ import annotations

import math
import numbers

import numpy as np
import torch
from sklearn.utils import Bunch
from sklearn.utils.validation import check_is_fitted

from .._estimator import HybridRegressor
from .._fitting import fitted_data, fitted_settings
from .._validation import check_target_layout
from ..training.schedule import TrainConfig
from ..methods import method_of, stackable_methods

__all__ = ["fitted_problem", "member_config", "parameter_entries", "check_level", "entry_values",
           "set_entry", "bounds_of"]


def fitted_problem(estimator, X, y) -> Bunch:
    """The fitted model, its training method and the data ``X, y`` as the model reads them.

    Returns a Bunch: ``model`` (the fitted HybridModule, not modified),
    ``method``, ``inputs`` and ``y`` (tensors, ``y`` flattened per sample),
    ``fit`` (the estimator's parameters at fit) and ``n_samples``.
    """
    if not isinstance(estimator, HybridRegressor):
        raise TypeError(f"estimator must be a fitted HybridRegressor, got {type(estimator).__name__}.")
    check_is_fitted(estimator)
    if getattr(estimator.model_, "encoder", None) is not None:
        raise ValueError("theta varies per sample (theta_encoder): there is no one theta to profile or resample.")
    fit = fitted_settings(estimator)
    method = method_of(fit, fitted=True)
    if not method.stackable:
        raise ValueError(f"Profiles and the bootstrap train stacked members, which method {method.name!r} "
                         f"cannot (its penalty needs the whole model); refit with one of {stackable_methods()}.")
    X, inputs = fitted_data(estimator, X)
    if len(X) < 3:
        raise ValueError(f"{len(X)} sample(s): profiles and the bootstrap need at least 3.")
    y = check_target_layout(y, np.empty((len(X), *estimator.y_shape_)))
    if not np.all(np.isfinite(y)):
        raise ValueError("y contains NaN or infinite values.")
    return Bunch(model=estimator.model_, method=method, inputs=inputs,
                 y=torch.tensor(y.reshape(len(X), -1), dtype=inputs[0].dtype, device=inputs[0].device), fit=fit,
                 n_samples=len(X))


def member_config(fit: dict, max_iter: int, lr: float | None, verbose: bool, stop_early: bool = False) -> TrainConfig:
    """The fit's optimisation settings for at most ``max_iter`` iterations of every member; with
    ``stop_early``, the fit's stopping rule (``tol``, ``n_iter_no_change``) ends the stacked training once
    every member meets it."""
    if not (isinstance(max_iter, numbers.Integral) and not isinstance(max_iter, bool) and max_iter > 0):
        raise ValueError(f"max_iter must be a positive integer, got {max_iter!r}.")
    if lr is not None and not (isinstance(lr, numbers.Real) and 0 < lr < math.inf):
        raise ValueError(f"lr must be a positive number or None, got {lr!r}.")
    return TrainConfig(lr=lr or fit["lr"], lr_theta=None if lr else fit["lr_theta"], max_iter=int(max_iter),
                       batch_size=fit["batch_size"], weight_decay=fit["weight_decay"], perturb=fit["perturb"],
                       verbose=verbose, tol=fit["tol"] if stop_early else None,
                       n_iter_no_change=fit["n_iter_no_change"])


def parameter_entries(science, params) -> list[tuple[str, int, str]]:
    """``(name, flat index, label)`` of every entry of the named free parameters (all free ones if None)."""
    free = [n for n in science.names if science.raw[n].requires_grad]
    if params is None:
        names = free
    else:
        names = [params] if isinstance(params, str) else list(params)
        for name in names:
            if name not in science.names:
                raise ValueError(f"Unknown parameter {name!r}; the science function's parameters are "
                                 f"{science.names}.")
            if name not in free:
                raise ValueError(f"Parameter {name!r} is fixed (theta_fixed): it was not estimated, so "
                                 "there is nothing to profile or resample.")
        if not names:
            raise ValueError("params names no parameter.")
    if not names:
        raise ValueError("Every parameter is fixed: there is nothing to profile or resample.")
    out = []
    for name in names:
        size = math.prod(science.shapes[name])
        for k in range(size):
            out.append((name, k, name if science.shapes[name] == () else f"{name}[{k}]"))
    return out


def check_level(level) -> float:
    if not (isinstance(level, numbers.Real) and not isinstance(level, bool) and 0 < level < 1):
        raise ValueError(f"level must be a number in (0, 1), e.g. 0.95, got {level!r}.")
    return float(level)


def entry_values(science, name: str) -> np.ndarray:
    """The current value of parameter ``name``, flattened (float64)."""
    with torch.no_grad():
        return science.transforms[name](science.raw[name]).detach().cpu().numpy().astype(float).reshape(-1)


def set_entry(science, name: str, k: int, value: float) -> None:
    """Set entry ``k`` of parameter ``name`` to ``value`` (through its bounds' reparametrisation)."""
    values = entry_values(science, name)
    values[k] = value
    raw = science.transforms[name].inverse(values.reshape(science.shapes[name]))
    with torch.no_grad():
        science.raw[name].copy_(torch.as_tensor(np.asarray(raw), dtype=science.raw[name].dtype))


def bounds_of(science, name: str, k: int) -> tuple[float, float]:
    t = science.transforms[name]
    low = np.broadcast_to(t.low.cpu().numpy(), science.shapes[name]).reshape(-1)[k]
    high = np.broadcast_to(t.high.cpu().numpy(), science.shapes[name]).reshape(-1)[k]
    return float(low), float(high)
