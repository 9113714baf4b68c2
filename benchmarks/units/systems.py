"""The unit benchmark's systems: six of the project's own, each written once and measured in many units.

Written for ``bench_units.py`` (issue "Your units, your machine") and kept out of the tests. Each system is
given in a reference unit system where its states and rates are of order one; a unit system multiplies time by
``T`` (a value in the new time unit is ``T`` times the old: ``T = 1000`` takes seconds to milliseconds) and
each state ``j`` by ``S[j]``. The science function is the same code in every unit system (the user writes
their own model in their own units): only its parameters' values change, each by the known power of ``T`` and
of the states' factors that its dimension gives (:attr:`System.dims`). The data are simulated once in the
reference units and converted, so every unit system holds the same physics and the same noise.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable

import numpy as np
import torch

from helpers import rk4_trajectories

__all__ = ["System", "SYSTEMS", "UNIT_SYSTEMS", "UnitSystem", "convert", "convert_back", "science_in", "make_data",
           "true_rhs_in", "test_states", "check_conversion"]


# -- the systems, in their reference units ---------------------------------------------------------------------

def sirs_f(v, beta=0.3, gamma=0.1):
    """Susceptible, infected, recovered as shares, rates per day; the waning of immunity is missing."""
    s, i, r = v[:, 0], v[:, 1], v[:, 2]
    return torch.stack([-beta * s * i, beta * s * i - gamma * i, gamma * i], dim=-1)


def sirs_true(v):
    s, i, r = v[:, 0], v[:, 1], v[:, 2]
    return np.stack([-0.5 * s * i + 0.15 * r, 0.5 * s * i - 0.2 * i, 0.2 * i - 0.15 * r], axis=-1)


def spring_f(v, k=1.5):
    """A mass on a spring (position, velocity); its viscous damping is missing."""
    return torch.stack([v[:, 1], -k * v[:, 0]], dim=-1)


def spring_true(v):
    return np.stack([v[:, 1], -2.0 * v[:, 0] - 0.4 * v[:, 1]], axis=-1)


def rlc_f(v, r=0.3, w2=1.5):
    """A series RLC circuit (charge, current): R / L and 1 / (L C); a cubic conductance's loss is missing."""
    return torch.stack([v[:, 1], -r * v[:, 1] - w2 * v[:, 0]], dim=-1)


def rlc_true(v):
    return np.stack([v[:, 1], -0.2 * v[:, 1] - 2.5 * v[:, 0] - 0.5 * v[:, 1] ** 3], axis=-1)


def chain_reaction_f(v, k1=0.5, k2=0.3):
    """A -> B -> C, first order both; A's second-order (dimerisation) loss is missing. Slow in seconds."""
    a, b = v[:, 0], v[:, 1]
    return torch.stack([-k1 * a, k1 * a - k2 * b, k2 * b], dim=-1)


def chain_reaction_true(v):
    a, b = v[:, 0], v[:, 1]
    return np.stack([-0.8 * a - 0.6 * a ** 2, 0.8 * a - 0.4 * b, 0.4 * b], axis=-1)


def herd_f(v, a=1.0, b=1.0, c=0.8, d=0.6):
    """Prey and predators (Lotka-Volterra), counted in units of 1e4 animals in the reference; prey crowding
    is missing."""
    x, y = v[:, 0], v[:, 1]
    return torch.stack([a * x - b * x * y, c * x * y - d * y], dim=-1)


def herd_true(v):
    x, y = v[:, 0], v[:, 1]
    return np.stack([1.1 * x - 0.9 * x * y - 0.3 * x ** 2, 0.7 * x * y - 0.5 * y], axis=-1)


def rooms_f(v, k=0.5, h=0.2):
    """Two rooms exchanging heat, one losing it outside (temperatures above the outside): complete."""
    t1, t2 = v[:, 0], v[:, 1]
    return torch.stack([-k * (t1 - t2), k * (t1 - t2) - h * t2], dim=-1)


def rooms_true(v):
    t1, t2 = v[:, 0], v[:, 1]
    return np.stack([-0.7 * (t1 - t2), 0.7 * (t1 - t2) - 0.3 * t2], axis=-1)


@dataclass
class System:
    """A system in its reference units.

    ``dims`` gives each parameter's dimension as ``(time power, {state index: power})``: the parameter's
    value in a unit system is its reference value times ``T ** time_power * prod(S[j] ** power)``. A rate
    (per time) has time power -1; ``beta`` of ``beta s i`` in ``ds/dt`` has ``(-1, {1: -1})``, since
    ``s`` and ``ds/dt`` share ``s``'s unit.
    """

    name: str
    field: str
    science: Callable
    true_rhs: Callable
    theta_true: dict
    dims: dict
    state_names: list
    n_samples: int
    n_steps: int
    dt: float
    low: tuple
    high: tuple
    missing: str  # the effect the science leaves out, in words ("" when complete)
    same_unit: list = field(default_factory=list)  # groups of states that must share a unit (a conserved sum)
    derivative_of: dict = field(default_factory=dict)  # state j is d(state k)/dt: its unit is k's per time

    @property
    def complete(self) -> bool:
        return not self.missing


SYSTEMS = {s.name: s for s in [
    System("sirs", "epidemiology", sirs_f, sirs_true, {"beta": 0.5, "gamma": 0.2},
           {"beta": (-1, {0: -1}), "gamma": (-1, {})}, ["s", "i", "r"], 25, 25, 2.0,
           (0.6, 0.01, 0.0), (0.95, 0.1, 0.3), "waning immunity +0.15 r in ds, -0.15 r in dr", [[0, 1, 2]]),
    System("spring", "mechanics", spring_f, spring_true, {"k": 2.0}, {"k": (-2, {})}, ["x", "x_dot"], 25, 25,
           0.15, (-1.0, -1.0), (1.0, 1.0), "viscous damping -0.4 x_dot", derivative_of={1: 0}),
    System("rlc", "electrical", rlc_f, rlc_true, {"r": 0.2, "w2": 2.5}, {"r": (-1, {}), "w2": (-2, {})},
           ["q", "i"], 25, 25, 0.15, (-1.0, -1.0), (1.0, 1.0), "cubic conductance -0.5 i^3", derivative_of={1: 0}),
    System("chain_reaction", "chemistry", chain_reaction_f, chain_reaction_true, {"k1": 0.8, "k2": 0.4},
           {"k1": (-1, {}), "k2": (-1, {})}, ["a", "b", "c"], 24, 20, 0.25, (0.5, 0.0, 0.0), (2.0, 0.5, 0.5),
           "dimerisation -0.6 a^2", [[0, 1, 2]]),
    System("herd", "ecology", herd_f, herd_true, {"a": 1.1, "b": 0.9, "c": 0.7, "d": 0.5},
           {"a": (-1, {}), "b": (-1, {1: -1}), "c": (-1, {0: -1}), "d": (-1, {})}, ["prey", "predators"],
           30, 20, 0.3, (0.5, 0.3), (2.5, 1.5), "prey crowding -0.3 prey^2"),
    System("rooms", "heat", rooms_f, rooms_true, {"k": 0.7, "h": 0.3}, {"k": (-1, {}), "h": (-1, {})},
           ["t1", "t2"], 25, 20, 0.3, (0.5, 0.0), (3.0, 2.0), "", [[0, 1]]),
]}


@dataclass
class UnitSystem:
    """Time times ``T``; every state times ``S``, or, with ``per_state``, state ``j`` times ``per_state[j % len]``
    (states that must share a unit take their group's first factor; a velocity takes its position's per time)."""

    name: str
    T: float
    S: float = 1.0
    per_state: tuple = ()

    def state_factors(self, system: System) -> np.ndarray:
        n = len(system.state_names)
        factors = np.array([self.per_state[j % len(self.per_state)] for j in range(n)], dtype=float) \
            if self.per_state else np.full(n, float(self.S))
        for group in system.same_unit:
            factors[group] = factors[group[0]]
        for j, k in system.derivative_of.items():
            factors[j] = factors[k] / self.T
        return factors


#: The reference (order one) first; then time and state scales from 1e-3 to 1e3, alone and combined (``t1e3``:
#: time values times 1e3, as seconds to milliseconds; ``s1e-3``: states times 1e-3; ``t10_mixed``: time times 10,
#: the states times 1e3 and 1e-2 in turn).
UNIT_SYSTEMS = {u.name: u for u in [
    UnitSystem("reference", 1.0),
    UnitSystem("t1e3", 1e3),
    UnitSystem("t1e-3", 1e-3),
    UnitSystem("s1e3", 1.0, 1e3),
    UnitSystem("s1e-3", 1.0, 1e-3),
    UnitSystem("t1e3_s1e-3", 1e3, 1e-3),
    UnitSystem("t1e-2_s1e2", 1e-2, 1e2),
    UnitSystem("t10_mixed", 10.0, per_state=(1e3, 1e-2)),
]}


def convert(system: System, units: UnitSystem, theta: dict) -> dict:
    """Parameter values in the reference units -> their values in ``units``."""
    S = units.state_factors(system)
    out = {}
    for name, value in theta.items():
        time_power, state_powers = system.dims[name]
        factor = units.T ** time_power
        for j, power in state_powers.items():
            factor *= S[j] ** power
        out[name] = float(float(value) * factor)
    return out


def convert_back(system: System, units: UnitSystem, theta: dict) -> dict:
    """Parameter values in ``units`` -> their values in the reference units."""
    one = convert(system, units, {k: 1.0 for k in theta})
    return {k: float(np.ravel(v)[0]) / one[k] for k, v in theta.items()}


class ScienceInUnits:
    """The science function as a user writes it in a unit system: the same code, its defaults converted.

    A class (not a closure) so that it pickles into the loop's worker processes, as a user's module-level
    function does; its signature carries the converted defaults, which the package reads theta from.
    """

    def __init__(self, system_name: str, units_name: str):
        import inspect

        system, units = SYSTEMS[system_name], UNIT_SYSTEMS[units_name]
        self.system_name, self.units_name = system_name, units_name
        self.func = system.science
        self.__name__ = system.science.__name__
        defaults = {k: p.default for k, p in inspect.signature(self.func).parameters.items()
                    if p.default is not p.empty}
        converted = convert(system, units, defaults)
        params = [inspect.Parameter("v", inspect.Parameter.POSITIONAL_OR_KEYWORD)]
        params += [inspect.Parameter(k, inspect.Parameter.POSITIONAL_OR_KEYWORD, default=converted[k])
                   for k in defaults]
        self.__signature__ = inspect.Signature(params)

    def __call__(self, v, **theta):
        return self.func(v, **theta)

    def __reduce__(self):
        return ScienceInUnits, (self.system_name, self.units_name)


def science_in(system: System, units: UnitSystem) -> ScienceInUnits:
    """The science function as a user writes it in ``units`` (see :class:`ScienceInUnits`)."""
    return ScienceInUnits(system.name, units.name)


def make_data(system: System, units: UnitSystem, seed: int, noise: float = 0.01, n_samples: int | None = None):
    """``X`` (n, s), ``y`` (n, n_steps, s) and ``dt`` in ``units``: the reference data converted."""
    rng = np.random.default_rng(seed)
    n = system.n_samples if n_samples is None else n_samples
    X = rng.uniform(system.low, system.high, size=(n, len(system.low)))
    y = rk4_trajectories(system.true_rhs, X, system.dt, system.n_steps)
    spread = y.reshape(-1, y.shape[-1]).std(0)
    y = y + noise * spread * rng.standard_normal(y.shape)
    S = units.state_factors(system)
    return (X * S).astype(np.float32), (y * S).astype(np.float32), system.dt * units.T


def true_rhs_in(system: System, units: UnitSystem) -> Callable:
    """The true right-hand side in ``units``: ``S * f(x / S) / T``."""
    S = units.state_factors(system)
    return lambda x: system.true_rhs(np.asarray(x) / S) * S / units.T


def test_states(system: System, units: UnitSystem, seed: int) -> np.ndarray:
    """Noise-free test states (20 trajectories from new starts), in ``units``."""
    X, y, _ = make_data(system, units, seed + 1000, noise=0.0, n_samples=20)
    return np.concatenate([X, y.reshape(-1, y.shape[-1])]).astype(float)


def check_conversion(system: System, units: UnitSystem) -> float:
    """Largest relative gap between the converted science at converted theta and the reference science
    carried into ``units`` (``S * f(x / S; theta) / T``): zero when ``dims`` are right."""
    S = units.state_factors(system)
    x = np.random.default_rng(0).uniform(system.low, system.high, size=(50, len(system.low))) * S
    theta = convert(system, units, system.theta_true)
    with torch.no_grad():
        new = science_in(system, units)(torch.as_tensor(x), **{k: torch.tensor(v) for k, v in theta.items()}).numpy()
        ref = system.science(torch.as_tensor(x / S), **{k: torch.tensor(v) for k, v in system.theta_true.items()})
    ref = ref.numpy() * S / units.T
    return float(np.max(np.abs(new - ref)) / np.max(np.abs(ref)))
