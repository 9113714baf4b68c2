"""HybridRegressor beyond fit and predict: simulation over any horizon, the fit report,
nested ``residual__`` parameters, sample weights and the early-stopping hold-out.

A mixin, so that :mod:`sklearn_hybrid._estimator` keeps the scikit-learn core
(parameters, validation, fit, predict) and each addition stays in one place.
"""

from __future__ import annotations

import math
import numbers

import numpy as np
import torch
from sklearn.utils.validation import check_is_fitted

from ._fit_report import format_report
from ._validation import check_positive, torch_threads
from .integrate import upsample_inputs

__all__ = ["EstimatorExtras"]

#: Parameters that fix how predictions are computed; changing one after fit would be ignored.
STRUCTURE_PARAMS = ("structure", "dt", "n_substeps", "solver", "observed", "n_inputs",
                    "input_interp", "theta_encoder")


def _same(a, b) -> bool:
    if a is b:
        return True
    try:
        return bool(np.array_equal(np.asarray(a, dtype=object), np.asarray(b, dtype=object)))
    except Exception:  # values that numpy cannot compare are different objects
        return False


def check_sample_weight(sample_weight, n: int, dtype: torch.dtype, device=None) -> torch.Tensor | None:
    """Validate per-sample weights: shape (n,), finite, non-negative, not all zero."""
    if sample_weight is None:
        return None
    w = np.asarray(sample_weight, dtype=float)
    if w.ndim == 0:
        w = np.full(n, float(w))
    if w.shape != (n,):
        raise ValueError(f"sample_weight has shape {w.shape}; expected ({n},), one weight per sample.")
    if not np.all(np.isfinite(w)) or np.any(w < 0):
        raise ValueError("sample_weight must be finite and non-negative.")
    if not w.sum() > 0:
        raise ValueError("sample_weight sums to zero: no sample would count.")
    return torch.as_tensor(w, dtype=dtype, device=device)


def split_holdout(setup, weight, fraction):
    """Split the samples of a fit setup into trained and validation parts.

    Returns ``(inputs, y, info)``; ``info["train_weight"]`` is the weight of the
    trained samples and ``info["data"]`` (only with a fraction) the validation
    ``(inputs, y, weight)``.
    """
    if fraction is None:
        return setup.inputs, setup.y, {"train_weight": weight}
    n = len(setup.y)
    if not (isinstance(fraction, numbers.Real) and 0 < fraction < 1):
        raise ValueError(f"validation_fraction must be in (0, 1) or None, got {fraction!r}.")
    n_val = int(round(fraction * n))
    if n_val < 1 or n - n_val < 1:
        raise ValueError(f"validation_fraction={fraction} leaves no usable split of {n} samples.")
    order = torch.randperm(n, generator=torch.Generator().manual_seed(setup.seed))
    device = setup.y.device
    train, val = order[n_val:].sort().values.to(device), order[:n_val].sort().values.to(device)

    def part(idx):
        return (tuple(t[idx] for t in setup.inputs), setup.y[idx],
                None if weight is None else weight[idx])

    inputs, y, w = part(train)
    return inputs, y, {"train_weight": w, "data": part(val)}


class EstimatorExtras:
    """Methods of :class:`~sklearn_hybrid.HybridRegressor` beyond fit and predict."""

    def set_params(self, **params):
        """Set parameters; ``residual__<option>`` sets one option of the residual specification.

        ``set_params(residual__hidden=(64, 64))`` turns ``residual="mlp"`` into
        ``{"kind": "mlp", "hidden": (64, 64)}`` (a dict given by the user is
        copied, never changed), so grids such as ``{"residual__hidden": [...]}``
        work in ``GridSearchCV``.

        Parameters
        ----------
        **params : dict
            Estimator parameters.

        Returns
        -------
        self
        """
        nested = {k.split("__", 1)[1]: params.pop(k) for k in list(params)
                  if k.startswith("residual__")}
        super().set_params(**params)
        if nested:
            spec = self.residual
            if isinstance(spec, str):
                spec = {"kind": spec}
            elif isinstance(spec, dict):
                spec = dict(spec)
            else:
                raise ValueError(
                    f"residual__{next(iter(nested))} sets an option of a residual given by name "
                    f"or dict, but residual is a {type(spec).__name__}; set residual itself."
                )
            spec.update(nested)
            self.residual = spec
        return self

    def _check_structure_unchanged(self) -> None:
        """Raise if a parameter that fixes the predictions changed since fit (it would be ignored)."""
        # _fitted_structure: the same snapshot in fits pickled before _fitted_params (benchmark caches)
        fitted = getattr(self, "_fitted_params", None) or getattr(self, "_fitted_structure", None)
        if fitted is None:
            return
        changed = [k for k in STRUCTURE_PARAMS if k in fitted and not _same(getattr(self, k), fitted[k])]
        if changed:
            detail = ", ".join(f"{k}={fitted[k]!r} -> {getattr(self, k)!r}" for k in changed)
            raise ValueError(
                f"{detail} was changed after fit, and the fitted model was built with the old "
                "value. Refit, or set it back; to predict on another time grid or horizon use "
                "simulate(x0, n_steps, dt=...)."
            )

    def simulate(self, x0, n_steps=None, *, u=None, dt=None, use_residual=True) -> np.ndarray:
        """Simulate the fitted hybrid ODE from initial states over any horizon and output spacing.

        The integration step (RK4, or a fixed-grid torchdiffeq solver) is never
        longer than in training: with another ``dt`` the number of steps per
        output interval becomes
        ``ceil(n_substeps * dt / dt_fit)``.

        Parameters
        ----------
        x0 : array-like of shape (n, ...)
            Initial states (all components, observed or not; without the
            inputs of a forced system); one state alone may drop the leading axis.
            A DataFrame's columns must be the fit's first feature names (the
            states), in their order.
        n_steps : int, optional
            Number of output intervals; for a forced system it follows from ``u``.
        u : array-like of shape (n, n_steps + 1, n_inputs), optional
            Inputs on the output grid from time 0 (forced systems only); for one
            initial state ``(n_steps + 1, n_inputs)`` or ``(n_steps + 1,)``.
        dt : float, optional
            Time between outputs (default: the ``dt`` of the fit).
        use_residual : bool or array-like of bool of shape (n,), default=True
            False simulates the science part alone; one flag per initial state
            simulates hybrid and science-only runs in one batch (a long free
            run costs its number of steps, nearly whatever the batch).

        Returns
        -------
        ndarray of shape (n, n_steps + 1, ...)
            States at times ``0, dt, ..., n_steps * dt`` (without the leading
            axis for a single initial state).  ``[..., observed]`` gives the
            observed components.
        """
        check_is_fitted(self)
        self._check_structure_unchanged()
        s = self.model_.structure
        if not hasattr(s, "states"):
            raise ValueError(f"simulate needs structure='ode'; this model's structure is {self.structure!r}.")
        if getattr(self.model_, "encoder", None) is not None:
            raise ValueError("simulate does not support a theta_encoder yet (theta is inferred per "
                             "input window); use predict.")
        state_shape = tuple(s.state_shape)
        self._check_state_names(x0)
        x0 = np.ascontiguousarray(x0, dtype=float)  # torch refuses negative strides (a reversed view)
        single = x0.shape == state_shape
        x0 = x0[None] if single else x0
        if x0.shape[1:] != state_shape:
            raise ValueError(f"x0 has shape {x0.shape}; expected (n, {', '.join(map(str, state_shape))}) "
                             f"or {state_shape}.")
        if not np.all(np.isfinite(x0)):
            raise ValueError("x0 contains NaN or infinite values.")
        dt = s.dt if dt is None else dt
        check_positive("dt", dt)
        n_sub = max(1, math.ceil(s.n_substeps * dt / s.dt - 1e-9))
        u, n_steps = self._check_inputs(s, u, n_steps, len(x0), single)
        dtype, device = self._fitted_dtype(), self.device_
        if not isinstance(use_residual, (bool, np.bool_)):
            flags = np.asarray(use_residual)
            if flags.dtype != bool or flags.shape != (len(x0),):
                raise ValueError(f"use_residual must be a bool or {len(x0)} bools, one per initial state; "
                                 f"got {flags.dtype} values of shape {flags.shape}.")
            use_residual = (bool(flags[0]) if flags.all() or not flags.any() else
                            torch.as_tensor(flags, dtype=dtype, device=device).reshape(-1, *[1] * len(state_shape)))
        with torch_threads(self.n_threads), torch.no_grad():
            x = torch.as_tensor(x0, dtype=dtype, device=device)
            u_fine = None if u is None else torch.as_tensor(
                upsample_inputs(u, 2 * n_sub, s.input_interp), dtype=dtype, device=device)
            states = s.states(self.model_, x, u_fine, use_residual, n_steps, float(dt), n_sub)
            out = torch.cat([x[:, None], states], dim=1).cpu().numpy().astype(float)
        out[:, 0] = x0  # exactly the given states, not their rounding to the model's dtype
        return out[0] if single else out

    def _check_state_names(self, x0) -> None:
        """Refuse columns named otherwise than the fit's states (predict does the same for X)."""
        columns, fitted = getattr(x0, "columns", None), getattr(self, "feature_names_in_", None)
        if columns is None or fitted is None:
            return
        columns, states = [str(c) for c in columns], [str(c) for c in fitted[:len(columns)]]
        if columns != states:
            raise ValueError(f"x0 has columns {columns}; this model was fitted with states {states}, in that order.")

    @staticmethod
    def _check_inputs(s, u, n_steps, n, single):
        if not s.n_inputs:
            if u is not None:
                raise ValueError("This hybrid ODE has no inputs (n_inputs=0): do not pass u.")
            if not (isinstance(n_steps, numbers.Integral) and not isinstance(n_steps, bool)
                    and n_steps >= 1):
                raise ValueError(f"n_steps must be a positive integer, got {n_steps!r}.")
            return None, int(n_steps)
        if u is None:
            raise ValueError(f"This hybrid ODE is forced (n_inputs={s.n_inputs}): give u.")
        u = np.ascontiguousarray(u, dtype=float)
        if single and u.ndim == 1:
            u = u[:, None]
        if single and u.ndim == 2:
            u = u[None]
        if u.ndim != 3 or u.shape[0] != n or u.shape[2] != s.n_inputs or u.shape[1] < 2:
            raise ValueError(f"u has shape {u.shape}; expected ({n}, n_steps + 1, {s.n_inputs}).")
        if n_steps is not None and n_steps != u.shape[1] - 1:
            raise ValueError(f"n_steps={n_steps} disagrees with u, which covers {u.shape[1] - 1} steps.")
        if not np.all(np.isfinite(u)):
            raise ValueError("u contains NaN or infinite values.")
        return u, u.shape[1] - 1

    def fit_report(self, profile=None) -> str:
        """A text report of the fit: settings, iterations, and theta with what is known of it.

        Theta is the estimate at the end of training.  Whether the data
        identify it is a separate question, answered by a profile
        (:func:`~sklearn_hybrid.identifiability.profile_theta`): pass it as
        ``profile`` and the report gives per parameter the verdict and, where
        identified, the interval whose coverage ``benchmarks/uncertainty/bench_uncertainty.py``
        measures.  The standard error shown beside theta (``theta_std_``) is
        the Gauss-Newton one of lmfit and ``curve_fit`` with the network held
        fixed: the part of the uncertainty that noise in ``y`` alone makes.
        It misses what the network trades with theta, so no interval is built
        from it.

        Parameters
        ----------
        profile : ThetaProfile, optional
            ``profile_theta(est, X, y)`` of this fit.

        Returns
        -------
        str
        """
        check_is_fitted(self)
        science = self.model_.science
        # the settings of the fit, whatever set_params changed since (fits pickled before: the current ones)
        fit = getattr(self, "_fitted_params", None) or self.get_params(deep=False)
        func = getattr(fit["science"], "__name__", type(fit["science"]).__name__)
        stop = (f"stopped early: loss and theta changed by less than tol={fit['tol']} over "
                f"{fit['n_iter_no_change']} iterations" if self.stopped_early_ else
                "ran to max_iter")
        # n_substeps given as "auto" (in the structure, or a fit pickled with the flat keyword): the choice made
        auto = fit.get("n_substeps") == "auto" or isinstance(getattr(self.model_.structure, "substeps_option", 0), str)
        chosen = getattr(self, "n_substeps_", None) if auto else None
        lines = [f"science: {func}, structure: {fit['structure']}, method: {fit['method']}"
                 + (f", n_substeps: {chosen} (auto)" if chosen else ""),
                 f"iterations: {self.n_iter_} of max_iter={fit['max_iter']} ({stop})",
                 f"training loss (last iteration): {self.history_['loss'][-1]:.4g}"]
        layout = getattr(self.model_.structure, "layout", lambda: "")()
        if layout:  # X alone cannot say where a forced system's state ends
            lines.append(layout)
        if getattr(self, "_not_usable", None):  # first, before any number a reader might trust
            lines.insert(0, f"NOT USABLE: the training went bad: {self._not_usable}")
        if "validation_loss" in self.history_ and len(self.history_["validation_loss"]):
            lines.append(f"validation loss (last check): {self.history_['validation_loss'][-1]:.4g}")
        drift = getattr(self, "theta_drift_", None)  # absent from fits made before it existed
        if drift:
            lines.append("theta drift (relative change over the last 10 % of its summed learning "
                         "rate; a settled theta moves little there): "
                         + ", ".join(f"{k} {v:.2g}" for k, v in drift.items()))
        # the encoder turns its parameters' own gradients off: they are inferred, not fixed
        inferred = getattr(self.model_, "encoder", None) is not None
        notes = {}
        for name in science.names:
            if name in (fit["theta_fixed"] or ()) or (not inferred and not science.raw[name].requires_grad):
                notes[name] = "(fixed)"
                continue
            said = ["(inferred per sample by the encoder; mean over the training samples)"] if inferred else []
            if fit["theta_bounds"] and name in fit["theta_bounds"]:
                said.append(f"(bounds {tuple(None if b is None else float(b) for b in fit['theta_bounds'][name])})")
            if said:
                notes[name] = " ".join(said)
        if inferred:
            how = "no standard errors: theta is inferred per sample; predict_theta(X) gives it for each"
            return format_report("Hybrid fit", lines, self.theta_, None, how, extra=notes)
        verdicts, after = None, []
        if profile is not None:
            # the profile says what the report prints of it: this module imports nothing of identifiability/
            if not callable(getattr(profile, "fit_report_lines", None)):
                raise TypeError("profile must be the ThetaProfile of profile_theta(est, X, y), "
                                f"got {type(profile).__name__}.")
            _check_profile_of_this_fit(profile, science.names, self, notes)
            verdicts, after = profile.fit_report_lines(science.names)
        how = ("noise-only standard error: Gauss-Newton with the network held fixed, not an interval of theta, "
               "since the network can trade with theta")
        subset = getattr(self, "_standard_error_samples", None)
        if subset:
            how += f"; from {subset[0]} of {subset[1]} samples, scaled to all (a short training)"
        if profile is None:
            after = first_screen(getattr(self, "network_share_", None))
        return format_report("Hybrid fit", lines, self.theta_, self.theta_std_, how,
                             std_label="noise-only standard error", extra=notes, verdicts=verdicts,
                             notes_after=after)


#: The network's share of the prediction from which the first screen says that the science model leaves out
#: part of the data (the share of noise that a network fits stays well under it).
SCREEN_SHARE = 0.05


def first_screen(share: float | None) -> list[str]:
    """The report's lines on what the network's share of the prediction implies, and the next step.

    Free (read from the fit): it never calls theta identified, it only says where to go, so that no
    one pays for a step whose only answer is "go to the next one".
    """
    loop = ("close_the_loop(est, X, y) (sklearn_hybrid.diagnosis) names what the science misses and refits theta "
            "without the network, with intervals; it reuses this fit")
    profile = ("profile_theta(est, X, y) (sklearn_hybrid.identifiability) tells whether this hybrid's theta is "
               "identified; pass it as fit_report(profile=...)")
    if share is None:
        return [f"(whether the data identify theta: {profile})"]
    if share >= SCREEN_SHARE:
        return [f"(first screen: the network makes {share:.1%} of the prediction, so the science model leaves out "
                "part of these data, and the network may have taken over part of what theta does: theta above is "
                f"not yet a measurement. Next: {loop}. Or: {profile})"]
    return [f"(first screen: the network makes {share:.1%} of the prediction; the science model explains nearly "
            f"all of the fit. Whether the data pin theta down: {profile}; or {loop}, which also checks that "
            "nothing is missing)"]


def _check_profile_of_this_fit(profile, names, estimator, notes) -> None:
    """Refuse a profile of another fit, or of this estimator before a refit: its intervals and verdicts
    would be printed as this fit's, beside this fit's theta."""
    again = "Profile this fit: est.fit_report(profile=profile_theta(est, X, y))."
    base = lambda label: label.split("[")[0]  # noqa: E731  "k[1]" -> "k"
    unknown = sorted({base(label) for label in profile.verdicts} - set(names))
    if unknown:
        raise ValueError(f"The profile holds parameter(s) {unknown}, which this fit's science function does not "
                         f"have ({list(names)}): it is the profile of another model. {again}")
    fixed = sorted({base(label) for label in profile.verdicts if notes.get(base(label)) == "(fixed)"})
    if fixed:
        held = ", ".join(f"{name}={np.round(estimator.theta_[name], 6)}" for name in fixed)  # float32 digits off
        raise ValueError(f"The profile holds parameter(s) {fixed}, which this fit held fixed ({held}, theta_fixed): "
                         f"it is the profile of another fit, whose intervals are not this fit's. {again}")
    token = getattr(estimator, "_fit_token", None)
    if profile.fit_token is not None and profile.fit_token != token:
        made = ", ".join(f"{label}={value:.6g}" for label, value in profile.estimate.items())
        raise ValueError(f"The profile was made for another fit ({made}), or for this estimator before it was "
                         f"refit: its intervals are not this fit's. {again}")
