"""Intervals of a model without a network, such as the closed loop's ``science_only``.

Least squares with the errors of one sample (a trajectory) correlated, as
noise in a trajectory's initial state makes them: the cluster-robust
("sandwich") covariance with one cluster per sample,

    A = sum_i J_i^T J_i,    B = sum_i (J_i^T r_i)(J_i^T r_i)^T,
    cov(theta) = n / (n - p) * A^-1 B A^-1,

with ``J_i`` the derivative of sample i's predictions by theta and ``r_i``
its residuals, and Student's t with ``n - p`` degrees of freedom.  Initial
states fitted per sample (the closed loop's ``fit_initial_states``) are
nuisance parameters of one sample each: their derivatives ``K_i`` are
projected out of ``J_i`` (``J_i <- J_i - K_i (K_i^T K_i)^-1 K_i^T J_i``), which
is the theta block of the same sandwich over theta and every sample's states.  The
Gauss-Newton standard error ``s^2 A^-1`` (lmfit, ``curve_fit``) assumes every
output value independent and is too narrow here.
"""

from __future__ import annotations

import copy
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np
import torch
from scipy import stats
from sklearn.utils.validation import check_is_fitted

from .._fitting import fitted_data, fitted_settings, ode_structure
from .._validation import check_target_layout, torch_threads
from .._fit_report import theta_jacobian
from .._probe import check_finite_model
from ..residual import ZeroResidual
from ._members import check_level

__all__ = ["science_intervals", "ScienceIntervals", "CONFOUNDED_R2"]


#: A science parameter whose sensitivity column an added term's columns explain to this uncentred R^2
#: (a variance inflation factor of 10, the usual line for collinearity) is told from the term only
#: through the term's assumed form.
CONFOUNDED_R2 = 0.9


@dataclass
class ScienceIntervals:
    """Estimates, cluster-robust standard errors, intervals and verdicts of a network-free model.

    A parameter whose direction the data do not inform (``A`` singular there,
    or a standard error beyond its estimate's magnitude) is ``"not identified"``.
    With fewer samples than the parameters plus two every verdict is ``"not
    available"`` and ``unavailable`` says why: no cluster-robust interval is given.
    One that is identified only given the form of a term the closed loop chose
    (it trades with the term's part in its own direction, or a term of another
    form that fits as well moves it) is ``"conditional"``: ``conditional`` says
    why, and its interval covers the values under those other forms too.
    """

    estimate: dict
    std: dict
    intervals: dict
    verdicts: dict
    level: float
    n_samples: int
    incomplete: str | None = None
    conditional: dict = field(default_factory=dict)
    #: the parameters whose interval was widened to their values under other forms (by ``widen``)
    spans_forms: set = field(default_factory=set)
    #: why no interval could be given (too few samples for a cluster-robust covariance), or None
    unavailable: str | None = None
    #: how far each estimate can be from an exact integration's (set by ``widen_for_step``), per label
    step_error: dict = field(default_factory=dict)

    def widen_for_step(self, error: Mapping[str, float]) -> None:
        """Widen each interval by how far its estimate can be off through the integration's finite step
        (``error``: per label, e.g. from halving the step), which the noise-only interval does not see."""
        self.step_error = dict(error)
        for label, e in self.step_error.items():
            if self.verdicts.get(label) in ("identified", "conditional") and e > 0:
                low, high = self.intervals[label]
                self.intervals[label] = (low - e, high + e)

    def widen(self, label: str, values: Sequence[float]) -> None:
        """Widen ``label``'s interval to hold ``values``: its estimates under other forms of a chosen
        term that fit as well (the uncertainty of the choice)."""
        if self.verdicts.get(label) in ("identified", "conditional"):
            low, high = self.intervals[label]
            self.intervals[label] = (min([low, *values]), max([high, *values]))
            if len(values):
                self.spans_forms.add(label)

    def make_conditional(self, label: str, why: str, values: Sequence[float] = ()) -> None:
        """Call ``label`` identified only given the chosen term's form, for the reason ``why``; its
        interval is widened to hold ``values`` (its estimates under other forms that fit as well)."""
        if self.verdicts.get(label) not in ("identified", "conditional"):
            return
        self.widen(label, values)
        self.verdicts[label] = "conditional"
        self.conditional[label] = "; ".join(filter(None, [self.conditional.get(label), why]))

    def report(self) -> str:
        lines = [f"[[Parameters of the network-free model]]  ({100 * self.level:.0f} % intervals, cluster-robust "
                 f"over {self.n_samples} samples)"]
        for label, verdict in self.verdicts.items():
            low, high = self.intervals[label]
            if verdict == "identified":
                lines.append(f"    {label}: {self.estimate[label]:.6g} +/- {self.std[label]:.3g}, "
                             f"{100 * self.level:.0f} % interval [{low:.6g}, {high:.6g}]")
            elif verdict == "conditional":
                span = ("over the forms the data cannot tell apart (a range of estimates, not a confidence interval)"
                        if label in self.spans_forms else "given that form alone (how much the parameter trades "
                        "with it, the data cannot say)")
                lines.append(f"    {label}: {self.estimate[label]:.6g}  CONDITIONAL on the form of the term added "
                             f"({self.conditional[label]}); [{low:.6g}, {high:.6g}] {span}")
            elif verdict == "not available":
                lines.append(f"    {label}: {self.estimate[label]:.6g}  NO INTERVAL: {self.unavailable}")
            elif self.incomplete:
                lines.append(f"    {label}: {self.estimate[label]:.6g}  NOT IDENTIFIED: the model may be incomplete")
            else:
                lines.append(f"    {label}: {self.estimate[label]:.6g}  NOT IDENTIFIED by these data")
        material = {k: e for k, e in self.step_error.items() if self.verdicts.get(k) in ("identified", "conditional")
                    and e > 0.1 * (self.intervals[k][1] - self.intervals[k][0]) / 2}
        if material:
            lines.append("    (the integration's step moves " + ", ".join(f"{k} by {e:.3g}" for k, e in material.items())
                         + ": each interval is widened by it; a finer step (n_substeps) narrows it)")
        if self.incomplete:
            lines.append(f"    ({self.incomplete}; its intervals would assume a complete model)")
        elif any(v == "conditional" for v in self.verdicts.values()):
            lines.append("    (a conditional parameter is known only as well as the form of the term it depends on: "
                         "one that 'trades with' a term is told from it only through that form (R^2: how much of "
                         "its sensitivity the term's explains); 'with ... added' or 'instead of' name forms the "
                         "held-out data could not tell from the choice, and the parameter's value under them. Give "
                         "the form your physics knows as a user term and close the loop again, or measure where "
                         "the forms differ)")
        if not self.incomplete and any(v == "identified" for v in self.verdicts.values()):
            lines.append("    (intervals of this model: they hold the truth only if it is complete; an effect it "
                         "misses that its parameters can partly absorb leaves no trace in these data)")
        return "\n".join(lines)

    def __str__(self) -> str:
        return self.report()


def science_intervals(estimator, X, y, level=0.95, incomplete: str | None = None,
                      fitted_states=None, terms: Mapping[str, Sequence[str]] | None = None) -> ScienceIntervals:
    """Intervals of the parameters of a fitted model without a network.

    Parameters
    ----------
    estimator : HybridRegressor
        Fitted with ``residual=ZeroResidual()`` (no network), such as
        ``close_the_loop(...).science_only``.  Its fixed parameters are
        intervals too: the closed loop fixes them at the least-squares values.
    X, y : array-like
        The data the parameters were fitted on.
    level : float, default=0.95
    incomplete : str, optional
        Why the model may miss something (``close_the_loop`` says so when a
        candidate term lowered the held-out error without passing the
        evidence): every verdict is then "not identified", since an interval
        of a misspecified model holds its own best fit, not the truth.
    fitted_states : list of int, optional
        Components of the initial state (columns of ``X``) that were fitted
        per sample with the parameters, as ``close_the_loop(...,
        fit_initial_states=True)`` fits the unobserved ones; ``X`` holds the
        fitted values.  Their uncertainty widens theta's intervals.

    Returns
    -------
    ScienceIntervals
    """
    level = check_level(level)
    check_is_fitted(estimator)
    model = estimator.model_
    if not isinstance(fitted_settings(estimator)["residual"], ZeroResidual):
        raise ValueError("science_intervals is for models without a network (close_the_loop's science_only); "
                         "for a hybrid fit use profile_theta, which re-trains the network.")
    X, inputs = fitted_data(estimator, X, torch.float64)
    states = _check_fitted_states(fitted_states, estimator)
    y = check_target_layout(y, np.empty((len(X), *estimator.y_shape_))).reshape(len(X), -1)
    if not np.all(np.isfinite(y)):  # a NaN residual makes every standard error NaN: "not identified", wrongly
        raise ValueError("y contains NaN or infinite values. Intervals need every output value: drop the samples "
                         "that hold them (keep = np.isfinite(y).reshape(len(y), -1).all(axis=1); X[keep], y[keep]).")
    model = copy.deepcopy(model).to(torch.float64).eval()
    science = model.science
    _check_terms(terms, science.names)
    with torch_threads(estimator.n_threads), torch.no_grad():
        def predict():
            return model(*inputs)[0].reshape(len(X), -1).cpu().numpy()

        def predict_many(raw):  # every step of the differences in one vectorised simulation
            params = {f"science.raw.{name}": value for name, value in raw.items()}
            out = torch.func.vmap(lambda p: torch.func.functional_call(model, p, inputs)[0])(params)
            return out.reshape(len(out), len(X), -1).cpu().numpy()

        base = predict()
        check_finite_model(base, science.name, science.as_dict(), "predictions")
        entries = [(name, k) for name in science.names for k in range(science.raw[name].numel())]
        labels = [(name, k, name if science.shapes[name] == () else f"{name}[{k}]") for name, k in entries]
        J = theta_jacobian(science, predict, entries, predict_many, base)  # (n, m, p)
        if states:
            K = _state_derivatives(predict, inputs, states)  # (n, m, q)
    check_finite_model(J, science.name, science.as_dict(), "derivatives of the predictions by theta")
    if states:  # theta's derivatives orthogonal to what each sample's own states can do
        J = np.stack([J[i] - K[i] @ np.linalg.lstsq(K[i], J[i], rcond=None)[0] for i in range(len(J))])
    r = y - base
    n, p = len(X), J.shape[-1]
    if n < p + 2:
        return _unavailable(science, labels, n, p, level, incomplete)
    A = np.einsum("nmp,nmq->pq", J, J)
    score = np.einsum("nmp,nm->np", J, r)
    B = score.T @ score
    dof = n - p
    t = stats.t.ppf(0.5 + level / 2, dof)
    # The condition of A with each parameter in units of its own sensitivity: collinear columns, not
    # parameters of different sizes (a coefficient of i^3 with i in thousandths is of order 1e5).
    size = np.sqrt(np.diag(A))
    try:
        if not np.all(size > 0):
            raise np.linalg.LinAlgError("a parameter moves no prediction")
        correlation = A / np.outer(size, size)
        cond_ok = np.linalg.cond(correlation) < 1e12
        A_inv = np.linalg.inv(correlation) / np.outer(size, size)
    except np.linalg.LinAlgError:
        cond_ok, A_inv = False, np.full_like(A, np.nan)
    cov = n / dof * A_inv @ B @ A_inv
    out = ScienceIntervals(estimate={}, std={}, intervals={}, verdicts={}, level=level, n_samples=n,
                           incomplete=incomplete)
    for j, (name, k, label) in enumerate(labels):
        value = float(np.ravel(np.asarray(science.as_dict()[name], dtype=float))[k])
        std = float(np.sqrt(cov[j, j])) if cov[j, j] >= 0 else float("nan")
        identified = cond_ok and np.isfinite(std) and std < max(abs(value), 1e-12) and not incomplete
        out.estimate[label], out.std[label] = value, std
        out.intervals[label] = (value - t * std, value + t * std) if identified else (-np.inf, np.inf)
        out.verdicts[label] = "identified" if identified else "not identified"
    for label, why in _confounded(A, [lab for _, _, lab in labels], [name for name, _, _ in labels], terms).items():
        out.make_conditional(label, why)
    return out


def _unavailable(science, labels, n: int, p: int, level: float, incomplete) -> ScienceIntervals:
    """No intervals from ``n`` samples for ``p`` parameters (``n < p + 2``), and why.

    Each sample is one cluster.  At the least-squares fit the samples' scores ``J_i^T r_i`` sum to zero, so
    ``B`` has rank at most ``n - 1``: with one sample it is zero and so is every standard error (a single
    trajectory gave omega 0.657334 +/- 1.12e-07, the truth 2/3 far outside), and below ``p + 1`` samples
    ``B`` is singular in some direction of theta.  With ``p + 1`` the t interval would rest on one degree
    of freedom, its variance infinite; ``p + 2`` is the least that leaves two.  The Gauss-Newton error that
    counts every output value is no fallback: it is the one the errors shared along a trajectory make too
    narrow (see the module's docstring).
    """
    why = (f"{n} sample(s) for {p} parameter(s): a cluster-robust interval needs at least {p + 2} (each sample "
           "is one cluster, whose scores sum to zero at the fit; with fewer its standard errors are zero or rest "
           "on under two degrees of freedom). Fit on more samples (trajectories), or fix parameters known from "
           "elsewhere")
    values = science.as_dict()
    out = ScienceIntervals(estimate={}, std={}, intervals={}, verdicts={}, level=level, n_samples=n,
                           incomplete=incomplete, unavailable=why)
    for name, k, label in labels:
        out.estimate[label] = float(np.ravel(np.asarray(values[name], dtype=float))[k])
        out.std[label], out.intervals[label], out.verdicts[label] = float("nan"), (-np.inf, np.inf), "not available"
    return out


def _check_terms(terms, names) -> None:
    """``terms`` maps each chosen term's label to parameters of this model (its coefficient and shape)."""
    if terms is None:
        return
    if not isinstance(terms, Mapping) or any(isinstance(p, str) or not isinstance(p, Sequence)
                                             for p in terms.values()):
        raise TypeError("terms must map each chosen term's label to a list of its parameters' names, e.g. "
                        f"{{'x/(K + |x|) on g[x]': ['c_sat', 'K_sat']}}; got {terms!r}.")
    unknown = sorted({p for params in terms.values() for p in params} - set(names))
    if unknown:
        raise ValueError(f"terms names {unknown}, which are not parameters of this model; its parameters are "
                         f"{list(names)}.")


def _confounded(A: np.ndarray, labels: list[str], names: list[str],
                terms: Mapping[str, Sequence[str]] | None) -> dict[str, str]:
    """The parameters (outside ``terms``) whose sensitivity column a term's parameters explain to
    ``CONFOUNDED_R2`` or more, from the information matrix ``A`` (sums of products of the columns),
    with the reason in words."""
    out: dict[str, str] = {}
    owned = {name for params in (terms or {}).values() for name in params}
    for term, params in (terms or {}).items():
        cols = [i for i, name in enumerate(names) if name in params]
        if not cols:
            continue
        A_tt = A[np.ix_(cols, cols)]
        for i, (label, name) in enumerate(zip(labels, names)):
            if name in owned or A[i, i] <= 0:
                continue
            a = A[i, cols]
            r2 = float(a @ np.linalg.lstsq(A_tt, a, rcond=None)[0] / A[i, i])
            if r2 >= CONFOUNDED_R2:
                out[label] = f"trades with {term}, R^2 {r2:.2f}"
    return out


def _check_fitted_states(fitted_states, estimator) -> list[int]:
    if fitted_states is None:
        return []
    shape = tuple(getattr(estimator.model_.structure, "state_shape", ()))
    if ode_structure(estimator) is None or len(shape) != 1:
        raise ValueError("fitted_states names components of an initial state: it needs structure='ode' with a "
                         "state vector.")
    states = [int(j) for j in np.atleast_1d(fitted_states)]
    if any(not 0 <= j < shape[0] for j in states) or len(set(states)) != len(states):
        raise ValueError(f"fitted_states must list distinct state components (0 to {shape[0] - 1}), "
                         f"got {fitted_states!r}.")
    return states


def _state_derivatives(predict, inputs, states) -> np.ndarray:
    """Central differences of every sample's predictions by its own initial states ``states``."""
    x0 = inputs[0]
    columns = []
    for j in states:
        saved = x0[:, j].clone()
        h = 1e-6 * torch.clamp(saved.abs(), min=1.0)
        preds = []
        for sign in (1, -1):
            x0[:, j] = saved + sign * h
            preds.append(predict())
        x0[:, j] = saved
        columns.append((preds[0] - preds[1]) / (2 * h.cpu().numpy()[:, None]))
    return np.stack(columns, axis=-1)
