"""Terms of kind "scaled": a parameter of an equation that varies with the state, f_j(x) * x_k."""

import inspect
import pickle

import numpy as np
import pytest
import torch
from test_closed_loop import select_on_simulated_data

from sklearn_hybrid.diagnosis import SCIENCE_OUTPUT, augment_science, physics_terms

NAMES = ["A", "B"]


def relaxation_f(v, k=0.5, d=0.4):
    """A relaxes towards B at rate k; B decays at rate d (one state or a batch)."""
    A, B = v[..., 0], v[..., 1]
    return torch.stack([B - k * A, -d * B], dim=-1)


def test_scaled_terms_are_built_per_uncertain_component_state_and_input():
    values = np.random.default_rng(0).uniform(0, 2, (50, 3))
    terms = physics_terms(["A", "B", "u"], values, scaled={0: "A"}, n_states=2)
    scaled = {t.name: t for t in terms if t.kind == "scaled"}
    assert set(scaled) == {"f[A]*A", "f[A]*A^2", "f[A]*B", "f[A]*B^2", "f[A]*u"}  # an input scales linearly
    assert {t.component for t in scaled.values()} == {0}
    assert all(t.component is None for t in terms if t.kind != "scaled")
    # without the science outputs, or with the kind left out, there are none
    assert not [t for t in physics_terms(["A", "B"], values[:, :2]) if t.kind == "scaled"]
    kinds = ["polynomial"]
    assert not [t for t in physics_terms(["A", "B"], values[:, :2], kinds=kinds, scaled={0: "A"}) if t.kind == "scaled"]
    d = {"A": torch.tensor([1.0, 2.0]), "B": torch.tensor([0.5, 0.0]), SCIENCE_OUTPUT: torch.tensor([[3.0, 1.0],
                                                                                                   [4.0, 1.0]])}
    torch.testing.assert_close(scaled["f[A]*A^2"](d), torch.tensor([3.0, 16.0]))
    torch.testing.assert_close(scaled["f[A]*u"]({**d, "u": torch.tensor([2.0, 0.5])}), torch.tensor([6.0, 2.0]))


@pytest.mark.parametrize("options, match", [({"scaled": {-1: "A"}}, "non-negative integer"),
                                            ({"scaled": {"A": "A"}}, "non-negative integer"),
                                            ({"n_states": 3}, r"n_states must be an integer in \[0, 2\]"),
                                            ({"n_states": True}, "n_states must be")])
def test_bad_scaled_options_are_named(options, match):
    values = np.ones((5, 2))
    scaled = {0: "A"}
    with pytest.raises(ValueError, match=match):
        physics_terms(NAMES, values, **{"scaled": scaled, **options})
    assert scaled == {0: "A"}  # the caller's mapping is left as it was


def test_augmented_science_scales_its_own_output():
    values = np.random.default_rng(0).uniform(0, 2, (50, 2))
    term, = [t for t in physics_terms(NAMES, values, scaled={0: "A"}) if t.name == "f[A]*A"]
    aug = augment_science(relaxation_f, [{"component": 0, "term": term.name, "coef": 0.7, "function": term.func,
                                          "kind": term.kind}], NAMES)
    assert list(inspect.signature(aug).parameters) == ["v", "k", "d", "c_f_A_A"]
    v = torch.tensor([[0.3, 1.0], [1.5, 0.2]], dtype=torch.float64)
    f = relaxation_f(v)
    expected = torch.stack([f[:, 0] * (1 + 0.7 * v[:, 0]), f[:, 1]], dim=-1)
    torch.testing.assert_close(aug(v), expected)
    torch.testing.assert_close(aug(v[0]), expected[0])  # one state, as solve_ivp hands it over
    torch.testing.assert_close(pickle.loads(pickle.dumps(aug))(v, k=0.2), aug(v, k=0.2))


def test_the_selection_finds_a_rate_that_grows_with_the_state():
    """dA/dt = (B - k A)(1 + 0.7 A): two polynomial terms (A^2 and A*B) would be needed, one scaled term is exact."""
    rng = np.random.default_rng(1)
    dt, n_steps = 0.2, 12

    def truth(t, x):
        return [(x[1] - 0.5 * x[0]) * (1 + 0.7 * x[0]), -0.4 * x[1]]

    x0 = rng.uniform([0.0, 0.2], [1.5, 2.0], size=(40, 2))
    sel = select_on_simulated_data(relaxation_f, {"k": 0.5, "d": 0.4}, truth, x0, dt, n_steps, 0.005, rng, NAMES,
                                   lambda names, states: physics_terms(names, states, scaled={0: "A", 1: "B"}))
    assert [(t.component, t.name, t.kind) for t in sel["added"]] == [(0, "f[A]*A", "scaled")]
    assert sel["added"][0].coef == pytest.approx(0.7, rel=0.05)
    assert sel["theta"]["k"] == pytest.approx(0.5, rel=0.05) and sel["theta"]["d"] == pytest.approx(0.4, rel=0.02)
    # each scaled candidate was only ever placed on its own component
    assert all(s["component"] == 0 for s in sel["steps"] if s["term"].startswith("f[A]"))
    assert all(s["component"] == 1 for s in sel["steps"] if s["term"].startswith("f[B]"))


def fed_decay_f(v, u, k=0.5):
    """A is fed at rate u and decays at rate k (one state or a batch)."""
    return torch.stack([u[..., 0] - k * v[..., 0]], dim=-1)


def test_the_selection_finds_a_rate_that_follows_the_input():
    """dA/dt = (u - k A)(1 + 0.8 u): polynomial terms would need u^2 and A*u, one scaled term is exact."""
    from sklearn_hybrid import HybridRegressor, pack_inputs
    from sklearn_hybrid.diagnosis import Candidates, Evidence, ScienceFit
    from sklearn_hybrid.diagnosis.loop import stepwise

    rng = np.random.default_rng(3)
    dt, n_steps, n = 0.25, 12, 40
    x0, u = rng.uniform(0.0, 2.0, (n, 1)), rng.uniform(0.2, 1.5, n)  # one constant input per trajectory
    t = dt * np.arange(n_steps + 1)
    x = np.stack([x0[i] + (u[i] / 0.6 - x0[i]) * (1 - np.exp(-0.6 * (1 + 0.8 * u[i]) * t))[:, None]
                  for i in range(n)])  # the exact solution at k = 0.6
    y = x[:, 1:] + 0.005 * rng.standard_normal(x[:, 1:].shape)
    inputs = np.repeat(u[:, None, None], n_steps + 1, axis=1)
    X = pack_inputs(x0, inputs)
    est = HybridRegressor(science=fed_decay_f, dt=dt, n_inputs=1, max_iter=2, random_state=0).fit(X, y)
    states, flat_u = x.reshape(-1, 1), inputs.reshape(-1, 1)
    learned = (flat_u - 0.6 * states) * (1 + 0.8 * flat_u)
    library = physics_terms(["A", "u"], np.hstack([states, flat_u]), scaled={0: "A"}, n_states=1)
    splits = [(np.arange(n - 12), np.arange(n - 12, n))]
    sel = stepwise.forward_selection(fed_decay_f, {"k": 0.5}, ScienceFit(est, X, y), splits, ["A", "u"], 1,
                                     [states, flat_u], learned, [0], candidates=Candidates(terms=library),
                                     evidence=Evidence(second_look=None))
    assert [t.key for t in sel["added"]] == [(0, "f[A]*u")]
    assert sel["added"][0].coef == pytest.approx(0.8, rel=0.05)
    assert sel["theta"]["k"] == pytest.approx(0.6, rel=0.05)
