"""The incomplete science models f_theta of the paper's six tasks.

Every function is written with torch operations on batch-first tensors; its
arguments with a numeric default are the parameters theta that
:class:`~sklearn_hybrid.HybridRegressor` estimates.  The defaults are
plausible starting values, deliberately *not* the values that generated the
data (or the published reference values), so a fit has something to find.

==========================  ===================================  ==================
function                    task (structure)                      theta
==========================  ===================================  ==================
:func:`pendulum_f`          pendulum time series, images (ode)   omega
:func:`duffing_f`           Duffing oscillator (ode)              alpha
:func:`diffusion_f`         reaction-diffusion (ode)              a, b
:func:`wind_tunnel_f`       wind tunnel, A1 + C2 (compose)        r in (0, 1)
:func:`light_tunnel_f`      light tunnel, F3 + hexagon (compose)  w, t_p, t_c (3 each)
==========================  ===================================  ==================
"""

from __future__ import annotations

import math
from functools import lru_cache
from typing import Callable

import numpy as np
import torch

from .causal_chamber import EXPOSURE_F3, L_MIN, S_CAMERA, S_MAX, hexagon_mask

__all__ = ["pendulum_f", "duffing_f", "diffusion_f", "laplacian", "wind_tunnel_f",
           "fan_speed_ratio", "light_tunnel_f", "make_light_tunnel_f", "light_tunnel_colour",
           "THETA_BOUNDS"]

_DOMAIN_LENGTH = 2.0  # the reaction-diffusion domain [-1, 1]^2

#: Bounds that keep each parameter physical; pass them as ``theta_bounds``.  Only r needs
#: one: a one-sided bound is a softplus, whose small slope near small values (a, b ~ 1e-3)
#: would slow their training down by orders of magnitude.
THETA_BOUNDS = {
    "pendulum_f": {},
    "duffing_f": {},
    "diffusion_f": {},
    "wind_tunnel_f": {"r": (0.0, 1.0)},
    "light_tunnel_f": {},
}


# ------------------------------------------------------------------------------ ODE tasks
def pendulum_f(v: torch.Tensor, omega=0.5) -> torch.Tensor:
    """Undamped pendulum, the known part of ``v'' + gamma v' + (2 pi omega)^2 sin v = 0``.

    Parameters
    ----------
    v : Tensor of shape (batch, 2)
        State ``[angle, angular velocity]``.
    omega : float, default=0.5
        Frequency parameter (the data of :func:`~sklearn_hybrid.datasets.make_pendulum`
        use 2/3).

    Returns
    -------
    Tensor of shape (batch, 2)
        ``[v', -(2 pi omega)^2 sin v]``; the damping is left to the network.
    """
    return torch.stack([v[:, 1], -(2 * math.pi * omega) ** 2 * torch.sin(v[:, 0])], dim=-1)


def duffing_f(v: torch.Tensor, alpha=0.5) -> torch.Tensor:
    """Linear oscillator, the known part of ``v'' + alpha v - beta v^3 = 0``.

    Parameters
    ----------
    v : Tensor of shape (batch, 2)
        State ``[position, velocity]``.
    alpha : float, default=0.5
        Linear stiffness (the data of :func:`~sklearn_hybrid.datasets.make_duffing` use 1).

    Returns
    -------
    Tensor of shape (batch, 2)
        ``[v', -alpha v]``; the cubic term is left to the network.
    """
    return torch.stack([v[:, 1], -alpha * v[:, 0]], dim=-1)


def laplacian(fields: torch.Tensor, dx: float, boundary: str = "periodic") -> torch.Tensor:
    """Five-point Laplacian over the last two axes.

    Parameters
    ----------
    fields : Tensor of shape (..., H, W)
        Fields on a square grid of spacing ``dx``.
    dx : float
        Grid spacing.
    boundary : {"periodic", "neumann"}, default="periodic"
        Wrap-around, or zero flux by repeating the edge values (the convention of
        :func:`~sklearn_hybrid.datasets.make_reaction_diffusion`).

    Returns
    -------
    Tensor of the shape of ``fields``
    """
    if boundary == "periodic":
        neighbours = (torch.roll(fields, 1, -1) + torch.roll(fields, -1, -1)
                      + torch.roll(fields, 1, -2) + torch.roll(fields, -1, -2))
    elif boundary == "neumann":
        padded = torch.cat([fields[..., :1, :], fields, fields[..., -1:, :]], dim=-2)
        padded = torch.cat([padded[..., :1], padded, padded[..., -1:]], dim=-1)
        neighbours = (padded[..., 2:, 1:-1] + padded[..., :-2, 1:-1]
                      + padded[..., 1:-1, 2:] + padded[..., 1:-1, :-2])
    else:
        raise ValueError(f"boundary must be 'periodic' or 'neumann', got {boundary!r}.")
    return (neighbours - 4 * fields) / dx**2


def diffusion_f(state: torch.Tensor, a=0.01, b=0.01, boundary="periodic") -> torch.Tensor:
    """Diffusion-only part of the FitzHugh-Nagumo reaction-diffusion system.

    Parameters
    ----------
    state : Tensor of shape (batch, 2, G, G)
        Fields ``[u, v]`` on a ``G x G`` grid covering ``[-1, 1]^2`` (spacing
        ``2 / G``, as in the generator).
    a, b : float, default=0.01
        Diffusion coefficients of u and v (the data use 1e-3 and 5e-3).
    boundary : {"periodic", "neumann"}, default="periodic"
        Must match the data (the generator's default is periodic); not a
        parameter (non-numeric), change it with ``functools.partial``.

    Returns
    -------
    Tensor of shape (batch, 2, G, G)
        ``[a lap(u), b lap(v)]``; the reaction terms are left to the network.
    """
    dx = _DOMAIN_LENGTH / state.shape[-1]
    lap = laplacian(state, dx, boundary)
    return torch.stack([a * lap[:, 0], b * lap[:, 1]], dim=1)


# ------------------------------------------------------------------------------ wind tunnel
def fan_speed_ratio(load: torch.Tensor) -> torch.Tensor:
    """Model A1 as a fraction of the top speed: ``max(L, L_min)`` for ``L > 0``, else 0."""
    return torch.where(load > 0, torch.clamp(load, min=L_MIN), torch.zeros_like(load))


def wind_tunnel_f(x: torch.Tensor, r=0.5) -> torch.Tensor:
    """Chamber pressure from the fan loads, models A1 + C2 of the Causal Chambers.

    C2 with A1 has the closed form ``S_max (1 - r) (l(L_in)^2 - l(L_out)^2)``
    above the ambient pressure, ``l(L) = max(L, L_min) 1[L > 0]`` (see
    ``shared/reference/causal_chamber.md``); the hatch (model C3) and the fan
    dynamics (model A2) are missing on purpose.

    Parameters
    ----------
    x : Tensor of shape (batch, m, 3)
        Windows of ``load_in``, ``load_out`` (in [0, 1]) and ``hatch`` (unused).
    r : float, default=0.5
        Ratio of the fans' maximum airflow that the chamber lets through; keep it
        in (0, 1) with ``theta_bounds={"r": (0, 1)}``.  The hybrid paper's
        reference value is 0.7, the publisher's code uses 0.75.

    Returns
    -------
    Tensor of shape (batch, m)
        Pressure difference to the ambient pressure, in Pa.
    """
    return S_MAX * (1 - r) * (fan_speed_ratio(x[..., 0]) ** 2 - fan_speed_ratio(x[..., 1]) ** 2)


# ------------------------------------------------------------------------------ light tunnel
@lru_cache(maxsize=8)
def _hexagon(image_size: int) -> torch.Tensor:
    return torch.as_tensor(hexagon_mask(image_size), dtype=torch.float64)


def light_tunnel_colour(x: torch.Tensor, w, t_p, t_c, exposure: float = EXPOSURE_F3) -> torch.Tensor:
    """Colour of model F3 for raw actuator settings.

    ``c = min(1, e diag(w) S x_rgb / 255 * ((t_p - t_c) cos^2(a1 - a2) + t_c))``, the
    transmission multiplying each camera channel as in the publisher's code
    (the hybrid paper's equation writes it before S).

    Parameters
    ----------
    x : Tensor of shape (batch, 5)
        ``red, green, blue`` (LED levels 0..255) and ``pol_1, pol_2`` (degrees).
    w, t_p, t_c : Tensor or sequence of shape (3,)
        White-balance gains and transmissions with the polarisers parallel / crossed.
    exposure : float, default=2.5
        Exposure e of F3 (fixed, as in the paper).

    Returns
    -------
    Tensor of shape (batch, 3)
    """
    S = torch.as_tensor(S_CAMERA, dtype=x.dtype, device=x.device)
    w, t_p, t_c = (torch.as_tensor(p, dtype=x.dtype, device=x.device) for p in (w, t_p, t_c))
    malus = torch.cos(torch.deg2rad(x[:, 3] - x[:, 4])) ** 2
    transmission = (t_p - t_c) * malus[:, None] + t_c
    camera = (x[:, :3] / 255.0) @ S.T  # LED colours seen by the camera channels
    colour = exposure * w * camera * transmission
    return torch.clamp(colour, max=1.0)


class _LightTunnelF:
    """F3 in the hexagon for one image size; a class so that fitted estimators pickle."""

    def __init__(self, image_size: int, exposure: float):
        self.image_size, self.exposure = image_size, exposure
        self.__name__ = "light_tunnel_f"
        self.__doc__ = (f"Model F3 rendered into the hexagon of {image_size}-pixel images "
                        "(see make_light_tunnel_f).")

    def __call__(self, x: torch.Tensor, w=(1.0, 1.0, 1.0), t_p=(0.5, 0.5, 0.5),
                 t_c=(0.1, 0.1, 0.1)) -> torch.Tensor:
        colour = light_tunnel_colour(x, w, t_p, t_c, self.exposure)
        mask = _hexagon(self.image_size).to(dtype=x.dtype, device=x.device)
        return colour[:, :, None, None] * mask

    def __repr__(self) -> str:
        return f"make_light_tunnel_f(image_size={self.image_size}, exposure={self.exposure})"


def make_light_tunnel_f(image_size: int = 100, exposure: float = EXPOSURE_F3) -> Callable:
    """Model F3 rendered into the light-source hexagon, for images of a given size.

    Parameters
    ----------
    image_size : int, default=100
        Height and width of the images (100 for ``lt_camera_v1``).
    exposure : float, default=2.5
        Fixed exposure e of F3.

    Returns
    -------
    callable
        ``f(x, w=[1, 1, 1], t_p=[0.5, 0.5, 0.5], t_c=[0.1, 0.1, 0.1])`` mapping
        raw settings ``(batch, 5)`` to images ``(batch, 3, image_size,
        image_size)``: the colour of :func:`light_tunnel_colour` inside the
        hexagon, 0 outside.  Its nine parameters are known only up to scale;
        compare them with ``theta_error(..., metric="cosine")``.
    """
    if isinstance(image_size, bool) or not isinstance(image_size, (int, np.integer)) or image_size < 8:
        raise ValueError(f"image_size must be an integer >= 8, got {image_size!r}.")
    return _LightTunnelF(int(image_size), float(exposure))


light_tunnel_f = make_light_tunnel_f(100)
