"""A second law-discovery batch: 9 effects outside the closed loop's term list, and 3 complete controls.

Written on 2026-12-07 for issue "Name the law, not a stand-in", after the first batch (``laws.py``) had been seen
by eleven revisions of the discovery family: a test of the family as it stands on laws it was not revised on.
Committed before any arm ran on it (the commit that adds this file runs nothing; its author simulated the true
systems only, to see that every trajectory stays finite). Textbook laws of fields the first batch has and others
(gene regulation, pharmacology, catalysis, neuroscience, plankton ecology, heat), two or three states, the
science model an engineer would write first: it lacks the law, or has its low-dose / low-density simplification
(a linear kill, a linear recovery), whose parameter the law keeps as its rate at rest. None of the laws is one
kind of the term list (a saturation ``x/(K + x)`` of one state, a power, a hinge, an exponential of one state,
a tanh are listed, and are not used here); ``Ivlev``'s ``1 - exp(-b x)`` times a second state and Smith's
``u/sqrt(1 + (u/K)^2)`` times a state are products the list does not hold.

The systems use the identification benchmark's :class:`~identification.systems.System` and its simulation and
protocol (50 training and 20 test trajectories, noise as a share of each state's spread, function-space scores).
"""

from __future__ import annotations

from functools import partial

import numpy as np
import torch

from discovery.laws import law_system, POP, logistic_prey_f, mass_action_sir_f, on_component, pair_flux


# ------------------------------------------------------------------------------------------------ science models
def dilution3_f(v, u, D=0.4):
    """A flow reactor with an enzyme: substrate fed at ``u``, product and inhibitor washed out; the conversion
    not known."""
    s, p, q = v[:, 0], v[:, 1], v[:, 2]
    return torch.stack([D * (u[:, 0] - s), -D * p, -D * q], dim=-1)


def unregulated_gene_f(v, dm=0.5, kp=1.0, dp=0.3):
    """mRNA decaying, protein made from it and decaying; how the mRNA is made not known."""
    m, p = v[:, 0], v[:, 1]
    return torch.stack([-dm * m, kp * m - dp * p], dim=-1)


def heated_pair_f(v, u, h=0.25, l=0.2):
    """Two bodies (temperatures in 100 K above the surroundings): the first heated by ``u``, conduction between
    them, the second losing heat to the surroundings."""
    t1, t2 = v[:, 0], v[:, 1]
    return torch.stack([u[:, 0] - h * (t1 - t2), h * (t1 - t2) - l * t2], dim=-1)


def linear_kill_f(v, g=0.3, k=0.6, d=0.4):
    """Tumour growing, killed in proportion to the drug's concentration (low-dose pharmacology), drug decaying."""
    x, c = v[:, 0], v[:, 1]
    return torch.stack([g * x - k * c * x, -d * c], dim=-1)


def two_feeds_f(v, s1=0.8, s2=0.6, d=0.3):
    """Two reactants fed and washed out of a catalytic reactor; the surface reaction not known."""
    a, b = v[:, 0], v[:, 1]
    return torch.stack([s1 - d * a, s2 - d * b], dim=-1)


def leaky_pair_f(v, tau=1.0, c=1.0, di=0.8):
    """An excitatory population leaking, an inhibitory one driven by it; the excitatory input not known."""
    e, i = v[:, 0], v[:, 1]
    return torch.stack([-e / tau, c * e - di * i], dim=-1)


def grazed_plankton_f(v, u, g=0.8, e=0.4, m=0.3):
    """Phytoplankton grazed by zooplankton; how phytoplankton grow in the light ``u`` not known."""
    x, z = v[:, 0], v[:, 1]
    return torch.stack([-g * x * z, e * g * x * z - m * z], dim=-1)


# controls: the science is the whole truth
def inhibited_enzyme_f(v, u, D=0.4, V=1.5, Km=0.5, Ki=0.3):
    s, p, q = v[:, 0], v[:, 1], v[:, 2]
    rate = V * s / (Km * (1 + q / Ki) + s)
    return torch.stack([D * (u[:, 0] - s) - rate, -D * p + rate, -D * q], dim=-1)


def repressed_gene_f(v, a=2.0, K=0.8, dm=0.5, kp=1.0, dp=0.3):
    m, p = v[:, 0], v[:, 1]
    return torch.stack([a / (1 + (p / K) ** 2) - dm * m, kp * m - dp * p], dim=-1)


def emax_kill_f(v, g=0.3, k=0.6, ec50=0.7, d=0.4):
    x, c = v[:, 0], v[:, 1]
    return torch.stack([g * x - k * c * x / (1 + c / ec50), -d * c], dim=-1)


# ------------------------------------------------------------------------------------------------------- effects
def _ivlev(x, u):
    p = 0.9 * x[:, 1] * (1 - np.exp(-1.4 * x[:, 0]))
    return pair_flux(p, 0.5)


def _treatment(x, u):  # gamma I / (1 + a I) in place of gamma I: gamma = 0.8, a = 4
    i = x[:, 1]
    return on_component(1, 2, 0.8 * i * (1 - 1 / (1 + 4 * i)))


def _competitive(x, u):
    s, q = x[:, 0], x[:, 2]
    rate = 1.5 * s / (0.5 * (1 + q / 0.3) + s)
    return np.stack([-rate, rate, np.zeros_like(s)], axis=1)


def _repression(x, u):
    return on_component(0, 2, 2.0 / (1 + (x[:, 1] / 0.8) ** 2))


def _convection(x, u):
    d = x[:, 0] - x[:, 1]
    q = 0.15 * np.sign(d) * np.abs(d) ** 1.25
    return np.stack([-q, q], axis=1)


def _emax(x, u):  # k c x / (1 + c / EC50) in place of k c x: k = 0.6, EC50 = 0.7
    tumour, c = x[:, 0], x[:, 1]
    return on_component(0, 2, 0.6 * c * tumour * (1 - 1 / (1 + c / 0.7)))


def _langmuir_hinshelwood(x, u):
    a, b = x[:, 0], x[:, 1]
    rate = 2.0 * a * b / (1 + 0.8 * a + 0.5 * b) ** 2
    return np.stack([-rate, -rate], axis=1)


def _wilson_cowan(x, u):
    e, i = x[:, 0], x[:, 1]
    return on_component(0, 2, 1.5 / (1 + np.exp(-(4.0 * e - 3.0 * i - 1.0))))


def _smith(x, u):
    light = u[:, 0]
    return on_component(0, 2, 1.2 * x[:, 0] * light / np.sqrt(1 + (light / 0.8) ** 2))


_system = partial(law_system, batch=19)


CONC = {"S": "mmol/L", "P": "mmol/L", "Q": "mmol/L", "u": "mmol/L"}
LAWS_2 = [
    _system("ivlev_predation", "ecology", "state times 1 - exp of another",
            "predation 0.9 y (1 - exp(-1.4 x)), half converted", logistic_prey_f, {"r": 1.1, "K": 3.5, "m": 0.35},
            _ivlev, ["x", "y"], POP, 0.3, 30, (0.3, 0.3), (2.5, 1.5)),
    _system("saturating_treatment", "epidemiology", "rational (saturating in I), in place of a linear term",
            "recovery 0.8 I / (1 + 4 I) in place of 0.8 I (a treatment capacity)", mass_action_sir_f,
            {"beta": 2.2, "gamma": 0.8, "mu": 0.1}, _treatment, ["S", "I"], {"S": "1", "I": "1"}, 0.25, 30,
            (0.4, 0.02), (0.95, 0.3), zero=[0]),
    _system("competitive_inhibition", "biochemistry", "rational of two states (three states)",
            "conversion 1.5 S / (0.5 (1 + Q/0.3) + S), an inhibitor Q washed out", dilution3_f, {"D": 0.4},
            _competitive, ["S", "P", "Q"], CONC, 0.3, 30, (0.2, 0.0, 0.0), (2.0, 0.5, 0.6), (0.5, 2.5), zero=[2]),
    _system("hill_repression", "gene regulation", "Hill repression (n = 2), not zero at rest",
            "transcription 2 / (1 + (p/0.8)^2)", unregulated_gene_f, {"dm": 0.5, "kp": 1.0, "dp": 0.3},
            _repression, ["m", "p"], {"m": "nmol/L", "p": "nmol/L"}, 0.3, 30, (0.0, 0.0), (3.0, 3.0), zero=[1]),
    _system("natural_convection", "heat", "power 5/4 of a difference",
            "natural convection 0.15 (T1 - T2)^(5/4) between two bodies", heated_pair_f, {"h": 0.25, "l": 0.2},
            _convection, ["T1", "T2"], {"T1": "100 K", "T2": "100 K", "u": "100 K/s"}, 0.3, 30, (1.0, 0.2),
            (3.0, 1.0), (0.2, 1.0)),
    _system("emax_kill", "pharmacology", "rational, in place of a product",
            "kill 0.6 c x / (1 + c/0.7) in place of 0.6 c x (an Emax drug)", linear_kill_f,
            {"g": 0.3, "k": 0.6, "d": 0.4}, _emax, ["x", "c"], {"x": "1e9 cells", "c": "mg/L"}, 0.25, 30,
            (0.5, 0.2), (3.0, 3.0), zero=[1]),
    _system("langmuir_hinshelwood", "catalysis", "rational, squared denominator, one sign on both states",
            "surface reaction 2 A B / (1 + 0.8 A + 0.5 B)^2 consuming both", two_feeds_f,
            {"s1": 0.8, "s2": 0.6, "d": 0.3}, _langmuir_hinshelwood, ["A", "B"], {"A": "mol/L", "B": "mol/L"}, 0.3,
            30, (0.2, 0.2), (3.0, 3.0)),
    _system("wilson_cowan", "neuroscience", "logistic sigmoid of two states",
            "excitatory input 1.5 / (1 + exp(-(4 E - 3 I - 1)))", leaky_pair_f, {"tau": 1.0, "c": 1.0, "di": 0.8},
            _wilson_cowan, ["E", "I"], {"E": "1", "I": "1"}, 0.2, 30, (0.0, 0.0), (1.5, 1.5), zero=[1]),
    _system("smith_photosynthesis", "plankton ecology", "state times a root-saturated input",
            "growth 1.2 x u / sqrt(1 + (u/0.8)^2) in the light u", grazed_plankton_f, {"g": 0.8, "e": 0.4, "m": 0.3},
            _smith, ["x", "z"], {"x": "mmol N/m3", "z": "mmol N/m3", "u": "100 W/m2"}, 0.25, 30, (0.2, 0.2),
            (1.5, 1.0), (0.0, 2.0), zero=[1]),
    # controls
    _system("control_inhibited_enzyme", "biochemistry", "control", "nothing (competitive inhibition written in)",
            inhibited_enzyme_f, {"D": 0.4, "V": 1.5, "Km": 0.5, "Ki": 0.3}, None, ["S", "P", "Q"], CONC, 0.3, 30,
            (0.2, 0.0, 0.0), (2.0, 0.5, 0.6), (0.5, 2.5)),
    _system("control_repressed_gene", "gene regulation", "control", "nothing (Hill repression written in)",
            repressed_gene_f, {"a": 2.0, "K": 0.8, "dm": 0.5, "kp": 1.0, "dp": 0.3}, None, ["m", "p"],
            {"m": "nmol/L", "p": "nmol/L"}, 0.3, 30, (0.0, 0.0), (3.0, 3.0)),
    _system("control_emax_kill", "pharmacology", "control", "nothing (Emax kill written in)", emax_kill_f,
            {"g": 0.3, "k": 0.6, "ec50": 0.7, "d": 0.4}, None, ["x", "c"], {"x": "1e9 cells", "c": "mg/L"}, 0.25,
            30, (0.5, 0.2), (3.0, 3.0)),
]
