"""Conventions of issue 12: early stopping, uncertainty and fit report, simulation beyond the
training horizon, structure parameters changed after fit, nested residual parameters, sample weights."""

import numpy as np
import pytest
import torch
from sklearn.base import clone
from sklearn.model_selection import GridSearchCV

from sklearn_hybrid import HybridRegressor, HybridRegressorCV, pack_inputs
from sklearn_hybrid.training.stopping import EarlyStopping
from sklearn_hybrid.datasets import make_pendulum
from sklearn_hybrid.diagnosis import free_run

SMALL = dict(residual={"hidden": (16, 16)}, random_state=0, dt=0.2)


def pendulum_f(v, omega=0.5):
    return torch.stack([v[:, 1], -(2 * torch.pi * omega) ** 2 * torch.sin(v[:, 0])], dim=-1)


def line(x, a=0.5, b=0.0):
    return a * x[:, 0] + b


@pytest.fixture(scope="module")
def pendulum():
    return make_pendulum(n_train=12, n_val=4, n_test=4, n_steps=5, random_state=0)


@pytest.fixture(scope="module")
def fitted(pendulum):
    return HybridRegressor(science=pendulum_f, method="erm", lr=1e-2, max_iter=80, tol=None,
                           **SMALL).fit(pendulum.X_train, pendulum.y_train)


# ---------------------------------------------------------------- early stopping
def test_stopping_rule_needs_flat_loss_and_still_theta():
    losses = np.ones(400)
    rule = EarlyStopping(tol=1e-3, n_iter_no_change=100)
    # theta still moving: no stop although the loss is flat
    assert not any(rule.should_stop(it, losses, np.array([1.0 + it * 1e-3])) for it in range(300))
    rule = EarlyStopping(tol=1e-3, n_iter_no_change=100)
    stops = [it for it in range(400) if rule.should_stop(it, losses, np.array([1.0]))]
    assert stops[0] == 199  # the earliest stop: the end of the second window
    falling = np.linspace(1, 0, 400)  # the loss still improves (scale 1): no stop
    rule = EarlyStopping(tol=1e-3, n_iter_no_change=100)
    assert not any(rule.should_stop(it, falling, np.array([1.0])) for it in range(400))


def test_early_stopping_ends_a_converged_fit_and_n_iter_tells(pendulum):
    X, y = pendulum.X_train, pendulum.y_train
    est = HybridRegressor(science=pendulum_f, method="erm", lr=1e-2, max_iter=3000, tol=1e-2,
                          n_iter_no_change=20, **SMALL).fit(X, y)
    assert est.stopped_early_ and est.n_iter_ < 3000 and est.n_iter_ % 20 == 0
    assert len(est.history_["loss"]) == est.n_iter_ == est.history_["n_iter"]
    assert est.history_["theta"]["omega"].shape == (est.n_iter_,)
    assert "stopped early" in est.fit_report()
    off = clone(est).set_params(tol=None, max_iter=50).fit(X, y)
    assert off.n_iter_ == 50 and not off.stopped_early_


def test_early_stopping_on_validation_loss(pendulum):
    X, y = pendulum.X_train, pendulum.y_train
    est = HybridRegressor(science=pendulum_f, method="erm", lr=1e-2, max_iter=60, tol=1e-3,
                          n_iter_no_change=20, validation_fraction=0.25, **SMALL).fit(X, y)
    assert est.history_["validation_loss"].shape == (3,)
    assert np.all(np.isfinite(est.history_["validation_loss"]))
    with pytest.raises(ValueError, match="validation_fraction"):
        clone(est).set_params(validation_fraction=1.5).fit(X, y)
    with pytest.raises(ValueError, match="tol"):
        clone(est).set_params(tol=-1.0).fit(X, y)


# ---------------------------------------------------------------- uncertainty and report
def test_theta_std_matches_least_squares_on_a_linear_model():
    """With the network contributing nothing, the standard errors are those of linear regression."""
    rng = np.random.default_rng(0)
    X = rng.normal(size=(200, 1))
    y = 2.0 * X[:, 0] + 1.0 + 0.1 * rng.normal(size=200)
    est = HybridRegressor(science=line, structure="additive", method="erm", lr=5e-2, max_iter=400,
                          tol=None, residual=lambda i, o: _Zero(), dtype="float64",
                          random_state=0).fit(X, y)
    A = np.column_stack([X[:, 0], np.ones(200)])
    coef, rss, *_ = np.linalg.lstsq(A, y, rcond=None)
    cov = rss[0] / (200 - 2) * np.linalg.inv(A.T @ A)
    assert est.theta_["a"] == pytest.approx(coef[0], abs=1e-4)
    assert est.theta_std_["a"] == pytest.approx(np.sqrt(cov[0, 0]), rel=1e-3)
    assert est.theta_std_["b"] == pytest.approx(np.sqrt(cov[1, 1]), rel=1e-3)
    np.testing.assert_allclose(est.theta_cov_, cov, rtol=1e-3, atol=1e-9)
    report = est.fit_report()
    assert f"a: {est.theta_['a']:.6g}  (noise-only standard error {est.theta_std_['a']:.6g})" in report
    assert "95 % interval" not in report  # no interval without a profile that the benchmark backs
    assert "Gauss-Newton" in report


class _Zero(torch.nn.Module):
    def forward(self, x):
        return torch.zeros(len(x), dtype=x.dtype)


def test_fixed_parameter_has_zero_std_and_is_marked(pendulum):
    def damped(v, omega=0.5, gamma=0.5):
        return torch.stack([v[:, 1], -(2 * torch.pi * omega) ** 2 * torch.sin(v[:, 0])
                            - gamma * v[:, 1]], dim=-1)

    est = HybridRegressor(science=damped, theta_fixed=["gamma"], method="erm", max_iter=5,
                          **SMALL).fit(pendulum.X_train, pendulum.y_train)
    assert est.theta_std_["gamma"] == 0.0 and est.theta_std_["omega"] > 0
    assert est.theta_cov_.shape == (1, 1)
    assert "gamma: 0.5  (noise-only standard error 0)  (fixed)" in est.fit_report()


def test_report_with_a_theta_encoder_says_theta_is_inferred_not_fixed():
    data = make_pendulum(omega=(0.1, 1.0), n_train=12, n_val=2, n_test=2, n_input_steps=10, random_state=0)
    est = HybridRegressor(science=pendulum_f, theta_encoder="mlp", method="erm", max_iter=3,
                          theta_bounds={"omega": (np.float64(0.1), 2)}, **{**SMALL, "dt": data.dt})
    report = est.fit(data.X_train, data.y_train).fit_report()
    line = next(row for row in report.splitlines() if row.strip().startswith("omega:"))
    assert "inferred per sample" in line and "(bounds (0.1, 2.0))" in line
    assert "fixed" not in line and "nan" not in line and "+/-" not in line
    assert "predict_theta(X)" in report


def test_a_start_far_above_a_one_sided_bound_stays_finite(pendulum):
    """lmfit-style positivity on a parameter in the thousands (a stiffness in N/m): the start is kept, and two
    steps move it by at most about the learning rate relative to its size (not to 1e-3 of it, nor to infinity)."""
    def heavy(v, m=1000.0):
        return pendulum_f(v, 0.5) * (m / 1000.0)

    est = HybridRegressor(science=heavy, theta_bounds={"m": (0, None)}, method="erm", max_iter=2, **SMALL)
    m = est.fit(pendulum.X_train, pendulum.y_train).theta_["m"]
    assert m == pytest.approx(1000.0, rel=2.5 * 2 * est.lr) and m != pytest.approx(1000.0, rel=1e-3)


def test_reversed_views_are_read_like_copies(pendulum, fitted):
    """A negative-stride view (X[::-1]) is valid input; torch refuses it, so it is copied first."""
    X, y = pendulum.X_train[::-1], pendulum.y_train[::-1]
    a = HybridRegressor(science=pendulum_f, method="erm", max_iter=3, **SMALL).fit(X, y)
    b = HybridRegressor(science=pendulum_f, method="erm", max_iter=3, **SMALL).fit(X.copy(), y.copy())
    assert a.theta_ == b.theta_
    np.testing.assert_array_equal(fitted.predict(X), fitted.predict(X.copy()))
    assert fitted.score(X, y) == fitted.score(X.copy(), y.copy())
    np.testing.assert_array_equal(fitted.simulate(X, 3), fitted.simulate(X.copy(), 3))


def test_sweep_report_gives_the_spread_across_seeds(pendulum):
    cv = HybridRegressorCV(HybridRegressor(science=pendulum_f, method="erm", max_iter=5, **SMALL),
                           seeds=[0, 1]).fit(pendulum.X_train, pendulum.y_train)
    spread = np.std([m.theta_["omega"] for m in cv.estimators_])
    assert cv.theta_std_["omega"] == pytest.approx(spread)
    assert "standard deviation across the 2 seed(s)" in cv.fit_report()
    assert all(hasattr(m, "theta_std_") for m in cv.estimators_)


# ---------------------------------------------------------------- simulation beyond training
def test_simulate_extends_predict(fitted, pendulum):
    X = pendulum.X_test
    long = fitted.simulate(X, 40)
    assert long.shape == (len(X), 41, 2)
    np.testing.assert_array_equal(long[:, 0], X)
    np.testing.assert_allclose(long[:, 1:6], fitted.predict(X), rtol=1e-5, atol=1e-6)
    single = fitted.simulate(X[0], 40)
    np.testing.assert_allclose(single, long[0], rtol=1e-5, atol=1e-6)  # float32: batch size rounds
    # half the output spacing: every second output is on the training grid
    fine = fitted.simulate(X, 20, dt=0.1)
    np.testing.assert_allclose(fine[:, ::2], long[:, :11], atol=2e-4)
    science = fitted.simulate(X, 5, use_residual=False)
    np.testing.assert_allclose(science[:, 1:], fitted.predict_science(X), rtol=1e-5, atol=1e-6)
    np.testing.assert_allclose(free_run(fitted, X, n_steps=40), long)
    with pytest.raises(ValueError, match="n_steps"):
        fitted.simulate(X, 0)
    with pytest.raises(ValueError, match="x0 has shape"):
        fitted.simulate(X[:, :1], 5)
    with pytest.raises(ValueError, match="no inputs"):
        fitted.simulate(X, 5, u=np.zeros((len(X), 6, 1)))


def test_simulate_forced_system():
    def forced(v, u, k=1.0):
        return torch.stack([v[:, 1], u[:, 0] - k * v[:, 0]], dim=-1)

    rng = np.random.default_rng(0)
    x0, u = rng.normal(size=(6, 2)), rng.normal(size=(6, 6, 1))
    y = rng.normal(size=(6, 5, 1))
    est = HybridRegressor(science=forced, n_inputs=1, observed=[0], method="erm", max_iter=3,
                          **SMALL).fit(pack_inputs(x0, u), y)
    u_long = rng.normal(size=(6, 21, 1))
    states = est.simulate(x0, u=u_long)
    assert states.shape == (6, 21, 2)
    np.testing.assert_allclose(est.simulate(x0, u=u)[:, 1:, [0]], est.predict(pack_inputs(x0, u)),
                               rtol=1e-5, atol=1e-6)
    with pytest.raises(ValueError, match="forced"):
        est.simulate(x0, 5)
    with pytest.raises(ValueError, match="disagrees"):
        est.simulate(x0, 3, u=u_long)
    # one flag per initial state: hybrid and science-only runs in one batch
    flags = np.array([True, False] * 3)
    mixed = est.simulate(x0, u=u_long, use_residual=flags)
    np.testing.assert_allclose(mixed[flags], est.simulate(x0[flags], u=u_long[flags]), rtol=1e-5, atol=1e-6)
    np.testing.assert_allclose(mixed[~flags], est.simulate(x0[~flags], u=u_long[~flags], use_residual=False),
                               rtol=1e-5, atol=1e-6)
    for bad in (np.array([True, False]), np.ones(6)):
        with pytest.raises(ValueError, match="use_residual must be a bool or 6 bools"):
            est.simulate(x0, u=u_long, use_residual=bad)


def test_simulate_needs_an_ode():
    X = np.random.default_rng(0).normal(size=(20, 2))
    est = HybridRegressor(science=line, structure="additive", max_iter=2, random_state=0,
                          residual={"hidden": (4,)}).fit(X, X[:, 0])
    with pytest.raises(ValueError, match="structure='ode'"):
        est.simulate(X, 3)


def test_changing_a_structure_parameter_after_fit_raises(fitted, pendulum):
    est = clone(fitted)
    est.fit(pendulum.X_train[:4], pendulum.y_train[:4])
    for name, value in (("dt", 0.1), ("n_substeps", 8), ("solver", "dopri5")):
        est.set_params(**{name: value})
        with pytest.raises(ValueError, match=f"{name}=.* was changed after fit"):
            est.predict(pendulum.X_test)
        est.set_params(**{name: fitted.get_params()[name]})
    est.predict(pendulum.X_test)  # set back: fine
    est.set_params(max_iter=7)  # a training parameter: applies at the next fit
    est.predict(pendulum.X_test)


# ---------------------------------------------------------------- nested residual parameters
def test_nested_residual_parameters(pendulum):
    spec = {"hidden": (16, 16), "activation": "tanh"}
    est = HybridRegressor(science=pendulum_f, residual=spec)
    est.set_params(residual__hidden=(8,))
    assert est.residual == {"hidden": (8,), "activation": "tanh"}
    assert spec == {"hidden": (16, 16), "activation": "tanh"}  # the user's dict is not changed
    assert HybridRegressor(science=pendulum_f).set_params(residual__hidden=(4,)).residual == \
        {"kind": "mlp", "hidden": (4,)}
    with pytest.raises(ValueError, match="residual__hidden .*residual is a function"):
        HybridRegressor(science=pendulum_f, residual=lambda i, o: None).set_params(residual__hidden=(4,))
    search = GridSearchCV(HybridRegressor(science=pendulum_f, method="erm", max_iter=2, **SMALL),
                          {"residual__hidden": [(4,), (8,)]}, cv=2)
    search.fit(pendulum.X_train, pendulum.y_train)
    assert search.best_estimator_.residual_.net[0].out_features in (4, 8)


# ---------------------------------------------------------------- sample weights
def test_sample_weight_equals_duplication_and_score_uses_it(pendulum):
    X, y = pendulum.X_train[:6], pendulum.y_train[:6]
    params = dict(science=pendulum_f, method="erm", max_iter=15, tol=None, dtype="float64", **SMALL)
    w = np.array([2.0, 1, 1, 1, 1, 0])
    weighted = HybridRegressor(**params).fit(X, y, sample_weight=w)
    duplicated = HybridRegressor(**params).fit(np.r_[X[:1], X[:5]], np.r_[y[:1], y[:5]])
    assert weighted.theta_["omega"] == pytest.approx(duplicated.theta_["omega"], rel=1e-9)
    ones = HybridRegressor(**params).fit(X, y, sample_weight=np.ones(6))
    plain = HybridRegressor(**params).fit(X, y)
    assert ones.theta_["omega"] == pytest.approx(plain.theta_["omega"], rel=1e-12)
    assert weighted.score(X, y, sample_weight=w) != weighted.score(X, y)
    for bad, match in ((np.ones(5), "shape"), (-np.ones(6), "non-negative"), (np.zeros(6), "zero")):
        with pytest.raises(ValueError, match=match):
            HybridRegressor(**params).fit(X, y, sample_weight=bad)


def test_standard_errors_of_a_short_minibatch_fit_use_a_subset():
    """1 + 2p passes over every sample would cost far more than a few mini-batches trained:
    a random subset, its covariance scaled to all samples, close to the full computation."""
    import torch

    from sklearn_hybrid._fit_report import theta_uncertainty

    data = make_pendulum(n_train=600, n_val=1, n_test=1, n_steps=3, random_state=0)
    est = HybridRegressor(science=pendulum_f, dt=data.dt, method="erm", max_iter=3, batch_size=16,
                          residual={"hidden": (8,)}, random_state=0).fit(data.X_train, data.y_train)
    assert est._standard_error_samples == (32, 600)
    inputs = est.model_.structure.tensors(data.X_train, torch.float32)
    y = torch.tensor(data.y_train.reshape(600, -1), dtype=torch.float32)
    full, _, _ = theta_uncertainty(est.model_, inputs, y)
    assert full["omega"] / 2 < est.theta_std_["omega"] < 2 * full["omega"]
    assert "from 32 of 600 samples" in est.fit_report()
