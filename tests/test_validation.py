"""Bad input gets a clear error naming the problem, and nothing the user had is changed."""

import numpy as np
import pytest
import torch

from sklearn_hybrid import DivergenceError, HybridRegressor
from sklearn_hybrid.models import pendulum_f

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
        fit(data, rho=rho)


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


def test_predict_before_fit_and_wrong_features(data):
    from sklearn.exceptions import NotFittedError

    with pytest.raises(NotFittedError):
        HybridRegressor(science=pendulum_f).predict(data[0])
    est = fit(data)
    with pytest.raises(ValueError, match="expecting 2 features"):
        est.predict(np.zeros((3, 3)))
