"""A sixth law-discovery batch: 16 effects outside the closed loop's term list, and 4 complete controls.

Written on 2026-12-08 for issue "Name the law, not a stand-in", after the first five batches (``laws.py``,
``laws_second.py``, ``laws_third.py``, ``laws_fourth.py``, ``laws_fifth.py``) had been seen: a test of the package
as it stands (``loop`` and the loop with discovery, ``DEFAULT_ARMS``) on laws none of the earlier batches holds,
chosen as a domain expert would, at least two from each of enzyme kinetics, epidemiology, ecology and population
biology, mechanics, electrochemistry and electronics, and heat transfer, and one from each of hydrology,
pharmacology, atmospheric physics and optics. Committed before any arm ran on it (the commit that adds this file
runs nothing); its author simulated the true systems only, to see that every trajectory stays finite, where the
states go and what share of its equation each law is. The laws' constants and the states' ranges were set in that
simulation, so that each effect is 14 % to 43 % of its equation's RMS on the visited states (the first constants
chosen made several laws all or more of their equations, near a steady state where the science's terms cancel).

Two to three states each, the science model an engineer would write first: it has the law's simplification, whose
parameter the law keeps, or lacks the law: Michaelis-Menten in one substrate, the co-substrate taken as in excess
(V and Ka, the ping-pong bi-bi rate's as the co-substrate grows), an irreversible Michaelis-Menten (V and Ks, the
reversible rate's without product), Gammaitoni-Nucci's incidence ``beta S I / u`` (Wells-Riley at a low dose,
beta kept), a dose-response linear in the pathogen (rho, the Beta-Poisson's low-dose slope), Holling's type II (a
and h, Hassell-Varley's at one predator), a growth rate the same at every temperature (r, Ratkowsky's at 25 C),
Hertz's elastic contact without dissipation (Hunt-Crossley's damping added), a constant air-film damping (c, the
squeeze film's at the rest gap), Tafel's kinetics (k0 and alpha, the Koutecky-Levich current's kinetic part), a
fixed capacitance (Cb, the varactor's at its bias), a coolant taken as at the buffer's temperature along the whole
coil (UA, the effectiveness-NTU's limit at a large flow), a pad that does not evaporate (Dalton's evaporation
added), a saturated area linear in the soil's store (Wm, the ARNO curve's capacity), an absorption blind to the pH
(ka, the rate at pH 6.5), neutral bulk heat transfer (C, Louis' at Ri = 0), a cold cavity's fixed detuning (c, the
pump's coupling). None of the laws is one kind of the closed loop's term list (``diagnosis/terms.py``) or a sum of
its kinds; all are products, ratios and compositions of several states, constants and the input: ping-pong's
``V A B / (Kb A + Ka B + A B)``, the reversible ``(V S/Ks - Vr P/Kp) / (1 + S/Ks + P/Kp)``, Wells-Riley's
``S (1 - exp(-beta tau I / u)) / tau``, Beta-Poisson's ``S (1 - (1 + W/b)^-alpha)``, Hassell-Varley's
``a x y / (y^m + a h x)``, Ratkowsky's ``((T - Tmin)(1 - exp(c (T - Tmax))))^2`` scaling a logistic growth,
Hunt-Crossley's ``d^1.5 w``, the squeeze film's ``w / h^3``, Koutecky-Levich's ``c e^eta / (1 + k0 e^eta / m)``,
the varactor's ``i sqrt((phi + V) / (phi + Vb))``, effectiveness-NTU's ``u (1 - exp(-UA/u)) (Th - Tc)``, Dalton's
``(1 + 0.54 u)(es(T) - e)`` with Magnus' ``es = exp(a T / (b + T))``, the ARNO curve's ``u (1 - (1 - W/Wm)^0.75)``,
Henderson-Hasselbalch's ``A / (1 + 10^(u - pKa))``, Louis' ``U dT / (1 + 4.7 b dT / U^2)^2`` and the thermo-optic
``u / (1 + (D - k theta)^2)``. One of them, the squeeze film's ``c w / h^3``, is a science term scaled by a power of
a variable of one sign, the form the loop's discovery offers since 48e2264 (kind 'modulated', ``T |x|^p``); it is
kept, as the law an expert would name for a plate on an air film. Ratkowsky's factor stays near its optimum over
the temperatures visited (23 to 38 C), where it is close to a quadratic in T: a science term times a quadratic in T
leaves 17 % of the effect.

The systems use the identification benchmark's :class:`~identification.systems.System` and its simulation and
protocol (50 training and 20 test trajectories, noise as a share of each state's spread, function-space scores).
"""

from __future__ import annotations

from functools import partial

import numpy as np
import torch

from discovery.laws import law_system, on_component, pair_flux


# ------------------------------------------------------------------------------------------------ science models
def michaelis_bisubstrate_f(v, u, D=0.5, V=1.5, Ka=0.4, Bin=2.0):
    """An enzyme reactor: the substrate ``A`` fed at ``u`` and the co-substrate ``B`` at ``Bin``, converted to ``P``
    at Michaelis-Menten's ``V A / (Ka + A)``, the co-substrate taken as in excess; everything washed out at ``D``."""
    a, b, p = v[:, 0], v[:, 1], v[:, 2]
    ap = a.clamp(min=0.0)
    r = V * ap / (Ka + ap)
    return torch.stack([D * (u[:, 0] - a) - r, D * (Bin - b) - r, r - D * p], dim=-1)


def irreversible_enzyme_f(v, u, D=0.5, V=1.2, Ks=0.5):
    """An enzyme reactor: the substrate ``S`` fed at ``u`` and converted to ``P`` at Michaelis-Menten's
    ``V S / (Ks + S)``, taken as irreversible (the product neither binds nor turns back); both washed out at ``D``."""
    s, p = v[:, 0], v[:, 1]
    sp = s.clamp(min=0.0)
    r = V * sp / (Ks + sp)
    return torch.stack([D * (u[:, 0] - s) - r, r - D * p], dim=-1)


def gammaitoni_nucci_f(v, u, beta=3.0, gamma=0.5, w=0.15):
    """Airborne infection in a building ventilated at ``u`` air changes (in units of the reference): the
    Gammaitoni-Nucci incidence ``beta S I / u`` (Wells-Riley at a low dose of quanta), recovery ``gamma``, the
    recovered losing their immunity at ``w``."""
    s, i = v[:, 0], v[:, 1]
    inc = beta * s.clamp(min=0.0) * i.clamp(min=0.0) / u[:, 0]
    return torch.stack([w * (1 - s - i) - inc, inc - gamma * i], dim=-1)


def exponential_dose_f(v, rho=0.8, gamma=0.5, mu=0.05, xi=2.0, delta=0.6):
    """Cholera with a water reservoir: infection at ``rho S W``, the dose-response linear in the pathogen's
    concentration ``W`` (``rho`` its low-dose slope), recovery ``gamma``, births and deaths ``mu``, the infected
    shedding into the water at ``xi``, the pathogen decaying at ``delta``."""
    s, i, w = v[:, 0], v[:, 1], v[:, 2]
    inc = rho * s.clamp(min=0.0) * w.clamp(min=0.0)
    return torch.stack([mu * (1 - s) - inc, inc - (gamma + mu) * i, xi * i - delta * w], dim=-1)


def handling_prey_f(v, r=1.0, K=3.0, a=1.2, h=0.6, e=0.5, m=0.4):
    """Prey growing logistically, eaten at Holling's type II ``a x y / (1 + a h x)`` (``a`` the attack rate, ``h``
    the handling time), half converted to predators, which die at ``m``."""
    x, y = v[:, 0], v[:, 1]
    xp = x.clamp(min=0.0)
    eaten = a * xp * y / (1 + a * h * xp)
    return torch.stack([r * x * (1 - x / K) - eaten, e * eaten - m * y], dim=-1)


def isothermal_growth_f(v, u, r=0.8, K=2.0, k=0.6):
    """Bacteria (``x``, in units of 1e8 cells/g) growing logistically in a food whose temperature ``T`` (in 10 C)
    follows the store's ``u`` at ``k``; the growth rate ``r`` taken as its value at 25 C at every temperature."""
    x, t = v[:, 0], v[:, 1]
    return torch.stack([r * x * (1 - x / K), k * (u[:, 0] - t)], dim=-1)


def hertz_pad_f(v, u, k=1.0, c=0.1, g=1.0):
    """A mass resting on a rubber pad (indentation ``d``, its rate ``w``) in gravity ``g`` and under the force
    ``u``: Hertz's elastic contact ``k d^1.5`` and a light air damping ``c``."""
    d, w = v[:, 0], v[:, 1]
    return torch.stack([w, g + u[:, 0] - k * d.clamp(min=0.0) ** 1.5 - c * w], dim=-1)


def viscous_plate_f(v, u, k=3.0, c=0.5):
    """A MEMS plate (gap ``h`` in units of its rest gap, speed ``w``) on its suspension ``k`` under the inertial
    force ``u``, the air film's damping taken as a constant ``c`` (its value at the rest gap)."""
    h, w = v[:, 0], v[:, 1]
    return torch.stack([w, -k * (h - 1) - c * w + u[:, 0]], dim=-1)


def tafel_cell_f(v, u, k0=0.5, alpha=1.0, q=0.5, s=0.1):
    """An electrode driven by the current ``u``: its double layer's overpotential ``eta`` discharged by the
    Faradaic current ``k0 c exp(alpha eta)`` (Tafel, the transfer of charge the only limit), consuming the
    reactant ``c`` that the flow renews at ``q``."""
    eta, c = v[:, 0], v[:, 1]
    i = k0 * c * torch.exp(alpha * eta)
    return torch.stack([u[:, 0] - i, q * (1 - c) - s * i], dim=-1)


def fixed_capacitor_f(v, u, L=1.0, R=0.4, Cb=1.0):
    """A series circuit driven by the voltage ``u``: an inductor (current ``i``), a resistance ``R`` and a varactor
    (voltage ``V``) taken as a fixed capacitance ``Cb``, its value at the bias 1 V."""
    i, vc = v[:, 0], v[:, 1]
    return torch.stack([(u[:, 0] - R * i - vc) / L, i / Cb], dim=-1)


def ideal_exchanger_f(v, u, P=0.3, UA=0.6, c=0.5, l=0.4):
    """A heated tank ``Th`` cooled through a coil whose coolant comes from a buffer tank ``Tc`` at the capacity rate
    ``u``: the heat removed ``UA (Th - Tc)`` (the coolant's temperature taken as ``Tc`` along the whole coil, the
    limit of a large flow), the buffer losing heat at ``l``."""
    th, tc = v[:, 0], v[:, 1]
    q = UA * (th - tc)
    return torch.stack([P - q, c * q - l * tc], dim=-1)


def dry_surface_f(v, u, S=0.3, h=0.5, ve=1.0, Ta=2.5, e0=1.0):
    """A wet pad (temperature ``T`` in 10 C) in a ventilated chamber (vapour pressure ``e`` in kPa) with the air
    speed ``u``: the pad heated by the sun at ``S`` and exchanging heat with the air at ``Ta``, the chamber's
    vapour relaxing to the outside's ``e0`` at ``ve``; the pad's evaporation not known."""
    t, e = v[:, 0], v[:, 1]
    return torch.stack([S + h * (Ta - t), ve * (e0 - e)], dim=-1)


def linear_area_f(v, u, Wm=1.0, k=0.2, et=0.3):
    """A catchment: rain ``u`` on the soil's store ``W`` (in 100 mm), the share ``W / Wm`` of the area saturated and
    running off into the channel's store ``Q`` (drained at ``k``), evaporation ``et W / Wm``."""
    w, q = v[:, 0], v[:, 1]
    a = w.clamp(min=0.0) / Wm
    return torch.stack([u[:, 0] * (1 - a) - et * a, u[:, 0] * a - k * q], dim=-1)


def ph_blind_f(v, u, ka=0.8, kt=0.2, ke=0.3):
    """A weak acid in the gut (amount ``A``) absorbed at ``ka`` (its rate at the gut's pH 6.5) whatever the pH
    ``u``, carried on at ``kt``, eliminated from the plasma (``C``) at ``ke``."""
    a, c = v[:, 0], v[:, 1]
    return torch.stack([-(ka + kt) * a, ka * a - ke * c], dim=-1)


def neutral_layer_f(v, u, C=0.3, R=1.0, k=0.3, Tr=5.0, C2=0.1):
    """The night's surface layer: the ground (``Ts``, in K) cooling by radiation at ``R`` and warmed by the air
    (``Ta``) through the bulk formula ``C U (Ta - Ts)`` in the wind ``U = u`` (neutral stratification), the air
    losing that heat and relaxing to the residual layer's ``Tr`` at ``k``."""
    ts, ta = v[:, 0], v[:, 1]
    flux = u[:, 0] * (ta - ts)
    return torch.stack([C * flux - R, -C2 * flux + k * (Tr - ta)], dim=-1)


def cold_cavity_f(v, u, g=1.0, c=1.0, b=0.8, r=0.5):
    """An optical microcavity pumped with the power ``u``: its stored energy ``a`` fed at ``c u`` times the
    Lorentzian ``1 / (1 + 1.2^2)`` at the cold cavity's detuning 1.2 linewidths, lost at ``g``; the absorbed
    power heating it (``theta``) at ``b``, cooled at ``r``."""
    a, th = v[:, 0], v[:, 1]
    return torch.stack([c * u[:, 0] / (1 + 1.2 ** 2) - g * a, b * a - r * th], dim=-1)


# controls: the science is the whole truth
def ping_pong_f(v, u, D=0.5, V=1.5, Ka=0.4, Kb=0.15, Bin=2.0):
    a, b, p = v[:, 0], v[:, 1], v[:, 2]
    ap, bp = a.clamp(min=0.0), b.clamp(min=0.0)
    r = V * ap * bp / (Kb * ap + Ka * bp + ap * bp + 1e-12)
    return torch.stack([D * (u[:, 0] - a) - r, D * (Bin - b) - r, r - D * p], dim=-1)


def wells_riley_f(v, u, beta=3.0, gamma=0.5, w=0.15, tau=0.3):
    s, i = v[:, 0], v[:, 1]
    inc = s.clamp(min=0.0) * -torch.expm1(-beta * tau * i.clamp(min=0.0) / u[:, 0]) / tau
    return torch.stack([w * (1 - s - i) - inc, inc - gamma * i], dim=-1)


def hunt_crossley_f(v, u, k=1.0, c=0.1, lam=0.5, g=1.0):
    d, w = v[:, 0], v[:, 1]
    return torch.stack([w, g + u[:, 0] - k * d.clamp(min=0.0) ** 1.5 * (1 + lam * w) - c * w], dim=-1)


def ntu_exchanger_f(v, u, P=0.3, UA=0.6, c=0.5, l=0.4):
    th, tc = v[:, 0], v[:, 1]
    q = u[:, 0] * -torch.expm1(-UA / u[:, 0]) * (th - tc)
    return torch.stack([P - q, c * q - l * tc], dim=-1)


# ------------------------------------------------------------------------------------------------------- effects
def _ping_pong(x, u):  # V A B / (Kb A + Ka B + A B) in place of V A / (Ka + A): V = 1.5, Ka = 0.4, Kb = 0.15
    a, b = np.clip(x[:, 0], 0, None), np.clip(x[:, 1], 0, None)
    extra = 1.5 * a * b / (0.15 * a + 0.4 * b + a * b + 1e-12) - 1.5 * a / (0.4 + a)
    return np.stack([-extra, -extra, extra], axis=1)


def _reversible(x, u):  # (V S/Ks - Vr P/Kp) / (1 + S/Ks + P/Kp) in place of V S / (Ks + S): V = 1.2, Ks = 0.5,
    s, p = np.clip(x[:, 0], 0, None), np.clip(x[:, 1], 0, None)  # Vr = 0.2, Kp = 6 (Haldane's Keq = 72)
    extra = (1.2 * s / 0.5 - 0.2 * p / 6.0) / (1 + s / 0.5 + p / 6.0) - 1.2 * s / (0.5 + s)
    return pair_flux(extra)


def _wells_riley(x, u):  # S (1 - exp(-beta tau I / u)) / tau in place of beta S I / u: beta = 3, tau = 0.3
    s, i = np.clip(x[:, 0], 0, None), np.clip(x[:, 1], 0, None)
    dose = 3.0 * 0.3 * i / u[:, 0]
    return pair_flux(s * (-np.expm1(-dose) - dose) / 0.3)


def _beta_poisson(x, u):  # rho beta/alpha S (1 - (1 + W/beta)^-alpha) in place of rho S W: rho = 0.8,
    s, w = np.clip(x[:, 0], 0, None), np.clip(x[:, 2], 0, None)  # alpha = 0.25, beta = 4
    extra = 0.8 * s * (4.0 / 0.25 * (1 - (1 + w / 4.0) ** -0.25) - w)
    return np.stack([-extra, extra, np.zeros_like(s)], axis=1)


def _hassell_varley(x, u):  # a x y / (y^m + a h x) in place of a x y / (1 + a h x): a = 1.2, h = 0.6, m = 0.5
    prey, y = np.clip(x[:, 0], 0, None), np.clip(x[:, 1], 0, None)
    extra = 1.2 * prey * y * (1 / (y ** 0.5 + 0.72 * prey) - 1 / (1 + 0.72 * prey))
    return pair_flux(extra, 0.5)


def _ratkowsky_rate(t, tmin=-0.2, tmax=4.0, c=3.0):
    """Ratkowsky's square-root model's rate ``((T - Tmin)(1 - exp(c (T - Tmax))))^2`` (its constant ``b`` dropped)."""
    return ((t - tmin) * -np.expm1(c * (t - tmax))) ** 2


def _ratkowsky(x, u):  # r x (1 - x/K) g(T) / g(2.5) in place of r x (1 - x/K): r = 0.8, K = 2, Tmin = -2 C,
    t = np.clip(x[:, 1], -0.2, 4.0)  # Tmax = 40 C, c = 0.3 per C, the reference 25 C
    return on_component(0, 2, 0.8 * x[:, 0] * (1 - x[:, 0] / 2.0) * (_ratkowsky_rate(t) / _ratkowsky_rate(2.5) - 1))


def _hunt_crossley(x, u):  # -lambda k d^1.5 w (Hunt-Crossley), the pad's dissipation: k = 1, lambda = 0.5
    d, w = np.clip(x[:, 0], 0, None), x[:, 1]
    return on_component(1, 2, -0.5 * 1.0 * d ** 1.5 * w)


def _squeeze_film(x, u):  # c w / h^3 in place of c w (Reynolds' squeeze film, h in units of the rest gap): c = 0.5
    h, w = x[:, 0], x[:, 1]
    return on_component(1, 2, -0.5 * w * (1 / h ** 3 - 1))


def _koutecky_levich(x, u):  # i_k i_L / (i_k + i_L), i_k = k0 c exp(alpha eta), i_L = m c, in place of i_k:
    eta, c = x[:, 0], x[:, 1]  # k0 = 0.5, alpha = 1, m = 8, s = 0.1
    kinetic = 0.5 * np.exp(1.0 * eta)
    extra = c * kinetic * (8.0 / (kinetic + 8.0) - 1)
    return np.stack([-extra, -0.1 * extra], axis=1)


def _varactor(x, u):  # i / C(V), C = Cb sqrt((phi + Vb)/(phi + V)), in place of i / Cb: Cb = 1, phi = 0.6, Vb = 1
    i, vc = x[:, 0], np.clip(x[:, 1], -0.59, None)
    return on_component(1, 2, i / 1.0 * (np.sqrt((0.6 + vc) / (0.6 + 1.0)) - 1))


def _ntu(x, u):  # u (1 - exp(-UA/u)) (Th - Tc) in place of UA (Th - Tc) (effectiveness-NTU): UA = 0.6, c = 0.5
    flow = u[:, 0]
    return pair_flux((flow * -np.expm1(-0.6 / flow) - 0.6) * (x[:, 0] - x[:, 1]), 0.5)


def _magnus(t):
    """Saturation vapour pressure (kPa) at ``t`` in 10 C (the August-Roche-Magnus formula)."""
    return 0.6108 * np.exp(17.27 * t / (t + 23.73))


def _dalton(x, u):  # evaporation E = 0.08 (1 + 0.54 U)(es(T) - e) (Dalton's law, Penman's wind function), cooling
    t, e = x[:, 0], x[:, 1]  # the pad at 0.15 E and raising the chamber's vapour pressure at 0.15 E
    evaporation = 0.08 * (1 + 0.54 * u[:, 0]) * (_magnus(t) - e)
    return np.stack([-0.15 * evaporation, 0.15 * evaporation], axis=1)


def _arno(x, u):  # saturated area 1 - (1 - W/Wm)^(b/(1+b)) in place of W/Wm (ARNO/VIC curve): Wm = 1, b = 3
    share = np.clip(x[:, 0] / 1.0, 0, 1)
    return pair_flux(u[:, 0] * (1 - (1 - share) ** 0.75 - share))


def _henderson_hasselbalch(x, u):  # ka A f(pH) / f(6.5), f = 1/(1 + 10^(pH - pKa)), in place of ka A: ka = 0.8,
    ratio = (1 + 10 ** (6.5 - 6.5)) / (1 + 10 ** (u[:, 0] - 6.5))  # pKa = 6.5 (a weak acid)
    return pair_flux(0.8 * x[:, 0] * (ratio - 1))


def _louis(x, u):  # C U dT / (1 + 4.7 Ri)^2, Ri = b dT / U^2, dT = Ta - Ts (Louis, stable), in place of C U dT:
    diff = x[:, 1] - x[:, 0]  # C = 0.3, C2 = 0.1, b = 0.04
    ri = 0.04 * np.clip(diff, 0, None) / u[:, 0] ** 2
    extra = 0.3 * u[:, 0] * diff * (1 / (1 + 4.7 * ri) ** 2 - 1)
    return np.stack([extra, -extra * 0.1 / 0.3], axis=1)


def _thermo_optic(x, u):  # c u / (1 + (1.2 - kappa theta)^2) in place of c u / (1 + 1.2^2): c = 1, kappa = 0.1
    lorentz = 1 / (1 + (1.2 - 0.1 * x[:, 1]) ** 2)
    return on_component(0, 2, 1.0 * u[:, 0] * (lorentz - 1 / (1 + 1.2 ** 2)))


_system = partial(law_system, batch=23)


ENZYME = {"A": "mmol/L", "B": "mmol/L", "P": "mmol/L", "u": "mmol/L"}
AIRBORNE = {"S": "1", "I": "1", "u": "1"}
PAD = {"d": "mm", "w": "mm/s", "u": "N/kg"}
EXCHANGER = {"Th": "10 K", "Tc": "10 K", "u": "kW/K"}
LAWS_6 = [
    _system("ping_pong_bi_bi", "enzyme kinetics", "a rational of two states, in place of one state's saturation",
            "conversion 1.5 A B / (0.15 A + 0.4 B + A B) (ping-pong bi-bi, Kb = 0.15) in place of Michaelis-Menten's "
            "1.5 A / (0.4 + A), the co-substrate B taken as in excess", michaelis_bisubstrate_f,
            {"D": 0.5, "V": 1.5, "Ka": 0.4}, _ping_pong, ["A", "B", "P"], ENZYME, 0.3, 30, (0.2, 0.5, 0.0),
            (2.0, 2.0, 1.0), (0.5, 2.5)),
    _system("reversible_michaelis_menten", "enzyme kinetics", "a difference of two states over a sum, in place of "
            "one state's saturation", "conversion (1.2 S/0.5 - 0.2 P/6) / (1 + S/0.5 + P/6) (reversible "
            "Michaelis-Menten, Haldane's Keq = 72) in place of the irreversible 1.2 S / (0.5 + S)",
            irreversible_enzyme_f, {"D": 0.5, "V": 1.2, "Ks": 0.5}, _reversible, ["S", "P"],
            {"S": "mmol/L", "P": "mmol/L", "u": "mmol/L"}, 0.3, 30, (0.2, 0.0), (2.0, 2.0), (0.5, 2.5)),
    _system("wells_riley_ventilation", "epidemiology", "a state times 1 - exp of a state over the input, in place "
            "of their product", "incidence S (1 - exp(-0.9 I / u)) / 0.3 (Wells-Riley, exposure periods of 0.3) in "
            "place of Gammaitoni-Nucci's 3 S I / u, u the ventilation", gammaitoni_nucci_f,
            {"beta": 3.0, "gamma": 0.5, "w": 0.15}, _wells_riley, ["S", "I"], AIRBORNE, 0.3, 30, (0.4, 0.05),
            (0.95, 0.3), (0.6, 2.0)),
    _system("beta_poisson_cholera", "epidemiology", "a state times 1 - (1 + another)^-alpha, in place of a product",
            "infection 0.8 S 4 (1 - (1 + W/4)^-0.25) / 0.25 (Beta-Poisson dose-response, alpha = 0.25, beta = 4) in "
            "place of the low-dose 0.8 S W", exponential_dose_f,
            {"rho": 0.8, "gamma": 0.5, "mu": 0.05, "xi": 2.0, "delta": 0.6}, _beta_poisson, ["S", "I", "W"],
            {"S": "1", "I": "1", "W": "1e6 cells/L"}, 0.3, 30, (0.4, 0.02, 0.0), (0.95, 0.3, 1.5), zero=[2]),
    _system("hassell_varley_interference", "ecology", "a fractional power of a state in a rational of two states",
            "predation 1.2 x y / (y^0.5 + 0.72 x) (Hassell-Varley interference, m = 0.5) in place of Holling's "
            "1.2 x y / (1 + 0.72 x), half converted", handling_prey_f,
            {"r": 1.0, "K": 3.0, "a": 1.2, "h": 0.6, "m": 0.4}, _hassell_varley, ["x", "y"], {"x": "1", "y": "1"},
            0.3, 30, (0.3, 0.3), (2.5, 1.5)),
    _system("ratkowsky_growth", "population biology", "((T - a)(1 - exp(c (T - b))))^2 times the science's term",
            "growth 0.8 x (1 - x/2) g(T)/g(2.5), g = ((T + 0.2)(1 - exp(3 (T - 4))))^2 (Ratkowsky's square-root "
            "model, 25 C the reference) in place of 0.8 x (1 - x/2) at every temperature", isothermal_growth_f,
            {"r": 0.8, "K": 2.0, "k": 0.6}, _ratkowsky, ["x", "T"], {"x": "1e8 cells/g", "T": "10 C", "u": "10 C"},
            0.3, 30, (0.1, 2.3), (1.2, 3.8), (2.3, 3.9), zero=[1]),
    _system("hunt_crossley_contact", "mechanics", "a power 1.5 of a state times another",
            "contact dissipation -0.5 d^1.5 w (Hunt-Crossley) beside Hertz's elastic 1.0 d^1.5", hertz_pad_f,
            {"k": 1.0, "c": 0.1}, _hunt_crossley, ["d", "w"], PAD, 0.2, 30, (0.6, -0.4), (1.4, 0.4), (-0.3, 0.3),
            zero=[0]),
    _system("squeeze_film_damping", "mechanics", "a state over the cube of another, in place of the state",
            "damping 0.5 w / h^3 (Reynolds' squeeze film) in place of 0.5 w, its value at the rest gap",
            viscous_plate_f, {"k": 3.0, "c": 0.5}, _squeeze_film, ["h", "w"], {"h": "um", "w": "um/ms", "u": "um/ms2"},
            0.1, 30, (0.75, -0.6), (1.25, 0.6), (-1.0, 1.0), zero=[0]),
    _system("koutecky_levich_electrode", "electrochemistry", "a state times exp of another over a constant plus that "
            "exp, in place of the product", "current 0.5 c exp(eta) 8 / (0.5 exp(eta) + 8) (Koutecky-Levich, the "
            "mass-transport limit 8 c) in place of Tafel's 0.5 c exp(eta)", tafel_cell_f,
            {"k0": 0.5, "alpha": 1.0, "q": 0.5}, _koutecky_levich, ["eta", "c"],
            {"eta": "25 mV", "c": "mol/m3", "u": "mA"}, 0.25, 30, (-0.5, 0.6), (1.5, 1.0), (0.1, 1.2)),
    _system("varactor_lc", "electronics", "a state times the root of a sum of another and a constant",
            "voltage rate i sqrt((0.6 + V)/1.6) (an abrupt-junction varactor, C = Cb sqrt((0.6 + 1)/(0.6 + V))) in "
            "place of i / Cb, Cb = 1 its capacitance at the bias 1 V", fixed_capacitor_f,
            {"L": 1.0, "R": 0.4, "Cb": 1.0}, _varactor, ["i", "V"], {"i": "mA", "V": "V", "u": "V"}, 0.2, 30,
            (-0.5, 0.3), (0.5, 2.5), (0.3, 2.5), zero=[0]),
    _system("ntu_exchanger", "heat transfer", "the input times 1 - exp(-k / the input) times a difference of two "
            "states", "heat removed u (1 - exp(-0.6/u)) (Th - Tc) (effectiveness-NTU, the tank's side isothermal) in "
            "place of 0.6 (Th - Tc), u the coolant's capacity rate", ideal_exchanger_f,
            {"P": 0.3, "UA": 0.6, "c": 0.5, "l": 0.4}, _ntu, ["Th", "Tc"], EXCHANGER, 0.3, 30, (1.0, 0.0),
            (3.0, 1.5), (1.2, 3.5)),
    _system("dalton_evaporation", "heat transfer", "the input times exp(a T / (b + T)) less another state",
            "evaporation E = 0.08 (1 + 0.54 u)(es(T) - e), es = 0.6108 exp(17.27 T/(T + 23.73)) (Dalton's law, "
            "Penman's wind function, the Magnus formula), cooling the pad at 0.15 E and wetting the air at 0.15 E",
            dry_surface_f, {"S": 0.3, "h": 0.5, "ve": 1.0}, _dalton, ["T", "e"],
            {"T": "10 C", "e": "kPa", "u": "m/s"}, 0.3, 30, (1.0, 0.3), (3.5, 2.5), (0.5, 4.0)),
    _system("arno_runoff", "hydrology", "the input times (1 - a state)^0.75, in place of the input times the state",
            "saturated area 1 - (1 - W)^0.75 (the ARNO/VIC variable infiltration curve, b = 3) in place of the "
            "linear W / Wm, Wm = 1", linear_area_f, {"Wm": 1.0, "k": 0.2, "et": 0.3}, _arno, ["W", "Q"],
            {"W": "100 mm", "Q": "100 mm", "u": "100 mm/d"}, 0.2, 30, (0.05, 0.0), (0.5, 0.6), (0.0, 0.8)),
    _system("henderson_hasselbalch_absorption", "pharmacology", "a state times 1 / (1 + 10^(u - pKa)), in place of "
            "the state", "absorption 0.8 A 2 / (1 + 10^(pH - 6.5)) (Henderson-Hasselbalch, the un-ionised acid "
            "absorbed, 0.8 its rate at pH 6.5) in place of 0.8 A at every pH", ph_blind_f,
            {"ka": 0.8, "kt": 0.2, "ke": 0.3}, _henderson_hasselbalch, ["A", "C"], {"A": "mg", "C": "mg/L", "u": "pH"},
            0.2, 30, (0.5, 0.0), (2.0, 1.0), (5.8, 7.2)),
    _system("louis_stable_layer", "atmospheric physics", "a product over the square of 1 + a difference of states "
            "over the input squared", "heat flux 0.3 U dT / (1 + 4.7 Ri)^2, Ri = 0.04 dT / U^2 (Louis' stable "
            "surface layer) in place of the neutral 0.3 U dT, dT = Ta - Ts, U = u the wind", neutral_layer_f,
            {"C": 0.3, "R": 1.0, "k": 0.3}, _louis, ["Ts", "Ta"], {"Ts": "K", "Ta": "K", "u": "m/s"}, 0.25, 30,
            (-1.0, 1.5), (1.0, 3.0), (1.5, 4.5)),
    _system("thermo_optic_cavity", "optics", "the input times a Lorentzian of a constant less a state",
            "pumping u / (1 + (1.2 - 0.1 theta)^2) (the thermo-optic shift of the resonance) in place of the cold "
            "cavity's u / (1 + 1.2^2)", cold_cavity_f, {"g": 1.0, "c": 1.0, "b": 0.8, "r": 0.5}, _thermo_optic,
            ["a", "theta"], {"a": "nJ", "theta": "K", "u": "mW"}, 0.25, 30, (0.0, 0.0), (1.0, 1.5), (0.5, 2.5),
            zero=[1]),
    # controls
    _system("control_ping_pong", "enzyme kinetics", "control", "nothing (the ping-pong bi-bi rate written in)",
            ping_pong_f, {"D": 0.5, "V": 1.5, "Ka": 0.4, "Kb": 0.15}, None, ["A", "B", "P"], ENZYME, 0.3, 30,
            (0.2, 0.5, 0.0), (2.0, 2.0, 1.0), (0.5, 2.5)),
    _system("control_wells_riley", "epidemiology", "control", "nothing (the Wells-Riley incidence written in)",
            wells_riley_f, {"beta": 3.0, "gamma": 0.5, "w": 0.15}, None, ["S", "I"], AIRBORNE, 0.3, 30,
            (0.4, 0.05), (0.95, 0.3), (0.6, 2.0)),
    _system("control_hunt_crossley", "mechanics", "control", "nothing (Hunt-Crossley's dissipation written in)",
            hunt_crossley_f, {"k": 1.0, "c": 0.1, "lam": 0.5}, None, ["d", "w"], PAD, 0.2, 30, (0.6, -0.4),
            (1.4, 0.4), (-0.3, 0.3)),
    _system("control_ntu_exchanger", "heat transfer", "control", "nothing (the effectiveness-NTU written in)",
            ntu_exchanger_f, {"P": 0.3, "UA": 0.6, "c": 0.5, "l": 0.4}, None, ["Th", "Tc"], EXCHANGER, 0.3, 30,
            (1.0, 0.0), (3.0, 1.5), (1.2, 3.5)),
]
