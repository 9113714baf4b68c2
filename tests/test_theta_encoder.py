"""theta_encoder: theta varying per sample, inferred from each sample's input window."""

import pickle

import numpy as np
import pytest
import torch
from sklearn.base import clone
from sklearn.exceptions import NotFittedError
from sklearn.model_selection import GridSearchCV

from sklearn_hybrid import (HybridRegressor, HybridRegressorCV, make_per_sample_theta_scorer,
                            theta_error)
from sklearn_hybrid.encoder import build_encoder
from sklearn_hybrid.integrate import integrate

DT = 0.2


def decay_f(v, k=1.0):
    """dv/dt = -k v; ``-k * v`` does not broadcast a per-sample k of shape (n,) against v (n, 1)."""
    return -k * v


def decay_columns_f(v, k=1.0):
    """The same model written per column, which broadcasts a per-sample k as it is."""
    return torch.stack([-k * v[:, 0]], dim=-1)


def decay_two_f(v, k=1.0, c=0.0):
    return -k * v + c


def make_decay(n, seed, n_window=4, n_steps=3):
    """Exponential decays, each sample with its own rate k ~ U(0.5, 2): X windows, y the continuation."""
    rng = np.random.default_rng(seed)
    k = rng.uniform(0.5, 2.0, n)
    v0 = rng.uniform(1.0, 2.0, n)
    t = DT * np.arange(n_window + n_steps)
    states = (v0[:, None] * np.exp(-k[:, None] * t))[..., None]
    return states[:, :n_window], states[:, n_window:], k


FAST = dict(dt=DT, n_substeps=1, residual={"hidden": (8,)}, theta_encoder={"hidden": (16,)},
            max_iter=5, random_state=0, method="erm")


@pytest.fixture(scope="module")
def decay():
    return make_decay(24, seed=0)


@pytest.fixture(scope="module")
def fitted(decay):
    X, y, _ = decay
    return HybridRegressor(science=decay_f, **FAST).fit(X, y)


def test_shapes(decay, fitted):
    X, y, _ = decay
    theta = fitted.predict_theta(X)
    assert set(theta) == {"k"} and theta["k"].shape == (len(X),)
    assert isinstance(fitted.theta_["k"], float)
    assert fitted.theta_["k"] == pytest.approx(theta["k"].mean(), rel=1e-5)
    assert fitted.predict(X).shape == y.shape == fitted.predict_science(X).shape
    assert fitted.history_["theta"]["k"].shape == (5,)
    trace = fitted.residual_trace(X)
    assert trace["points"].shape == (len(X) * 4, 1) == trace["residual"].shape


def test_presets_start_at_theta_init_and_probe_picks_the_call(decay):
    X, y, _ = decay
    est = HybridRegressor(science=decay_f, theta_init={"k": 0.7}, **{**FAST, "max_iter": 1}, lr=1e-12)
    est.fit(X, y)
    np.testing.assert_allclose(est.predict_theta(X)["k"], 0.7, rtol=1e-5)
    assert est.model_.encoder.direct is False  # -k * v needs vmap
    est = HybridRegressor(science=decay_columns_f, **FAST).fit(X, y)
    assert est.model_.encoder.direct is True


def test_vmap_and_direct_call_agree(decay):
    """The same model written two ways (vmap path, direct path) trains to the same result."""
    X, y, _ = decay
    a = HybridRegressor(science=decay_f, **{**FAST, "dtype": "float64"}).fit(X, y)
    b = HybridRegressor(science=decay_columns_f, **{**FAST, "dtype": "float64"}).fit(X, y)
    np.testing.assert_allclose(a.predict_theta(X)["k"], b.predict_theta(X)["k"], rtol=1e-10)
    np.testing.assert_allclose(a.predict(X), b.predict(X), rtol=1e-10)


def test_predict_science_uses_each_samples_theta(decay, fitted):
    X, _, _ = decay
    k = torch.as_tensor(fitted.predict_theta(X)["k"], dtype=torch.float32)
    x0 = torch.as_tensor(X[:, -1], dtype=torch.float32)  # the last state of the window
    expected = integrate(lambda v, u: -k[:, None] * v, x0, 3, DT, n_substeps=1)
    np.testing.assert_allclose(fitted.predict_science(X), expected.numpy(), rtol=1e-5, atol=1e-6)


def test_bounds_hold_for_every_sample(decay):
    X, y, _ = decay
    est = HybridRegressor(science=decay_f, theta_init={"k": 1.0}, theta_bounds={"k": (0.9, 1.1)},
                          **{**FAST, "max_iter": 30}, lr=0.1).fit(X, y)
    for inputs in (X, 100 * X, -50 * X):  # also far outside the training data
        k = est.predict_theta(inputs)["k"].astype(np.float32)  # a saturated bound rounds onto it
        assert np.all((k >= np.float32(0.9)) & (k <= np.float32(1.1)))
    assert np.ptp(est.predict_theta(X)["k"]) > 0  # it did learn something per sample


def test_theta_fixed_stays_shared(decay):
    X, y, _ = decay
    est = HybridRegressor(science=decay_two_f, theta_init={"c": 0.25}, theta_fixed=["c"],
                          **{**FAST, "max_iter": 20}, lr=1e-2).fit(X, y)
    theta = est.predict_theta(X[:7])
    np.testing.assert_array_equal(theta["c"], np.full(7, 0.25))
    assert np.ptp(theta["k"]) > 0 and est.theta_["c"] == 0.25
    assert est.model_.encoder.n_out == 1
    with pytest.raises(ValueError, match="outside theta_fixed"):
        HybridRegressor(science=decay_f, theta_fixed=["k"], **FAST).fit(X, y)


def test_determinism(decay):
    X, y, _ = decay
    a = HybridRegressor(science=decay_f, **FAST).fit(X, y).predict_theta(X)["k"]
    b = HybridRegressor(science=decay_f, **FAST).fit(X, y).predict_theta(X)["k"]
    c = HybridRegressor(science=decay_f, **{**FAST, "random_state": 1}).fit(X, y).predict_theta(X)["k"]
    np.testing.assert_array_equal(a, b)
    assert not np.array_equal(a, c)


def test_clone_and_pickle(decay, fitted):
    X, _, _ = decay
    assert clone(fitted).get_params()["theta_encoder"] == FAST["theta_encoder"]
    restored = pickle.loads(pickle.dumps(fitted))
    np.testing.assert_array_equal(restored.predict_theta(X)["k"], fitted.predict_theta(X)["k"])
    np.testing.assert_array_equal(restored.predict(X), fitted.predict(X))


def test_unfitted_and_bad_specs(decay):
    X, y, _ = decay
    with pytest.raises(NotFittedError):
        HybridRegressor(science=decay_f, theta_encoder="mlp").predict_theta(X)
    bad = [("transformer", ValueError, "Unknown theta_encoder kind"),
           ({"kind": "mlp", "depth": 3}, ValueError, "Invalid options"),
           (torch.nn.Linear(8, 1), TypeError, "factory rather than a module instance"),
           (42, TypeError, "theta_encoder must be"),
           (lambda in_shape, n_out: "net", TypeError, "returned str"),
           (lambda in_shape, n_out: torch.nn.Linear(1, 3), ValueError, "must return")]
    for spec, error, message in bad:
        with pytest.raises(error, match=message):
            HybridRegressor(science=decay_f, **{**FAST, "theta_encoder": spec}).fit(X, y)
    with pytest.raises(ValueError, match="input windows"):
        HybridRegressor(science=decay_f, **FAST).fit(X[:, -1], y)
    with pytest.raises(ValueError, match="forced ODEs"):
        HybridRegressor(science=decay_f, n_inputs=1, **FAST).fit(X, y)


def test_encoder_factory_returning_one_network_twice(decay):
    X, y, _ = decay
    net = torch.nn.Sequential(torch.nn.Flatten(), torch.nn.Linear(int(np.prod(X.shape[1:])), 1))
    same = lambda in_shape, n_out: net  # noqa: E731  (the trap: one network for every fit)
    HybridRegressor(science=decay_f, **{**FAST, "theta_encoder": same}).fit(X, y)
    with pytest.raises(ValueError, match="it had returned before; it must build a new network"):
        HybridRegressor(science=decay_f, **{**FAST, "theta_encoder": same}).fit(X, y)


@pytest.mark.filterwarnings("ignore:Converting a tensor with requires_grad")
def test_science_that_cannot_run_per_sample(decay):
    X, y, _ = decay

    def branching_f(v, k=1.0):
        return -k * v if float(v.sum()) > 0 else k * v  # Python branch on a tensor value

    with pytest.raises(ValueError, match="per sample"):
        HybridRegressor(science=branching_f, **FAST).fit(X, y)


def test_factory_and_cnn_preset():
    net = build_encoder(lambda in_shape, n_out: torch.nn.Sequential(
        torch.nn.Flatten(), torch.nn.Linear(int(np.prod(in_shape)), n_out)), (4, 1), 2)
    assert net(torch.zeros(3, 4, 1)).shape == (3, 2)
    cnn = build_encoder({"kind": "cnn", "hidden": (4, 4), "dense": (8,)}, (3, 2, 6, 6), 2)
    assert cnn(torch.randn(5, 3, 2, 6, 6)).shape == (5, 2)
    with pytest.raises(ValueError, match="windows of fields"):
        build_encoder("cnn", (4, 2), 1)


def test_fields_with_cnn_encoder():
    """A field state (1, 4, 4) with a per-sample diffusion-like rate: vmap path, batch-norm encoder."""
    rng = np.random.default_rng(0)
    k = rng.uniform(0.5, 2.0, 6)
    fields = rng.uniform(1, 2, (6, 1, 4, 4))
    t = DT * np.arange(5)
    states = fields[:, None] * np.exp(-k[:, None] * t)[:, :, None, None, None]
    X, y = states[:, :3], states[:, 3:]
    est = HybridRegressor(science=decay_f, **{
        **FAST, "residual": {"kind": "cnn", "hidden": (4,)},
        "theta_encoder": {"kind": "cnn", "hidden": (4,), "dense": (8,)}}).fit(X, y)
    assert est.predict(X).shape == y.shape and est.predict_theta(X)["k"].shape == (6,)
    # batch norm uses running statistics at prediction: a sample's theta does not depend on its batch
    np.testing.assert_allclose(est.predict_theta(X[:1])["k"], est.predict_theta(X)["k"][:1], rtol=1e-6)


def test_static_structures(decay):
    X, _, k = decay
    x = X[:, :, 0]  # features: the window itself

    def gain_f(x, k=1.0):
        return k * x[:, 0]

    y = k * x[:, 0] + 0.1 * x[:, 1]
    for structure in ("additive", "compose"):
        est = HybridRegressor(science=gain_f, structure=structure, **FAST).fit(x, y)
        assert est.predict(x).shape == y.shape and est.predict_theta(x)["k"].shape == (len(x),)
    assert est.predict_science(x).shape == y.shape  # compose with z and y of one shape


@pytest.mark.parametrize("perturb", ["residual", "all"])
def test_sam_family(decay, perturb):
    X, y, _ = decay
    for method in ("sam", "asam", "fsam", "p-reg", "f-reg"):
        est = HybridRegressor(science=decay_f, **{**FAST, "method": method}, perturb=perturb).fit(X, y)
        assert np.all(np.isfinite(est.predict_theta(X)["k"]))


def test_sam_perturbs_the_encoder_only_with_perturb_all(decay, monkeypatch):
    from sklearn_hybrid.methods import FisherSAM

    X, y, _ = decay
    seen = {}
    original = FisherSAM.perturbation

    def spy(self, perturbed, grads, is_weight, n_batch_dims=0):
        seen.setdefault("n", len(perturbed))
        return original(self, perturbed, grads, is_weight, n_batch_dims=n_batch_dims)

    monkeypatch.setattr(FisherSAM, "perturbation", spy)
    counts = {}
    for perturb in ("residual", "all"):
        seen.clear()
        est = HybridRegressor(science=decay_f, **{**FAST, "method": "fsam"}, perturb=perturb).fit(X, y)
        counts[perturb] = seen["n"]
    n_residual = len(list(est.residual_.parameters()))
    n_encoder = len(list(est.model_.encoder.parameters()))
    assert counts == {"residual": n_residual, "all": n_residual + n_encoder}


def test_recovers_per_sample_rate():
    """A tiny fit infers each sample's decay rate (easy case: the window shows it)."""
    X, y, k = make_decay(64, seed=0)
    X_test, _, k_test = make_decay(32, seed=1)
    est = HybridRegressor(science=decay_columns_f, dt=DT, n_substeps=1, residual={"hidden": (16,), "zero_init": False},
                          theta_encoder={"hidden": (32, 32)}, theta_bounds={"k": (0.1, 3.0)},
                          method="erm", lr=1e-2, max_iter=600, random_state=0).fit(X, y)
    inferred = est.predict_theta(X_test)["k"]
    # k spans 0.5 .. 2; erm leaves a shared offset that the network g(v) can absorb (about 0.1 here),
    # which is the paper's point, while the ranking of the samples is nearly exact. (With the network in the
    # data's scales the encoder needs 600 iterations where it needed 300: at 300, 0.23 and a correlation 0.93.)
    # error 0.13 and correlation 0.978 on an Intel Xeon's AVX-512 path, 0.15 and 0.968 under
    # ATEN_CPU_CAPABILITY=avx2 with MKL_CBWR=COMPATIBLE: held to 0.2 and 0.95 so that they hold on any x86-64 CPU
    assert theta_error({"k": inferred}, {"k": k_test}) < 0.2
    assert np.corrcoef(inferred, k_test)[0, 1] > 0.95


def test_gridsearch_with_per_sample_scorer(decay):
    X, y, k = decay
    scorer = make_per_sample_theta_scorer(X, {"k": k})
    search = GridSearchCV(HybridRegressor(science=decay_f, **FAST), {"lr": [1e-3, 1e-2]},
                          scoring=scorer, cv=2).fit(X, y)
    best = search.best_estimator_
    assert search.best_score_ <= 0
    assert scorer(best, X[5:9]) == pytest.approx(-theta_error(best.predict_theta(X[5:9]), {"k": k[5:9]}))
    with pytest.raises(ValueError, match="not rows of the X"):
        scorer(best, X + 1.0)
    with pytest.raises(ValueError, match="one value per sample"):
        make_per_sample_theta_scorer(X, {"k": k[:3]})
    assert pickle.loads(pickle.dumps(scorer))(best, X) == scorer(best, X)


def test_hybrid_regressor_cv_trains_members_one_by_one(decay):
    X, y, k = decay
    template = HybridRegressor(science=decay_f, **{**FAST, "method": "fsam"})
    cv = HybridRegressorCV(template, rhos=[0.01, 0.1], seeds=[0, 1],
                           scoring=make_per_sample_theta_scorer(X, {"k": k})).fit(X, y)
    assert len(cv.estimators_) == 4 and np.all(cv.cv_results_["diverged_at"] == -1)
    assert cv.predict_theta(X)["k"].shape == (len(X),)
    # each member is the separate fit with its configuration
    member = cv.estimators_[1]
    alone = clone(member)  # its configuration: the template with its rho and seed
    assert alone.method.rho == cv.cv_results_["params"][1]["rho"]
    train_idx = np.sort(np.random.default_rng(0).permutation(len(X))[5:])  # validation_fraction 0.2
    alone.fit(X[train_idx], y[train_idx])
    np.testing.assert_allclose(member.predict_theta(X)["k"], alone.predict_theta(X)["k"], rtol=1e-5)
    assert set(cv.theta_std_) == {"k"}


def test_closed_loop_refuses_the_encoder_clearly(decay):
    """The loop's network-free refits use one theta for every sample: a per-sample theta is refused."""
    from sklearn_hybrid.diagnosis import close_the_loop

    X, y, _ = decay
    with pytest.raises(ValueError, match="does not support theta_encoder"):
        close_the_loop(HybridRegressor(science=decay_columns_f, **{**FAST, "max_iter": 3}), X, y,
                       state_names=["v"])
