"""The fast RK4 path (sklearn_hybrid.integrate.fast): same states and gradients as plain autograd."""

import inspect

import numpy as np
import pytest
import torch

from sklearn_hybrid import HybridRegressor, OdeStructure
from sklearn_hybrid.integrate import fast as fast_rk4, kernels
from sklearn_hybrid.datasets import make_duffing, make_pendulum
from sklearn_hybrid.integrate import integrate
from sklearn_hybrid.residual import MLP, ConvNet
from sklearn_hybrid.models import duffing_f, pendulum_f

D = torch.float64


def forced_f(v, u, k=1.0, c=0.1):
    return torch.stack([v[:, 1], -k * v[:, 0] - c * v[:, 1] + u[:, 0]], dim=-1)


def _reference(science, thetas, net, x0, u, n_steps, dt, n_sub):
    def rhs(v, uu):
        args = (v,) if uu is None else (v, uu)
        return science(*args, **thetas) + net(*args)

    return integrate(rhs, x0, n_steps, dt, n_substeps=n_sub, u_fine=u)


@pytest.mark.parametrize("activation", ["relu", "tanh", "softplus"])
@pytest.mark.parametrize("forced", [False, True])
def test_states_and_gradients_match_autograd(activation, forced):
    torch.manual_seed(0)
    n_steps, n_sub, dt = 3, 2, 0.2
    science = forced_f if forced else pendulum_f
    ins = ((2,), (1,)) if forced else ((2,),)
    net = MLP(ins, (2,), hidden=(8, 8), activation=activation).to(D)
    theta = {"k": torch.tensor(1.3, dtype=D, requires_grad=True),
             "c": torch.tensor(0.2, dtype=D, requires_grad=True)} if forced else \
        {"omega": torch.tensor(0.6, dtype=D, requires_grad=True)}
    x0 = torch.randn(5, 2, dtype=D, requires_grad=True)
    u = torch.randn(5, 2 * n_sub * n_steps + 1, 1, dtype=D) if forced else None
    w = torch.randn(5, n_steps, 2, dtype=D)
    params = [*theta.values(), x0, *net.parameters()]

    ref = _reference(science, theta, net, x0, u, n_steps, dt, n_sub)
    grads_ref = torch.autograd.grad((ref * w).sum(), params)
    weights, biases, acts = fast_rk4.mlp_parts(net)
    fast = fast_rk4.ode_states(science, list(theta), [t[None] for t in theta.values()],
                            [p[None] for p in weights], [p[None] for p in biases], acts, x0[None],
                            None if u is None else u[None], n_steps, dt, n_sub)[0]
    grads = torch.autograd.grad((fast * w).sum(), params)
    torch.testing.assert_close(fast, ref, rtol=1e-12, atol=1e-12)
    for g, g_ref in zip(grads, grads_ref):
        torch.testing.assert_close(g, g_ref, rtol=1e-10, atol=1e-12)


def spring_f(v, k=1.0):
    return -k * v  # theta does not broadcast per row: the stacked path must use vmap


@pytest.mark.parametrize("science, forced, activation", [
    (pendulum_f, False, "relu"), (spring_f, False, "tanh"), (forced_f, True, "relu")])
def test_stacked_members_get_their_own_gradients(science, forced, activation):
    torch.manual_seed(1)
    K, n_steps, n_sub, dt = 3, 2, 3, 0.1
    ins = ((2,), (1,)) if forced else ((2,),)
    nets = [MLP(ins, (2,), hidden=(8, 8), activation=activation).to(D) for _ in range(K)]
    names = {pendulum_f: ["omega"], spring_f: ["k"], forced_f: ["k", "c"]}[science]
    thetas = [torch.linspace(0.5, 0.7, K, dtype=D).requires_grad_() for _ in names]
    parts = [fast_rk4.mlp_parts(n) for n in nets]
    weights = [torch.stack([p[0][i] for p in parts]).detach().requires_grad_() for i in range(3)]
    biases = [torch.stack([p[1][i] for p in parts]).detach().requires_grad_() for i in range(3)]
    x0, w = torch.randn(K, 4, 2, dtype=D), torch.randn(K, 4, n_steps, 2, dtype=D)
    u = torch.randn(K, 4, 2 * n_sub * n_steps + 1, 1, dtype=D) if forced else None
    out = fast_rk4.ode_states(science, names, thetas, weights, biases, parts[0][2], x0, u,
                           n_steps, dt, n_sub)
    grads = torch.autograd.grad((out * w).sum(), [*thetas, *weights, *biases])
    n = len(names)
    for k, net in enumerate(nets):
        theta = {name: t[k].detach().requires_grad_() for name, t in zip(names, thetas)}
        ref = _reference(science, theta, net, x0[k], None if u is None else u[k], n_steps, dt, n_sub)
        torch.testing.assert_close(out[k], ref, rtol=1e-12, atol=1e-12)
        g_ref = torch.autograd.grad((ref * w[k]).sum(), [*theta.values(), *net.parameters()])
        mine = [g[k] for g in grads[:n]]
        for i in range(3):
            mine += [grads[n + i][k], grads[n + 3 + i][k]]
        for g, r in zip(mine, g_ref):
            torch.testing.assert_close(g, r, rtol=1e-10, atol=1e-12)


def test_supports():
    mlp = MLP(((2,),), (2,))
    assert fast_rk4.supports(mlp, (2,), "rk4")
    assert not fast_rk4.supports(mlp, (2,), "dopri5")
    assert not fast_rk4.supports(MLP(((20,),), (20,)), (20,), "rk4")  # large state: autograd
    assert not fast_rk4.supports(ConvNet(((2, 4, 4),), (2, 4, 4)), (2, 4, 4), "rk4")
    with fast_rk4.disabled():
        assert not fast_rk4.supports(mlp, (2,), "rk4")
    assert fast_rk4.supports(mlp, (2,), "rk4")


@pytest.mark.parametrize("method", ["erm", "fsam", "f-reg"])
def test_fit_same_with_and_without_fast_path(method):
    rng = np.random.default_rng(0)
    X = rng.uniform(-1, 1, (10, 2))
    y = np.stack([X * np.cos(0.3 * t) for t in range(1, 4)], axis=1)
    kw = dict(science=pendulum_f, method=method, dt=0.2, max_iter=15, lr=1e-2, dtype="float64",
              residual={"hidden": (8, 8)}, theta_bounds={"omega": (0.1, 2.0)},
              observed=[0], random_state=0)
    fast = HybridRegressor(**kw).fit(X, y[..., :1])
    with fast_rk4.disabled():
        slow = HybridRegressor(**kw).fit(X, y[..., :1])
    assert fast.theta_["omega"] == pytest.approx(slow.theta_["omega"], rel=1e-9)
    np.testing.assert_allclose(fast.history_["loss"], slow.history_["loss"], rtol=1e-9)
    np.testing.assert_allclose(fast.predict(X), slow.predict(X), rtol=1e-9, atol=1e-12)


def test_masked_network_on_the_fast_path():
    """MLPOn (a MaskedMLP): the fast path serves it, with the same fit as autograd, and the masked
    component gets nothing, in a single fit and in a stacked sweep."""
    from sklearn_hybrid import HybridRegressorCV
    from sklearn_hybrid.diagnosis import MLPOn

    rng = np.random.default_rng(0)
    X = rng.uniform(-1, 1, (10, 2))
    y = np.stack([X * np.cos(0.3 * t) for t in range(1, 4)], axis=1)
    kw = dict(science=pendulum_f, method="fsam", dt=0.2, max_iter=15, lr=1e-2, dtype="float64",
              residual=MLPOn([1], hidden=(8, 8), zero_init=False), random_state=0)
    fast = HybridRegressor(**kw).fit(X, y)
    assert fast_rk4.supports(fast.residual_, (2,), "rk4")
    with fast_rk4.disabled():
        slow = HybridRegressor(**kw).fit(X, y)
    assert fast.theta_["omega"] == pytest.approx(slow.theta_["omega"], rel=1e-9)
    np.testing.assert_allclose(fast.history_["loss"], slow.history_["loss"], rtol=1e-9)
    assert np.all(fast.residual_trace(X)["residual"][:, 0] == 0)
    cv = HybridRegressorCV(HybridRegressor(**kw), rhos=[0.01, 0.1], seeds=[0]).fit(X, y)
    assert np.all(cv.best_estimator_.residual_trace(X)["residual"][:, 0] == 0)


def test_fixed_theta_gets_no_gradient_and_stays():
    rng = np.random.default_rng(0)
    X = rng.uniform(-1, 1, (6, 2))
    y = np.stack([X] * 3, axis=1)
    est = HybridRegressor(science=pendulum_f, method="erm", dt=0.1, max_iter=5,
                          residual={"hidden": (8,)}, theta_fixed=["omega"], random_state=0).fit(X, y)
    assert est.theta_["omega"] == pytest.approx(0.5)


def test_science_mixing_samples_falls_back_to_autograd():
    def centred_f(v, k=1.0):  # subtracts the batch mean: samples are not independent
        return -k * (v - v.mean(0))

    rng = np.random.default_rng(0)
    X = rng.uniform(-1, 1, (8, 2))
    y = np.stack([X * 0.9, X * 0.8], axis=1)
    kw = dict(science=centred_f, method="erm", dt=0.1, max_iter=4, dtype="float64",
              residual={"hidden": (8,)}, random_state=0)
    fast = HybridRegressor(**kw).fit(X, y)
    with fast_rk4.disabled():
        slow = HybridRegressor(**kw).fit(X, y)
    assert fast.theta_["k"] == pytest.approx(slow.theta_["k"], rel=1e-12)


@pytest.mark.parametrize("make, science, accel", [
    (make_pendulum, pendulum_f, lambda v, w: -(2 * np.pi * 2 / 3) ** 2 * torch.sin(v) - 0.5 * w),
    (make_duffing, duffing_f, lambda v, w: -v + v ** 3)])
def test_default_solver_step_keeps_integration_error_far_below_the_noise(make, science, accel):
    """The RK4 step that n_substeps="auto" (the default) chooses from the science model is not a speed
    trade: on the paper's ODE tasks its error against the data generator's tight-tolerance solution
    is under a tenth of the noise."""
    data = make(50, 1, 1, noise=0.0, random_state=0)
    default_noise = inspect.signature(make).parameters["noise"].default
    fitted = HybridRegressor(science=science, structure=OdeStructure(dt=float(data.dt)), max_iter=1, residual={"hidden": (8,)},
                             random_state=0).fit(data.X_train, data.y_train)
    n_substeps = fitted.n_substeps_
    assert OdeStructure().options()["n_substeps"] == "auto" and n_substeps in (1, 2, 4, 8, 16)  # the default

    def true_rhs(v, u):
        return torch.stack([v[:, 1], accel(v[:, 0], v[:, 1])], dim=-1)

    states = integrate(true_rhs, torch.as_tensor(data.X_train, dtype=D), data.y_train.shape[1],
                       data.dt, n_substeps=n_substeps)
    error = np.abs(states.numpy() - data.y_train).max()
    assert error < 0.1 * default_noise


def test_stage_buffers_are_reused_within_a_fit_and_freed_after_it(monkeypatch):
    rng = np.random.default_rng(0)
    X = rng.uniform(-1, 1, (6, 2))
    y = np.stack([X] * 3, axis=1)
    taken = []
    original = kernels.take

    def spy(shape, dtype):
        buffer = original(shape, dtype)
        taken.append(buffer)  # kept alive, so that distinct buffers have distinct ids
        return buffer

    monkeypatch.setattr(kernels, "take", spy)
    HybridRegressor(science=pendulum_f, method="erm", dt=0.1, max_iter=4,
                    residual={"hidden": (8,)}, random_state=0).fit(X, y)
    # states and one hidden layer forward, one delta buffer backward, per iteration:
    # after the first iteration every take is served from the pool
    assert len(taken) == 4 * 3 and len({id(b) for b in taken}) == 3
    assert not kernels._POOL  # nothing held once the fit is over


@pytest.mark.parametrize("activation", ["tanh", "softplus"])
def test_simulation_without_gradients_same_as_modules(activation):
    """simulate / predict read theta once and run the MLP as bare products (fast_rk4.frozen_rhs):
    the same states as the modules, with and without the network, bounded theta included."""
    from sklearn_hybrid.diagnosis import MLPOn, free_run

    rng = np.random.default_rng(1)
    X = np.column_stack([rng.uniform(-1, 1, (12, 2)), rng.normal(size=(12, 4))])
    y = rng.normal(size=(12, 3, 1))
    est = HybridRegressor(science=forced_f, n_inputs=1, observed=[0], dt=0.2, max_iter=3, dtype="float64",
                          residual=MLPOn([1], hidden=(8, 8), activation=activation, zero_init=False),
                          theta_bounds={"k": (0.1, 5.0)}, random_state=0).fit(X, y)
    u = rng.normal(size=40)
    for use_residual in (True, False):
        fast = free_run(est, [0.3, -0.2], u=u, use_residual=use_residual)
        with fast_rk4.disabled():
            slow = free_run(est, [0.3, -0.2], u=u, use_residual=use_residual)
        np.testing.assert_allclose(fast, slow, rtol=1e-12, atol=1e-12)
    with fast_rk4.disabled():
        slow_predict = est.predict(X)
    np.testing.assert_allclose(est.predict(X), slow_predict, rtol=1e-12, atol=1e-12)
    with torch.no_grad():
        assert fast_rk4.frozen_rhs(est.model_.science, est.model_.residual) is not None
    assert fast_rk4.frozen_rhs(est.model_.science, est.model_.residual) is None  # gradients wanted


def test_recipes_free_runs_of_several_records_as_one_batch():
    """The recipes' scorers simulate records of different lengths as one padded batch: each run
    equals the record simulated alone."""
    from sklearn_hybrid.diagnosis import free_run
    from sklearn_hybrid.recipes import _free_runs

    rng = np.random.default_rng(2)
    X = np.column_stack([rng.uniform(-1, 1, (12, 2)), rng.normal(size=(12, 4))])
    inputs, x0s = [rng.normal(size=40), rng.normal(size=30)], [np.array([0.1, 0.2]), np.array([-0.3, 0.0])]
    for interp, exact_until in (("linear", 30), ("cubic", 20)):  # a spline feels the padding at the end
        est = HybridRegressor(science=forced_f, n_inputs=1, observed=[0], dt=0.2, max_iter=2, input_interp=interp,
                              dtype="float64", random_state=0).fit(X, rng.normal(size=(12, 3, 1)))
        runs = _free_runs(est, x0s, inputs, use_residual=True)
        for run, x0, u in zip(runs, x0s, inputs):
            assert run.shape == (len(u), 2)
            alone = free_run(est, x0, u=u)[0]
            np.testing.assert_allclose(run[:exact_until], alone[:exact_until], rtol=1e-9, atol=1e-9)
            np.testing.assert_allclose(run, alone, rtol=0.05, atol=0.05)


def thrust_f(v, u, b=0.8):
    """A cart's speed under a thrust: the science reads the input only, never the state."""
    return torch.stack([b * u[:, 0]], dim=-1)


def test_a_science_that_ignores_the_state_trains_on_the_fast_path():
    """Its derivative by the state is zero, not an error (a fit crashed with 'The differentiated Tensor at
    index 0 appears to not have been used in the graph'), and the fast path trains as the generic one."""
    from sklearn_hybrid import pack_inputs

    rng = np.random.default_rng(1)
    x0, u = rng.uniform(0, 1, (12, 1)), rng.uniform(0.2, 1.0, (12, 5, 1))
    y = x0[:, None, :] + 0.2 * np.cumsum(u[:, 1:], axis=1) - 0.05 * np.arange(1, 5)[None, :, None]
    kw = dict(science=thrust_f, dt=0.2, n_inputs=1, method="erm", max_iter=10, lr=1e-2, dtype="float64",
              residual={"hidden": (8,)}, random_state=0)
    X = pack_inputs(x0, u)
    fast = HybridRegressor(**kw).fit(X, y)
    with fast_rk4.disabled():
        slow = HybridRegressor(**kw).fit(X, y)
    assert fast.theta_["b"] != 0.8
    assert fast.theta_["b"] == pytest.approx(slow.theta_["b"], rel=1e-9)
    np.testing.assert_allclose(fast.history_["loss"], slow.history_["loss"], rtol=1e-9)
