"""HybridRegressorCV: K configurations trained as one batched model equal K separate fits."""

import numpy as np
import pytest
import torch
from sklearn.base import clone

from sklearn_hybrid import DivergenceError, HybridRegressor, HybridRegressorCV, _cv, make_theta_scorer
from sklearn_hybrid.integrate import fast as fast_rk4
from sklearn_hybrid.models import pendulum_f


def linear_f(x, a=1.0):
    return a * x[:, :2]


@pytest.fixture(scope="module")
def pendulum():
    rng = np.random.default_rng(0)
    X = rng.uniform(-1, 1, (12, 2))
    t = 0.2 * np.arange(1, 4)
    y = np.stack([X[:, 0:1] * np.cos(4 * t) + X[:, 1:2] * np.sin(4 * t) / 4,
                  -4 * X[:, 0:1] * np.sin(4 * t) + X[:, 1:2] * np.cos(4 * t)], axis=-1)
    return X, y


def _assert_members_equal_separate_fits(cv, base, X, y, tol):
    for params, member in zip(cv.cv_results_["params"], cv.estimators_):
        alone = clone(member).fit(X, y)  # the template with the member's settings
        assert alone.random_state == params["random_state"] and getattr(alone.method, "rho", None) in (None, params["rho"])
        for name, value in alone.theta_.items():
            np.testing.assert_allclose(member.theta_[name], value, rtol=tol, atol=tol)
        np.testing.assert_allclose(member.history_["loss"], alone.history_["loss"], rtol=tol, atol=tol)
        np.testing.assert_allclose(member.predict(X), alone.predict(X), rtol=tol, atol=tol)


@pytest.mark.parametrize("method", ["erm", "fsam", "asam", "p-reg"])
@pytest.mark.parametrize("dtype, tol", [("float64", 1e-10), ("float32", 2e-5)])
def test_batched_equals_separate_fits_ode(pendulum, method, dtype, tol):
    X, y = pendulum
    base = HybridRegressor(science=pendulum_f, method=method, dt=0.2, max_iter=8, lr=1e-2,
                           residual={"hidden": (8, 8)}, dtype=dtype, batch_size=8)
    sweep = {"lams": [1e-3, 1e-1]} if method == "p-reg" else {"rhos": [0.02, 0.2]}
    cv = HybridRegressorCV(base, seeds=[0, 5], validation_fraction=None, **sweep).fit(X, y)
    assert len(cv.estimators_) == 4
    _assert_members_equal_separate_fits(cv, base, X, y, tol)


def test_batched_generic_path_equals_separate_fits():
    """Structures the fast path does not serve run under torch.func.vmap."""
    rng = np.random.default_rng(1)
    X = rng.normal(size=(16, 3))
    y = np.stack([1.5 * X[:, 0] + np.sin(X[:, 2]), 1.5 * X[:, 1]], axis=1)
    base = HybridRegressor(science=linear_f, structure="additive", method="sam", max_iter=6,
                           residual={"hidden": (8,)}, dtype="float64")
    cv = HybridRegressorCV(base, rhos=[0.05, 0.5], seeds=[0, 1], validation_fraction=None).fit(X, y)
    _assert_members_equal_separate_fits(cv, base, X, y, 1e-10)
    with fast_rk4.disabled():  # an ODE through the generic batched path too
        X2, y2 = X[:, :2], np.stack([X[:, :2]] * 2, axis=1)
        base2 = HybridRegressor(science=pendulum_f, method="fsam", dt=0.1, max_iter=3,
                                residual={"hidden": (8,)}, dtype="float64")
        cv2 = HybridRegressorCV(base2, rhos=[0.1], seeds=[0, 1], validation_fraction=None).fit(X2, y2)
        _assert_members_equal_separate_fits(cv2, base2, X2, y2, 1e-10)


def test_selection_uncertainty_and_results(pendulum):
    X, y = pendulum
    base = HybridRegressor(science=pendulum_f, method="fsam", dt=0.2, max_iter=10, lr=1e-2,
                           residual={"hidden": (8,)}, random_state=0)
    scorer = make_theta_scorer({"omega": 4 / (2 * np.pi)})
    cv = HybridRegressorCV(base, rhos=[0.01, 0.3], seeds=[0, 1, 2], scoring=scorer).fit(X, y)
    res = cv.cv_results_
    assert len(res["params"]) == 6 and res["score"].shape == (6,)
    assert res["theta_omega"].shape == (6,) and (res["diverged_at"] == -1).all()
    assert cv.best_index_ == int(np.argmax(res["score"]))
    assert cv.best_estimator_ is cv.estimators_[cv.best_index_]
    assert cv.theta_ == cv.best_estimator_.theta_
    same = [k for k, p in enumerate(res["params"]) if p["rho"] == cv.best_params_["rho"]]
    assert cv.theta_std_["omega"] == pytest.approx(np.std(res["theta_omega"][same]))
    assert cv.theta_std_["omega"] > 0  # seeds differ
    assert cv.predict(X).shape == y.shape
    assert cv.score(X, y) == pytest.approx(cv.best_estimator_.score(X, y))
    assert cv.n_features_in_ == 2
    # members train on the same 80 %: a member equals a separate fit on those samples
    train = np.setdiff1d(np.arange(len(X)), np.random.default_rng(0).permutation(len(X))[:2])
    alone = clone(cv.estimators_[0]).fit(X[train], y[train])
    assert alone.theta_["omega"] == pytest.approx(res["theta_omega"][0], rel=1e-5)


def test_clone_and_defaults(pendulum):
    X, y = pendulum
    base = HybridRegressor(science=pendulum_f, method="sam", dt=0.2, max_iter=3,
                           residual={"hidden": (8,)}, random_state=4)
    cv = HybridRegressorCV(base)
    assert clone(cv).get_params()["estimator__random_state"] == 4
    cv.fit(X, y)
    # the method's own rho; lam, which SAM does not have, at the class default (and ignored)
    assert cv.cv_results_["params"] == [{"rho": 0.05, "lam": 1e-3, "random_state": 4}]


def test_bad_input(pendulum):
    X, y = pendulum
    base = HybridRegressor(science=pendulum_f, dt=0.2, max_iter=2, residual={"hidden": (8,)})
    with pytest.raises(TypeError, match="HybridRegressor"):
        HybridRegressorCV(object()).fit(X, y)
    with pytest.raises(ValueError, match="f-reg"):
        HybridRegressorCV(clone(base).set_params(method="f-reg")).fit(X, y)
    with pytest.raises(ValueError, match="rhos"):
        HybridRegressorCV(base, rhos=[0.1, -1]).fit(X, y)
    with pytest.raises(ValueError, match="validation_fraction"):
        HybridRegressorCV(base, validation_fraction=1.5).fit(X, y)
    with pytest.raises(ValueError, match="NaN"):
        HybridRegressorCV(base).fit(np.full_like(X, np.nan), y)


def test_one_diverging_member_does_not_spoil_the_others(pendulum, monkeypatch):
    X, y = pendulum
    base = HybridRegressor(science=pendulum_f, method="erm", dt=0.2, max_iter=6,
                           residual={"hidden": (8,)}, theta_bounds={"omega": (0.1, 5.0)})
    cv = HybridRegressorCV(base, seeds=[0, 1], validation_fraction=None)
    # seed 1's network starts with an infinite weight: only that member diverges
    original = _cv.prepare_fit

    def poisoned(estimator, X, y):
        setup = original(estimator, X, y)
        if estimator.random_state == 1:
            with torch.no_grad():
                setup.model.residual.net[0].weight[0, 0] = float("inf")
        return setup

    monkeypatch.setattr(_cv, "prepare_fit", poisoned)
    cv.fit(X, y)
    assert list(cv.cv_results_["diverged_at"]) == [-1, 0]
    assert cv.best_index_ == 0 and np.isfinite(cv.theta_["omega"])
    alone = clone(base).set_params(random_state=0).fit(X, y)
    assert cv.theta_["omega"] == pytest.approx(alone.theta_["omega"], rel=1e-5)


def test_groups_in_worker_processes_match_one_group(pendulum):
    X, y = pendulum
    base = HybridRegressor(science=pendulum_f, method="fsam", dt=0.2, max_iter=5,
                           residual={"hidden": (8,)}, dtype="float64")
    kw = dict(rhos=[0.05, 0.1, 0.2], seeds=[0, 1], validation_fraction=None)
    one = HybridRegressorCV(base, **kw).fit(X, y)
    two = HybridRegressorCV(base, n_jobs=2, **kw).fit(X, y)
    np.testing.assert_allclose(two.cv_results_["theta_omega"], one.cv_results_["theta_omega"],
                               rtol=1e-10)
    np.testing.assert_allclose(two.cv_results_["score"], one.cv_results_["score"], rtol=1e-10)
    with pytest.raises(ValueError, match="n_jobs"):
        HybridRegressorCV(base, n_jobs=0, **kw).fit(X, y)


def test_every_member_diverging_raises(pendulum):
    X, y = pendulum
    def grows(v, omega=0.5):  # finite at the initial states, infinite along the trajectory
        return torch.exp(torch.exp(3 * v)) * omega

    # (a y of 1e30 used to make them diverge; the fit now refuses it before training: float32 overflow)
    base = HybridRegressor(science=grows, method="erm", dt=0.2, max_iter=3,
                           residual={"hidden": (8,)})
    with pytest.raises(DivergenceError, match="every member"):
        HybridRegressorCV(base, seeds=[0, 1]).fit(X, y)


def test_science_mixing_samples_uses_the_generic_path():
    def centred_f(v, k=1.0):
        return -k * (v - v.mean(0))

    rng = np.random.default_rng(0)
    X = rng.uniform(-1, 1, (8, 2))
    y = np.stack([X * 0.9, X * 0.8], axis=1)
    base = HybridRegressor(science=centred_f, method="sam", dt=0.1, max_iter=4, dtype="float64",
                           residual={"hidden": (8,)})
    cv = HybridRegressorCV(base, seeds=[0, 1], validation_fraction=None).fit(X, y)
    _assert_members_equal_separate_fits(cv, base, X, y, 1e-10)
