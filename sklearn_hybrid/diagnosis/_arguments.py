"""Checks of :func:`~sklearn_hybrid.diagnosis.close_the_loop`'s arguments, made before anything is fitted.

Each names the problem: an unknown state, an option out of range, a unit for a variable that does not exist.
"""

from __future__ import annotations

from numbers import Real

import numpy as np

from ..science import read_signature
from .residual import _names, parameter_jacobian


def _check_options(validation_fraction, max_terms, n_candidates, cv, z, min_gain):
    fraction = validation_fraction
    if isinstance(fraction, bool) or not isinstance(fraction, Real) or not 0 < fraction < 1:
        raise ValueError(f"validation_fraction must be in (0, 1), got {validation_fraction!r}.")
    if isinstance(z, bool) or not isinstance(z, Real) or not 0 < z < np.inf:
        raise ValueError(f"z must be a positive number of standard errors, got {z!r}.")
    if isinstance(min_gain, bool) or not isinstance(min_gain, Real) or not 0 <= min_gain < 1:
        raise ValueError(f"min_gain must be in [0, 1) (a share of the held-out error), got {min_gain!r}.")
    if cv is not None and (isinstance(cv, bool) or not isinstance(cv, (int, np.integer)) or cv < 2):
        raise ValueError(f"cv must be None or an integer of at least 2, got {cv!r}.")
    for name, value in (("max_terms", max_terms), ("n_candidates", n_candidates)):
        if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < 1:
            raise ValueError(f"{name} must be a positive integer, got {value!r}.")


def _uncertain_components(estimator, X, y, exact, state_names) -> list[int] | None:
    """Output components that may receive terms (None: all of them)."""
    if exact is None or estimator.structure != "ode":
        return None
    X, y = np.asarray(X, dtype=float), np.asarray(y)
    n_inputs = estimator.n_inputs or 0
    d = _n_states(estimator, X, y)
    if isinstance(exact, str):
        if exact != "auto":
            raise ValueError(f"exact must be 'auto', None or a list of state names or indices, got {exact!r}.")
        theta = getattr(estimator, "theta_", None) or {**read_signature(estimator.science)[1],
                                                       **dict(estimator.theta_init or {})}
        sample = X[: min(len(X), 64)]
        args = [sample[:, :d]] + ([sample[:, d:d + n_inputs]] if n_inputs else [])
        jac, _ = parameter_jacobian(estimator.science, theta, args)
        if jac.shape[-1] == 0:
            return None
        fixed = [j for j in range(jac.shape[1]) if not np.any(np.abs(jac[:, j, :]) > 1e-12)]
    else:
        fixed = _state_indices(exact, _names(state_names, d, "x", "state_names"), "exact")
    uncertain = [j for j in range(d) if j not in fixed]
    if not uncertain:
        raise ValueError("Every component is exact: there is nothing for the network or the diagnosis to do.")
    return uncertain if fixed else None


def _offset_states(estimator, X, y, offsets, state_names) -> list[int]:
    """Indices of the states named in ``offsets``; in an ODE only measured states can have a sensor offset."""
    names = _names(state_names, _n_variables(estimator, X, y), "x", "state_names")
    out = _state_indices([offsets] if isinstance(offsets, (str, int)) else offsets, names, "offsets")
    unmeasured = [names[j] for j in out if estimator.structure == "ode" and estimator.observed is not None
                  and j not in estimator.observed]
    if unmeasured:
        raise ValueError(f"offsets names {unmeasured}, not measured (observed={estimator.observed}): an offset "
                         "on an unmeasured state only relabels its initial value.")
    if len(set(out)) < len(out):
        raise ValueError(f"offsets lists a state twice: {list(offsets)}.")
    return out


def _check_units(estimator, X, y, units, state_names, input_names, user_terms) -> None:
    """``units`` may name the states, the inputs and the user's terms only: a misspelt name would lose its
    unit silently."""
    if not units:
        return
    n_inputs = (estimator.n_inputs or 0) if estimator.structure == "ode" else 0
    known = (_names(state_names, _n_variables(estimator, X, y), "x", "state_names")
             + (_names(input_names, n_inputs, "u", "input_names") if n_inputs else []) + list(user_terms or {}))
    unknown = [k for k in units if k not in known]
    if unknown:
        raise ValueError(f"units names {unknown}, neither a state, an input nor a user term; the names are "
                         f"{known}.")


def _state_indices(items, names: list[str], option: str) -> list[int]:
    """State names or indices given to ``option`` as indices, each checked."""
    out = []
    for item in items:
        if isinstance(item, str):
            if item not in names:
                raise ValueError(f"{option} names unknown state {item!r}; states are {names}.")
            item = names.index(item)
        if isinstance(item, bool) or not isinstance(item, (int, np.integer)) or not 0 <= item < len(names):
            raise ValueError(f"{option} entry {item!r} is not a state index in [0, {len(names)}).")
        out.append(int(item))
    return out


def _n_states(estimator, X, y) -> int:
    """States of an ODE estimator's ``X``: its columns less the packed inputs (one per output time and 0)."""
    X, y = np.asarray(X), np.asarray(y)
    n_inputs = estimator.n_inputs or 0
    return X.shape[1] - (y.shape[1] + 1) * n_inputs if n_inputs else int(np.prod(X.shape[1:]))


def _n_variables(estimator, X, y) -> int:
    """The states of an ODE estimator, the features of any other."""
    return _n_states(estimator, X, y) if estimator.structure == "ode" else int(np.prod(np.shape(X)[1:]))
