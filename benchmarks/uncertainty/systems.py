"""Systems of the uncertainty benchmark (bench_uncertainty.py): data, science model, true theta.

Kept out of the tests.  Two come from the paper (pendulum without its damping,
Duffing without its cubic force); four were written for this benchmark, each
from another field and with another kind of missing effect; one has a
parameter the network can absorb exactly (a constant heat input, which the
network's output bias reproduces), one a complete science model.  Every
repeat draws new initial states and noise; noise is added to X (the measured
initial states) and to y, as in the paper's generators.

:data:`LOOP_STATES` are the two systems of ``bench_loop_states.py`` (a closed loop that fits the starts of
the states it does not measure), with their data, :func:`make_loop_states`.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable

import numpy as np
import torch
from scipy.integrate import solve_ivp

from sklearn_hybrid.datasets import make_duffing, make_pendulum
from sklearn_hybrid.models import duffing_f, pendulum_f


@dataclass
class System:
    name: str
    field: str
    missing: str
    science: Callable
    theta_true: dict
    theta_init: dict
    make: Callable  # repeat -> (X, y, dt)
    state_names: list
    units: dict
    not_identifiable: tuple = ()  # parameters a network can absorb exactly (hybrid fits)
    product_pair: tuple = ()  # parameters that enter only as a product: no data identify them (every method)
    complete: bool = False
    extra: dict = field(default_factory=dict)


def _simulate(rhs, x0, dt, n_steps):
    t = dt * np.arange(n_steps + 1)
    out = [solve_ivp(lambda _, v: rhs(v), (0, t[-1]), x, t_eval=t, rtol=1e-10, atol=1e-12).y.T for x in x0]
    return np.stack(out)  # (n, n_steps + 1, d)


def _noisy(states, noise, rng):
    X = states[:, 0] + noise * rng.standard_normal(states[:, 0].shape)
    y = states[:, 1:] + noise * rng.standard_normal(states[:, 1:].shape)
    return X, y


N_TRAIN = 20


def _pendulum(repeat):
    d = make_pendulum(n_train=N_TRAIN, n_val=1, n_test=1, random_state=1000 + repeat)
    return d.X_train, d.y_train, d.dt


def _duffing(repeat):
    d = make_duffing(n_train=N_TRAIN, n_val=1, n_test=1, random_state=2000 + repeat)
    return d.X_train, d.y_train, d.dt


def logistic_f(v, r=0.65, K=10.5):
    return r * v * (1 - v / K)


def _grazed_logistic(repeat):  # population: logistic growth, grazed at a saturating rate
    rng = np.random.default_rng(3000 + repeat)
    x0 = rng.uniform(0.5, 9.0, (N_TRAIN, 1))
    states = _simulate(lambda v: 0.9 * v * (1 - v / 8.0) - 0.6 * v / (1 + v), x0, 0.5, 12)
    X, y = _noisy(states, 0.03, rng)
    return X, y, 0.5


def reaction_f(v, k1=0.55, k2=0.4):
    a, b = v[:, 0], v[:, 1]
    return torch.stack([-k1 * a, k1 * a - k2 * b], dim=-1)


def _autocatalysis(repeat):  # chemistry: A -> B -> out, the autocatalytic A + B -> 2 B missing
    rng = np.random.default_rng(4000 + repeat)
    x0 = rng.uniform(0.0, 2.0, (N_TRAIN, 2))

    def rhs(v):
        a, b = v
        return [-0.8 * a - 0.3 * a * b, 0.8 * a + 0.3 * a * b - 0.3 * b]

    X, y = _noisy(_simulate(rhs, x0, 0.4, 12), 0.01, rng)
    return X, y, 0.4


def heated_body_f(v, k=0.35, q=0.8):
    return -k * (v - 1.0) + q


def _heated_body(repeat):  # heat: Newton cooling plus a constant heater; a quadratic loss missing
    rng = np.random.default_rng(5000 + repeat)
    x0 = rng.uniform(0.5, 3.0, (N_TRAIN, 1))
    X, y = _noisy(_simulate(lambda v: -0.5 * (v - 1.0) + 0.6 - 0.08 * v ** 2, x0, 0.5, 10), 0.01, rng)
    return X, y, 0.5


def spring_f(v, k=1.5, c=0.2):
    return torch.stack([v[:, 1], -k * v[:, 0] - c * v[:, 1]], dim=-1)


def _damped_spring(repeat):  # mechanics: the science is complete
    rng = np.random.default_rng(6000 + repeat)
    x0 = rng.uniform(-1.0, 1.0, (N_TRAIN, 2))
    X, y = _noisy(_simulate(lambda v: [v[1], -2.0 * v[0] - 0.3 * v[1]], x0, 0.2, 15), 0.01, rng)
    return X, y, 0.2


def cooled_plate_f(v, h=0.35, A=1.5):
    """Newton cooling of a plate towards 1 (100 K) through its area A with transfer coefficient h: only h * A
    enters, so no data identify h or A alone."""
    return -h * A * (v - 1.0)


def _cooled_plate(repeat):  # heat: h and A enter only as a product; a radiative-like loss -0.1 T^2 missing
    rng = np.random.default_rng(7000 + repeat)
    x0 = rng.uniform(0.5, 3.0, (N_TRAIN, 1))
    X, y = _noisy(_simulate(lambda v: -0.5 * 1.0 * (v - 1.0) - 0.1 * v ** 2, x0, 0.5, 10), 0.01, rng)
    return X, y, 0.5


SYSTEMS = {s.name: s for s in [
    System("pendulum", "mechanics (paper)", "damping -0.5 v_dot", pendulum_f, {"omega": 2 / 3}, {"omega": 0.5},
           _pendulum, ["v", "v_dot"], {"v": "rad", "v_dot": "rad/s"}),
    System("duffing", "mechanics (paper)", "cubic force +x^3", duffing_f, {"alpha": 1.0}, {"alpha": 0.7},
           _duffing, ["x", "x_dot"], {"x": "m", "x_dot": "m/s"}),
    System("grazed_logistic", "population", "grazing -0.6 x/(1 + x)", logistic_f, {"r": 0.9, "K": 8.0},
           {"r": 0.65, "K": 10.5}, _grazed_logistic, ["x"], {"x": "1e3 animals"}),
    System("autocatalysis", "chemistry", "autocatalysis 0.3 A B (both balances)", reaction_f,
           {"k1": 0.8, "k2": 0.3}, {"k1": 0.55, "k2": 0.4}, _autocatalysis, ["A", "B"],
           {"A": "mol/l", "B": "mol/l"}),
    System("heated_body", "heat", "loss -0.08 T^2; the heater q is a constant the network absorbs",
           heated_body_f, {"k": 0.5, "q": 0.6}, {"k": 0.35, "q": 0.8}, _heated_body, ["T"], {"T": "100 K"},
           not_identifiable=("q",)),
    System("damped_spring", "mechanics", "nothing (complete science)", spring_f, {"k": 2.0, "c": 0.3},
           {"k": 1.5, "c": 0.2}, _damped_spring, ["x", "x_dot"], {"x": "m", "x_dot": "m/s"}, complete=True),
    # issue 63: a structurally non-identifiable pair, added after the profile had called one identified
    System("cooled_plate", "heat", "loss -0.1 T^2; h and A enter only as h * A (structurally non-identifiable)",
           cooled_plate_f, {"h": 0.5, "A": 1.0}, {"h": 0.35, "A": 1.5}, _cooled_plate, ["T"], {"T": "100 K"},
           product_pair=("h", "A")),
]}


# --- bench_loop_states.py: one state measured, the other's start fitted by the closed loop ---------------

LOOP_N, LOOP_STEPS = 30, 25  # trajectories and steps of a repeat


def sir_f(v, beta=0.5, gamma=0.15):
    S, I = v[:, 0], v[:, 1]
    return torch.stack([-beta * S * I, beta * S * I - gamma * I], dim=-1)


def tanks_f(v, k1=0.3, k2=0.3):
    h1, h2 = torch.clamp(v[:, 0], min=0), torch.clamp(v[:, 1], min=0)
    return torch.stack([-k1 * torch.sqrt(h1), k1 * torch.sqrt(h1) - k2 * torch.sqrt(h2)], dim=-1)


LOOP_STATES = {
    "sir_hidden_susceptible": dict(
        science=sir_f, truth={"beta": 0.8, "gamma": 0.25}, init={"beta": 0.5, "gamma": 0.15}, dt=1.0,
        names=["S", "I"], noise=0.003, guess=0.9,
        rhs=lambda v: [-0.8 * v[0] * v[1], 0.8 * v[0] * v[1] - 0.25 * v[1]],
        start=lambda rng: np.column_stack([rng.uniform(0.6, 0.99, LOOP_N), rng.uniform(0.01, 0.08, LOOP_N)])),
    "tanks_hidden_upper": dict(
        science=tanks_f, truth={"k1": 0.5, "k2": 0.4}, init={"k1": 0.35, "k2": 0.3}, dt=0.5,
        names=["h1", "h2"], noise=0.01, guess=1.0,
        rhs=lambda v: [-0.5 * np.sqrt(max(v[0], 0)), 0.5 * np.sqrt(max(v[0], 0)) - 0.4 * np.sqrt(max(v[1], 0))
                       - 0.05 * v[1]],
        start=lambda rng: np.column_stack([rng.uniform(0.5, 2.0, LOOP_N), rng.uniform(0.1, 1.0, LOOP_N)])),
}


def make_loop_states(system, repeat):
    """``(X, y)`` of one repeat: X holds the guessed start of the unmeasured state and the measured one's."""
    rng = np.random.default_rng(5000 + repeat)
    x0 = system["start"](rng)
    t = system["dt"] * np.arange(1, LOOP_STEPS + 1)
    states = np.stack([solve_ivp(lambda _, v: system["rhs"](v), (0, t[-1]), s, t_eval=t, rtol=1e-10,
                                 atol=1e-12).y.T for s in x0])
    y = states[..., 1:] + system["noise"] * rng.standard_normal((LOOP_N, LOOP_STEPS, 1))
    X = np.column_stack([np.full(LOOP_N, system["guess"]),
                         x0[:, 1] + system["noise"] * rng.standard_normal(LOOP_N)])
    return X, y
