"""A fifth law-discovery batch: 12 effects outside the closed loop's term list, and 3 complete controls.

Written on 2026-12-07 for issue "Name the law, not a stand-in", after the first four batches (``laws.py``,
``laws_second.py``, ``laws_third.py``, ``laws_fourth.py``) had been seen: a test of the package as it stands
(``loop`` and the loop with discovery, ``DEFAULT_ARMS``) on laws none of the earlier batches holds, chosen as a
domain expert would. A first draft chose them blind to the term list; four of its laws had the list's kinds (the
powers of the theta-logistic, Peukert and Manning, the cubic of dominance) and were replaced, before the file was
committed, by laws of other fields outside it. Committed before any arm ran on it (the commit that adds this file
runs nothing); its author simulated the true systems only, to see that every trajectory stays finite, where the
states go and what share of its equation each law is.

Textbook laws of fields the other batches have and others (gas kinetics, epidemiology, vehicle dynamics,
structural engineering, heat transfer, pharmacology, soil physics, photochemistry, acoustics, physical
oceanography, electronics, polymer physics), two or three states each, the science model an engineer would write
first: it has the law's simplification, whose parameter the law keeps: a unimolecular rate at its high-pressure
limit (k, the Lindemann-Hinshelwood falloff's k_inf), mass-action incidence (beta, the rate at low prevalence),
linear tyres (Cf and Cr, the cornering stiffnesses at zero slip), an elastic storey (A, the Bouc-Wen stiffness
share at zero hysteretic displacement), a constant film coefficient (h at the reference flow), a constant unbound
fraction (ke and k12 at low concentration), infiltration at the saturated conductivity (Ks, Green-Ampt's rate once
the wetting front is deep), an optically thin solution with a transparent product (k, the photolysis rate at low
absorbance), Minnaert's linearised bubble (its stiffness 3 kappa at rest), a fixed exchange between two ocean boxes
(d, the exchange without a density difference), a linear inductor (L at zero flux), a Hookean dumbbell (k at
rest). None of the laws is one kind of the closed loop's term list (``diagnosis/terms.py``) or a sum of its kinds;
all are products and compositions it does not hold: a state times a saturation of a sum of states with a constant
(Lindemann), ``S log(1 + beta I / k)``, Pacejka's ``D sin(C arctan(B alpha))`` of a slip angle that sums two states
and the input, Bouc-Wen's ``-beta |w| z - gamma w |z|``, an input to the power 0.8 times a difference of two
states, the root of the quadratic binding equation, Green-Ampt's ``(psi + h) / F`` (a state and a constant over
another state), ``(1 - exp(-tau)) / tau`` of a sum of states times the input and a state (the inner filter),
Rayleigh-Plesset's ``(R^-k - 1 - u - c W/R - 1.5 W^2) / R``, Stommel's ``|T - S| (T, S)``, Froehlich's
``x |x| / (a - |x|)`` and Warner's ``x r^2 / (L^2 - r^2)`` with ``r`` the norm of two states.

The systems use the identification benchmark's :class:`~identification.systems.System` and its simulation and
protocol (50 training and 20 test trajectories, noise as a share of each state's spread, function-space scores).
"""

from __future__ import annotations

from functools import partial

import numpy as np
import torch

from discovery.laws import law_system, on_component, pair_flux, vital_sir_f


# ------------------------------------------------------------------------------------------------ science models
def high_pressure_reactor_f(v, u, D=0.5, k=1.0):
    """A gas-phase flow reactor: ``A`` fed at ``u`` decomposing to two ``P`` at ``k A``, the unimolecular rate at its
    high-pressure limit (taken to hold at every pressure), both washed out at ``D``."""
    a, p = v[:, 0], v[:, 1]
    r = k * a
    return torch.stack([D * (u[:, 0] - a) - r, 2 * r - D * p], dim=-1)


def linear_tyres_f(v, u, Cf=55.0, Cr=65.0, U=20.0, a=1.1, b=1.5, k2=1.6):
    """A car at the speed ``U`` steered by the road-wheel angle ``u``: its lateral velocity ``vy`` and yaw rate ``r``
    (the single-track model per unit mass, the centre of mass ``a`` behind the front axle and ``b`` ahead of the
    rear, ``k2`` = Iz / m), each axle's side force linear in its slip angle, ``Cf`` and ``Cr`` the cornering
    stiffnesses."""
    vy, r = v[:, 0], v[:, 1]
    front = Cf * (u[:, 0] - (vy + a * r) / U)
    rear = Cr * (b * r - vy) / U
    return torch.stack([front + rear - U * r, (a * front - b * rear) / k2], dim=-1)


def elastic_storey_f(v, u, k=4.0, a=0.1, c=0.3, A=1.0):
    """A storey (drift ``x``, its rate ``w``) on a shaking ground of acceleration ``u``: the restoring force
    ``a k x + (1 - a) k z``, a hysteretic displacement ``z`` taken as elastic (``dz/dt = A w``, ``A`` the initial
    stiffness's share), viscous damping ``c``."""
    x, w, z = v[:, 0], v[:, 1], v[:, 2]
    return torch.stack([w, -a * k * x - (1 - a) * k * z - c * w - u[:, 0], A * w], dim=-1)


def fixed_film_channel_f(v, u, P=1.0, h=0.8, a=1.0, c=0.5):
    """A heated wall ``Tw`` cooled by the coolant ``Tf`` in its channel (temperatures above the inlet's), the coolant
    renewed by the flow ``u``; the film coefficient ``h`` taken as the same at every flow."""
    tw, tf = v[:, 0], v[:, 1]
    q = h * (tw - tf)
    return torch.stack([P - q, c * q - a * u[:, 0] * tf], dim=-1)


def constant_unbound_f(v, u, ke=0.5, k12=0.3, k21=0.2):
    """A drug infused at ``u`` into plasma (total concentration ``C``), eliminated at ``ke C`` and distributed to a
    tissue ``Ct`` at ``k12 C``: the unbound fraction taken as the same at every concentration."""
    c, ct = v[:, 0], v[:, 1]
    return torch.stack([u[:, 0] - (ke + k12) * c + k21 * ct, k12 * c - k21 * ct], dim=-1)


def steady_infiltration_f(v, u, Ks=1.1, c=2.0):
    """A ponded basin: water supplied at ``u`` onto the ponded depth ``h``, spilling over its bund at ``c h`` and
    infiltrating into the soil (infiltrated depth ``F``) at the saturated conductivity ``Ks``, the rate once the
    wetting front is deep."""
    one = torch.ones_like(v[:, 0])
    return torch.stack([u[:, 0] - c * v[:, 0] - Ks * one, Ks * one], dim=-1)


def thin_photolysis_f(v, u, D=0.3, Ain=2.0, k=0.8):
    """A flow photoreactor: ``A`` fed at ``Ain`` and photolysed to ``B`` at ``k u A`` in the lamp's intensity ``u``
    (an optically thin solution, the product transparent), both washed out at ``D``."""
    a, b = v[:, 0], v[:, 1]
    r = k * u[:, 0] * a
    return torch.stack([D * (Ain - a) - r, r - D * b], dim=-1)


def minnaert_bubble_f(v, u, k=4.2, c=0.3):
    """A gas bubble (radius ``R`` in units of its rest radius, wall speed ``W``) in a sound field of pressure ``u``
    (in units of the ambient): Minnaert's oscillator linearised at rest, stiffness ``k`` (3 kappa), damping ``c``."""
    r, w = v[:, 0], v[:, 1]
    return torch.stack([w, -k * (r - 1) - u[:, 0] - c * w], dim=-1)


def mixed_boxes_f(v, u, lam=2.0, Ta=1.0, mu=1.0, d=0.1):
    """Two ocean boxes, equator and pole: their differences of temperature ``T`` and of salinity ``S`` (each as the
    density difference it makes, in units of the thermal one's scale), relaxed by the surface to the atmosphere's
    ``Ta`` at ``lam`` and to the surface contrast ``u`` at ``mu``, and exchanged between the boxes at a fixed rate
    ``d`` (the exchange without a density difference); no overturning circulation."""
    t, s = v[:, 0], v[:, 1]
    return torch.stack([lam * (Ta - t) - d * t, mu * (u[:, 0] - s) - d * s], dim=-1)


def linear_inductor_f(v, u, L=1.0, R=0.5, C=1.0):
    """A series circuit driven by the voltage ``u``: an inductor of flux linkage ``psi`` (current ``psi / L``, a
    linear core), a resistance ``R`` and a capacitor of voltage ``vc``."""
    psi, vc = v[:, 0], v[:, 1]
    i = psi / L
    return torch.stack([u[:, 0] - R * i - vc, i / C], dim=-1)


def hookean_dumbbell_f(v, u, k=0.5):
    """A polymer dumbbell's end-to-end vector ``(x, y)`` (in units of its coil size) in a planar elongational flow of
    rate ``u``, pulled back by a Hookean spring ``k`` (overdamped)."""
    x, y = v[:, 0], v[:, 1]
    return torch.stack([u[:, 0] * x - k * x, -u[:, 0] * y - k * y], dim=-1)


# controls: the science is the whole truth
def falloff_reactor_f(v, u, D=0.5, k=1.0, Mh=1.0, Mi=2.0):
    a, p = v[:, 0], v[:, 1]
    m = (a + p).clamp(min=0.0) + Mi
    r = k * a * m / (Mh + m)
    return torch.stack([D * (u[:, 0] - a) - r, 2 * r - D * p], dim=-1)


def bound_drug_f(v, u, ke=0.5, k12=0.3, k21=0.2, B=5.0, Kd=1.0):
    c, ct = v[:, 0], v[:, 1]
    cp = c.clamp(min=0.0)
    s = cp - B - Kd
    free = 2 * Kd * cp / (torch.sqrt(s ** 2 + 4 * Kd * cp) - s)  # the root of the binding equation, written stably
    scale = (Kd + B) / Kd  # over the unbound fraction at low concentration
    return torch.stack([u[:, 0] - (ke + k12) * scale * free + k21 * ct, k12 * scale * free - k21 * ct], dim=-1)


def rayleigh_plesset_f(v, u, k=4.2, c=0.3):
    r, w = v[:, 0], v[:, 1]
    rc = r.clamp(min=0.2)
    return torch.stack([w, (rc ** -k - 1 - u[:, 0] - c * w / rc - 1.5 * w ** 2) / rc], dim=-1)


# ------------------------------------------------------------------------------------------------------- effects
def _lindemann(x, u):  # k A M / (Mh + M) in place of k A, M = A + P + Mi: k = 1, Mh = 1, Mi = 2
    a, m = x[:, 0], np.clip(x[:, 0] + x[:, 1], 0, None) + 2.0
    return pair_flux(1.0 * a * (m / (1.0 + m) - 1), 2.0)


def _negative_binomial(x, u):  # k S log(1 + beta I / k) in place of beta S I (May): beta = 2, k = 1.5
    s, i = np.clip(x[:, 0], 0, None), np.clip(x[:, 1], 0, None)
    extra = 1.5 * s * np.log1p(2.0 * i / 1.5) - 2.0 * s * i
    return np.stack([-extra, extra, np.zeros_like(s)], axis=1)


def _magic_formula(alpha, stiffness, peak, C=1.3):
    """Pacejka's side force ``D sin(C arctan(B alpha))`` (E = 0) less the linear ``stiffness alpha``: ``B C D`` is
    the stiffness, the slope at zero slip."""
    return peak * np.sin(C * np.arctan(stiffness / (C * peak) * alpha)) - stiffness * alpha


def _pacejka(x, u):  # the magic formula in place of linear tyres: Cf = 55, Cr = 65, peaks 0.8 g b/L and 0.8 g a/L
    vy, r = x[:, 0], x[:, 1]
    front = _magic_formula(u[:, 0] - (vy + 1.1 * r) / 20.0, 55.0, 4.53)
    rear = _magic_formula((1.5 * r - vy) / 20.0, 65.0, 3.32)
    return np.stack([front + rear, (1.1 * front - 1.5 * rear) / 1.6], axis=1)


def _bouc_wen(x, u):  # A w - beta |w| z - gamma w |z| in place of A w (Bouc-Wen, n = 1): A = 1, beta = 0.6, gamma = 0.4
    w, z = x[:, 1], x[:, 2]
    return on_component(2, 3, -0.6 * np.abs(w) * z - 0.4 * w * np.abs(z))


def _dittus_boelter(x, u):  # h u^0.8 (Tw - Tf) in place of h (Tw - Tf): h = 0.8, c = 0.5
    flow = np.clip(u[:, 0], 0, None)
    return pair_flux(0.8 * (flow ** 0.8 - 1) * (x[:, 0] - x[:, 1]), 0.5)


def _unbound(c, B=5.0, Kd=1.0):
    """The unbound concentration at the total ``c``: the root of ``f^2 + (B + Kd - c) f - Kd c = 0``."""
    c = np.clip(c, 0, None)
    s = c - B - Kd
    return 2 * Kd * c / (np.sqrt(s ** 2 + 4 * Kd * c) - s)


def _protein_binding(x, u):  # (ke, k12) f(C) / fu0 in place of (ke, k12) C, fu0 = Kd / (Kd + B): B = 5, Kd = 1
    extra = _unbound(x[:, 0]) * 6.0 - x[:, 0]
    return np.stack([-(0.5 + 0.3) * extra, 0.3 * extra], axis=1)


def _green_ampt(x, u):  # Ks (1 + (psi + h) dtheta / F) in place of Ks: Ks = 1.1, psi = 11 cm, dtheta = 0.3
    h, depth = np.clip(x[:, 0], 0, None), x[:, 1]
    return pair_flux(1.1 * (11.0 + h) * 0.3 / depth)


def _inner_filter(x, u):  # k u A (1 - exp(-tau)) / tau, tau = 0.25 A + 0.15 B, in place of k u A: k = 0.8
    a, b = x[:, 0], np.clip(x[:, 1], 0, None)
    tau = np.clip(0.25 * a + 0.15 * b, 1e-9, None)
    return pair_flux(0.8 * u[:, 0] * a * (-np.expm1(-tau) / tau - 1))


def _rayleigh_plesset(x, u):  # Rayleigh-Plesset in place of Minnaert's linearisation: k = 4.2, c = 0.3
    r, w, p = x[:, 0], x[:, 1], u[:, 0]
    truth = (r ** -4.2 - 1 - p - 0.3 * w / r - 1.5 * w ** 2) / r
    return on_component(1, 2, truth - (-4.2 * (r - 1) - p - 0.3 * w))


def _stommel(x, u):  # exchange d + k |T - S| in place of d (Stommel's overturning k |T - S|): d = 0.1, k = 0.5
    flow = 0.5 * np.abs(x[:, 0] - x[:, 1])
    return -flow[:, None] * x


def _froehlich(x, u):  # current psi / (L (1 - |psi|/2.5)) in place of psi / L (Froehlich): L = 1, R = 0.5, C = 1
    psi = x[:, 0]
    extra = psi * np.abs(psi) / (2.5 - np.abs(psi))
    return np.stack([-0.5 * extra, extra / 1.0], axis=1)


def _warner(x, u):  # -k (x, y) / (1 - r^2/L^2) in place of -k (x, y) (FENE, Warner): k = 0.5, L = 3
    r2 = x[:, 0] ** 2 + x[:, 1] ** 2
    return -0.5 * x * (r2 / (9.0 - r2))[:, None]


_system = partial(law_system, batch=22)


GAS = {"A": "mol/m3", "P": "mol/m3", "u": "mol/m3"}
DRUG = {"C": "mg/L", "Ct": "mg/L", "u": "mg/L/h"}
BUBBLE = {"R": "10 um", "W": "10 um/us", "u": "100 kPa"}
LAWS_5 = [
    _system("lindemann_falloff", "gas kinetics", "state times a saturation of a sum of states, in place of the state",
            "decomposition A M / (1 + M), M = A + P + 2 (Lindemann-Hinshelwood falloff), in place of the "
            "high-pressure limit A", high_pressure_reactor_f, {"D": 0.5, "k": 1.0}, _lindemann, ["A", "P"], GAS,
            0.25, 30, (0.3, 0.0), (2.5, 1.5), (0.5, 3.0)),
    _system("negative_binomial_incidence", "epidemiology", "state times log(1 + a state), in place of a product",
            "incidence 1.5 S log(1 + 2 I / 1.5) (May's clumped infection) in place of mass action 2 S I",
            vital_sir_f, {"beta": 2.0, "gamma": 0.5, "mu": 0.1}, _negative_binomial, ["S", "I", "R"],
            {"S": "1", "I": "1", "R": "1"}, 0.3, 30, (0.4, 0.02, 0.0), (0.95, 0.3, 0.3), zero=[2]),
    _system("pacejka_cornering", "vehicle dynamics", "sin(C arctan(B a)) of a sum of two states and the input, "
            "in place of the sum", "side forces D sin(1.3 arctan(B alpha)) (Pacejka's magic formula, E = 0, B C D the "
            "cornering stiffness, peaks D 4.53 front and 3.32 rear) in place of 55 and 65 alpha, alpha the slip angles "
            "u - (vy + 1.1 r)/20 and (1.5 r - vy)/20", linear_tyres_f, {"Cf": 55.0, "Cr": 65.0}, _pacejka,
            ["vy", "r"], {"vy": "m/s", "r": "rad/s", "u": "rad"}, 0.05, 30, (-1.0, -0.4), (1.0, 0.4),
            (-0.1, 0.1)),
    _system("bouc_wen_hysteresis", "structural engineering", "products of a state and the absolute value of "
            "another, in place of a linear law", "hysteresis dz/dt = w - 0.6 |w| z - 0.4 w |z| (Bouc-Wen, n = 1) in "
            "place of the elastic w", elastic_storey_f, {"k": 4.0, "a": 0.1, "c": 0.3, "A": 1.0}, _bouc_wen,
            ["x", "w", "z"], {"x": "cm", "w": "cm/s", "z": "cm", "u": "cm/s2"}, 0.2, 30, (-0.5, -0.5, -0.3),
            (0.5, 0.5, 0.3), (-3.0, 3.0), zero=[0, 1]),
    _system("dittus_boelter_cooling", "heat transfer", "an input to the power 0.8 times a difference of two states",
            "film coefficient 0.8 u^0.8 (Dittus-Boelter) in place of 0.8 at every flow u", fixed_film_channel_f,
            {"P": 1.0, "h": 0.8, "a": 1.0, "c": 0.5}, _dittus_boelter, ["Tw", "Tf"],
            {"Tw": "10 K", "Tf": "10 K", "u": "m/s"}, 0.15, 30, (0.2, 0.0), (3.5, 1.5), (0.6, 1.6)),
    _system("saturable_protein_binding", "pharmacology", "root of a quadratic in a state, in place of the state",
            "unbound drug 6 f(C), f the root of f^2 + (6 - C) f - C = 0 (binding capacity 5, Kd 1), in place of C "
            "in elimination and distribution", constant_unbound_f, {"ke": 0.5, "k12": 0.3, "k21": 0.2},
            _protein_binding, ["C", "Ct"], DRUG, 0.3, 30, (0.2, 0.0), (2.0, 1.0), (0.0, 1.0)),
    _system("green_ampt_infiltration", "soil physics", "a sum of a state and a constant over another state, in "
            "place of a constant", "infiltration 1.1 (1 + 0.3 (11 + h) / F) (Green-Ampt, suction 11 cm, moisture "
            "deficit 0.3) in place of the saturated conductivity 1.1", steady_infiltration_f, {"Ks": 1.1, "c": 2.0},
            _green_ampt, ["h", "F"], {"h": "cm", "F": "cm", "u": "cm/h"}, 0.1, 30, (0.0, 3.0), (6.0, 8.0),
            (2.5, 10.0)),
    _system("inner_filter_photolysis", "photochemistry", "(1 - exp(-tau)) / tau of a sum of states times input and "
            "state", "photolysis 0.8 u A (1 - exp(-tau)) / tau, tau = 0.25 A + 0.15 B (Beer-Lambert, the product "
            "absorbing), in place of 0.8 u A", thin_photolysis_f, {"D": 0.3, "Ain": 2.0, "k": 0.8}, _inner_filter,
            ["A", "B"], {"A": "mmol/L", "B": "mmol/L", "u": "10 mW/cm2"}, 0.25, 30, (0.3, 0.0), (2.5, 1.5),
            (0.2, 2.0)),
    _system("rayleigh_plesset_bubble", "acoustics", "powers and ratios of two states and the input, in place of a "
            "linear law", "wall acceleration (R^-4.2 - 1 - u - 0.3 W/R - 1.5 W^2) / R (Rayleigh-Plesset) in place of "
            "-4.2 (R - 1) - u - 0.3 W", minnaert_bubble_f, {"k": 4.2, "c": 0.3}, _rayleigh_plesset, ["R", "W"],
            BUBBLE, 0.15, 30, (0.8, -0.3), (1.25, 0.3), (-0.4, 0.4), zero=[0]),
    _system("stommel_overturning", "physical oceanography", "each state times the absolute difference of two",
            "exchange at 0.1 + 0.5 |T - S| of both differences (Stommel's thermohaline overturning 0.5 |T - S|) in "
            "place of the fixed 0.1", mixed_boxes_f, {"lam": 2.0, "Ta": 1.0, "mu": 1.0, "d": 0.1}, _stommel, ["T", "S"],
            {"T": "1", "S": "1", "u": "1"}, 0.2, 30, (0.0, 0.0), (2.0, 2.0), (0.0, 2.0)),
    _system("froehlich_inductor", "electronics", "x |x| / (a - |x|) of a state, in place of the state",
            "current psi / (1 - |psi|/2.5) (Froehlich's saturating core) in place of psi", linear_inductor_f,
            {"L": 1.0, "R": 0.5, "C": 1.0}, _froehlich, ["psi", "vc"], {"psi": "Wb", "vc": "V", "u": "V"}, 0.2, 30,
            (-1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)),
    _system("fene_dumbbell", "polymer physics", "states times r^2 / (L^2 - r^2), r the norm of two states",
            "spring -0.5 (x, y) / (1 - r^2/9) (FENE, Warner) in place of Hookean -0.5 (x, y)", hookean_dumbbell_f,
            {"k": 0.5}, _warner, ["x", "y"], {"x": "1", "y": "1", "u": "1/s"}, 0.2, 30, (-1.2, -1.2), (1.2, 1.2),
            (0.0, 0.9)),
    # controls
    _system("control_lindemann_falloff", "gas kinetics", "control", "nothing (the falloff written in)",
            falloff_reactor_f, {"D": 0.5, "k": 1.0, "Mh": 1.0, "Mi": 2.0}, None, ["A", "P"], GAS, 0.25, 30,
            (0.3, 0.0), (2.5, 1.5), (0.5, 3.0)),
    _system("control_protein_binding", "pharmacology", "control", "nothing (saturable binding written in)",
            bound_drug_f, {"ke": 0.5, "k12": 0.3, "k21": 0.2, "B": 5.0, "Kd": 1.0}, None, ["C", "Ct"], DRUG, 0.3,
            30, (0.2, 0.0), (2.0, 1.0), (0.0, 1.0)),
    _system("control_rayleigh_plesset", "acoustics", "control", "nothing (the Rayleigh-Plesset equation written in)",
            rayleigh_plesset_f, {"k": 4.2, "c": 0.3}, None, ["R", "W"], BUBBLE, 0.15, 30, (0.8, -0.3), (1.25, 0.3),
            (-0.4, 0.4)),
]
