"""Term families: which candidate terms to offer, chosen from the states, their units and the data.

A family is an object with a ``name`` and one method, ``terms(context)``, which returns the
:class:`~sklearn_hybrid.diagnosis.Term` objects it offers for a :class:`TermContext` (the variables,
their units, where they were visited and, for a family that reads it, what the network learned).
Today's kinds of terms are the families of :data:`TERM_FAMILIES` (``physics.py``), consulted at one
site, :func:`physics_terms`, by the closed loop and by your own code; symbolic regression on what the
network learned is one more family (:class:`SymbolicDiscovery`, ``discovery.py``), which the closed
loop runs where you ask for it (``Candidates(discovery=...)``).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence

import numpy as np
import torch

from ..terms import TERM_KINDS, Term
from .base import TermContext, TermFamily, VariableFamily
from .discovery import SymbolicDiscovery
from .physics import PHYSICS_FAMILIES

__all__ = ["TermContext", "TermFamily", "VariableFamily", "TERM_FAMILIES", "physics_terms", "SymbolicDiscovery"]

#: Today's kinds of terms by name, in the order the library lists them (the ranking breaks ties by it).
TERM_FAMILIES: dict[str, TermFamily] = {f.name: f for f in PHYSICS_FAMILIES}


def physics_terms(variables: Sequence[str], values: np.ndarray, units: Mapping[str, str] | None = None,
                  kinds: Sequence[str] | None = None, user_terms: Mapping[str, Callable] | None = None,
                  positive: Sequence[str] = (), scaled: Mapping[int, str] | None = None,
                  n_states: int | None = None) -> list[Term]:
    """The default candidate library over the named variables.

    Parameters
    ----------
    variables : list of str
        Variable names (states, then inputs).
    values : ndarray of shape (n_points, n_variables)
        Where the variables were visited; sets the starting grids (scales, quantiles for knots).
    units : dict of str to str, optional
        Units of the variables (for the report). A variable whose unit is an angle (``"rad"``,
        ``"deg"``, ``"0.1 rad"``) also gets its harmonics ``sin(n a + phase)`` (kind ``"periodic"``).
    kinds : list of str, optional
        Kinds to include (default all of ``TERM_KINDS``).
    user_terms : dict of str to callable, optional
        Your own terms by name: ``f(d) -> Tensor`` with ``d`` mapping variable names to tensors.
    positive : list of str, optional
        Variables that are never negative (levels, concentrations): no hinge below zero for them.
    scaled : dict of int to str, optional
        Output components whose science output may vary with a state or an input, with their
        labels (``{1: "v"}``): terms ``f[v]*x`` and ``f[v]*x^2`` for every state ``x`` and ``f[v]*u``
        for every input ``u`` (kind ``"scaled"``), each placed on its own component only. Default
        none: the terms need the science output, which only the augmented science model and the
        selection provide.
    n_states : int, optional
        How many of ``variables`` are states (the rest are inputs, which scale an output linearly
        only); default all.

    Returns
    -------
    list of Term
    """
    if isinstance(kinds, str):  # a string is a sequence of letters, none of them a kind
        raise ValueError(f"kinds must be a list of term kinds, got the string {kinds!r}; write [{kinds!r}].")
    kinds = list(TERM_KINDS if kinds is None else kinds)
    unknown = sorted(set(kinds) - set(TERM_KINDS))
    if unknown:
        raise ValueError(f"Unknown term kinds {unknown}; choose from {list(TERM_KINDS)}.")
    variables = list(variables)
    if len(set(variables)) < len(variables):
        raise ValueError(f"variables must have distinct names, got {variables}.")
    units = dict(units or {})
    values = np.asarray(values, dtype=float)
    if values.ndim == 1 and len(variables) == 1:
        values = values[:, None]
    if values.ndim != 2 or values.shape[1] != len(variables) or len(values) == 0:
        raise ValueError(f"values must hold the {len(variables)} variables {variables} at one point or more, "
                         f"shape (n_points, {len(variables)}); got shape {values.shape}.")
    if not np.all(np.isfinite(values)):
        raise ValueError("values holds NaN or infinite entries: the starting grids (scales, knots) come from them.")
    n_states = len(variables) if n_states is None else n_states
    if isinstance(n_states, bool) or not isinstance(n_states, (int, np.integer)) or not 0 <= n_states <= len(variables):
        raise ValueError(f"n_states must be an integer in [0, {len(variables)}] (how many of {variables} are states), "
                         f"got {n_states!r}.")
    scaled = dict(scaled or {})
    bad = [j for j in scaled if isinstance(j, bool) or not isinstance(j, (int, np.integer)) or j < 0]
    if bad:
        raise ValueError(f"scaled maps output components (non-negative integer indices) to labels; got keys {bad}.")
    context = TermContext(tuple(variables), values, units, n_states, frozenset(positive), scaled)
    chosen = [family for name, family in TERM_FAMILIES.items() if name in kinds]
    terms: list[Term] = [t for f in chosen if not isinstance(f, VariableFamily) for t in f.terms(context)]
    for i in range(len(variables)):  # variable by variable, as the library has always listed them
        terms += [t for f in chosen if isinstance(f, VariableFamily) for t in f.terms_of(context, i)]
    if user_terms and "user" not in kinds:
        raise ValueError(f"user_terms {list(user_terms)} given, but kinds {kinds} leaves out 'user'.")
    taken = {t.name for t in terms} | set(variables)
    for name, func in (user_terms or {}).items():
        if not callable(func):
            raise TypeError(f"user term {name!r} is not callable.")
        if name in taken:
            raise ValueError(f"user term {name!r} has the name of a variable or a built-in term; rename it.")
        _check_user_term(name, func, variables, values)
        terms.append(Term(name, func, "user", unit=units.get(name, "")))
    return terms


def _check_user_term(name: str, func: Callable, variables: Sequence[str], values: np.ndarray) -> None:
    """The term is called as the selection will call it: on a dict of float64 tensors, one per
    variable, returning one value per point (or one for all)."""
    d = {v: torch.as_tensor(values[:, i].copy()) for i, v in enumerate(variables)}
    try:
        out = func(d)
    except Exception as exc:
        hint = f" The variables are {list(variables)}." if isinstance(exc, KeyError) else ""
        raise ValueError(f"user term {name!r} raised {type(exc).__name__}: {exc}.{hint} It receives a dict of "
                         "torch tensors by variable name and must use torch operations.") from exc
    if not torch.is_tensor(out) or out.shape not in ((), (len(values),)):
        got = tuple(out.shape) if torch.is_tensor(out) else type(out).__name__
        raise ValueError(f"user term {name!r} returned {got} for {len(values)} points; it must return a torch "
                         f"tensor of shape ({len(values)},).")
