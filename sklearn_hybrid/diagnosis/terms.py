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
The families of ``families/`` offer them (:func:`~sklearn_hybrid.diagnosis.physics_terms` builds
the default library from the data's scale, one family per kind); the same torch function serves the
ranking (on the states the network visited) and the augmented science model (during its refit), so
there is one implementation per term.

A term of kind ``"scaled"`` multiplies the science model's own output for one component by a
state, ``f_j(x) * x_k`` (or ``x_k^2``), or by an input, ``f_j(x) * u``: a parameter of that
equation that varies with the state or with what drives the system (an inductance that saturates
with the current, a growth rate that depends on the density or follows the season, a rate
constant that grows with the temperature). It reads the science output from the variables under
the key ``SCIENCE_OUTPUT``, which the augmented science model and the selection provide.

A term of kind ``"inhibited"`` or ``"modulated"`` (offered with the closed loop's discovery) reads a science term
itself (slowed down, limited or scaled exponentially or by a power of a variable): the part
of the science output that a parameter the science is linear in makes, under the key ``parameter_part(name)``,
which :class:`TermVariables` computes from the science model when a term first asks for it.
"""

from __future__ import annotations

import re
from collections.abc import Callable, Mapping, Sequence
from functools import partial
from itertools import combinations, combinations_with_replacement
from typing import Any

import numpy as np
import torch

__all__ = ["Term", "named_terms", "constant_term", "monomial_terms", "nonsmooth_terms",
           "trigonometric_terms", "sqrt_term", "TERM_KINDS", "SCIENCE_OUTPUT", "power_unit", "product_unit",
           "parameter_part", "TermVariables", "inhibited_term", "modulated_term", "powered_term"]

TERM_KINDS = ("polynomial", "drag", "dry_friction", "hinge", "sqrt", "power", "exponential", "saturation", "periodic",
              "norm", "scaled", "user")
# Key of the science model's output, shape (batch, n_outputs), among a term's variables: not an
# identifier, so no state or input can be named so.
SCIENCE_OUTPUT = "<science output>"
_PART = "<{}'s term>"
_PART_KEY = re.compile(r"<(.+)'s term>")


def parameter_part(name: str) -> str:
    """Key of the science output's part made by its parameter ``name`` (the output less the output with that
    parameter zero), shape (batch, n_outputs), among a term's variables."""
    return _PART.format(name)


class TermVariables(dict):
    """The variables a term reads, by name, with each science parameter's part (:func:`parameter_part`) made on
    first use by ``part(name)``: a science model augmented with no inhibited term never pays for one."""

    def __init__(self, values: Mapping[str, torch.Tensor], part: Callable[[str], torch.Tensor] | None = None):
        super().__init__(values)
        self._part = part

    def __missing__(self, key: str) -> torch.Tensor:
        match = _PART_KEY.fullmatch(key) if isinstance(key, str) else None
        if match is None or self._part is None:
            raise KeyError(key)
        self[key] = value = self._part(match.group(1))
        return value


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
    # a discovered form: whether it is dimensionally consistent in the units given (None: not known)
    consistent: bool | None = None
    # a science term scaled by a factor: the coefficient at which it makes the law on the term's own equation
    # (its function's keyword ``reference``); its screening refit starts there, not where it was ranked
    law_coefficient: float | None = None
    # simpler forms of the term, a shape constant held at its null value (a phase of zero): once the term is
    # accepted the loop tries each, as it sets a discovered form's constants to zero, and keeps one that validates
    # as well (a constant the data do not need takes up noise and trades with theta)
    reductions: tuple = ()

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


def drag_term(d, x):
    return d[x] * d[x].abs()


def abs_term(d, x):
    return d[x].abs()


def sine(d, x):
    return torch.sin(d[x])


def cosine(d, x):
    return torch.cos(d[x])


def sign_term(d, x):
    return torch.sign(d[x])


def _signed_sqrt(d, x):
    return torch.sign(d[x]) * torch.sqrt(d[x].abs() + 1e-12)


def norm_term(d, over, factor=None):
    """The Euclidean norm of the variables ``over`` (a speed, a distance), times ``d[factor]`` if given."""
    norm = torch.sqrt(sum(d[x] ** 2 for x in over))
    return norm if factor is None else norm * d[factor]


_ANGLE_UNIT = re.compile(r"^\s*(?P<scale>[0-9]*\.?[0-9]+(?:[eE][-+]?[0-9]+)?)?\s*\*?\s*(?P<unit>rad|deg|°)\s*$")


def scaled_term(d, component, factors):
    """The science output of ``component`` times ``monomial(d, factors)``."""
    return d[SCIENCE_OUTPUT][..., component] * monomial(d, factors)


def inhibited_term(d, param, reference, x, power, K, limited=False):
    """``param``'s part of the science output on component ``reference`` times ``|x|^power / (K^power +
    |x|^power)`` (with coefficient -1 the part becomes the part over ``1 + (|x|/K)^power``), or with ``limited``
    times ``K^power / (K^power + |x|^power)`` (the part becomes the part times ``|x|^power / (K^power +
    |x|^power)``)."""
    a = (d[x].abs() / K) ** power
    return d[parameter_part(param)][..., reference] * (1 if limited else a) / (1 + a)


def modulated_term(d, param, reference, x, k):
    """``param``'s part of the science output on component ``reference`` times ``exp(k x) - 1``: with coefficient
    1 the part becomes the part times ``exp(k x)``, the parameter still the term's rate at ``x = 0``."""
    return d[parameter_part(param)][..., reference] * torch.expm1(torch.clamp(k * d[x], max=50.0))


def powered_term(d, param, reference, x, p):
    """``param``'s part of the science output on component ``reference`` times ``|x|^p - 1``: with coefficient 1
    the part becomes the part times ``|x|^p``, the parameter the term's rate at ``|x| = 1`` in ``x``'s units (a
    film coefficient growing as the flow to the power 0.8)."""
    return d[parameter_part(param)][..., reference] * (power_abs_term(d, x, p) - 1)


def dry_friction_term(d, x, w):
    return torch.tanh(d[x] / w)


def power_abs_term(d, x, p):
    """``|x|^p``; the tiny floor keeps the gradient in ``p`` (``log|x|``) finite where ``x`` is zero."""
    return (d[x].abs() + 1e-12) ** p


def power_signed_term(d, x, p):
    """``x |x|^(p-1)``: odd in ``x``, so a flow or a force keeps the sign of what drives it."""
    return d[x] * (d[x].abs() + 1e-12) ** (p - 1)


def hinge_above_term(d, x, knot):
    return torch.relu(d[x] - knot)


def hinge_below_term(d, x, knot):
    return torch.relu(knot - d[x])


def exponential_term(d, x, k):
    return torch.exp(torch.clamp(k * d[x], max=50.0))


def saturation_term(d, x, K):
    return d[x] / (K + d[x].abs())


def harmonic_term(d, x, frequency, phase):
    """``sin(n a + phase)`` of the angle ``a`` in radians: ``frequency`` is n times the radians per unit of ``d[x]``."""
    return torch.sin(frequency * d[x] + phase)


def phase_difference_term(d, x, z, x_radians, z_radians, phase):
    """``sin(b - a + phase)`` of the angles ``a`` (``d[x]``) and ``b`` (``d[z]``) in radians: ``x_radians`` and
    ``z_radians`` are the radians per unit of each."""
    return torch.sin(z_radians * d[z] - x_radians * d[x] + phase)


def angle_difference_term(d, x, z, x_radians, z_radians):
    """``b - a`` of the angles ``a`` (``d[x]``) and ``b`` (``d[z]``) in radians (``x_radians`` and ``z_radians``
    radians per unit): the linear pull between two angles, the small-angle form of :func:`phase_difference_term`."""
    return z_radians * d[z] - x_radians * d[x]


# The names these had before the kinds became families: a science model augmented and pickled then names them.
_scaled = scaled_term
_dry_friction = dry_friction_term
_power_abs = power_abs_term
_power_signed = power_signed_term
_hinge_above = hinge_above_term
_hinge_below = hinge_below_term
_exponential = exponential_term
_saturation = saturation_term
_harmonic = harmonic_term


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
