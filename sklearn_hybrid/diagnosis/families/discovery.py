"""Symbolic regression on what the network learned: the family that offers a law the term list does not know.

:class:`SymbolicDiscovery` runs Operon (``pyoperon``, a C++ genetic-programming engine with a
scikit-learn interface) per equation on the states the network visited, the equation's science output
among the variables (``f``), against what the network learned there. Its Pareto front of length against
error holds the candidate forms, short to long; each becomes a term (``kind="discovered"``, see
:func:`~sklearn_hybrid.diagnosis.families.symbolic.form_term`) that goes through the same evidence test
and the same network-free refit as every other term, its constants fitted jointly with theta. The samples
only propose: which form is the law is judged in the ODE, on held-out trajectories.
"""

from __future__ import annotations

import itertools
import time
from collections.abc import Callable, Sequence

import numpy as np
import torch

from ...structures.scales import moments
from ..terms import Term

__all__ = ["SymbolicDiscovery", "monomial_forms"]

SCIENCE_SYMBOL = "f"  # the science output of the equation, a variable of the search
DIRECTION = "dtheta"  # the science's parameter directions, variables of the search that no offered form keeps


class SymbolicDiscovery:
    """Propose closed forms for what the network learned, by symbolic regression (Operon).

    Parameters
    ----------
    operators : tuple of str, default=("add,sub,mul,div,square", "add,sub,mul,div,square,sqrt", "add,sub,mul,div,exp,log")
        The grammars searched in turn, each a set of operators by Operon's names (``constant`` and
        ``variable`` are always allowed): rational functions first (saturations, Hill functions,
        polynomials), then with roots, then with exponentials and logarithms. Each grammar has its own
        front and offers its own forms: with every operator at once, the search fills the front with
        exponentials that mimic a rational law.
    max_length : int, default=20
        The longest form, in nodes of its expression tree.
    population_size : int, default=300
        Forms per generation.
    generations : int, default=25
        Generations per round; rounds go on until the front settles or ``max_rounds``.
    max_rounds : int, default=8
        At most this many rounds per equation.
    tol : float, default=0.01
        The front has settled when a round lowers no length's error by more than this share.
    max_forms : int, default=4
        Forms offered per equation and grammar: the front's knee (the form whose error falls most below the
        next shorter one's), then the shortest among those within reach (the samples rank a law's form beside
        stand-ins of its length; each offered form is judged in the ODE); a form dimensionally inconsistent in
        the variables' units (``Term.consistent`` False) only where too few consistent ones are. Each is
        offered without the parts a science parameter provides (they are theta's error) and, where that
        dropped something, also whole (a law may hold such a part: ``x^2 y/(K + x^2)`` is
        ``y - K y/(K + x^2)``, beside a science's ``-m y``).
    slack : float, default=0.5
        A form is within reach when its error is at most ``1 + slack`` times the front's lowest, or when it
        explains at least ``r2`` of what the network learned.
    max_constants : int, default=3
        A form with more named constants is not offered: each is a parameter of every refit that screens the
        form (the cost grows with them), and a textbook law has few.
    r2 : float, default=0.99
        See ``slack``: the longer forms of a front mostly fit the network's own errors.
    max_points : int, default=400
        Visited states the search reads (evenly spaced among those given).
    random_state : int, default=0
        Seed of the search.
    use_directions : bool, default=True
        Give the search the science's parameter directions on the equation as variables too (``dtheta1``, ...):
        what the network learned also carries theta's error, and a form may then write the law plus a
        multiple of each direction. Those parts are theta's and are dropped; a form that uses a direction
        otherwise is offered with the direction written in the variables where a product of their powers is
        the direction (``monomial_forms``), and not offered where none is.
    use_science : bool, default=False
        Offer the equation's science output as a variable ``f`` (a parameter that varies with the state:
        ``f * x``).

    Attributes
    ----------
    fronts_ : dict of int to dict of str to list of dict
        After :meth:`terms`: per equation and grammar, the front's forms (``formula``, ``length``, ``mse``)
        as Operon wrote them, before simplification.
    seconds_ : float
        CPU seconds of the last search.
    """

    name = "discovered"

    def __init__(self, operators: tuple[str, ...] = ("add,sub,mul,div,square", "add,sub,mul,div,square,sqrt",
                                                     "add,sub,mul,div,exp,log"), max_length: int = 20,
                 population_size: int = 300, generations: int = 25, max_rounds: int = 8, tol: float = 0.01,
                 max_forms: int = 4, slack: float = 0.5, max_constants: int = 3, r2: float = 0.99,
                 max_points: int = 400,
                 random_state: int = 0, use_directions: bool = True, use_science: bool = False) -> None:
        self.operators, self.max_length, self.population_size = operators, max_length, population_size
        self.generations, self.max_rounds, self.tol = generations, max_rounds, tol
        self.max_forms, self.slack, self.r2, self.max_points = max_forms, slack, r2, max_points
        self.max_constants = max_constants
        self.random_state, self.use_directions, self.use_science = random_state, use_directions, use_science

    def __repr__(self) -> str:
        return (f"SymbolicDiscovery(max_length={self.max_length}, population_size={self.population_size}, "
                f"max_rounds={self.max_rounds})")

    def terms(self, context, log: Callable[[str], None] = lambda message: None) -> list[Term]:
        """Forms found on each of ``context.components`` from ``context.learned``, as terms: on any equation
        (a form found on one may be the flux another equation shares), except those that read an equation's
        science output, which stay on it.

        Raises
        ------
        ImportError
            If ``pyoperon`` is not installed (``pip install pyoperon``).
        ValueError
            If the context holds no ``learned`` residual, or a setting is out of range.
        """
        if context.learned is None:
            raise ValueError("SymbolicDiscovery reads what the network learned (TermContext.learned); the "
                             "context holds none.")
        for name in ("max_length", "population_size", "generations", "max_rounds", "max_forms", "max_constants",
                     "max_points"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < 1:
                raise ValueError(f"SymbolicDiscovery: {name} must be a positive integer, got {value!r}.")
        grammars = (self.operators,) if isinstance(self.operators, str) else self.operators
        if not grammars or not all(isinstance(g, str) and g for g in grammars):
            raise ValueError("SymbolicDiscovery: operators must be a grammar (Operon's operator names joined by "
                             f"commas, e.g. 'add,sub,mul,div') or a tuple of them, got {self.operators!r}.")
        start = time.process_time()
        self.fronts_ = {}
        rows = np.unique(np.linspace(0, len(context.values) - 1, min(self.max_points, len(context.values))).astype(int))
        out: list[Term] = []
        for j in context.components:
            names = list(context.variables)
            X = context.values[rows]
            science = context.science_output
            if self.use_science and science is not None and np.ptp(science[rows, j]) > 0:
                names.append(SCIENCE_SYMBOL)
                X = np.column_stack([X, science[rows, j]])
            target = np.asarray(context.learned[rows, j], dtype=float)
            if not np.any(target):
                continue
            directions = None if context.directions is None else context.directions[rows, j, :]
            written = {}
            if self.use_directions and directions is not None:
                new = _new_directions(directions, X)
                names += [f"{DIRECTION}{k + 1}" for k in range(new.shape[1])]
                written = {f"{DIRECTION}{k + 1}": form for k, form in
                           enumerate(monomial_forms(new, context.values[rows], context.variables)) if form}
                X = np.column_stack([X, new])
            # searched in the data's scales (each variable and the target over its spread, not shifted, so a
            # form keeps its shape): the same physics in other units is the same search; forms come back in
            # the user's units
            scales, size = _spreads(X), float(_spreads(target[:, None])[0])
            self.fronts_[j] = {}
            for grammar in grammars:
                front = self._search(X / scales, target / size, grammar, log, f"equation {j} ({grammar})")
                self.fronts_[j][grammar] = front
                out += [t for t in self._offered(front, names, j, X, directions, float(np.var(target / size)),
                                                 dict(context.units), scales, written)
                        if t.name not in {o.name for o in out}]
        self.seconds_ = time.process_time() - start
        return out

    def _search(self, X: np.ndarray, y: np.ndarray, grammar: str, log: Callable[[str], None],
                where: str) -> list[dict]:
        """Operon's front, rounds of ``generations`` until no length's error falls by ``tol`` in a round."""
        try:
            from pyoperon.sklearn import SymbolicRegressor
        except ImportError as exc:
            raise ImportError("SymbolicDiscovery needs pyoperon, the symbolic regression engine: "
                              "pip install pyoperon") from exc
        best: dict[int, float] = {}
        front: list[dict] = []
        for r in range(self.max_rounds):
            reg = SymbolicRegressor(
                allowed_symbols=f"{grammar},constant,variable", objectives=["r2", "length"],
                max_length=self.max_length, population_size=self.population_size, pool_size=self.population_size,
                generations=self.generations, max_evaluations=10 ** 9, n_threads=1, optimizer_iterations=10,
                random_state=self.random_state + r, epsilon=1e-6)
            reg.fit(X, y)
            found = [{"formula": m["model"], "length": int(m["length"]), "mse": float(m["mean_squared_error"])}
                     for m in reg.pareto_front_]
            front = _pareto(front + found)
            now = {m["length"]: m["mse"] for m in front}
            moved = any(length not in best or mse < (1 - self.tol) * best[length] for length, mse in now.items())
            best = now
            log(f"  discovery on {where}: round {r + 1}, front of {len(front)} forms, lowest error "
                f"{min(now.values()):.3g}")
            if not moved and r > 0:
                break
        return front

    def _offered(self, front: list[dict], names: list[str], component: int, X: np.ndarray,
                 directions: np.ndarray | None, variance: float, units: dict, scales: np.ndarray,
                 written: dict | None = None) -> list[Term]:
        """The shortest forms within reach (see ``slack`` and ``r2``), as terms (simplified, deduplicated)."""
        from .symbolic import form_term  # sympy is imported where a search has run, not with the package
        if not front:
            return []
        bound = max((1 + self.slack) * min(m["mse"] for m in front), (1 - self.r2) * variance)
        near = [m for m in sorted(front, key=lambda m: m["length"]) if m["mse"] <= bound]
        # the knee first: the form whose error falls most below the next shorter one's (the law caught, what
        # the longer forms add is the network's own error)
        steps = [(front[i - 1]["mse"] / max(front[i]["mse"], 1e-300), i) for i in range(1, len(front))]
        knee = front[max(steps)[1]] if steps else front[0]
        near = [knee] + [m for m in near if m is not knee]
        out: dict[str, Term] = {}
        aside: list[Term] = []
        kept: dict[str, Term] = {}

        def term_of(formula: str, keep: bool):
            return form_term(formula, names, component, values=X, directions=directions,
                             theta_parts=[v for v in names if v.startswith(DIRECTION)], units=units,
                             science=SCIENCE_SYMBOL if SCIENCE_SYMBOL in names else None, scales=scales,
                             theta_forms=written, keep_parameter_parts=keep)
        for m in near:
            made = term_of(m["formula"], False)
            if made is None or len(made[0].shape) > self.max_constants:
                continue
            if made[0].consistent is False:  # kept aside: offered only where no consistent form is
                aside.append(made[0])
                continue
            if made[0].name not in out and len(out) < self.max_forms:  # one form written twice: the first
                out[made[0].name] = made[0]
                # the form with the parts a science parameter provides kept, where dropping them changed it
                whole = term_of(m["formula"], True)
                if whole is not None and whole[0].name != made[0].name and len(whole[0].shape) <= self.max_constants:
                    kept[whole[0].name] = whole[0]
        for term in aside:
            if term.name not in out and len(out) < self.max_forms:
                out[term.name] = term
        return list(out.values()) + [t for name, t in kept.items() if name not in out]


def _new_directions(directions: np.ndarray, X: np.ndarray, tol: float = 1e-9) -> np.ndarray:
    """The directions a variable does not already give: one that is a constant plus a multiple of a variable
    (``k x`` of a science's ``-k x``) would only let the search write that variable twice."""
    keep = []
    for d in directions.T:
        size = float(np.sum((d - d.mean()) ** 2))
        if size == 0:
            continue
        gives = False
        for x in X.T:
            A = np.column_stack([np.ones(len(x)), x])
            rest = d - A @ np.linalg.lstsq(A, d, rcond=None)[0]
            gives = gives or float(rest @ rest) < tol * size
        if not gives:
            keep.append(d)
    return np.column_stack(keep) if keep else np.zeros((len(directions), 0))


def monomial_forms(directions: np.ndarray, values: np.ndarray, variables: Sequence[str], max_power: int = 3,
                   tol: float = 1e-8) -> list[tuple[float, dict[str, int]] | None]:
    """Each direction written as ``c * prod(variable^power)`` where a product of the variables' powers is it.

    The search reads a science parameter's direction as one variable (beta's ``S I`` in ``-beta S I``), so a
    law that modifies the science's term is found as that direction times a function of the states; written
    in the variables, the form can be offered (``symbolic.form_term``'s ``theta_forms``).

    Parameters
    ----------
    directions : ndarray of shape (n_points, n_directions)
        The science's parameter sensitivities at the visited states, one column each.
    values : ndarray of shape (n_points, n_variables)
        The variables at the same states, one column each.
    variables : sequence of str
        The variables' names, one per column of ``values``.
    max_power : int, default=3
        The highest power of each variable tried.
    tol : float, default=1e-8
        A product writes a direction when the least-squares remainder is under ``tol`` of its squared size.

    Returns
    -------
    list of (float, dict of str to int) or None
        Per direction, the coefficient and the powers of the variables that enter (the lowest total power
        that fits), or None where no product does.

    Raises
    ------
    ValueError
        If ``directions`` and ``values`` differ in points, or ``variables`` does not name every column.
    """
    values, directions = np.asarray(values, dtype=float), np.asarray(directions, dtype=float)
    if values.ndim != 2 or directions.ndim != 2 or len(values) != len(directions) \
            or values.shape[1] != len(variables):
        raise ValueError(f"monomial_forms needs directions (n_points, n_directions), values (n_points, "
                         f"n_variables) and one name per variable; got shapes {directions.shape}, {values.shape} "
                         f"and {len(variables)} names.")
    powers = sorted((p for p in itertools.product(range(max_power + 1), repeat=values.shape[1]) if sum(p)),
                    key=lambda p: (sum(p), p[::-1]))
    out: list[tuple[float, dict[str, int]] | None] = []
    for d in directions.T:
        size, found = float(d @ d), None
        for p in powers if size > 0 else ():
            m = np.prod(values ** np.array(p), axis=1)
            mm = float(m @ m)
            if mm == 0:
                continue
            c = float(m @ d) / mm
            rest = d - c * m
            if float(rest @ rest) < tol * size:
                found = (c, {v: k for v, k in zip(variables, p) if k})
                break
        out.append(found)
    return out


def _spreads(X: np.ndarray) -> np.ndarray:
    """Each column's spread as the network's scales read it (``structures.scales.moments``), 1 where it has none."""
    spread = moments(torch.as_tensor(np.asarray(X, dtype=float)))[1]
    return np.where(np.isnan(spread), 1.0, spread)


def _pareto(forms: list[dict]) -> list[dict]:
    """The forms no shorter-or-equal form beats in error, shortest first."""
    out: list[dict] = []
    for m in sorted(forms, key=lambda m: (m["length"], m["mse"])):
        if np.isfinite(m["mse"]) and (not out or m["mse"] < out[-1]["mse"]):
            out.append(m)
    return out
