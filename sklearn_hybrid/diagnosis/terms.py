"""What physics usually misses: named candidate terms, some with a fitted nonlinear parameter.

A :class:`Term` is the package's one vocabulary of candidate terms: the closed loop ranks and adds
them, :class:`~sklearn_hybrid.diagnosis.CandidateLibrary` evaluates them as the columns of a sparse
regression, and :func:`~sklearn_hybrid.diagnosis.augment_science` adds them to a science function.
A term is a torch function of the named variables (states, then inputs) with, for some
kinds, one *shape* parameter fitted together with its coefficient: the width ``w`` of dry friction
``tanh(v/w)``, the ``knot`` of a hinge ``max(0, x - knot)``, the constant ``K`` of a saturation
``x/(K + |x|)``, the rate ``k`` of ``exp(k x)``, the exponent ``p`` of a power law ``|x|^p`` or
``x |x|^(p-1)`` (radiation, allometric scaling, an outflow whose exponent is not one half), the phase
of a harmonic ``sin(n x + phase)`` of an angle. Dry friction is also offered as ``sign(v)`` itself.
:func:`physics_terms` builds the default library
from the data's scale; the same torch function serves the ranking (on the states the network
visited) and the augmented science model (during its refit), so there is one implementation per
term.

A term of kind ``"scaled"`` multiplies the science model's own output for one component by a
state, ``f_j(x) * x_k`` (or ``x_k^2``), or by an input, ``f_j(x) * u``: a parameter of that
equation that varies with the state or with what drives the system (an inductance that saturates
with the current, a growth rate that depends on the density or follows the season, a rate
constant that grows with the temperature). It reads the science output from the variables under
the key ``SCIENCE_OUTPUT``, which the augmented science model and the selection provide.
"""

from __future__ import annotations

import re
from collections.abc import Callable, Mapping, Sequence
from functools import partial
from itertools import combinations, combinations_with_replacement
from typing import Any

import numpy as np
import torch

__all__ = ["Term", "physics_terms", "named_terms", "constant_term", "monomial_terms", "nonsmooth_terms",
           "trigonometric_terms", "sqrt_term", "TERM_KINDS", "SCIENCE_OUTPUT", "power_unit", "product_unit"]

TERM_KINDS = ("polynomial", "drag", "dry_friction", "hinge", "sqrt", "power", "exponential", "saturation", "periodic",
              "norm", "scaled", "user")
# Key of the science model's output, shape (batch, n_outputs), among a term's variables: not an
# identifier, so no state or input can be named so.
SCIENCE_OUTPUT = "<science output>"


class Term:
    """A candidate term ``coef * func(d, **shape)`` of the named variables.

    Parameters
    ----------
    name : str
        Readable name, e.g. ``"tanh(v/w)"``.
    func : callable
        ``func(d, **shape) -> Tensor`` with ``d`` mapping variable names to ``(batch,)`` tensors.
    kind : str
        Which physics it stands for (one of ``TERM_KINDS``), shown in reports.
    shape : dict of str to (list of float, (float, float)), optional
        Each nonlinear parameter's starting grid and bounds, e.g. ``{"w": ([0.01, 0.1], (1e-4, 10))}``.
    unit : str, default=""
        Units of the term (for the report); ``""`` if dimensionless or unknown.
    component : int, optional
        The only output component the term may be added to (a ``"scaled"`` term scales that
        component's science output); default any.
    field : str, optional
        The vector field the term is one component of, e.g. ``"|(vx, vz)|*(vx, vz)"`` for
        ``|(vx, vz)|*vx``: a drag along the speed acts on every velocity component at once. The closed
        loop also tries the field's terms together, each on its own equation.
    """

    field: str | None = None  # (a Term pickled before fields existed has none)

    def __init__(self, name: str, func: Callable, kind: str,
                 shape: Mapping[str, tuple[Sequence[float], tuple[float, float]]] | None = None,
                 unit: str = "", component: int | None = None, field: str | None = None) -> None:
        self.name, self.func, self.kind, self.unit = name, func, kind, unit
        self.shape, self.component, self.field = dict(shape or {}), component, field

    def __call__(self, d: Mapping[str, torch.Tensor], **shape: Any) -> torch.Tensor:
        return self.func(d, **shape)

    def grid(self) -> list[dict[str, float]]:
        """Every combination of the shape parameters' starting values (one empty dict if none)."""
        combos: list[dict[str, float]] = [{}]
        for pname, (values, _) in self.shape.items():
            combos = [{**c, pname: float(v)} for c in combos for v in values]
        return combos

    def __repr__(self) -> str:
        return f"Term({self.name!r}, kind={self.kind!r})"


_SIMPLE_UNIT = re.compile(r"^[A-Za-z_]\w*$")


def power_unit(unit: str, power: int) -> str:
    """Units of ``x**power`` for ``x`` in ``unit`` (``"m/s"``, 2 -> ``"(m/s)^2"``); ``""`` when dimensionless."""
    unit = unit if isinstance(unit, str) else str(unit)  # a unit given as another object only labels the report
    if unit in ("", "1") or power == 0:
        return ""
    if power == 1:
        return unit
    return f"{unit if _SIMPLE_UNIT.match(unit) else f'({unit})'}^{power}"


def product_unit(parts: Sequence[str]) -> str:
    """Units of a product of factors in the given units; ``""`` when dimensionless."""
    return "*".join(p for p in parts if p)


# The term functions: module-level, bound to their variables with functools.partial, so that a
# science model augmented with them can be pickled (joblib.dump of a fitted estimator).
def constant(d):
    return torch.ones_like(next(iter(d.values())))


def monomial(d, factors):
    """``prod(d[name] ** power for name, power in factors)``."""
    out = d[factors[0][0]] ** factors[0][1]
    for name, power in factors[1:]:
        out = out * d[name] ** power
    return out


def _scaled(d, component, factors):
    """The science output of ``component`` times ``monomial(d, factors)``."""
    return d[SCIENCE_OUTPUT][..., component] * monomial(d, factors)


def drag_term(d, x):
    return d[x] * d[x].abs()


def abs_term(d, x):
    return d[x].abs()


def sine(d, x):
    return torch.sin(d[x])


def cosine(d, x):
    return torch.cos(d[x])


def _dry_friction(d, x, w):
    return torch.tanh(d[x] / w)


def sign_term(d, x):
    return torch.sign(d[x])


def _power_abs(d, x, p):
    """``|x|^p``; the tiny floor keeps the gradient in ``p`` (``log|x|``) finite where ``x`` is zero."""
    return (d[x].abs() + 1e-12) ** p


def _power_signed(d, x, p):
    """``x |x|^(p-1)``: odd in ``x``, so a flow or a force keeps the sign of what drives it."""
    return d[x] * (d[x].abs() + 1e-12) ** (p - 1)


def _hinge_above(d, x, knot):
    return torch.relu(d[x] - knot)


def _hinge_below(d, x, knot):
    return torch.relu(knot - d[x])


def _signed_sqrt(d, x):
    return torch.sign(d[x]) * torch.sqrt(d[x].abs() + 1e-12)


def _exponential(d, x, k):
    return torch.exp(torch.clamp(k * d[x], max=50.0))


def _saturation(d, x, K):
    return d[x] / (K + d[x].abs())


def norm_term(d, over, factor=None):
    """The Euclidean norm of the variables ``over`` (a speed, a distance), times ``d[factor]`` if given."""
    norm = torch.sqrt(sum(d[x] ** 2 for x in over))
    return norm if factor is None else norm * d[factor]


def _harmonic(d, x, frequency, phase):
    """``sin(n a + phase)`` of the angle ``a`` in radians: ``frequency`` is n times the radians per unit of ``d[x]``."""
    return torch.sin(frequency * d[x] + phase)


# Harmonics of an angle in the library: whatever acts on a body turning about an axis repeats with each
# full turn, so its effect is a sum of sin(n a + phase) with whole n (a pendulum's own sin(a) is n = 1;
# a motor's cogging torque has one n per pole pair, a detent or a cam its own count).
_HARMONICS = (1, 2, 3, 4, 6, 8)
_ANGLE_UNIT = re.compile(r"^\s*(?P<scale>[0-9]*\.?[0-9]+(?:[eE][-+]?[0-9]+)?)?\s*\*?\s*(?P<unit>rad|deg|°)\s*$")


def angle_factor(unit: str) -> float | None:
    """Radians per unit of a variable whose unit is an angle (``"rad"``, ``"deg"``, ``"0.1 rad"``), else None."""
    if not isinstance(unit, str):  # a unit given as something else only labels the report, as before
        return None
    match = _ANGLE_UNIT.match(unit)
    if match is None:
        return None
    scale = float(match["scale"]) if match["scale"] else 1.0
    return scale * (1.0 if match["unit"] == "rad" else np.pi / 180)


def monomial_term(factors: Sequence[tuple[str, int]], units: Mapping[str, str] | None = None) -> Term:
    """The product of ``name ** power`` over ``factors``, named as ``"x^2*v"`` (variables in the given order)."""
    units = units or {}
    name = "*".join(v if p == 1 else f"{v}^{p}" for v, p in factors)
    unit = product_unit([power_unit(units.get(v, ""), p) for v, p in factors])
    return Term(name, partial(monomial, factors=tuple((v, int(p)) for v, p in factors)), "polynomial", unit=unit)


def monomial_terms(variables: Sequence[str], degree: int, units: Mapping[str, str] | None = None,
                   interaction_only: bool = False) -> list[Term]:
    """Every monomial of total degree 1 to ``degree``, degree by degree, in scikit-learn's
    ``PolynomialFeatures`` order (so that the names are those of its powers)."""
    variables, out = list(variables), []
    combos = combinations if interaction_only else combinations_with_replacement
    for total in range(1, degree + 1):
        for combo in combos(range(len(variables)), total):
            factors = [(variables[i], combo.count(i)) for i in sorted(set(combo))]
            out.append(monomial_term(factors, units))
    return out


def constant_term() -> Term:
    """The constant ``"1"``."""
    return Term("1", constant, "polynomial")


def sqrt_term(x: str, unit: str = "") -> Term:
    """``sqrt|x|`` signed as ``x`` (Torricelli outflow, turbulent flow): odd, so a flow keeps its direction."""
    return Term(f"sqrt|{x}|", partial(_signed_sqrt, x=x), "sqrt", unit=f"{unit}^(1/2)" if unit else "")


def trigonometric_terms(x: str) -> list[Term]:
    """``sin(x)`` and ``cos(x)``."""
    return [Term(f"sin({x})", partial(sine, x=x), "periodic"), Term(f"cos({x})", partial(cosine, x=x), "periodic")]


def nonsmooth_terms(x: str, unit: str = "") -> list[Term]:
    """``sign(x)`` (dry friction), ``|x|`` and ``x|x|`` (drag)."""
    return [Term(f"sign({x})", partial(sign_term, x=x), "dry_friction"),
            Term(f"|{x}|", partial(abs_term, x=x), "drag", unit=unit),
            Term(f"{x}|{x}|", partial(drag_term, x=x), "drag", unit=power_unit(unit, 2))]


def named_terms(variables: Sequence[str], units: Mapping[str, str] | None = None, degree: int = 5) -> dict[str, Term]:
    """The terms without a shape parameter over ``variables``, by name: the constant ``"1"``, the
    monomials up to ``degree``, ``sin``, ``cos``, ``sign``, ``|x|``, ``x|x|`` and ``sqrt|x|`` of each
    variable. A term given by its name (``augment_science``) is one of these."""
    units = units or {}
    terms = [constant_term(), *monomial_terms(variables, degree, units)]
    for x in variables:
        unit = units.get(x, "")
        terms += [*trigonometric_terms(x), *nonsmooth_terms(x, unit), sqrt_term(x, unit)]
    return {t.name: t for t in terms}


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
    terms: list[Term] = []
    if "polynomial" in kinds:
        terms += _polynomials(variables, units)
    if "scaled" in kinds:
        terms += _scaled_terms(scaled, variables[:n_states], variables[n_states:])
    if "norm" in kinds:
        terms += _norms(variables[:n_states], units)
    for i, x in enumerate(variables):
        col, u = values[:, i], units.get(x, "")
        scale = float(np.sqrt(np.mean(col**2))) or 1.0
        terms += _single_variable(x, col, scale, u, kinds, x in positive)
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


def _polynomials(variables: Sequence[str], units: Mapping[str, str]) -> list[Term]:
    """Constant, powers up to 3 and the products of two variables up to degree 3."""
    terms = [constant_term()]
    terms += [monomial_term([(x, p)], units) for x in variables for p in (1, 2, 3)]
    terms += [monomial_term([(x, px), (z, pz)], units)
              for x, z in combinations(variables, 2) for px, pz in ((1, 1), (2, 1), (1, 2))]
    return terms


#: Units of a length or a speed (m, mm, cm/s, km/h, ...): the components of a position or a velocity.
_SPATIAL_UNIT = re.compile(r"^(k|c|m|u|µ|n)?m(/((m|u|µ)?s|h|min))?$")


def _norms(states: Sequence[str], units: Mapping[str, str]) -> list[Term]:
    """For every pair of states in one unit of length or speed (two coordinates, two velocity
    components), and for all of them where three or more share it (a position or a velocity in
    space): their norm ``|(a, b)|`` and the norm times each, ``|(a, b)|*a``: drag along the
    speed, a force that grows with the distance (the latter the components of one vector field,
    ``field`` ``|(a, b)|*(a, b)``). The norm of two concentrations, populations or
    angles, or of states of unknown units, is no physical quantity, and no such term is offered."""
    by_unit: dict[str, list[str]] = {}
    for x in states:
        unit = units.get(x, "")
        if isinstance(unit, str) and _SPATIAL_UNIT.match(unit):
            by_unit.setdefault(unit, []).append(x)
    out = []
    for unit, group in by_unit.items():
        vectors = list(combinations(group, 2)) + ([tuple(group)] if len(group) > 2 else [])
        for over in vectors:
            label = f"|({', '.join(over)})|"
            out.append(Term(label, partial(norm_term, over=over), "norm", unit=unit))
            out += [Term(f"{label}*{x}", partial(norm_term, over=over, factor=x), "norm", unit=power_unit(unit, 2),
                         field=f"{label}*({', '.join(over)})") for x in over]
    return out


def _scaled_terms(scaled: Mapping[int, str], states: Sequence[str], inputs: Sequence[str]) -> list[Term]:
    """``f[label]*x`` and ``f[label]*x^2`` for every scaled component and state, ``f[label]*u`` for every
    input (a rate proportional to what drives it; ``f[label]*1`` is the science output itself, which a
    parameter of its own equation scales already)."""
    powers = [(x, p) for x in states for p in (1, 2)] + [(u, 1) for u in inputs]
    return [Term(f"f[{label}]*{x}" + (f"^{p}" if p > 1 else ""),
                 partial(_scaled, component=int(j), factors=((x, p),)), "scaled", component=int(j))
            for j, label in scaled.items() for x, p in powers]


def _single_variable(x: str, col: np.ndarray, scale: float, unit: str, kinds: Sequence[str],
                     positive: bool) -> list[Term]:
    """Non-polynomial terms of one variable, their grids set by its scale and quantiles."""
    out = []
    wide = (1e-6 * scale, 1e3 * scale)
    if "drag" in kinds:
        _, magnitude, drag = nonsmooth_terms(x, unit)
        out += [drag, magnitude]
    if "dry_friction" in kinds:  # sign(x) smoothed over a fitted width w (-> sign as w -> 0)
        out.append(Term(f"tanh({x}/w)", partial(_dry_friction, x=x), "dry_friction",
                        {"w": ([0.01 * scale, 0.1 * scale, 0.5 * scale], wide)}))
        # sign(x) itself: the sharp law, which a fitted width reaches only where least squares still feels
        # it (tanh(x/w) flattens in w once w is below most visited |x|). Only for a variable that changes
        # sign: otherwise it is the constant.
        if col.min() < 0 < col.max():
            out.append(nonsmooth_terms(x)[0])
    if "hinge" in kinds:  # a stop, an overflow, a dead zone: active beyond a fitted knot c
        knots = np.quantile(col, [0.1, 0.3, 0.5, 0.7, 0.9])
        bounds = (float(col.min()), float(col.max()))
        # the knot is not called c: c_<term> names every coefficient
        out.append(Term(f"max(0, {x} - knot)", partial(_hinge_above, x=x), "hinge",
                        {"knot": (knots[1:], bounds)}, unit=unit))
        if not (positive and bounds[0] >= 0 and knots[0] <= 0):
            out.append(Term(f"max(0, knot - {x})", partial(_hinge_below, x=x), "hinge",
                            {"knot": (knots[:-1], bounds)}, unit=unit))
    if "sqrt" in kinds:
        out.append(sqrt_term(x, unit))
    if "power" in kinds:  # a law outside the listed degrees: radiation, allometric scaling, a fitted Torricelli
        powers = ([0.5, 1.5, 2.5], (0.1, 5.0))  # the exponent p, fitted
        out.append(Term(f"|{x}|^p", partial(_power_abs, x=x), "power", {"p": powers}))
        if col.min() < 0 < col.max():  # for a variable of one sign the odd version is the same column
            out.append(Term(f"{x}|{x}|^(p-1)", partial(_power_signed, x=x), "power", {"p": powers}))
    if "exponential" in kinds:  # Arrhenius-like activation, diode current, decay
        k = [s / scale for s in (-3.0, -1.0, 1.0, 3.0)]
        out.append(Term(f"exp(k*{x})", partial(_exponential, x=x), "exponential",
                        {"k": (k, (-20.0 / scale, 20.0 / scale))}))
    if "saturation" in kinds:  # Michaelis-Menten, Holling type II, a saturating actuator
        out.append(Term(f"{x}/(K + |{x}|)", partial(_saturation, x=x), "saturation",
                        {"K": ([0.1 * scale, 0.5 * scale, 2.0 * scale], (1e-3 * scale, 1e3 * scale))}))
    radians = angle_factor(unit)
    if "periodic" in kinds and radians is not None:  # only an angle repeats: a length or a level does not
        angle = x if radians == 1 else f"{radians:.6g}*{x}"  # the angle in radians
        for n in _HARMONICS:
            out.append(Term(f"sin({'' if n == 1 else f'{n}*'}{angle} + phase)",
                            partial(_harmonic, x=x, frequency=n * radians), "periodic",
                            {"phase": ([0.0, np.pi / 2], (-np.pi, np.pi))}))
    return out
