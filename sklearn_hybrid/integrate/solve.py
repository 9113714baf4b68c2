"""ODE integration on the output grid, with measured inputs reconstructed in between.

The fixed-step RK4 takes ``n_substeps`` classic Runge-Kutta steps per output
interval, so every output time is hit exactly (no interpolation error of the
kind torchdiffeq's ``step_size`` grids introduce when the step does not divide
the output spacing).  Adaptive solvers (``"dopri5"`` and every other
torchdiffeq method) are delegated to :func:`torchdiffeq.odeint`.

A forced system needs its input u(t) between samples; how it is rebuilt
decides the result on measured data (see the Silverbox notes), so the choice
is explicit: ``"cubic"`` (spline), ``"linear"``, ``"zoh"`` or ``"fft"``
(band-limited, periodic extension).
"""

from __future__ import annotations

from typing import Callable

import numpy as np
import torch

__all__ = ["integrate", "upsample_inputs", "INPUT_INTERPOLATIONS"]

INPUT_INTERPOLATIONS = ("cubic", "linear", "zoh", "fft")
#: torchdiffeq's fixed-grid methods: without a ``step_size`` they take one step per output interval.
_FIXED_GRID = ("euler", "midpoint", "heun2", "heun3", "explicit_adams", "implicit_adams", "fixed_adams")


def upsample_inputs(u: np.ndarray, factor: int, kind: str = "cubic") -> np.ndarray:
    """Rebuild sampled inputs on a grid ``factor`` times finer.

    Parameters
    ----------
    u : ndarray of shape (n_samples, n_times, n_inputs)
        Inputs on the output time grid (including time 0).
    factor : int
        Refinement; the result has ``factor * (n_times - 1) + 1`` points.
    kind : {"cubic", "linear", "zoh", "fft"}
        Reconstruction between samples.

    Returns
    -------
    ndarray of shape (n_samples, factor * (n_times - 1) + 1, n_inputs)
    """
    n_times = u.shape[1]
    fine = np.arange(factor * (n_times - 1) + 1) / factor
    coarse = np.arange(n_times)
    if kind == "linear" or (kind == "cubic" and n_times < 4):
        idx = np.minimum(np.floor(fine).astype(int), n_times - 2)
        w = (fine - idx)[None, :, None]
        return (1 - w) * u[:, idx] + w * u[:, idx + 1]
    if kind == "zoh":
        return u[:, np.floor(fine).astype(int)]
    if kind == "cubic":
        from scipy.interpolate import CubicSpline

        return CubicSpline(coarse, u, axis=1)(fine)
    if kind == "fft":
        from scipy.signal import resample

        return resample(u, factor * n_times, axis=1)[:, : len(fine)]
    raise ValueError(f"Unknown input_interp {kind!r}; choose one of {INPUT_INTERPOLATIONS}.")


def _rk4(rhs, x, n_steps, dt, n_substeps, u_fine):
    h = dt / n_substeps
    outputs, s = [], 0
    for _ in range(n_steps):
        for _ in range(n_substeps):
            if u_fine is None:
                u0 = um = u1 = None
            else:  # inputs at the step's start, midpoint and end (grid of h/2)
                u0, um, u1 = u_fine[:, 2 * s], u_fine[:, 2 * s + 1], u_fine[:, 2 * s + 2]
            k1 = rhs(x, u0)
            k2 = rhs(x + 0.5 * h * k1, um)
            k3 = rhs(x + 0.5 * h * k2, um)
            k4 = rhs(x + h * k3, u1)
            x = x + (h / 6.0) * (k1 + 2.0 * (k2 + k3) + k4)
            s += 1
        outputs.append(x)
    return torch.stack(outputs, dim=1)


def _odeint(rhs, x, n_steps, dt, n_substeps, u_fine, method, options):
    import torchdiffeq

    t = torch.arange(n_steps + 1, dtype=x.dtype, device=x.device) * dt
    if u_fine is None:
        func = lambda t_, v: rhs(v, None)  # noqa: E731
    else:
        h_half = dt / (2 * n_substeps)
        last = u_fine.shape[1] - 1

        def func(t_, v):  # linear interpolation on the fine input grid
            pos = torch.clamp(t_ / h_half, 0, last)
            i = torch.clamp(pos.floor().long(), max=last - 1)
            w = pos - i
            return rhs(v, (1 - w) * u_fine[:, i] + w * u_fine[:, i + 1])

    options = dict(options or {})
    if method in _FIXED_GRID:  # n_substeps steps per output interval, as the RK4 takes
        options.setdefault("options", {"step_size": dt / n_substeps})
    return torchdiffeq.odeint(func, x, t, method=method, **options)[1:].movedim(0, 1)


def integrate(rhs: Callable, x0: torch.Tensor, n_steps: int, dt: float, *,
              n_substeps: int = 4, solver: str = "rk4", u_fine: torch.Tensor | None = None,
              solver_options: dict | None = None) -> torch.Tensor:
    """Integrate ``dv/dt = rhs(v, u)`` and return the states at the output times.

    Parameters
    ----------
    rhs : callable
        ``rhs(v, u) -> dv/dt``; ``u`` is None for autonomous systems.
    x0 : Tensor of shape (batch, *state_shape)
        Initial states at time 0.
    n_steps : int
        Number of outputs, at times ``dt, 2 dt, ..., n_steps dt``.
    dt : float
        Output spacing.
    n_substeps : int
        Steps per output interval of ``"rk4"`` and of torchdiffeq's fixed-grid
        methods (``"euler"``, ``"midpoint"``...; unless ``solver_options``
        sets their ``options``); also fixes the input grid spacing.
    solver : str
        ``"rk4"`` (output-aligned, classic RK4) or a torchdiffeq method.
    u_fine : Tensor of shape (batch, 2 * n_substeps * n_steps + 1, n_inputs), optional
        Inputs on a grid of half the RK4 step (see :func:`upsample_inputs`).
    solver_options : dict, optional
        Extra keyword arguments for :func:`torchdiffeq.odeint` (``rtol``, ``atol``...).

    Returns
    -------
    Tensor of shape (batch, n_steps, *state_shape)
    """
    if solver == "rk4":
        return _rk4(rhs, x0, n_steps, dt, n_substeps, u_fine)
    return _odeint(rhs, x0, n_steps, dt, n_substeps, u_fine, solver, solver_options)
