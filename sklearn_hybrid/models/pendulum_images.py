"""The pendulum-images model: a hybrid neural ODE between image encoders and a decoder.

This is the example of a *nested* composition, written as a callable
structure ``structure(x, f, g) -> y``: the estimator hands over the images
``x``, the science function ``f`` with theta bound (here
:func:`~sklearn_hybrid.models.pendulum_f`, theta = omega) and the network
``g`` built by a factory called with no arguments.  ``g`` may hold any
number of sub-networks; the structure decides how they and ``f`` are wired::

    v0     = g.state_encoder(x)                  # initial [angle, velocity]
    latent = g.latent_encoder(x)                 # appearance code
    v(t)   = ODESolve(dv/dt = f(v) + g.ode(v), v(0) = v0)
    y_k    = g.decoder([angle(t_k), latent])     # one image per output time

Usage::

    from functools import partial
    from sklearn_hybrid import HybridRegressor
    from sklearn_hybrid.models import PendulumImagesNet, PendulumImagesStructure, pendulum_f

    est = HybridRegressor(
        science=pendulum_f,
        structure=PendulumImagesStructure(dt=0.2, n_steps=10),
        residual=partial(PendulumImagesNet, n_input_frames=10, image_size=48),
        method="fsam", batch_size=50)
"""

from __future__ import annotations

from typing import Sequence

import numpy as np
import torch
from torch import nn

from ..integrate import integrate
from ..residual import MLP
from .networks import FrameDecoder, ImageEncoder

__all__ = ["PendulumImagesNet", "PendulumImagesStructure", "latent_trajectories"]


class PendulumImagesNet(nn.Module):
    """All neural parts of the pendulum-images model in one module.

    Parameters
    ----------
    n_input_frames : int, default=10
        Input frames m_x.
    image_size : int, default=48
        Frame height and width d.
    latent_dim : int, default=8
        Length of the appearance code of the second encoder.
    encoder_channels : sequence of int, default=(32, 64, 64)
        Channels of both encoders' stride-2 convolutions.
    encoder_hidden : int, default=256
        Width of the encoders' fully connected layer.
    ode_hidden : sequence of int, default=(128, 128)
        Hidden widths of the ODE's residual MLP (the pendulum task's network).
    fc_hidden, conv_channels : sequence of int
        Decoder sizes; the defaults (1152, 1152) and (576, 288) are the
        paper's.  On a CPU use far smaller ones, e.g. (256, 256) and (32, 16).
    """

    def __init__(self, n_input_frames: int = 10, image_size: int = 48, latent_dim: int = 8,
                 encoder_channels: Sequence[int] = (32, 64, 64), encoder_hidden: int = 256,
                 ode_hidden: Sequence[int] = (128, 128),
                 fc_hidden: Sequence[int] = (1152, 1152),
                 conv_channels: Sequence[int] = (576, 288)):
        super().__init__()
        self.n_input_frames, self.image_size = int(n_input_frames), int(image_size)
        self.state_encoder = ImageEncoder(n_input_frames, image_size, 2, encoder_channels,
                                          encoder_hidden)
        self.latent_encoder = ImageEncoder(n_input_frames, image_size, latent_dim,
                                           encoder_channels, encoder_hidden)
        self.ode = MLP(((2,),), (2,), hidden=ode_hidden)
        self.decoder = FrameDecoder(1 + latent_dim, image_size, fc_hidden, conv_channels)

    def check_input(self, x: torch.Tensor) -> None:
        """Raise a clear error if ``x`` is not ``(batch, n_input_frames, d, d)``."""
        expected = (self.n_input_frames, self.image_size, self.image_size)
        if x.ndim != 4 or tuple(x.shape[1:]) != expected:
            raise ValueError(f"PendulumImagesNet expects X of shape (n, {expected[0]}, "
                             f"{expected[1]}, {expected[2]}), got {tuple(x.shape)}.")

    def decode(self, angles: torch.Tensor, latent: torch.Tensor) -> torch.Tensor:
        """Images ``(batch, T, d, d)`` from angles ``(batch, T)`` and codes ``(batch, k)``."""
        batch, steps = angles.shape
        codes = torch.cat([angles[..., None], latent[:, None].expand(-1, steps, -1)], dim=-1)
        return self.decoder(codes.reshape(batch * steps, -1)).reshape(
            batch, steps, self.image_size, self.image_size)


class PendulumImagesStructure:
    """Callable structure ``(x, f, g) -> y`` of the pendulum-images model.

    Parameters
    ----------
    dt : float, default=0.2
        Time between frames.
    n_steps : int, default=10
        Output frames m_y.
    n_substeps : int, default=2
        RK4 steps per frame interval.
    """

    def __init__(self, dt: float = 0.2, n_steps: int = 10, n_substeps: int = 2):
        if not (isinstance(dt, (int, float)) and dt > 0):
            raise ValueError(f"dt must be a positive number, got {dt!r}.")
        for name, value in (("n_steps", n_steps), ("n_substeps", n_substeps)):
            if isinstance(value, bool) or not isinstance(value, int) or value < 1:
                raise ValueError(f"{name} must be a positive integer, got {value!r}.")
        self.dt, self.n_steps, self.n_substeps = float(dt), n_steps, n_substeps

    def states(self, x: torch.Tensor, f, g: PendulumImagesNet) -> tuple[torch.Tensor, torch.Tensor]:
        """Latent pendulum states ``(batch, n_steps, 2)`` and appearance codes ``(batch, k)``."""
        if not isinstance(g, PendulumImagesNet):
            raise TypeError("PendulumImagesStructure needs residual=partial(PendulumImagesNet, ...), "
                            f"got a network of type {type(g).__name__}.")
        g.check_input(x)
        v0, latent = g.state_encoder(x), g.latent_encoder(x)
        states = integrate(lambda v, u: f(v) + g.ode(v), v0, self.n_steps, self.dt,
                           n_substeps=self.n_substeps)
        return states, latent

    def __call__(self, x: torch.Tensor, f, g: PendulumImagesNet) -> torch.Tensor:
        states, latent = self.states(x, f, g)
        return g.decode(states[..., 0], latent)

    def __repr__(self) -> str:
        return (f"PendulumImagesStructure(dt={self.dt}, n_steps={self.n_steps}, "
                f"n_substeps={self.n_substeps})")


def latent_trajectories(estimator, X) -> np.ndarray:
    """Latent ``[angle, velocity]`` at the output times of a fitted pendulum-images estimator.

    Parameters
    ----------
    estimator : HybridRegressor
        Fitted with a :class:`PendulumImagesStructure`.
    X : array-like of shape (n, m_x, d, d)
        Input frames.

    Returns
    -------
    ndarray of shape (n, n_steps, 2)
        The encoder's angles are defined only up to the symmetries of the
        images (for instance a shift or a flip); their frequency is omega.
    """
    model = estimator.model_
    structure = getattr(model.structure, "func", None)
    if not isinstance(structure, PendulumImagesStructure):
        raise TypeError("latent_trajectories needs an estimator fitted with PendulumImagesStructure.")
    first = next(model.parameters())
    with torch.no_grad():
        x = torch.as_tensor(np.asarray(X), dtype=first.dtype, device=first.device)
        states, _ = structure.states(x, model.science, model.residual)
    return states.cpu().numpy().astype(float)
