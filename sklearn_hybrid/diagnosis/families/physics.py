"""Today's term kinds as families: what physics usually misses, offered from the states, their units and data.

Each family is one kind of :data:`~sklearn_hybrid.diagnosis.TERM_KINDS`. Three read all the variables at
once (polynomials, a state's science output scaled by a state, norms of a vector); the others offer terms of
one variable at a time, their starting shapes set by its scale and quantiles.
"""

from __future__ import annotations

from functools import partial
from itertools import combinations

import re

import numpy as np


from ..terms import (Term, angle_difference_term, angle_factor, constant_term, dry_friction_term, exponential_term,
                     harmonic_term, hinge_above_term, hinge_below_term, monomial_term, nonsmooth_terms, norm_term,
                     power_abs_term, phase_difference_term, power_signed_term, power_unit, saturation_term, scaled_term,
                     sqrt_term)
from .base import TermContext, TermFamily, VariableFamily

__all__ = ["PHYSICS_FAMILIES", "PHASE_DIFFERENCES"]

#: Units of a length or a speed (m, mm, cm/s, km/h, ...): the components of a position or a velocity.
_SPATIAL_UNIT = re.compile(r"^(k|c|m|u|µ|n)?m(/((m|u|µ)?s|h|min))?$")


# Harmonics of an angle in the library: whatever acts on a body turning about an axis repeats with each
# full turn, so its effect is a sum of sin(n a + phase) with whole n (a pendulum's own sin(a) is n = 1;
# a motor's cogging torque has one n per pole pair, a detent or a cam its own count).
_HARMONICS = (1, 2, 3, 4, 6, 8)


def _polynomials(context: TermContext) -> list[Term]:
    """Constant, powers up to 3 and the products of two variables up to degree 3."""
    variables, units = context.variables, context.units
    terms = [constant_term()]
    terms += [monomial_term([(x, p)], units) for x in variables for p in (1, 2, 3)]
    terms += [monomial_term([(x, px), (z, pz)], units)
              for x, z in combinations(variables, 2) for px, pz in ((1, 1), (2, 1), (1, 2))]
    return terms


def _norms(context: TermContext) -> list[Term]:
    """For every pair of states in one unit of length or speed (two coordinates, two velocity
    components), and for all of them where three or more share it (a position or a velocity in
    space): their norm ``|(a, b)|`` and the norm times each, ``|(a, b)|*a``: drag along the
    speed, a force that grows with the distance (the latter the components of one vector field,
    ``field`` ``|(a, b)|*(a, b)``). The norm of two concentrations, populations or
    angles, or of states of unknown units, is no physical quantity, and no such term is offered."""
    by_unit: dict[str, list[str]] = {}
    for x in context.states:
        unit = context.units.get(x, "")
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


def _scaled_terms(context: TermContext) -> list[Term]:
    """``f[label]*x`` and ``f[label]*x^2`` for every scaled component and state, ``f[label]*u`` for every
    input (a rate proportional to what drives it; ``f[label]*1`` is the science output itself, which a
    parameter of its own equation scales already)."""
    powers = [(x, p) for x in context.states for p in (1, 2)] + [(u, 1) for u in context.inputs]
    return [Term(f"f[{label}]*{x}" + (f"^{p}" if p > 1 else ""),
                 partial(scaled_term, component=int(j), factors=((x, p),)), "scaled", component=int(j))
            for j, label in context.scaled.items() for x, p in powers]


def _drag(x: str, col: np.ndarray, scale: float, unit: str, positive: bool) -> list[Term]:
    _, magnitude, drag = nonsmooth_terms(x, unit)
    return [drag, magnitude]


def _friction(x: str, col: np.ndarray, scale: float, unit: str, positive: bool) -> list[Term]:
    """sign(x) smoothed over a fitted width w (-> sign as w -> 0), and sign(x) itself: the sharp law,
    which a fitted width reaches only where least squares still feels it (tanh(x/w) flattens in w once w
    is below most visited |x|). The latter only for a variable that changes sign: otherwise it is the
    constant."""
    out = [Term(f"tanh({x}/w)", partial(dry_friction_term, x=x), "dry_friction",
                {"w": ([0.01 * scale, 0.1 * scale, 0.5 * scale], _wide(scale))})]
    if col.min() < 0 < col.max():
        out.append(nonsmooth_terms(x)[0])
    return out


def _hinge(x: str, col: np.ndarray, scale: float, unit: str, positive: bool) -> list[Term]:
    """A stop, an overflow, a dead zone: active beyond a fitted knot (not called c: c_<term> names every
    coefficient)."""
    knots = np.quantile(col, [0.1, 0.3, 0.5, 0.7, 0.9])
    bounds = (float(col.min()), float(col.max()))
    out = [Term(f"max(0, {x} - knot)", partial(hinge_above_term, x=x), "hinge", {"knot": (knots[1:], bounds)}, unit=unit)]
    if not (positive and bounds[0] >= 0 and knots[0] <= 0):
        out.append(Term(f"max(0, knot - {x})", partial(hinge_below_term, x=x), "hinge",
                        {"knot": (knots[:-1], bounds)}, unit=unit))
    return out


def _sqrt(x: str, col: np.ndarray, scale: float, unit: str, positive: bool) -> list[Term]:
    return [sqrt_term(x, unit)]


def _power(x: str, col: np.ndarray, scale: float, unit: str, positive: bool) -> list[Term]:
    """A law outside the listed degrees: radiation, allometric scaling, a fitted Torricelli; for a
    variable of one sign the odd version is the same column."""
    powers = ([0.5, 1.5, 2.5], (0.1, 5.0))  # the exponent p, fitted
    out = [Term(f"|{x}|^p", partial(power_abs_term, x=x), "power", {"p": powers})]
    if col.min() < 0 < col.max():
        out.append(Term(f"{x}|{x}|^(p-1)", partial(power_signed_term, x=x), "power", {"p": powers}))
    return out


def _exponential_terms(x: str, col: np.ndarray, scale: float, unit: str, positive: bool) -> list[Term]:
    """Arrhenius-like activation, diode current, decay."""
    k = [s / scale for s in (-3.0, -1.0, 1.0, 3.0)]
    return [Term(f"exp(k*{x})", partial(exponential_term, x=x), "exponential", {"k": (k, (-20.0 / scale, 20.0 / scale))})]


def _saturation_terms(x: str, col: np.ndarray, scale: float, unit: str, positive: bool) -> list[Term]:
    """Michaelis-Menten, Holling type II, a saturating actuator."""
    return [Term(f"{x}/(K + |{x}|)", partial(saturation_term, x=x), "saturation",
                 {"K": ([0.1 * scale, 0.5 * scale, 2.0 * scale], (1e-3 * scale, 1e3 * scale))})]


def _periodic(x: str, col: np.ndarray, scale: float, unit: str, positive: bool) -> list[Term]:
    """Harmonics of an angle: only an angle repeats, a length or a level does not."""
    radians = angle_factor(unit)
    if radians is None:
        return []
    return [Term(f"sin({'' if n == 1 else f'{n}*'}{_in_radians(x, radians)} + phase)",
                 partial(harmonic_term, x=x, frequency=n * radians), "periodic",
                 {"phase": ([0.0, np.pi / 2], (-np.pi, np.pi))}) for n in _HARMONICS]


def _phase_differences(context: TermContext) -> list[Term]:
    """``sin(b - a + phase)`` for every pair of states ``a``, ``b`` whose units are angles: two phases that pull
    on each other (coupled oscillators, two pendula on one beam, a generator on the grid), a term that no
    harmonic of one angle makes; and ``b - a``, the same pull when linear (a spring between two pendula, a
    torsion spring between two shafts), which no single listed term makes either."""
    angles = [(x, angle_factor(context.units.get(x, ""))) for x in context.states]
    angles = [(x, radians) for x, radians in angles if radians is not None]
    out = []
    for (x, rx), (z, rz) in combinations(angles, 2):
        difference = f"{_in_radians(z, rz)} - {_in_radians(x, rx)}"
        func = partial(phase_difference_term, x=x, z=z, x_radians=rx, z_radians=rz)
        term = Term(f"sin({difference} + phase)", func, "periodic", {"phase": ([0.0, np.pi / 2], (-np.pi, np.pi))})
        # Kuramoto's coupling has no phase: tried once the term is accepted (loop.collapse.drop_spare_constants)
        term.reductions = (Term(f"sin({difference})", partial(func, phase=0.0), "periodic"),)
        out += [term, Term(difference, partial(angle_difference_term, x=x, z=z, x_radians=rx, z_radians=rz),
                           "polynomial", unit="rad")]
    return out


def _in_radians(x: str, radians: float) -> str:
    return x if radians == 1 else f"{radians:.6g}*{x}"


def _wide(scale: float) -> tuple[float, float]:
    return (1e-6 * scale, 1e3 * scale)


# In the order the library has always listed them: the ranking breaks ties by it.
PHYSICS_FAMILIES: tuple[TermFamily, ...] = (
    TermFamily("polynomial", _polynomials),
    TermFamily("scaled", _scaled_terms),
    TermFamily("norm", _norms),
    VariableFamily("drag", _drag),
    VariableFamily("dry_friction", _friction),
    VariableFamily("hinge", _hinge),
    VariableFamily("sqrt", _sqrt),
    VariableFamily("power", _power),
    VariableFamily("exponential", _exponential_terms),
    VariableFamily("saturation", _saturation_terms),
    VariableFamily("periodic", _periodic),
)

#: The harmonic of a difference of two angles: offered with discovery only (a change of the default term list
#: waits for the identification benchmark's rerun).
PHASE_DIFFERENCES = TermFamily("phase_difference", _phase_differences)
