"""HybridRegressor: the user-facing snippets, structures, determinism, model selection."""

import pickle

import numpy as np
import pytest
import torch
from sklearn.base import clone
from sklearn.model_selection import GridSearchCV, cross_validate, validation_curve

from sklearn_hybrid import (HybridRegressor, make_flat_scorer, make_theta_scorer, pack_inputs,
                            theta_error)
from sklearn_hybrid.datasets import make_pendulum
from sklearn_hybrid.integrate import integrate

FAST = dict(max_iter=30, residual={"hidden": (16, 16)}, random_state=0)


def pendulum_f(v, omega=0.5):
    return torch.stack([v[:, 1], -(2 * torch.pi * omega) ** 2 * torch.sin(v[:, 0])], dim=-1)


@pytest.fixture(scope="module")
def pendulum():
    return make_pendulum(n_train=12, n_val=4, n_test=4, n_steps=5, random_state=0)


def test_readme_snippet(pendulum):
    X, y = pendulum.X_train, pendulum.y_train
    est = HybridRegressor(science=pendulum_f, method="sam", dt=0.2, **FAST).fit(X, y)
    assert set(est.theta_) == {"omega"} and isinstance(est.theta_["omega"], float)
    assert est.predict(pendulum.X_test).shape == pendulum.y_test.shape
    assert est.history_["loss"].shape == (30,) and est.history_["theta"]["omega"].shape == (30,)
    assert est.history_["theta"]["omega"][-1] == pytest.approx(est.theta_["omega"])
    assert est.n_features_in_ == 2


def test_training_reduces_loss_and_moves_theta(pendulum):
    est = HybridRegressor(science=pendulum_f, method="erm", dt=0.2, lr=1e-2,
                          **{**FAST, "max_iter": 150}).fit(pendulum.X_train, pendulum.y_train)
    loss = est.history_["loss"]
    assert loss[-10:].mean() < 0.2 * loss[:10].mean()
    # from 0.5 towards the true 2/3
    assert abs(est.theta_["omega"] - 2 / 3) < abs(0.5 - 2 / 3)


def test_gridsearch_theta_scorer(pendulum):
    est = HybridRegressor(science=pendulum_f, dt=0.2, **{**FAST, "max_iter": 10})
    scorer = make_theta_scorer({"omega": 2 / 3})
    search = GridSearchCV(est, {"rho": [0.01, 0.05, 0.1]}, scoring=scorer, cv=2)
    search.fit(pendulum.X_train, pendulum.y_train)
    assert search.best_params_["rho"] in (0.01, 0.05, 0.1)
    assert search.best_score_ == pytest.approx(-theta_error(
        search.best_estimator_.theta_, {"omega": 2 / 3}), abs=1e-12) or search.refit
    # scikit-learn's own scorers need 2-D y: make_flat_scorer flattens the (n, steps, states)
    # targets and predictions per sample
    mse = make_flat_scorer("neg_mean_squared_error")
    scores = cross_validate(est, pendulum.X_train, pendulum.y_train, cv=2,
                            scoring={"theta": scorer, "mse": mse})
    assert np.all(np.isfinite(scores["test_mse"]))
    fitted = clone(est).fit(pendulum.X_train, pendulum.y_train)
    flat_pred = fitted.predict(pendulum.X_test).reshape(len(pendulum.X_test), -1)
    assert mse(fitted, pendulum.X_test, pendulum.y_test) == pytest.approx(-np.mean(
        (flat_pred - pendulum.y_test.reshape(len(pendulum.y_test), -1)) ** 2))
    assert np.all(scores["test_theta"] <= 0)
    _, valid = validation_curve(est, pendulum.X_train, pendulum.y_train, param_name="rho",
                                param_range=[0.01, 0.1], cv=2, scoring=scorer)
    assert valid.shape == (2, 2)


def test_gridsearch_over_a_setting_of_the_method_object(pendulum):
    """Issue 64: ``method=SAM()`` with a grid over ``method__rho`` searches the same fits as the flat ``rho``
    grid of ``method="sam"``, and leaves the user's method object as it was."""
    from sklearn_hybrid.methods import SAM

    scorer = make_theta_scorer({"omega": 2 / 3})
    method = SAM(rho=0.05)
    nested = GridSearchCV(HybridRegressor(science=pendulum_f, dt=0.2, method=method, **{**FAST, "max_iter": 10}),
                          {"method__rho": [0.01, 0.1]}, scoring=scorer, cv=2).fit(pendulum.X_train,
                                                                                   pendulum.y_train)
    flat = GridSearchCV(HybridRegressor(science=pendulum_f, dt=0.2, method="sam", **{**FAST, "max_iter": 10}),
                        {"rho": [0.01, 0.1]}, scoring=scorer, cv=2).fit(pendulum.X_train, pendulum.y_train)
    np.testing.assert_allclose(nested.cv_results_["mean_test_score"], flat.cv_results_["mean_test_score"])
    assert nested.best_params_["method__rho"] == flat.best_params_["rho"]
    assert nested.best_estimator_.method.rho == flat.best_params_["rho"] and method.rho == 0.05
    with pytest.raises(ValueError, match="Invalid parameter 'rh' for method SAM; its settings are"):
        HybridRegressor(science=pendulum_f, method=SAM()).set_params(method__rh=0.1)


def test_gridsearch_parallel(pendulum):
    est = HybridRegressor(science=pendulum_f, dt=0.2, **{**FAST, "max_iter": 5})
    search = GridSearchCV(est, {"rho": [0.01, 0.1]}, cv=2, n_jobs=2,
                          scoring=make_theta_scorer({"omega": 2 / 3})).fit(
        pendulum.X_train, pendulum.y_train)
    assert np.isfinite(search.best_score_)


def test_determinism(pendulum):
    X, y = pendulum.X_train, pendulum.y_train
    a = HybridRegressor(science=pendulum_f, dt=0.2, **FAST).fit(X, y)
    torch.manual_seed(123)  # the global RNG must not matter
    b = HybridRegressor(science=pendulum_f, dt=0.2, **FAST).fit(X, y)
    c = HybridRegressor(science=pendulum_f, dt=0.2, **{**FAST, "random_state": 1}).fit(X, y)
    assert a.theta_ == b.theta_
    np.testing.assert_array_equal(a.predict(X), b.predict(X))
    assert a.theta_ != c.theta_
    state = torch.random.get_rng_state()
    HybridRegressor(science=pendulum_f, dt=0.2, **FAST).fit(X, y)
    assert torch.equal(state, torch.random.get_rng_state())  # global RNG untouched


def test_clone_pickle_and_inputs_not_mutated(pendulum):
    X, y = pendulum.X_train.copy(), pendulum.y_train.copy()
    init = {"omega": 0.55}
    bounds = {"omega": (0.1, 2.0)}
    est = HybridRegressor(science=pendulum_f, dt=0.2, theta_init=init, theta_bounds=bounds,
                          **FAST)
    fitted = clone(est).fit(X, y)
    np.testing.assert_array_equal(X, pendulum.X_train)
    np.testing.assert_array_equal(y, pendulum.y_train)
    assert init == {"omega": 0.55} and bounds == {"omega": (0.1, 2.0)}
    assert not hasattr(est, "theta_")
    restored = pickle.loads(pickle.dumps(fitted))
    np.testing.assert_allclose(restored.predict(X), fitted.predict(X))


def test_bounds_fixed_and_vector_parameters():
    rng = np.random.default_rng(0)
    X = rng.normal(size=(40, 3))
    y = X @ np.array([1.0, -2.0, 0.5]) + 3.0

    def linear(x, w=[0.0, 0.0, 0.0], c=1.0):
        return x @ w + c

    est = HybridRegressor(science=linear, structure="additive", method="erm", lr=5e-2,
                          theta_fixed=["c"], theta_bounds={"w": (-1.5, 1.5)},
                          **{**FAST, "max_iter": 60}).fit(X, y)
    assert est.theta_["c"] == 1.0
    assert est.theta_["w"].shape == (3,)
    assert np.all(np.abs(est.history_["theta"]["w"]) < 1.5)


def test_compose_structure_with_freg_reduction():
    rng = np.random.default_rng(0)
    X = rng.uniform(0, 1, size=(30, 4))
    y = np.tanh(2.0 * X[:, :2])  # y depends on z = a * x[:, :2]

    def half(x, a=1.0):
        return a * x[:, :2]

    def wide(x, a=1.0):  # science output larger than y: f-reg learns a linear map A
        return a * x

    for science in (half, wide):
        est = HybridRegressor(science=science, structure="compose", method="f-reg",
                              **FAST).fit(X, y)
        assert est.predict(X).shape == y.shape
        assert (est.model_.reduction is None) == (science is half)


def test_callable_structure_nested():
    rng = np.random.default_rng(1)
    X = rng.uniform(-1, 1, size=(30, 2))
    y = np.sin(1.5 * X[:, :1]) * 2.0

    def scaled_sin(x, k=1.0):
        return torch.sin(k * x[:, :1])

    class Nets(torch.nn.Module):
        def __init__(self):
            super().__init__()
            self.inner = torch.nn.Linear(2, 1)
            self.outer = torch.nn.Linear(2, 1)

    def nested(x, f, g):
        return g.outer(torch.cat([x[:, :1], f(x) * g.inner(x)], dim=-1))

    est = HybridRegressor(science=scaled_sin, structure=nested, method="sam",
                          **{**FAST, "residual": Nets}).fit(X, y)
    assert est.predict(X).shape == (30, 1)


def test_forced_partially_observed_ode():
    """A damped oscillator driven by u(t), observing only the position."""
    rng = np.random.default_rng(0)
    n, m, dt = 8, 10, 0.1
    t = np.arange(m + 1) * dt
    u = np.sin(2 * np.pi * rng.uniform(0.5, 1.5, (n, 1)) * t)[:, :, None]
    x0 = rng.normal(size=(n, 2))
    X = pack_inputs(x0, u)

    def oscillator(v, u, k=1.0):
        return torch.stack([v[:, 1], -k * v[:, 0] + u[:, 0]], dim=-1)

    y = rng.normal(size=(n, m, 1))
    est = HybridRegressor(science=oscillator, dt=dt, n_inputs=1, observed=[0], **FAST).fit(X, y)
    assert est.predict(X).shape == (n, m, 1)
    for interp in ("linear", "zoh", "fft"):
        HybridRegressor(science=oscillator, dt=dt, n_inputs=1, observed=[0], input_interp=interp,
                        **{**FAST, "max_iter": 2}).fit(X, y)
    with pytest.raises(ValueError, match="expecting 13 features"):
        est.predict(X[:, :-1])


def test_rk4_matches_dopri5_and_closed_form():
    """Output-aligned RK4 against torchdiffeq's dopri5 and against exp(-t)."""
    x0 = torch.tensor([[1.0, 0.5], [-0.3, 2.0]], dtype=torch.float64)

    def rhs(v, u):
        return torch.stack([v[:, 1], -(2 * torch.pi * 2 / 3) ** 2 * torch.sin(v[:, 0])], -1)

    dopri = integrate(rhs, x0, 10, 0.2, solver="dopri5",
                      solver_options={"rtol": 1e-11, "atol": 1e-11})
    err8 = (integrate(rhs, x0, 10, 0.2, n_substeps=8) - dopri).abs().max()
    err16 = (integrate(rhs, x0, 10, 0.2, n_substeps=16) - dopri).abs().max()
    assert err8 < 5e-5
    assert 12 < err8 / err16 < 20  # fourth order: halving the step divides the error by 16
    decay = integrate(lambda v, u: -v, x0, 5, 0.5, n_substeps=4)
    expected = x0[:, None] * torch.exp(-0.5 * torch.arange(1, 6, dtype=torch.float64))[None, :, None]
    torch.testing.assert_close(decay, expected, atol=2e-5, rtol=0)


def test_dopri5_solver_fits(pendulum):
    est = HybridRegressor(science=pendulum_f, dt=0.2, solver="dopri5",
                          **{**FAST, "max_iter": 3}).fit(pendulum.X_train, pendulum.y_train)
    assert est.predict(pendulum.X_test).shape == pendulum.y_test.shape


def test_reaction_diffusion_field_state():
    rng = np.random.default_rng(0)
    X = rng.uniform(size=(3, 2, 8, 8))
    y = rng.uniform(size=(3, 2, 2, 8, 8))

    def diffusion(s, a=1e-3, b=1e-3):
        lap = (torch.roll(s, 1, -1) + torch.roll(s, -1, -1) + torch.roll(s, 1, -2)
               + torch.roll(s, -1, -2) - 4 * s)
        return torch.stack([a * lap[:, 0], b * lap[:, 1]], dim=1) * 64

    est = HybridRegressor(science=diffusion, dt=0.1, method="fsam",
                          **{**FAST, "max_iter": 3, "residual": "cnn"}).fit(X, y)
    assert est.predict(X).shape == y.shape
    # fields are named by their per-sample shape, not as "8 features"
    with pytest.raises(ValueError, match=r"X has per-sample shape \(8, 8, 2\); this model was fitted on \(2, 8, 8\)"):
        est.predict(np.moveaxis(X, 1, -1))
    with pytest.raises(ValueError, match=r"needs its leading axis: X\[None\]"):
        est.predict(X[0])


def test_verbose_progress_bar(pendulum, capsys):
    HybridRegressor(science=pendulum_f, dt=0.2, verbose=True, **{**FAST, "max_iter": 3}).fit(
        pendulum.X_train, pendulum.y_train)
    assert "omega" in capsys.readouterr().err


def test_minibatch(pendulum):
    est = HybridRegressor(science=pendulum_f, dt=0.2, batch_size=5, **FAST)
    est.fit(pendulum.X_train, pendulum.y_train)
    assert np.isfinite(est.history_["loss"]).all()


def test_predict_science_and_residual_trace(pendulum):
    est = HybridRegressor(science=pendulum_f, dt=0.2, **FAST).fit(pendulum.X_train, pendulum.y_train)
    science_only = est.predict_science(pendulum.X_test)
    assert science_only.shape == pendulum.y_test.shape
    assert not np.allclose(science_only, est.predict(pendulum.X_test))
    trace = est.residual_trace(pendulum.X_test)
    n, m = pendulum.y_test.shape[:2]
    assert trace["points"].shape == (n * (m + 1), 2) and trace["inputs"] is None
    g = est.residual_(torch.as_tensor(trace["points"], dtype=torch.float32)).detach().numpy()
    np.testing.assert_allclose(trace["residual"], g, rtol=1e-4, atol=1e-6)
    # the traced states are the predicted trajectory
    np.testing.assert_allclose(trace["points"].reshape(n, m + 1, 2)[:, 1:],
                               est.predict(pendulum.X_test), rtol=1e-6)


def test_pipeline_and_theta_scorer_through_it():
    from sklearn.pipeline import make_pipeline
    from sklearn.preprocessing import FunctionTransformer

    rng = np.random.default_rng(0)
    X = rng.uniform(-1, 1, size=(30, 2))
    y = 2.0 * np.exp(X[:, 0]) + 0.3 * X[:, 1] ** 2

    def scaled(x, a=1.0):
        return a * x[:, 0]

    pipe = make_pipeline(FunctionTransformer(np.exp),
                         HybridRegressor(science=scaled, structure="additive", **FAST))
    search = GridSearchCV(pipe, {"hybridregressor__lr": [1e-3, 1e-2]}, cv=2,
                          scoring=make_theta_scorer({"a": 2.0})).fit(X, y)
    assert search.best_score_ <= 0
    assert pipe.fit(X, y).predict(X).shape == (30,)


def test_lr_theta_gives_theta_its_own_step(pendulum):
    """Adam moves a parameter by about its learning rate per step: lr_theta scales theta's."""
    X, y = pendulum.X_train, pendulum.y_train
    common = dict(science=pendulum_f, dt=0.2, method="erm", **{**FAST, "max_iter": 5})
    slow = HybridRegressor(lr=1e-4, **common).fit(X, y)
    fast = HybridRegressor(lr=1e-4, lr_theta=1e-2, **common).fit(X, y)
    moved_slow = abs(slow.theta_["omega"] - 0.5)
    moved_fast = abs(fast.theta_["omega"] - 0.5)
    assert moved_slow < 6e-4 and moved_fast > 20 * moved_slow
    with pytest.raises(ValueError, match="lr_theta must be a positive number"):
        HybridRegressor(lr_theta=0.0, **common).fit(X, y)


def test_theta_drift_tells_a_frozen_theta_from_a_settled_one():
    """The window is the last 10 % of the summed learning rate, not of the iterations."""
    from sklearn_hybrid.training.schedule import TrainConfig, cosine_lr, theta_drift

    config = TrainConfig(lr=1e-2, max_iter=1000)
    lr = cosine_lr(config.lr, 1000, config)
    marching = 1.0 + np.cumsum(lr)  # Adam pushing steadily: one lr per step until the end
    settled = 1.0 + 0.5 * (1 - np.exp(-np.arange(1000) / 50.0))  # arrived early on
    drift = theta_drift({"a": marching, "b": settled}, lr)
    assert drift["a"] == pytest.approx(0.1 * (marching[-1] - 1.0) / marching[-1], rel=0.02)
    assert drift["b"] < 1e-4 < 1e-2 < drift["a"]
    last_iters = abs(marching[-1] - marching[900]) / marching[-1]  # plain 10 % of iterations
    assert last_iters < 0.05 * drift["a"]  # would call the frozen theta settled
    constant = TrainConfig(lr=1e-2, max_iter=1000, min_lr=1e-2)
    np.testing.assert_allclose(cosine_lr(1e-2, 1000, constant), 1e-2)
    vector = theta_drift({"v": np.stack([settled, marching], axis=1)}, lr)
    assert vector["v"] == pytest.approx(drift["a"])


def test_theta_drift_attribute_and_schedule_match_the_optimizer(pendulum):
    X, y = pendulum.X_train, pendulum.y_train
    est = HybridRegressor(science=pendulum_f, dt=0.2, method="erm", lr=1e-2, lr_theta=3e-2,
                          tol=None, **FAST).fit(X, y)
    from sklearn_hybrid.training.schedule import TrainConfig, cosine_lr, make_optimizer, theta_drift

    config = TrainConfig(lr=1e-2, lr_theta=3e-2, max_iter=30)
    p = torch.nn.Parameter(torch.zeros(1))
    optimizer, scheduler = make_optimizer([p], [torch.nn.Parameter(torch.zeros(1))], config)
    seen = []
    for _ in range(30):
        seen.append(optimizer.param_groups[0]["lr"])
        optimizer.step(), scheduler.step()
    np.testing.assert_allclose(cosine_lr(3e-2, 30, config), seen, rtol=1e-6)
    assert est.theta_drift_ == pytest.approx(
        theta_drift(est.history_["theta"], cosine_lr(3e-2, 30, config)))
    assert set(est.theta_drift_) == {"omega"} and est.theta_drift_["omega"] > 0
    assert "theta drift" in est.fit_report()


def test_passes_after_fit_take_what_the_fits_memory_allows(monkeypatch):
    # the paper-size pendulum images asked for 48 GB after training (standard errors over all
    # 200 sequences at once in float64): predict and the standard errors now run in passes of
    # the size the fit's own memory estimate allows, decided once at fit
    import sklearn_hybrid.training.memory as memory
    from sklearn_hybrid._fit_report import theta_uncertainty

    data = make_pendulum(10, 2, 2, random_state=0)
    est = HybridRegressor(science=pendulum_f, dt=data.dt, batch_size=4, max_iter=3, random_state=0)
    assert est.fit(data.X_train, data.y_train)._samples_per_pass == memory.PASS_SIZE_MAX  # plenty
    whole, whole_std = est.predict(data.X_train), est.theta_std_["omega"]
    # 1 kB per training sample in float32, 2 kB in float64; half of 8 kB holds two samples
    monkeypatch.setattr(memory, "fit_memory_bytes", lambda model, inputs, n_batch: 1000 * n_batch)
    monkeypatch.setattr(memory, "available_memory_bytes", lambda device=None: 8000)
    est.fit(data.X_train, data.y_train)
    assert est._samples_per_pass == 2
    sizes = []
    hook = est.model_.register_forward_pre_hook(lambda module, args: sizes.append(len(args[0])))
    prediction = est.predict(data.X_train)
    hook.remove()
    assert sizes == [2] * 5
    np.testing.assert_allclose(prediction, whole, rtol=1e-6, atol=1e-6)  # float32: a pass of 2 rounds differently
    assert est.theta_std_["omega"] == pytest.approx(whole_std, rel=1e-6)  # in passes of 2
    inputs = est.model_.structure.tensors(est._structure_X(est._fitted_X(data.X_train)), torch.float32)
    y = torch.as_tensor(data.y_train, dtype=torch.float32)
    one, chunked = (theta_uncertainty(est.model_, inputs, y, chunk=c)[0]["omega"] for c in (None, 3))
    assert chunked == pytest.approx(one, rel=1e-9) and np.isfinite(one) and one > 0


def test_a_model_with_every_parameter_held_predicts_no_more_than_it_needs(monkeypatch):
    """Without a network the science part's loss is the loss (the verdict predicts once, not twice), and
    with every parameter held there is no standard error to compute (no prediction for it): on a long
    record each of those passes integrates every step."""
    from sklearn_hybrid import _fit_report
    from sklearn_hybrid.residual import ZeroResidual
    from sklearn_hybrid.training import verdict

    data = make_pendulum(8, 2, 2, random_state=0)
    passes = {"science alone": 0, "standard errors": 0}
    predict, flat = verdict._predict, _fit_report.flat_predictions

    def counted_predict(model, inputs, chunk, use_residual=True):
        passes["science alone"] += not use_residual
        return predict(model, inputs, chunk, use_residual)

    monkeypatch.setattr(verdict, "_predict", counted_predict)
    def counted_flat(*args, **kwargs):
        passes["standard errors"] += 1
        return flat(*args, **kwargs)

    monkeypatch.setattr(_fit_report, "flat_predictions", counted_flat)
    held = HybridRegressor(science=pendulum_f, dt=data.dt, residual=ZeroResidual(), method="erm", max_iter=30,
                           theta_fixed={"omega": 0.6}, verbose=False).fit(data.X_train, data.y_train)
    assert passes == {"science alone": 0, "standard errors": 0}
    assert held.theta_std_ == {"omega": 0.0}
    free = HybridRegressor(science=pendulum_f, dt=data.dt, max_iter=30, random_state=0,
                           verbose=False).fit(data.X_train, data.y_train)
    assert passes["science alone"] == 1 and passes["standard errors"] == 3  # base and +-h of omega
    assert np.isfinite(free.theta_std_["omega"]) and free.theta_std_["omega"] > 0


def test_theta_jacobian_in_one_vectorised_pass_matches_one_pass_per_step():
    """``theta_jacobian`` with ``predict_many`` (every step of the central differences in one batch)
    gives the differences of one prediction per step, through the bounds' transform; a batch that raises
    or does not reproduce ``base`` is not used."""
    from sklearn_hybrid._fit_report import theta_jacobian
    from sklearn_hybrid.science import ScienceModel

    def f(x, a=2.0, b=(0.5, 1.5)):
        return a * x[:, :1] ** 2 + b[0] * x[:, 1:] + torch.exp(b[1] * x[:, :1])

    science = ScienceModel(f, theta_bounds={"a": (0.0, 10.0)}, dtype=torch.float64)
    x = torch.linspace(-1, 1, 14, dtype=torch.float64).reshape(7, 2)

    def predict():
        return science(x).detach().numpy()

    def predict_many(raw):
        values = {n: science.transforms[n](raw[n]) for n in raw}
        return torch.stack([f(x, values["a"][i], values["b"][i]) for i in range(len(values["a"]))]).detach().numpy()

    entries = [("a", 0), ("b", 0), ("b", 1)]
    base = predict()
    before = {n: science.raw[n].detach().clone() for n in science.names}
    one_by_one = theta_jacobian(science, predict, entries)
    batched = theta_jacobian(science, predict, entries, predict_many, base)
    np.testing.assert_allclose(batched, one_by_one, rtol=1e-12, atol=1e-12)
    # the analytic derivatives, in theta's own units
    np.testing.assert_allclose(one_by_one[..., 0], x[:, :1].numpy() ** 2, rtol=1e-5)
    np.testing.assert_allclose(one_by_one[..., 1], x[:, 1:].numpy(), rtol=1e-5, atol=1e-9)
    assert all(torch.equal(science.raw[n], before[n]) for n in science.names)  # theta left as it was
    wrong = theta_jacobian(science, predict, entries, lambda raw: predict_many(raw) + 1.0, base)
    failing = theta_jacobian(science, predict, entries, lambda raw: 1 / 0, base)
    np.testing.assert_allclose(wrong, one_by_one, rtol=1e-12)
    np.testing.assert_allclose(failing, one_by_one, rtol=1e-12)


def test_a_model_with_every_parameter_held_is_evaluated_not_trained(monkeypatch):
    """The closed loop's network-free estimator holds every theta and has no network: its one iteration
    evaluates the loss without a backward pass (on long records that pass cost seconds), its network
    share is 0 without predicting twice, and a SAM-family fit of the science alone still moves theta."""
    from sklearn_hybrid.residual import MLP, ZeroResidual, is_zero_residual

    data = make_pendulum(8, 2, 2, random_state=0)
    backward = []
    original = torch.autograd.grad
    monkeypatch.setattr(torch.autograd, "grad", lambda *a, **k: backward.append(1) or original(*a, **k))
    held = HybridRegressor(science=pendulum_f, dt=data.dt, residual=ZeroResidual(), method="erm", max_iter=1,
                           theta_fixed={"omega": 0.6}, verbose=False).fit(data.X_train, data.y_train)
    assert backward == [] and held.n_iter_ == 1 and held.theta_["omega"] == pytest.approx(0.6)
    assert held.network_share_ == 0.0
    assert is_zero_residual(held.model_.residual)
    assert not is_zero_residual(MLP([(2,)], (2,)))  # a network that starts at zero is still a network
    science_alone = held.predict(data.X_train)
    np.testing.assert_allclose(held.history_["loss"][0], np.mean((science_alone - data.y_train) ** 2), rtol=1e-5)
    free = {m: HybridRegressor(science=pendulum_f, dt=data.dt, residual=ZeroResidual(), method=m, max_iter=20,
                               random_state=0, verbose=False).fit(data.X_train, data.y_train).theta_["omega"]
            for m in ("erm", "fsam")}
    assert free["fsam"] == pytest.approx(free["erm"]) and free["erm"] != pytest.approx(0.5)  # nothing to perturb
