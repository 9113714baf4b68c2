"""Harmonics of an angle: sin(n a + phase) in the library for variables whose unit is an angle, and only for them."""

import numpy as np
import pytest
import torch
from scipy.integrate import solve_ivp

from sklearn_hybrid import HybridRegressor
from sklearn_hybrid.diagnosis import Candidates, Evidence, ScienceFit, physics_terms
from sklearn_hybrid.diagnosis.loop import stepwise
from sklearn_hybrid.diagnosis.terms import angle_factor

NAMES, UNITS = ["theta", "omega"], {"theta": "rad", "omega": "rad/s"}


def spin_down_f(v, c=0.25):
    """A rotor coasting down on viscous friction: the science model, which knows of no cogging."""
    return torch.stack([v[:, 1], -c * v[:, 1]], dim=-1)


@pytest.mark.parametrize("unit, factor", [("rad", 1.0), ("0.1 rad", 0.1), ("deg", np.pi / 180), ("1e-3 rad", 1e-3)])
def test_an_angle_unit_gives_radians_per_unit(unit, factor):
    assert angle_factor(unit) == pytest.approx(factor)


@pytest.mark.parametrize("unit", ["rad/s", "m", "", "radius", "1", "V", None, 3])
def test_other_units_are_not_angles(unit):
    assert angle_factor(unit) is None


def test_a_unit_that_is_not_a_string_still_only_labels_the_report():
    terms = physics_terms(["x"], np.linspace(-1, 1, 20)[:, None], {"x": 3})
    assert not [t for t in terms if t.kind == "periodic"] and "x^2" in {t.name for t in terms}


def test_only_angles_get_harmonics_and_a_scaled_unit_is_turned_into_radians():
    values = np.random.default_rng(0).normal(size=(50, 3))
    terms = {t.name: t for t in physics_terms(["a", "w", "x"], values, {"a": "0.1 rad", "w": "rad/s", "x": "m"})}
    periodic = [name for name, t in terms.items() if t.kind == "periodic"]
    assert periodic == [f"sin({'' if n == 1 else f'{n}*'}0.1*a + phase)" for n in (1, 2, 3, 4, 6, 8)]
    d = {"a": torch.tensor([5.0]), "w": torch.tensor([0.0]), "x": torch.tensor([0.0])}
    # 5 units of 0.1 rad are 0.5 rad: the fourth harmonic's argument is 2 rad
    assert float(terms["sin(4*0.1*a + phase)"](d, phase=0.0)) == pytest.approx(np.sin(2.0))
    assert not [t for t in physics_terms(["a"], values[:, :1], {"a": "rad"}, kinds=["polynomial"])
                if t.kind == "periodic"]


def _select(cogging: float, seed: int = 0) -> dict:
    """forward_selection on 40 spin-downs of a rotor with a cogging torque -cogging sin(3 theta), 10 judged (a
    system of its own: the identification benchmark's rotors are driven, with other harmonics and amplitudes)."""
    rng = np.random.default_rng(seed)
    dt, n_steps, n, c = 0.1, 30, 40, 0.3

    def truth(t, s):
        return [s[1], -c * s[1] - cogging * np.sin(3 * s[0])]

    x0 = np.column_stack([rng.uniform(-1, 1, n), rng.uniform(1.0, 3.0, n)])
    t = dt * np.arange(n_steps + 1)
    x = np.stack([solve_ivp(truth, (0, t[-1]), s, t_eval=t, rtol=1e-9, atol=1e-11).y.T for s in x0])
    y = x[:, 1:] + 0.01 * rng.standard_normal(x[:, 1:].shape)
    est = HybridRegressor(science=spin_down_f, dt=dt, max_iter=2, random_state=0).fit(x0, y)
    states = x.reshape(-1, 2)
    learned = np.stack([truth(0, s) for s in states])
    splits = [(np.arange(n - 10), np.arange(n - 10, n))]
    return stepwise.forward_selection(spin_down_f, {"c": 0.25}, ScienceFit(est, x0, y), splits, NAMES, 2, [states],
                                      learned, [1], candidates=Candidates(terms=physics_terms(NAMES, states, UNITS)),
                                      evidence=Evidence(second_look=None))


def test_a_cogging_torque_is_named_as_its_harmonic():
    sel = _select(0.2)
    assert [t.name for t in sel["added"]] == ["sin(3*theta + phase)"]
    term = sel["added"][0].record()
    angles = np.linspace(-np.pi, np.pi, 101)
    # matched in function space: coef sin(3 a + phase) against -0.2 sin(3 a), whatever sign the phase took
    added = term["coef"] * np.sin(3 * angles + term["shape"]["phase"])
    np.testing.assert_allclose(added, -0.2 * np.sin(3 * angles), atol=0.02)
    assert sel["theta"]["c"] == pytest.approx(0.3, rel=0.05)


def test_no_harmonic_is_added_where_nothing_is_missing():
    sel = _select(0.0)
    assert sel["added"] == []
    assert any(s["kind"] == "periodic" for s in sel["steps"])  # they were candidates, and judged
