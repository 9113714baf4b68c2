"""Forward selection of missing terms: rank two ways, accept on held-out evidence.

One step ranks every candidate term twice: by how much of the residual the network still carries
beyond the current science model it explains on the visited states (fitted together with the
science parameters' sensitivities, which absorb mere parameter shifts), and by how much of the
network-free model's training error its addition would remove (a score test on the trajectories,
which does not trust the network to have learned the effect). The best few of each ranking are
added to the science model one at a time (and a term that ranks on several components also on all
of them at once: a reaction's flux enters every balance it converts; the terms of one vector field,
each on its own equation: a drag along the speed acts on every velocity component; and sets of terms on one equation
that explain the residual only together, :func:`~sklearn_hybrid.diagnosis.loop.joint.joint_candidates`,
judged as one family per step by Holm's rule), refitted without the network
(:class:`ScienceFit`, on at most 256 evenly spaced training samples) and judged on validation
samples (:class:`~sklearn_hybrid.diagnosis.judge.Judge`, :func:`evidence`).
The best one that passes is refitted on every training sample and kept, and a term kept earlier
that it makes dispensable (the model without it validates as well) is dropped; the next step
starts from there. Selection stops when no candidate passes; an equation left with two or more
terms, not all polynomial, then has them replaced by one term of another kind that validates as well
(:func:`~sklearn_hybrid.diagnosis.loop.collapse.replace_stand_ins`), a discovered form on one equation gives
way to another equation's, its constants shared, where that validates as well
(:func:`~sklearn_hybrid.diagnosis.loop.collapse.one_shape_per_flux`), and a discovered form's constants that
the held-out data do not need are dropped (:func:`~sklearn_hybrid.diagnosis.loop.collapse.drop_spare_constants`).
The candidates, their rankings and their augmented models are built in
:mod:`~sklearn_hybrid.diagnosis.loop.candidates`.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import replace
from typing import Any

import numpy as np
import torch

from ...science import read_signature
from ..judge import FIT_FAILURES, Judge, training_folds
from .candidates import (Candidates, augment_with, discovered_terms, first_models, initial_values, interleave,
                         merge_rankings, network_carries, offset_candidate, rank_by_residual, rank_by_fit, shape_bounds,
                         term_columns)
from .collapse import canonical_inhibited, drop_spare_constants, one_shape_per_flux, replace_stand_ins
from .groups import (candidate_groups, field_groups, first_placements, flow_candidates, flow_groups,
                     join_shape_groups)
from ..evidence import Evidence
from .joint import joint_candidates
from .placed import PlacedTerm, label_joined_shapes
from .report import format_gain
from ..results import Selection, Step
from .second_look import Screened, correct_joint, look_again, simplest_of_the_best
from ..sensitivity import free_columns, parameter_jacobian, science_output
from ..science_fit import ScienceFit
from ..families.base import TermContext
from ..families.inhibited import inhibited_terms, linear_parts, part_reader
from ..families.physics import PHASE_DIFFERENCES
from ..terms import SCIENCE_OUTPUT, TermVariables

__all__ = ["forward_selection"]


def forward_selection(science: Callable, theta: Mapping[str, Any], fit: ScienceFit,
                      splits: Sequence[tuple[np.ndarray, np.ndarray]], variables: Sequence[str], n_states: int,
                      args: Sequence[np.ndarray], learned: np.ndarray, components: Sequence[int], *,
                      candidates: Candidates, evidence: Evidence,
                      param_names: Mapping[str, str] | None = None, groups: np.ndarray | None = None,
                      offsets: Sequence[int] = (), flow_pairs: Sequence[tuple[int, int]] = (),
                      units: Mapping[str, str] | None = None, network: Callable | None = None,
                      log: Callable[[str], None] = lambda s: None) -> dict:
    """Add terms one at a time while a network-free refit validates better by more than the noise.

    With one split, when no candidate passes but some lowered the validation error by ``min_gain``
    with z above 2, those are judged again by ``evidence.second_look`` contiguous folds of the
    *training* samples (see :func:`look_again`).

    Parameters
    ----------
    science : callable
        The original science function.
    theta : dict
        Starting values of its parameters (the hybrid fit's ``theta_``).
    fit : ScienceFit
        Network-free simulation over every sample.
    splits : list of (train, validation) row-index pairs
        One pair: fitted on ``train``, judged on ``validation``. Several (contiguous blocks as
        validation, the other rows as train): every sample judges, by a fit without its block.
    variables : list of str
        Names of the columns of ``args`` (states, then inputs).
    n_states : int
        Number of state columns (the rest are inputs).
    args : list of ndarray
        The science function's inputs at the states the network visited.
    learned : ndarray of shape (n_points, n_outputs)
        What the hybrid model learned there: science output plus network.
    components : list of int
        Outputs that may receive terms (the uncertain ones).
    candidates : Candidates
        The terms (``terms``: a list, the library itself), ``max_terms`` and ``n_candidates``.
    evidence : Evidence
        The test a candidate must pass (``z``, ``min_gain``) and the second look (``second_look``). Its
        samples are ``splits`` and ``groups``: the selection's own, which may be windows of the records.
    param_names : dict of str to str, optional
        Names of the new coefficients by term.
    groups : ndarray of int, optional
        Every sample's group, numbered from 0 (see ``evidence.held_out_splits``): the
        evidence compares one mean error per judged group.
    offsets : list of int, optional
        States whose sensor may read with a constant offset: each is a candidate at every step until
        accepted (an offset changes every equation that reads the state, so no ranking of
        right-hand-side columns can rank it), judged like a term.
    flow_pairs : list of (int, int), optional
        Components whose states may exchange (one unit): a term ranked on both with opposite signs is also a
        candidate as a flow, one coefficient for both
        (:func:`~sklearn_hybrid.diagnosis.loop.groups.flow_candidates`), and as a group, a coefficient
        each (a yield other than one, :func:`~sklearn_hybrid.diagnosis.loop.groups.flow_groups`).
    units : dict of str to str, optional
        The variables' units: a discovered form that adds quantities of different units is marked.
    network : callable, optional
        The fitted network as the science's inputs feed it (``network(*args)``, shaped like the science's
        output): with ``candidates.discovery``, the search runs only on the equations where the network's
        part, frozen in the science model, lowers the held-out error (:func:`network_carries`); without it,
        wherever the listed terms leave the residual unexplained.

    Returns
    -------
    Selection
        ``science`` (augmented function, or the original), ``theta`` (fitted on the training
        samples), ``added`` (the accepted terms, fitted: :class:`PlacedTerm`), ``steps`` (a
        :class:`~sklearn_hybrid.diagnosis.results.Step` per candidate tried, with its validation error
        and verdict), ``rivals`` (candidates the held-out
        data could not tell from the choice: ``role`` ``"instead"`` of the accepted terms ``of`` (their
        keys) or ``"add"``-ed to the final model, with ``cand``, its screening fit ``theta`` and
        validation ``mse``), ``base_errors`` /
        ``errors`` (validation errors per sample before any term and at the end) and ``seconds``.
    """
    start_time = time.perf_counter()
    values = np.hstack([np.asarray(a).reshape(len(a), -1) for a in args])
    parts = linear_parts(science, theta, args) if candidates.discovery else {}
    tensors = TermVariables({name: torch.as_tensor(np.asarray(col, dtype=float))
                             for name, col in zip(variables, values.T)}, part_reader(science, theta, args))
    tensors[SCIENCE_OUTPUT] = torch.as_tensor(science_output(science, theta, args), dtype=torch.float64)
    columns = term_columns(candidates.terms, tensors)
    judge = Judge(fit, splits, groups)
    recheck = training_folds(fit, splits, groups, evidence.second_look)
    current, theta_now = science, judge.fit(science, theta)
    judge.settle(science, theta_now)
    errors = base_errors = judge.errors(science, theta_now)
    if candidates.discovery:  # closed forms for what the network learned, at the hybrid's own theta
        carried = None if network is None else (lambda wanted: network_carries(
            judge, science, theta_now, network, base_errors, evidence, wanted, args, log))
        found = discovered_terms(candidates, columns, np.asarray(learned) - tensors[SCIENCE_OUTPUT].numpy(),
                                 free_columns(*parameter_jacobian(science, theta, args), fit.fixed), values,
                                 tensors[SCIENCE_OUTPUT].numpy(), variables, n_states, components, log, units,
                                 carried)
        columns += term_columns(found, tensors)
        # the science's own terms slowed down or limited by a variable: laws the search finds only among many forms
        inhibited = inhibited_terms(parts, variables, values, components)
        log(f"  {len(inhibited)} inhibited or modulated science term(s) offered, of parameter(s) "
            f"{', '.join(parts) or 'none'}")
        columns += term_columns(inhibited, tensors)
        # two phases that pull on each other: no harmonic of one angle in the list makes that term
        columns += term_columns(PHASE_DIFFERENCES.terms(TermContext(tuple(variables), values, dict(units or {}),
                                                                    n_states)), tensors)
    # each discovered form is judged in the ODE at least once, placed where it explains most and as a flow:
    # the rankings read it at the constants the search gave it, fitted to what the network learned, which
    # carries the network's own error; a law whose constants the refit moves may rank below a stand-in there
    unjudged = {t.name for t in found} if candidates.discovery else set()
    scale = np.sqrt(np.mean(np.asarray(learned, dtype=float) ** 2, axis=0))
    log(f"science refitted alone: validation MSE {errors.mean():.4g}")
    added: list[PlacedTerm] = []
    # A term dropped by the converged test right after the screening test accepted it: not proposed
    # again (the two tests disagree on it, and proposing it again would repeat the same step forever).
    rejected: set[tuple] = set()
    visited: set[frozenset] = {frozenset()}
    known: dict[tuple, dict] = {}  # each model the path settled on (its terms in order) and its fit
    steps: list[Step] = []
    # candidates the held-out data could not tell from the choice: instead of an accepted term (within
    # min_gain of its error) or, at the last step, added to the final model (lowering its error a little)
    rivals: list[dict] = []
    step = 0
    while len(added) < candidates.max_terms:
        step += 1
        remaining = learned - science_output(current, theta_now, args)
        jac = free_columns(*parameter_jacobian(current, theta_now, args), fit.fixed)
        taken = {k for t in added for k in t.covers} | rejected
        scored = rank_by_residual(columns, remaining, jac, components, taken)
        by_residual = interleave(scored, candidates.n_candidates)
        by_fit = first_models(rank_by_fit(columns, science, current, added, theta_now, judge.screen, scale,
                                          components, taken, variables, n_states, param_names), candidates.n_candidates)
        declared = [offset_candidate(k, variables) for k in offsets]
        ranked = merge_rankings(by_residual, by_fit) + [c for c in declared if c.key not in taken]
        in_ranked = {r.key for r in ranked}
        ranked += [c for c in first_placements(scored, unjudged) if c.key not in in_ranked]
        if not ranked:
            break
        tried: list[Screened] = []
        room = candidates.max_terms - len(added)  # a group adds a term per member
        together = [g for g in candidate_groups(ranked) + field_groups(ranked, scored) if len(g.members) <= room]
        joint = [g for g in joint_candidates(columns, remaining, jac, components, taken, n=candidates.n_candidates)
                 if len(g.members) <= room]
        every_flow = flow_candidates(scored, flow_pairs, len(scored))  # best first
        flows = [f for f in every_flow[:candidates.n_candidates] if not f.covers & taken]
        in_flows = {f.key for f in flows}
        flows += [f for f in every_flow if f.name in unjudged and not f.covers & taken and f.key not in in_flows]
        unjudged = set()
        grouped = {frozenset(m.key for m in g.members) for g in together}
        together += [g for g in flow_groups(flows, scored) if len(g.members) <= room
                     and frozenset(m.key for m in g.members) not in grouped]
        for cand in join_shape_groups(added, ranked + flows) + together + joint:
            placed = [*added, *(_at_law(e) for e in cand.entries())]
            candidate_science = augment_with(science, placed, variables, n_states, param_names)
            start = {**theta_now, **initial_values(candidate_science, placed, len(cand.entries()))}
            try:
                bounds = shape_bounds(candidate_science, placed)
                fitted = _screen(judge, candidate_science, start, bounds, len(added), theta)
                cand_errors = judge.errors(candidate_science, fitted, bounds, screening=True)
            except FIT_FAILURES as exc:  # a term that breaks the simulation
                steps.append(Step.of(step, cand.row(), failed=repr(exc)))
                continue
            verdict = evidence.verdict(errors, cand_errors)
            steps.append(Step.of(step, cand.row(), verdict=verdict))
            log(f"  step {step}: {cand.name} on {cand.where()}: validation MSE "
                f"{verdict['mse_after']:.4g} (gain {format_gain(verdict['gain'])}, z {verdict['z']:.1f})")
            tried.append(Screened(cand, fitted, verdict, cand_errors, candidate_science, len(steps) - 1))
        correct_joint(tried, steps, len(joint), evidence, log)
        best = simplest_of_the_best(tried, evidence.min_gain)
        if best is None and recheck is not None:
            best = look_again(recheck, tried, current, theta_now, added, steps, evidence, log, len(joint))
        if best is None:
            rivals += [{"role": "add", "cand": t.cand, "theta": t.theta, "mse": t.verdict["mse_after"]} for t in tried
                       if t.verdict["gain"] > 0 and np.isfinite(t.verdict["mse_after"])]
            break
        best_mse = best.verdict["mse_after"]
        rivals += [{"role": "instead", "of": _key(best.cand.entries()), "cand": t.cand, "theta": t.theta,
                    "mse": t.verdict["mse_after"]} for t in tried
                   if t.cand is not best.cand and t.verdict["mse_after"] <= (1 + evidence.min_gain) * best_mse]
        cand, theta_now, _, errors, current, index, second_look = best
        # the screen may have stopped early: converge, so that the next step's gains are the terms'
        bounds = shape_bounds(current, [*added, *cand.entries()])
        theta_now = judge.fit(current, theta_now, bounds)
        errors = judge.errors(current, theta_now, bounds)
        steps[index] = replace(steps[index], accepted=True)
        added = label_joined_shapes(added + [replace(entry.with_fitted(current, theta_now, len(added) + k),
                                                     second_look=second_look)
                                             for k, entry in enumerate(cand.entries())])
        log(f"  accepted {cand.name} on {cand.where()}")
        known[_key(added)] = theta_now
        current, added, theta_now, errors = _drop_dispensable(
            science, current, added, theta_now, errors, judge, variables, n_states, param_names,
            evidence, steps, log, known, recheck)
        model = frozenset(t.key for t in added)
        dropped_at_once = {e.key for e in cand.entries()} - model
        rejected |= dropped_at_once
        if not dropped_at_once and model in visited:  # drops and additions that lead back to a model already left
            log("  stopped: the selection came back to a model it had left")
            break
        visited.add(model)
        judge.settle(current, theta_now)
    current, added, theta_now, errors = replace_stand_ins(
        science, current, added, theta_now, errors, judge, columns, learned, args, variables, n_states, param_names,
        steps, log, evidence=evidence, candidates=candidates, fixed=fit.fixed)
    current, added, theta_now, errors = one_shape_per_flux(
        science, current, added, theta_now, errors, judge, variables, n_states, param_names, steps, log,
        evidence=evidence)
    current, added, theta_now, errors = drop_spare_constants(
        science, current, added, theta_now, errors, judge, variables, n_states, param_names, steps, log,
        evidence=evidence)
    current, added, theta_now, errors, renamed = canonical_inhibited(
        science, current, added, theta_now, errors, judge, variables, n_states, param_names, steps, log,
        evidence=evidence, values=values)
    # a rival to a term written in its other form is a rival to that form: the same model
    rivals = [{**r, "of": tuple(renamed.get(k, k) for k in r["of"])} if "of" in r else r for r in rivals]
    return Selection(science=current, theta=theta_now, added=added, steps=steps, rivals=rivals,
                     base_errors=base_errors, errors=errors, seconds=time.perf_counter() - start_time)


def _at_law(entry: PlacedTerm) -> PlacedTerm:
    """The entry at its term's law coefficient where it has one and sits on the equation of the science term it
    scales, alone or as a flow out of it (into it: the opposite sign); the screening refit starts from the law."""
    law = entry.term.law_coefficient
    if law is None:
        return entry
    reference = entry.term.func.keywords["reference"]
    if entry.component == reference:
        return replace(entry, coef=law)
    return replace(entry, coef=-law) if entry.opposite == reference else entry


def _screen(judge: Judge, science, start: dict, bounds: dict, n_kept: int, origin: Mapping[str, Any]) -> dict:
    """The screening refit of a candidate model whose terms after the first ``n_kept`` are new.

    With the new coefficients at zero the candidate is the model the step continues from, so its
    refit can only end worse on its own training samples when the search got lost: a start that
    makes the simulation overflow (``exp(k*x)`` with its ranked coefficient and grid ``k``) clamps
    every residual, the Jacobian is zero and least squares stops where it began. Such a refit
    starts again from the new coefficients at zero. So does one that raises (a science function may
    raise at a start outside its domain). Before ScienceFit bounded a diverged simulation's finite
    residuals, least squares itself raised from such starts on a non-finite Jacobian (a Brusselator's
    ``x^2*y`` on dx/dt, ranked at 2.96, lost to three terms that stand in for it).

    A refit that still ends no better than that model did not move: the science refitted alone can sit
    where least squares cannot leave (a Michaelis constant refitted across zero, a pole inside the visited
    states). It is tried once more with the science's parameters at ``origin``, the hybrid's own theta
    the selection started from, and kept if better.
    """
    nested = {**start, **{coef: 0.0 for _, _, coef in science.terms[n_kept:]}}
    try:
        fitted = judge.fit(science, start, bounds, screening=True)
    except FIT_FAILURES:
        fitted = judge.fit(science, nested, bounds, screening=True)
    stuck, error = judge.training_error(science, nested), judge.training_error(science, fitted)
    if error > stuck:
        fitted = judge.fit(science, nested, bounds, screening=True)
        error = judge.training_error(science, fitted)
    if error >= stuck and any(not np.array_equal(start[k], v) for k, v in origin.items()):
        try:
            again = judge.fit(science, {**start, **origin}, bounds, screening=True)
        except FIT_FAILURES:
            return fitted
        if judge.training_error(science, again) < stuck:
            return again
    return fitted


def _key(added: Sequence[PlacedTerm]) -> tuple:
    """A model's terms in order: the same key gives the same parameter names."""
    return tuple(t.key for t in added)


def _drop_dispensable(science, current, added: list[PlacedTerm], theta, errors, judge, variables, n_states,
                      param_names, evidence: Evidence, steps, log, known=None, recheck=None):
    """Backward steps: drop a term that the terms accepted after it have made dispensable.

    A term that passed early may only have stood in for one found later (a hinge with a low knot
    for ``B^2``); it goes when the model without it, refitted, validates as well by the same test
    a new term must pass (the model with it is not better by ``evidence``'s ``min_gain`` and ``z``). ``known``:
    fits of models the path has settled on, by :func:`_key`; a reduced model among them is refitted
    from that fit too (see :func:`_refit_from_best`). A term accepted on a second look is tested by
    the judge that accepted it, ``recheck``: the validation samples alone found it unproven.
    """
    original = read_signature(science)[1]
    while len(added) > 1:
        trials = []
        on_folds = None  # the current model's errors on the second look's folds, when a term needs them
        for i in range(len(added)):
            rest = added[:i] + added[i + 1:]
            reduced = augment_with(science, rest, variables, n_states, param_names)
            start = {k: v for k, v in theta.items() if k in original}
            for k, t in enumerate(rest):  # the kept terms' latest values, under the reduced model's names
                start[reduced.terms[k][2]] = theta[t.param]
                start.update({glob: theta[t.shape_params[loc]] for loc, glob in reduced.shape_names[k].items()})
            starts = [start] + ([{**start, **known[_key(rest)]}] if known and _key(rest) in known else [])
            try:
                bounds = shape_bounds(reduced, rest)
                fitted = _refit_from_best(judge, reduced, starts, bounds)
                reduced_errors = judge.errors(reduced, fitted, bounds)
                with_it, without = errors, reduced_errors  # the judged errors with and without the term
                if added[i].second_look:
                    if on_folds is None:
                        on_folds = recheck.errors(current, theta, shape_bounds(current, added))
                    with_it, without = on_folds, recheck.errors(reduced, fitted, bounds)
            except FIT_FAILURES:
                continue
            if not evidence.verdict(without, with_it)["accepted"]:
                trials.append((reduced_errors.mean(), i, rest, reduced, fitted, reduced_errors, with_it, without))
        if not trials:
            break
        _, i, rest, reduced, fitted, reduced_errors, with_it, without = min(trials, key=lambda t: t[0])
        label = "drop, second look" if added[i].second_look else "drop"  # which judge's errors the row holds
        steps.append(Step.of(label, added[i].row(), verdict=evidence.verdict(with_it, without), dropped=True))
        log(f"  dropped {added[i].name} on component {added[i].component}: the later terms explain it")
        added = [t.with_fitted(reduced, fitted, k) for k, t in enumerate(rest)]
        current, theta, errors = reduced, fitted, reduced_errors
    return current, added, theta, errors


def _refit_from_best(judge: Judge, science, starts: Sequence[dict], bounds: dict) -> dict:
    """The fit, among those from each start, with the lowest training error.

    A drop starts the reduced model from the full model's values, which can be far from any good
    fit without the dropped term: a scaled term ``f[T]*T`` rescales the whole equation, so without
    it the other parameters may make the simulation overflow, least squares stalls there, and its
    validation error is so large and scattered that the drop test, which asks whether the term is
    *significantly* better, lets it go (seen on a radiating body: h became -27). The fit the
    reduced model had on the path is the second start.
    """
    fits = [judge.fit(science, start, bounds) for start in starts]
    return min(fits, key=lambda theta: judge.training_error(science, theta))
