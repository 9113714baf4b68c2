"""Pendulum trajectories rendered as grey-scale image sequences (the paper's *pendulum images* task)."""

from __future__ import annotations

import numpy as np
from sklearn.utils import Bunch, check_random_state

from ._synthetic import (ParamSpec, check_common, check_float, check_int, draw_param, finish_bunch,
                         pendulum_states, split_samples, output_times)

# Geometry as fractions of the image side: the bob's outer edge stays ~3 px inside the border at any angle.
_ROD_LENGTH = 0.34
_BOB_RADIUS = 0.08
_ROD_HALF_WIDTH = 0.02
_ROD_INTENSITY = 0.5
_EDGE_SOFTNESS = 0.6  # pixels; the width of the smooth edges that make the images anti-aliased
_CHUNK = 512  # frames rendered at once, to bound the temporary (chunk, H, W) arrays


def _soft_inside(signed_distance: np.ndarray) -> np.ndarray:
    """Smooth indicator of ``signed_distance > 0`` (logistic edge of width ``_EDGE_SOFTNESS`` pixels)."""
    return 0.5 * (1.0 + np.tanh(signed_distance / (2 * _EDGE_SOFTNESS)))


def render_pendulum(angles: np.ndarray, image_size: int = 48) -> np.ndarray:
    """Render pendulum angles as anti-aliased grey images in [0, 1].

    The pivot is at the image centre; angle 0 hangs straight down (rows grow downwards) and positive angles swing
    towards larger column indices. The bob is a disc with a smooth edge, the rod a segment of half the bob's
    intensity; every pixel is a smooth function of the angle.

    Parameters
    ----------
    angles : array-like of float
        Pendulum angles in radians, any shape ``S``.
    image_size : int
        Side of the square images in pixels (>= 8).

    Returns
    -------
    images : ndarray of float32, shape ``S + (image_size, image_size)``
    """
    size = check_int("image_size", image_size, 8)
    angles = np.asarray(angles, dtype=float)
    if not np.all(np.isfinite(angles)):
        raise ValueError("angles must be finite.")
    centre = size / 2
    coords = np.arange(size) + 0.5 - centre  # pixel centres relative to the pivot
    rows, cols = coords[:, None], coords[None, :]
    length, radius, half_width = _ROD_LENGTH * size, _BOB_RADIUS * size, _ROD_HALF_WIDTH * size
    flat = angles.reshape(-1)
    out = np.empty((flat.size, size, size), dtype=np.float32)
    for start in range(0, flat.size, _CHUNK):
        a = flat[start:start + _CHUNK, None, None]
        down, right = np.cos(a), np.sin(a)  # unit vector from pivot to bob in (row, col)
        bob = _soft_inside(radius - np.hypot(rows - length * down, cols - length * right))
        along = np.clip(rows * down + cols * right, 0.0, length)  # closest point on the rod
        rod = _ROD_INTENSITY * _soft_inside(half_width - np.hypot(rows - along * down, cols - along * right))
        out[start:start + _CHUNK] = np.maximum(bob, rod)
    return out.reshape(angles.shape + (size, size))


def make_pendulum_images(n_train: int = 200, n_val: int = 200, n_test: int = 200, *, omega: ParamSpec = 2 / 3,
                         gamma: float = 0.5, dt: float = 0.2, n_input_steps: int = 10, n_steps: int = 10,
                         image_size: int = 48, noise: float = 0.0, random_state=None) -> Bunch:
    """Image sequences of a damped pendulum (the paper's *pendulum images* task).

    Trajectories of ``v'' + gamma v' + (2 pi omega)^2 sin v = 0`` are simulated as in
    :func:`~sklearn_hybrid.datasets.make_pendulum` (angle and velocity U(-pi/2, pi/2) at the first input frame)
    and rendered with :func:`render_pendulum`. X holds the frames at times ``-(m_x - 1) dt, ..., 0``, y those at
    ``dt, ..., m_y dt``.

    Parameters
    ----------
    n_train, n_val, n_test : int
        Number of sequence pairs per split (>= 1).
    omega : float or (float, float)
        Frequency parameter (> 0), or a ``(low, high)`` range to draw one value per sample.
    gamma : float
        Damping coefficient (>= 0).
    dt : float
        Time between frames (> 0).
    n_input_steps, n_steps : int
        Input and output sequence lengths m_x and m_y (>= 1).
    image_size : int
        Image side d in pixels (>= 8).
    noise : float
        Standard deviation of Gaussian pixel noise (>= 0); noisy pixels are clipped back to [0, 1].
    random_state : int, RandomState instance or None
        Seed; the same seed gives identical arrays.

    Returns
    -------
    data : Bunch
        ``X_*`` float32 (n, m_x, d, d) and ``y_*`` float32 (n, m_y, d, d); the noise-free true angles
        ``angles_X_*`` (n, m_x) and ``angles_y_*`` (n, m_y); ``t``, ``t_input``, ``dt``; ``theta_true``
        ``{"omega": value or (low, high)}``; ``theta_train/val/test`` ``{"omega": (n,) array}``; ``params``;
        ``DESCR``.
    """
    sizes, dt, n_steps, n_input_steps, noise = check_common(n_train, n_val, n_test, dt, n_steps,
                                                             n_input_steps, noise)
    gamma = check_float("gamma", gamma, 0.0)
    image_size = check_int("image_size", image_size, 8)
    rng = check_random_state(random_state)
    n = sum(sizes)
    omegas, omega_spec = draw_param("omega", omega, n, rng, strict=True)
    angles = pendulum_states(rng, n, omegas, gamma, dt, n_input_steps + n_steps)[..., 0]
    images = render_pendulum(angles, image_size)
    if noise > 0:
        images = np.clip(images + noise * rng.standard_normal(images.shape), 0.0, 1.0).astype(np.float32)
    arrays = {"X": images[:, :n_input_steps], "y": images[:, n_input_steps:],
              "angles_X": angles[:, :n_input_steps], "angles_y": angles[:, n_input_steps:],
              "theta": {"omega": omegas}}
    params = dict(omega=omega_spec, gamma=gamma, dt=dt, n_steps=n_steps, n_input_steps=n_input_steps,
                  image_size=image_size, noise=noise, initial_state_range=(-np.pi / 2, np.pi / 2))
    t, t_input = output_times(dt, n_steps, n_input_steps)
    return finish_bunch(split_samples(arrays, sizes), dt=dt, t=t, t_input=t_input, theta_true={"omega": omega_spec},
                   params=params, title="Damped pendulum rendered as grey images",
                   equation="v'' + gamma v' + (2 pi omega)^2 sin v = 0; pivot at the centre, angle 0 = down")
