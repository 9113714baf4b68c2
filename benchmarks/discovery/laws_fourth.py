"""A fourth law-discovery batch: 12 effects outside the closed loop's term list, and 3 complete controls.

Written on 2026-12-07 for issue "Name the law, not a stand-in", after the first three batches (``laws.py``,
``laws_second.py``, ``laws_third.py``) had been seen: a test of the package as it stands (``loop`` and the loop
with discovery, ``DEFAULT_ARMS``) on laws none of the earlier batches holds. Committed before any arm ran on it
(the commit that adds this file runs nothing); its author simulated the true systems only, to see that every
trajectory stays finite, where the states go and what share of its equation each law is.
One revision, a family of the science's own terms slowed down by a variable (``families/inhibited.py``), was
developed on seen cases of the earlier batches (eddy_brake, gain_compression) before this batch's laws were chosen.

Textbook laws of fields the other batches have and others (bioprocess, thermodynamics, plankton ecology,
magnetism, pneumatics, contact mechanics, fisheries, biochemistry, physiology, physics, aerospace, ecology), two or
three states each, the science model an engineer would write first: it lacks the law (a soft surface's push, the
coupling of two phases), or has its simplification, whose parameter the law keeps: Monod growth on one substrate
where oxygen also limits (mu, the rate with both in excess), the ideal gas (nRT), a growth linear in the light (r,
its slope in dim light), Curie's linear magnetisation (chi, the slope at zero field), an air spring linearised at
rest (its stiffness there), Schaefer's harvest ``q E x`` (q at unit effort and stock), Michaelis-Menten without
its inhibitor (V and Km), a growth rate the same at every temperature or in every light (r at the reference
temperature, in saturating light), a uniform gravity (g at the surface). None of the laws is one kind of the term
list: a product of two saturations times a state, ``1/(x - b) - a/x^2``, an input times an exponential of it times
two states, Langevin's ``coth(z) - 1/z``, a power 1.4 of a ratio, a hinge to the power 1.5, fractional powers of
two states, ``sin`` of a difference of two states, an inverse square of a state; noncompetitive inhibition (a
Michaelis-Menten rate over ``1 + I/Ki``) has the form ``families/inhibited.py`` offers with discovery.

The systems use the identification benchmark's :class:`~identification.systems.System` and its simulation and
protocol (50 training and 20 test trajectories, noise as a share of each state's spread, function-space scores).
"""

from __future__ import annotations

from functools import partial

import numpy as np
import torch

from discovery.laws import law_system, on_component, pair_flux


# ------------------------------------------------------------------------------------------------ science models
def single_monod_f(v, u, D=0.25, mu=1.0, Ks=0.3, kla=0.8):
    """An aerated chemostat: Monod growth on the substrate ``S`` fed at ``u`` (two units of substrate and half a
    unit of oxygen per unit of biomass), oxygen ``O`` (a share of saturation) transferred at ``kla``; the substrate
    and biomass washed out at ``D``. The oxygen taken as never limiting."""
    s, o, x = v[:, 0], v[:, 1], v[:, 2]
    r = mu * s.clamp(min=0.0) * x / (Ks + s.clamp(min=0.0))
    return torch.stack([D * (u[:, 0] - s) - 2 * r, kla * (1 - o) - 0.5 * r, r - D * x], dim=-1)


def ideal_piston_f(v, nRT=1.0, F=1.0, c=0.4):
    """A piston (unit mass) on a gas column of length ``x``: the ideal gas's force ``nRT / x`` against the load
    ``F``, viscous damping ``c``."""
    x, w = v[:, 0], v[:, 1]
    return torch.stack([w, nRT / x.clamp(min=0.2) - F - c * w], dim=-1)


def linear_light_f(v, u, r=1.0, m=0.3):
    """A bloom: phytoplankton ``P`` taking up the nutrient ``N`` at ``r L N P``, linear in the light ``L = u``
    (its slope in dim light), and dying at ``m``."""
    n, p = v[:, 0], v[:, 1]
    uptake = r * u[:, 0] * n.clamp(min=0.0) * p
    return torch.stack([-uptake, uptake - m * p], dim=-1)


def curie_magnet_f(v, u, k=1.0, chi=1.0, g=0.8):
    """A magnetisation ``M`` relaxing at ``k`` to Curie's ``chi B`` in the field ``B`` of a coil, which follows the
    drive ``u`` at ``g``."""
    m, b = v[:, 0], v[:, 1]
    return torch.stack([k * (chi * b - m), g * (u[:, 0] - b)], dim=-1)


def linear_air_spring_f(v, k=1.4, c=0.2):
    """A mass on an air spring (displacement ``x`` compressing it), the spring linearised at rest, damped."""
    return torch.stack([v[:, 1], -k * v[:, 0] - c * v[:, 1]], dim=-1)


def falling_ball_f(v, g=1.0, c=0.1):
    """A ball (height ``x`` above a soft surface) in gravity and air damping; the surface not known."""
    return torch.stack([v[:, 1], -g - c * v[:, 1]], dim=-1)


def schaefer_fishery_f(v, r=1.0, K=4.0, q=1.0, s=0.5, p=1.0, c=1.2):
    """A fish stock ``x`` growing logistically, harvested at Schaefer's ``q E x``; the effort ``E`` growing with the
    profit, price ``p`` per catch and cost ``c`` per effort (open access)."""
    x, e = v[:, 0], v[:, 1]
    h = q * e * x
    return torch.stack([r * x * (1 - x / K) - h, s * (p * h - c * e)], dim=-1)


def michaelis_cleared_f(v, u, D=1.0, V=1.2, Km=0.5, a=0.3, d=0.25):
    """A flow reactor: substrate fed at ``u`` and converted by Michaelis-Menten, an inhibitor ``I`` fed at ``a``
    and cleared at ``d``; how the inhibitor acts not known."""
    s, i = v[:, 0], v[:, 1]
    rate = V * s.clamp(min=0.0) / (Km + s.clamp(min=0.0))
    return torch.stack([D * (u[:, 0] - s) - rate, a - d * i], dim=-1)


def crowded_growth_f(v, u, r=0.6, c=0.3, k=0.5):
    """A population growing at rate ``r`` and crowding, its temperature (in 10 K) relaxing to the water's ``u``;
    the growth rate taken as the same at every temperature."""
    x, t = v[:, 0], v[:, 1]
    return torch.stack([r * x - c * x ** 2, k * (u[:, 0] - t)], dim=-1)


def free_phases_f(v, w1=1.0, w2=1.6):
    """Two phase oscillators turning at their own frequencies; their coupling not known."""
    one = torch.ones_like(v[:, 0])
    return torch.stack([w1 * one, w2 * one], dim=-1)


def uniform_gravity_f(v, g=1.0):
    """A probe coasting up in a uniform gravity."""
    return torch.stack([v[:, 1], -g * torch.ones_like(v[:, 1])], dim=-1)


def grazed_algae_f(v, u, r=1.0, a=0.8, e=0.4, m=0.3):
    """Algae growing at rate ``r``, grazed by zooplankton; the light ``u`` not in the growth."""
    x, z = v[:, 0], v[:, 1]
    return torch.stack([r * x - a * x * z, e * a * x * z - m * z], dim=-1)


# controls: the science is the whole truth
def dual_monod_f(v, u, D=0.25, mu=1.0, Ks=0.3, kla=0.8, Ko=0.15):
    s, o, x = v[:, 0], v[:, 1], v[:, 2]
    sp, op = s.clamp(min=0.0), o.clamp(min=0.0)
    r = mu * sp * op * x / ((Ks + sp) * (Ko + op))
    return torch.stack([D * (u[:, 0] - s) - 2 * r, kla * (1 - o) - 0.5 * r, r - D * x], dim=-1)


def van_der_waals_piston_f(v, nRT=1.0, F=1.0, c=0.4, a=0.15, b=0.2):
    x, w = v[:, 0], v[:, 1]
    xc = x.clamp(min=0.2)
    return torch.stack([w, nRT / (xc - b) - a / xc ** 2 - F - c * w], dim=-1)


def coupled_phases_f(v, w1=1.0, w2=1.6, K=0.35):
    one = torch.ones_like(v[:, 0])
    pull = K * torch.sin(v[:, 1] - v[:, 0])
    return torch.stack([w1 * one + pull, w2 * one - pull], dim=-1)


# ------------------------------------------------------------------------------------------------------- effects
def _dual_monod(x, u):  # mu S O X / ((Ks + S)(Ko + O)) in place of mu S X / (Ks + S): mu = 1, Ks = 0.3, Ko = 0.15
    s, o, b = np.clip(x[:, 0], 0, None), np.clip(x[:, 1], 0, None), x[:, 2]
    extra = s * b / (0.3 + s) * (o / (0.15 + o) - 1)
    return np.stack([-2 * extra, -0.5 * extra, extra], axis=1)


def _van_der_waals(x, u):  # nRT / (x - b) - a / x^2 in place of nRT / x: nRT = 1, a = 0.15, b = 0.2
    length = x[:, 0]
    return on_component(1, 2, 1.0 / (length - 0.2) - 0.15 / length ** 2 - 1.0 / length)


def _steele(x, u):  # r L N P exp(-L/3) in place of r L N P (Steele, a peak at L = 3): r = 1
    light = u[:, 0]
    return pair_flux(1.0 * light * np.clip(x[:, 0], 0, None) * x[:, 1] * (np.exp(-light / 3.0) - 1))


def _langevin(z):
    """coth(z) - 1/z, its series z/3 - z^3/45 near zero."""
    small = np.abs(z) < 1e-3
    safe = np.where(small, 1.0, z)
    return np.where(small, z / 3 - z ** 3 / 45, 1 / np.tanh(safe) - 1 / safe)


def _langevin_magnet(x, u):  # Ms L(B/b) in place of chi B, Ms = 3 b chi: k = 1, chi = 1, b = 0.5
    b = x[:, 1]
    return on_component(0, 2, 1.0 * (1.5 * _langevin(b / 0.5) - 1.0 * b))


def _air_spring(x, u):  # -p0 A ((L/(L - x))^1.4 - 1) in place of -k x, k = 1.4 p0 A / L: p0 A = 1, L = 1
    d = x[:, 0]
    return on_component(1, 2, -((1 / (1 - d)) ** 1.4 - 1 - 1.4 * d))


def _hertz(x, u):  # a soft surface's push 40 max(0, -x)^1.5
    return on_component(1, 2, 40.0 * np.clip(-x[:, 0], 0, None) ** 1.5)


def _cobb_douglas(x, u):  # q E^0.6 x^0.8 in place of q E x: q = 1, s p = 0.5
    stock, e = np.clip(x[:, 0], 0, None), np.clip(x[:, 1], 0, None)
    return pair_flux(1.0 * (e ** 0.6 * stock ** 0.8 - e * stock), 0.5)


def _noncompetitive(x, u):  # V S / ((Km + S)(1 + I/Ki)) in place of V S / (Km + S): V = 1.2, Km = 0.5, Ki = 2
    s, i = np.clip(x[:, 0], 0, None), x[:, 1]
    return on_component(0, 2, 1.2 * s / (0.5 + s) * (1 - 1 / (1 + i / 2.0)))


def _q10(x, u):  # r x exp(q (T - T0)) in place of r x: r = 0.6, q = 0.35 (Q10 = 1.42), T0 = 2 (20 C)
    return on_component(0, 2, 0.6 * x[:, 0] * (np.exp(0.35 * (x[:, 1] - 2.0)) - 1))


def _kuramoto(x, u):
    pull = 0.35 * np.sin(x[:, 1] - x[:, 0])
    return np.stack([pull, -pull], axis=1)


def _inverse_square(x, u):  # g / (1 + h/R)^2 in place of g: g = 1, R = 3
    return on_component(1, 2, 1.0 * (1 - 1 / (1 + x[:, 0] / 3.0) ** 2))


def _light(x, u):  # r x L / (KL + L) in place of r x: r = 1, KL = 0.3
    light = u[:, 0]
    return on_component(0, 2, 1.0 * x[:, 0] * (light / (0.3 + light) - 1))


_system = partial(law_system, batch=21)


AERATED = {"S": "g/L", "O": "1", "X": "g/L", "u": "g/L"}
PISTON = {"x": "m", "v": "m/s"}
PHASES = {"theta1": "rad", "theta2": "rad"}
LAWS_4 = [
    _system("dual_substrate_monod", "bioprocess", "product of two saturations times a state, in place of one",
            "growth S O X / ((0.3 + S)(0.15 + O)) in place of Monod S X / (0.3 + S) (oxygen O also limits)",
            single_monod_f, {"D": 0.25, "mu": 1.0, "Ks": 0.3, "kla": 0.8}, _dual_monod, ["S", "O", "X"], AERATED,
            0.4, 30, (0.5, 0.3, 0.2), (3.0, 1.0, 1.5), (1.0, 4.0)),
    _system("van_der_waals_piston", "thermodynamics", "1/(x - b) - a/x^2, in place of 1/x",
            "gas force 1 / (x - 0.2) - 0.15 / x^2 (van der Waals) in place of the ideal 1 / x", ideal_piston_f,
            {"nRT": 1.0, "F": 1.0, "c": 0.4}, _van_der_waals, ["x", "v"], PISTON, 0.2, 30, (0.6, -0.5),
            (1.6, 0.5), zero=[0]),
    _system("steele_photoinhibition", "plankton ecology", "input times an exponential of it times two states",
            "uptake L N P exp(-L/3) (Steele: a peak at L = 3) in place of L N P in the light L = u", linear_light_f,
            {"r": 1.0, "m": 0.3}, _steele, ["N", "P"], {"N": "mmol N/m3", "P": "mmol N/m3", "u": "100 W/m2"},
            0.25, 30, (0.5, 0.05), (2.5, 0.5), (0.0, 3.0)),
    _system("langevin_magnet", "magnetism", "coth(z) - 1/z of a state (Langevin), in place of a linear law",
            "magnetisation 1.5 L(B/0.5) (Langevin) in place of Curie's B (chi = 1, the slope at zero field)",
            curie_magnet_f, {"k": 1.0, "chi": 1.0, "g": 0.8}, _langevin_magnet, ["M", "B"],
            {"M": "MA/m", "B": "T", "u": "T"}, 0.25, 30, (-1.0, -1.5), (1.0, 1.5), (-2.0, 2.0), zero=[1]),
    _system("adiabatic_air_spring", "pneumatics", "power 1.4 of a ratio, in place of its linearisation",
            "air spring -((1/(1 - x))^1.4 - 1) in place of -1.4 x (adiabatic, a column of length 1)",
            linear_air_spring_f, {"k": 1.4, "c": 0.2}, _air_spring, ["x", "v"], {"x": "m", "v": "m/s"}, 0.2, 30,
            (-0.35, -0.6), (0.35, 0.6), zero=[0]),
    _system("hertz_contact", "contact mechanics", "a hinge to the power 1.5 (Hertz)",
            "a soft surface's push 40 max(0, -x)^1.5 on a ball falling onto it", falling_ball_f,
            {"g": 1.0, "c": 0.1}, _hertz, ["x", "v"], {"x": "m", "v": "m/s"}, 0.1, 40, (0.3, -0.5), (1.5, 0.5),
            zero=[0]),
    _system("cobb_douglas_harvest", "fisheries", "fractional powers of two states, in place of their product",
            "harvest E^0.6 x^0.8 (Cobb-Douglas) in place of Schaefer's E x, the effort growing with the profit",
            schaefer_fishery_f, {"r": 1.0, "K": 4.0, "q": 1.0, "s": 0.5, "p": 1.0, "c": 1.2}, _cobb_douglas,
            ["x", "E"], {"x": "1", "E": "1"}, 0.3, 30, (0.5, 0.2), (3.0, 1.5)),
    _system("noncompetitive_inhibition", "biochemistry", "rational of two states, in place of Michaelis-Menten",
            "conversion 1.2 S / ((0.5 + S)(1 + I/2)) in place of 1.2 S / (0.5 + S), an inhibitor I fed and cleared",
            michaelis_cleared_f, {"D": 1.0, "V": 1.2, "Km": 0.5, "a": 0.3, "d": 0.25}, _noncompetitive, ["S", "I"],
            {"S": "mmol/L", "I": "mmol/L", "u": "mmol/L"}, 0.2, 30, (0.2, 0.0), (3.0, 2.5), (0.0, 4.0), zero=[1]),
    _system("q10_growth", "physiology", "state times an exponential of another, in place of a linear growth",
            "growth 0.6 x exp(0.35 (T - 2)) in place of 0.6 x (Q10 = 1.42 per 10 K about 20 C)", crowded_growth_f,
            {"r": 0.6, "c": 0.3, "k": 0.5}, _q10, ["x", "T"], {"x": "1", "T": "10 K", "u": "10 K"}, 0.3, 30,
            (0.1, 1.0), (1.5, 3.5), (1.0, 3.5), zero=[1]),
    _system("kuramoto_pair", "physics", "sin of a difference of two states",
            "coupling 0.35 sin(theta2 - theta1), + on theta1, - on theta2", free_phases_f, {"w1": 1.0, "w2": 1.6},
            _kuramoto, ["theta1", "theta2"], PHASES, 0.2, 30, (0.0, 0.0), (6.28, 6.28)),
    _system("inverse_square_gravity", "aerospace", "rational (inverse square of a state), in place of a constant",
            "gravity 1 / (1 + h/3)^2 in place of 1 (a planet of radius 3)", uniform_gravity_f, {"g": 1.0},
            _inverse_square, ["h", "v"], {"h": "1000 km", "v": "1000 km/s"}, 0.08, 30, (0.0, 1.0), (0.5, 1.8),
            zero=[0]),
    _system("light_limited_growth", "ecology", "state times a saturation of the input, in place of the state",
            "growth x L / (0.3 + L) in place of x in the light L = u", grazed_algae_f,
            {"r": 1.0, "a": 0.8, "e": 0.4, "m": 0.3}, _light, ["x", "z"],
            {"x": "mmol N/m3", "z": "mmol N/m3", "u": "100 W/m2"}, 0.25, 30, (0.2, 0.2), (1.5, 1.0), (0.3, 3.0),
            zero=[1]),
    # controls
    _system("control_dual_monod", "bioprocess", "control", "nothing (dual-substrate Monod growth written in)",
            dual_monod_f, {"D": 0.25, "mu": 1.0, "Ks": 0.3, "kla": 0.8, "Ko": 0.15}, None, ["S", "O", "X"], AERATED,
            0.4, 30, (0.5, 0.3, 0.2), (3.0, 1.0, 1.5), (1.0, 4.0)),
    _system("control_van_der_waals", "thermodynamics", "control", "nothing (the van der Waals gas written in)",
            van_der_waals_piston_f, {"nRT": 1.0, "F": 1.0, "c": 0.4, "a": 0.15, "b": 0.2}, None, ["x", "v"], PISTON,
            0.2, 30, (0.6, -0.5), (1.6, 0.5)),
    _system("control_kuramoto", "physics", "control", "nothing (the coupling written in)", coupled_phases_f,
            {"w1": 1.0, "w2": 1.6, "K": 0.35}, None, ["theta1", "theta2"], PHASES, 0.2, 30, (0.0, 0.0),
            (6.28, 6.28)),
]
