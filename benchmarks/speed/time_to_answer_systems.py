"""Seven small systems for ``bench_time_to_answer.py``, written for it and kept out of the tests.

Different fields, one to four states, 24 to 40 trajectories; six science models leave out one effect
of a different kind (a second-order reaction, quadratic drag, prey crowding, saturable elimination,
dry friction, a damper on one mass of a chain) and one is complete.  The science's parameters start
at the function's defaults, 20-40 % from the truth.  The data are simulated with a fine RK4 (64 steps
per output interval) from random initial states, with Gaussian noise of 1 % of each state's spread
on the outputs; the models are compared in function space on the states of 20 noise-free test
trajectories from other initial states; :func:`interval_verdicts` reads an interval's verdict against the truth
(shared by the benchmarks that run these systems).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable

import numpy as np
import torch

from helpers import rk4_trajectories


# ------------------------------------------------------------------------------------------------ chemistry, 1 state
def decay_f(v, k1=0.3):
    """A reactant decaying at first order; its second-order (dimerisation) loss is missing."""
    return -k1 * v


def decay_true(v):
    return -0.5 * v - 0.4 * v ** 2


# ------------------------------------------------------------------------------------------------ mechanics, 2 states
def drag_mass_f(v, k=2.5):
    """A mass on a spring (position x, velocity x_dot); the air's quadratic drag is missing."""
    return torch.stack([v[:, 1], -k * v[:, 0]], dim=-1)


def drag_mass_true(v):
    return np.stack([v[:, 1], -3.2 * v[:, 0] - 0.6 * v[:, 1] * np.abs(v[:, 1])], axis=-1)


# ------------------------------------------------------------------------------------------------ ecology, 2 states
def plankton_f(v, a=0.8, b=0.5, d=0.2, m=0.4):
    """Phytoplankton p grazed by zooplankton z (Lotka-Volterra); the phytoplankton's crowding is missing."""
    p, z = v[:, 0], v[:, 1]
    return torch.stack([a * p - b * p * z, d * p * z - m * z], dim=-1)


def plankton_true(v):
    p, z = v[:, 0], v[:, 1]
    return np.stack([1.2 * p - 0.6 * p * z - 0.25 * p ** 2, 0.3 * p * z - 0.5 * z], axis=-1)


# ------------------------------------------------------------------------------------------------ pharmacology, 2 states
def drug_f(v, ka=0.8, ke=0.1):
    """An oral dose: gut amount g absorbed at ka into the blood c, eliminated at ke; the liver's
    saturable (Michaelis-Menten) elimination is missing."""
    g, c = v[:, 0], v[:, 1]
    return torch.stack([-ka * g, ka * g - ke * c], dim=-1)


def drug_true(v):
    g, c = v[:, 0], v[:, 1]
    return np.stack([-1.2 * g, 1.2 * g - 0.15 * c - 0.8 * c / (0.5 + c)], axis=-1)


# ------------------------------------------------------------------------------------------------ mechatronics, 2 states
def stage_f(v, k=1.5, c=0.1):
    """A linear stage on a spring with viscous damping; the guide's dry (Coulomb) friction is missing."""
    return torch.stack([v[:, 1], -k * v[:, 0] - c * v[:, 1]], dim=-1)


def stage_true(v):
    return np.stack([v[:, 1], -2.0 * v[:, 0] - 0.15 * v[:, 1] - 0.3 * np.tanh(v[:, 1] / 0.02)], axis=-1)


# ------------------------------------------------------------------------------------------------ epidemiology, 3 states
def sir_f(v, beta=0.9, gamma=0.15):
    """An epidemic in shares of a population (susceptible, infected, recovered): complete."""
    s, i = v[:, 0], v[:, 1]
    return torch.stack([-beta * s * i, beta * s * i - gamma * i, gamma * i], dim=-1)


def sir_true(v):
    s, i = v[:, 0], v[:, 1]
    return np.stack([-1.3 * s * i, 1.3 * s * i - 0.25 * i, 0.25 * i], axis=-1)


# ------------------------------------------------------------------------------------------------ structures, 4 states
def chain_f(v, k1=1.5, k2=0.6):
    """Two masses in a chain (wall - k1 - mass 1 - k2 - mass 2); the damper on mass 2 is missing."""
    x1, v1, x2, v2 = v[:, 0], v[:, 1], v[:, 2], v[:, 3]
    return torch.stack([v1, -k1 * x1 + k2 * (x2 - x1), v2, -k2 * (x2 - x1)], dim=-1)


def chain_true(v):
    x1, v1, x2, v2 = v[:, 0], v[:, 1], v[:, 2], v[:, 3]
    return np.stack([v1, -2.0 * x1 + 0.8 * (x2 - x1), v2, -0.8 * (x2 - x1) - 0.4 * v2], axis=-1)


@dataclass
class System:
    name: str
    field: str
    science: Callable
    true_rhs: Callable
    theta_true: dict
    state_names: list
    n_samples: int
    n_steps: int
    dt: float
    low: tuple
    high: tuple
    missing: str  # the effect the science leaves out, in words ("" when complete)
    units: dict = field(default_factory=dict)

    @property
    def complete(self) -> bool:
        return not self.missing

    def missing_rhs(self, x: np.ndarray) -> np.ndarray:
        """What the science at the true theta lacks at states ``x``."""
        return self.true_rhs(x) - call_science(self.science, x, self.theta_true)


SYSTEMS = {s.name: s for s in [
    System("decay", "chemistry", decay_f, decay_true, {"k1": 0.5}, ["c"], 24, 20, 0.25, (0.2,), (2.0,),
           "second-order loss -0.4 c^2"),
    System("drag_mass", "mechanics", drag_mass_f, drag_mass_true, {"k": 3.2}, ["x", "x_dot"], 30, 25, 0.15,
           (-1.5, -1.5), (1.5, 1.5), "quadratic drag -0.6 x_dot |x_dot|"),
    System("plankton", "ecology", plankton_f, plankton_true, {"a": 1.2, "b": 0.6, "d": 0.3, "m": 0.5},
           ["p", "z"], 40, 20, 0.3, (0.5, 0.3), (3.0, 2.0), "crowding -0.25 p^2"),
    System("drug", "pharmacology", drug_f, drug_true, {"ka": 1.2, "ke": 0.15}, ["g", "c"], 30, 20, 0.3,
           (0.0, 0.0), (3.0, 2.0), "saturable elimination -0.8 c / (0.5 + c)"),
    System("stage", "mechatronics", stage_f, stage_true, {"k": 2.0, "c": 0.15}, ["x", "x_dot"], 30, 25, 0.15,
           (-1.0, -1.0), (1.0, 1.0), "dry friction -0.3 tanh(x_dot / 0.02)"),
    System("sir", "epidemiology", sir_f, sir_true, {"beta": 1.3, "gamma": 0.25}, ["s", "i", "r"], 30, 20, 0.5,
           (0.5, 0.02, 0.0), (0.98, 0.3, 0.2), ""),
    System("chain", "structures", chain_f, chain_true, {"k1": 2.0, "k2": 0.8}, ["x1", "v1", "x2", "v2"], 30, 25,
           0.2, (-1.0, -1.0, -1.0, -1.0), (1.0, 1.0, 1.0, 1.0), "damper on mass 2, -0.4 v2"),
]}


def call_science(f: Callable, x: np.ndarray, theta: dict) -> np.ndarray:
    """A science function in float64 at numpy states ``x`` (n, n_states); returns (n, n_states)."""
    kw = {k: torch.as_tensor(np.asarray(v, dtype=float), dtype=torch.float64) for k, v in theta.items()}
    with torch.no_grad():
        out = f(torch.as_tensor(np.asarray(x, dtype=float), dtype=torch.float64), **kw).numpy()
    return out.reshape(len(x), -1)


def simulate(system: System, seed: int, noise: float = 0.01, n_samples: int | None = None):
    """Initial states ``X`` (n, s) and noisy trajectories ``y`` (n, n_steps, s), float32."""
    rng = np.random.default_rng(seed)
    n = system.n_samples if n_samples is None else n_samples
    X = rng.uniform(system.low, system.high, size=(n, len(system.low)))
    y = rk4_trajectories(system.true_rhs, X, system.dt, system.n_steps)
    spread = y.reshape(-1, y.shape[-1]).std(0)
    y = y + noise * spread * rng.standard_normal(y.shape)
    return X.astype(np.float32), y.astype(np.float32)


def test_states(system: System, seed: int) -> np.ndarray:
    """States where the models are compared in function space: 20 noise-free test trajectories."""
    X, y = simulate(system, seed + 1000, noise=0.0, n_samples=20)
    return np.concatenate([X, y.reshape(-1, y.shape[-1])]).astype(float)


def interval_verdicts(intervals, truth: dict) -> dict:
    """Each parameter's verdict and interval from a ``science_intervals`` result, and whether it holds."""
    out = {}
    for k, v in truth.items():
        if k not in getattr(intervals, "verdicts", {}):
            continue
        low, high = (float(b) for b in intervals.intervals[k])
        identified = intervals.verdicts[k] == "identified"
        out[k] = {"verdict": intervals.verdicts[k], "interval": [low, high], "identified": identified,
                  "holds": bool(low <= v <= high)}
    return out
