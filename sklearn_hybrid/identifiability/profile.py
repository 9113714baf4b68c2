"""Profiles of theta through a hybrid fit: is each parameter identified by the data?

For a parameter theta_i the profile is ``J(theta_i) = min L(theta_i, theta_rest, phi)``
over the other parameters *and the network*: with a flexible network it can be
flat, and then no regulariser makes the data pin theta_i down; the method only
picks one value in the flat set.  Each grid value is a member of one stacked
training, warm-started from the fit with theta_i held there; one more member
retrains everything from the fit, so that every point had the same budget.
A second, smaller round places members near each crossing of the threshold.

The threshold is lmfit's F-test (``conf_interval``) on the profile of the mean
squared error, counted in *samples* (trajectories), not output values: the
errors along one trajectory are correlated (noise in its initial state runs
through all of its steps), so each trajectory is one observation.  The verdict
follows Raue et al. (2009): an interval where the profile crosses the
threshold on both sides (the interval spans every value under it, as the
confidence set is all of them, not only those next to the minimum);
*practically non-identifiable* where it is under it at one end of the
profiled range; *structurally non-identifiable* (flat) at both ends.
"""

from __future__ import annotations

import copy
from dataclasses import dataclass, field

import numpy as np
from scipy import stats

from ..training.engine import DivergenceError
from ..training.stacked import evaluate_members, train_members
from ..methods import ERM
from .._validation import check_n_jobs, torch_threads
from ..training.stopping import loss_trend
from ._interval import IDENTIFIED, PRACTICAL, STRUCTURAL, UNSETTLED, read_interval, refinement
from ._members import (bounds_of, check_level, entry_values, fitted_problem, member_config,
                       parameter_entries, set_entry)

__all__ = ["profile_theta", "ThetaProfile", "IDENTIFIED", "PRACTICAL", "STRUCTURAL", "UNSETTLED",
           "ADVICE"]

#: What would identify a parameter the data leave open, said wherever a verdict is.
ADVICE = ("a parameter the data do not identify is the regulariser's choice, not a measurement: close_the_loop "
          "names what the science misses and refits it without the network (science_intervals gives its "
          "intervals); or fix a parameter known from elsewhere (theta_fixed), declare exact equations, or "
          "collect data that vary what the parameter does")



@dataclass
class ThetaProfile:
    """Profiles of the parameters of a fit, with an interval and a verdict each.

    Attributes
    ----------
    estimate : dict of str to float
        The fit's value of each profiled entry (``name`` or ``name[k]``).
    values, loss : dict of str to ndarray
        The profile of each entry: its values (sorted) and the data loss (mean
        squared error) of members that minimised the plain loss (erm) there:
        what the data alone allow once the network may compensate.  Members
        that held another entry (or none) are points too where their loss is
        under the threshold: the profile there is at most their loss.
    objective : dict of str to ndarray
        With ``objective=True``: the fit's own objective (the loss plus p-reg's
        penalty, or the sharpness-aware loss of the SAM family) at the same
        values, of members trained with the fit's method; empty otherwise.
    threshold : float
        Data loss under which a value is inside the interval at ``level``.
    intervals : dict of str to tuple
        ``(low, high)``, spanning every profiled value under the threshold (a
        profile that falls back under it beyond a crossing is not cut
        there); a side where the profile is under the threshold at the end of
        the profiled range is ``-inf`` / ``inf``.
    verdicts : dict of str to str
        ``"identified"``, ``"practically non-identifiable"``,
        ``"structurally non-identifiable"``, or ``"not settled"`` where the
        profile crosses the threshold on both sides of an interval that leaves
        out the fit's own estimate (more training moved theta: the fit had not
        converged, and the members, trained with its budget, neither), or
        where a crossing was made by a member that had not settled
        (``unsettled``).
    objective_minimum : dict of str to float
        Where the method's objective is lowest along the profile: the value of
        theta the regulariser prefers (with ``objective=True``).
    n_iter : int
        Iterations the members trained (every member of a round trains until
        all of them meet the fit's stopping rule, at most the fit's own count).
    dropped : dict of str to list of float
        Values whose member diverged in training: left out of the profile (a
        diverged member says nothing of how well the data fit there), and said
        in the report.
    fit_token : str or None
        Which fit of the estimator was profiled: ``fit_report(profile=...)``
        refuses a profile of another fit, or of this estimator before a refit,
        whose intervals would not be this fit's.
    unsettled : dict of str to list of float
        Values beyond an interval whose members crossed the threshold while
        still moving (their training ended before it met the fit's stopping
        rule): such a crossing backs no bound, and the verdict is ``"not
        settled"`` (parameters that enter only as a product with another
        look identified so, each member unable to move the other far enough).
    """

    estimate: dict
    values: dict
    loss: dict
    objective: dict
    threshold: float
    best_loss: float
    level: float
    n_samples: int
    n_iter: int
    method: str
    intervals: dict = field(default_factory=dict)
    verdicts: dict = field(default_factory=dict)
    objective_minimum: dict = field(default_factory=dict)
    dropped: dict = field(default_factory=dict)
    fit_token: str | None = None
    unsettled: dict = field(default_factory=dict)

    def verdict_text(self, label: str) -> str:
        """What the profile says of one entry, in words, with its interval where identified."""
        low, high = self.intervals[label]
        span = f"[{_fmt(self.values[label][0])}, {_fmt(self.values[label][-1])}]"
        if self.verdicts[label] == IDENTIFIED:
            return f"identified, {100 * self.level:.0f} % interval [{_fmt(low)}, {_fmt(high)}] (profile)"
        if self.verdicts[label] == UNSETTLED and self.unsettled.get(label):
            # the values are left to .unsettled: how many crossings are unsettled moves with rounding
            return ("NOT SETTLED: where the profile crosses the threshold, its members' loss was still falling "
                    "when their training ended: their loss is an upper bound of the profile there, not the "
                    "profile, so no bound is backed (the network or another parameter may take over this one "
                    "further on; the values: .unsettled); profile with a larger max_iter (these members trained "
                    f"{self.n_iter})")
        if self.verdicts[label] == UNSETTLED:
            return (f"NOT SETTLED: the profile's interval [{_fmt(low)}, {_fmt(high)}] leaves out the estimate: "
                    "training on from the fit moved theta, so the fit had not converged and the profile is not "
                    "a converged one either; refit with a larger max_iter before profiling")
        if self.verdicts[label] == STRUCTURAL:
            return (f"NOT IDENTIFIED: the data fit as well over the whole profiled range {span} "
                    "(the network takes over what this parameter does)")
        return (f"NOT IDENTIFIED: bounded on one side only, [{_fmt(low)}, {_fmt(high)}] within the "
                f"profiled range {span}")

    def report(self) -> str:
        """A text report: per parameter the verdict, the interval and what would identify it."""
        lines = [f"[[Profiles]]  ({self.how()})"]
        for label in self.verdicts:
            where = (f"; the {self.method} objective is lowest at {_fmt(self.objective_minimum[label])}"
                     if label in self.objective_minimum else "")
            lines.append(f"    {label}: {_fmt(self.estimate[label])}  {self.verdict_text(label)}{where}")
        if any(v != IDENTIFIED for v in self.verdicts.values()):
            lines.append(f"    ({ADVICE})")
        return "\n".join(lines)

    def fit_report_lines(self, names) -> tuple[dict, list[str]]:
        """What ``HybridRegressor.fit_report(profile=...)`` prints of these profiles, said by the profile
        so that the estimator's report imports nothing of this module.

        Parameters
        ----------
        names : sequence of str
            The fit's parameter names; the entries of a vector parameter (``name[k]``) are joined.

        Returns
        -------
        verdicts : dict of str to str
            Per parameter the verdict text of its profiled entries.
        after : list of str
            The lines printed after the report's table.
        """
        verdicts = {}
        for name in names:
            labels = [label for label in self.verdicts if label == name or label.startswith(name + "[")]
            if labels:
                verdicts[name] = "; ".join((f"{label}: " if label != name else "") + self.verdict_text(label)
                                           for label in labels)
        after = [f"(profiles: {self.how()})"]
        if any(v != IDENTIFIED for v in self.verdicts.values()):
            after.append(f"({ADVICE})")
        return verdicts, after

    def how(self) -> str:
        """How the profiles were made, in one line."""
        dropped = sum(len(v) for v in self.dropped.values())
        return (f"{100 * self.level:.0f} %, F-test on {self.n_samples} samples; at each value the other parameters "
                f"and the network re-trained from the fit on the plain loss, {self.n_iter} iterations"
                + (f"; {dropped} value(s) left out, their training diverged: "
                   + ", ".join(f"{k} at {[float(f'{v:.5g}') for v in vs]}" for k, vs in self.dropped.items() if vs)
                   if dropped else ""))

    def __str__(self) -> str:
        return self.report()

    def plot(self, ax=None):
        """Plot the profiles (see :func:`~sklearn_hybrid.identifiability.plot_profile`)."""
        from ..plotting import plot_profile

        return plot_profile(self, ax=ax)


def _fmt(value) -> str:
    return f"{float(value):.5g}"


def profile_theta(estimator, X, y, params=None, *, grid=None, span=0.5, n_points=5, level=0.95,
                  max_iter=None, lr=None, refine=True, objective=False, n_jobs=None,
                  verbose="auto") -> ThetaProfile:
    """Profile each parameter of a fitted hybrid model: an interval and a verdict per parameter.

    Parameters
    ----------
    estimator : HybridRegressor
        A fitted estimator (any stackable method: erm, p-reg, sam, asam, fsam).
    X, y : array-like
        The data it was fitted on (or other data of the same layout).
    params : str or list of str, optional
        Parameters to profile (every entry of a vector parameter); default all free ones.
    grid : dict, optional
        ``label -> values`` to profile at instead of the default grid (values
        strictly inside the parameter's bounds).
    span : float, default=0.5
        The default grid spans the estimate +/- ``span`` times its magnitude
        (at most to 99 % of the way to a bound).
    n_points : int, default=5
        Points of the default grid (with ``refine``, up to six more near the
        crossings: the setting whose coverage ``benchmarks/uncertainty/bench_uncertainty.py``
        measures).
    level : float, default=0.95
        Confidence level of the intervals.
    max_iter : int, optional
        Iterations of every member from the fit (default: as many as the fit
        took, ``n_iter_``: no point of the profile gets more training than the
        estimate got).  A crossing of the threshold made by a member whose
        loss was still falling at the end (by more than a tenth of the
        threshold's margin over its last window) backs no bound: the verdict
        is then "not settled", and a larger ``max_iter`` settles it.
    lr : float, optional
        Learning rate of the members (default: the fit's ``lr`` and ``lr_theta``).
    refine : bool, default=True
        Train a second round of members near each crossing of the threshold
        (three per side, placed by a parabola through the first round), so
        that an interval narrower than the grid's step is not interpolated
        across it.
    objective : bool, default=False
        Also profile the fit's own objective (the loss plus p-reg's penalty,
        or the sharpness-aware loss): members trained with the fit's method at
        the plain profile's values, a second stacked training.  Its minimum is
        where the method's regulariser puts theta inside what the data allow.
    n_jobs : int, optional
        Train the members in this many worker processes (joblib; under
        ``joblib.parallel_backend("dask")`` on a Dask cluster).  Default: one
        group in this process, which on a small model costs the fewest CPU
        seconds (each group pays the per-operation overhead again).  Each
        group stops when its own members settle, so a verdict at the margin
        may differ from one group's.
    verbose : bool or "auto", default="auto"
        A progress bar over the members' iterations: ``"auto"`` once they
        have trained 5 seconds, in a terminal or a notebook (as a fit's).

    Returns
    -------
    ThetaProfile
    """
    level = check_level(level)
    n_jobs = check_n_jobs(n_jobs)
    if not (isinstance(span, (int, float)) and not isinstance(span, bool) and span > 0 and np.isfinite(span)):
        raise ValueError(f"span must be a positive number, got {span!r}.")
    if not (isinstance(n_points, (int, np.integer)) and not isinstance(n_points, bool) and n_points >= 3):
        raise ValueError(f"n_points must be an integer of at least 3, got {n_points!r}.")
    problem = fitted_problem(estimator, X, y)
    science = problem.model.science
    entries = parameter_entries(science, params)
    # every member trains its whole budget: the fit's stopping rule compares losses to a thousandth of the
    # variance of y, far coarser than the threshold's margin once the network fits well, and members it
    # stopped were still falling where they crossed (crossings that moved with training noise)
    config = member_config(problem.fit, estimator.n_iter_ if max_iter is None else max_iter, lr, verbose)
    grids = _grids(science, entries, grid, span, n_points)
    n_free = sum(int(np.prod(science.shapes[n])) for n in science.names if science.raw[n].requires_grad)
    dof = problem.n_samples - n_free
    if dof < 1:
        raise ValueError(f"{problem.n_samples} samples for {n_free} free parameters: no degrees of freedom left.")

    n_threads = estimator.n_threads if n_jobs == 1 else 1
    plain = ERM()  # what the data alone allow: every member minimises the plain loss
    points = [(label, name, k, v) for name, k, label in entries for v in grids[label]]
    found, members, n_iter = _train_points(problem, plain, points, config, n_jobs, n_threads, entries,
                                           with_free=True)
    threshold_of = lambda best: best * (1 + stats.f.ppf(level, 1, dof) / dof)  # noqa: E731
    if refine:
        first = _with_members(found, members, threshold_of(_best(members)))
        extra = [(label, name, k, v) for name, k, label in entries
                 for v in refinement(first[label], threshold_of(_best(members)))]
        if extra:
            more, more_members, second = _train_points(problem, plain, extra, config, n_jobs, n_threads, entries)
            n_iter, members = max(n_iter, second), members + more_members
            for label, rows in more.items():
                found[label] += rows
    dropped = {label: sorted(row[0] for row in rows if not np.isfinite(row[1])) for label, rows in found.items()}
    found = {label: [row for row in rows if np.isfinite(row[1])] for label, rows in found.items()}
    free = np.isfinite(members[0]["loss"])  # the free member is a point of every profile
    short = [label for label, rows in found.items() if len(rows) + free < 3]
    if short:
        left_out = {k: dropped[k] for k in short}
        at_start = _not_finite_at_start(problem, plain, config, entries, left_out)
        if at_start == left_out:  # before any step: no learning rate can help
            raise DivergenceError(
                f"The profile of {short} has fewer than 3 values whose training did not diverge: at {left_out} "
                "the model's loss is not finite before the first training step (the science function is outside "
                "its domain with the parameter held there), so a lower lr cannot help. Profile a narrower span "
                "(profile_theta(..., span=...) or grid=...) inside the values where the science is finite.")
        raise DivergenceError(
            f"The profile of {short} has fewer than 3 values whose training did not diverge (left out: "
            f"{left_out}): no interval can be read from it. Profile with a lower lr "
            "(profile_theta(..., lr=...)) or a narrower span.")
    best = _best(members)
    out = ThetaProfile(estimate={}, values={}, loss={}, objective={}, threshold=threshold_of(best), best_loss=best,
                       level=level, n_samples=problem.n_samples, n_iter=int(n_iter), method=problem.method.name,
                       dropped={k: v for k, v in dropped.items() if v}, fit_token=getattr(estimator, "_fit_token", None))
    rows = _with_members(found, members, out.threshold)
    for name, k, label in entries:
        values, loss, fall, carried = (np.array(c) for c in zip(*sorted(rows[label])))
        out.estimate[label] = float(entry_values(science, name)[k])
        out.values[label], out.loss[label] = values, loss
        out.intervals[label], out.verdicts[label], unsettled = read_interval(values, loss, out.threshold, fall,
                                                                                    carried)
        if unsettled:
            out.unsettled[label] = unsettled
        low, high = out.intervals[label]
        if out.verdicts[label] == IDENTIFIED and not low <= out.estimate[label] <= high:
            out.verdicts[label] = UNSETTLED
    if objective:  # the method's own objective, each member trained on it, at the plain profile's values
        at = [(label, name, k, v) for name, k, label in entries for v in out.values[label]]
        regularised, _, _ = _train_points(problem, problem.method, at, config, n_jobs, n_threads, objective=True)
        for label, rows in regularised.items():
            out.objective[label] = np.array([row[1] for row in sorted(rows)])
            out.objective_minimum[label] = float(out.values[label][np.argmin(out.objective[label])])
    return out


def _train_points(problem, method, points, config, n_jobs, n_threads, entries=(), with_free=False,
                  objective=False):
    """Train one member per ``(label, name, k, value)`` point with ``method``, entry ``k`` of ``name``
    held at ``value``, warm-started from the fit (and, ``with_free``, one member that holds nothing).

    Returns ``{label: [(value, loss, fall, carried), ...]}`` (the data loss, or with ``objective`` the
    method's objective; ``fall``, ``carried``: how fast the member's loss was still falling, see
    :func:`_trends`), the members as dicts (``held``: the label held, None for the free member; ``at``: the
    value of every one of ``entries``; ``loss``; ``trend``: its ``(fall, carried)``) and the iterations the round trained.  A member whose training
    diverged has an infinite loss.
    """
    science = problem.model.science
    models = ([copy.deepcopy(problem.model)] if with_free else []) + _held_models(problem, points)
    offset = len(models) - len(points)
    held = {}
    for i, (_, name, k, _) in enumerate(points):
        held.setdefault(name, np.zeros((len(models), *science.shapes[name]), dtype=bool))
        held[name].reshape(len(models), -1)[offset + i, k] = True
    with torch_threads(n_threads):
        history, models = train_members(models, method, problem.inputs, problem.y, config,
                                        [0] * len(models), held=held, n_jobs=n_jobs, n_threads=n_threads)
        scores = evaluate_members(models, method, problem.inputs, problem.y, config)
    value = scores["objective" if objective else "loss"]
    loss = np.where(np.isfinite(value) & (history["diverged_at"] < 0), value, np.inf)
    trends = _trends(history, config)
    found = {}
    for i, (label, name, k, v) in enumerate(points):
        found.setdefault(label, []).append((float(v), float(loss[offset + i]), *trends[offset + i]))
    labels = [None] * offset + [label for label, _, _, _ in points]
    members = [{"held": labels[i], "loss": float(loss[i]), "trend": trends[i],
                "at": {label: float(entry_values(models[i].science, name)[k]) for name, k, label in entries}}
               for i in range(len(models))]
    return found, members, int(history["n_iter"])


def _not_finite_at_start(problem, method, config, entries, values: dict) -> dict:
    """Of the ``values`` held per label, those where the fit's model (theta held there, nothing trained) has a
    non-finite loss: the science is not finite there, whatever the training would do."""
    where = {label: (name, k) for name, k, label in entries}
    points = [(label, *where[label], v) for label, vs in values.items() for v in vs]
    loss = evaluate_members(_held_models(problem, points), method, problem.inputs, problem.y, config)["loss"]
    out = {}
    for (label, _, _, v), value in zip(points, loss):
        if not np.isfinite(value):
            out.setdefault(label, []).append(v)
    return out


def _held_models(problem, points) -> list:
    """A copy of the fit's model per ``(label, name, k, value)`` point, entry ``k`` of ``name`` held at ``value``."""
    models = []
    for _, name, k, value in points:
        member = copy.deepcopy(problem.model)
        set_entry(member.science, name, k, value)
        models.append(member)
    return models


def _trends(history, config) -> list[tuple[float, float]]:
    """Each member's fall of loss over its last window and that fall carried on
    (:func:`~sklearn_hybrid.training.stopping.loss_trend`): a member still falling ended wherever its
    budget ran out, and its loss is only an upper bound of the profile there."""
    return [loss_trend(history["loss"][:, k], config.n_iter_no_change) for k in range(history["loss"].shape[1])]


def _best(members) -> float:
    """The lowest data loss of any member: the profiles' common minimum, from which the threshold is read."""
    return float(min(m["loss"] for m in members))


def _with_members(found, members, threshold) -> dict:
    """Each profile's rows with the other members' values of its entry added.

    A profile is a minimum over everything but its entry, so a member that held another entry, or none,
    shows that the profile at its own value of this entry is at most its loss.  The free member is a
    point of every profile (as it always was); another member is added where its loss is under the
    threshold, where it proves its value inside the confidence set: a parameter that another compensates
    (one that enters only as a product with it) is found so over the values the compensation reached, and
    the member whose loss set the threshold lies under it in every profile, so none has nothing under it.
    A member over the threshold is not added: it is only an upper bound, no crossing.
    """
    rows = {label: list(r) for label, r in found.items()}
    for member in members:
        if not np.isfinite(member["loss"]) or (member["held"] is not None and member["loss"] > threshold):
            continue
        for label, value in member["at"].items():
            if label != member["held"]:
                rows[label].append((value, member["loss"], *member["trend"]))
    return rows


def _grids(science, entries, grid, span, n_points):
    grids = {}
    grid = dict(grid or {})
    unknown = sorted(set(grid) - {label for _, _, label in entries} - {name for name, _, _ in entries})
    if unknown:
        raise ValueError(f"grid names {unknown}, which are not profiled; profiled: {[e[2] for e in entries]}.")
    for name, k, label in entries:
        low, high = bounds_of(science, name, k)
        centre = float(entry_values(science, name)[k])
        given = grid.get(label, grid.get(name) if science.shapes[name] == () else None)
        if given is not None:
            values = np.asarray(given, dtype=float).ravel()
            if values.size < 2 or not np.all(np.isfinite(values)):
                raise ValueError(f"grid[{label!r}] must hold at least two finite values.")
            outside = values[(values <= low) | (values >= high)]
            if outside.size:
                raise ValueError(f"grid[{label!r}] holds {outside.tolist()}, outside the bounds ({low}, {high}) "
                                 f"of {name!r}; profile values strictly inside them.")
        else:
            half = span * max(abs(centre), 1e-3)
            lo = max(centre - half, centre - 0.99 * (centre - low)) if np.isfinite(low) else centre - half
            hi = min(centre + half, centre + 0.99 * (high - centre)) if np.isfinite(high) else centre + half
            values = np.concatenate([np.linspace(lo, centre, n_points // 2 + 1)[:-1],
                                     np.linspace(centre, hi, n_points - n_points // 2)[1:]])
        grids[label] = values
    return grids

