"""Fewer parameters where the data need no more: stand-ins replaced, a discovered form's spare constants dropped.

A selection that adds one term at a time can end with two stand-ins that explain an effect only
together: for a heat loss ``T^2.7`` a square root and an exponential, each accepted in its own step,
where the power law ``|T|^p`` alone does as well. The stand-ins also pull the science parameters
off their values (each fits part of the effect and the parameters the rest). :func:`replace_stand_ins`
tries, on every equation that ended with two or more terms not all polynomial, the single terms of
the other kinds that best explain what those terms explain, and keeps the one whose model validates
within ``min_gain`` of the model with the stand-ins, when it has fewer parameters. It only ever
removes parameters, so it cannot add a term where nothing is missing.

:func:`drop_spare_constants` does the same within a discovered form (``kind="discovered"``): each of its
constants set to zero in turn (:func:`~sklearn_hybrid.diagnosis.families.symbolic.reduced_forms`), the
reduced form kept where its model validates within ``min_gain`` of the full one, and so does a term with
``reductions`` (a difference of two phases tried without its phase). The search fits its forms
to what the network learned, whose error a spare constant takes up; in the refit such a constant trades
with theta. :func:`one_shape_per_flux` puts an accepted discovered form in place of another equation's
discovered form, sharing the first one's constants, where that validates as well: a flux taken on one equation
and, in another step, a rival form of it on another. :func:`canonical_inhibited` writes an accepted inhibited
term slowed down, or limited where that is the law.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import replace

import numpy as np

from ...science import read_signature
from ..evidence import Evidence
from ..judge import FIT_FAILURES, Judge
from .candidates import Candidates, augment_with, initial_values, rank_by_residual, shape_bounds
from ..families.inhibited import other_form
from ..families.symbolic import reduced_forms
from .placed import PlacedTerm, label_joined_shapes
from ..results import Step, Verdict
from ..sensitivity import free_columns, parameter_jacobian, science_output

__all__ = ["replace_stand_ins", "drop_spare_constants", "one_shape_per_flux", "canonical_inhibited"]

#: How far below -1 an inhibited term's coefficient may fall and still be read as the law's -1 (the noise in a
#: fitted coefficient): ``canonical_inhibited`` keeps a limited form there.
LAW_SLACK = 0.1


def replace_stand_ins(science: Callable, current: Callable, added: list[PlacedTerm], theta: dict,
                      errors: np.ndarray, judge: Judge, columns: list[tuple], learned: np.ndarray,
                      args: Sequence[np.ndarray], variables: Sequence[str], n_states: int,
                      param_names: Mapping[str, str] | None, steps: list[Step], log: Callable[[str], None], *,
                      evidence: Evidence, candidates: Candidates = Candidates(),
                      fixed: set = frozenset()) -> tuple:
    """Replace the terms of an equation by one term of another kind that validates as well.

    Parameters
    ----------
    science, current : callable
        The original science function, and it with the ``added`` terms.
    added : list of PlacedTerm
        The accepted terms, fitted (as :func:`~sklearn_hybrid.diagnosis.loop.stepwise.forward_selection`
        keeps them), with ``theta`` their model's parameters and ``errors`` its held-out errors.
    judge : Judge
        Refits and held-out errors, the selection's own.
    columns, learned, args, variables, n_states, param_names
        As in the selection: the terms' columns on the visited states, what the hybrid learned
        there, the science function's inputs, the variables' names, the number of states, and the
        new coefficients' names.
    steps : list of Step
        The selection's rows; each replacement tried adds one (``step`` ``"replace"``).
    evidence : Evidence
        A replacement does as well when its held-out error is within ``min_gain`` of the model's.
    candidates : Candidates, default=Candidates()
        Its ``n_candidates``: the single terms tried per equation.
    fixed : set of str
        Parameters the refits hold (they cannot absorb a shift).

    Returns
    -------
    tuple
        ``(current, added, theta, errors)``, replaced where a single term did as well.
    """
    min_gain = evidence.min_gain
    for j in sorted({t.component for t in added if t.kind != "offset"}):
        on_j = [t for t in added if t.component == j and t.kind != "offset"]
        if len(on_j) < 2 or all(t.kind == "polynomial" for t in on_j):
            continue  # a Taylor reading (x + x^3, the two terms of a limit cycle) is not a stand-in
        rest = [t for t in added if t not in on_j]
        reduced = augment_with(science, rest, variables, n_states, param_names)
        start = _start(science, reduced, rest, theta)
        try:
            base = judge.fit(reduced, start, shape_bounds(reduced, rest))
        except FIT_FAILURES:
            continue
        remaining = learned - science_output(reduced, base, args)
        jac = free_columns(*parameter_jacobian(reduced, base, args), fixed)
        kinds, budget = {t.kind for t in on_j}, sum(t.n_parameters() for t in on_j)
        taken = {t.key for t in rest}
        ranked = [c for c in rank_by_residual(columns, remaining, jac, [j], taken)
                  if c.kind not in kinds and c.n_parameters() < budget][:candidates.n_candidates]
        best = None
        for cand in ranked:
            refit = _judged_refit(science, [*rest, cand], base, 1, judge, variables, n_states, param_names,
                                  float(np.mean(errors)), min_gain)
            if refit is None:
                continue
            model, fitted, cand_errors, judged = refit
            steps.append(Step.of("replace", cand.row(), verdict=judged, replaces=[t.name for t in on_j]))
            log(f"  replace {', '.join(t.name for t in on_j)} on component {j} by {cand.name}: validation "
                f"MSE {judged.mse_after:.4g} against {judged.mse_before:.4g}{' (as well)' if judged.accepted else ''}")
            if judged.accepted and (best is None or judged.mse_after < best[0]):
                best = (judged.mse_after, cand, model, fitted, cand_errors, len(steps) - 1)
        if best is None:
            continue
        _, cand, current, theta, errors, index = best
        added = _kept(steps, index, current, theta, [*rest, cand])  # the new one: no second look
        log(f"  replaced {', '.join(t.name for t in on_j)} on component {j} by {cand.name}")
    return current, added, theta, errors


def drop_spare_constants(science: Callable, current: Callable, added: list[PlacedTerm], theta: dict,
                         errors: np.ndarray, judge: Judge, variables: Sequence[str], n_states: int,
                         param_names: Mapping[str, str] | None, steps: list[Step], log: Callable[[str], None], *,
                         evidence: Evidence) -> tuple:
    """Set each constant of each accepted discovered form to zero in turn (or, for a term with ``reductions``,
    take each of those), and keep the reduced form whose model validates best within ``evidence.min_gain`` of the
    model's; again until none does.

    A group's members (one form on several equations, ``shape_group``) are reduced together. The arguments
    are :func:`replace_stand_ins`'s; each reduction tried adds a row to ``steps`` (``step`` ``"simplify"``).

    Returns
    -------
    tuple
        ``(current, added, theta, errors)``, with the spare constants dropped.
    """
    original = read_signature(science)[1]
    while True:
        now, best = float(np.mean(errors)), None
        start = {k: theta[k] for k in original}  # the science's own parameters; the terms from their values
        units = {}  # a group's members reduce together: one unit per shape group, or per single term
        for t in added:
            if t.kind == "discovered" or t.term.reductions:
                units.setdefault(t.shape_group or id(t), []).append(t)
        for members in units.values():
            for term in members[0].term.reductions or reduced_forms(members[0].term):
                group = members[0].shape_group and term.name
                made = {id(m): replace(m, term=term, shape={k: m.shape[k] for k in term.shape}, shape_group=group,
                                       param=None, shape_params=None) for m in members}
                placed = [made.get(id(t), t) for t in added]
                refit = _judged_refit(science, placed, start, len(placed), judge, variables, n_states, param_names,
                                      now, evidence.min_gain)
                if refit is None:
                    continue
                model, fitted, cand_errors, judged = refit
                row = made[id(members[0])].row()
                if len(members) > 1:
                    row["component"] = [m.component for m in members]
                steps.append(Step.of("simplify", row, verdict=judged, replaces=[members[0].name]))
                log(f"  simplify {members[0].name} to {term.name}: validation MSE {judged.mse_after:.4g} against "
                    f"{now:.4g}{' (as well)' if judged.accepted else ''}")
                if judged.accepted and (best is None or judged.mse_after < best[0]):
                    best = (judged.mse_after, members[0].name, term.name, model, fitted, cand_errors, placed,
                            len(steps) - 1)
        if best is None:
            return current, added, theta, errors
        _, old, new, current, theta, errors, placed, index = best
        added = _kept(steps, index, current, theta, placed)
        log(f"  simplified {old} to {new}")


def one_shape_per_flux(science: Callable, current: Callable, added: list[PlacedTerm], theta: dict,
                       errors: np.ndarray, judge: Judge, variables: Sequence[str], n_states: int,
                       param_names: Mapping[str, str] | None, steps: list[Step], log: Callable[[str], None], *,
                       evidence: Evidence) -> tuple:
    """Replace a discovered form on one equation by another equation's discovered form, joined to its shape,
    where the model validates within ``evidence.min_gain`` of the model's; again until none does.

    One flux, one shape: the selection may take a predation's law on the prey's equation and, in another step,
    a rival form on the predator's that a science parameter completes (``y/(K + x^2)`` beside ``-m y`` where the
    law is ``x^2 y/(K + x^2)``), at the cost of the law with a shape of its own. The law joined to the held shape
    costs a coefficient only. The arguments are :func:`replace_stand_ins`'s; each replacement tried adds a row
    to ``steps`` (``step`` ``"one shape"``).

    Returns
    -------
    tuple
        ``(current, added, theta, errors)``, with the replacements that validated.
    """
    original = read_signature(science)[1]
    tried: set[tuple] = set()
    while True:
        now, best = float(np.mean(errors)), None
        start = {k: theta[k] for k in original}  # the science's own parameters; the terms from their values
        shaped = [t for t in added if t.shape and t.kind == "discovered" and t.opposite is None]
        names = {t.key for t in added}
        for held in shaped:
            for other in shaped:
                if other.component == held.component or (other.component, held.name) in names \
                        or (held.key, other.key) in tried or other.shape_group is not None:
                    continue
                tried.add((held.key, other.key))
                joined = replace(held, component=other.component, coef=other.coef, shape_group=held.name,
                                 shares_shape=True, param=None, shape_params=None, second_look=False)
                placed = label_joined_shapes([t for t in added if t is not other] + [joined])
                refit = _judged_refit(science, placed, start, len(placed), judge, variables, n_states, param_names,
                                      now, evidence.min_gain)
                if refit is None:
                    continue
                model, fitted, cand_errors, judged = refit
                steps.append(Step.of("one shape", joined.row(), verdict=judged, replaces=[other.name]))
                log(f"  {other.name} on component {other.component} as {held.name}, its shape shared: validation "
                    f"MSE {judged.mse_after:.4g} against {now:.4g}{' (as well)' if judged.accepted else ''}")
                if judged.accepted and (best is None or judged.mse_after < best[0]):
                    best = (judged.mse_after, other, held, model, fitted, cand_errors, placed, len(steps) - 1)
        if best is None:
            return current, added, theta, errors
        _, other, held, current, theta, errors, placed, index = best
        added = _kept(steps, index, current, theta, placed)
        log(f"  replaced {other.name} on component {other.component} by {held.name}, its shape shared")


def canonical_inhibited(science: Callable, current: Callable, added: list[PlacedTerm], theta: dict,
                        errors: np.ndarray, judge: Judge, variables: Sequence[str], n_states: int,
                        param_names: Mapping[str, str] | None, steps: list[Step], log: Callable[[str], None], *,
                        evidence: Evidence, values: np.ndarray) -> tuple:
    """Write each accepted inhibited term on its own equation slowed down, or limited where that is the law.

    Slowed down, ``T (1 + c |x|^n/(K^n + |x|^n))``, and limited, ``T (1 + c' K^n/(K^n + |x|^n))``, are the same
    functions of ``x`` beside the science's term ``T = p d``: ``p' = p (1 + c)``, ``c' = -c / (1 + c)``. The data
    cannot choose between them, but ``p`` is the term's rate at rest in one and at saturation in the other, and a
    law of one form reached through the other sits at ``p`` near zero and a large coefficient (an eddy-current
    brake ``c v / (1 + (v/K)^2)`` as the limited form: c 0.0009, coefficient 454). The limited form is kept where
    its coefficient is the law's -1 (within ``LAW_SLACK``, or a part of it, down to 0: a rate that needs ``x``);
    everywhere else the term is written slowed down, ``p`` the science's rate at rest, where an effect that
    vanishes there leaves it (a kill ``-a x c^2/(K^2 + c^2)`` beside a growth ``g x``: the limited form holds
    ``g (1 + c')``, the growth and the kill at saturation). A limited reading needs its saturation in the data:
    its ``K`` within the visited ``|x|`` (``values``, one column per variable); beyond them the factor is a
    power of ``x`` and ``p'`` holds ``1/K^n`` (a Q10 growth read as limited, ``K`` three times the warmest
    temperature visited: r 5.7 for 1.0). The other form is refitted from the converted values and kept where it
    validates within ``evidence.min_gain`` (it is the same model). The other arguments are
    :func:`replace_stand_ins`'s; each one tried adds a row to ``steps`` (``step`` ``"canonical"``).

    Returns
    -------
    tuple
        ``(current, added, theta, errors, renamed)``; ``renamed`` maps a replaced term's key to its new one.
    """
    def law(c):
        return -1.0 - LAW_SLACK <= c <= 0.0

    renamed = {}
    for t in list(added):
        keywords = t.term.func.keywords if t.kind == "inhibited" else {}
        if not keywords or t.opposite is not None or t.shape_group is not None or t.component != keywords["reference"]:
            continue  # on its own equation only: elsewhere the part's yield enters the coefficient
        c, p, limited = theta[t.param], keywords["param"], keywords.get("limited", False)
        if c == -1.0:  # the other form has no finite coefficient
            continue
        seen = theta[t.shape_params["K"]] <= np.max(np.abs(values[:, list(variables).index(keywords["x"])]))
        # limited where that is the law (c' = -c / (1 + c) for a slowed-down term) and its saturation is seen
        if limited == (seen and law(c if limited else -c / (1.0 + c)) and (limited or not law(c))):
            continue
        twin = replace(t, term=other_form(t.term), coef=-c / (1.0 + c), param=None, shape_params=None,
                       shape={"K": theta[t.shape_params["K"]]}, second_look=False)
        placed = [twin if s is t else s for s in added]
        start = {k: theta[k] for k in read_signature(science)[1]}
        start[p] = theta[p] * (1.0 + c)
        refit = _judged_refit(science, placed, start, len(placed), judge, variables, n_states, param_names,
                              float(np.mean(errors)), evidence.min_gain)
        if refit is None:
            continue
        model, fitted, cand_errors, judged = refit
        steps.append(Step.of("canonical", twin.row(), verdict=judged, replaces=[t.name]))
        log(f"  {t.name} (coefficient {c:.4g}) as {twin.name} (coefficient {-c / (1.0 + c):.4g}): validation MSE "
            f"{judged.mse_after:.4g} against {float(np.mean(errors)):.4g}{' (as well)' if judged.accepted else ''}")
        if judged.accepted:
            added = _kept(steps, len(steps) - 1, model, fitted, placed)
            current, theta, errors = model, fitted, cand_errors
            renamed[t.key] = twin.key
    return current, added, theta, errors, renamed


def _kept(steps: list[Step], index: int, current: Callable, theta: dict, placed: list[PlacedTerm]) -> list[PlacedTerm]:
    """The stage's choice kept: ``steps[index]`` marked accepted, and ``placed`` read at their fitted values
    in ``current`` (``theta``), as the model's terms from now on."""
    steps[index] = replace(steps[index], accepted=True)
    return [t.with_fitted(current, theta, k) for k, t in enumerate(placed)]


def _judged_refit(science: Callable, placed: list[PlacedTerm], base: dict, newest: int, judge: Judge,
                  variables: Sequence[str], n_states: int, param_names: Mapping[str, str] | None, now: float,
                  min_gain: float) -> tuple | None:
    """The model of ``placed`` refitted from ``base`` (its last ``newest`` terms from their own values) and
    judged against the held-out error ``now``: ``(model, fitted, errors, verdict)``, the verdict accepted where
    the refit validates within ``min_gain`` of ``now``; None where the refit failed."""
    model = augment_with(science, placed, variables, n_states, param_names)
    bounds = shape_bounds(model, placed)
    try:
        fitted = judge.fit(model, {**base, **initial_values(model, placed, newest)}, bounds)
        errors = judge.errors(model, fitted, bounds)
    except FIT_FAILURES:
        return None
    mse = float(np.mean(errors))
    ok = bool(np.isfinite(mse) and mse <= (1 + min_gain) * now)
    return model, fitted, errors, Verdict(now, mse, 1 - mse / now if now > 0 else 0.0, float("nan"), None, ok)


def _start(science: Callable, reduced, rest: list[PlacedTerm], theta: dict) -> dict:
    """The reduced model's starting values: the original parameters and the kept terms' latest values."""
    start = {k: v for k, v in theta.items() if k in read_signature(science)[1]}
    for k, t in enumerate(rest):
        start[reduced.terms[k][2]] = theta[t.param]
        start.update({glob: theta[t.shape_params[loc]] for loc, glob in reduced.shape_names[k].items()})
    return start
