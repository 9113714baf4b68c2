"""Library of named candidate terms for explaining a residual.

A :class:`CandidateLibrary` turns named variables (states, inputs, derivatives) into a matrix of named
candidate terms: monomials up to a degree, optional ``sin``/``cos``, non-smooth friction-like terms
(``sign(x)``, ``|x|``, ``x|x|``) and terms the user supplies by name. Each term can carry units so that
the equations found by :class:`~sklearn_hybrid.diagnosis.SparseTermRegression` read in physical units.
The columns are :class:`~sklearn_hybrid.diagnosis.Term` objects (``terms_``), the closed loop's own
vocabulary, so that a term the regression selects is added to a science function as it is.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from functools import partial
from typing import Any

import numpy as np
import torch
from sklearn.base import BaseEstimator, TransformerMixin
from sklearn.utils.validation import check_is_fitted, validate_data

from ..terms import Term, constant_term, monomial_terms, nonsmooth_terms, trigonometric_terms

__all__ = ["CandidateLibrary", "numpy_term"]


class _NamedColumns(np.ndarray):
    """2-D float array whose columns can also be read by variable name (``Z["v"]``).

    Custom terms receive this view, so a callable written either as ``lambda Z: Z[:, 0]`` or as
    ``lambda d: d["v"]`` works without the user saying which convention it follows.
    """

    def __new__(cls, Z: np.ndarray, names: Sequence[str]) -> "_NamedColumns":
        obj = np.asarray(Z).view(cls)
        obj._names = {name: i for i, name in enumerate(names)}
        return obj

    def __array_finalize__(self, obj: Any) -> None:
        self._names = getattr(obj, "_names", {})

    def __getitem__(self, key: Any) -> Any:
        if isinstance(key, str):
            if key not in self._names:
                raise KeyError(f"Unknown variable {key!r}; known variables: {list(self._names)}.")
            return np.asarray(self)[:, self._names[key]]
        return super().__getitem__(key)

    def keys(self) -> list[str]:
        return list(self._names)


def numpy_term(d: Mapping[str, torch.Tensor], func: Callable, name: str, names: Sequence[str]) -> torch.Tensor:
    """A user's numpy term as a :class:`Term`'s function: ``func`` gets the variables as one array
    indexable as ``Z[:, j]`` or ``Z["name"]`` (a copy: it cannot alter the caller's data).

    Computed in numpy, it carries no derivative by the state: in an augmented ODE it enters as a
    known function of the visited states; write it with torch operations (a ``Term``) where the
    refit needs derivatives through it.
    """
    first = d[names[0]]
    Z = np.column_stack([d[v].detach().cpu().numpy().astype(np.float64, copy=False).reshape(-1) for v in names])
    try:
        values = func(_NamedColumns(Z.copy(), names))
    except Exception as exc:
        raise ValueError(f"custom term {name!r} failed on the data: {exc!r}. It receives an array "
                         "indexable as Z[:, j] or Z['name'].") from exc
    values = np.asarray(values, dtype=np.float64)
    if values.ndim == 2 and values.shape[1] == 1:
        values = values[:, 0]
    if values.shape != (len(Z),):
        raise ValueError(f"custom term {name!r} returned shape {values.shape}; expected ({len(Z)},).")
    return torch.as_tensor(values, dtype=first.dtype, device=first.device).reshape(first.shape)


def _selected_variables(option: bool | Sequence[str], names: list[str], label: str) -> list[str]:
    """Resolve a ``bool`` or list-of-names option to the variables it applies to."""
    if isinstance(option, (bool, np.bool_)):
        return list(names) if option else []
    if isinstance(option, str):
        option = [option]
    unknown = [v for v in option if v not in names]
    if unknown:
        raise ValueError(f"{label} names unknown variables {unknown}; known variables: {names}.")
    return list(option)


class CandidateLibrary(TransformerMixin, BaseEstimator):
    """Named candidate terms built from named variables.

    Parameters
    ----------
    degree : int, default=3
        Highest total degree of the monomials (products and powers of the variables). ``0`` keeps
        no monomial except the constant (when ``include_bias``).
    include_bias : bool, default=True
        Add the constant term, named ``"1"``. The sparse regression decides whether an offset is needed.
    interaction_only : bool, default=False
        Keep only products of distinct variables (no ``x^2``), as in ``PolynomialFeatures``.
    trigonometric : bool or list of str, default=False
        Add ``sin(x)`` and ``cos(x)`` for every variable (``True``) or for the variables named.
    nonsmooth : bool or list of str, default=False
        Add ``sign(x)``, ``|x|`` and ``x|x|`` (dry friction, quadratic drag) for every variable
        (``True``) or for the variables named.
    custom_terms : dict of str to callable or Term, default=None
        Extra terms by name. A callable gets the ``(n_samples, n_variables)`` data, which can be
        indexed by position (``Z[:, 0]``) or by variable name (``Z["v"]``), and returns
        ``n_samples`` finite values (numpy: it enters an augmented ODE without derivatives by the
        state). A :class:`~sklearn_hybrid.diagnosis.Term` is a torch function of the variables by name.
    units : dict of str to str, default=None
        Units of every variable (and optionally of custom terms), e.g. ``{"theta": "rad",
        "omega": "rad/s"}``. Term units are then derived, e.g. ``"rad*rad/s"``; a custom term without
        an entry gets ``"?"``.

    Attributes
    ----------
    n_features_in_ : int
        Number of variables seen in :meth:`fit`.
    variable_names_ : ndarray of str
        Names of the variables.
    feature_names_in_ : ndarray of str
        Column names, set only when ``Z`` was a DataFrame (scikit-learn convention).
    terms_ : list of Term
        The candidate terms, in column order of :meth:`transform`: each evaluates its column and
        can be added to a science function (:func:`~sklearn_hybrid.diagnosis.augment_science`).
    term_names_ : ndarray of str
        Names of the candidate terms, in column order of :meth:`transform`.
    term_units_ : ndarray of str or None
        Units of each term, or ``None`` when ``units`` was not given.
    n_terms_ : int
        Number of candidate terms.

    Examples
    --------
    >>> import numpy as np
    >>> lib = CandidateLibrary(degree=2, include_bias=False, units={"x": "m", "v": "m/s"})
    >>> Theta = lib.fit_transform(np.ones((4, 2)), feature_names=["x", "v"])
    >>> list(lib.get_feature_names_out())
    ['x', 'v', 'x^2', 'x*v', 'v^2']
    >>> list(lib.term_units_)
    ['m', 'm/s', 'm^2', 'm*m/s', '(m/s)^2']
    """

    def __init__(
        self,
        degree: int = 3,
        include_bias: bool = True,
        interaction_only: bool = False,
        trigonometric: bool | Sequence[str] = False,
        nonsmooth: bool | Sequence[str] = False,
        custom_terms: Mapping[str, Callable] | None = None,
        units: Mapping[str, str] | None = None,
    ) -> None:
        self.degree = degree
        self.include_bias = include_bias
        self.interaction_only = interaction_only
        self.trigonometric = trigonometric
        self.nonsmooth = nonsmooth
        self.custom_terms = custom_terms
        self.units = units

    def fit(self, Z: Any, y: Any = None, *, feature_names: Sequence[str] | None = None) -> "CandidateLibrary":
        """Record the variable names and build the list of named terms.

        Parameters
        ----------
        Z : array-like of shape (n_samples, n_variables)
            Values of the variables (a DataFrame's columns name them).
        y : None
            Ignored; present for pipeline compatibility.
        feature_names : list of str, default=None
            Names of the variables (keyword only). Defaults to the DataFrame's columns, else ``x0, x1, ...``.

        Returns
        -------
        self : CandidateLibrary
        """
        if feature_names is None and isinstance(y, (list, tuple)) and y and all(isinstance(v, str) for v in y):
            raise TypeError("Pass the variable names as fit(Z, feature_names=[...]), not positionally.")
        Z = validate_data(self, Z, reset=True, dtype=np.float64, ensure_min_samples=1)
        names = self._resolve_names(feature_names, Z.shape[1])
        self.variable_names_ = np.asarray(names, dtype=object)
        self._check_params(names)

        trig = _selected_variables(self.trigonometric, names, "trigonometric")
        nonsmooth = _selected_variables(self.nonsmooth, names, "nonsmooth")
        terms = self._build_terms(names, trig, nonsmooth)
        if not terms:
            raise ValueError("The library has no terms: raise degree, set include_bias, or add terms.")
        term_names = [t.name for t in terms]
        duplicated = sorted({t for t in term_names if term_names.count(t) > 1})
        if duplicated:
            raise ValueError(f"Duplicate term names {duplicated}: rename the custom terms or variables.")
        self.terms_ = terms
        self.term_names_ = np.asarray(term_names, dtype=object)
        self.term_units_ = None if self.units is None else np.asarray([self._unit(t) for t in terms], dtype=object)
        self.n_terms_ = len(term_names)
        # Evaluate once so a broken custom term fails at fit, not later.
        self._evaluate(Z)
        return self

    def transform(self, Z: Any) -> np.ndarray:
        """Evaluate every candidate term.

        Parameters
        ----------
        Z : array-like of shape (n_samples, n_variables)
            Values of the variables, in the order seen in :meth:`fit`.

        Returns
        -------
        Theta : ndarray of shape (n_samples, n_terms)
            Candidate terms, columns named by :meth:`get_feature_names_out`.
        """
        check_is_fitted(self, "term_names_")
        return self._evaluate(validate_data(self, Z, reset=False, dtype=np.float64))

    def _evaluate(self, Z: np.ndarray) -> np.ndarray:
        # copies: a term cannot alter the caller's data
        d = {name: torch.tensor(Z[:, i]) for i, name in enumerate(self.variable_names_)}
        with torch.no_grad():
            columns = [np.broadcast_to(term(d).numpy(), (len(Z),)) for term in self.terms_]
        Theta = np.column_stack(columns) if columns else np.empty((len(Z), 0))
        bad = ~np.all(np.isfinite(Theta), axis=0)
        if bad.any():
            raise ValueError(f"Terms {list(self.term_names_[bad])} are not finite on these data.")
        return Theta

    def get_feature_names_out(self, input_features: Sequence[str] | None = None) -> np.ndarray:
        """Names of the candidate terms.

        Parameters
        ----------
        input_features : list of str, default=None
            If given, must equal the variable names seen in :meth:`fit`.

        Returns
        -------
        names : ndarray of str
        """
        check_is_fitted(self, "term_names_")
        if input_features is not None and list(input_features) != list(self.variable_names_):
            raise ValueError(f"input_features {list(input_features)} differ from the variables seen in fit "
                             f"{list(self.variable_names_)}.")
        return self.term_names_.copy()

    # ------------------------------------------------------------------ helpers
    def _resolve_names(self, feature_names: Sequence[str] | None, n_variables: int) -> list[str]:
        seen = getattr(self, "feature_names_in_", None) if hasattr(self, "n_features_in_") else None
        if feature_names is None:
            # validate_data sets feature_names_in_ only for a DataFrame; fall back to x0, x1, ...
            return [str(c) for c in seen] if seen is not None else [f"x{i}" for i in range(n_variables)]
        names = [feature_names] if isinstance(feature_names, str) else list(feature_names)
        if len(names) != n_variables:
            raise ValueError(f"feature_names has {len(names)} names but Z has {n_variables} columns.")
        if not all(isinstance(n, str) and n for n in names):
            raise ValueError("feature_names must be non-empty strings.")
        if len(set(names)) != len(names):
            raise ValueError(f"feature_names must be unique, got {names}.")
        if seen is not None and [str(c) for c in seen] != names:
            raise ValueError(f"feature_names {names} differ from the DataFrame columns {list(seen)}.")
        return names

    def _check_params(self, names: list[str]) -> None:
        if isinstance(self.degree, bool) or not isinstance(self.degree, (int, np.integer)) or self.degree < 0:
            raise ValueError(f"degree must be a non-negative integer, got {self.degree!r}.")
        custom = self.custom_terms or {}
        if not isinstance(custom, Mapping):
            raise TypeError("custom_terms must be a dict mapping term names to callables.")
        for term, func in custom.items():
            if not isinstance(term, str) or not term:
                raise ValueError(f"custom term names must be non-empty strings, got {term!r}.")
            if not callable(func):
                raise TypeError(f"custom term {term!r} is not callable.")
            if isinstance(func, Term) and func.shape:
                raise ValueError(f"custom term {term!r} has shape parameters {list(func.shape)}, which a library "
                                 "column cannot fit; fix their values in the function.")
        if self.units is not None:
            if not isinstance(self.units, Mapping):
                raise TypeError("units must be a dict mapping variable names to unit strings.")
            unknown = [k for k in self.units if k not in names and k not in custom]
            if unknown:
                raise ValueError(f"units names unknown variables or terms {unknown}; variables: {names}.")
            missing = [v for v in names if v not in self.units]
            if missing:
                raise ValueError(f"units gives no units for variables {missing}.")
            if not all(isinstance(u, str) for u in self.units.values()):
                raise TypeError("units values must be strings such as 'rad/s' ('' or '1' if dimensionless).")

    def _build_terms(self, names: list[str], trig: list[str], nonsmooth: list[str]) -> list[Term]:
        units = dict(self.units or {})
        terms = [constant_term()] if self.include_bias else []
        terms += monomial_terms(names, self.degree, units, self.interaction_only)
        for v in trig:
            terms += trigonometric_terms(v)
        for v in nonsmooth:
            terms += nonsmooth_terms(v, units.get(v, ""))
        for name, func in (self.custom_terms or {}).items():
            if isinstance(func, Term):  # a torch term: enters an augmented ODE with its derivatives
                terms.append(Term(name, func.func, "user", unit=func.unit))
            else:
                terms.append(Term(name, partial(numpy_term, func=func, name=name, names=tuple(names)), "user"))
        return terms

    def _unit(self, term: Term) -> str:
        """The unit shown for a term: ``"1"`` when dimensionless, ``"?"`` for a custom term without one."""
        if term.kind == "user":
            return (self.units or {}).get(term.name, term.unit or "?")
        return term.unit or "1"
