"""A formula found by symbolic regression, as a term: a canonical form, named constants, a torch function.

:func:`form_term` reads a formula in the variables' names (as a symbolic regressor writes it), drops an
added constant (the library's own term ``"1"`` stands for it), moves the overall factor to the term's
coefficient, simplifies with sympy to a canonical form, and names every other number a constant
``K1, K2, ...``: shape parameters that the network-free refit fits together with theta, as it fits a
hinge's knot. The term's function is :class:`SymbolicForm`, a picklable torch function of the formula.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence

import numpy as np
import sympy
import torch

from ..sensitivity import parameter_basis
from ..terms import SCIENCE_OUTPUT, Term

__all__ = ["SymbolicForm", "form_term", "canonical_form", "consistent_units", "drop_parameter_parts", "reduced_forms",
           "rest_share_dropped"]

# sympy's functions as torch computes them (a formula of the operators a physicist writes)
_TORCH = {"exp": torch.exp, "log": torch.log, "sqrt": torch.sqrt, "Abs": torch.abs, "sin": torch.sin,
          "cos": torch.cos, "tanh": torch.tanh, "sign": torch.sign}


class SymbolicForm:
    """``formula(d, **constants)``: a sympy formula of the named variables as a term's torch function.

    Parameters
    ----------
    formula : str
        The formula in sympy's syntax, over ``variables`` and ``constants`` (as ``srepr`` writes it).
    variables : dict of str to str
        The formula's symbols by the variable each stands for (``"f"`` the science output of ``component``).
    constants : tuple of str
        Its constants, passed by name at each call.
    component : int, optional
        The output whose science output the symbol ``science`` (if any) reads.
    """

    def __init__(self, formula: str, variables: Mapping[str, str], constants: Sequence[str],
                 component: int | None = None, science: str | None = None) -> None:
        self.formula, self.variables, self.constants = formula, dict(variables), tuple(constants)
        self.component, self.science = component, science
        self._compiled = None

    def __getstate__(self) -> dict:  # the compiled function is generated code: compiled again after a load
        return {**self.__dict__, "_compiled": None}

    def __call__(self, d: Mapping[str, torch.Tensor], **constants: torch.Tensor) -> torch.Tensor:
        if self._compiled is None:
            expr = _numbers_folded(sympy.sympify(self.formula, locals=_symbols(self)))
            symbols = [sympy.Symbol(s) for s in (*self.variables, *self.constants)]
            self._compiled = sympy.lambdify(symbols, expr, modules=[_TORCH, "math"])
        args = [d[SCIENCE_OUTPUT][..., self.component] if s == self.science else d[v]
                for s, v in self.variables.items()]
        one = args[0] if args else next(iter(d.values()))
        values = [torch.as_tensor(constants[c], dtype=one.dtype) for c in self.constants]
        out = self._compiled(*args, *values)
        return out if torch.is_tensor(out) else torch.full_like(one, float(out))


def _numbers_folded(expr: sympy.Expr) -> sympy.Expr:
    """``expr`` with each function of numbers alone (``exp(-1)``, ``sqrt(2)``, left where a constant was set to
    zero) evaluated to a float: torch's functions take tensors, not numbers."""
    return expr.replace(lambda e: e.is_number and not e.is_Atom, lambda e: e.evalf())


def _symbols(form: SymbolicForm) -> dict:
    return {s: sympy.Symbol(s) for s in (*form.variables, *form.constants)}


def canonical_form(expr: sympy.Expr) -> tuple[float, sympy.Expr, dict[str, float]]:
    """``(factor, form, constants)`` with ``expr`` equal to ``factor * form`` less an added constant.

    The form is simplified, its numbers replaced by symbols ``K1, K2, ...`` (``constants`` their values);
    an exponent within 1e-6 of a whole or half number is taken as that number (a square, a square root).
    """
    expr = sympy.sympify(expr)
    expr = expr.replace(lambda e: e.is_Pow and e.exp.is_Float and abs(2 * e.exp - round(2 * e.exp)) < 2e-6,
                        lambda e: sympy.Pow(e.base, sympy.Rational(round(2 * e.exp), 2)))
    if expr.is_Add:  # the added constant is the library's own term
        expr = expr.as_independent(*expr.free_symbols, as_Add=True)[1]
    expr = sympy.factor_terms(_one_fraction(expr))
    factor, form = _monic(expr)
    constants: dict[str, float] = {}

    def name(number: sympy.Float) -> sympy.Symbol:
        value = float(number)
        for k, v in constants.items():  # one constant written twice is one constant
            if math.isclose(v, value, rel_tol=1e-9):
                return sympy.Symbol(k)
        key = f"K{len(constants) + 1}"
        constants[key] = value
        return sympy.Symbol(key)

    # a whole number added to a quantity (the 1 of x^2 + 1, made exact by the simplification) is a fitted
    # constant that happened to be whole: it carries the quantity's unit and is fitted like the others
    form = form.replace(lambda e: e.is_Add and e.free_symbols,
                        lambda e: sympy.Add(*[sympy.Float(a) if a.is_Integer else a for a in e.args]))
    form = form.replace(lambda e: e.is_Float, name)
    return float(factor), form, constants


def _one_fraction(expr: sympy.Expr) -> sympy.Expr:
    """A ratio as one numerator over one denominator (sums of fractions collected); other forms as they are."""
    return sympy.cancel(sympy.together(expr)) if any(p.exp.is_negative for p in expr.atoms(sympy.Pow)) else expr


def _monic(expr: sympy.Expr) -> tuple[sympy.Expr, sympy.Expr]:
    """``(factor, form)`` with ``expr = factor * form`` and each sum of ``form``'s product (numerator or
    denominator) with a variable term of coefficient one (``S/(K + S)``, as a textbook writes it): the form's
    constants are then its own."""
    factor, form = expr.as_coeff_Mul()
    parts = []
    for part in sympy.Mul.make_args(form):
        base, power = part.as_base_exp()
        if base.is_Add and power.is_Integer:
            first = [a for a in sympy.Add.make_args(base) if a.free_symbols][0]
            lead, variable_part = first.as_coeff_Mul()
            if lead != 0:  # the lead written exactly: a 1.0 left elsewhere is a fitted number that happens to be 1
                factor = factor * lead ** power
                base = variable_part + sympy.expand((base - first) / lead)
        parts.append(base ** power)
    return factor, sympy.Mul(*parts)


def form_term(formula: str, variables: Sequence[str], component: int, *, science: str | None = None,
              values: np.ndarray | None = None, directions: np.ndarray | None = None, theta_parts: Sequence[str] = (),
              units: Mapping[str, str] | None = None, spread: float = 1e3,
              scales: Sequence[float] | None = None,
              theta_forms: Mapping[str, tuple[float, Mapping[str, int]]] | None = None,
              keep_parameter_parts: bool = False) -> tuple[Term, float] | None:
    """The term of a formula over ``variables`` (``science`` names the symbol that stands for the science
    output of ``component``), and its coefficient; None for a formula with nothing left. The term may be
    placed on any equation unless it reads the science output (then on ``component``'s only).

    With ``values`` (the variables at the visited states, one column each) and ``directions`` (the science's
    parameter sensitivities there, one column each), the formula's additive parts that a parameter of the
    science already provides are dropped: a form found on what the network learned also carries theta's
    error, and the part theta can take is theta's. The variables named in ``theta_parts`` (the directions
    themselves, given to the search as variables) are dropped where the formula is linear in them with a
    constant coefficient; a formula that uses one otherwise gives None, unless ``theta_forms`` writes that
    direction in the variables (``(c, {variable: power})``, the direction ``c * prod(variable^power)``): it is
    then read as written (a law that modifies a science term, ``beta S I / (1 + K I^2)`` found as
    ``dtheta1 / (1 + K I^2)`` where ``dtheta1`` is beta's direction ``S I``), and its part that a parameter
    provides is dropped as any other, the multiple of the direction it holds at rest included, with
    ``keep_parameter_parts`` too (the law's departure from the science term is offered, ``S I^3/(K + I^2)``,
    and beta keeps its meaning at low prevalence; see :func:`rest_share_dropped`); with
    ``keep_parameter_parts`` no other part is dropped but a constant (a law may hold a part in a parameter's
    direction, ``x^2 y/(K + x^2) = y - K y/(K + x^2)`` beside a science's ``-m y``: placed on another
    equation, or with a constant set to zero, the part is the law's). Of the forms equal up to a constant, the
    one that vanishes where the variables do is written. Each remaining constant starts at the value the
    formula gives it and may move within a factor ``spread`` either way, keeping its sign (a constant through
    zero turns a saturation into a pole). With ``units``, a form that adds or compares quantities of different
    units with no constant between them is marked (``Term.consistent`` False, see :func:`consistent_units`).
    With ``scales``, the formula reads each variable over its scale (a search run in the data's scales): it is
    written back in the variables' own units.
    """
    symbols = {f"X{i + 1}": sympy.Symbol(v) for i, v in enumerate(variables)}
    read = symbols if scales is None else {k: s / sympy.Float(float(c)) for (k, s), c in zip(symbols.items(), scales)}
    expr = sympy.sympify(formula, locals=read)
    written = theta_forms or {}
    inside = []  # the directions written inside the law, as products of the variables
    for name in theta_parts:
        part = sympy.Symbol(name)
        if part in expr.free_symbols:
            if sympy.diff(expr, part).is_number:  # a multiple of a direction: theta's part, dropped
                expr = expr.subs(part, 0)
            elif name in written:  # a direction inside the law, written in the variables
                coefficient, powers = written[name]
                inside.append(sympy.Mul(*[sympy.Symbol(v) ** int(k) for v, k in powers.items()]))
                expr = expr.subs(part, sympy.Float(coefficient) * inside[-1])
            else:  # a direction inside the law that no variables write: not a form of the variables
                return None
    if values is not None and directions is not None:
        kept = np.asarray(directions)[:, :0] if keep_parameter_parts else directions
        expr = drop_parameter_parts(expr, [symbols[f"X{i + 1}"] for i in range(len(variables))], values, kept)
    for monomial in inside:  # the rest share of a direction written inside the law is its parameter's
        expr = rest_share_dropped(expr, monomial, list(symbols.values()))
    expr = _zero_at_rest(expr, list(symbols.values()))
    factor, form, constants = canonical_form(expr)
    used = sorted((s.name for s in form.free_symbols if s.name not in constants), key=list(variables).index)
    if not used or factor == 0 or not math.isfinite(factor):
        return None
    shape = {k: ([v], (v / spread, v * spread) if v > 0 else (v * spread, v / spread)) for k, v in constants.items()}
    func = SymbolicForm(sympy.srepr(form), {v: v for v in used}, list(constants), component, science)
    name = sympy.sstr(form).replace("**", "^")
    # A form of the states alone may stand on any equation, as a listed term does: a predation found on the
    # prey's residual also feeds the predator (a group of the two, each with its coefficient). A form that
    # reads the science output of ``component`` stays on that equation.
    term = Term(name, func, "discovered", shape, component=component if science in used else None)
    term.consistent = consistent_units(form, units or {}, set(constants))
    return term, factor


def reduced_forms(term: Term) -> list[Term]:
    """The discovered ``term`` with one of its constants set to zero, one term per constant whose removal
    leaves a finite form of the variables (``x y/(x + K1 y)`` from ``y (x + K2 y)/(x + K1 y)``); none for a
    term that is not a discovered form.

    The search writes a law with whatever constants lower its error on what the network learned, which also
    carries the network's own error: a constant the law lacks comes out small, not zero, and trades with
    theta in the refit. Each reduced form keeps the other constants (their starting values and bounds are the
    term's), its equation and its units' verdict (setting a constant to zero adds no new sum).

    Parameters
    ----------
    term : Term
        A term, usually one :func:`form_term` made (its function a :class:`SymbolicForm`).

    Returns
    -------
    list of Term
        One reduced term per constant that can go, in the order of the constants; empty for another term.
    """
    form = term.func
    if not isinstance(form, SymbolicForm) or not form.constants:
        return []
    expr = sympy.sympify(form.formula, locals=_symbols(form))
    out = []
    for k in form.constants:
        reduced = _one_fraction(expr.subs(sympy.Symbol(k), 0))
        if reduced.has(sympy.zoo, sympy.nan, sympy.oo, -sympy.oo):
            continue
        if reduced.is_Mul:  # a number left as a factor (exp(-exp(K1 y)) at K1 = 0) is the coefficient's
            reduced = reduced.as_independent(*reduced.free_symbols)[1]
        names = {s.name for s in reduced.free_symbols}
        used = [v for v in form.variables if v in names]
        if not used:  # a constant is the library's own term
            continue
        left = [c for c in form.constants if c in names]
        func = SymbolicForm(sympy.srepr(reduced), {v: form.variables[v] for v in used}, left, form.component,
                            form.science)
        made = Term(sympy.sstr(reduced).replace("**", "^"), func, term.kind, {c: term.shape[c] for c in left},
                    unit=term.unit, component=term.component, field=term.field)
        made.consistent = term.consistent
        out.append(made)
    return out


def consistent_units(form: sympy.Expr, units: Mapping[str, str], constants: set[str]) -> bool | None:
    """Whether ``form`` is dimensionally consistent in ``units``: the parts of each sum in one unit, and the
    argument of each exponential, logarithm or other function without one, where a named constant may carry
    whatever unit makes its part fit. None where a variable of the form has no unit given.

    Units are read as labels: two variables are in one unit when their unit strings are equal, ``""`` and
    ``"1"`` are no unit; the coefficient of the term carries the unit of its equation.
    """
    def unit_of(e):  # a dict {unit: power}, or None where a constant makes it anything ("free")
        if e.is_Symbol:
            if e.name in constants:
                return None
            label = units.get(e.name)
            if label is None:
                raise LookupError(e.name)
            return {} if label in ("", "1") else {label: 1}
        if e.is_Number:
            return {}
        if e.is_Mul:
            parts = [unit_of(a) for a in e.args]
            if any(p is None for p in parts):
                return None
            out: dict = {}
            for p in parts:
                for k, v in p.items():
                    out[k] = out.get(k, 0) + v
            return {k: v for k, v in out.items() if v != 0}
        if e.is_Pow:
            base = unit_of(e.base)
            if e.exp.is_Number:
                return None if base is None else {k: v * e.exp for k, v in base.items()}
            if base not in (None, {}) or unit_of(e.exp) not in (None, {}):
                raise ValueError("a power of a quantity in units by another")
            return {}
        if e.is_Add:
            parts = [p for p in (unit_of(a) for a in e.args) if p is not None]
            if any(p != parts[0] for p in parts[1:]):
                raise ValueError("a sum of quantities in different units")
            return parts[0] if len(parts) == len(e.args) else None
        if e.is_Function:
            if any(unit_of(a) not in (None, {}) for a in e.args):
                raise ValueError("a function of a quantity in units")
            return {}
        return {}
    try:
        unit_of(form)
    except LookupError:
        return None
    except ValueError:
        return False
    return True


def _zero_at_rest(expr: sympy.Expr, symbols: Sequence[sympy.Symbol]) -> sympy.Expr:
    """``expr`` less its value where every variable is zero, where that value is finite: the search writes a
    law up to a constant (its intercept is the library's term ``"1"``), and of the forms equal up to a constant
    the textbook's vanishes at rest (``x^2/(K + x^2)``, not ``-K/(K + x^2)``)."""
    at_rest = _value_at_rest(expr, symbols)
    return expr if at_rest is None else _one_fraction(expr - at_rest)


def _value_at_rest(expr: sympy.Expr, symbols: Sequence[sympy.Symbol]) -> sympy.Expr | None:
    """``expr``'s value where every variable is zero, where that is a finite real number other than zero."""
    at_rest = expr.subs({s: 0 for s in symbols})
    if not at_rest.is_number or at_rest.has(sympy.zoo, sympy.nan, sympy.oo, -sympy.oo) or not at_rest.is_real \
            or at_rest == 0:
        return None
    return at_rest


def rest_share_dropped(expr: sympy.Expr, direction: sympy.Expr, symbols: Sequence[sympy.Symbol]) -> sympy.Expr:
    """``expr`` less the multiple of ``direction`` it holds at rest, where ``expr`` is ``direction`` times a
    function of the variables that is finite and not zero where they all are.

    A law that modifies a science term (``beta S I / (1 + K I)`` in place of ``beta S I``) is found as the
    term's direction times a function (``S I / (K + I)``), and that function's value at rest is a multiple
    of the direction, which the parameter provides: the parameter keeps its meaning as the term's rate where
    the law's departure vanishes (beta the contact rate at low prevalence), and the form left is the law's
    departure, ``S I^2 / (K + I)``. Unchanged where the function is not finite at rest (``exp(-E/T)``) or
    vanishes there.

    Parameters
    ----------
    expr : sympy.Expr
        The form.
    direction : sympy.Expr
        A science parameter's direction written in the variables (a product of their powers).
    symbols : sequence of sympy.Symbol
        The variables; rest is where they are all zero.

    Returns
    -------
    sympy.Expr
        The form less ``direction`` times its ratio's value at rest.
    """
    at_rest = _value_at_rest(sympy.cancel(sympy.together(expr / direction)), symbols)
    return expr if at_rest is None else _one_fraction(expr - at_rest * direction)


def drop_parameter_parts(expr: sympy.Expr, symbols: Sequence[sympy.Symbol], values: np.ndarray,
                         directions: np.ndarray, tol: float = 1e-8) -> sympy.Expr:
    """``expr`` less its additive parts that lie in the span of ``directions`` (columns at the points
    ``values``) to within ``tol`` of their squared size: a constant, or a multiple of a state the science already
    scales by a parameter. Numbers that change ``expr`` at no point (rounding left by the search) go first,
    and again at the end (a sum the search wrote in two parts may cancel once collected)."""
    expr = _without_negligible_numbers(expr, symbols, values)
    Q = parameter_basis(np.column_stack([np.ones(len(values)), directions]))  # a constant is theta's too
    kept = []
    for part in sympy.Add.make_args(sympy.expand(expr, deep=False)):
        col = _evaluate(part, symbols, values)
        if col is None:
            kept.append(part)
            continue
        size = float(col @ col)
        rest = col - Q @ (Q.T @ col)
        if size > 0 and float(rest @ rest) >= tol * size:
            kept.append(part)
    return _without_negligible_numbers(_one_fraction(sympy.Add(*kept)), symbols, values, tol=1e-5)


def _without_negligible_numbers(expr: sympy.Expr, symbols: Sequence[sympy.Symbol], values: np.ndarray,
                                tol: float = 1e-6) -> sympy.Expr:
    """``expr`` with every number set to zero that moves its values by less than ``tol`` of their size."""
    base = _evaluate(expr, symbols, values)
    if base is None or not np.any(base):
        return expr
    size = float(np.sqrt(np.mean(base ** 2)))
    for number in sorted(expr.atoms(sympy.Float), key=lambda f: abs(float(f))):
        trial = expr.subs(number, 0)
        col = _evaluate(trial, symbols, values)
        if col is not None and float(np.sqrt(np.mean((col - base) ** 2))) < tol * size:
            expr = trial
    return expr


def _evaluate(part: sympy.Expr, symbols: Sequence[sympy.Symbol], values: np.ndarray) -> np.ndarray | None:
    """The part's value at each point, or None where it is not finite."""
    if part.has(sympy.zoo, sympy.nan, sympy.oo, -sympy.oo):
        return None
    with np.errstate(all="ignore"):
        out = sympy.lambdify(list(symbols), part, modules="numpy")(*values.T)
    out = np.broadcast_to(np.asarray(out, dtype=float), (len(values),))
    return out if np.all(np.isfinite(out)) else None
