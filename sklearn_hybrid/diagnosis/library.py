"""Library of named candidate terms for explaining a residual.

A :class:`CandidateLibrary` turns named variables (states, inputs, derivatives) into a matrix of named
candidate terms: monomials up to a degree, optional ``sin``/``cos``, non-smooth friction-like terms
(``sign(x)``, ``|x|``, ``x|x|``) and terms the user supplies by name. Each term can carry units so that
the equations found by :class:`~sklearn_hybrid.diagnosis.SparseTermRegression` read in physical units.
"""

from __future__ import annotations

import re
from collections.abc import Callable, Mapping, Sequence
from typing import Any

import numpy as np
from sklearn.base import BaseEstimator, TransformerMixin
from sklearn.preprocessing import PolynomialFeatures
from sklearn.utils.validation import check_is_fitted, validate_data

__all__ = ["CandidateLibrary"]

_SIMPLE_UNIT = re.compile(r"^[A-Za-z_]\w*$")


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


def _power_unit(unit: str, power: int) -> str:
    """Units of ``x**power`` for ``x`` in ``unit``; '' when dimensionless."""
    if unit in ("", "1") or power == 0:
        return ""
    if power == 1:
        return unit
    base = unit if _SIMPLE_UNIT.match(unit) else f"({unit})"
    return f"{base}^{power}"


def _product(parts: list[str]) -> str:
    parts = [p for p in parts if p]
    return "*".join(parts) if parts else "1"


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
    custom_terms : dict of str to callable, default=None
        Extra terms by name. Each callable gets the ``(n_samples, n_variables)`` data, which can be
        indexed by position (``Z[:, 0]``) or by variable name (``Z["v"]``), and returns
        ``n_samples`` finite values.
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

        self._poly = None
        if self.degree >= 1:
            self._poly = PolynomialFeatures(self.degree, interaction_only=self.interaction_only,
                                            include_bias=False).fit(Z)
        self._trig = _selected_variables(self.trigonometric, names, "trigonometric")
        self._nonsmooth = _selected_variables(self.nonsmooth, names, "nonsmooth")
        term_names, term_units = self._build_names(names)
        if not term_names:
            raise ValueError("The library has no terms: raise degree, set include_bias, or add terms.")
        duplicated = sorted({t for t in term_names if term_names.count(t) > 1})
        if duplicated:
            raise ValueError(f"Duplicate term names {duplicated}: rename the custom terms or variables.")
        self.term_names_ = np.asarray(term_names, dtype=object)
        self.term_units_ = None if self.units is None else np.asarray(term_units, dtype=object)
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
        names = list(self.variable_names_)
        col = {name: Z[:, i] for i, name in enumerate(names)}
        blocks = []
        if self.include_bias:
            blocks.append(np.ones((Z.shape[0], 1)))
        if self._poly is not None:
            blocks.append(self._poly.transform(Z))
        for v in self._trig:
            blocks.append(np.column_stack([np.sin(col[v]), np.cos(col[v])]))
        for v in self._nonsmooth:
            x = col[v]
            blocks.append(np.column_stack([np.sign(x), np.abs(x), x * np.abs(x)]))
        for term, func in (self.custom_terms or {}).items():
            blocks.append(self._evaluate_custom(term, func, Z, names))
        Theta = np.hstack(blocks) if blocks else np.empty((Z.shape[0], 0))
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

    def _build_names(self, names: list[str]) -> tuple[list[str], list[str]]:
        units = dict(self.units or {})
        u = {v: units.get(v, "") for v in names}
        term_names, term_units = [], []
        if self.include_bias:
            term_names.append("1")
            term_units.append("1")
        if self._poly is not None:
            for powers in self._poly.powers_:
                factors = [(v, int(p)) for v, p in zip(names, powers) if p > 0]
                term_names.append("*".join(v if p == 1 else f"{v}^{p}" for v, p in factors))
                term_units.append(_product([_power_unit(u[v], p) for v, p in factors]))
        for v in self._trig:
            term_names += [f"sin({v})", f"cos({v})"]
            term_units += ["1", "1"]
        for v in self._nonsmooth:
            term_names += [f"sign({v})", f"|{v}|", f"{v}|{v}|"]
            term_units += ["1", _product([_power_unit(u[v], 1)]), _product([_power_unit(u[v], 2)])]
        for term in self.custom_terms or {}:
            term_names.append(term)
            term_units.append(units.get(term, "?"))
        return term_names, term_units

    @staticmethod
    def _evaluate_custom(term: str, func: Callable, Z: np.ndarray, names: list[str]) -> np.ndarray:
        view = _NamedColumns(Z.copy(), names)  # a copy: user code must not be able to alter Z
        try:
            values = func(view)
        except Exception as exc:
            raise ValueError(f"custom term {term!r} failed on the data: {exc!r}. It receives an array "
                             "indexable as Z[:, j] or Z['name'].") from exc
        values = np.asarray(values, dtype=np.float64)
        if values.ndim == 2 and values.shape[1] == 1:
            values = values[:, 0]
        if values.shape != (Z.shape[0],):
            raise ValueError(f"custom term {term!r} returned shape {values.shape}; expected ({Z.shape[0]},).")
        return values[:, None]
