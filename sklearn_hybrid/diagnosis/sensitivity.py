"""The science output and its sensitivities to theta, at the points where a network acts.

What :class:`~sklearn_hybrid.diagnosis.ResidualDiagnosis` and the closed loop's selection compare a
network's contribution with: the science function's output in float64, and its central
differences in every scalar parameter (a correction a network carries for a wrong theta is, to
first order, a combination of them).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from typing import Any

import numpy as np
import torch

__all__ = ["state_labels", "root_mean_square", "science_output", "finite_differences", "parameter_jacobian",
           "science_sensitivities", "free_columns", "exact_components", "parameter_basis"]


def state_labels(given: Sequence[str] | None, size: int, prefix: str, label: str) -> list[str]:
    if given is None:
        return [f"{prefix}{i}" for i in range(size)]
    names = [given] if isinstance(given, str) else list(given)
    if len(names) != size:
        raise ValueError(f"{label} has {len(names)} names but the fitted model has {size} such variables.")
    return names


def root_mean_square(a: np.ndarray, axis=0) -> np.ndarray:
    return np.sqrt(np.mean(np.square(a), axis=axis))


def science_output(science: Callable, theta: Mapping[str, Any], args: Sequence[np.ndarray]) -> np.ndarray:
    """The science function's output at ``args`` (batch first), in float64, flattened: ``(n, n_outputs)``."""
    tensors = [torch.as_tensor(np.asarray(a, dtype=float)) for a in args]
    values = {k: torch.as_tensor(np.asarray(v, dtype=float)) for k, v in theta.items()}
    with torch.no_grad():
        out = science(*tensors, **values)
    return out.reshape(len(tensors[0]), -1).numpy()


def finite_differences(output: Callable[[dict], np.ndarray], theta: Mapping[str, Any]
                       ) -> tuple[np.ndarray, list[str]]:
    """Central differences of ``output(theta)`` in every scalar parameter: ``(*output shape, p)``.

    Also returns the parameter names (``name[i]`` for elements of vector parameters).
    """
    columns, names = [], []
    for name, value in theta.items():
        value = np.asarray(value, dtype=float)
        for idx in np.ndindex(value.shape):
            h = 1e-5 * max(abs(float(value[idx])), 1e-3)
            plus, minus = value.copy(), value.copy()
            plus[idx] += h
            minus[idx] -= h
            diff = output({**theta, name: plus}) - output({**theta, name: minus})
            columns.append(diff / (2 * h))
            names.append(name if value.ndim == 0 else f"{name}[{','.join(map(str, idx))}]")
    if not columns:
        return np.zeros((*output(dict(theta)).shape, 0)), names
    return np.stack(columns, axis=-1), names


def parameter_jacobian(science: Callable, theta: Mapping[str, Any],
                       args: Sequence[np.ndarray]) -> tuple[np.ndarray, list[str]]:
    """Central differences of the science output in every scalar parameter: ``(n, n_outputs, p)``.

    Also returns the parameter names (``name[i]`` for elements of vector parameters).
    """
    return finite_differences(lambda values: science_output(science, values, args), theta)


def science_sensitivities(estimator: Any, args: list[np.ndarray],
                          jacobian: bool = True) -> tuple[np.ndarray, np.ndarray, list[str]]:
    """Science output and its derivatives with respect to every (scalar) parameter.

    Parameters
    ----------
    estimator : fitted HybridRegressor
    args : list of ndarray
        The science function's inputs, batch first (e.g. ``[states, inputs]``).
    jacobian : bool, default=True
        False skips the derivatives (``jac`` has no parameter axis entries).

    Returns
    -------
    f : ndarray of shape (n, n_outputs)
        Science output at the fitted theta.
    jac : ndarray of shape (n, n_outputs, n_params)
        Central finite differences in float64 (robust for any torch-written function).
    names : list of str
        Parameter names (``name[i]`` for elements of vector parameters).
    """
    func, theta = estimator.science, estimator.theta_
    f = science_output(func, theta, args)
    if not jacobian:
        return f, np.zeros((*f.shape, 0)), []
    jac, names = parameter_jacobian(func, theta, args)
    return f, jac, names


def free_columns(jac: np.ndarray, names: Sequence[str], fixed: set) -> np.ndarray:
    """The sensitivities of the parameters a refit may move: a fixed one cannot absorb a shift."""
    return jac[..., [i for i, name in enumerate(names) if name.split("[")[0] not in fixed]]


def parameter_basis(S: np.ndarray) -> np.ndarray:
    """An orthonormal basis ``Q`` of the columns of ``S`` (points x parameters) that are not zero throughout:
    ``r - Q @ (Q.T @ r)`` is the part of ``r`` no parameter shift can take."""
    S = S[:, np.any(np.abs(S) > 0, axis=0)]
    return np.linalg.qr(S)[0] if S.shape[1] else np.zeros((len(S), 0))


def exact_components(jac: np.ndarray, names: Sequence[str], fixed: set) -> list[int] | None:
    """The outputs whose science equation depends on no free parameter at the points of ``jac``
    (``(n, n_outputs, p)``, see :func:`parameter_jacobian`): exact physics, a definition such as
    ``d angle/dt = velocity`` rather than a model; None where no parameter is free at all."""
    jac = free_columns(jac, names, fixed)
    if jac.shape[-1] == 0:
        return None
    return [j for j in range(jac.shape[1]) if not np.any(np.abs(jac[:, j, :]) > 1e-12)]
