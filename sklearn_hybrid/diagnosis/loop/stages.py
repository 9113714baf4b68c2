"""The closed loop's stages, each with a typed input and output; :func:`close_the_loop` runs them in turn.

:func:`check_arguments` (everything that can be checked before a fit) -> :class:`Setup`;
:func:`first_fit` -> the fitted hybrid; :func:`learned_residual` (what it learned beyond the science,
on its visited states) -> :class:`LearnedResidual`; :func:`select_terms` (the forward selection, on
windows of a long record where it has one) -> :class:`~sklearn_hybrid.diagnosis.results.Selection`
with :class:`Judged`; :func:`refit_without_network` (the chosen model on every sample, its intervals
and caveats) -> :class:`NetworkFree`; :func:`score_models` -> the report's rows.
"""

from __future__ import annotations

import sys
import time
import warnings
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, replace
from typing import Any

import numpy as np
import torch
from sklearn.base import clone
from sklearn.exceptions import NotFittedError
from sklearn.utils import check_random_state
from sklearn.utils.validation import check_is_fitted

from ..._fitting import ode_structure
from ..._probe import check_finite_model
from ...identifiability import science_intervals
from ...residual import MLPOn
from ...training.engine import DivergenceError
from ...training.progress import is_interactive
from ..evidence import Evidence
from ..results import AddedTerm, Selection, Step
from ..science_fit import ScienceFit, fits_every_state
from ..sensitivity import science_output, state_labels
from .arguments import (check_fitted_horizon, check_names, check_options, check_param_names, check_refit_params,
                        check_targets, count_states, offset_states, settings_object, uncertain_components)
from .candidates import Candidates
from .caveats import left_unexplained, mirror_trades, open_question, weigh_rivals, worse_than_hybrid
from .refit import accurate_substeps, cut_windows, fixed_science, inside_bounds, step_error, windowable
from .report import Scoring, residual_profile
from .stepwise import forward_selection
from .watch import current_watch

__all__ = ["Clock", "Setup", "LearnedResidual", "Judged", "NetworkFree", "check_arguments", "first_fit",
           "learned_residual", "select_terms", "refit_without_network", "score_models", "flow_pairs"]

_MAX_POINTS = 5000  # visited states used to rank candidates: plenty for a handful of columns


class Clock:
    """The loop's progress lines and its CPU seconds by stage (``LoopResult.timings``).

    ``verbose``: True prints every line, ``"auto"`` the stages only and only in a terminal or a
    notebook, False nothing. A stage line carries the elapsed time: the long stages say how long.
    """

    def __init__(self, verbose: bool | str) -> None:
        self.start, self.timings, self._cpu = time.perf_counter(), {}, time.process_time()
        self.auto = isinstance(verbose, str) and verbose == "auto"
        self.show = is_interactive(sys.stdout) if self.auto else bool(verbose)

    def lap(self, stage: str) -> None:
        now = time.process_time()
        self.timings[stage] = self.timings.get(stage, 0.0) + now - self._cpu
        self._cpu = now

    def log(self, message: str) -> None:
        detail = message.startswith(("  ", "|")) or "\n" in message
        if self.show and not (self.auto and detail):
            print(message if detail else f"[{time.perf_counter() - self.start:4.0f} s] {message}", flush=True)

    def seconds(self) -> float:
        return time.perf_counter() - self.start


@dataclass(frozen=True)
class Setup:
    """The loop's checked arguments: the test, the candidates, the held-out split and the components."""

    evidence: Evidence
    candidates: Candidates
    splits: list
    codes: np.ndarray | None  # the group of each sample, where samples are judged in groups
    is_ode: bool
    uncertain: list[int] | None  # components that may gain a term (None: every one)
    offsets: list[int]
    n_states: int | None
    scaled: dict | None  # per uncertain equation of an ODE, the state whose name its scaled terms use
    units: Mapping[str, str] | None
    state_names: Sequence[str] | None
    input_names: Sequence[str] | None
    param_names: Mapping[str, str] | None
    fit_initial_states: bool | str


def check_arguments(estimator: Any, X: Any, y: Any, X_test: Any, y_test: Any, *, state_names, input_names, units,
                    exact, candidates, offsets, evidence, fit_initial_states, param_names, refit_params,
                    test_scorer, refit_hybrid, n_jobs) -> Setup:
    """Every check that needs no fit, made before anything is fitted (a mistake found after a long fit
    costs the fit)."""
    evidence = settings_object("evidence", evidence, Evidence, "Evidence(z=..., cv=...)")
    candidates = settings_object("candidates", candidates, Candidates, "Candidates(kinds=..., max_terms=...)")
    check_options(n_jobs, X_test, y_test)
    check_targets(X, y, X_test, y_test, test_scorer)
    splits, codes = evidence.splits(len(y))  # checks the groups and the split's own limits
    check_fitted_horizon(estimator, y)
    ode = ode_structure(estimator)
    every = fits_every_state(fit_initial_states, ("all", "final"))
    if every and ode is None:
        raise ValueError(f"fit_initial_states={fit_initial_states!r} needs an estimator with structure='ode'.")
    if fit_initial_states and not every and (ode is None or ode.observed is None):
        raise ValueError("fit_initial_states=True needs an estimator with structure='ode' and observed=[...] "
                         "leaving some states unmeasured: only their initial values are fitted (fit_initial_states="
                         "'all' fits the measured ones too).")
    if getattr(estimator, "theta_encoder", None) is not None:
        raise ValueError("close_the_loop does not support theta_encoder: its network-free refits judge each term "
                         "with one theta shared by every sample. Close the loop on a model with a shared theta.")
    uncertain = uncertain_components(estimator, X, y, exact, state_names)
    offsets = offset_states(estimator, X, y, offsets, state_names)
    variables, first_values = check_names(estimator, X, y, state_names, input_names, units, candidates.user_terms,
                                          candidates.positive)
    n_states = count_states(estimator, X, y) if ode is not None else None
    # an ODE's uncertain equations may have a parameter that varies with the state or an input: f_j(x) * x_k
    scaled = (None if n_states is None else
              {j: variables[j] for j in (range(n_states) if uncertain is None else uncertain)})
    # the user's terms are tried on the data's first states
    library = candidates.library(variables, first_values, units, scaled, n_states)
    check_param_names(param_names, {t.name for t in library} | {f"offset({variables[j]})" for j in offsets})
    check_refit_params(estimator, refit_params)
    if not isinstance(refit_hybrid, (bool, np.bool_)):
        raise TypeError(f"refit_hybrid must be True or False, got {refit_hybrid!r}.")
    if refit_params and not refit_hybrid:  # silently unused settings would read as applied
        raise ValueError("refit_params set the hybrid refit, which runs only with refit_hybrid=True: pass "
                         "close_the_loop(..., refit_hybrid=True, refit_params=...).")
    return Setup(evidence, candidates, splits, codes, ode is not None, uncertain, offsets, n_states, scaled, units,
                 state_names, input_names, param_names, fit_initial_states)


def first_fit(estimator: Any, X: Any, y: Any, setup: Setup, clock: Clock) -> Any:
    """The estimator if fitted, else a clone fitted on ``X, y``."""
    try:
        check_is_fitted(estimator, "model_")
        return estimator
    except NotFittedError:
        before = clone(estimator)
    if setup.is_ode and _is_default_network(before.residual):
        # The default network is started at zero, so training starts from the science model: a random
        # start can push a state out of the science function's domain (an infected share below zero
        # makes S I grow without bound) and must first be undone. It acts on the uncertain components
        # only: the exact equations stay the science's.
        components = setup.uncertain if setup.uncertain is not None else list(range(setup.n_states))
        before.set_params(residual=MLPOn(components))
    clock.log("fitting the hybrid model ...")
    before.fit(X, y)
    clock.lap("hybrid fit")
    return before


@dataclass(frozen=True)
class LearnedResidual:
    """What the hybrid learned beyond its science model, on (at most 5000 of) its visited states."""

    args: list  # the science function's inputs there: states, then inputs
    values: np.ndarray  # the same, one column per variable
    base: np.ndarray  # the science output
    residual: np.ndarray  # the network's part
    learned: np.ndarray  # their sum: what the hybrid learned
    states: list[str]
    variables: list[str]  # states, then inputs
    outputs: list[str]  # a name per science output: g[state]
    components: list[int]  # the uncertain ones
    candidates: Candidates  # the terms on these states


def learned_residual(before: Any, X: Any, setup: Setup, random_state: Any) -> LearnedResidual:
    """The learned residual on the visited states and the candidate terms made there."""
    trace = before.residual_trace(X)
    points, inputs = trace["points"], trace["inputs"]
    keep = check_random_state(random_state).permutation(len(points))[:_MAX_POINTS]
    args = [points[keep]] + ([] if inputs is None else [inputs[keep]])
    residual = trace["residual"][keep].reshape(len(keep), -1)
    base = science_output(before.science, before.theta_, args)
    check_finite_model(base, getattr(before.science, "__name__", "science"), before.theta_,
                       "outputs on the states the hybrid visited")
    if base.shape != residual.shape:
        raise ValueError(f"The science output has {base.shape[1]} values per sample and the network's part "
                         f"{residual.shape[1]}: close_the_loop needs a science model shaped like the target.")
    n_states = points[0].size
    states = state_labels(setup.state_names, n_states, "x", "state_names")
    variables = states + ([] if inputs is None else state_labels(setup.input_names, inputs.shape[1], "u",
                                                                 "input_names"))
    outputs = [f"g[{s}]" for s in states] if setup.is_ode else [f"g[{j}]" for j in range(base.shape[1])]
    values = np.hstack([a.reshape(len(a), -1) for a in args])
    # the candidates on the visited states (a library made on the data's first states only checked the names)
    terms = setup.candidates.library(variables, values, setup.units, setup.scaled, setup.n_states)
    return LearnedResidual(args, values, base, residual, base + residual, states, variables, outputs,
                           list(range(base.shape[1])) if setup.uncertain is None else setup.uncertain,
                           replace(setup.candidates, terms=terms))


@dataclass(frozen=True)
class Judged:
    """The samples that judged the terms, as the report names them."""

    n: int
    unit: str


def select_terms(before: Any, X: Any, y: Any, fit: ScienceFit, setup: Setup, learned: LearnedResidual,
                 clock: Clock) -> tuple[Selection, Judged]:
    """The forward selection by network-free fits ``fit`` of the training samples; a long record's candidates
    are fitted and judged on windows of it (``Evidence.window``), the chosen model refitted on the whole
    records later."""
    evidence = setup.evidence
    select, splits, codes = fit, setup.splits, setup.codes
    window = (None if setup.fit_initial_states or not windowable(before)
              else evidence.window_for(before.y_shape_[0]))
    if window:
        X_w, y_w, record = cut_windows(X, y, window)
        select = ScienceFit(before, X_w, y_w, n_steps=window)
        groups = None if evidence.groups is None else np.asarray(evidence.groups)[record]
        splits, codes = replace(evidence, groups=groups).splits(len(y_w))
    judged = np.concatenate([te for _, te in splits])
    n_val = len(judged) if codes is None else len(np.unique(codes[judged]))
    unit = "samples" if codes is None else "groups"
    if window:
        unit = (f"{unit} (windows of {window} steps cut from the {len(y)} records, each started from its "
                "smoothed first state; the chosen model refitted on the whole records)")
    blocks = "" if evidence.cv is None else f" in {evidence.cv} blocks"
    clock.log(f"selecting terms ({len(learned.candidates.terms)} candidates on {len(learned.components)} "
              f"component(s), {n_val} validation {unit}{blocks}) ...")
    flows = (flow_pairs(learned.components, learned.states, setup.units)
             if setup.is_ode and learned.candidates.flows else ())
    sel = forward_selection(before.science, before.theta_, select, splits, learned.variables,
                            len(learned.states), learned.args, learned.learned, learned.components,
                            candidates=learned.candidates, evidence=evidence, param_names=setup.param_names,
                            groups=codes, offsets=setup.offsets, flow_pairs=flows, units=setup.units,
                            network=network_part(before), log=clock.log)
    clock.lap("selection")
    return sel, Judged(n_val, unit)


def network_part(before: Any) -> Callable | None:
    """The fitted network as the science's inputs feed it, where it adds to the science (an ODE's right-hand
    side, an additive model); None where it composes with it or a theta encoder binds per-sample theta."""
    model = before.model_
    if model.encoder is not None or not (ode_structure(before) is not None
                                         or getattr(model.structure, "additive", False)):
        return None
    dtype = next((p.dtype for p in model.residual.parameters()), torch.float64)

    def network(*args):
        with torch.no_grad():
            return model.residual(*(a.to(dtype) for a in args)).to(torch.float64)
    return network


@dataclass(frozen=True)
class NetworkFree:
    """The chosen model refitted without the network on every sample, and what it answers."""

    science: Callable  # the augmented science (the original where nothing was added)
    theta: dict
    added: list[AddedTerm]
    steps: list[Step]  # the selection's, each naming its output
    estimator: Any  # the network-free model as an estimator
    intervals: Any
    rivals: list
    unexplained: dict
    fit: ScienceFit
    X: Any  # the samples the hybrid refit starts from (the fitted unmeasured states, where fitted)


def refit_without_network(before: Any, X: Any, y: Any, fit: ScienceFit, setup: Setup, learned: LearnedResidual,
                          sel: Selection, clock: Clock) -> NetworkFree:
    """The chosen model fitted on every sample, its integration step checked, its intervals with the caveats
    of the choice (a form that trades with a parameter, a rival form, what is left unexplained)."""
    final, evidence = sel.science, setup.evidence
    bounds = {g: b for t in sel.added for g, b in t.parameter_bounds().items()}
    substeps = accurate_substeps(fit, final, sel.theta)
    if substeps is not None:  # the model chosen needs a finer integration than the science did
        fit = ScienceFit(before, X, y, setup.fit_initial_states, n_substeps=substeps)
    theta = fit.fit(final, sel.theta, bounds)
    integration = step_error(before, X, y, fit, final, theta, bounds, setup.fit_initial_states)
    clock.lap("integration step check")
    terms = [t.with_values(theta) for t in sel.added]
    added = [_added_term(t, learned, setup.units) for t in terms]
    steps = [replace(s, output=", ".join(_output_of(learned, j, s.kind) for j in np.atleast_1d(s.component)))
             for s in sel.steps]  # a group's step stands on several components
    remaining = learned.learned - science_output(final, theta, learned.args)
    unexplained = residual_profile(remaining, learned.learned, learned.values, learned.variables, learned.outputs,
                                   learned.components)
    incomplete = open_question(steps, evidence.min_gain)
    if incomplete is None:  # the errors below are simulated only when the answer still depends on them
        # fitted unmeasured starts: the hybrid's are other ones, so their errors do not compare
        errors = None if fit.latent else (fit.errors(final, theta), _sample_errors(before, X, y))
        # what the network learned beyond the final model is a missing effect only where the hybrid fits the
        # data better: one that fits worse (trained short, its network carrying its theta's error) leaves a
        # remainder of its own, which the data do not support (a complete model's intervals were withheld)
        supported = errors is None or np.mean(errors[1]) < np.mean(errors[0])
        incomplete = ((left_unexplained(unexplained, learned.residual, learned.learned, learned.outputs)
                       if supported else None)
                      or (None if errors is None else worse_than_hybrid(*errors, evidence, setup.codes)))
    if setup.fit_initial_states:  # the hybrid refit starts every sample from the states fitted with the final model
        X = np.array(X, dtype=float)
        X[:, :fit.initial_states.shape[1]] = fit.initial_states
    current_watch().selected(final, theta, steps)  # a study may stop here (watch.py)
    alone = fixed_science(before, final, theta, X, y, n_substeps=getattr(fit.structure, "n_substeps", None))
    # a chosen term's form is a choice: a science parameter that trades with it, or that a rival form moves,
    # is identified only given that form (caveats.py)
    chosen = {f"{t.term} on {t.output}": [t.param, *t.shape_params.values()] for t in added if t.kind != "offset"}
    intervals = science_intervals(alone, X, y, incomplete=incomplete, fitted_states=fit.latent or None, terms=chosen)
    intervals.widen_for_step(integration)
    rivals = weigh_rivals(intervals, sel.rivals, before.science, terms, theta, fit, learned.variables,
                          len(learned.states), setup.param_names, clock.log)
    mirror_trades(intervals, before.science, theta, terms, learned.args, learned.variables, learned.components,
                  learned.outputs)
    clock.lap("network-free refit and intervals")
    return NetworkFree(final, theta, added, steps, alone, intervals, rivals, unexplained, fit, X)


def score_models(scoring: Scoring, before: Any, before_row: Callable, refit: NetworkFree, y: Any, *,
                 refit_hybrid: bool, refit_params: Mapping[str, Any] | None,
                 clock: Clock) -> tuple[list[dict], Any]:
    """The report's rows (the first hybrid, the refitted hybrid if asked, the network-free model) and the
    refitted hybrid (None when not asked, nothing was added, or it diverged)."""
    clock.log("scoring the network-free model ..." if scoring.executor is None else
              "scoring the network-free model in a worker process ...")
    alone_row = scoring.submit(refit.estimator)  # with a worker, scored during the refit
    rows = [{"stage": "before", "science": getattr(before.science, "__name__", "science"), "added": "",
             **before_row()}]
    after, augmented = None, (refit.science if refit.added else None)
    clock.lap("scoring")
    if augmented is not None and refit_hybrid:
        # theta starts from the network-free refit; the network starts afresh, since the first fit's network
        # already carries the effect and erm has no reason to hand it to the term
        after = clone(before).set_params(science=augmented, theta_init=inside_bounds(refit.theta, before.theta_bounds),
                                         **dict(refit_params or {}))
        clock.log(f"refitting the hybrid with {augmented.__name__}: {augmented.equation}")
        try:
            after.fit(refit.X, y)
        except DivergenceError as exc:  # reported, not raised: the selection itself stays useful
            rows.append({"stage": "after", "theta": {}, "failed": f"refit diverged: {exc}"})
            after = None
        clock.lap("hybrid refit")
        if after is not None:
            clock.log("scoring the refitted hybrid ...")
            rows.append({"stage": "after", "science": augmented.__name__, "added": augmented.equation,
                         **scoring.submit(after)()})
    rows.append({"stage": "science only", "science": getattr(refit.science, "__name__", "science"),
                 "added": getattr(augmented, "equation", ""), **alone_row()})
    clock.lap("scoring")
    return rows, after


def warn_unscored(theta_true: Mapping[str, Any] | None, *thetas: Mapping[str, Any]) -> None:
    """Only known at the end: ``theta_true`` may name the coefficient of a term the loop might add."""
    unscored = sorted(set(theta_true or {}).difference(*thetas))
    if unscored:
        warnings.warn(f"theta_true names {unscored}, parameters of neither the science model nor the terms added: "
                      "their error is not reported.", UserWarning, stacklevel=3)


def flow_pairs(components: Sequence[int], states: Sequence[str], units: Mapping[str, str] | None) -> list:
    """Ordered pairs of uncertain equations whose states may exchange a flow: states in one unit (or both
    without one); a flow between a position and a speed is no physics."""
    units = units or {}
    return [(i, j) for i in components for j in components
            if i != j and i < len(states) and j < len(states) and units.get(states[i], "") == units.get(states[j], "")]


def _output_of(learned: LearnedResidual, component: int, kind: str) -> str:
    """A sensor offset stands on a measured state, a term on an equation."""
    return learned.states[component] if kind == "offset" else learned.outputs[component]


def _added_term(term: Any, learned: LearnedResidual, units: Mapping[str, str] | None) -> AddedTerm:
    record = term.record()
    if record["kind"] == "offset":
        record["unit"] = (units or {}).get(learned.states[record["component"]], "")
    if "opposite" in record:
        record["opposite_output"] = learned.outputs[record["opposite"]]
    return AddedTerm(**record, output=_output_of(learned, record["component"], record["kind"]))


def _sample_errors(estimator: Any, X: Any, y: Any) -> np.ndarray:
    """Each sample's mean squared error of a fitted estimator on ``X, y`` (its outputs flattened)."""
    pred = np.asarray(estimator.predict(X), dtype=float).reshape(len(X), -1)
    return np.mean((pred - np.asarray(y, dtype=float).reshape(len(X), -1)) ** 2, axis=1)


def _is_default_network(residual: Any) -> bool:
    return residual == "mlp" or (isinstance(residual, Mapping) and residual.get("kind", "mlp") == "mlp"
                                 and set(residual) <= {"kind"})
