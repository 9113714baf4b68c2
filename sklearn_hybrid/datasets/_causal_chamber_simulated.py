"""SIMULATED stand-ins of the Causal Chambers datasets, for offline use (not measured data).

The exact commanded inputs of the publisher's protocol generators (:func:`wind_tunnel_inputs`,
:func:`light_tunnel_inputs`), and outputs of physics richer than the science models A1+C2 and F3:
:func:`make_wind_tunnel_simulated` and :func:`make_light_tunnel_simulated` return what
:func:`~sklearn_hybrid.datasets.fetch_wind_tunnel` and
:func:`~sklearn_hybrid.datasets.fetch_light_tunnel` return, with ``simulated=True``. The constants
are the publisher's, from :mod:`._causal_chamber`.
"""

from __future__ import annotations

import numpy as np
from sklearn.utils import Bunch, check_random_state

from ..models.causal_chamber import (BAROMETER_PRECISION, C3_BETA, C3_R0, C_MAX, C_MIN, FAN_DRAG_K, FAN_INERTIA,
                                     HEX_CENTER_X, HEX_CENTER_Y, HEX_RADIUS, L_MIN, OMEGA_MAX, S_MAX, TORQUE_T,
                                     hexagon_mask, model_f3_colour)
from ._causal_chamber import (CITATION, LIGHT_TUNNEL_DESCR, WIND_TUNNEL_DESCR, WT_SAMPLE_PERIOD, check_window,
                              light_tunnel_bunch, wind_tunnel_bunch)
from ._synthetic import check_float, check_int

__all__ = ["light_tunnel_inputs", "make_light_tunnel_simulated", "make_wind_tunnel_simulated", "wind_tunnel_inputs"]

_SIM_WT = ("SIMULATED, NOT MEASURED. Exact commanded inputs of the publisher's generator "
           "loads_hatch_mix.py; outputs from fan dynamics A2 (I dw/dt = tau(L) - K w^2, held "
           "inputs, {dt} s per step), hatch model C3 (r(H) = min(1, 0.75 + 0.15 H/45)), a drifting "
           "ambient pressure and N(0, 0.2 Pa) barometer noise.")
_SIM_LT = ("SIMULATED, NOT MEASURED. Exact commanded inputs of the publisher's generator "
           "random_actuators.py (seed 0); images from model F3 rendered into the hexagon, plus "
           "effects F3 lacks: Gaussian blur (spill) of the hexagon, radial vignetting, a gamma "
           "tone curve (1/2.2) and N(0, 0.01) pixel noise.")


def wind_tunnel_inputs(n_steps: int = 10000, speed: str = "fast") -> dict[str, np.ndarray]:
    """Commanded load_in, load_out, hatch of the publisher's generator ``loads_hatch_mix.py``.

    Values are rounded as the generator writes them into the protocol (4 and 2 decimals).
    """
    if speed not in ("fast", "slow"):
        raise ValueError(f"speed must be 'fast' or 'slow', got {speed!r}.")
    t = np.linspace(0.1, 32 if speed == "fast" else 8, n_steps)
    hatch = np.sign(np.sin(t / 8 * np.pi * 2))
    hatch[hatch == 0] = 1
    return {"load_in": np.round(np.maximum((np.sin(2 * t) + 1) / 2, 0.01), 4),
            "load_out": np.round(np.maximum((np.sign(np.sin(3 * t)) + 1) / 2, 0.01), 4),
            "hatch": np.round((1 - hatch) / 2 * 45, 2)}


def _fan_speed(load: np.ndarray, dt: float) -> np.ndarray:
    """Model A2 with the load held over each step, solved exactly (w' = b (w_inf^2 - w^2))."""
    tau = TORQUE_T * np.maximum(load, L_MIN) ** 3 * (C_MAX - C_MIN)
    tau[load == 0] = 0.0
    w_inf, b = np.sqrt(tau / FAN_DRAG_K), FAN_DRAG_K / FAN_INERTIA
    th = np.tanh(b * w_inf * dt)
    omega, w = np.empty_like(load), 0.0  # the protocol starts with the fans off
    for i in range(load.size):
        if w_inf[i] > 0:
            w = w_inf[i] * (w + w_inf[i] * th[i]) / (w_inf[i] + w * th[i])
        else:  # no torque: w' = -b w^2
            w = w / (1 + b * w * dt)
        omega[i] = w
    return omega


def make_wind_tunnel_simulated(
    n_runs: int = 5,
    n_steps: int = 10000,
    window: int = 200,
    stride: int = 50,
    dt: float = WT_SAMPLE_PERIOD,
    ambient_pressure: float = 96500.0,
    random_state=None,
) -> Bunch:
    """SIMULATED stand-in of :func:`fetch_wind_tunnel` (not measured data).

    Parameters
    ----------
    n_runs : int, default=5
        Number of runs (repetitions of the protocol with fresh noise).
    n_steps : int, default=10000
        Steps per run.
    window, stride : int, default=200, 50
        Window length and step, in samples.
    dt : float, default=0.1
        Seconds per protocol step (approximate for the real chamber).
    ambient_pressure : float, default=96500.0
        Mean ambient pressure in Pa (a placeholder level; only differences matter).
    random_state : int, RandomState instance or None, default=None
        Seeds the noise and the ambient drift.

    Returns
    -------
    data : Bunch
        Same fields as :func:`fetch_wind_tunnel`, ``simulated=True``.
    """
    check_window(window, stride)
    n_runs, n_steps = check_int("n_runs", n_runs, 1), check_int("n_steps", n_steps, window)
    dt = check_float("dt", dt, 0.0, strict=True)
    ambient_pressure = check_float("ambient_pressure", ambient_pressure)
    rng = check_random_state(random_state)
    u = wind_tunnel_inputs(n_steps)
    w_in, w_out = _fan_speed(u["load_in"], dt), _fan_speed(u["load_out"], dt)
    r = np.minimum(1.0, C3_R0 + C3_BETA * u["hatch"] / 45)
    dp = S_MAX * (1 - r) * ((w_in / OMEGA_MAX) ** 2 - (w_out / OMEGA_MAX) ** 2)
    runs = []
    for _ in range(n_runs):
        amb = ambient_pressure + np.cumsum(rng.normal(0.0, 0.01, n_steps))  # slow drift
        runs.append({**u, "pressure_ambient": amb + rng.normal(0, BAROMETER_PRECISION, n_steps),
                     "pressure_downwind": amb + dp + rng.normal(0, BAROMETER_PRECISION, n_steps)})
    origin = _SIM_WT.format(dt=dt)
    return wind_tunnel_bunch(runs, window, stride, WIND_TUNNEL_DESCR.format(kind="SIMULATED", origin=origin,
                                                            cite=CITATION), simulated=True)


def light_tunnel_inputs(n_samples: int = 10000) -> np.ndarray:
    """Commanded R, G, B, pol_1, pol_2 of the publisher's ``random_actuators.py`` (seed 0)."""
    rng = np.random.default_rng(0)
    pol = np.arange(-180, 180, 0.1)
    X = np.empty((n_samples, 5))
    for i in range(n_samples):  # same call order as the generator
        X[i, :3] = [rng.integers(0, 255) for _ in range(3)]
        X[i, 3:] = np.round([rng.choice(pol), rng.choice(pol)], 1)
    return X


def make_light_tunnel_simulated(
    n_samples: int = 10000, image_size: int = 100, random_state=None
) -> Bunch:
    """SIMULATED stand-in of :func:`fetch_light_tunnel` (not measured data).

    Parameters
    ----------
    n_samples : int, default=10000
        Number of images (the commanded inputs are the first ``n_samples`` of the protocol).
    image_size : int, default=100
        Image height and width in pixels.
    random_state : int, RandomState instance or None, default=None
        Seeds the pixel noise.

    Returns
    -------
    data : Bunch
        Same fields as :func:`fetch_light_tunnel`, ``simulated=True``.
    """
    from scipy.ndimage import gaussian_filter

    n_samples, image_size = check_int("n_samples", n_samples, 1), check_int("image_size", image_size, 1)
    rng = check_random_state(random_state)
    X = light_tunnel_inputs(n_samples)
    colour = model_f3_colour(X).astype(np.float32)
    # Effects F3 lacks: blurred edges/spill, vignetting (30 % darker at the hexagon's corners).
    yy, xx = np.mgrid[:image_size, :image_size] / image_size
    d2 = ((xx - HEX_CENTER_X) ** 2 + (yy - HEX_CENTER_Y) ** 2) / HEX_RADIUS**2
    profile = gaussian_filter(hexagon_mask(image_size).astype(float), 0.015 * image_size)
    profile = (profile * (1 - 0.3 * np.minimum(d2, 1.0))).astype(np.float32)
    images = np.empty((n_samples, 3, image_size, image_size), dtype=np.float32)
    for a in range(0, n_samples, 500):  # chunks bound the temporaries
        lin = colour[a:a + 500, :, None, None] * profile
        noisy = lin ** (1 / 2.2) + rng.normal(0, 0.01, lin.shape).astype(np.float32)
        images[a:a + 500] = np.clip(noisy, 0, 1)
    descr = LIGHT_TUNNEL_DESCR.format(kind="SIMULATED", origin=_SIM_LT, cite=CITATION)
    return light_tunnel_bunch(X, images, descr, simulated=True)
