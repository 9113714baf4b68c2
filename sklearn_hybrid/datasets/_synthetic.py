"""Synthetic data of the paper's simulated tasks: pendulum, Duffing oscillator, reaction-diffusion.

Every generator integrates the true equations with scipy's explicit Runge-Kutta 5(4) (``RK45``) at tight
tolerances and returns a :class:`sklearn.utils.Bunch` of train/validation/test splits. The paper describes its
integrator as RK45 with a fine time step and a subsampled output; ``solve_ivp`` reads ``t_eval`` from a dense
interpolant that does not influence the adaptive steps, so evaluating directly at multiples of ``dt`` gives the
same values (to ~1e-15) as evaluating on the fine grid and subsampling.

Parameters that the paper estimates (``omega``, ``alpha``, ``a``, ``b``) accept either a number, used for every
sample, or a ``(low, high)`` pair, from which one value per sample is drawn uniformly ("learning with varying
scientific parameters"). Sequences are simulated from a random state at the *start* of the input window, so the
initial-state distribution stated in each docstring holds at time ``-(n_input_steps - 1) * dt``.
"""

from __future__ import annotations

import numbers
from typing import Callable

import numpy as np
from scipy.integrate import solve_ivp
from sklearn.utils import Bunch, check_random_state

_SPLITS = ("train", "val", "test")
# Tolerances far below the default noise (0.01); they keep energy errors of the ODE tasks near 1e-9.
_ODE_TOL = 1e-10
_PDE_TOL = 1e-8
# Duffing initial states have at most this fraction of the escape (separatrix) energy: large enough that the
# cubic term changes the force by up to ~70 %, small enough that no trajectory comes close to escaping.
_DUFFING_ENERGY_FRACTION = 0.9

ParamSpec = float | tuple[float, float]


# ----------------------------------------------------------------------------------------- validation helpers
def check_int(name: str, value, minimum: int) -> int:
    if isinstance(value, bool) or not isinstance(value, numbers.Integral) or value < minimum:
        raise ValueError(f"{name} must be an integer >= {minimum}, got {value!r}.")
    return int(value)


def check_float(name: str, value, minimum: float | None = None, strict: bool = False) -> float:
    try:
        out = float(value)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be a real number, got {value!r}.") from None
    if not np.isfinite(out):
        raise ValueError(f"{name} must be finite, got {value!r}.")
    if minimum is not None and (out < minimum or (strict and out == minimum)):
        raise ValueError(f"{name} must be {'>' if strict else '>='} {minimum}, got {value!r}.")
    return out


def check_common(n_train, n_val, n_test, dt, n_steps, n_input_steps, noise) -> tuple:
    sizes = tuple(check_int(k, v, 1) for k, v in zip(("n_train", "n_val", "n_test"), (n_train, n_val, n_test)))
    return (sizes, check_float("dt", dt, 0.0, strict=True), check_int("n_steps", n_steps, 1),
            check_int("n_input_steps", n_input_steps, 1), check_float("noise", noise, 0.0))


def draw_param(name: str, value, n: int, rng, strict: bool) -> tuple[np.ndarray, ParamSpec]:
    """Per-sample values of a parameter given as a number or a ``(low, high)`` range (non-negative)."""
    if np.ndim(value) == 0:
        spec = check_float(name, value, 0.0, strict=strict)
        return np.full(n, spec), spec
    if np.ndim(value) != 1 or len(value) != 2:
        raise ValueError(f"{name} must be a number or a (low, high) pair, got {value!r}.")
    low, high = (check_float(f"{name} {side}", v, 0.0) for side, v in zip(("low", "high"), value))
    if not low < high:
        raise ValueError(f"{name} range must satisfy low < high, got {value!r}.")
    return rng.uniform(low, high, n), (low, high)


# ----------------------------------------------------------------------------------------- shared machinery
def _integrate(rhs: Callable, state0: np.ndarray, n_points: int, dt: float, tol: float) -> np.ndarray:
    """RK45 solution at times ``0, dt, ..., (n_points - 1) dt``; returns shape ``(state0.size, n_points)``."""
    times = dt * np.arange(n_points)
    sol = solve_ivp(rhs, (0.0, times[-1]), state0.ravel(), method="RK45", t_eval=times, rtol=tol, atol=tol)
    if not sol.success:
        raise RuntimeError(f"ODE integration failed: {sol.message}")
    return sol.y


def _simulate_oscillator(accel: Callable, state0: np.ndarray, n_points: int, dt: float) -> np.ndarray:
    """Integrate ``v'' = accel(v, v')`` for all samples as one system; ``state0`` (n, 2) -> (n, n_points, 2)."""
    n = state0.shape[0]

    def rhs(_t, z):
        v, w = z[:n], z[n:]
        return np.concatenate([w, accel(v, w)])

    return _integrate(rhs, state0.T, n_points, dt, _ODE_TOL).reshape(2, n, n_points).transpose(1, 2, 0)


def pendulum_states(rng, n: int, omega: np.ndarray, gamma: float, dt: float, n_points: int) -> np.ndarray:
    """Damped pendulum trajectories (n, n_points, 2) whose first state is U(-pi/2, pi/2) in angle and velocity."""
    state0 = rng.uniform(-np.pi / 2, np.pi / 2, size=(n, 2))
    stiffness = (2 * np.pi * omega) ** 2
    return _simulate_oscillator(lambda v, w: -gamma * w - stiffness * np.sin(v), state0, n_points, dt)


def output_times(dt: float, n_steps: int, n_input_steps: int) -> tuple[np.ndarray, np.ndarray]:
    return dt * np.arange(1, n_steps + 1), dt * np.arange(1 - n_input_steps, 1)


def _window(states: np.ndarray, n_input_steps: int, rng, noise: float) -> tuple[np.ndarray, np.ndarray]:
    """Split (n, m_x + m_y, ...) trajectories into noisy X (a single state if m_x == 1) and y."""
    X = states[:, 0] if n_input_steps == 1 else states[:, :n_input_steps]
    y = states[:, n_input_steps:]
    if noise > 0:
        X = X + noise * rng.standard_normal(X.shape)
        y = y + noise * rng.standard_normal(y.shape)
    return X, y


def split_samples(arrays: dict, sizes: tuple) -> Bunch:
    """Bunch with ``<key>_train/_val/_test`` for every array (first axis = samples) or dict of arrays."""
    cuts = np.cumsum(sizes)[:-1]
    out = Bunch()
    for key, value in arrays.items():
        if isinstance(value, dict):
            parts = {name: np.split(arr, cuts) for name, arr in value.items()}
            for i, split in enumerate(_SPLITS):
                out[f"{key}_{split}"] = {name: p[i] for name, p in parts.items()}
        else:
            for split, part in zip(_SPLITS, np.split(value, cuts)):
                out[f"{key}_{split}"] = part
    return out


def _shape_lines(bunch: Bunch) -> str:
    return "\n".join(f"  {k}: {bunch[k].shape}" for k in ("X_train", "y_train", "X_val", "X_test"))


def finish_bunch(bunch: Bunch, *, dt, t, t_input, theta_true, params, title, equation, feature_names=None) -> Bunch:
    bunch.update(t=t, t_input=t_input, dt=dt, theta_true=theta_true, params=params)
    if feature_names is not None:
        bunch["feature_names"] = feature_names
    settings = ", ".join(f"{k}={v!r}" for k, v in params.items())
    bunch["DESCR"] = f"{title}\n  {equation}\n  {settings}\nShapes:\n{_shape_lines(bunch)}\n"
    return bunch


# ----------------------------------------------------------------------------------------- generators
def make_pendulum(n_train: int = 25, n_val: int = 25, n_test: int = 25, *, omega: ParamSpec = 2 / 3,
                  gamma: float = 0.5, dt: float = 0.2, n_steps: int = 10, n_input_steps: int = 1,
                  noise: float = 0.01, random_state=None) -> Bunch:
    """Damped pendulum time series (the paper's *pendulum time-series* task).

    Simulates ``v'' + gamma v' + (2 pi omega)^2 sin v = 0``. The angle and angular velocity at the start of the
    input window are drawn from U(-pi/2, pi/2).

    Parameters
    ----------
    n_train, n_val, n_test : int
        Number of input-output pairs per split (>= 1).
    omega : float or (float, float)
        Frequency parameter (> 0), or a ``(low, high)`` range to draw one value per sample; the paper's
        varying-parameter setting uses ``(0.1, 1.0)`` with ``n_input_steps=10``.
    gamma : float
        Damping coefficient (>= 0).
    dt : float
        Time between stored states (> 0).
    n_steps : int
        Output sequence length m_y (>= 1).
    n_input_steps : int
        Input sequence length m_x (>= 1). With 1, X is the state at time 0; otherwise X holds the states at times
        ``-(m_x - 1) dt, ..., 0``.
    noise : float
        Standard deviation of the Gaussian noise added to X and y (>= 0).
    random_state : int, RandomState instance or None
        Seed; the same seed gives identical arrays.

    Returns
    -------
    data : Bunch
        ``X_*`` of shape (n, 2) (or (n, m_x, 2)) with columns ``[angle, velocity]``; ``y_*`` of shape
        (n, n_steps, 2); ``t`` (output times ``dt .. n_steps dt``), ``t_input``, ``dt``; ``theta_true``
        ``{"omega": value or (low, high)}``; ``theta_train/val/test`` ``{"omega": (n,) array}``; ``params``;
        ``feature_names``; ``DESCR``.
    """
    sizes, dt, n_steps, n_input_steps, noise = check_common(n_train, n_val, n_test, dt, n_steps,
                                                             n_input_steps, noise)
    gamma = check_float("gamma", gamma, 0.0)
    rng = check_random_state(random_state)
    n = sum(sizes)
    omegas, omega_spec = draw_param("omega", omega, n, rng, strict=True)
    states = pendulum_states(rng, n, omegas, gamma, dt, n_input_steps + n_steps)
    X, y = _window(states, n_input_steps, rng, noise)
    params = dict(omega=omega_spec, gamma=gamma, dt=dt, n_steps=n_steps, n_input_steps=n_input_steps,
                  noise=noise, initial_state_range=(-np.pi / 2, np.pi / 2), solver="RK45", tol=_ODE_TOL)
    return finish_bunch(split_samples({"X": X, "y": y, "theta": {"omega": omegas}}, sizes), dt=dt,
                   t=output_times(dt, n_steps, n_input_steps)[0], t_input=output_times(dt, n_steps, n_input_steps)[1],
                   theta_true={"omega": omega_spec}, params=params, title="Damped pendulum time series",
                   equation="v'' + gamma v' + (2 pi omega)^2 sin v = 0, state [v, v']",
                   feature_names=["angle", "angular_velocity"])


def _duffing_initial_states(rng, alpha: np.ndarray, beta: float) -> np.ndarray:
    """Uniform draws from the bounded region {E < fraction * E_s, |v| < v_s} of each sample's potential well.

    In units ``v = p sqrt(alpha/beta)``, ``v' = q alpha / sqrt(beta)`` the energy ratio is
    ``E / E_s = 2 q^2 + 2 p^2 - p^4`` whatever alpha and beta are, so rejection sampling is done once in (p, q).
    """
    n, fraction = alpha.size, _DUFFING_ENERGY_FRACTION
    q_max = np.sqrt(fraction / 2)
    accepted = np.empty((0, 2))
    while accepted.shape[0] < n:  # acceptance is ~65 %, so this loops once or twice
        p, q = rng.uniform(-1, 1, 2 * n), rng.uniform(-q_max, q_max, 2 * n)
        keep = 2 * q**2 + 2 * p**2 - p**4 < fraction
        accepted = np.concatenate([accepted, np.column_stack([p[keep], q[keep]])])
    p, q = accepted[:n].T
    return np.column_stack([p * np.sqrt(alpha / beta), q * alpha / np.sqrt(beta)])


def make_duffing(n_train: int = 100, n_val: int = 100, n_test: int = 100, *, alpha: ParamSpec = 1.0,
                 beta: float = 1.0, gamma: float = 0.0, dt: float = 0.1, n_steps: int = 10,
                 n_input_steps: int = 1, noise: float = 0.01, random_state=None) -> Bunch:
    """Duffing oscillator time series (the paper's *duffing oscillator* task).

    Simulates ``v'' + gamma v' + alpha v - beta v^3 = 0`` (the paper's softening sign). Its potential
    ``alpha v^2/2 - beta v^4/4`` has a well of depth ``E_s = alpha^2 / (4 beta)`` bounded by maxima at
    ``v_s = +-sqrt(alpha / beta)``; states with more energy escape to infinity in finite time. The paper gives no
    initial-condition range, so the state at the start of the input window is drawn uniformly from
    ``{|v| < v_s, E < 0.9 E_s}`` (rejection sampling). For alpha = beta = 1 this means amplitudes up to 0.83 and
    velocities up to 0.67, where the cubic force reaches ~70 % of the linear one, while no orbit comes near the
    separatrix. The region scales with each sample's alpha, so small alpha gives small, slow oscillations.

    Parameters
    ----------
    n_train, n_val, n_test : int
        Number of input-output pairs per split (>= 1).
    alpha : float or (float, float)
        Linear stiffness (> 0), or a ``(low, high)`` range (low >= 0) to draw one value per sample; the paper's
        varying-parameter setting uses ``(0.0, 2.0)`` with ``n_input_steps=10``.
    beta : float
        Cubic coefficient (> 0).
    gamma : float
        Damping coefficient (>= 0; the paper uses 0).
    dt, n_steps, n_input_steps, noise, random_state
        As in :func:`make_pendulum` (defaults dt=0.1, m_y=10).

    Returns
    -------
    data : Bunch
        ``X_*`` (n, 2) or (n, m_x, 2) with columns ``[position, velocity]``; ``y_*`` (n, n_steps, 2); ``t``,
        ``t_input``, ``dt``; ``theta_true`` ``{"alpha": value or (low, high)}``; ``theta_train/val/test``
        ``{"alpha": (n,) array}``; ``params``; ``feature_names``; ``DESCR``.
    """
    sizes, dt, n_steps, n_input_steps, noise = check_common(n_train, n_val, n_test, dt, n_steps,
                                                             n_input_steps, noise)
    beta = check_float("beta", beta, 0.0, strict=True)
    gamma = check_float("gamma", gamma, 0.0)
    rng = check_random_state(random_state)
    n = sum(sizes)
    alphas, alpha_spec = draw_param("alpha", alpha, n, rng, strict=True)
    state0 = _duffing_initial_states(rng, alphas, beta)
    states = _simulate_oscillator(lambda v, w: -gamma * w - alphas * v + beta * v**3, state0,
                                  n_input_steps + n_steps, dt)
    X, y = _window(states, n_input_steps, rng, noise)
    params = dict(alpha=alpha_spec, beta=beta, gamma=gamma, dt=dt, n_steps=n_steps, n_input_steps=n_input_steps,
                  noise=noise, initial_energy_fraction=_DUFFING_ENERGY_FRACTION, solver="RK45", tol=_ODE_TOL)
    t, t_input = output_times(dt, n_steps, n_input_steps)
    return finish_bunch(split_samples({"X": X, "y": y, "theta": {"alpha": alphas}}, sizes), dt=dt, t=t, t_input=t_input,
                   theta_true={"alpha": alpha_spec}, params=params, title="Duffing oscillator time series",
                   equation="v'' + gamma v' + alpha v - beta v^3 = 0, state [v, v']",
                   feature_names=["position", "velocity"])


def _laplacian(fields: np.ndarray, dx: float, boundary: str) -> np.ndarray:
    """Five-point Laplacian over the last two axes (periodic: wrap-around; neumann: zero-flux edge padding)."""
    if boundary == "periodic":
        neighbours = sum(np.roll(fields, s, axis=ax) for s in (1, -1) for ax in (-1, -2))
    else:
        padded = np.pad(fields, [(0, 0)] * (fields.ndim - 2) + [(1, 1), (1, 1)], mode="edge")
        neighbours = (padded[..., 2:, 1:-1] + padded[..., :-2, 1:-1]
                      + padded[..., 1:-1, 2:] + padded[..., 1:-1, :-2])
    return (neighbours - 4 * fields) / dx**2


def make_reaction_diffusion(n_train: int = 100, n_val: int = 100, n_test: int = 100, *, a: ParamSpec = 1e-3,
                            b: ParamSpec = 5e-3, k: float = 5e-3, grid_size: int = 32, dt: float = 0.1,
                            n_steps: int = 5, n_input_steps: int = 1, noise: float = 0.01,
                            boundary: str = "periodic", random_state=None) -> Bunch:
    """FitzHugh-Nagumo reaction-diffusion fields (the paper's *reaction-diffusion* task).

    Simulates ``u_t = a lap(u) + u - u^3 - k - v`` and ``v_t = b lap(v) + u - v`` on ``[-1, 1]^2`` discretised
    with ``grid_size`` points per axis (``dx = 2 / grid_size``) and the five-point Laplacian. The boundary is
    periodic by default (the paper does not say; periodic matches the setting of Yin et al., 2021) or zero-flux
    Neumann. The fields at the start of the input window are U(0, 1) per pixel. All samples are integrated as
    one vectorised RK45 system; the default size takes a few seconds on one core.

    Parameters
    ----------
    n_train, n_val, n_test : int
        Number of input-output pairs per split (>= 1).
    a, b : float or (float, float)
        Diffusion coefficients of u and v (>= 0), or ``(low, high)`` ranges to draw one value per sample; the
        paper's varying-parameter setting uses ``(0.0, 0.02)`` for both with ``n_input_steps=5``.
    k : float
        Constant reaction term kappa.
    grid_size : int
        Grid points per axis (>= 3).
    dt, n_steps, n_input_steps, noise, random_state
        As in :func:`make_pendulum` (defaults dt=0.1, m_y=5).
    boundary : {"periodic", "neumann"}
        Boundary condition of the Laplacian.

    Returns
    -------
    data : Bunch
        ``X_*`` (n, 2, G, G) or (n, m_x, 2, G, G) with channels ``[u, v]``; ``y_*`` (n, n_steps, 2, G, G); ``t``,
        ``t_input``, ``dt``; ``theta_true`` ``{"a": ..., "b": ...}``; ``theta_train/val/test`` with per-sample
        ``a`` and ``b``; ``params``; ``feature_names`` (the channel names); ``DESCR``.
    """
    sizes, dt, n_steps, n_input_steps, noise = check_common(n_train, n_val, n_test, dt, n_steps,
                                                             n_input_steps, noise)
    k = check_float("k", k)
    grid = check_int("grid_size", grid_size, 3)
    if boundary not in ("periodic", "neumann"):
        raise ValueError(f"boundary must be 'periodic' or 'neumann', got {boundary!r}.")
    rng = check_random_state(random_state)
    n = sum(sizes)
    a_values, a_spec = draw_param("a", a, n, rng, strict=False)
    b_values, b_spec = draw_param("b", b, n, rng, strict=False)
    state0 = rng.uniform(0.0, 1.0, size=(n, 2, grid, grid))
    dx = 2.0 / grid
    diffusion = np.stack([a_values, b_values], axis=1)[:, :, None, None]  # (n, 2, 1, 1)

    def rhs(_t, z):
        fields = z.reshape(n, 2, grid, grid)
        u, v = fields[:, 0], fields[:, 1]
        out = diffusion * _laplacian(fields, dx, boundary)
        out[:, 0] += u - u**3 - k - v
        out[:, 1] += u - v
        return out.ravel()

    n_points = n_input_steps + n_steps
    states = np.moveaxis(_integrate(rhs, state0, n_points, dt, _PDE_TOL).reshape(n, 2, grid, grid, n_points),
                         -1, 1)
    X, y = _window(states, n_input_steps, rng, noise)
    params = dict(a=a_spec, b=b_spec, k=k, grid_size=grid, dx=dx, dt=dt, n_steps=n_steps,
                  n_input_steps=n_input_steps, noise=noise, boundary=boundary, initial_state_range=(0.0, 1.0),
                  solver="RK45", tol=_PDE_TOL)
    t, t_input = output_times(dt, n_steps, n_input_steps)
    return finish_bunch(split_samples({"X": X, "y": y, "theta": {"a": a_values, "b": b_values}}, sizes), dt=dt, t=t,
                   t_input=t_input, theta_true={"a": a_spec, "b": b_spec}, params=params,
                   title="FitzHugh-Nagumo reaction-diffusion on [-1, 1]^2",
                   equation="u_t = a lap(u) + u - u^3 - k - v,  v_t = b lap(v) + u - v",
                   feature_names=["u", "v"])
