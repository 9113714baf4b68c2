"""Candidates of a selection step: the terms' columns, the two rankings, and how a candidate becomes a model.

:class:`Candidates` holds the user's settings of the search: which terms, how many may be added.

A candidate is a term placed on a component with a starting ``shape`` and ``coef``
(:class:`~sklearn_hybrid.diagnosis.loop.placed.PlacedTerm`), or several judged as one
(:class:`~sklearn_hybrid.diagnosis.loop.placed.PlacedGroup`). :func:`rank_by_residual` ranks them by
the residual the network still carries, :func:`rank_by_fit` by the network-free model's training error
they would remove; :func:`augment_with` turns the placed terms into an augmented science function
(:func:`~sklearn_hybrid.diagnosis.augment_science`) for :mod:`~sklearn_hybrid.diagnosis.loop.stepwise`
to refit and judge.
"""

from __future__ import annotations

import inspect
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, replace
from itertools import zip_longest
from typing import Any

import numpy as np
import torch

from ...science import read_signature
from ..augment import augment_science
from ..judge import FIT_FAILURES
from ..science_fit import ScienceFit
from ..sensitivity import finite_differences, free_columns, parameter_basis
from ..families import SymbolicDiscovery, TermContext, physics_terms
from ..terms import Term
from .placed import PlacedTerm, label_joined_shapes, offset_term


@dataclass(frozen=True, eq=False)
class Candidates:
    """Which terms :func:`~sklearn_hybrid.diagnosis.close_the_loop` may add, and how many.

    Parameters
    ----------
    terms : list of Term, optional
        The candidates; default :func:`~sklearn_hybrid.diagnosis.physics_terms` over the states and
        inputs and, for an ODE, each uncertain equation's own science output times a state or an input
        (kind ``"scaled"``).
    kinds : list of str, optional
        Which kinds of :func:`~sklearn_hybrid.diagnosis.physics_terms` (default all).
    user_terms : dict of str to callable, optional
        Your own terms by name: torch functions of a dict of variables (their units may be given in
        ``close_the_loop``'s ``units`` by these names).
    positive : list of str, optional
        Variables that are never negative (levels, concentrations): no hinge below zero for them.
    max_terms : int, default=4
        At most this many terms added.
    n_candidates : int, default=4
        Candidates taken from each ranking per step (up to twice as many refitted).
    discovery : SymbolicDiscovery or bool, optional
        Also search closed forms for what the network learned (:class:`~sklearn_hybrid.diagnosis.SymbolicDiscovery`,
        symbolic regression; ``True`` for its defaults), on each equation where no single term of the list
        explains at least ``explained`` of it beyond the science's own parameters. Each form is one more
        candidate, judged like every term. With it, the science's own terms slowed down or limited by a
        variable are candidates too on every equation (kind ``"inhibited"``,
        :func:`~sklearn_hybrid.diagnosis.families.inhibited.inhibited_terms`): a parameter's part ``T`` times
        ``|x|^n/(K^n + |x|^n)``, which at coefficient -1 is the law ``T / (1 + (|x|/K)^n)``, or times
        ``K^n/(K^n + |x|^n)``, the law ``T |x|^n/(K^n + |x|^n)`` (a rate limited by ``x``), ``n`` one or two, or
        times ``exp(k x) - 1``, the law ``T exp(k x)`` at coefficient 1, or, for ``x`` of one sign, times
        ``|x|^p - 1``, the law ``T |x|^p`` at coefficient 1 (kind ``"modulated"``);
        and for two states whose units are angles, ``sin(b - a + phase)`` (two phases that pull on each other)
        and ``b - a`` (the pull when linear: a spring between two pendula), ``families.physics.PHASE_DIFFERENCES``.
        Default off.
    explained : float, default=0.95
        The share of an equation's residual a single listed term must explain for the search to skip it.
    flows : bool, default=True
        Also offer a term ranked on two equations of states in one unit, with opposite signs, as a flow
        between them: one coefficient, ``+c`` on one and ``-c`` on the other.
    """

    terms: Sequence[Term] | None = None
    kinds: Sequence[str] | None = None
    user_terms: Mapping[str, Callable] | None = None
    positive: Sequence[str] = ()
    max_terms: int = 4
    n_candidates: int = 4
    discovery: Any = None
    explained: float = 0.95
    flows: bool = True

    def check(self) -> None:
        """Raise ``ValueError`` naming the setting that is out of range (the names and the terms
        themselves are checked against the data by ``close_the_loop``)."""
        for name in ("max_terms", "n_candidates"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < 1:
                raise ValueError(f"{name} must be a positive integer, got {value!r}.")
        if not (self.discovery in (None, False, True) or callable(getattr(self.discovery, "terms", None))):
            raise TypeError(f"discovery must be True, False or a SymbolicDiscovery, got {self.discovery!r}.")
        if not 0 < self.explained <= 1:
            raise ValueError(f"explained must be in (0, 1], got {self.explained!r}.")
        if not isinstance(self.flows, (bool, np.bool_)):
            raise TypeError(f"flows must be True or False, got {self.flows!r}.")
        if self.terms is not None:  # a name or a plain function would fail deep inside the ranking
            terms = self.terms
            how = ("a term by its name: named_terms(state_names)['v_dot'] (sklearn_hybrid.diagnosis.named_terms); "
                   "your own function of a dict of variables: Candidates(user_terms={'name': f})")
            if isinstance(terms, (str, Term)) or not isinstance(terms, Sequence):
                raise TypeError(f"terms must be a list of Term objects, got {type(terms).__name__} {terms!r}; {how}.")
            for term in terms:
                if not isinstance(term, Term):
                    what = "a function" if callable(term) else f"a {type(term).__name__}"
                    raise TypeError(f"terms holds {term!r} ({what}); it must hold Term objects: {how}.")

    def library(self, variables: Sequence[str], values: np.ndarray, units: Mapping[str, str] | None,
                scaled: Mapping[int, str] | None, n_states: int | None) -> list[Term]:
        """The candidate terms: ``terms``, or :func:`~sklearn_hybrid.diagnosis.physics_terms` of ``kinds``,
        ``user_terms`` and ``positive`` over the ``variables`` at ``values`` (and the ``scaled`` outputs of
        an ODE's uncertain equations, by index)."""
        if self.terms is not None:
            return list(self.terms)
        return physics_terms(variables, values, units, self.kinds, self.user_terms, self.positive, scaled, n_states)


def term_columns(terms: Sequence[Term], variables: dict[str, torch.Tensor]) -> list[tuple]:
    """``(term, shape, values)`` of every term at every starting shape, on the visited states.

    Finite and not identically zero only; the states do not change during the selection, so this is
    computed once for both rankings and every step (a ``"scaled"`` term's column from the science
    output at the starting parameters: close enough to rank it).
    """
    n = len(next(iter(variables.values())))
    out = []
    for term in terms:
        for shape in term.grid():
            with torch.no_grad():
                col = term(variables, **{k: torch.tensor(v, dtype=torch.float64) for k, v in shape.items()})
            col = np.broadcast_to(col.numpy(), (n,))
            if np.all(np.isfinite(col)) and np.any(col):
                out.append((term, shape, col))
    return out


def discovered_terms(candidates: Candidates, columns: list[tuple], remaining: np.ndarray, jac: np.ndarray,
                     values: np.ndarray, science_values: np.ndarray, variables: Sequence[str], n_states: int,
                     components: Sequence[int], log: Callable[[str], None],
                     units: Mapping[str, str] | None = None,
                     carried: Callable[[list[int]], list[int]] | None = None) -> list[Term]:
    """The discovery family's forms (``candidates.discovery``) for the equations the listed terms leave unexplained.

    An equation is searched where the part of ``remaining`` (what the network learned) that no parameter of
    the science can take is material (over a twentieth of it) and no single listed term explains
    ``candidates.explained`` of it; and, given ``carried`` (:func:`network_carries`: the equations, of those
    given, on which the network's part lowers the held-out error), only there: elsewhere the network learned
    noise or theta's error, and a closed form of that would be too (the search and the screening of its forms
    are the loop's most expensive step).
    """
    family = SymbolicDiscovery() if candidates.discovery is True else candidates.discovery
    if not family:
        return []
    wanted = []
    for j in components:
        total = float(np.sum(remaining[:, j] ** 2))
        Q = parameter_basis(jac[:, j, :])
        free = remaining[:, j] - Q @ (Q.T @ remaining[:, j])
        if total == 0 or float(free @ free) < 0.05 * total:
            continue
        best = max((t.gain for t in rank_by_residual(columns, remaining, jac, [j], set())), default=0.0)
        share = best * total / float(free @ free)
        log(f"  the best listed term explains {share:.0%} of equation {j}'s residual beyond the parameters"
            + (": a closed form wanted" if share < candidates.explained else ""))
        if share < candidates.explained:
            wanted.append(j)
    if wanted and carried is not None:
        wanted = carried(wanted)
    if not wanted:
        return []
    context = TermContext(tuple(variables), values, dict(units or {}), n_states, learned=remaining,
                          science_output=science_values, directions=jac, components=tuple(wanted))
    found = family.terms(context, log=log)
    log(f"  discovery offered {len(found)} form(s): {', '.join(t.name for t in found)}")
    return found


def network_carries(judge: Any, science: Callable, theta: Mapping[str, Any], network: Callable,
                    base_errors: np.ndarray, evidence: Any, components: Sequence[int], args: Sequence[np.ndarray],
                    log: Callable[[str], None] = lambda s: None) -> list[int]:
    """The equations among ``components`` on which the fitted network carries what the held-out data confirm.

    The network, frozen and added to ``science`` (the science parameters refitted around it: the hybrid's own
    theta took part of the effect's job), must lower the held-out error against ``base_errors`` (the science
    refitted alone) by the test a term must pass (``evidence.verdict``); and its part on each equation must count
    in that: the whole network against the network without that part, by the same test. A part that does not
    count learned what the science's parameters and the other parts explain (noise, theta's error), and a closed
    form of it would be noise too. Parts are dropped one at a time, never kept alone: parts on several equations
    can balance each other (a flow between compartments), and dropping one of them breaks that and counts
    against the drop. Where a simulation fails or a held-out trajectory runs off to infinity (the network off
    its visited states) there is no evidence either way, and the equations are kept.
    """
    whole = _errors_with_network(judge, science, theta, network)
    if whole is None:
        return list(components)
    verdict = evidence.verdict(base_errors, whole)
    log(f"  the network, frozen in the science model: validation MSE {verdict['mse_after']:.4g} "
        f"(gain {verdict['gain']:.1%}, z {verdict['z']:.1f})"
        + ("" if verdict["accepted"] else ": no held-out evidence of an effect there, no search"))
    if not verdict["accepted"]:
        return []
    with torch.no_grad():
        output = network(*(torch.as_tensor(np.asarray(a, dtype=float)) for a in args)).numpy()
    acting = set(np.flatnonzero(np.any(output.reshape(len(output), -1) != 0, axis=0)))
    out = []
    for j in components:
        # the network without its part on j: where nothing else of it acts, that is the science alone
        without = (base_errors if not acting - {j} else
                   _errors_with_network(judge, science, theta, network, drop=j))
        if without is None:
            out.append(j)
            continue
        part = evidence.verdict(without, whole)
        log(f"  its part on equation {j}: validation MSE {part['mse_before']:.4g} without it (gain {part['gain']:.1%}, "
            f"z {part['z']:.1f})" + ("" if part["accepted"] else ": no held-out evidence of an effect there, no "
                                     "search on it"))
        if part["accepted"]:
            out.append(j)
    return out


def _errors_with_network(judge: Any, science: Callable, theta: Mapping[str, Any], network: Callable,
                         drop: int | None = None) -> np.ndarray | None:
    """Held-out errors of ``science`` plus the frozen ``network`` (without its output ``drop``), the science
    parameters refitted around it; None where a simulation failed or ran off to infinity."""
    inputs, defaults = read_signature(science)

    def with_network(*args, **values):
        out = network(*args)
        if drop is not None:
            out = out.clone()
            out[..., drop] = 0.0
        return science(*args, **values) + out

    with_network.__signature__ = inspect.Signature(
        [inspect.Parameter(n, inspect.Parameter.POSITIONAL_OR_KEYWORD) for n in inputs]
        + [inspect.Parameter(k, inspect.Parameter.KEYWORD_ONLY, default=v) for k, v in defaults.items()])
    try:
        after = judge.errors(with_network, judge.fit(with_network, theta))
    except FIT_FAILURES:  # the network off its visited states broke a simulation: no verdict either way
        return None
    return after if np.all(np.isfinite(after)) else None


def rank_by_residual(columns: list[tuple], remaining: np.ndarray, jac: np.ndarray, components: Sequence[int],
          taken: set) -> list[PlacedTerm]:
    """Every (component, term) scored by the share of the remaining residual it explains.

    The term is fitted together with the parameter sensitivities of its component, so a term that
    only stands in for a parameter shift gains nothing.
    """
    total = float(sum(np.sum(remaining[:, j] ** 2) for j in components)) or 1.0
    by_name: dict[str, list] = {}
    for term, shape, col in columns:
        by_name.setdefault(term.name, []).append((term, shape, col))
    ranked = []
    for j in components:
        Q = parameter_basis(jac[:, j, :])
        r = remaining[:, j] - Q @ (Q.T @ remaining[:, j])
        for name, options in by_name.items():
            if (j, name) in taken:
                continue
            best = None
            for term, shape, col in options:
                if term.component not in (None, j):
                    continue
                c = col - Q @ (Q.T @ col)
                cc = float(c @ c)
                if cc < 1e-3 * float(col @ col):  # within the parameters' span: a shift, not a term
                    continue
                gain = float(c @ r) ** 2 / cc
                # (this compares the unscaled gain with the best one's share of the total, as it always has)
                if best is None or gain > best.gain:
                    best = PlacedTerm(term, j, shape, float(c @ r) / cc, gain / total)
            if best is not None:
                ranked.append(best)
    return sorted(ranked, key=lambda t: -t.gain)


def rank_by_fit(columns: list[tuple], science: Callable, current: Callable, added: list[PlacedTerm],
                 theta: Mapping[str, Any], fit: ScienceFit, scale: np.ndarray, components: Sequence[int],
                 taken: set, names: Sequence[str], n_states: int,
                 param_names: Mapping[str, str] | None) -> list[PlacedTerm]:
    """Every (component, term, shape) scored by the training error its addition removes, without the network.

    A score test in trajectory space: the sensitivity of the network-free prediction to the new
    term's coefficient (forward difference at 0; a science term scaled by a factor is also read at its law's
    coefficient, :func:`_readings`), made orthogonal to the sensitivities of the
    parameters already there, explains a share of the remaining training error. This does not rely
    on the network having learned the missing effect well: where the hybrid fit traded the effect
    between theta and the network, the ranking by its residual (:func:`rank_by_residual`) misleads.
    ``current`` is ``science`` with the ``added`` terms.
    """
    base = fit.predict(current, theta).ravel()
    r = fit.y.ravel() - base
    J = free_columns(*finite_differences(lambda values: fit.predict(current, values).ravel(), theta), fit.fixed)
    J = J[:, np.all(np.isfinite(J), axis=0)]
    Q = np.linalg.qr(J)[0] if J.shape[1] else np.zeros((len(base), 0))
    r = r - Q @ (Q.T @ r)
    total = float(r @ r) or 1.0
    placed = [PlacedTerm(term, j, shape, step) for term, shape, values in columns
              for size in [float(np.sqrt(np.mean(values ** 2)))] if np.isfinite(size) and size > 0
              for j in components if (j, term.name) not in taken and term.component in (None, j)
              for step in _readings(term, j, 1e-4 * scale[j] / size)]
    best: dict[tuple, PlacedTerm] = {}
    for cand, col in _trajectory_columns(placed, science, added, theta, fit, base, names, n_states, param_names):
        if not np.all(np.isfinite(col)):
            continue
        c = col - Q @ (Q.T @ col)
        cc = float(c @ c)
        if cc < 1e-6 * float(col @ col) or cc == 0:  # within the parameters' span
            continue
        gain = float(c @ r) ** 2 / cc / total
        if (cand.component, cand.name) not in best or gain > best[cand.component, cand.name].gain:
            best[cand.component, cand.name] = replace(cand, coef=float(c @ r) / cc, gain=gain, ranked_by="fit")
    return sorted(best.values(), key=lambda t: -t.gain)


def _readings(term: Term, component: int, step: float) -> tuple[float, ...]:
    """The coefficients a term's column is read at, its best reading kept: a small step (the prediction's
    derivative in the coefficient), and, for a science term scaled by a factor on its own equation, also the
    law's coefficient (the secant from the science to the law at the term's shape). A strong law moves the
    trajectories far from where the derivative was taken, and read there alone it ranks below looser forms; the
    secant at a shape of the coarse grid can miss where the derivative, its size free, comes near."""
    law = term.law_coefficient
    return (step,) if law is None or term.func.keywords["reference"] != component else (step, law)


# Candidates simulated together: one simulation's per-operation overhead (the solver's, the science's) is shared,
# while every lane evaluates all of the batch's terms.
BATCH = 32


def _trajectory_columns(placed: list[PlacedTerm], science: Callable, added: list[PlacedTerm],
                        theta: Mapping[str, Any], fit: ScienceFit, base: np.ndarray, names: Sequence[str],
                        n_states: int, param_names: Mapping[str, str] | None):
    """Each candidate with its column: the network-free prediction's forward difference in its coefficient,
    ``(prediction at coef - base) / coef`` (``cand.coef`` is the step). ``BATCH`` candidates share one vectorised
    simulation of the science with all of them, each lane moving one coefficient off zero. A batch that cannot
    be vectorised, or whose lane at zero is not ``base`` (a term not finite at a visited state: zero times it
    spoils the others' lanes), is simulated one candidate at a time."""
    for i in range(0, len(placed), BATCH):
        group, preds = placed[i:i + BATCH], None
        try:
            augmented = augment_with(science, [*added, *group], names, n_states, param_names)
        except ValueError:  # a parameter name taken twice (a name given for a term placed twice)
            augmented = None
        if augmented is not None:
            start = {**theta, **initial_values(augmented, [*added, *group], newest=len(group))}
            coefs = [augmented.terms[len(added) + k][2] for k in range(len(group))]
            rows = np.vstack([np.zeros(len(group)), np.diag([cand.coef for cand in group])])
            preds = fit.predict_many(augmented, start, coefs, rows)
        if preds is not None and np.allclose(preds[0].ravel(), base, rtol=1e-9, atol=1e-12, equal_nan=True):
            yield from ((cand, (preds[k + 1].ravel() - base) / cand.coef) for k, cand in enumerate(group))
            continue
        for cand in group:
            augmented = augment_with(science, [*added, cand], names, n_states, param_names)
            start = {**theta, **initial_values(augmented, [*added, cand])}
            with np.errstate(all="ignore"):
                yield cand, (fit.predict(augmented, start).ravel() - base) / cand.coef


def interleave(ranked: list[PlacedTerm], n: int) -> list[PlacedTerm]:
    """The ``n`` best candidates, taken in turn from each component's own ranking.

    Shares are compared within a component only: a large residual on one component (say the
    observed tank) must not crowd out every candidate for another (the unobserved one).
    """
    by_component: dict[int, list[PlacedTerm]] = {}
    for cand in ranked:
        by_component.setdefault(cand.component, []).append(cand)
    queues = sorted(by_component.values(), key=lambda q: -q[0].gain)
    out = []
    while len(out) < n and any(queues):
        for queue in queues:
            if queue and len(out) < n:
                out.append(queue.pop(0))
    return out


def first_models(ranked: list[PlacedTerm], n: int) -> list[PlacedTerm]:
    """The best ``n`` models of a ranking: a science term slowed down and the same term limited by one variable
    are one model once theta is refitted (:func:`~sklearn_hybrid.diagnosis.families.inhibited.other_form`), and
    tie; they take one place together, both kept, since the refit reaches a law at a finite coefficient only
    from its own form. A science term of a flux (its part on several equations) comes with its placements on
    the flux's other equations, so that it is screened as a group too: a factor of the flux acts on all of
    them, and alone on one it explains the other balances no better."""
    out, models = [], set()
    for cand in ranked:
        model = _model(cand)
        if model in models or len(models) < n:
            models.add(model)
            out.append(cand)
    fluxes = {c.name for c in out if c.kind in ("inhibited", "modulated") and c.term.component is None}
    kept = {c.key for c in out}
    return out + [c for c in ranked if c.name in fluxes and c.key not in kept]


def _model(cand: PlacedTerm) -> tuple:
    if cand.kind != "inhibited":
        return cand.key
    kw = cand.term.func.keywords
    return cand.component, kw["param"], kw["reference"], kw["x"], kw["power"]


def merge_rankings(*rankings: list[PlacedTerm]) -> list[PlacedTerm]:
    """The candidates of several rankings, taken in turn, each (component, term) once."""
    out, seen = [], set()
    for group in zip_longest(*rankings):
        for cand in group:
            if cand is not None and cand.key not in seen:
                seen.add(cand.key)
                out.append(cand)
    return out


def offset_candidate(state: int, variables: Sequence[str]) -> PlacedTerm:
    """The candidate "the sensor of this state reads with a constant offset", starting at zero."""
    return PlacedTerm(offset_term(f"offset({variables[state]})"), state, {}, 0.0, float("nan"), "declared")


def augment_with(science: Callable, placed: Sequence[PlacedTerm], variables: Sequence[str], n_states: int | None,
                 param_names: Mapping[str, str] | None):
    """``science`` with the ``placed`` terms, in that order (:func:`~sklearn_hybrid.diagnosis.augment_science`,
    whose public input is a list of dicts: each term is handed over as one)."""
    terms = [{"component": t.component, "term": t.name, "kind": t.kind, "coef": t.coef, "function": t.term.func,
              "shape": t.shape, "param": (param_names or {}).get(t.name), "opposite": t.opposite,
              "shape_group": t.shape_group} for t in label_joined_shapes(list(placed))]
    return augment_science(science, terms, variables, n_states=n_states)


def initial_values(augmented, placed: Sequence[PlacedTerm], newest: int = 1) -> dict:
    """Starting values of the coefficients and shape parameters of the ``newest`` terms."""
    out = {}
    for i in range(len(placed) - newest, len(placed)):
        out[augmented.terms[i][2]] = placed[i].coef
        out.update({glob: placed[i].shape[local] for local, glob in augmented.shape_names[i].items()})
    return out


def shape_bounds(augmented, placed: Sequence[PlacedTerm]) -> dict:
    """The bounds of the ``placed`` terms' shape parameters, by their names in ``augmented``."""
    return {glob: t.term.shape[local][1] for t, names in zip(placed, augmented.shape_names)
            for local, glob in names.items()}
