"""Close the loop: fit a hybrid model, diagnose its residual, add the missing terms, refit, compare.

:func:`close_the_loop` is the one call; it keeps the network out of exact equations with
:class:`~sklearn_hybrid.diagnosis.MLPOn`.
"""

from __future__ import annotations

import inspect
import sys
import time
import warnings
from collections.abc import Callable, Mapping, Sequence
from dataclasses import replace
from typing import Any

import numpy as np
from sklearn.base import clone
from sklearn.exceptions import NotFittedError
from sklearn.utils import check_random_state
from sklearn.utils.validation import check_is_fitted

from ..._fitting import ode_structure
from ...identifiability import science_intervals
from ...training.engine import DivergenceError
from ...training.progress import is_interactive
from ...residual import MLPOn
from .arguments import (check_fitted_horizon, check_names, check_options, check_param_names, check_refit_params,
                        check_targets, count_states, offset_states, refuse_moved, settings_object,
                        uncertain_components)
from ..evidence import Evidence
from .candidates import Candidates
from .caveats import left_unexplained, mirror_trades, open_question, weigh_rivals, worse_than_hybrid
from .report import LoopResult, Scoring, format_table, residual_profile
from ..sensitivity import state_labels, science_output
from ..science_fit import ScienceFit
from .refit import accurate_substeps, cut_windows, fixed_science, inside_bounds, step_error, windowable
from .stepwise import forward_selection
from .watch import current_watch

__all__ = ["close_the_loop"]


def close_the_loop(estimator: Any, X: Any, y: Any, X_test: Any = None, y_test: Any = None, *,
                   state_names: Sequence[str] | None = None, input_names: Sequence[str] | None = None,
                   units: Mapping[str, str] | None = None, exact: str | Sequence[Any] | None = "auto",
                   candidates: Candidates | None = None,
                   offsets: Sequence[Any] = (), evidence: Evidence | None = None,
                   fit_initial_states: bool = False,
                   param_names: Mapping[str, str] | None = None,
                   refit_params: Mapping[str, Any] | None = None, theta_true: Mapping[str, Any] | None = None,
                   test_scorer: Callable | None = None, refit_hybrid: bool = False, n_jobs: int | None = None,
                   random_state: Any = 0, verbose: bool | str = "auto", **moved: Any) -> LoopResult:
    """Fit, find the residual, add the missing terms that held-out data support, refit, compare.

    1. The hybrid model is fitted (unless it already is). With exact components (below) and the
       default network, the network acts only on the other components; the default network is
       started at zero (:class:`MLPOn`), so that training starts from the science model.
    2. What the hybrid learned along the visited states, science plus network, is compared with the
       science model; candidate terms (:func:`~sklearn_hybrid.diagnosis.physics_terms`) are ranked
       by how much of the difference each explains on the uncertain components, and again by how
       much of the network-free model's training error each would remove (the hybrid may have
       traded the effect between theta and the network).
    3. The best-ranked few of each ranking are each added to the science model (a term among them on
       several components also on all of them at once, one coefficient each: a flux between
       compartments enters every balance it connects; and sets of two or three terms on one
       equation that explain the difference only together, such as ``x'`` and ``x^2 x'`` of a limit
       cycle, see ``diagnosis/joint.py``), refitted *without the network* by least
       squares on the training samples (at most 256 of them, evenly spaced, for this screening;
       shape parameters such as a knot or a width fitted too), and judged on the last
       ``validation_fraction`` of the samples: a term is kept only when
       it lowers the held-out error by at least ``min_gain`` and by more than ``z`` standard errors
       (Student's t quantile at the tail probability of the normal ``z``: 3.85 for 12 samples); the
       sets of a step are one family, judged by Holm's rule at the rate of one term.
       When none passes but some lowered it by ``min_gain`` at z above 2, those get a second look:
       judged the same way on ``second_look`` folds of the training samples.
       This repeats from the augmented model until no candidate passes, so the augmented science
       never validates worse than the original.
    4. The augmented science is refitted without the network on every sample (``science_only``, the
       model an engineer keeps, with its parameters' intervals). With ``refit_hybrid=True`` the
       hybrid is also trained again with the augmented science (``after``), a full second training,
       for a report row that shows what the network still adds.

    Parameters
    ----------
    estimator : HybridRegressor
        Fitted or not (then a clone is fitted on ``X, y``); structure ``"ode"``, ``"additive"``
        or ``"compose"`` with a science output shaped like ``y``.
    X, y : array-like
        Training data, as for the estimator's ``fit``. For windows cut from one record, keep them
        in time order: the validation samples are the last ones.
    X_test, y_test : array-like, optional
        Test data for the default metrics (:func:`prediction_metrics`).
    state_names, input_names, units : optional
        Names of the states (or features) and inputs, and their units (shown in the report; also the
        units of ``user_terms`` by their names).
    exact : "auto", list of str or int, or None, default="auto"
        Components of an ODE whose science equation is exact (kinematic identities such as
        ``d angle/dt = velocity``, conservation laws): no term is added there and the default
        network does not act there. ``"auto"`` takes the components whose science output depends on
        no parameter -- the physicist's default: an equation with nothing to estimate is a
        definition, not a model. ``None`` makes every component uncertain.
    candidates : Candidates, optional
        Which terms may be added and how many (:class:`~sklearn_hybrid.diagnosis.Candidates`: the
        terms, or the kinds of :func:`physics_terms`, your own terms, variables that are never
        negative, ``max_terms`` and ``n_candidates``). Default ``Candidates()``: every kind, at most
        four terms.
    offsets : list of str or int, optional
        Measured states (or features) whose sensor may read with a constant offset, by name or
        index: each is a candidate at every step, judged like a term. Accepted, the model's state is
        the reading, and every equation sees the reading less the fitted offset. A level gauge with a
        shifted zero changes a Torricelli outflow ``sqrt(x)`` in a way no added term can.
    evidence : Evidence, optional
        The test a term must pass on held-out samples (:class:`~sklearn_hybrid.diagnosis.Evidence`):
        which samples judge (``validation_fraction``, ``cv`` blocks, ``groups`` of samples judged
        as one), the evidence asked (``z``, ``min_gain``) and the second look on the training
        samples. Default ``Evidence()``: the last quarter of the samples judge, z 3, 5 % gain, a
        second look on 4 folds.
    fit_initial_states : bool, default=False
        For an ODE whose ``observed`` leaves states unmeasured: the network-free refits fit the
        initial unobserved states of every sample too (see :class:`ScienceFit`), and the hybrid is
        refitted from the states the final one found. Use it when ``X`` holds estimates of those
        states (from the data's differences, or made with the science model, which are wrong
        where the science misses an effect). It costs one more fitted value per sample and
        unobserved state in every refit (see the closed-loop results pages for timings).
    param_names : dict of str to str, optional
        Names of the new coefficients by term, e.g. ``{"v_dot": "c_damping"}``.
    refit_params : dict, optional
        ``set_params`` overrides for the hybrid refit (e.g. ``max_iter``).
    theta_true : dict, optional
        Known parameter values for the theta error (max relative error).
    test_scorer : callable, optional
        ``test_scorer(estimator) -> dict`` of named metrics, used instead of the default metrics.
    refit_hybrid : bool, default=False
        Also train the hybrid again with the augmented science (the ``after`` row): as long as the
        first training, and not needed for the answer (the network-free model and its intervals).
        ``refit_params`` apply to it.
    n_jobs : int or None, default=None
        Processes that score the models (joblib's convention: None is 1, -1 all cores). With 2,
        the first hybrid is scored in a second process while the terms are selected, and the
        network-free model while the hybrid is refitted: with free runs of long test records
        (Silverbox), that is most of the scoring time.
    random_state : int, default=0
        Seeds the subsampling of visited states.
    verbose : bool or "auto", default="auto"
        Print progress: True every stage and candidate, and the report; ``"auto"`` the stages with
        their elapsed time, in a terminal or a notebook (not in logs or captured output); False
        nothing.
    **moved
        Nothing is accepted here: a keyword that moved into ``Evidence`` (``z``, ``cv``,
        ``validation_fraction``, ``min_gain``, ``groups``, ``second_look``) or ``Candidates``
        (``terms``, ``kinds``, ``user_terms``, ``positive``, ``max_terms``, ``n_candidates``) raises a
        ``TypeError`` that says where it went, any other Python's own.

    Returns
    -------
    LoopResult
        ``before``, ``after`` (hybrid refitted with the augmented science; None when nothing was
        added or the refit failed), ``science`` (the augmented function, or None), ``science_theta``
        (fitted values of every parameter of the final science model, without the network),
        ``science_only`` (an estimator holding that model), ``intervals`` (its parameters' intervals and
        verdicts, :func:`~sklearn_hybrid.identifiability.science_intervals`), ``initial_states`` (with
        ``fit_initial_states``: every sample's initial state, unobserved components fitted with the final
        model; else None), ``added`` (the accepted terms),
        ``steps`` (every candidate tried, with its validation error and verdict), ``rivals`` (forms the
        held-out data could not tell from the chosen terms that moved a science parameter, refitted:
        their ``model``, ``theta`` and the parameters they ``moved``), ``exact``
        (the exact components), ``unexplained`` (what the final science model still misses:
        ``share`` per output and binned ``profiles``; see :func:`plot_unexplained`), ``table``,
        ``report`` (markdown), ``seconds`` and ``timings`` (CPU seconds of this process by stage: the
        hybrid fit, when the loop made it, the selection, the final network-free refit with its
        intervals, the hybrid refit and the scoring).
    """
    if moved:
        refuse_moved(moved, [name for name in inspect.signature(close_the_loop).parameters if name != "moved"])
    start = time.perf_counter()
    timings, clock = {}, [time.process_time()]

    def lap(stage: str) -> None:  # CPU seconds of this process by stage, for LoopResult.timings
        now = time.process_time()
        timings[stage] = timings.get(stage, 0.0) + now - clock[0]
        clock[0] = now

    auto = isinstance(verbose, str) and verbose == "auto"
    show = is_interactive(sys.stdout) if auto else bool(verbose)

    def log(message: str) -> None:  # stage lines carry the elapsed time: the long stages say how long
        detail = message.startswith(("  ", "|")) or "\n" in message
        if show and not (auto and detail):  # "auto": the stages only
            print(message if detail else f"[{time.perf_counter() - start:4.0f} s] {message}", flush=True)
    evidence = settings_object("evidence", evidence, Evidence, "Evidence(z=..., cv=...)")
    candidates = settings_object("candidates", candidates, Candidates, "Candidates(kinds=..., max_terms=...)")
    check_options(n_jobs, X_test, y_test)
    check_targets(X, y, X_test, y_test, test_scorer)
    # the held-out split checks the groups and its own limits before anything is fitted
    splits, codes = evidence.splits(len(y))
    check_fitted_horizon(estimator, y)
    ode = ode_structure(estimator)
    if fit_initial_states and (ode is None or ode.observed is None):
        raise ValueError("fit_initial_states=True needs an estimator with structure='ode' and observed=[...] "
                         "leaving some states unmeasured: only their initial values are fitted.")
    if getattr(estimator, "theta_encoder", None) is not None:
        raise ValueError("close_the_loop does not support theta_encoder: its network-free refits judge each term "
                         "with one theta shared by every sample. Close the loop on a model with a shared theta.")
    uncertain = uncertain_components(estimator, X, y, exact, state_names)
    offsets = offset_states(estimator, X, y, offsets, state_names)
    variables, first_values = check_names(estimator, X, y, state_names, input_names, units, candidates.user_terms,
                                          candidates.positive)
    # the user's terms are tried on the data's first states before anything is fitted
    n_states = count_states(estimator, X, y) if ode is not None else None
    # an ODE's uncertain equations may have a parameter that varies with the state or an input: f_j(x) * x_k
    scaled = (None if n_states is None else
              {j: variables[j] for j in (range(n_states) if uncertain is None else uncertain)})
    library = candidates.library(variables, first_values, units, scaled, n_states)
    check_param_names(param_names, {t.name for t in library} | {f"offset({variables[j]})" for j in offsets})
    check_refit_params(estimator, refit_params)
    if not isinstance(refit_hybrid, (bool, np.bool_)):
        raise TypeError(f"refit_hybrid must be True or False, got {refit_hybrid!r}.")
    if refit_params and not refit_hybrid:  # silently unused settings would read as applied
        raise ValueError("refit_params set the hybrid refit, which runs only with refit_hybrid=True: pass "
                         "close_the_loop(..., refit_hybrid=True, refit_params=...).")
    lap("set-up")
    try:
        check_is_fitted(estimator, "model_")
        before = estimator
    except NotFittedError:
        before = clone(estimator)
        if ode is not None and _is_default_network(before.residual):
            # The default network is started at zero, so training starts from the science model: a random
            # start can push a state out of the science function's domain (an infected share below zero
            # makes S I grow without bound) and must first be undone. It acts on the uncertain components
            # only: the exact equations stay the science's.
            components = uncertain if uncertain is not None else list(range(n_states))
            before.set_params(residual=MLPOn(components))
        log("fitting the hybrid model ...")
        before.fit(X, y)
        lap("hybrid fit")
    trace = before.residual_trace(X)
    points, inputs = trace["points"], trace["inputs"]
    keep = check_random_state(random_state).permutation(len(points))[:_MAX_POINTS]
    args = [points[keep]] + ([] if inputs is None else [inputs[keep]])
    science = before.science
    residual = trace["residual"][keep].reshape(len(keep), -1)
    base = science_output(science, before.theta_, args)
    if base.shape != residual.shape:
        raise ValueError(f"The science output has {base.shape[1]} values per sample and the network's part "
                         f"{residual.shape[1]}: close_the_loop needs a science model shaped like the target.")
    learned = base + residual
    n_states = points[0].size
    states = state_labels(state_names, n_states, "x", "state_names")
    variables = states + ([] if inputs is None else state_labels(input_names, inputs.shape[1], "u", "input_names"))
    outputs = [f"g[{s}]" for s in states] if ode is not None else [f"g[{j}]" for j in range(base.shape[1])]
    components = list(range(base.shape[1])) if uncertain is None else uncertain
    values = np.hstack([a.reshape(len(a), -1) for a in args])
    # the candidates on the visited states (a library made on the data's first states only checked the names)
    candidates = replace(candidates, terms=candidates.library(variables, values, units, scaled, n_states))

    with Scoring(n_jobs, X, X_test, y_test, test_scorer, theta_true) as scoring:
        log("scoring the first hybrid ..." if scoring.executor is None else
            "scoring the first hybrid in a worker process ...")
        before_row = scoring.submit(before)
        lap("scoring")
        fit = ScienceFit(before, X, y, fit_initial_states)
        # a long record's candidates are fitted and judged on windows of it (Evidence.window); the chosen
        # model is refitted on the whole records below
        window = None if fit_initial_states or not windowable(before) else evidence.window_for(before.y_shape_[0])
        select, select_splits, select_codes = fit, splits, codes
        if window:
            X_w, y_w, record = cut_windows(X, y, window)
            select = ScienceFit(before, X_w, y_w, n_steps=window)
            groups_w = None if evidence.groups is None else np.asarray(evidence.groups)[record]
            select_splits, select_codes = replace(evidence, groups=groups_w).splits(len(y_w))
        judged = np.concatenate([te for _, te in select_splits])
        n_val = len(judged) if select_codes is None else len(np.unique(select_codes[judged]))
        unit = "samples" if select_codes is None else "groups"
        if window:
            unit = (f"{unit} (windows of {window} steps cut from the {len(y)} records, each started from its "
                    "smoothed first state; the chosen model refitted on the whole records)")
        blocks = "" if evidence.cv is None else f" in {evidence.cv} blocks"
        log(f"selecting terms ({len(candidates.terms)} candidates on {len(components)} component(s), "
            f"{n_val} validation {unit}{blocks}) ...")
        sel = forward_selection(science, before.theta_, select, select_splits, variables, n_states, args, learned,
                                components, candidates=candidates, evidence=evidence,
                                param_names=param_names, groups=select_codes, offsets=offsets,
                                flow_pairs=flow_pairs(components, states, units) if ode is not None and candidates.flows
                                else (),
                                units=units, log=log)
        final = sel["science"]
        lap("selection")
        bounds = {g: b for t in sel["added"] for g, b in t.parameter_bounds().items()}
        substeps = accurate_substeps(fit, final, sel["theta"])
        if substeps is not None:  # the model chosen needs a finer integration than the science did
            fit = ScienceFit(before, X, y, fit_initial_states, n_substeps=substeps)
        science_theta = fit.fit(final, sel["theta"], bounds)  # every sample, now that the terms are chosen
        integration = step_error(before, X, y, fit, final, science_theta, bounds, fit_initial_states)
        lap("integration step check")
        final_terms = [t.with_values(science_theta) for t in sel["added"]]

        def outputs_of(component, kind):  # a sensor offset stands on a measured state, not on an equation
            return states[component] if kind == "offset" else outputs[component]

        # what leaves the loop is a dict per term and per step, as the report, the benchmarks and users read it
        added = [t.record() for t in final_terms]
        for record in added:
            record["output"] = outputs_of(record["component"], record["kind"])
            if "opposite" in record:
                record["opposite_output"] = outputs[record["opposite"]]
            if record["kind"] == "offset":
                record["unit"] = (units or {}).get(states[record["component"]], "")
        for s in sel["steps"]:  # a group's step stands on several components
            s["output"] = ", ".join(outputs_of(j, s["kind"]) for j in np.atleast_1d(s["component"]))
        remaining = learned - science_output(final, science_theta, args)
        unexplained = residual_profile(remaining, learned, values, variables, outputs, components)
        incomplete = open_question(sel["steps"], evidence.min_gain)
        if incomplete is None:  # the errors below are simulated only when the answer still depends on them
            # fitted unmeasured starts: the hybrid's are other ones, so their errors do not compare
            errors = None if fit.latent else (fit.errors(final, science_theta), _sample_errors(before, X, y))
            # what the network learned beyond the final model is a missing effect only where the hybrid fits
            # the data better: one that fits worse (trained short, its network carrying its theta's error)
            # leaves a remainder of its own, which the data do not support (a complete model's intervals were
            # withheld)
            supported = errors is None or np.mean(errors[1]) < np.mean(errors[0])
            incomplete = ((left_unexplained(unexplained, residual, learned, outputs) if supported else None)
                          or (None if errors is None else worse_than_hybrid(*errors, evidence, codes)))

        if fit_initial_states:  # the hybrid refit starts every sample from the states fitted with the final model
            X = np.array(X, dtype=float)
            X[:, :fit.initial_states.shape[1]] = fit.initial_states
        current_watch().selected(final, science_theta, sel["steps"])  # a study may stop here (watch.py)
        alone = fixed_science(before, final, science_theta, X, y,
                              n_substeps=getattr(fit.structure, "n_substeps", None))
        # a chosen term's form is a choice: a science parameter that trades with it, or that a rival form
        # moves, is identified only given that form (caveats.py)
        chosen = {f"{t['term']} on {t['output']}": [t["param"], *t["shape_params"].values()]
                  for t in added if t["kind"] != "offset"}
        intervals = science_intervals(alone, X, y, incomplete=incomplete, fitted_states=fit.latent or None,
                                       terms=chosen)
        intervals.widen_for_step(integration)
        rivals = weigh_rivals(intervals, sel["rivals"], science, final_terms, science_theta, fit, variables,
                              n_states, param_names, log)
        mirror_trades(intervals, science, science_theta, final_terms, args, variables, components, outputs)
        lap("network-free refit and intervals")
        log("scoring the network-free model ..." if scoring.executor is None else
            "scoring the network-free model in a worker process ...")
        alone_row = scoring.submit(alone)  # with a worker, scored during the refit
        rows = [{"stage": "before", "science": getattr(science, "__name__", "science"), "added": "",
                 **before_row()}]
        after, augmented = None, (final if sel["added"] else None)
        lap("scoring")
        if augmented is not None and refit_hybrid:
            # theta starts from the network-free refit; the network starts afresh, since the first
            # fit's network already carries the effect and erm has no reason to hand it to the term
            after = clone(before).set_params(science=augmented, theta_init=inside_bounds(science_theta, before.theta_bounds),
                                             **dict(refit_params or {}))
            log(f"refitting the hybrid with {augmented.__name__}: {augmented.equation}")
            try:
                after.fit(X, y)
            except DivergenceError as exc:  # reported, not raised: the selection itself stays useful
                rows.append({"stage": "after", "theta": {}, "failed": f"refit diverged: {exc}"})
                after = None
            lap("hybrid refit")
            if after is not None:
                log("scoring the refitted hybrid ...")
                rows.append({"stage": "after", "science": augmented.__name__, "added": augmented.equation,
                             **scoring.submit(after)()})
        rows.append({"stage": "science only", "science": getattr(final, "__name__", "science"),
                     "added": getattr(augmented, "equation", ""), **alone_row()})
        lap("scoring")
    unscored = sorted(set(theta_true or {}) - set(before.theta_) - set(science_theta))
    if unscored:  # only now known: theta_true may name the coefficient of a term the loop might add
        warnings.warn(f"theta_true names {unscored}, parameters of neither the science model nor the terms added: "
                      "their error is not reported.", UserWarning, stacklevel=2)
    report = format_table(rows, added, sel["steps"], unexplained, n_val, z=evidence.z, min_gain=evidence.min_gain,
                          cv=evidence.cv, unit=unit, tested=X_test is not None or test_scorer is not None)
    log(report)
    return LoopResult(before=before, after=after, science=augmented, science_theta=science_theta, science_only=alone,
                 intervals=intervals, initial_states=fit.initial_states.copy() if fit_initial_states else None,
                 added=added, steps=sel["steps"], rivals=rivals, exact=[] if uncertain is None else
                 [j for j in range(base.shape[1]) if j not in uncertain],
                 unexplained=unexplained, table=rows, report=report, seconds=time.perf_counter() - start,
                 units=dict(units or {}),
                 timings=timings)


def _sample_errors(estimator, X, y) -> np.ndarray:
    """Each sample's mean squared error of a fitted estimator on ``X, y`` (its outputs flattened)."""
    pred = np.asarray(estimator.predict(X), dtype=float).reshape(len(X), -1)
    return np.mean((pred - np.asarray(y, dtype=float).reshape(len(X), -1)) ** 2, axis=1)


_MAX_POINTS = 5000  # visited states used to rank candidates: plenty for a handful of columns


def flow_pairs(components: Sequence[int], states: Sequence[str], units: Mapping[str, str] | None) -> list:
    """Ordered pairs of uncertain equations whose states may exchange a flow: states in one unit (or both
    without one); a flow between a position and a speed is no physics."""
    units = units or {}
    return [(i, j) for i in components for j in components
            if i != j and i < len(states) and j < len(states) and units.get(states[i], "") == units.get(states[j], "")]


def _is_default_network(residual) -> bool:
    return residual == "mlp" or (isinstance(residual, Mapping) and residual.get("kind", "mlp") == "mlp"
                                 and set(residual) <= {"kind"})
