"""Checks of :func:`~sklearn_hybrid.diagnosis.close_the_loop`'s arguments, made before anything is fitted.

Each names the problem: an unknown state, an option out of range, a unit for a variable that does not exist.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from difflib import get_close_matches
from typing import Any

import numpy as np
from sklearn.exceptions import NotFittedError
from sklearn.utils.validation import check_is_fitted

from ..._fitting import ode_structure
from ..._validation import check_not_nested
from ...science import read_signature
from ..._probe import check_finite_model
from ..sensitivity import exact_components, parameter_jacobian, science_output, state_labels
from .report import rate_shares


def check_options(n_jobs, X_test, y_test) -> None:
    """The options of ``close_the_loop`` that belong to no settings object."""
    if n_jobs is not None and (isinstance(n_jobs, bool) or not isinstance(n_jobs, (int, np.integer)) or n_jobs == 0):
        raise ValueError(f"n_jobs must be None or a non-zero integer (joblib's convention), got {n_jobs!r}.")
    if (X_test is None) != (y_test is None):
        raise ValueError("X_test and y_test go together: give both, or neither.")


def check_refit_params(estimator, refit_params) -> None:
    """``refit_params`` are ``set_params`` keys of the estimator, checked now rather than after the selection."""
    keys = set(refit_params or {})
    owned = sorted(keys & {"science", "theta_init"})  # the loop sets these itself for the refit
    if owned:
        raise ValueError(f"refit_params may not set {owned}: the refit takes the augmented science model and "
                         "starts theta from its network-free fit.")
    unknown = sorted(keys - set(estimator.get_params(deep=True)))
    if unknown:
        raise ValueError(f"refit_params names {unknown}, which are not parameters of {type(estimator).__name__} "
                         f"(see its get_params()).")


def check_param_names(param_names, term_names) -> None:
    """Each key of ``param_names`` names a candidate term, each value a valid parameter name."""
    unknown = [k for k in (param_names or {}) if k not in term_names]
    if unknown:
        close = sorted({m for k in unknown for m in get_close_matches(str(k), sorted(term_names), n=3)})
        raise ValueError(f"param_names names {unknown}, which are no candidate terms"
                         + (f"; close ones: {close}." if close else f" (e.g. {sorted(term_names)[:8]})."))
    invalid = [v for v in (param_names or {}).values() if not isinstance(v, str) or not v.isidentifier()]
    if invalid:
        raise ValueError(f"param_names must map terms to valid Python identifiers, got {invalid}.")


def uncertain_components(estimator, X, y, exact, state_names) -> list[int] | None:
    """Output components that may receive terms (None: all of them)."""
    ode = ode_structure(estimator)
    if exact is None or ode is None:
        return None
    X, y = np.asarray(X, dtype=float), np.asarray(y)
    n_inputs = ode.n_inputs
    d = count_states(estimator, X, y)
    if isinstance(exact, str):
        if exact != "auto":
            raise ValueError(f"exact must be 'auto', None or a list of state names or indices, got {exact!r}.")
        theta = getattr(estimator, "theta_", None) or {**read_signature(estimator.science)[1],
                                                       **dict(estimator.theta_init or {})}
        sample = X[: min(len(X), 64)]
        args = [sample[:, :d]] + ([sample[:, d:d + n_inputs]] if n_inputs else [])
        # a science that is not finite here has no derivatives to read: say so, rather than call every
        # equation exact (NaN derivatives are no dependence on a parameter)
        name = getattr(estimator.science, "__name__", "science")
        check_finite_model(science_output(estimator.science, theta, args), name, theta,
                           "outputs at the data's first states")
        jac, names = parameter_jacobian(estimator.science, theta, args)
        check_finite_model(jac, name, theta, "derivatives by theta at the data's first states")
        # an equation whose only parameters are fixed (theta_fixed) has nothing to estimate either
        fixed = exact_components(jac, names, set(estimator.theta_fixed or ()))
        if fixed is None:
            return None
        if fixed:  # the network's shares once, not once per equation
            learned = learned_equations(estimator, X)
            fixed = [j for j in fixed if j not in learned]
    else:
        fixed = _state_indices(exact, state_labels(state_names, d, "x", "state_names"), "exact")
    uncertain = [j for j in range(d) if j not in fixed]
    if not uncertain:
        raise ValueError("Every component is exact: there is nothing for the network or the diagnosis to do.")
    return uncertain if fixed else None


#: The share of an equation's rate that a fitted hybrid's network must carry for exact="auto" to take a
#: parameter-free equation as a model missing an effect (a tank fed with no outlet written), not a definition:
#: on a definition (d angle/dt = velocity) the network fits noise, a share of about 1 %.
LEARNED_SHARE = 0.2


def learned_equations(estimator, X) -> list[int]:
    """The equations on which a fitted hybrid's network carries at least ``LEARNED_SHARE`` of the rate; none
    for an estimator not yet fitted (its network is placed by ``exact`` then)."""
    try:
        check_is_fitted(estimator, "model_")
    except NotFittedError:
        return []
    shares = rate_shares(estimator, X)
    return [] if shares is None else [j for j, share in enumerate(shares) if share >= LEARNED_SHARE]


def offset_states(estimator, X, y, offsets, state_names) -> list[int]:
    """Indices of the states named in ``offsets``; in an ODE only measured states can have a sensor offset."""
    names = state_labels(state_names, _n_variables(estimator, X, y), "x", "state_names")
    out = _state_indices([offsets] if isinstance(offsets, (str, int)) else offsets, names, "offsets")
    ode = ode_structure(estimator)
    observed = None if ode is None else ode.observed
    unmeasured = [names[j] for j in out if observed is not None and j not in observed]
    if unmeasured:
        raise ValueError(f"offsets names {unmeasured}, not measured (observed={observed}): an offset "
                         "on an unmeasured state only relabels its initial value.")
    if len(set(out)) < len(out):
        raise ValueError(f"offsets lists a state twice: {list(offsets)}.")
    return out


def check_names(estimator, X, y, state_names, input_names, units, user_terms,
                 positive) -> tuple[list[str], np.ndarray]:
    """Every name an option gives must name something, and no two things one name: a misspelt name
    would lose its unit or its positivity silently, and a shared one would label a term with the
    wrong variable. Returns the variable names (states, then inputs) and their values in ``X``
    (the initial states and first inputs), for checking the candidate terms before any fit."""
    X = np.asarray(X, dtype=float)
    ode = ode_structure(estimator)
    n_inputs = 0 if ode is None else ode.n_inputs
    n = _n_variables(estimator, X, y)
    if input_names is not None and not n_inputs:
        raise ValueError(f"input_names {list(input_names)} given, but the estimator has no inputs "
                         f"(n_inputs={n_inputs}, structure={estimator.structure!r}).")
    variables = (state_labels(state_names, n, "x", "state_names")
                 + (state_labels(input_names, n_inputs, "u", "input_names") if n_inputs else []))
    names = variables + list(user_terms or {})
    twice = sorted({name for name in names if names.count(name) > 1})
    if twice:
        raise ValueError(f"{twice} name(s) more than one of the states, inputs and user terms {names}; "
                         "each needs its own name.")
    for option, given, known in (("units", units, names), ("positive", positive, variables)):
        unknown = [k for k in (given or ()) if k not in known]
        if unknown:
            raise ValueError(f"{option} names {unknown}, which the model does not have; the names are {known}.")
    flat = X.reshape(len(X), -1)
    return variables, flat[:, :n + n_inputs]


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


def count_states(estimator, X, y) -> int:
    """States of an ODE estimator's ``X``: its columns less the packed inputs (one per output time and 0)."""
    X, y = np.asarray(X), np.asarray(y)
    ode = ode_structure(estimator)
    n_inputs = 0 if ode is None else ode.n_inputs
    return X.shape[1] - (y.shape[1] + 1) * n_inputs if n_inputs else int(np.prod(X.shape[1:]))


def _n_variables(estimator, X, y) -> int:
    """The states of an ODE estimator, the features of any other."""
    return count_states(estimator, X, y) if ode_structure(estimator) is not None else int(np.prod(np.shape(X)[1:]))


def settings_object(name: str, value: Any, cls: type, example: str) -> Any:
    """A settings object of ``close_the_loop`` (``Evidence``, ``Candidates``): the default for None, checked."""
    value = cls() if value is None else value
    if not isinstance(value, cls):
        raise TypeError(f"{name} must be a {cls.__name__} object (sklearn_hybrid.diagnosis.{example}), got "
                        f"{type(value).__name__}.")
    value.check()
    return value


#: Keywords of close_the_loop that moved into its settings objects: name -> (class, its field).
MOVED = {**{name: ("Evidence", name) for name in ("validation_fraction", "cv", "second_look", "groups", "z",
                                                  "min_gain")},
         **{name: ("Candidates", name) for name in ("terms", "kinds", "user_terms", "positive", "max_terms",
                                                     "n_candidates")},
         "term_kinds": ("Candidates", "kinds")}


def refuse_moved(moved: Mapping[str, Any], known: Sequence[str]) -> None:
    """Say where each keyword that moved into ``Evidence`` / ``Candidates`` went (Python's own
    TypeError for any other unknown keyword)."""
    unknown = [name for name in moved if name not in MOVED]
    if unknown:
        close = get_close_matches(unknown[0], known, n=1)
        raise TypeError(f"close_the_loop() got an unexpected keyword argument {unknown[0]!r}"
                        + (f"; did you mean {close[0]!r}?" if close else ""))
    lines = []
    for cls in ("Evidence", "Candidates"):
        names = [name for name in moved if MOVED[name][0] == cls]
        if names:
            shown = ", ".join(f"{MOVED[name][1]}={short_repr(moved[name])}" for name in names)
            lines.append(f"{' and '.join(names)} moved into {cls}: close_the_loop(..., {cls.lower()}={cls}({shown}))")
    raise TypeError("; ".join(lines) + " (from sklearn_hybrid.diagnosis).")


def short_repr(value: Any) -> str:
    text = repr(value)
    return text if len(text) <= 30 and "\n" not in text else "..."


def check_targets(X: Any, y: Any, X_test: Any, y_test: Any, test_scorer: Callable | None) -> None:
    """Refuse what would fail deep inside a refit or the scoring: y or y_test not finite, y_test of
    other states or steps (without a ``test_scorer``, y_test is scored against the predictions).

    The arguments are read, never changed: what the estimator is given stays the caller's.
    """
    y = np.atleast_1d(np.asarray(check_not_nested(y), dtype=float))
    tested = [("y", X, y)]
    scored = y_test is not None and test_scorer is None
    if scored:
        tested.append(("y_test", X_test, np.atleast_1d(np.asarray(check_not_nested(y_test, "y_test"), dtype=float))))
    for name, X_, values in tested:
        bad = ~np.isfinite(values.reshape(len(values), -1)).all(axis=1)
        if np.any(bad):
            raise ValueError(f"{name} is not finite: sample(s) {np.flatnonzero(bad)[:5].tolist()} hold NaN or "
                             "infinite values, which no least-squares refit can match. Drop them: keep = "
                             f"np.isfinite({name}).reshape(len({name}), -1).all(axis=1).")
        if len(values) != len(X_):
            raise ValueError(f"{name} has {len(values)} samples and {name.replace('y', 'X')} {len(X_)}.")
    if scored:
        shape, test_shape = y.shape[1:], tested[1][2].shape[1:]
        if test_shape != shape and test_shape != (math.prod(shape),):
            raise ValueError(f"y_test has per-sample shape {test_shape}; y has {shape}: the test data must hold the "
                             "same observed components over the same steps as y (for a longer horizon, "
                             "give test_scorer, a function of the fitted estimator that runs est.simulate).")


def check_fitted_horizon(estimator: Any, y: Any) -> None:
    """A fitted estimator predicts y's per-sample shape of its fit: refuse another (torch would say
    only that a shape is invalid, deep inside a refit)."""
    fitted = getattr(estimator, "y_shape_", None)
    if fitted is None or not hasattr(estimator, "model_"):
        return
    shape = tuple(np.shape(y)[1:])
    if shape != tuple(fitted) and shape != (math.prod(fitted),):
        raise ValueError(f"y has per-sample shape {shape}; the estimator was fitted on y of per-sample shape "
                         f"{tuple(fitted)}. Close the loop on data of the fitted horizon, or pass an unfitted "
                         "estimator (sklearn.base.clone(est)), which close_the_loop fits on these data.")
