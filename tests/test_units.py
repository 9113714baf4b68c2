"""The same physics in any units gives the same fit, and when units are the problem the errors say so.

theta steps relative to its size, the network trains in the data's scales, and the gradients are taken in units
of the data's spread: each invariance test writes one small system in its order-one units and in others a
scientist would pick (time in milliseconds, states as fractions or in thousands), fits both, and compares theta
converted back (few iterations: what is tested is that the optimisation is the same, not that it converged).
A theta that diverged is named (not the science function, which a NaN theta makes return NaN), and the advice
after a training that went bad prints the data's scales.
"""

import warnings

import numpy as np
import pytest
import torch
from sklearn.exceptions import ConvergenceWarning

from sklearn_hybrid import HybridRegressor, OdeStructure
from sklearn_hybrid.integrate import integrate
from sklearn_hybrid.training.engine import DivergenceError


def decay_f(v, k=0.3):
    """A first-order decay of two states into each other: k per time unit."""
    return torch.stack([-k * v[:, 0] + 0.2 * k * v[:, 1], k * v[:, 0] - k * v[:, 1]], dim=-1)


def _data(T=1.0, S=1.0, n=12, n_steps=10, dt=0.3):
    """Trajectories of dv/dt = decay at k = 0.5 minus a missing -0.4 v0^2, in units time x T, states x S."""
    rng = np.random.default_rng(0)
    X = rng.uniform(0.5, 1.5, size=(n, 2))

    def rhs(v, u=None):
        return decay_f(v, k=0.5) - 0.4 * torch.stack([v[:, 0] ** 2, 0 * v[:, 1]], dim=-1)

    with torch.no_grad():
        y = integrate(rhs, torch.as_tensor(X), n_steps, dt, n_substeps=8).numpy()
    y = y + 0.01 * rng.standard_normal(y.shape)
    return (X * S).astype(np.float32), (y * S).astype(np.float32), dt * T


def _science_in(T, S):
    """decay_f as a user writes it in those units: the code unchanged, k per new time unit."""
    def decay_in_units(v, k=0.3 / T):
        return decay_f(v, k=k)

    return decay_in_units


@pytest.mark.parametrize("T, S", [(1e3, 1.0), (1e-3, 1.0), (1.0, 1e-3), (1.0, 1e4), (1e3, 1e-2)])
def test_an_ode_fit_in_other_units_is_the_order_one_fit(T, S):
    settings = dict(random_state=0, max_iter=60, tol=None, n_substeps=2)
    X, y, dt = _data()
    reference = HybridRegressor(science=decay_f, dt=dt, **settings).fit(X, y)
    Xs, ys, dts = _data(T, S)
    scaled = HybridRegressor(science=_science_in(T, S), dt=dts, **settings).fit(Xs, ys)
    assert scaled.theta_["k"] * T == pytest.approx(reference.theta_["k"], rel=1e-3)
    assert reference.theta_["k"] != pytest.approx(0.3, rel=0.05)  # it moved: the comparison means something
    np.testing.assert_allclose(scaled.predict(Xs[:3]) / S, reference.predict(X[:3]), rtol=1e-3, atol=1e-4)
    np.testing.assert_allclose(scaled.history_["loss"] / S ** 2, reference.history_["loss"], rtol=1e-2)


def test_a_small_theta_steps_relative_to_its_size():
    """A rate of 2e-6 per ms (2 per s) is not thrown away by the first step (it moved by the learning rate)."""
    T = 1e6  # microseconds
    X, y, dt = _data(T)
    est = HybridRegressor(science=_science_in(T, 1.0), dt=dt, random_state=0, max_iter=30, tol=None).fit(X, y)
    path = est.history_["theta"]["k"]
    assert np.all(path > 0) and np.max(np.abs(np.diff(path))) < 0.1 * 0.3 / T


def test_bounded_theta_in_other_units():
    """One bound: the softplus steps relative to the start's distance from it; two: relative to the span."""
    settings = dict(random_state=0, max_iter=40, tol=None, n_substeps=2)
    X, y, dt = _data()
    Xs, ys, dts = _data(1e3)
    for bounds in ((0.0, None), (0.0, 2.0)):
        ref = HybridRegressor(science=decay_f, dt=dt, theta_bounds={"k": bounds}, **settings).fit(X, y)
        scaled_bounds = tuple(None if b is None else b / 1e3 for b in bounds)
        est = HybridRegressor(science=_science_in(1e3, 1.0), dt=dts, theta_bounds={"k": scaled_bounds},
                              **settings).fit(Xs, ys)
        assert est.theta_["k"] * 1e3 == pytest.approx(ref.theta_["k"], rel=1e-3)


def test_a_theta_that_diverges_is_named_not_the_science():
    """A theta thrown to 1e35 makes any science return NaN: the error says theta diverged, from where, and
    prints the data's scales."""
    X, y, dt = _data()
    with pytest.raises(DivergenceError) as info:
        HybridRegressor(science=decay_f, dt=dt, random_state=0, lr_theta=1e37, max_iter=50, tol=None).fit(X, y)
    message = str(info.value)
    assert "theta diverged: k became" in message and "from {'k': 0.3" in message
    assert "the science function is not the cause" in message and "returned [nan" not in message
    assert "The data's scales: state spread 0.292, 0.258; horizon 3 time units" in message


def test_a_divergence_without_dt_says_dt_was_not_given():
    X, y, _ = _data()
    with pytest.warns(UserWarning, match="dt was not given"), pytest.raises(DivergenceError) as info:
        HybridRegressor(science=decay_f, random_state=0, lr_theta=1e37, max_iter=50, tol=None).fit(X, y)
    assert "dt was not given, so one time unit was taken between outputs" in str(info.value)


def test_a_fit_that_is_not_usable_prints_the_data_scales():
    X, y, dt = _data()
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        HybridRegressor(science=decay_f, dt=dt, random_state=0, lr=1e-12, max_iter=30, tol=None).fit(X, y)
    messages = [str(w.message) for w in caught if issubclass(w.category, ConvergenceWarning)]
    assert messages and "The data's scales: state spread" in messages[0], messages


def _driven(v, u, k=1.0, g=0.5):
    """A mass on a spring driven by a force u (position, velocity)."""
    return torch.stack([v[:, 1], -k * v[:, 0] + g * u[:, 0]], dim=-1)


@pytest.mark.parametrize("T, S", [(1e3, 1.0), (1.0, 1e-3), (1e-2, 1e2)])
def test_a_forced_partially_observed_ode_in_other_units_is_the_order_one_fit(T, S):
    """Inputs u (in their own unit, unchanged) and a velocity nobody observes: x in units x S, time x T, so the
    velocity is in S / T, k per T^2 and g in S / T^2 per unit of u."""
    from sklearn_hybrid import pack_inputs

    rng = np.random.default_rng(0)
    n, m, dt = 10, 12, 0.2
    t = np.arange(m + 1) * dt
    u = np.sin(2 * np.pi * rng.uniform(0.3, 0.8, (n, 1)) * t)[:, :, None]
    x0 = rng.uniform(-1, 1, size=(n, 2))
    with torch.no_grad():
        def rhs(v, u_):
            return _driven(v, u_, k=1.6, g=0.8) - 0.3 * torch.stack([0 * v[:, 1], v[:, 1]], dim=-1)

        y = integrate(rhs, torch.as_tensor(x0), m, dt, n_substeps=8,
                      u_fine=torch.as_tensor(np.repeat(u, 16, axis=1)[:, : 16 * m + 1])).numpy()[..., :1]
    settings = dict(random_state=0, max_iter=60, tol=None, n_inputs=1, observed=[0])
    ref = HybridRegressor(science=_driven, dt=dt, **settings).fit(pack_inputs(x0, u), y.astype(np.float32))

    def driven_in_units(v, u, k=1.0 / T ** 2, g=0.5 * S / T ** 2):
        return _driven(v, u, k=k, g=g)

    X = pack_inputs(x0 * np.array([S, S / T]), u)
    est = HybridRegressor(science=driven_in_units, dt=dt * T, **settings).fit(X, (y * S).astype(np.float32))
    assert est.theta_["k"] * T ** 2 == pytest.approx(ref.theta_["k"], rel=1e-3)
    assert est.theta_["g"] * T ** 2 / S == pytest.approx(ref.theta_["g"], rel=1e-3)
    assert ref.theta_["k"] != pytest.approx(1.0, rel=0.02)  # it moved


def _fan(x, a=1.0, b=0.2):
    """A fan's pressure rise from its speed x[:, 0] and the flow x[:, 1] (a static law): a x0^2 - b x1."""
    return (a * x[:, 0] ** 2 - b * x[:, 1])[:, None]


def _fan_data(X_scale=1.0, y_scale=1.0):
    """The law at a = 1.5, b = 0.4 plus a missing 0.3 sin(2 x1), noisy; inputs x X_scale, pressure x y_scale."""
    rng = np.random.default_rng(0)
    X = rng.uniform(0.5, 2.0, size=(40, 2))
    y = _fan(torch.as_tensor(X), a=1.5, b=0.4).numpy() + 0.3 * np.sin(2 * X[:, 1:])
    y = y + 0.01 * rng.standard_normal(y.shape)
    return (X * X_scale).astype(np.float32), (y * y_scale).astype(np.float32)


@pytest.mark.parametrize("structure", ["additive", "compose"])
@pytest.mark.parametrize("Xs, Ys", [(1e3, 1.0), (1.0, 1e-3), (1e-2, 1e4)])
def test_a_static_fit_in_other_units_is_the_order_one_fit(structure, Xs, Ys):
    """Speed and flow in units x Xs, pressure in units x Ys: a in Ys / Xs^2, b in Ys / Xs. The network reads
    standardised inputs (and, composed, the science's output) and writes the target in units of its spread."""
    settings = dict(structure=structure, random_state=0, max_iter=60, tol=None)
    ref = HybridRegressor(science=_fan, **settings).fit(*_fan_data())

    def fan_in_units(x, a=1.0 * Ys / Xs ** 2, b=0.2 * Ys / Xs):
        return _fan(x, a=a, b=b)

    X, y = _fan_data(Xs, Ys)
    est = HybridRegressor(science=fan_in_units, **settings).fit(X, y)
    assert est.theta_["a"] * Xs ** 2 / Ys == pytest.approx(ref.theta_["a"], rel=1e-3)
    assert est.theta_["b"] * Xs / Ys == pytest.approx(ref.theta_["b"], rel=1e-3)
    assert ref.theta_["a"] != pytest.approx(1.0, rel=0.05)  # it moved: the comparison means something
    np.testing.assert_allclose(est.predict(X[:3]) / Ys, ref.predict(_fan_data()[0][:3]), rtol=1e-3, atol=1e-4)


def test_a_static_fit_that_is_not_usable_prints_the_data_scales():
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        HybridRegressor(science=_fan, structure="additive", random_state=0, lr=1e-12, max_iter=30,
                        tol=None).fit(*_fan_data(1e3))
    messages = [str(w.message) for w in caught if issubclass(w.category, ConvergenceWarning)]
    assert messages and "The data's scales: input spread 399, 481; target spread 1.59" in messages[0], messages


@pytest.mark.parametrize("structure", ["additive", "ode"])
def test_read_only_data_are_read_without_a_warning(structure):
    """The scales are read from a copy of y: torch warned that a read-only y (a memory map, as scikit-learn's
    checks pass it) is not writable when the static scales were first read from it."""
    X, y = _fan_data() if structure == "additive" else _data()[:2]
    X.setflags(write=False)
    y.setflags(write=False)
    kwargs = {"structure": structure} if structure == "additive" else {"structure": OdeStructure(dt=0.3)}
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        HybridRegressor(science=_fan if structure == "additive" else decay_f, max_iter=3, tol=None,
                        random_state=0, **kwargs).fit(X, y)


def test_a_bootstrap_member_of_an_ode_trains_in_its_resample_s_scales():
    """The stacked bootstrap's member takes the steps a separate fit on its resample takes: its network in the
    scales of the resample (weights counting samples), its gradients in units of the resample's variance."""
    from sklearn.base import clone

    from sklearn_hybrid.identifiability import bootstrap_theta

    X, y, dt = _data(n=8, n_steps=5)
    est = HybridRegressor(science=decay_f, dt=dt, n_substeps=1, residual={"hidden": (8,)}, max_iter=15, tol=None,
                          dtype="float64", random_state=0).fit(X, y)
    boot = bootstrap_theta(est, X, y, n_resamples=3, random_state=7)
    # the draw the bootstrap reports is the one it made: 3 resamples of len(y) samples, integer counts
    assert len(boot.seeds) == 3 and boot.weights.shape == (3, len(y)) and np.all(boot.weights.sum(1) == len(y))
    alone = clone(est).set_params(random_state=boot.seeds[1]).fit(X, y, sample_weight=boot.weights[1])
    assert boot.samples["k"][1] == pytest.approx(alone.theta_["k"], rel=1e-9)


def decay_squared(v, k=0.3, c=0.0):
    """decay_f with the missing -0.4 v0^2 as a term of coefficient c (-0.4 / S in states x S)."""
    return decay_f(v, k=k) + c * torch.stack([v[:, 0] ** 2, 0 * v[:, 1]], dim=-1)


@pytest.mark.parametrize("S", [1e-3, 1e3])
def test_the_network_free_refit_in_other_units_is_the_order_one_refit(S):
    """The closed loop's least-squares refit measures residuals in units of y's size: its gradient tolerance is
    absolute, and stopped the refit early on states in thousandths (a second term then looked worth adding)."""
    from sklearn_hybrid.diagnosis import ScienceFit

    settings = dict(random_state=0, max_iter=30, tol=None)
    fitted = {}
    for scale in (1.0, S):
        X, y, dt = _data(S=scale)
        est = HybridRegressor(science=decay_f, structure=OdeStructure(dt=dt, n_substeps=2), **settings).fit(X, y)
        fitted[scale] = ScienceFit(est, X, y).fit(decay_squared, {"k": est.theta_["k"], "c": 0.0})
    assert fitted[S]["k"] == pytest.approx(fitted[1.0]["k"], rel=1e-4)
    assert fitted[S]["c"] * S == pytest.approx(fitted[1.0]["c"], rel=1e-3)
    assert fitted[1.0]["c"] == pytest.approx(-0.4, rel=0.1)  # it converged: the comparison means something


def test_intervals_of_parameters_of_very_different_sizes_are_those_of_order_one():
    """A term's coefficient on states in 1e-6 units is of order 1e5 while k is of order one: the information
    matrix's condition is read with each parameter in units of its own sensitivity, not as written (which
    called both not identified)."""
    from sklearn_hybrid.identifiability import science_intervals
    from sklearn_hybrid.residual import ZeroResidual

    out = {}
    for S in (1.0, 1e-6):
        def decay_squared_in_units(v, k=0.3, c=-0.3 / S):  # the user's start of c in the same units
            return decay_squared(v, k=k, c=c)

        X, y, dt = _data(S=S)
        est = HybridRegressor(science=decay_squared_in_units, structure=OdeStructure(dt=dt, n_substeps=2),
                              residual=ZeroResidual(), random_state=0, max_iter=40, tol=None,
                              dtype="float64").fit(X, y)
        out[S] = science_intervals(est, X, y)
    ref, small = out[1.0], out[1e-6]
    assert ref.verdicts == small.verdicts == {"k": "identified", "c": "identified"}
    assert small.estimate["k"] == pytest.approx(ref.estimate["k"], rel=1e-3)
    assert small.std["k"] == pytest.approx(ref.std["k"], rel=0.01)
    assert small.std["c"] * 1e-6 == pytest.approx(ref.std["c"], rel=0.01)


def test_a_state_every_sample_starts_at_the_same_value_is_read_in_its_own_size():
    """An unobserved velocity that every sample starts at 0.5: its spread over the samples is zero, which the
    float sums wrote as 1e-16, and the network read it in units of 1e-16 (inputs of 1e15 once it moved)."""
    from sklearn_hybrid import pack_inputs
    from sklearn_hybrid.structures.scales import moments

    assert moments(torch.full((25, 1), 0.99, dtype=torch.float64))[1][0] == pytest.approx(0.99)
    rng = np.random.default_rng(0)
    n, m, dt = 10, 12, 0.2
    u = np.sin(2 * np.pi * rng.uniform(0.3, 0.8, (n, 1)) * np.arange(m + 1) * dt)[:, :, None]
    x0 = np.column_stack([rng.uniform(-1, 1, n), np.full(n, 0.5)])
    with torch.no_grad():
        y = integrate(lambda v, u_: _driven(v, u_, k=1.6, g=0.8), torch.as_tensor(x0), m, dt, n_substeps=8,
                      u_fine=torch.as_tensor(np.repeat(u, 16, axis=1)[:, : 16 * m + 1])).numpy()[..., :1]
    est = HybridRegressor(science=_driven, structure=OdeStructure(dt=dt, n_inputs=1, observed=[0]), max_iter=5,
                          tol=None, random_state=0).fit(pack_inputs(x0, u), y.astype(np.float32))
    network = getattr(est.model_.residual, "mlp", est.model_.residual)
    assert network.in_scale[1].item() == pytest.approx(0.5)
