"""The hybrid neural ODE ``dv/dt = f_theta(v[, u]) + g_phi(v[, u])``: forced, partially observed, its RK4
steps per output chosen from the data (``n_substeps="auto"``)."""

from __future__ import annotations

import inspect
import math
import numbers
import warnings
from types import SimpleNamespace

import numpy as np
import torch

from ..integrate import fast
from .._probe import call_science, probe_batch
from .._validation import check_positive
from ..integrate import INPUT_INTERPOLATIONS, integrate, upsample_inputs

__all__ = ["OdeStructure", "pack_inputs", "ODE_DEFAULTS"]


def pack_inputs(x0: np.ndarray, u: np.ndarray) -> np.ndarray:
    """Build the ``X`` of a forced ODE from initial states and input sequences.

    Parameters
    ----------
    x0 : ndarray of shape (n_samples, n_states)
        Initial states.
    u : ndarray of shape (n_samples, n_steps + 1, n_inputs)
        Inputs on the output grid, from time 0 to the last output time.

    Returns
    -------
    ndarray of shape (n_samples, n_states + (n_steps + 1) * n_inputs)

    Notes
    -----
    The fit reads the layout back from ``y``'s steps: the state is what remains of ``X`` after
    ``n_steps + 1`` input samples.  ``X`` alone cannot tell a surplus input sample from a state
    component, so pack exactly ``y``'s ``n_steps + 1`` samples (``u[:, :n_steps + 1]``).  A
    surplus is refused where the science function or ``y`` fixes the state's size; where neither
    does (a function such as ``-k * v + u`` and ``observed`` set) it becomes state components:
    the fit then warns that ``X`` could also be read as a smaller state, and ``fit_report()``
    says how it was read.
    """
    x0, u = np.asarray(x0, float), np.asarray(u, float)
    if u.ndim == 2:
        u = u[:, :, None]
    if x0.ndim != 2 or u.ndim != 3 or len(x0) != len(u):
        raise ValueError(f"pack_inputs needs x0 (n, d) and u (n, T, k); got {x0.shape} and {u.shape}.")
    return np.concatenate([x0, u.reshape(len(u), -1)], axis=1)


def _check_observed(observed) -> list[int]:
    """``observed`` as a non-empty list of distinct non-negative integers."""
    values = list(np.atleast_1d(np.asarray(observed, dtype=object)))
    if not values or not all(isinstance(i, numbers.Integral) and not isinstance(i, bool)
                             and i >= 0 for i in values):
        raise ValueError(
            f"observed must list the observed state components as non-negative integers "
            f"(e.g. observed=[0]), got {observed!r}."
        )
    if len(set(values)) != len(values):
        raise ValueError(f"observed={observed!r} lists a component twice.")
    return [int(i) for i in values]


#: Most integration steps per output interval: beyond it one iteration costs minutes.
N_SUBSTEPS_MAX = 1000
#: ``n_substeps="auto"``: the candidates, the largest integration error allowed, and what a forced system,
#: another solver or a science model that blows up takes.  The error is relative to y's spread: a tenth of a
#: noise of 1 % of the spread, with a margin of 4 for theta moving away from its start during the fit (RK4's
#: error grows as the fourth power of the rates: 4 covers rates 40 % faster).
AUTO_SUBSTEPS = (1, 2, 4, 8, 16)
AUTO_SUBSTEPS_TOL = 2.5e-4
DEFAULT_SUBSTEPS = 4


class OdeStructure:
    """Hybrid neural ODE, optionally forced by inputs and partially observed.

    ``X`` holds initial states (any per-sample shape, e.g. ``(2,)`` or a field
    ``(2, 32, 32)``); for a forced system (``n_inputs > 0``) each row is the
    initial state followed by the inputs on the output grid (see
    :func:`pack_inputs`).  ``y`` holds the observed states at ``dt, ...,
    n_steps * dt``, shaped ``(n, n_steps, n_observed)`` or flattened.

    Parameters
    ----------
    dt : float, default=1.0
        Time between consecutive outputs (outputs at ``dt, 2 dt, ...``),
        in the time unit of theta's rates.  The data cannot tell the time
        step, and a wrong one scales every rate in theta without a sign: a
        fit with ``structure="ode"`` (no object, so no ``dt``) warns and
        takes 1.0, the output step as the time unit.
    n_substeps : int or "auto", default="auto"
        Steps per output interval of ``"rk4"`` and of torchdiffeq's
        fixed-grid methods (``"euler"``, ``"midpoint"``...).  ``"auto"``: for
        the RK4 of an unforced system, the fewest of 1, 2, 4, 8, 16 whose free
        run of the science model (at its starting theta, from the training
        states) stays within 0.025 % of ``y``'s spread of a run with 64 steps,
        chosen at fit (``n_substeps_``); 4 for a forced system or another
        solver.  The cost of a fit grows with it.
    solver : str, default="rk4"
        ``"rk4"`` (output-aligned) or a torchdiffeq method such as
        ``"dopri5"`` (adaptive: ``n_substeps`` then only sets the grid of the
        inputs).
    observed : list of int, optional
        Indices of the state components that ``y`` observes.
    n_inputs : int, default=0
        Number of measured input channels u(t) (see
        :func:`~sklearn_hybrid.pack_inputs`: ``X`` holds the initial state,
        then the inputs at ``y``'s ``n_steps + 1`` times, and ``fit_report()``
        says how it was read).
    input_interp : {"cubic", "linear", "zoh", "fft"}, default="cubic"
        Reconstruction of u(t) between samples.
    solver_options : dict, optional
        Extra keyword arguments of torchdiffeq's adaptive solvers (``rtol``, ``atol``).

    Examples
    --------
    ``HybridRegressor(science=f, structure=OdeStructure(dt=0.1, observed=[0]))``: a
    hybrid ODE sampled every 0.1 time units, whose ``y`` holds the first state only.
    """

    additive = True

    def __init__(self, dt=1.0, n_substeps="auto", solver="rk4", observed=None, n_inputs=0,
                 input_interp="cubic", solver_options=None):
        check_positive("dt", dt)
        # "auto" is chosen from the data at fit (choose_substeps) where the RK4 integrates a free state; a forced
        # system's input grid and other solvers take the fixed default
        self.auto_substeps = isinstance(n_substeps, str) and n_substeps == "auto"
        self.substeps_option = n_substeps  # as given: what a fresh copy is built from
        if self.auto_substeps:
            n_substeps = DEFAULT_SUBSTEPS
            self.auto_substeps = solver == "rk4" and not n_inputs
        check_positive("n_substeps", n_substeps, integer=True)
        if n_substeps > N_SUBSTEPS_MAX:  # the memory check and every iteration would integrate them all
            raise ValueError(
                f"n_substeps must be at most {N_SUBSTEPS_MAX}, got {n_substeps!r}: every output interval is "
                "integrated in n_substeps steps, each kept for the backward pass. Dynamics that need more "
                "are stiff for RK4: use an adaptive solver (solver='dopri5'), or give y at a shorter dt.")
        if input_interp not in INPUT_INTERPOLATIONS:
            raise ValueError(f"Unknown input_interp {input_interp!r}; choose one of {INPUT_INTERPOLATIONS}.")
        if not isinstance(n_inputs, numbers.Integral) or isinstance(n_inputs, bool) or n_inputs < 0:
            raise ValueError(f"n_inputs must be a non-negative integer, got {n_inputs!r}.")
        self.dt, self.n_substeps, self.solver = float(dt), int(n_substeps), solver
        self.observed = None if observed is None else _check_observed(observed)
        self.n_inputs, self.input_interp = int(n_inputs), input_interp
        self.solver_options = solver_options

    def options(self) -> dict:
        """The options as stored (``dt`` a float, ``observed`` a list): what a fresh copy is built from."""
        return {"dt": self.dt, "n_substeps": "auto" if isinstance(self.substeps_option, str) else self.n_substeps,
                "solver": self.solver, "observed": self.observed,
                "n_inputs": self.n_inputs, "input_interp": self.input_interp, "solver_options": self.solver_options}

    def __eq__(self, other) -> bool:  # equal options: a refit with an equal object changes nothing
        return type(other) is type(self) and self.options() == other.options()

    __hash__ = None  # mutable (a fit's copy is set up), so unhashable, as a list

    def __repr__(self) -> str:
        given = [f"{k}={v!r}" for k, v in self.options().items() if v != ODE_DEFAULTS[k]]
        return f"OdeStructure({', '.join(given)})"

    def setup(self, X: np.ndarray, y_shape: tuple) -> None:
        """Learn the state shape and ``n_steps``; ``y`` is (n, n_steps, *observed shape)."""
        y_shape = tuple(y_shape)
        if not y_shape:
            raise ValueError(
                "For structure='ode' y must have shape (n_samples, n_steps, n_observed); got a "
                "1-D y (one value per sample)."
            )
        self.n_steps = y_shape[0]
        if self.n_inputs == 0:
            self.state_shape = tuple(X.shape[1:])
        else:
            if X.ndim != 2:
                raise ValueError("A forced ODE (n_inputs > 0) needs a 2-D X built with pack_inputs.")
            self.state_shape = (X.shape[1] - (self.n_steps + 1) * self.n_inputs,)
            if self.state_shape[0] < 1:
                raise ValueError(
                    f"X has {X.shape[1]} columns, too few for {self.n_steps + 1} input samples "
                    f"of {self.n_inputs} input(s) plus an initial state (y of shape "
                    f"(n, {', '.join(map(str, y_shape))}) has {self.n_steps} steps)."
                )
        n_state = math.prod(self.state_shape)
        if self.observed is not None:
            if len(self.state_shape) != 1 or not all(0 <= i < n_state for i in self.observed):
                raise ValueError(
                    f"observed={self.observed} must index a vector state of length {n_state}."
                )
            self.obs_shape = (len(self.observed),)
        else:
            self.obs_shape = tuple(self.state_shape)
        per_step = y_shape[1:]
        if per_step != self.obs_shape and not (per_step == () and self.obs_shape == (1,)):
            raise ValueError(self._layout_message(y_shape, n_state) + self._packing_note(X))

    def choose_substeps(self, science, x0: torch.Tensor, y: torch.Tensor) -> None:
        """Resolve ``n_substeps="auto"``: the fewest RK4 steps per output interval that integrate the science
        model accurately.

        The science model alone, at its starting theta, is run freely from (up to 64 of) the training
        states with 1, 2, 4, 8 and 16 steps per interval and compared with a run of 64; the first whose
        largest error stays under ``AUTO_SUBSTEPS_TOL`` of y's spread is taken (a far smaller error
        than measurement noise, so that the step size does not bias theta), else 16.  A science model
        that does not stay finite from these states keeps the fixed default.
        """
        if not self.auto_substeps:
            return
        model = SimpleNamespace(science=science, residual=None)
        x0 = x0[:64]
        scale = float(y.reshape(len(y), -1).std(0).max()) or 1.0
        with torch.no_grad():
            reference = self.states(model, x0, use_residual=False, n_substeps=64)
            if not torch.isfinite(reference).all():
                return
            for n in AUTO_SUBSTEPS:  # the fewest first: the finer runs are not needed once one passes
                run = self.states(model, x0, use_residual=False, n_substeps=n)
                if float((run - reference).abs().max()) <= AUTO_SUBSTEPS_TOL * scale:
                    self.n_substeps = n
                    return
        self.n_substeps = AUTO_SUBSTEPS[-1]

    def _packing_note(self, X) -> str:
        """How the columns of a forced system's X were split, counted from y's steps (empty unforced).

        The state's size is what remains of X after the inputs that y's steps need: an X packed with
        more input samples than that gives the state extra components (one per surplus column).
        """
        if not self.n_inputs:
            return ""
        samples = self.n_steps + 1
        return (f" X has {X.shape[1]} columns: y's {self.n_steps} steps need {samples} input samples of "
                f"{self.n_inputs} input(s) (times 0 to {self.n_steps} dt), {samples * self.n_inputs} "
                f"columns, which leaves {self.state_shape[0]} for the state. If the state has fewer "
                f"components, X holds more input samples than y's steps need: pack u with "
                f"{samples} samples, pack_inputs(x0, u[:, :{samples}]).")

    def layout(self) -> str:
        """How a forced system's X was read (empty unforced): the state, then the input samples."""
        if not self.n_inputs:
            return ""
        return (f"X read as a state of {self.state_shape[0]} component(s), then {self.n_steps + 1} samples of "
                f"{self.n_inputs} input(s) (times 0 to {self.n_steps} dt, from y's {self.n_steps} steps)")

    def _layout_message(self, y_shape, n_state):
        """Say which layout ``y`` needs, what it has, and the likely fix."""
        obs = self.obs_shape
        seen = (f"observed={self.observed}" if self.observed is not None
                else "all state components observed")
        msg = (f"For structure='ode' y must have shape (n_samples, n_steps, "
               f"{', '.join(map(str, obs))}) (state shape {self.state_shape} from X, {seen}); "
               f"got y of per-sample shape {y_shape}.")
        if len(y_shape) == 1:  # one component over time, or flattened trajectories: y cannot tell
            msg += (" If y holds one state component over time, say which with observed=[i]"
                    + (f"; if it was flattened, give it back its steps: y.reshape(len(y), -1, "
                       f"{', '.join(map(str, obs))})." if self.observed is None or len(self.observed) > 1 else "."))
        elif tuple(y_shape[:len(obs)]) == obs and len(y_shape) == len(obs) + 1:
            msg += " It looks transposed (time on the last axis): use np.moveaxis(y, -1, 1)."
        elif self.observed is not None and y_shape[1:] == tuple(self.state_shape):
            msg += (f" y holds every state component, but observed={self.observed} says it "
                    f"holds {len(self.observed)}: pass y[..., {self.observed}] or leave "
                    "observed=None.")
        elif self.observed is None and len(y_shape) == 2 and y_shape[1] < n_state:
            msg += (f" y holds {y_shape[1]} of the {n_state} state components: say which with "
                    "observed=[...].")
        return msg

    def tensors(self, X: np.ndarray, dtype: torch.dtype) -> tuple[torch.Tensor, ...]:
        n, d = len(X), math.prod(self.state_shape)
        if self.n_inputs == 0:
            return (torch.tensor(X, dtype=dtype),)  # a copy: the science never sees the caller's memory
        expected = d + (self.n_steps + 1) * self.n_inputs
        if X.shape[1] != expected:
            raise ValueError(f"X has {X.shape[1]} columns; this forced ODE needs {expected}.")
        u = X[:, d:].reshape(n, self.n_steps + 1, self.n_inputs)
        u_fine = upsample_inputs(u, 2 * self.n_substeps, self.input_interp)
        return (torch.tensor(X[:, :d].reshape(n, *self.state_shape), dtype=dtype),
                torch.as_tensor(u_fine, dtype=dtype))

    def _args(self, v, u):
        return (v,) if u is None else (v, u)

    def probe(self, science, inputs) -> None:
        takes = science.inputs  # the arguments without a default: (v,) or (v, u)
        if len(takes) == 1 and self.n_inputs:
            raise ValueError(f"The science function takes the state {takes[0]!r} alone, but n_inputs="
                             f"{self.n_inputs}: give it the inputs as its second argument, f({takes[0]}, u, ...), "
                             "or set n_inputs=0.")
        if len(takes) == 2 and not self.n_inputs:
            raise ValueError(f"The science function takes inputs {takes[1]!r} besides the state, but "
                             "n_inputs=0: set n_inputs and build X with pack_inputs(x0, u).")
        batch = probe_batch(inputs, self.state_shape)
        v = batch[0]
        u = batch[1][:, 0] if self.n_inputs else None
        try:
            call_science(science, self._args(v, u), v.shape,
                         "states" + (" and inputs" if u is not None else ""), differentiable=True)
        except ValueError as error:  # a state size taken wrongly from X shows as an output of the wrong shape
            if not self.n_inputs or "the structure needs" not in str(error):
                raise
            n = self.state_shape[0]
            raise ValueError(str(error) + self._packing_note(np.empty((0, n + (self.n_steps + 1) * self.n_inputs))))
        smaller = self._smaller_states_accepted(science, v, u)
        if smaller:
            # X cannot say which it is; the user can, once told (4 levels up: the caller of fit)
            warnings.warn(
                f"{self.layout()}. Neither y (observed={self.observed}) nor the science function "
                f"{science.name!r}, which works for a state of {' or '.join(map(str, smaller))} component(s) too, "
                "fixes the state's size, so X packed with more input samples than y's steps need would read "
                f"as this larger state. If the state has fewer components, pack exactly y's n_steps + 1 = "
                f"{self.n_steps + 1} input samples: pack_inputs(x0, u[:, :{self.n_steps + 1}]).",
                UserWarning, stacklevel=4)

    def _smaller_states_accepted(self, science, v, u) -> list[int]:
        """Smaller state sizes that a forced X with surplus input samples would also fit (largest first).

        k surplus input samples read as ``k * n_inputs`` extra state components.  Where ``y``
        observes the whole state it fixes the state's size and ``setup`` refused a surplus; with
        ``observed`` set, a smaller state that holds the observed components and that the science
        function maps to its own shape is as consistent with ``X`` as the state read.
        """
        if not self.n_inputs or self.observed is None or len(self.state_shape) != 1:
            return []
        sizes = []
        for k in range(1, 9):  # a few surplus samples: the usual mistake is u of the full record
            size = self.state_shape[0] - k * self.n_inputs
            if size <= max(self.observed):
                break
            try:
                with torch.no_grad():
                    out = science(*self._args(v[:, :size].detach(), u.detach()))
            except Exception:  # it needs the larger state: the size is fixed
                continue
            if isinstance(out, torch.Tensor) and tuple(out.shape) == (len(v), size):
                sizes.append(size)
        return sizes

    def residual_shapes(self):
        ins = (tuple(self.state_shape),) + (((self.n_inputs,),) if self.n_inputs else ())
        return ins, tuple(self.state_shape)

    def states(self, model, x0, u_fine=None, use_residual=True, n_steps=None, dt=None,
               n_substeps=None):
        """States at ``dt, ..., n_steps * dt`` (default: the training grid), all components.

        ``u_fine`` holds the inputs on the grid ``2 * n_substeps`` times finer
        than the output grid, as :meth:`tensors` builds it.
        """
        n_steps = self.n_steps if n_steps is None else n_steps
        dt = self.dt if dt is None else dt
        n_substeps = self.n_substeps if n_substeps is None else n_substeps
        # a tensor: the network's share per sample (1 hybrid, 0 science alone), one batch for both
        mask = use_residual if torch.is_tensor(use_residual) else None
        use_residual = bool(use_residual) if mask is None else True

        def rhs(v, u):
            args = self._args(v, u)
            if not use_residual:
                return model.science(*args)
            g = model.residual(*args)
            return model.science(*args) + (g if mask is None else mask * g)

        # the fast RK4 assumes one theta shared by every sample (not so with a theta encoder)
        if (use_residual and mask is None and torch.is_grad_enabled()
                and not getattr(model, "per_sample_theta", False)
                and fast.supports(model.residual, self.state_shape, self.solver)):
            # same RK4, gradients without per-stage autograd overhead (see integrate/fast.py); without
            # gradients (predict) the plain loop is faster, as nothing is kept for a backward
            return fast.hybrid_states(model.science, model.residual, x0, u_fine, n_steps, dt,
                                       n_substeps)
        if not getattr(model, "per_sample_theta", False):  # no gradients: theta read once (see integrate/fast.py)
            rhs = fast.frozen_rhs(model.science, model.residual if use_residual else None, mask) or rhs
        return integrate(rhs, x0, n_steps, dt, n_substeps=n_substeps, solver=self.solver,
                         u_fine=u_fine, solver_options=self.solver_options)

    def forward(self, model, x0, u_fine=None, use_residual=True):
        states = self.states(model, x0, u_fine, use_residual)
        pred = states if self.observed is None else states[..., self.observed]
        return pred, {"states": torch.cat([x0[:, None], states], dim=1), "u_fine": u_fine}

    def residual_values(self, model, extras):
        """g_phi at the states the prediction visits (time 0 and every output time)."""
        states = extras["states"]
        flat = states.reshape(-1, *self.state_shape)
        args = (flat,)
        if extras["u_fine"] is not None:
            u = extras["u_fine"][:, :: 2 * self.n_substeps]
            args = (flat, u.reshape(-1, self.n_inputs))
        return model.residual(*args).reshape(states.shape)

    def functional_penalty(self, model, pred, extras):
        g = self.residual_values(model, extras)  # (n, n_steps, ...): mean over each sample's steps
        return g.pow(2).reshape(g.shape[0], g.shape[1], -1).sum(-1).mean(1)

    def trace(self, model, inputs, pred, extras):
        states = extras["states"]
        u = extras["u_fine"]
        return {"points": states.reshape(-1, *self.state_shape),
                "inputs": None if u is None else u[:, :: 2 * self.n_substeps].reshape(-1, self.n_inputs),
                "residual": self.residual_values(model, extras).reshape(-1, *self.state_shape)}

    def make_reduction(self, dtype):
        return None


#: OdeStructure's options and their defaults, which the estimator's keywords of the same names share.
ODE_DEFAULTS = {name: p.default for name, p in inspect.signature(OdeStructure).parameters.items()}
