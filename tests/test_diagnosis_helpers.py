"""The helpers for closing the loop on one's own recordings: each defect a user audit found, tested."""

import warnings

import numpy as np
import pytest
import torch
from scipy.integrate import solve_ivp

from sklearn_hybrid import HybridRegressor
from sklearn_hybrid.datasets import make_windows
from sklearn_hybrid.diagnosis import (ResidualDiagnosis, augment_science, close_the_loop, fit_initial_state,
                                      free_run, physics_terms)


def oscillator(v, omega=1.0):
    return torch.stack([v[..., 1], -omega**2 * v[..., 0]], -1)


def forced_oscillator(v, u, omega=1.0):
    return torch.stack([v[..., 1], -omega**2 * v[..., 0] + u[..., 0]], -1)


@pytest.fixture(scope="module")
def record():
    t = np.arange(60) * 0.1
    return t, np.c_[np.sin(t), np.cos(t)]


@pytest.fixture(scope="module")
def angle_only(record):
    """A tiny fit that observes the angle only; its science part is exact (omega = 1)."""
    t, x = record
    w = make_windows(x[:, 0], length=5, stride=10, states=x)
    return HybridRegressor(science=oscillator, dt=0.1, method="erm", observed=[0], max_iter=5,
                           random_state=0).fit(w.X, w.y)


def test_initial_state_fitted_from_a_zero_velocity_guess(angle_only):
    # a component guessed at 0 had a trust region 1000x narrower: the search stopped at [0.5158, 0]
    y_head = free_run(angle_only, [0.3, 0.5], n_steps=9, use_residual=False)[0][:, 0]
    for guess in ([0.25, 0.0], [1.0, 0.0], [0.0, 0.0]):
        x0 = fit_initial_state(angle_only, y_head, guess, use_residual=False)
        np.testing.assert_allclose(x0, [0.3, 0.5], atol=1e-3)


def test_initial_state_uses_an_observed_array_and_checks_widths(record, angle_only):
    t, x = record
    w = make_windows(x[:, 0], length=5, stride=10, states=x)
    as_array = HybridRegressor(science=oscillator, dt=0.1, method="erm", observed=np.array([0]), max_iter=5,
                               random_state=0).fit(w.X, w.y)
    y_head = free_run(angle_only, [0.3, 0.5], n_steps=9, use_residual=False)[0][:, 0]
    # observed=np.array([0]) was read as "no observed components" and fitted both states to the angle
    np.testing.assert_allclose(fit_initial_state(as_array, y_head, [0.25, 0.1], use_residual=False), [0.3, 0.5],
                               atol=1e-3)
    with pytest.raises(ValueError, match=r"1 observed component\(s\) \[0\].*got shape \(10, 2\)"):
        fit_initial_state(angle_only, np.c_[y_head, np.zeros(10)], [0.25, 0.1])
    with pytest.raises(ValueError, match="free must list state indices in \\[0, 1\\]"):
        fit_initial_state(angle_only, y_head, [0.25, 0.1], free=[2])
    with pytest.raises(ValueError, match="observed must list state indices"):
        fit_initial_state(angle_only, y_head, [0.25, 0.1], observed=[2])
    with pytest.raises(ValueError, match="x0_guess holds NaN"):
        fit_initial_state(angle_only, y_head, [np.nan, 0.1])
    with pytest.raises(ValueError, match="NaN or infinite"):
        fit_initial_state(angle_only, np.r_[y_head[:9], np.inf], [0.25, 0.1])


def test_free_run_and_initial_state_check_the_inputs_length(record):
    t, x = record
    w = make_windows(x[:, 0], np.cos(2 * t), length=5, stride=10, states=x)
    est = HybridRegressor(science=forced_oscillator, dt=0.1, method="erm", observed=[0], n_inputs=1, max_iter=5,
                          random_state=0).fit(w.X, w.y)
    assert free_run(est, [0.3, 0.5], u=np.zeros(51), n_steps=50).shape == (1, 51, 2)
    with pytest.raises(ValueError, match="n_steps=100 disagrees with u"):  # was ignored
        free_run(est, [0.3, 0.5], u=np.zeros(51), n_steps=100)
    with pytest.raises(ValueError, match="u_head has 12 samples and y_head 10"):
        fit_initial_state(est, np.zeros(10), [0.25, 0.1], u_head=np.zeros(12))


def test_augmented_science_takes_a_single_state_as_the_original_does():
    augmented = augment_science(oscillator, [{"component": 1, "term": "v_dot", "coef": -0.5}], ["v", "v_dot"])
    one = augmented(torch.tensor([0.3, 0.5]))
    assert one.shape == (2,)
    np.testing.assert_allclose(one.numpy(), [0.5, -0.3 - 0.25])
    np.testing.assert_allclose(augmented(torch.tensor([[0.3, 0.5]]))[0].numpy(), one.numpy())
    # as solve_ivp hands a state over: damped, so the amplitude decays
    sol = solve_ivp(lambda _, v: augmented(torch.tensor(v)).numpy(), (0, 10), [1.0, 0.0], rtol=1e-8)
    assert sol.success and abs(sol.y[0, -1]) < 0.1


def test_augmented_science_names_bad_terms():
    with pytest.raises(ValueError, match="lacks \\['coef'\\]"):
        augment_science(oscillator, [{"component": 1, "term": "v"}], ["v", "v_dot"])
    with pytest.raises(ValueError, match="component must be a non-negative index"):
        augment_science(oscillator, [{"component": -1, "term": "v", "coef": 1.0}], ["v", "v_dot"])
    too_far = augment_science(oscillator, [{"component": 5, "term": "v", "coef": 1.0}], ["v", "v_dot"])
    with pytest.raises(ValueError, match="go to component 5, but the science function returns 2"):
        too_far(torch.zeros(4, 2))
    too_many = augment_science(oscillator, [{"component": 1, "term": "u", "coef": 1.0}], ["v", "v_dot", "u"])
    with pytest.raises(ValueError, match="variable_names has 3 names"):
        too_many(torch.zeros(4, 2))


def test_a_flow_enters_one_component_as_it_leaves_the_other_with_one_coefficient():
    flow = augment_science(oscillator, [{"component": 0, "term": "v", "coef": 0.2, "opposite": 1}], ["v", "v_dot"])
    assert "c_v" in flow.__signature__.parameters and len(flow.terms) == 1
    out = flow(torch.tensor([[0.5, 0.1]]), c_v=0.4)[0].numpy()
    np.testing.assert_allclose(out, [0.1 + 0.4 * 0.5, -0.5 - 0.4 * 0.5])
    assert "- c_v*v [component 1]" in flow.equation
    for bad in (0, -1, True, "1"):
        with pytest.raises(ValueError, match="'opposite' must be another output component"):
            augment_science(oscillator, [{"component": 0, "term": "v", "coef": 0.2, "opposite": bad}], ["v", "v_dot"])


def test_physics_terms_checks_its_values_and_names():
    values = np.random.default_rng(0).normal(size=(50, 2))
    with pytest.raises(ValueError, match="NaN or infinite"):
        physics_terms(["v", "w"], np.r_[values, [[np.nan, 0.0]]])
    with pytest.raises(ValueError, match=r"shape \(n_points, 3\); got shape \(50, 2\)"):
        physics_terms(["v", "w", "u"], values)
    with pytest.raises(ValueError, match="at one point or more"):
        physics_terms(["v", "w"], np.zeros((0, 2)))
    with pytest.raises(ValueError, match="distinct names"):
        physics_terms(["v", "v"], values)
    with pytest.raises(ValueError, match="the string 'drag'"):
        physics_terms(["v", "w"], values, kinds="drag")
    one = physics_terms(["v"], values[:, 0])  # one variable: a 1-D column is fine
    assert {t.name for t in one} >= {"v", "v^3", "v|v|"}


def test_residual_diagnosis_takes_numpy_numbers(angle_only, record):
    _, x = record
    X = make_windows(x[:, 0], length=5, stride=10, states=x).X
    with pytest.warns(UserWarning, match="not judged on held-out data"):  # no y given: said, not hidden
        ResidualDiagnosis(min_residual=np.float32(1e-4)).fit(angle_only, X)
    with pytest.raises(ValueError, match="min_residual"):
        ResidualDiagnosis(min_residual=True).fit(angle_only, X)
    with pytest.raises(ValueError, match="components must be a list"):
        ResidualDiagnosis(components=1).fit(angle_only, X)


@pytest.fixture(scope="module")
def damped():
    t = np.arange(120) * 0.1
    x = solve_ivp(lambda _, v: [v[1], -v[0] - 0.5 * v[1]], (0, t[-1]), [1, 0], t_eval=t, rtol=1e-9).y.T
    return make_windows(x, length=5, stride=5)


def test_close_the_loop_refuses_misspelt_options_before_fitting(damped):
    est = HybridRegressor(science=oscillator, dt=0.1, method="erm", max_iter=20, random_state=0)
    with pytest.raises(ValueError, match="refit_params names \\['max_iters'\\]"):
        close_the_loop(est, damped.X, damped.y, refit_params={"max_iters": 5})
    with pytest.raises(ValueError, match="refit_params may not set \\['science'\\]"):
        close_the_loop(est, damped.X, damped.y, refit_params={"science": oscillator})
    with pytest.raises(ValueError, match="param_names names \\['vdot'\\].*close ones: \\[.*'v_dot'"):
        close_the_loop(est, damped.X, damped.y, state_names=["v", "v_dot"], param_names={"vdot": "c_damping"})
    with pytest.raises(ValueError, match="valid Python identifiers"):
        close_the_loop(est, damped.X, damped.y, state_names=["v", "v_dot"], param_names={"v_dot": "c damping"})
    with pytest.raises(ValueError, match="refit_params set the hybrid refit, which runs only with refit_hybrid=True"):
        close_the_loop(est, damped.X, damped.y, refit_params={"max_iter": 5})  # would be silently unused
    with pytest.raises(TypeError, match="refit_hybrid must be True or False, got 'yes'"):
        close_the_loop(est, damped.X, damped.y, refit_hybrid="yes")
    assert not hasattr(est, "model_")  # nothing was fitted


def test_close_the_loop_names_the_damping_and_warns_of_an_unscored_theta_true(damped):
    est = HybridRegressor(science=oscillator, dt=0.1, method="erm", max_iter=20, random_state=0)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        out = close_the_loop(est, damped.X, damped.y, state_names=["v", "v_dot"],
                             theta_true={"omgea": 1.0, "c_damping": -0.5}, param_names={"v_dot": "c_damping"})
    assert [t["param"] for t in out.added] == ["c_damping"]
    assert out.science_theta["c_damping"] == pytest.approx(-0.5, rel=0.05)
    # no second training unasked; the CPU seconds of the stages it ran
    assert out.after is None and [r["stage"] for r in out.table] == ["before", "science only"]
    assert {"hybrid fit", "selection", "network-free refit and intervals"} <= set(out.timings)
    assert all(seconds >= 0 for seconds in out.timings.values())
    messages = [str(w.message) for w in caught if "theta_true" in str(w.message)]
    assert len(messages) == 1 and "['omgea']" in messages[0]  # c_damping is the added term's: scored
