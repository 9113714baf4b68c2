"""Bad input gets a clear error naming the problem, and nothing the user had is changed."""

import numpy as np
import pytest
import torch

from sklearn_hybrid import DivergenceError, HybridRegressor
from sklearn_hybrid._fitting import prepare_fit
from sklearn_hybrid.models import pendulum_f
from sklearn_hybrid.methods import SAM

FAST = dict(max_iter=5, residual={"hidden": (8,)}, random_state=0, dt=0.2)


@pytest.fixture
def data():
    rng = np.random.default_rng(0)
    return rng.uniform(-1, 1, (6, 2)), rng.uniform(-1, 1, (6, 3, 2))


def fit(data, **params):
    return HybridRegressor(**{"science": pendulum_f, **FAST, **params}).fit(*data)


@pytest.mark.parametrize("where", ["X", "y"])
@pytest.mark.parametrize("value", [np.nan, np.inf])
def test_non_finite_data(data, where, value):
    X, y = data[0].copy(), data[1].copy()
    (X if where == "X" else y)[0, 0] = value
    with pytest.raises(ValueError, match=f"Input {'X' if where == 'X' else 'y'} contains"):
        fit((X, y))


def test_sample_count_mismatch(data):
    with pytest.raises(ValueError, match="inconsistent numbers of samples"):
        fit((data[0], data[1][:-1]))


def test_shape_that_does_not_fit_the_structure(data):
    with pytest.raises(ValueError, match=r"y must have shape \(n_samples, n_steps, 2\)"):
        fit((data[0], data[1][:, :, :1].reshape(6, 3)[:, :3]))  # 3 values, state of 2


def test_science_without_parameters(data):
    def no_params(v):
        return v

    with pytest.raises(ValueError, match="no keyword argument with a numeric default"):
        fit(data, science=no_params)


@pytest.mark.parametrize("param", ["theta_init", "theta_bounds", "theta_fixed"])
def test_unknown_parameter_names(data, param):
    value = {"theta_init": {"omgea": 1.0}, "theta_bounds": {"omgea": (0, 1)},
             "theta_fixed": ["omgea"]}[param]
    with pytest.raises(ValueError, match=rf"{param} names unknown parameter\(s\) \['omgea'\].*'omega'"):
        fit(data, **{param: value})


def test_science_that_raises(data):
    def broken(v, omega=0.5):
        raise RuntimeError("division by the unknown")

    with pytest.raises(ValueError, match="science function 'broken' raised RuntimeError: division by the unknown"):
        fit(data, science=broken)


def test_science_returning_wrong_shape(data):
    def wrong(v, omega=0.5):
        return v[:, :1] * omega

    with pytest.raises(ValueError, match=r"'wrong' returned shape \(3, 1\).*needs \(3, 2\)"):
        fit(data, science=wrong)


def test_science_returning_numpy(data):
    def numpy_science(v, omega=0.5):
        return np.zeros((len(v), 2))

    with pytest.raises(TypeError, match="expected a torch.Tensor"):
        fit(data, science=numpy_science)


def test_unknown_method_lists_valid_ones(data):
    with pytest.raises(ValueError, match="Unknown method 'sgd'.*'fsam'"):
        fit(data, method="sgd")


@pytest.mark.parametrize("rho", [0, -0.05])
def test_non_positive_rho(data, rho):
    with pytest.raises(ValueError, match="rho must be a positive number"):
        fit(data, method=SAM(rho=rho))


@pytest.mark.parametrize("init", [3.0, 0.1, -1.0])
def test_theta_init_outside_bounds(data, init):
    with pytest.raises(ValueError, match="outside its bounds"):
        fit(data, theta_init={"omega": init}, theta_bounds={"omega": (0.1, 2.0)})


@pytest.mark.parametrize("params, message", [
    ({"structure": "tree"}, "Unknown structure 'tree'"),
    ({"residual": torch.nn.Linear(2, 2)}, "Pass a factory rather than a module instance"),
    ({"residual": {"kind": "rnn"}}, "Unknown residual kind 'rnn'"),
    ({"residual": {"hidden": (8,), "activation": "swish"}}, "Unknown activation 'swish'"),
    ({"max_iter": 0}, "max_iter must be a positive integer"),
    ({"lr": -1.0}, "lr must be a positive number"),
    ({"perturb": "theta"}, "perturb must be 'residual' or 'all'"),
    ({"dtype": "float16"}, "dtype must be one of"),
    ({"dt": 0.0}, "dt must be a positive number"),
    ({"n_inputs": -1}, "n_inputs must be a non-negative integer, got -1"),
    ({"n_inputs": "u"}, "n_inputs must be a non-negative integer, got 'u'"),
    ({"theta_bounds": {"omega": (1.0, 0.5)}}, "low >= high"),
    ({"science": None}, "needs a science function"),
])
def test_invalid_parameters(data, params, message):
    with pytest.raises((ValueError, TypeError), match=message):
        fit(data, **params)


def test_divergence_stops_and_keeps_previous_fit(data):
    est = fit(data)
    theta, pred = dict(est.theta_), est.predict(data[0])

    def exploding(v, omega=0.5):  # finite at the initial states, infinite along the trajectory
        return torch.exp(torch.exp(3 * v)) * omega

    est.set_params(science=exploding)
    with pytest.raises(DivergenceError, match="iteration 0.*science function 'exploding' returned"):
        est.fit(*data)
    assert est.theta_ == theta
    np.testing.assert_array_equal(est.predict(data[0]), pred)


def test_a_step_into_nan_is_undone_with_a_halved_learning_rate(data):
    # Adam's first step moves omega by about lr: 0.5 -> 0.0 or 1.0 lands where the science is NaN,
    # half of it does not.  The guard restores the start and halves the rates.
    def cliff(v, omega=0.5):
        return pendulum_f(v, omega) * torch.where((omega - 0.5).abs() > 0.4, torch.nan, 1.0)

    with pytest.warns(UserWarning, match=r"spiked at iterations \[1\].*halved"):
        est = fit(data, science=cliff, lr=0.5, max_iter=3)
    assert est.history_["lr_halved_at"] == [1]
    assert est.history_["lr_theta"][1] == 0.0  # no step at the undone iteration
    assert 0.1 < est.theta_["omega"] < 0.9 and est.theta_["omega"] != 0.5
    assert np.isfinite(est.predict(data[0])).all()


def test_spike_guard_restores_the_last_good_state_and_gives_up_after_its_halvings():
    from sklearn_hybrid.training.stopping import SpikeGuard

    model = torch.nn.Linear(2, 1)
    optimizer = torch.optim.Adam(model.parameters(), lr=0.1)
    scheduler = torch.optim.lr_scheduler.CosineAnnealingLR(optimizer, T_max=100)
    guard = SpikeGuard(model, optimizer, scheduler, every=4, max_halvings=2)
    good = [p.detach().clone() for p in model.parameters()]
    for it in range(4):  # healthy iterations: a copy at the 4th
        assert not guard.is_spike(1.0)
        guard.accept(it, 1.0)
        good = [p.detach().clone() for p in model.parameters()]
        model.weight.grad, model.bias.grad = torch.ones(1, 2), torch.ones(1)
        optimizer.step()
        scheduler.step()
    assert not guard.is_spike(9.0) and guard.is_spike(11.0) and guard.is_spike(float("nan"))
    rate = optimizer.param_groups[0]["lr"]
    assert guard.roll_back(4)
    assert all(torch.equal(p, q) for p, q in zip(model.parameters(), good))
    assert optimizer.param_groups[0]["lr"] == rate / 2
    assert scheduler.base_lrs == [0.05]
    assert not guard.roll_back(5)  # no step since the copy: halving cannot help
    guard.accept(5, 1.0)
    assert guard.roll_back(6) and not guard.roll_back(7)  # two halvings allowed
    assert guard.halved_at == [4, 6]


def test_predict_before_fit_and_wrong_features(data):
    from sklearn.exceptions import NotFittedError

    with pytest.raises(NotFittedError):
        HybridRegressor(science=pendulum_f).predict(data[0])
    est = fit(data)
    with pytest.raises(ValueError, match="expecting 2 features"):
        est.predict(np.zeros((3, 3)))


# --- unusual inputs that must work, and the memory of a fit ---------------------------------

def test_numpy_scalar_dt_and_negative_n_jobs(data):
    import sklearn_hybrid

    assert fit(data, dt=np.float32(0.2)).theta_ == fit(data).theta_
    cv = sklearn_hybrid.HybridRegressorCV(
        HybridRegressor(science=pendulum_f, method="erm", **FAST), seeds=[0, 1], n_jobs=-1,
        validation_fraction=0.5)
    assert len(cv.fit(*data).estimators_) == 2


def test_verbose_without_stderr(data, monkeypatch):
    monkeypatch.setattr("sys.stderr", None)
    assert fit(data, verbose=True).n_iter_ == FAST["max_iter"]


def test_dtype_changed_after_fit_predicts_with_the_fitted_model(data):
    est = fit(data)
    pred = est.predict(data[0])
    est.set_params(dtype="float64")
    np.testing.assert_array_equal(est.predict(data[0]), pred)


def test_predict_in_chunks_equals_one_pass(data, monkeypatch):
    est = fit(data)
    X = np.random.default_rng(1).uniform(-1, 1, (7, 2))
    whole = est.predict(X)
    trace = est.residual_trace(X)
    monkeypatch.setattr(est, "_samples_per_pass", 3)
    np.testing.assert_allclose(est.predict(X), whole, rtol=1e-6, atol=1e-7)
    for key in ("points", "residual"):
        np.testing.assert_allclose(est.residual_trace(X)[key], trace[key], rtol=1e-6, atol=1e-7)


def test_nan_prediction_names_the_science(data):
    def bounded(v, omega=0.5):  # finite for |angle| < 2 only
        return torch.stack([v[:, 1], -omega * torch.sqrt(4 - v[:, 0] ** 2)], dim=-1)

    est = fit(data, science=bounded)
    with pytest.raises(ValueError, match=r"not finite for sample\(s\) \[1\].*'bounded' returned"):
        est.predict(np.array([[0.1, 0.0], [3.0, 0.0]]))


def test_memory_of_a_fit_grows_with_batch_and_steps():
    from sklearn_hybrid.training.memory import fit_memory_bytes

    X = np.random.default_rng(0).uniform(-1, 1, (4, 2))
    sizes = {}
    for n_steps in (5, 10):
        y = np.zeros((4, n_steps, 2))
        setup = prepare_fit(HybridRegressor(science=pendulum_f, **FAST), X, y)
        sizes[n_steps] = [fit_memory_bytes(setup.model, setup.inputs, n) for n in (100, 200)]
    assert sizes[5][1] == pytest.approx(2 * sizes[5][0], rel=1e-6)
    assert sizes[10][0] == pytest.approx(2 * sizes[5][0], rel=0.1)


def test_memory_check_stays_cheap_at_an_extreme_horizon():
    """2,000 steps of 1,000 RK4 substeps, one sample a batch: an iteration integrates 2 million
    substeps, the memory check three (one and two substeps, extrapolated)."""
    import time

    from sklearn_hybrid.training.memory import check_fit_memory

    calls = []

    def counted(v, omega=0.5):
        calls.append(len(v))
        return pendulum_f(v, omega)

    X = np.random.default_rng(0).uniform(-1, 1, (4, 2))
    est = HybridRegressor(science=counted, **{**FAST, "n_substeps": 1000, "batch_size": 1})
    setup = prepare_fit(est, X, np.zeros((4, 2000, 2)))
    calls.clear()
    start = time.perf_counter()
    check_fit_memory(setup)
    assert time.perf_counter() - start < 1.0
    assert len(calls) == 4 * (1 + 2)  # RK4's four stages per substep


@pytest.mark.parametrize("params", [{}, {"observed": [0]}, {"forced": True}])
def test_memory_of_a_short_horizon_extrapolates_exactly(params):
    """The bytes the probe's second substep adds, counted per substep, are those of the whole horizon."""
    from sklearn_hybrid import pack_inputs
    from sklearn_hybrid.training import memory

    def forced(v, u, k=1.0):
        return torch.stack([v[:, 1], -k * v[:, 0] + u[:, 0]], dim=-1)

    rng = np.random.default_rng(0)
    X, y = rng.uniform(-1, 1, (40, 2)), np.zeros((40, 30, 2))
    params = {"science": pendulum_f, **FAST, **params}
    if params.pop("forced", False):
        X, params = pack_inputs(X, rng.uniform(-1, 1, (40, 31, 1))), {**params, "science": forced, "n_inputs": 1}
    if "observed" in params:
        y = y[..., :1]
    setup = prepare_fit(HybridRegressor(**params), X, y)
    two = tuple(t[:2].clone() for t in setup.inputs)
    whole = memory._saved_bytes(setup.model, two)
    assert memory.fit_memory_bytes(setup.model, setup.inputs, 2) == int(memory._PEAK_OVER_SAVED * whole)
    # the other samples' inputs are not counted (a slice of them shares their storage)
    assert memory.fit_memory_bytes(setup.model, two, 2) == memory.fit_memory_bytes(setup.model, setup.inputs, 2)


def test_fit_too_large_for_memory_says_what_to_change(data, monkeypatch):
    from sklearn_hybrid.training import memory

    est = fit(data)
    theta = dict(est.theta_)
    monkeypatch.setattr(memory, "available_memory_bytes", lambda device=None: 20_000)
    with pytest.raises(MemoryError, match=r"would need about .* GB .*batch_size=\d+"):
        est.fit(*data)
    assert est.theta_ == theta


def test_allocator_failure_is_explained(data, monkeypatch):
    from sklearn_hybrid import _estimator

    def out_of_memory(*args, **kwargs):
        raise RuntimeError("[enforce fail at alloc_cpu.cpp:121] DefaultCPUAllocator: can't "
                           "allocate memory: you tried to allocate 38654705664 bytes.")

    monkeypatch.setattr(_estimator, "train", out_of_memory)
    with pytest.raises(MemoryError, match=r"ran out of memory .*batch_size=\d+"):
        fit(data)


def test_random_state_none_uses_numpy_global_state_only(data):
    torch_state = torch.random.get_rng_state()
    np.random.seed(3)
    first = fit(data, random_state=None).theta_
    np.random.seed(3)
    assert fit(data, random_state=None).theta_ == first
    assert torch.equal(torch.random.get_rng_state(), torch_state)


def test_fast_path_switch_is_per_thread():
    import threading

    from sklearn_hybrid.integrate import fast as fast_rk4
    from sklearn_hybrid.residual import MLP

    mlp, seen = MLP(((2,),), (2,)), {}
    inside, release = threading.Event(), threading.Event()

    def other():
        with fast_rk4.disabled():
            inside.set()
            release.wait(5)

    thread = threading.Thread(target=other)
    thread.start()
    inside.wait(5)
    seen["while other thread disabled it"] = fast_rk4.supports(mlp, (2,), "rk4")
    release.set()
    thread.join()
    assert seen["while other thread disabled it"] and fast_rk4.supports(mlp, (2,), "rk4")


def test_failed_refit_of_a_sweep_keeps_the_earlier_sweep(data):
    from sklearn_hybrid import HybridRegressorCV

    cv = HybridRegressorCV(HybridRegressor(science=pendulum_f, method="erm", **FAST),
                           seeds=[0, 1], validation_fraction=0.5).fit(*data)
    theta, pred = dict(cv.theta_), cv.predict(data[0])
    with pytest.raises(ValueError, match=r"state shape \(3,\) from X"):
        cv.fit(np.c_[data[0], data[0][:, :1]], data[1])
    assert cv.n_features_in_ == 2 and cv.theta_ == theta
    np.testing.assert_array_equal(cv.predict(data[0]), pred)


def test_memory_probe_leaves_batch_norm_statistics_alone():
    from sklearn_hybrid.training.memory import fit_memory_bytes

    def net(in_shapes, out_shape):
        return torch.nn.Sequential(torch.nn.Flatten(), torch.nn.BatchNorm1d(2),
                                   torch.nn.Linear(2, 2))

    X = np.random.default_rng(0).uniform(-1, 1, (4, 2)) + 5  # far from BN's initial mean 0
    setup = prepare_fit(HybridRegressor(**{**FAST, "science": pendulum_f, "structure": "additive",
                                           "residual": net}), X, X)
    before = [b.clone() for b in setup.model.buffers()]
    fit_memory_bytes(setup.model, setup.inputs, 4)
    assert all(torch.equal(a, b) for a, b in zip(before, setup.model.buffers()))


def test_sweep_counts_the_memory_of_every_stacked_member(data, monkeypatch):
    from sklearn_hybrid import HybridRegressorCV
    from sklearn_hybrid.training import memory

    estimator = HybridRegressor(science=pendulum_f, method="erm", **FAST)
    setup = prepare_fit(estimator, *data)
    one = memory.fit_memory_bytes(setup.model, setup.inputs, len(data[0]))
    # room for two members, not for the four of the sweep (each trains on 3 of the 6 samples)
    monkeypatch.setattr(memory, "available_memory_bytes", lambda device=None: one / 0.8)
    estimator.fit(*data)  # a single fit on all six samples fits
    with pytest.raises(MemoryError, match="4 models trained together"):
        HybridRegressorCV(estimator, seeds=[0, 1, 2, 3], validation_fraction=0.5).fit(*data)


def test_network_share_of_a_hybrid_prediction():
    from sklearn_hybrid import network_share

    science = np.array([[1.0, 2.0], [3.0, 4.0]])
    assert network_share(science, science) == 0.0
    hybrid = science + 0.5
    expected = np.sqrt(np.mean(0.5 ** 2) / np.mean(hybrid ** 2))
    assert network_share(hybrid, science) == pytest.approx(expected)
    with pytest.raises(ValueError, match=r"y_hybrid has shape \(2, 2\) and y_science \(4,\)"):
        network_share(hybrid, science.ravel())
