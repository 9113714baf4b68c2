"""Turn terms found by the residual diagnosis into a new science function with new parameters.

The new function calls the original one (with the original parameters) and adds, to the chosen
output components, ``c * term`` with one new named parameter ``c`` per term; a sensor offset
(kind ``"offset"``) instead evaluates the whole right-hand side at the measured state less a new
parameter (the model's state is then the sensor's reading). It has a proper
signature (``inspect.signature`` shows every parameter with its initial value as default), so
:class:`~sklearn_hybrid.HybridRegressor` reads and estimates the old and the new parameters alike,
and it pickles (an :class:`AugmentedScience` whose term functions are module-level functions
bound with ``functools.partial``), so that a fitted estimator holding it can be saved.
"""

from __future__ import annotations

import inspect
import re
from collections.abc import Callable, Mapping, Sequence
from typing import Any

import numpy as np
import torch

from ..science import read_signature
from .terms import SCIENCE_OUTPUT, Term, TermVariables, named_terms

__all__ = ["augment_science", "AugmentedScience", "parameter_name"]


def _flat(x: torch.Tensor, single: bool = False) -> torch.Tensor:
    """``x`` as (batch, columns); no operation when it already is. A 1-D ``x`` is a batch of scalars
    (a static model's output), or with ``single`` one sample (a state handed over by ``solve_ivp``,
    which the original science function reads as such: ``v[..., 1]``)."""
    if x.ndim == 2:
        return x
    return x.reshape(1, -1) if single and x.ndim == 1 else x.reshape(len(x), -1)


def parameter_name(term: str, taken: Sequence[str], suffix: str = "", prefix: str = "c") -> str:
    """A valid, unused parameter name for the coefficient of ``term`` (``"v^3"`` -> ``"c_v3"``).

    ``prefix`` names other parameters of the term, e.g. ``"w"`` for the width of dry friction.
    """
    text = re.sub(r"\|(\w+)\|", r"_abs_\1_", term)
    text = re.sub(r"\[(\w+)\]", r"_\1", text).replace("^", "").replace("*", "_")  # "f[v]*x" -> "f_v_x"
    text = re.sub(r"\W+", "_", text).strip("_") or "term"
    base = f"{prefix}_{text}" + (f"_{suffix}" if suffix else "")
    name, i = base, 2
    while name in taken:
        name, i = f"{base}_{i}", i + 1
    return name


def augment_science(science: Callable, terms: Sequence[Mapping[str, Any]], variable_names: Sequence[str], *,
                    n_states: int | None = None, theta: Mapping[str, Any] | None = None,
                    name: str | None = None) -> AugmentedScience:
    """Build ``science + sum_i c_i * term_i`` as a new science function with named parameters.

    Parameters
    ----------
    science : callable
        The original science function ``f(*inputs, **theta)``.
    terms : list of dict
        Each with ``"component"`` (index of the output component the term is added to), ``"term"``
        (a :class:`~sklearn_hybrid.diagnosis.Term`, or the name of a term without shape parameters:
        ``"1"``, a monomial such as ``"v^2*v_dot"``, ``"sin(v)"``, ``"cos(v)"``, ``"sign(v)"``,
        ``"|v|"``, ``"v|v|"``, ``"sqrt|v|"``; see :func:`~sklearn_hybrid.diagnosis.named_terms`) and
        ``"coef"`` (initial value of its new parameter), as in :attr:`ResidualDiagnosis.new_terms_`;
        an optional ``"param"`` names the parameter. A term may bring its torch ``"function"``
        ``f(d, **shape)`` (a Term's, where ``"term"`` is only its name) with initial ``"shape"``
        values (each a new parameter named ``<shape>_<label>``), and a ``"label"`` for the parameter
        names (default the term's name). An entry of ``"kind"`` ``"offset"`` is a sensor offset on
        state ``"component"`` (a column of the first input): the right-hand side, original and added
        terms alike, sees ``x[component] - offset``, with ``"coef"`` the offset's initial value
        (parameter ``offset_<state>``). Terms with the same ``"shape_group"`` label share their shape
        parameters: the first of them makes them (from its ``"shape"``), the others read them.
    variable_names : list of str
        Names of the columns of the first input (the state or the features), then of the second
        input (the measured inputs of a forced ODE), if any.
    n_states : int, optional
        Number of columns of the first input; default: all names when the function has one input.
    theta : dict, optional
        Initial values of the original parameters (e.g. a fitted ``theta_``); default their defaults.
    name : str, optional
        ``__name__`` of the new function; default ``<original>_augmented``.

    Returns
    -------
    AugmentedScience
        The augmented science function; ``.terms`` lists ``(component, term, parameter)`` and
        ``.equation`` reads the added part. It pickles when ``science`` and the term functions do
        (module-level functions; the library's terms are).
    """
    inputs, defaults = read_signature(science)
    if len(inputs) not in (1, 2):
        raise ValueError(f"The science function has inputs {inputs}; augmentation handles one or two.")
    variable_names = list(variable_names)
    if n_states is None:
        if len(inputs) == 2:
            raise ValueError("With a forced science function f(v, u) give n_states (columns of v).")
        n_states = len(variable_names)
    theta = dict(theta or {})
    unknown = sorted(set(theta) - set(defaults))
    if unknown:
        raise ValueError(f"theta names unknown parameter(s) {unknown}; the science function has {sorted(defaults)}.")
    values = {k: theta.get(k, v) for k, v in defaults.items()}
    values = {k: float(v) if np.ndim(v) == 0 else np.asarray(v, float).tolist() for k, v in values.items()}

    added, taken, catalogue, opposites, shared = [], list(values) + list(inputs), None, {}, {}
    for t in terms:
        lacking = [key for key in ("component", "term", "coef") if key not in t]
        if lacking:
            raise ValueError(f"Each term needs 'component', 'term' and 'coef'; {dict(t)!r} lacks {lacking}.")
        component, term = int(t["component"]), t["term"]
        function = t.get("function")
        if isinstance(term, Term):
            term, function = term.name, function or term
        term = str(term)
        if component < 0:
            raise ValueError(f"Term {term!r}: component must be a non-negative index, got {component}.")
        is_offset = t.get("kind") == "offset"
        if is_offset and not 0 <= component < n_states:
            raise ValueError(f"A sensor offset needs a state index in [0, {n_states}), got {component}.")
        if is_offset and any(c == component and f is None for c, _, _, f, _ in added):
            raise ValueError(f"State {variable_names[component]!r} has two sensor offsets; give it one.")
        param = t.get("param") or (parameter_name(variable_names[component], taken, prefix="offset") if is_offset
                                   else parameter_name(t.get("label") or term, taken))
        if param in taken or not param.isidentifier():
            raise ValueError(f"Parameter name {param!r} is taken or not a valid identifier.")
        taken.append(param)
        values[param] = float(t["coef"])
        # an offset has no function of its own: it shifts the state every other part sees
        if function is None and not is_offset:  # a term given by name is one of the named terms
            catalogue = catalogue or named_terms(variable_names)
            if term not in catalogue:
                raise ValueError(f"Unknown term {term!r}: give it as a Term (sklearn_hybrid.diagnosis.Term(name, "
                                 f"f, 'user'), with f(d) a torch function of d mapping {variable_names} to tensors), "
                                 "or name one of named_terms(variable_names).")
            function = catalogue[term]
        func = None if is_offset else function
        # a term's nonlinear (shape) parameters become parameters of the new function too, made by the first
        # term of a shape group and shared by the others (one flux entering several balances has one shape)
        group = t.get("shape_group")
        if group is not None and group in shared:
            shape = shared[group]
            if set(shape) != set(dict(t.get("shape") or {})):
                raise ValueError(f"Term {term!r} is in shape group {group!r}, whose first term has the shape "
                                 f"parameters {sorted(shape)}; it has {sorted(dict(t.get('shape') or {}))}.")
        else:
            shape = {}
            for local, value in dict(t.get("shape") or {}).items():
                shape[local] = parameter_name(t.get("label") or term, taken, prefix=local)
                taken.append(shape[local])
                values[shape[local]] = float(value)
            if group is not None:
                shared[group] = shape
        opposite = t.get("opposite")
        if opposite is not None:
            if is_offset or isinstance(opposite, bool) or not isinstance(opposite, (int, np.integer)) \
                    or opposite < 0 or opposite == component:
                raise ValueError(f"Term {term!r}: 'opposite' must be another output component (an index) for a flow "
                                 f"out of component {component}, got {opposite!r}.")
            opposites[len(added)] = int(opposite)
        added.append((component, term, param, func, shape))

    name = name or f"{getattr(science, '__name__', 'science')}_augmented"
    return AugmentedScience(science, inputs, list(defaults), values, added, variable_names, n_states, name, opposites)


class AugmentedScience:
    """A science function plus named terms (and sensor offsets), made by :func:`augment_science`.

    Called like the original, ``f(*inputs, **theta)``, on a batch or on one state (a 1-D first input,
    as ``solve_ivp`` hands it over); ``inspect.signature`` lists the inputs, then
    every parameter with its initial value. ``terms`` lists ``(component, term, parameter)``,
    ``shape_names`` each term's shape parameters, ``opposites`` the component a flow enters by the index of
    its term, ``equation`` reads what was added.
    """

    opposites: dict = {}  # (an AugmentedScience pickled before flows existed has none)

    def __init__(self, science, inputs, original, values, added, variable_names, n_states, name, opposites=None):
        self.science, self.original, self.initial = science, list(original), dict(values)
        self.added, self.variable_names, self.n_states = list(added), list(variable_names), n_states
        self.opposites = dict(opposites or {})
        self.touched = sorted({component for component, _, _, func, _ in added if func is not None}
                              | set(self.opposites.values()))
        self.offsets = {component: param for component, _, param, func, _ in added if func is None}
        # called at every RK4 stage of every simulation (hundreds of thousands of times in a
        # selection, per step of a free run), where each tensor operation costs its overhead: one
        # unbind per input, no reshape of what is already flat, and each touched component added as
        # its column times a constant one-hot row (indexing and stacking every column took 4x the
        # science function's own time)
        self._one_hot: dict[tuple, dict[int, torch.Tensor]] = {}
        params = [inspect.Parameter(n, inspect.Parameter.POSITIONAL_OR_KEYWORD) for n in inputs]
        params += [inspect.Parameter(k, inspect.Parameter.POSITIONAL_OR_KEYWORD, default=v) for k, v in values.items()]
        self.__signature__ = inspect.Signature(params)
        self.__name__ = self.__qualname__ = name
        self.terms = [(c, term, p) for c, term, p, _, _ in added]
        self.shape_names = [dict(shape) for *_, shape in added]  # per term: shape -> parameter name
        equation = " ".join(f"+ {p}*{term} [component {c}]" + (f" - {p}*{term} [component {self.opposites[i]}]"
                                                                if i in self.opposites else "")
                            for i, (c, term, p, func, _) in enumerate(added) if func is not None)
        equation += "".join(f" [{variable_names[c]} measured as {variable_names[c]} + {p}]"
                            for c, p in self.offsets.items())
        self.equation = equation.strip()
        self.__doc__ = (f"{getattr(science, '__name__', 'science')} {self.equation}\n\n"
                        f"Original science function plus the terms found by the residual diagnosis.")

    def __repr__(self) -> str:
        return f"<science {self.__name__}: {getattr(self.science, '__name__', 'science')} {self.equation}>"

    def _rows(self, flat: torch.Tensor, components) -> dict[int, torch.Tensor]:
        """One-hot rows of ``flat``'s width for ``components``, made once per width, dtype and device."""
        cached = self._one_hot.setdefault((flat.shape[1], flat.dtype, flat.device), {})
        for j in components:
            if j >= flat.shape[1]:
                terms = [term for c, term, *_ in self.added if c == j]
                raise ValueError(f"Term(s) {terms} go to component {j}, but the science function returns "
                                 f"{flat.shape[1]} component(s) per sample.")
            if j not in cached:
                cached[j] = torch.eye(flat.shape[1], dtype=flat.dtype, device=flat.device)[j]
        return {j: cached[j] for j in components}

    def __call__(self, *args, **params):
        params = {**self.initial, **params}
        single = args[0].ndim == 1  # one state, not a batch
        if self.offsets:  # the sensor reads state + offset: the model's equations see the reading less the offset
            state = _flat(args[0], single)
            for j, row in self._rows(state, self.offsets).items():
                state = state - params[self.offsets[j]] * row
            args = (state.reshape(args[0].shape), *args[1:])
        original = {k: params[k] for k in self.original}
        out = self.science(*args, **original)
        columns = list(_flat(args[0], single).unbind(1))[:self.n_states]
        if len(args) > 1:
            columns += _flat(args[1], single).unbind(1)[:len(self.variable_names) - self.n_states]
        if len(columns) < len(self.variable_names):
            raise ValueError(f"variable_names has {len(self.variable_names)} names {self.variable_names}, but the "
                             f"inputs have {len(columns)} column(s).")
        flat = _flat(out, single)

        def part(name, base=flat):  # an inhibited term reads the part of the science output a parameter makes
            if name not in original:
                raise KeyError(f"an inhibited term reads the part of science parameter {name!r}, which "
                               f"{getattr(self.science, '__name__', 'the science')} does not have: {self.original}")
            return base - _flat(self.science(*args, **{**original, name: 0.0 * original[name]}), single)

        d = TermVariables(dict(zip(self.variable_names, columns)), part)
        d[SCIENCE_OUTPUT] = flat  # a "scaled" term reads the science output
        extra = {}
        for i, (component, _, param, func, shape) in enumerate(self.added):
            if func is None:
                continue
            value = params[param] * func(d, **{local: params[name] for local, name in shape.items()})
            extra[component] = value if component not in extra else extra[component] + value
            if i in self.opposites:  # a flow: what leaves one component enters the other
                j = self.opposites[i]
                extra[j] = -value if j not in extra else extra[j] - value
        for j, row in self._rows(flat, self.touched).items():
            value = extra[j]
            flat = torch.addcmul(flat, value.unsqueeze(-1), row) if torch.is_tensor(value) else flat + value * row
        return flat if flat.shape == out.shape else flat.reshape(out.shape)
