"""A third law-discovery batch: 10 effects outside the closed loop's term list, and 3 complete controls.

Written on 2026-12-07 for issue "Name the law, not a stand-in", after the first batch (``laws.py``) had been seen
by twelve revisions of the discovery family and the second (``laws_second.py``) by one: a test of the package as
it stands (``loop`` and the loop with discovery, ``DEFAULT_ARMS``) on laws no revision has seen. Committed before
any arm ran on it (the commit that adds this file runs nothing; its author simulated the true systems only, to
see that every trajectory stays finite and where the states go). Textbook laws of fields the other batches have
and others (hydraulics, aerospace, photonics, fermentation, electronics), two or three states, the science model
an engineer would write first: it lacks the law, or has its simplification (a linear damping, a gain without
compression, a growth without product inhibition), whose parameter the law keeps as its rate at rest. None of the
laws is one kind of the term list; ``sqrt`` of a difference, a drag times an exponential of another state and
``T^2 exp(-b/T)`` are products and compositions the list does not hold.

The systems use the identification benchmark's :class:`~identification.systems.System` and its simulation and
protocol (50 training and 20 test trajectories, noise as a share of each state's spread, function-space scores).
"""

from __future__ import annotations

from functools import partial

import numpy as np
import torch

from discovery.laws import law_system, POP, linear_spring_f, logistic_prey_f, on_component, pair_flux


# ------------------------------------------------------------------------------------------------ science models
def growing_predator_f(v, r=1.0, K=3.0, a=0.8, s=0.5):
    """Prey growing logistically, eaten by mass action; predators growing at rate ``s``, their limit not known."""
    x, y = v[:, 0], v[:, 1]
    return torch.stack([r * x * (1 - x / K) - a * x * y, s * y], dim=-1)


def fed_tanks_f(v, u, l=0.3):
    """Two tanks: the first fed at ``u``, the second drained linearly; the flow between them not known."""
    return torch.stack([u[:, 0], -l * v[:, 1]], dim=-1)


def falling_f(v, g=0.5):
    """A body falling in uniform gravity; the air's drag not known."""
    return torch.stack([v[:, 1], -g * torch.ones_like(v[:, 1])], dim=-1)


def monod_fermenter_f(v, u, D=0.2, mu=1.0, Ks=0.5, a=0.8):
    """A fermenter: Monod growth on the substrate fed at ``u`` (two units of substrate per unit of biomass), a
    product made in proportion, everything washed out at ``D``."""
    s, x, p = v[:, 0], v[:, 1], v[:, 2]
    r = mu * s.clamp(min=0.0) * x / (Ks + s.clamp(min=0.0))
    return torch.stack([D * (u[:, 0] - s) - 2 * r, r - D * x, a * r - D * p], dim=-1)


def heated_cathode_f(v, u, h=0.5, k=0.3):
    """A cathode heated by ``u`` (temperatures in 1000 K), conducting to its holder, which cools to 1000 K."""
    t, tc = v[:, 0], v[:, 1]
    return torch.stack([u[:, 0] - h * (t - tc), h * (t - tc) - k * (tc - 1)], dim=-1)


def growing_tumour_f(v, g=0.3, d=0.4):
    """A tumour growing exponentially, a drug decaying; how the drug kills not known."""
    x, c = v[:, 0], v[:, 1]
    return torch.stack([g * x, -d * c], dim=-1)


def laser_f(v, u, g=1.0, tn=1.0, tp=0.5, b=0.05):
    """Laser rate equations: carriers ``N`` pumped at ``u``, photons ``S`` by gain ``g N S`` without compression and
    spontaneous emission ``b N``."""
    n, s = v[:, 0], v[:, 1]
    gain = g * n * s
    return torch.stack([u[:, 0] - n / tn - gain, gain - s / tp + b * n], dim=-1)


def adapting_membrane_f(v, u, gl=0.5, a=0.3, b=0.8):
    """A membrane driven by a current ``u``, leaking, with a slow adaptation current ``w``; a voltage-gated
    current not known."""
    vm, w = v[:, 0], v[:, 1]
    return torch.stack([u[:, 0] - gl * vm - w, a * (b * vm - w)], dim=-1)


# controls: the science is the whole truth
def crowley_martin_f(v, r=1.0, K=3.0, a=1.5, b=0.8, c=0.5, e=0.5, m=0.4):
    x, y = v[:, 0], v[:, 1]
    eaten = a * x.clamp(min=0.0) * y / ((1 + b * x.clamp(min=0.0)) * (1 + c * y.clamp(min=0.0)))
    return torch.stack([r * x * (1 - x / K) - eaten, e * eaten - m * y], dim=-1)


def dragged_fall_f(v, g=0.5, k=0.5, H=1.2):
    h, w = v[:, 0], v[:, 1]
    return torch.stack([w, -g - k * torch.exp(-h / H) * w * w.abs()], dim=-1)


def compressed_laser_f(v, u, g=1.0, eps=2.0, tn=1.0, tp=0.5, b=0.05):
    n, s = v[:, 0], v[:, 1]
    gain = g * n * s / (1 + eps * s.clamp(min=0.0))
    return torch.stack([u[:, 0] - n / tn - gain, gain - s / tp + b * n], dim=-1)


# ------------------------------------------------------------------------------------------------------- effects
def _leslie_gower(x, u):  # s y (1 - h y/x): h = 0.8, s = 0.5
    return on_component(1, 2, -0.4 * x[:, 1] ** 2 / x[:, 0])


def _crowley_martin(x, u):
    p = 1.5 * x[:, 0] * x[:, 1] / ((1 + 0.8 * x[:, 0]) * (1 + 0.5 * x[:, 1]))
    return pair_flux(p, 0.5)


def _orifice(x, u):
    d = x[:, 0] - x[:, 1]
    return pair_flux(0.5 * np.sign(d) * np.sqrt(np.abs(d)))


def _atmosphere(x, u):
    w = x[:, 1]
    return on_component(1, 2, -0.5 * np.exp(-x[:, 0] / 1.2) * w * np.abs(w))


def _product_inhibition(x, u):  # mu S X / (Ks + S) / (1 + P/Kp) in place of Monod: mu = 1, Ks = 0.5, Kp = 0.6
    s, b, p = np.clip(x[:, 0], 0, None), x[:, 1], x[:, 2]
    extra = s * b / (0.5 + s) * (1 / (1 + p / 0.6) - 1)
    return np.stack([-2 * extra, extra, 0.8 * extra], axis=1)


def _thermionic(x, u):
    t = x[:, 0]
    return on_component(0, 2, -2.0 * t ** 2 * np.exp(-5.0 / t))


def _hill_kill(x, u):
    c = x[:, 1]
    return on_component(0, 2, -1.2 * c ** 2 * x[:, 0] / (0.25 + c ** 2))


def _eddy_brake(x, u):  # c v / (1 + (v/0.6)^2) in place of c v: c = 0.4
    v = x[:, 1]
    return on_component(1, 2, 0.4 * v * (1 - 1 / (1 + (v / 0.6) ** 2)))


def _gain_compression(x, u):  # g N S / (1 + eps S) in place of g N S: g = 1, eps = 2
    n, s = x[:, 0], np.clip(x[:, 1], 0, None)
    extra = n * s * (1 / (1 + 2.0 * s) - 1)
    return pair_flux(extra)


def _gated_current(x, u):
    vm = x[:, 0]
    return on_component(0, 2, -1.5 * (vm + 1) / (1 + np.exp(-(vm - 0.5) / 0.15)))


_system = partial(law_system, batch=20)


LAWS_3 = [
    _system("leslie_gower", "ecology", "rational of two states (y^2/x)",
            "predator limit -0.4 y^2 / x (Leslie-Gower: carrying capacity in proportion to prey)",
            growing_predator_f, {"r": 1.0, "K": 3.0, "a": 0.8, "s": 0.5}, _leslie_gower, ["x", "y"], POP, 0.3, 30,
            (0.5, 0.2), (2.5, 1.5), zero=[0]),
    _system("crowley_martin", "ecology", "product of two saturations",
            "predation 1.5 x y / ((1 + 0.8 x)(1 + 0.5 y)), half converted", logistic_prey_f,
            {"r": 1.0, "K": 3.0, "m": 0.4}, _crowley_martin, ["x", "y"], POP, 0.3, 30, (0.3, 0.3), (2.5, 1.5)),
    _system("orifice_tanks", "hydraulics", "square root of a difference",
            "orifice flow 0.5 sqrt(h1 - h2) from the first tank to the second", fed_tanks_f, {"l": 0.3},
            _orifice, ["h1", "h2"], {"h1": "m", "h2": "m", "u": "m/s"}, 0.4, 30, (1.0, 0.0), (3.0, 0.5),
            (0.1, 0.6)),
    _system("exponential_atmosphere", "aerospace", "drag times an exponential of another state",
            "drag -0.5 exp(-h/1.2) w |w| in an atmosphere thinning with height", falling_f, {"g": 0.5},
            _atmosphere, ["h", "w"], {"h": "km", "w": "km/s"}, 0.1, 30, (3.0, -1.5), (6.0, 0.5), zero=[0]),
    _system("product_inhibition", "fermentation", "Monod times a saturation of a third state, in place of Monod",
            "growth mu S X / (Ks + S) / (1 + P/0.6) in place of Monod (the product inhibits)", monod_fermenter_f,
            {"D": 0.2, "mu": 1.0, "Ks": 0.5, "a": 0.8}, _product_inhibition, ["S", "X", "P"],
            {"S": "g/L", "X": "g/L", "P": "g/L", "u": "g/L"}, 0.4, 30, (0.5, 0.1, 0.0), (3.0, 1.0, 1.0), (1.0, 4.0)),
    _system("thermionic_cooling", "electronics", "T^2 exp(-b/T) (Richardson)",
            "electron emission cooling -2 T^2 exp(-5/T) of a hot cathode", heated_cathode_f, {"h": 0.5, "k": 0.3},
            _thermionic, ["T", "Tc"], {"T": "1000 K", "Tc": "1000 K", "u": "1000 K/s"}, 0.3, 30, (1.0, 1.0),
            (2.5, 1.5), (0.2, 1.5), zero=[1]),
    _system("hill_kill", "pharmacology", "Hill (n = 2) times a state",
            "kill -1.2 c^2 x / (0.25 + c^2), a cooperative drug", growing_tumour_f, {"g": 0.3, "d": 0.4},
            _hill_kill, ["x", "c"], {"x": "1e9 cells", "c": "mg/L"}, 0.25, 30, (0.5, 0.2), (3.0, 3.0), zero=[1]),
    _system("eddy_brake", "mechanics", "rational (cubic over quadratic in v), in place of a linear damping",
            "eddy-current brake 0.4 v / (1 + (v/0.6)^2) in place of 0.4 v", linear_spring_f, {"k": 1.5, "c": 0.4},
            _eddy_brake, ["x", "v"], {"x": "m", "v": "m/s"}, 0.15, 30, (-2.0, -1.5), (2.0, 1.5), zero=[0]),
    _system("gain_compression", "photonics", "rational (saturating in S), in place of a product",
            "gain N S / (1 + 2 S) in place of N S (gain compression)", laser_f,
            {"g": 1.0, "tn": 1.0, "tp": 0.5, "b": 0.05}, _gain_compression, ["N", "S"], {"N": "1", "S": "1", "u": "1"},
            0.2, 30, (0.5, 0.05), (2.0, 1.0), (0.5, 3.0)),
    _system("gated_current", "neuroscience", "a sigmoid of a state times a linear driving force",
            "outward current -1.5 (V + 1) / (1 + exp(-(V - 0.5)/0.15))", adapting_membrane_f,
            {"gl": 0.5, "a": 0.3, "b": 0.8}, _gated_current, ["V", "w"], {"V": "50 mV", "w": "1", "u": "1"}, 0.2, 30,
            (-0.5, 0.0), (1.5, 0.5), (0.0, 2.0), zero=[1]),
    # controls
    _system("control_crowley_martin", "ecology", "control", "nothing (Crowley-Martin predation written in)",
            crowley_martin_f, {"r": 1.0, "K": 3.0, "a": 1.5, "b": 0.8, "c": 0.5, "e": 0.5, "m": 0.4}, None,
            ["x", "y"], POP, 0.3, 30, (0.3, 0.3), (2.5, 1.5)),
    _system("control_dragged_fall", "aerospace", "control", "nothing (drag in a thinning atmosphere written in)",
            dragged_fall_f, {"g": 0.5, "k": 0.5, "H": 1.2}, None, ["h", "w"], {"h": "km", "w": "km/s"}, 0.1, 30,
            (3.0, -1.5), (6.0, 0.5)),
    _system("control_compressed_laser", "photonics", "control", "nothing (gain compression written in)",
            compressed_laser_f, {"g": 1.0, "eps": 2.0, "tn": 1.0, "tp": 0.5, "b": 0.05}, None, ["N", "S"],
            {"N": "1", "S": "1", "u": "1"}, 0.2, 30, (0.5, 0.05), (2.0, 1.0), (0.5, 3.0)),
]
