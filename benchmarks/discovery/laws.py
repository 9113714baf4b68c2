"""The law-discovery batch: 17 effects whose form is outside the closed loop's term list, and 4 complete controls.

Written on 2026-12-06 for issue "Name the law, not a stand-in", before the discovery family's first run on any of
them, and committed before that run (the commit that adds this file runs nothing). Textbook laws of several
fields, two to four states each, the science model an engineer would write first: it lacks the law (or has its
mass-action or constant-resistance simplification, whose parameter the law keeps), and theta keeps its meaning.
Every effect here is a closed form of the states and the input; two need an operator the default grammars lack
(``tanh`` of Stribeck friction) or a form the library's kinds cannot write at all (``x log x``), on purpose.

The systems use the identification benchmark's :class:`~identification.systems.System` and its simulation and
protocol (50 training and 20 test trajectories, noise as a share of each state's spread, function-space scores).
"""

from __future__ import annotations

from functools import partial

import numpy as np
import torch

from identification.systems import System


def on_component(component: int, d: int, values: np.ndarray) -> np.ndarray:
    """An effect on one of ``d`` equations: ``values`` on ``component``, zero on the others."""
    out = np.zeros((len(values), d))
    out[:, component] = values
    return out


def pair_flux(values: np.ndarray, gain: float = 1.0) -> np.ndarray:
    """A flux that leaves the first state and enters the second, scaled by ``gain`` there."""
    return np.stack([-values, gain * values], axis=1)


# ------------------------------------------------------------------------------------------------ science models
def drug_kill_f(v, k=0.6, d=0.4):
    """Tumour under a decaying drug: the kill and the decay known, the growth not."""
    x, c = v[:, 0], v[:, 1]
    return torch.stack([-k * c * x, -d * c], dim=-1)


def logistic_prey_f(v, r=0.8, K=2.5, m=0.3):
    """Prey growing logistically, predators dying; how predators eat is not known."""
    x, y = v[:, 0], v[:, 1]
    return torch.stack([r * x * (1 - x / K), -m * y], dim=-1)


def mass_action_sir_f(v, beta=2.0, gamma=0.5, mu=0.12):
    """SIR in shares with births and deaths, mass-action incidence."""
    s, i = v[:, 0], v[:, 1]
    inc = beta * s.clamp(min=0.0) * i.clamp(min=0.0)
    return torch.stack([mu * (1 - s) - inc, inc - (gamma + mu) * i], dim=-1)


def mass_action_sis_f(v, beta=1.6, gamma=0.4):
    s, i = v[:, 0], v[:, 1]
    inc = beta * s.clamp(min=0.0) * i.clamp(min=0.0)
    return torch.stack([gamma * i - inc, inc - gamma * i], dim=-1)


def dying_sir_f(v, beta=1.2, gamma=0.4, delta=0.25):
    """SIR with deaths from the disease, so the population shrinks; mass-action incidence."""
    s, i = v[:, 0], v[:, 1]
    inc = beta * s.clamp(min=0.0) * i.clamp(min=0.0)
    return torch.stack([-inc, inc - (gamma + delta) * i, gamma * i], dim=-1)


def chemostat_f(v, u, D=0.25):
    """Dilution of substrate and biomass; the uptake law not known."""
    s, x = v[:, 0], v[:, 1]
    return torch.stack([D * (u[:, 0] - s), -D * x], dim=-1)


def isothermal_cstr_f(v, u, q=0.6, k=0.4, h=0.5):
    """A stirred reactor whose rate constant is taken as the same at every temperature."""
    c, T = v[:, 0], v[:, 1]
    rate = k * c
    return torch.stack([q * (u[:, 0] - c) - rate, q * (1 - T) + h * rate], dim=-1)


def inflow_washout_f(v, s=0.8, d=0.25):
    a, b = v[:, 0], v[:, 1]
    return torch.stack([s - d * a, -d * b], dim=-1)


def linear_electrode_f(v, u, g=0.5, d=0.3):
    """Double layer charged by a current, the charge transfer taken as linear in the overpotential."""
    eta, c = v[:, 0], v[:, 1]
    return torch.stack([u[:, 0] - g * eta, g * eta - d * c], dim=-1)


def diffusion_cell_f(v, g=0.15, d=0.08):
    """Two half cells exchanging ions by diffusion; the electric drive not known."""
    c1, c2 = v[:, 0], v[:, 1]
    flux = g * (c1 - c2)
    return torch.stack([-flux, flux - d * c2], dim=-1)


def linear_spring_f(v, k=1.5, c=0.15):
    return torch.stack([v[:, 1], -k * v[:, 0] - c * v[:, 1]], dim=-1)


def suspended_magnet_f(v, u, k=2.5, c=0.3):
    """A body on a spring (rest at 1) under a coil; the coil's pull not known."""
    return torch.stack([v[:, 1], -k * (v[:, 0] - 1) - c * v[:, 1]], dim=-1)


def conducting_pair_f(v, h=0.25, l=0.15):
    """Two bodies (temperatures in 100 K) exchanging heat by conduction and losing it to 300 K surroundings."""
    t1, t2 = v[:, 0], v[:, 1]
    return torch.stack([-h * (t1 - t2) - l * (t1 - 3), h * (t1 - t2) - l * (t2 - 3)], dim=-1)


def ohmic_heater_f(v, u, p=0.4, h=0.6, l=0.25):
    """A resistor heated by its voltage squared over a constant resistance, cooled through its case."""
    T, tc = v[:, 0], v[:, 1]
    return torch.stack([p * u[:, 0] ** 2 - h * (T - tc), h * (T - tc) - l * (tc - 1)], dim=-1)


# controls: the science is the whole truth
def holling_f(v, r=0.8, K=2.5, a=1.0, b=0.6, e=0.5, m=0.3):
    x, y = v[:, 0], v[:, 1]
    eaten = a * x.clamp(min=0.0) * y / (1 + b * x.clamp(min=0.0))
    return torch.stack([r * x * (1 - x / K) - eaten, e * eaten - m * y], dim=-1)


def arrhenius_cstr_f(v, u, q=0.6, k=0.4, h=0.5, E=3.0):
    c, T = v[:, 0], v[:, 1]
    rate = k * c * torch.exp(E * (1 - 1 / T.clamp(min=0.2)))
    return torch.stack([q * (u[:, 0] - c) - rate, q * (1 - T) + h * rate], dim=-1)


def forced_oscillator_f(v, u, k=1.5, c=0.2, b=0.8):
    return torch.stack([v[:, 1], -k * v[:, 0] - c * v[:, 1] + b * u[:, 0]], dim=-1)


def vital_sir_f(v, beta=2.0, gamma=0.5, mu=0.1):
    s, i, r = v[:, 0], v[:, 1], v[:, 2]
    inc = beta * s.clamp(min=0.0) * i.clamp(min=0.0)
    return torch.stack([mu * (1 - s) - inc, inc - (gamma + mu) * i, gamma * i - mu * r], dim=-1)


# ------------------------------------------------------------------------------------------------------- effects
def _holling_iii(x, u):
    p = 1.2 * x[:, 0] ** 2 * x[:, 1] / (0.64 + x[:, 0] ** 2)
    return pair_flux(p, 0.5)


def _beddington(x, u):
    p = 1.5 * x[:, 0] * x[:, 1] / (1 + 0.8 * x[:, 0] + 0.6 * x[:, 1])
    return pair_flux(p, 0.5)


def _ratio_dependent(x, u):
    p = 1.0 * x[:, 0] * x[:, 1] / (x[:, 0] + 0.7 * x[:, 1])
    return pair_flux(p, 0.5)


# A sign slip in the next two, found after their records were made: the flux is the truth's incidence less the
# science's, beta S I (1/(1 + K I) - 1), but it is passed negated, so the truth simulated is an incidence that
# rises to twice mass action, beta S I (2 - 1/(1 + K I)), not the saturated one the comments meant. The records
# rest on this truth (their scores compare with it, as every case's do), so it is kept and the effects' names say
# what was simulated.
def _saturating_incidence(x, u):  # beta S I (2 - 1/(1 + 3 I)) in place of beta S I, beta = 2.5 (see above)
    s, i = x[:, 0], x[:, 1]
    return pair_flux(-2.5 * s * i * (1 / (1 + 3 * i) - 1))


def _behavioural_incidence(x, u):  # beta S I (2 - 1/(1 + 8 I^2)) in place of beta S I, beta = 2.0 (see above)
    s, i = x[:, 0], x[:, 1]
    return pair_flux(-2.0 * s * i * (1 / (1 + 8 * i ** 2) - 1))


def _standard_incidence(x, u):  # beta S I / N in place of beta S I, N = S + I + R shrinking, beta = 1.4
    s, i, r = x[:, 0], x[:, 1], x[:, 2]
    extra = 1.4 * s * i * (1 / (s + i + r) - 1)
    return np.stack([-extra, extra, np.zeros_like(s)], axis=1)


def _haldane(x, u):
    s, b = x[:, 0], x[:, 1]
    uptake = 1.5 * s * b / (0.3 + s + s ** 2 / 0.5)
    return pair_flux(uptake, 0.5)


def _arrhenius(x, u):  # k C exp(E (1 - 1/T)) in place of k C: k = 0.4, E = 3, h = 0.5
    c, T = x[:, 0], x[:, 1]
    extra = 0.4 * c * (np.exp(3.0 * (1 - 1 / T)) - 1)
    return np.stack([-extra, 0.5 * extra], axis=1)


def _saturating_autocatalysis(x, u):
    a, b = x[:, 0], x[:, 1]
    return pair_flux(1.2 * a * b / (0.4 + b))


def _butler_volmer(x, u):  # 2 i0 sinh(a eta) in place of g eta: i0 = 0.3, a = 1.5, g = 0.5
    eta = x[:, 0]
    extra = 2 * 0.3 * np.sinh(1.5 * eta) - 0.5 * eta
    return np.stack([-extra, extra], axis=1)


def _nernst_drive(x, u):
    return pair_flux(0.3 * np.log(x[:, 0] / x[:, 1]))


def _stribeck(x, u):
    v = x[:, 1]
    return on_component(1, 2, -0.5 * np.tanh(v / 0.05) * np.exp(-(v / 0.4) ** 2))


def _coil_pull(x, u):
    return on_component(1, 2, 0.8 * u[:, 0] ** 2 / (0.5 + x[:, 0]) ** 2)


def _stiffening(x, u):
    return on_component(1, 2, -2.0 * x[:, 0] ** 3 / (1 + x[:, 0] ** 2))


def _radiation(x, u):
    return pair_flux(0.002 * (x[:, 0] ** 4 - x[:, 1] ** 4))


def _thermistor(x, u):  # u^2 / R(T), R = R0 exp(B (1/T - 1)), in place of u^2 / R0: p = 1/R0 = 0.4, B = 3
    T = x[:, 0]
    return on_component(0, 2, 0.4 * u[:, 0] ** 2 * (np.exp(3.0 * (1 - 1 / T)) - 1))


def _growth(x, u):
    return on_component(0, 2, 0.4 * x[:, 0] * np.log(6.0 / x[:, 0]))


def law_system(name, domain, kind, effect, science, theta, missing, names, units, dt, n_steps, low, high,
               u_range=None, zero=(), guess=None, *, batch):
    """A laws batch's :class:`~identification.systems.System`, its ``batch`` number given by each batch's file."""
    return System(name, domain, kind, effect, science, theta, missing, list(names), units, dt, n_steps, tuple(low),
                  tuple(high), u_range, zero_components=list(zero), batch=batch, theta_guess=dict(guess or {}))


_system = partial(law_system, batch=18)


POP = {"x": "1", "y": "1"}
LAWS = [
    _system("gompertz_growth", "oncology", "x log(K/x)", "Gompertz growth 0.4 x log(6/x)",
            drug_kill_f, {"k": 0.8, "d": 0.5}, _growth, ["x", "c"], {"x": "1e9 cells", "c": "mg/L"}, 0.25, 30,
            (0.3, 0.0), (4.0, 1.5), zero=[1]),
    _system("holling_iii", "ecology", "Hill (n = 2)", "predation 1.2 x^2 y / (0.64 + x^2), half converted",
            logistic_prey_f, {"r": 1.0, "K": 3.0, "m": 0.4}, _holling_iii, ["x", "y"], POP, 0.3, 30,
            (0.3, 0.3), (2.5, 1.5)),
    _system("beddington_deangelis", "ecology", "rational of two states",
            "predation 1.5 x y / (1 + 0.8 x + 0.6 y), half converted",
            logistic_prey_f, {"r": 1.0, "K": 3.0, "m": 0.4}, _beddington, ["x", "y"], POP, 0.3, 30,
            (0.3, 0.3), (2.5, 1.5)),
    _system("ratio_dependent", "ecology", "rational of two states", "predation x y / (x + 0.7 y), half converted",
            logistic_prey_f, {"r": 1.0, "K": 3.0, "m": 0.4}, _ratio_dependent, ["x", "y"], POP, 0.3, 30,
            (0.5, 0.3), (2.5, 1.5)),
    _system("saturating_incidence_i", "epidemiology", "rational (saturating in I)",
            "incidence 2.5 S I (2 - 1/(1 + 3 I)) in place of mass action (meant 2.5 S I / (1 + 3 I); a sign slip)",
            mass_action_sir_f, {"beta": 2.5, "gamma": 0.6, "mu": 0.1}, _saturating_incidence, ["S", "I"],
            {"S": "1", "I": "1"}, 0.25, 30, (0.4, 0.02), (0.95, 0.3)),
    _system("behavioural_incidence", "epidemiology", "rational (Hill in I)",
            "incidence 2 S I (2 - 1/(1 + 8 I^2)) in place of mass action (meant 2 S I / (1 + 8 I^2), contacts "
            "falling as cases rise; a sign slip)",
            mass_action_sis_f, {"beta": 2.0, "gamma": 0.5}, _behavioural_incidence, ["S", "I"],
            {"S": "1", "I": "1"}, 0.25, 30, (0.4, 0.02), (0.95, 0.4)),
    _system("standard_incidence", "epidemiology", "rational of three states",
            "incidence 1.4 S I / (S + I + R) in place of mass action, the population shrinking",
            dying_sir_f, {"beta": 1.4, "gamma": 0.3, "delta": 0.3}, _standard_incidence, ["S", "I", "R"],
            {"S": "1", "I": "1", "R": "1"}, 0.3, 30, (0.3, 0.05, 0.0), (0.9, 0.4, 0.3), zero=[2]),
    _system("haldane_chemostat", "kinetics", "rational (substrate inhibition)",
            "uptake 1.5 S X / (0.3 + S + S^2/0.5), half converted to biomass",
            chemostat_f, {"D": 0.3}, _haldane, ["S", "X"], {"S": "g/L", "X": "g/L", "u": "g/L"}, 0.4, 30,
            (0.1, 0.2), (2.0, 1.0), (0.5, 2.0)),
    _system("arrhenius_reactor", "kinetics", "exp(-E/T) times a state",
            "rate 0.4 C exp(3 (1 - 1/T)) in place of 0.4 C (T in units of the feed's)",
            isothermal_cstr_f, {"q": 0.6, "k": 0.4, "h": 0.5}, _arrhenius, ["C", "T"],
            {"C": "mol/L", "T": "300 K", "u": "mol/L"}, 0.25, 30, (0.2, 0.85), (1.5, 1.3), (0.5, 1.5)),
    _system("saturating_autocatalysis", "kinetics", "state times a saturation of another",
            "autocatalysis 1.2 A B / (0.4 + B)", inflow_washout_f, {"s": 1.0, "d": 0.3}, _saturating_autocatalysis,
            ["A", "B"], {"A": "mol/L", "B": "mol/L"}, 0.25, 30, (0.5, 0.05), (3.0, 1.0)),
    _system("butler_volmer", "electrochemistry", "sinh", "charge transfer 0.6 sinh(1.5 eta) in place of 0.5 eta",
            linear_electrode_f, {"g": 0.5, "d": 0.3}, _butler_volmer, ["eta", "c"],
            {"eta": "0.1 V", "c": "mol/L", "u": "A"}, 0.2, 30, (-0.5, 0.0), (0.5, 0.5), (-1.2, 1.2)),
    _system("nernst_drive", "electrochemistry", "log of a ratio", "electric drive 0.3 log(c1/c2) between half cells",
            diffusion_cell_f, {"g": 0.15, "d": 0.08}, _nernst_drive, ["c1", "c2"], {"c1": "mol/L", "c2": "mol/L"},
            0.3, 30, (0.3, 0.3), (2.0, 2.0)),
    _system("stribeck_friction", "mechanics", "tanh times a Gaussian (outside the default grammars)",
            "Stribeck friction -0.5 tanh(v/0.05) exp(-(v/0.4)^2)", linear_spring_f, {"k": 2.0, "c": 0.1},
            _stribeck, ["x", "v"], {"x": "m", "v": "m/s"}, 0.1, 40, (-1.5, -1.0), (1.5, 1.0), zero=[0]),
    _system("coil_pull", "electromechanics", "input squared over a distance squared",
            "a coil's pull 0.8 u^2 / (0.5 + x)^2", suspended_magnet_f, {"k": 3.0, "c": 0.4}, _coil_pull, ["x", "v"],
            {"x": "cm", "v": "cm/s", "u": "A"}, 0.15, 30, (0.7, -0.3), (1.3, 0.3), (0.0, 1.5), zero=[0]),
    _system("stiffening_spring", "mechanics", "rational (cubic over quadratic)", "spring -2 x^3 / (1 + x^2)",
            linear_spring_f, {"k": 1.5, "c": 0.2}, _stiffening, ["x", "v"], {"x": "m", "v": "m/s"}, 0.15, 30,
            (-2.0, -1.0), (2.0, 1.0), zero=[0]),
    _system("radiative_exchange", "heat", "difference of fourth powers",
            "radiation 0.002 (T1^4 - T2^4) between two bodies", conducting_pair_f, {"h": 0.3, "l": 0.2},
            _radiation, ["T1", "T2"], {"T1": "100 K", "T2": "100 K"}, 0.3, 30, (3.0, 3.0), (6.0, 6.0)),
    _system("thermistor", "heat", "input squared times exp(-B/T)",
            "self-heating u^2 / R(T), an NTC resistance R0 exp(3 (1/T - 1)), in place of u^2 / R0",
            ohmic_heater_f, {"p": 0.4, "h": 0.8, "l": 0.3}, _thermistor, ["T", "Tc"],
            {"T": "300 K", "Tc": "300 K", "u": "V"}, 0.25, 30, (0.9, 0.9), (1.3, 1.2), (0.0, 0.8), zero=[1]),
    # controls
    _system("control_holling", "ecology", "control", "nothing (Holling type II predation)", holling_f,
            {"r": 1.0, "K": 3.0, "a": 1.2, "b": 0.8, "e": 0.5, "m": 0.4}, None, ["x", "y"], POP, 0.3, 30,
            (0.3, 0.3), (2.5, 1.5)),
    _system("control_arrhenius_reactor", "kinetics", "control", "nothing (Arrhenius rate)", arrhenius_cstr_f,
            {"q": 0.6, "k": 0.4, "h": 0.5, "E": 3.0}, None, ["C", "T"], {"C": "mol/L", "T": "300 K", "u": "mol/L"},
            0.25, 30, (0.2, 0.85), (1.5, 1.3), (0.5, 1.5)),
    _system("control_forced_oscillator", "mechanics", "control", "nothing (forced damped spring)",
            forced_oscillator_f, {"k": 2.0, "c": 0.25, "b": 1.0}, None, ["x", "v"], {"x": "m", "v": "m/s", "u": "N/kg"},
            0.15, 30, (-1.0, -1.0), (1.0, 1.0), (-1.5, 1.5)),
    _system("control_vital_sir", "epidemiology", "control", "nothing (SIR with births and deaths)", vital_sir_f,
            {"beta": 2.5, "gamma": 0.6, "mu": 0.15}, None, ["S", "I", "R"], {"S": "1", "I": "1", "R": "1"}, 0.25, 30,
            (0.4, 0.02, 0.0), (0.95, 0.3, 0.3)),
]
