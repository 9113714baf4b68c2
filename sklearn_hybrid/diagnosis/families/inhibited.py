"""Inhibited science terms: a term the science model has, slowed down or limited by a variable.

Many textbook laws keep a term of the simple model and make it saturate in a variable: a growth inhibited by its
product, an eddy-current brake that weakens with speed, a laser's gain compressed by its photons, an incidence
damped by behaviour. The science's parameter keeps its meaning (the term's rate at rest) and the law is
``T / (1 + (|x|/K)^n)`` for a term ``T`` the parameter makes (``n`` one or two, as textbooks write them); what
the simple model misses is ``-T |x|^n / (K^n + |x|^n)``. No term of the list has that form (it multiplies the
science's own term, with its other parameters, by a saturation), and symbolic regression on what the network
learned finds it only as one of many forms of its length. The same term can instead need a variable to act at
all: a growth limited by a second substrate or by the light, ``T |x|^n / (K^n + |x|^n)``, the parameter its rate
at saturation; what the simple model misses is then ``-T K^n / (K^n + |x|^n)`` (beside the science's own term the
same functions of ``x``, but only this form reaches the law at a finite coefficient, the parameter's meaning
kept). Or the variable scales the term exponentially, ``T exp(k x)`` (Steele's photoinhibition, Aiba's product
inhibition, an Arrhenius or Q10 factor about ``x = 0``): what the simple model misses is ``T (exp(k x) - 1)``, the
law at coefficient 1 (kind ``"modulated"``). Or by a power of a quantity of one sign, ``T |x|^p`` (Dittus and
Boelter's film coefficient growing as the flow to the power 0.8, a rate constant growing as a power of the
temperature, an allometric rate): what the simple model misses is ``T (|x|^p - 1)``, the law at coefficient 1, the
parameter the term's rate at ``|x| = 1`` in ``x``'s units (kind ``"modulated"`` too).

This family offers it directly: for every parameter the science output is linear in, its part of the output
(:func:`~sklearn_hybrid.diagnosis.terms.parameter_part`, read from the science model at the current parameters,
so it follows the refit), times each factor of every state and input; coefficient -1 is the law (1 for the
exponential factor). Parts that
are proportional on several equations (a rate that moves matter from one state to another) are one term, which
the loop may place on each of them, as a flow or with a yield each; a part on one equation only is offered there.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from functools import cache, partial

import numpy as np
import torch

from ..sensitivity import science_output
from ..terms import Term, inhibited_term, modulated_term, powered_term

__all__ = ["linear_parts", "part_reader", "inhibited_terms", "other_form"]

#: How close ``f(2p) - f(p)`` must come to ``f(p) - f(0)`` (relative to the part's size) for ``f`` to be called
#: linear in ``p``; and how close two equations' parts must be to proportional to be one term.
LINEAR_TOLERANCE = 1e-6


def linear_parts(science: Callable, theta: Mapping[str, float], args: Sequence[np.ndarray],
                 exclude: Sequence[str] = ()) -> dict[str, np.ndarray]:
    """The part of the science output each scalar parameter it is linear in makes, at the visited states.

    Parameters
    ----------
    science : callable
        The science function.
    theta : dict of str to float
        Its parameters.
    args : list of ndarray
        Its inputs at the visited points (states first).
    exclude : list of str
        Parameters not to read (held fixed).

    Returns
    -------
    dict of str to ndarray of shape (n_points, n_outputs)
        ``f(theta) - f(theta with p = 0)`` for each parameter ``p`` whose doubling doubles that part, not zero
        and finite everywhere.
    """
    part_of = part_reader(science, theta, args)
    parts = {}
    for name, value in theta.items():
        if name in exclude or np.ndim(value) != 0 or float(value) == 0.0:
            continue
        with np.errstate(all="ignore"):
            part = part_of(name).numpy()
            doubled = part_reader(science, {**theta, name: 2.0 * float(value)}, args)(name).numpy()
        size = np.sqrt(np.mean(part ** 2))
        if np.all(np.isfinite(part)) and np.all(np.isfinite(doubled)) and size > 0 \
                and np.sqrt(np.mean((doubled - 2.0 * part) ** 2)) <= LINEAR_TOLERANCE * size:
            parts[name] = part
    return parts


def part_reader(science: Callable, theta: Mapping[str, float], args: Sequence[np.ndarray]
                ) -> Callable[[str], torch.Tensor]:
    """``part(name)``: the part of the science output at ``args`` that parameter ``name`` makes at ``theta`` (the
    science's own parameters), for :class:`~sklearn_hybrid.diagnosis.terms.TermVariables` on the visited states.
    Nothing is evaluated until a part is asked for (a selection without inhibited terms asks for none)."""
    @cache
    def base() -> np.ndarray:
        return science_output(science, theta, args)

    def part(name: str) -> torch.Tensor:
        return torch.as_tensor(base() - science_output(science, {**theta, name: 0.0}, args))

    return part


def inhibited_terms(parts: Mapping[str, np.ndarray], variables: Sequence[str], values: np.ndarray,
                    components: Sequence[int]) -> list[Term]:
    """Each parameter's part, on each group of equations where it is proportional, times ``|x| / (K + |x|)``,
    ``x^2 / (K^2 + x^2)`` (slowed down), ``K / (K + |x|)``, ``K^2 / (K^2 + x^2)`` (limited) and ``exp(k x) - 1``
    (modulated) for every variable ``x`` that varies, and ``|x|^p - 1`` (modulated) where ``x`` also keeps one
    sign.

    Parameters
    ----------
    parts : dict of str to ndarray of shape (n_points, n_outputs)
        :func:`linear_parts`.
    variables : list of str
        States, then inputs.
    values : ndarray of shape (n_points, n_variables)
        Where they were visited: the constant ``K`` starts at the quartiles of ``|x|``.
    components : list of int
        The equations that may receive terms: a part on none of them is not offered.

    Returns
    -------
    list of Term
        Kind ``"inhibited"``, shape parameter ``K`` (starting at the quartiles of ``|x|``, bounded by a
        thousandth and a thousand times the variable's scale), and kind ``"modulated"``, shape parameter ``k``
        (starting at plus and minus one and three over the variable's scale, bounded by twenty over it) or ``p``
        (starting at -1, 0.5 and 2, bounded by plus and minus 3).
    """
    terms = []
    for name, part in parts.items():
        for group in _proportional_groups(part, components):
            reference = group[0]
            label, only = f"[{name}-term of {variables[reference]}]", reference if len(group) == 1 else None
            # the term slows the science's term down where it acts: on its one equation, or (a rate that moves
            # matter between states) on any, as a flow or a group; the b-term of an equation, placed as a flow
            # with another's, would take the role of that other parameter's term and leave its parameter at zero
            for i, x in enumerate(variables):
                size = np.abs(values[:, i])
                if np.ptp(size) == 0:
                    continue
                scale = float(np.sqrt(np.mean(size ** 2)))
                quartiles = [float(q) for q in np.quantile(size, [0.25, 0.5, 0.75]) if q > 0]
                for power, limited in ((1, False), (2, False), (1, True), (2, True)):
                    terms.append(_inhibited(label, name, reference, x, power, limited,
                                            (quartiles or [scale], (1e-3 * scale, 1e3 * scale)), only))
                terms.append(_modulated(label, name, reference, x, scale, only))
                if _one_sign(values[:, i]):
                    terms.append(_powered(label, name, reference, x, only))
    return terms


def other_form(term: Term) -> Term:
    """The inhibited ``term``'s other form, slowed down for limited and limited for slowed down: beside the
    science's own term the same functions of the variable, ``T (1 + c s) = T (1 + c) (1 + c' (1 - s))`` with
    ``c' = -c / (1 + c)``, the parameter's value times ``1 + c``."""
    if term.kind != "inhibited":
        raise ValueError(f"other_form needs a term of inhibited_terms (kind 'inhibited'), got {term!r}.")
    kw = term.func.keywords
    return _inhibited(term.name.split("]")[0] + "]", kw["param"], kw["reference"], kw["x"], kw["power"],
                      not kw.get("limited", False), term.shape["K"], term.component)


def _inhibited(label: str, param: str, reference: int, x: str, power: int, limited: bool, grid: tuple,
               component: int | None) -> Term:
    form = ("K" if power == 1 else "K^2") if limited else (f"|{x}|" if power == 1 else f"{x}^2")
    denominator = f"K + |{x}|" if power == 1 else f"K^2 + {x}^2"
    return Term(f"{label}*{form}/({denominator})",
                partial(inhibited_term, param=param, reference=reference, x=x, power=power, limited=limited),
                "inhibited", {"K": grid}, component=component)


def _modulated(label: str, param: str, reference: int, x: str, scale: float, component: int | None) -> Term:
    term = Term(f"{label}*(exp(k*{x}) - 1)", partial(modulated_term, param=param, reference=reference, x=x),
                "modulated", {"k": ([s / scale for s in (-3.0, -1.0, 1.0, 3.0)], (-20.0 / scale, 20.0 / scale))},
                component=component)
    # ranked at the hybrid's theta, its coefficient trades with the parameter (the part is the parameter's), and
    # a screening refit from there ends in another valley (k near 0 and a large coefficient)
    term.law_coefficient = 1.0
    return term


def _powered(label: str, param: str, reference: int, x: str, component: int | None) -> Term:
    term = Term(f"{label}*(|{x}|^p - 1)", partial(powered_term, param=param, reference=reference, x=x),
                "modulated", {"p": ([-1.0, 0.5, 2.0], (-3.0, 3.0))}, component=component)
    term.law_coefficient = 1.0  # as the exponential factor's: the law's coefficient, where its refit starts
    return term


def _one_sign(col: np.ndarray) -> bool:
    """Whether ``col`` keeps one sign on all but a percent of its points at each end (a concentration's noisy
    readings near zero dip below it): a power of ``|x|`` where ``x`` changes sign is no law of ``x``."""
    low, high = np.quantile(col, [0.01, 0.99])
    return bool(low >= 0 or high <= 0)


def _proportional_groups(part: np.ndarray, components: Sequence[int]) -> list[list[int]]:
    """The equations where ``part`` is not zero, in groups where it is proportional, of the groups that touch
    ``components``."""
    nonzero = [j for j in range(part.shape[1]) if np.any(part[:, j])]
    groups: list[list[int]] = []
    for j in nonzero:
        for group in groups:
            a, b = part[:, group[0]], part[:, j]
            ratio = float(a @ b) / float(a @ a)
            if np.sqrt(np.mean((b - ratio * a) ** 2)) <= LINEAR_TOLERANCE * np.sqrt(np.mean(b ** 2)):
                group.append(j)
                break
        else:
            groups.append([j])
    return [g for g in groups if set(g) & set(components)]
