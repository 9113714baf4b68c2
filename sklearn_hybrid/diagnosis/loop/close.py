"""Close the loop: fit a hybrid model, diagnose its residual, add the missing terms, refit, compare.

:func:`close_the_loop` is the one call, an orchestration of the stages in ``stages.py``; it keeps the
network out of exact equations with :class:`~sklearn_hybrid.diagnosis.MLPOn`.
"""

from __future__ import annotations

import inspect
from collections.abc import Callable, Mapping, Sequence
from dataclasses import replace
from typing import Any

from ..evidence import Evidence
from ..science_fit import ScienceFit
from .arguments import refuse_moved
from .candidates import Candidates
from .report import LoopResult, Scoring, format_table
from .stages import (Clock, check_arguments, first_fit, learned_residual, refit_without_network, score_models,
                     select_terms, warn_unscored)

__all__ = ["close_the_loop"]


def close_the_loop(estimator: Any, X: Any, y: Any, X_test: Any = None, y_test: Any = None, *,
                   state_names: Sequence[str] | None = None, input_names: Sequence[str] | None = None,
                   units: Mapping[str, str] | None = None, exact: str | Sequence[Any] | None = "auto",
                   candidates: Candidates | None = None,
                   offsets: Sequence[Any] = (), evidence: Evidence | None = None,
                   fit_initial_states: bool | str = False,
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
        definition, not a model -- except where the fitted hybrid you pass has learned a fifth or
        more of that equation's rate (``loop.arguments.LEARNED_SHARE``: a tank written as fed with
        no outlet is a model missing an effect); an estimator not yet fitted is fitted with the
        network off those equations. ``None`` makes every component uncertain.
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
    fit_initial_states : bool, "all" or "final", default=False
        For an ODE whose ``observed`` leaves states unmeasured: the network-free refits fit the
        initial unobserved states of every sample too (see :class:`ScienceFit`), and the hybrid is
        refitted from the states the final one found. Use it when ``X`` holds estimates of those
        states (from the data's differences, or made with the science model, which are wrong
        where the science misses an effect). It costs one more fitted value per sample and
        unobserved state in every refit (see the closed-loop results pages for timings).
        ``"all"``: every initial state, the measured ones too, for an ``X`` read by sensors with
        noise: taken as exact, a noisy initial state biases theta (errors in variables) by more
        than its interval shows where the trajectories are short; fitted, it is read from the
        sample's whole trajectory, and the intervals count it as a nuisance parameter.
        ``"final"``: the terms judged from ``X``'s readings, as by default (fitted starts cost the held-out
        test power where the samples are few), and the chosen model refitted with every initial state fitted,
        as with ``"all"``: its theta and intervals free of the readings' noise.
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
        model; else None), ``added`` (the accepted terms, each an
        :class:`~sklearn_hybrid.diagnosis.AddedTerm`), ``steps`` (every candidate tried, a
        :class:`~sklearn_hybrid.diagnosis.Step` with its validation error and verdict), ``rivals`` (forms the
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
    clock = Clock(verbose)
    setup = check_arguments(estimator, X, y, X_test, y_test, state_names=state_names, input_names=input_names,
                            units=units, exact=exact, candidates=candidates, offsets=offsets, evidence=evidence,
                            fit_initial_states=fit_initial_states, param_names=param_names,
                            refit_params=refit_params, test_scorer=test_scorer, refit_hybrid=refit_hybrid,
                            n_jobs=n_jobs)
    clock.lap("set-up")
    before = first_fit(estimator, X, y, setup, clock)
    learned = learned_residual(before, X, setup, random_state)
    with Scoring(n_jobs, X, X_test, y_test, test_scorer, theta_true) as scoring:
        clock.log("scoring the first hybrid ..." if scoring.executor is None else
                  "scoring the first hybrid in a worker process ...")
        before_row = scoring.submit(before)
        clock.lap("scoring")
        # "final": the terms judged from X's readings (the test keeps its power), the chosen model refitted and its
        # intervals made with every initial state fitted (theta free of the readings' noise)
        final = fit_initial_states == "final"
        judging = replace(setup, fit_initial_states=False) if final else setup
        fit = ScienceFit(before, X, y, judging.fit_initial_states)
        selection, judged = select_terms(before, X, y, fit, judging, learned, clock)
        if final:
            setup, fit = replace(setup, fit_initial_states="all"), ScienceFit(before, X, y, "all")
        refit = refit_without_network(before, X, y, fit, setup, learned, selection, clock)
        rows, after = score_models(scoring, before, before_row, refit, y, refit_hybrid=refit_hybrid,
                                   refit_params=refit_params, clock=clock)
    warn_unscored(theta_true, before.theta_, refit.theta)
    evidence = setup.evidence
    report = format_table(rows, refit.added, refit.steps, refit.unexplained, judged.n, z=evidence.z,
                          min_gain=evidence.min_gain, cv=evidence.cv, unit=judged.unit,
                          tested=X_test is not None or test_scorer is not None)
    clock.log(report)
    return LoopResult(before=before, after=after, science=refit.science if refit.added else None,
                      science_theta=refit.theta, science_only=refit.estimator, intervals=refit.intervals,
                      initial_states=refit.fit.initial_states.copy() if fit_initial_states else None,
                      added=refit.added, steps=refit.steps, rivals=refit.rivals,
                      exact=[j for j in range(learned.base.shape[1]) if j not in learned.components],
                      unexplained=refit.unexplained, table=rows, report=report, seconds=clock.seconds(),
                      units=dict(units or {}), timings=clock.timings)
