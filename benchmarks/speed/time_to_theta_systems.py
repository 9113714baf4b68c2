"""Three small systems for ``bench_time_to_theta.py``, written for it and kept out of the tests.

Each has two states, a science model that leaves one effect out (which the network must learn)
and two parameters to estimate, started 25-35 % off.  The data are simulated with a fine RK4
(64 steps per output interval) from random initial states, with Gaussian noise of 1 % of the
states' spread on the outputs.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np
import torch

from helpers import rk4_trajectories


def prey_predator_f(v, a=0.8, b=0.3):
    """Lotka-Volterra without the prey's crowding: prey x grows at a, is eaten at b x y."""
    x, y = v[:, 0], v[:, 1]
    return torch.stack([a * x - b * x * y, 0.4 * b * x * y - 0.6 * y], dim=-1)


def prey_predator_true(v):
    x, y = v[:, 0], v[:, 1]
    a, b = 1.1, 0.45
    return np.stack([a * x - b * x * y - 0.15 * x ** 2, 0.4 * b * x * y - 0.6 * y], axis=-1)


def circuit_f(v, w2=3.0, r=0.2):
    """A series RLC circuit: charge q, current i; the resistor's cubic (saturating diode) loss is missing."""
    q, i = v[:, 0], v[:, 1]
    return torch.stack([i, -w2 * q - r * i], dim=-1)


def circuit_true(v):
    q, i = v[:, 0], v[:, 1]
    return np.stack([i, -4.0 * q - 0.3 * i - 0.5 * i ** 3], axis=-1)


def reactor_f(v, k1=0.5, k2=0.2):
    """A -> B -> products in a fed tank (feed 1.0 of A); A's second-order side reaction is missing."""
    a, b = v[:, 0], v[:, 1]
    return torch.stack([1.0 - k1 * a, k1 * a - k2 * b], dim=-1)


def reactor_true(v):
    a, b = v[:, 0], v[:, 1]
    return np.stack([1.0 - 0.7 * a - 0.25 * a ** 2, 0.7 * a - 0.3 * b], axis=-1)


@dataclass
class System:
    name: str
    field: str
    science: Callable
    true_rhs: Callable
    theta_true: dict
    n_samples: int
    n_steps: int
    dt: float
    low: tuple
    high: tuple


SYSTEMS = {
    "prey_predator": System("prey_predator", "population dynamics", prey_predator_f, prey_predator_true,
                            {"a": 1.1, "b": 0.45}, 50, 20, 0.25, (1.0, 0.5), (4.0, 2.5)),
    "circuit": System("circuit", "electronics", circuit_f, circuit_true, {"w2": 4.0, "r": 0.3},
                      30, 20, 0.15, (-1.0, -1.0), (1.0, 1.0)),
    "reactor": System("reactor", "chemistry", reactor_f, reactor_true, {"k1": 0.7, "k2": 0.3},
                      40, 15, 0.3, (0.0, 0.0), (2.0, 2.0)),
}


def simulate(system: System, seed: int, noise: float = 0.01):
    """Initial states ``X`` (n, 2) and noisy trajectories ``y`` (n, n_steps, 2)."""
    rng = np.random.default_rng(seed)
    X = rng.uniform(system.low, system.high, size=(system.n_samples, 2))
    y = rk4_trajectories(system.true_rhs, X, system.dt, system.n_steps)
    y = y + noise * y.reshape(-1, 2).std(0) * rng.standard_normal(y.shape)
    return X.astype(np.float32), y.astype(np.float32)
