"""A table of bad inputs: each raises a named error, and nothing the user had changes.

Every row is (what is wrong, how it is called, expected exception, a phrase the message
must contain). For every row the test also checks that the arrays and parameter objects
the user passed are unchanged and that an estimator fitted earlier still has the same
theta, feature count and predictions.
"""

import copy
import functools
import warnings
from dataclasses import dataclass
from types import SimpleNamespace
from typing import Callable

import numpy as np
import pytest
import torch

from sklearn.exceptions import ConvergenceWarning, NotFittedError

from sklearn_hybrid import DivergenceError, HybridRegressor, HybridRegressorCV, OdeStructure, pack_inputs
from sklearn_hybrid.methods import SAM, FisherSAM
from sklearn_hybrid.datasets import get_data_home, make_pendulum
from sklearn_hybrid.diagnosis import Evidence, ResidualDiagnosis, close_the_loop
from sklearn_hybrid.identifiability import profile_theta, science_intervals
from sklearn_hybrid.models import pendulum_f
from sklearn_hybrid.residual import MLP

FAST = dict(max_iter=3, residual={"hidden": (8,)}, random_state=0, dt=0.2)


def _data():
    rng = np.random.default_rng(0)
    return rng.uniform(-1, 1, (6, 2)), rng.uniform(-1, 1, (6, 5, 2))


@pytest.fixture(scope="module")
def earlier():
    """A fit the failing calls must leave alone."""
    X, y = _data()
    est = HybridRegressor(science=pendulum_f, **FAST).fit(X, y)
    return SimpleNamespace(est=est, X=X, theta=dict(est.theta_), pred=est.predict(X),
                           n_features=est.n_features_in_)


# --- science functions with something wrong -------------------------------------------------

def in_place(v, omega=0.5):  # degrees to radians, in place
    v[:, 0] *= torch.pi / 180
    return pendulum_f(v, omega)


def through_numpy(v, omega=0.5):  # theta's gradient is cut
    out = pendulum_f(v, omega).detach().numpy()
    return torch.as_tensor(out * omega.detach().numpy())


def numpy_on_tensor(v, omega=0.5):
    return torch.stack([v[:, 1], -omega * np.sin(v[:, 0])], dim=-1)


def nan_at_start(v, omega=0.5):
    return torch.stack([v[:, 1], -omega * torch.log(v[:, 0])], dim=-1)


def grows(v, omega=0.5):  # finite at the initial states, infinite along the trajectory
    return torch.exp(torch.exp(3 * v)) * omega


def transposed(v, omega=0.5):
    return torch.stack([v[:, 1], -omega * torch.sin(v[:, 0])], dim=0)


def tensor_default(v, omega=0.5, k=torch.tensor(1.0)):
    return pendulum_f(v, omega) * k


def raises(v, omega=0.5):
    raise RuntimeError("division by the unknown")


def returns_int(v, omega=0.5):  # a rounding to integers: no gradient, and no dtype a fit computes in
    return (pendulum_f(v, omega) * 10).long()


def returns_numpy(v, omega=0.5):
    return np.zeros((len(v), 2))


def clamps_in_place(v, omega=0.5):  # a domain guard that changes no value here, yet breaks autograd
    v[:, 0].clamp_(min=-10)
    return pendulum_f(v, omega)


def float64_constant(v, omega=0.5):  # promotes a float32 fit's states to float64
    return pendulum_f(v, omega) * torch.from_numpy(np.ones(1))


def scalar_of_x(x, k=1.0):  # one value per sample, for a y of shape (n, 1)
    return k * x[:, 0]


def transposed_composition(x, f, g):
    return (f(x) + g(x)).T


def forced_two_states(v, u, k=1.0):
    return torch.stack([v[:, 1], -k * v[:, 0] + u[:, 0]], dim=-1)


def packed_with(n_samples):
    """X of a forced system with n_samples input samples per trajectory (y's 5 steps need 6)."""
    def transform(X, y):
        u = np.linspace(-1, 1, len(X) * n_samples).reshape(len(X), n_samples, 1)
        return pack_inputs(X, u), y
    return transform


class Pend:
    def f(self, v, omega=0.5):  # passed as Pend.f, unbound
        return pendulum_f(v, omega)


def loud_network(in_shapes, out_shape):
    """A network whose random start is ten times the usual: its force blows the integration up."""
    net = MLP(in_shapes, out_shape, hidden=(8,), zero_init=False)
    with torch.no_grad():
        for p in net.parameters():
            p.mul_(10.0)
    return net


def one_large(where, value):
    def transform(X, y):
        X, y = X.copy(), y.copy()
        (X if where == "X" else y)[0, 0] = value
        return X, y
    return transform


# --- the table -----------------------------------------------------------------------------

@dataclass
class Call:
    """What a row does: set ``params`` on the earlier estimator, then ``run(est, X, y)``."""

    params: dict
    run: Callable


def fit(**params):
    return fit_on(lambda X, y: (X, y), **params)


def fit_on(transform, **params):
    """Fit with ``params`` on transformed data."""
    return Call({**FAST, "science": pendulum_f, **params},
                lambda est, X, y: est.fit(*transform(X, y)))


def predict_on(transform):
    return Call({}, lambda est, X, y: est.predict(transform(X)))


def cv(**params):
    def run(est, X, y):
        HybridRegressorCV(est, **params).fit(X, y)
    return Call({"method": "erm"}, run)


def diagnose(transform, estimator_params=None, **params):
    """ResidualDiagnosis of the earlier fit (its parameters set to ``estimator_params``), judged with
    (transformed) data."""
    return Call(dict(estimator_params or {}),
                lambda est, X, y: ResidualDiagnosis(random_state=0, **params).fit(est, *transform(X, y)))


def pendulum(X, y):
    """The package's pendulum task in place of the table's data (the issue's cases)."""
    data = make_pendulum(random_state=0)
    return data.X_train, data.y_train


def with_nan(where):
    def transform(X, y):
        X, y = X.copy(), y.copy()
        (X if where == "X" else y)[0, 0] = np.nan
        return X, y
    return transform


def short_profile(est, X, y):
    """A profile cheap enough for the table (three points, three iterations each)."""
    return profile_theta(est, X, y, n_points=3, max_iter=3, refine=False)


def report_with_profile_of(**other_params):
    """fit_report of the earlier fit with the profile of another fit (``other_params`` set on a copy)."""
    def run(est, X, y):
        other = copy.deepcopy(est).set_params(**other_params).fit(X, y)
        return est.fit_report(profile=short_profile(other, X, y))
    return Call({}, run)


def report_of_fixed_fit_with_profile_of_earlier(est, X, y):
    """The issue's case: a fit that held omega fixed at 0.8 given the earlier fit's profile."""
    fixed = copy.deepcopy(est).set_params(theta_fixed={"omega": 0.8}).fit(X, y)
    return fixed.fit_report(profile=short_profile(est, X, y))


def intervals_with_nan_in_y(est, X, y):
    """science_intervals of a network-free copy of the earlier fit, with one NaN in y."""
    from sklearn_hybrid.diagnosis import ZeroResidual

    free = copy.deepcopy(est).set_params(residual=ZeroResidual()).fit(X, y)
    return science_intervals(free, *with_nan("y")(X, y))


def loop(transform=lambda X, y: (X, y), **kwargs):
    """close_the_loop of the earlier fit on (transformed) data, with keyword arguments."""
    return Call({}, lambda est, X, y: close_the_loop(est, *transform(X, y), **kwargs))


def candidates_of(terms):
    from sklearn_hybrid.diagnosis import Candidates

    return Call({}, lambda est, X, y: close_the_loop(est, X, y, candidates=Candidates(terms=terms)))


def y_test_of(transform):
    """close_the_loop of the earlier fit with the training data as test data, y_test transformed."""
    return Call({}, lambda est, X, y: close_the_loop(est, X, y, X, transform(y)))


def plot_on(transform):
    """plot_fit of the earlier fit against (transformed) data."""
    def run(est, X, y):
        import matplotlib

        matplotlib.use("Agg")
        from sklearn_hybrid import plot_fit

        return plot_fit(est, *transform(X, y))
    return Call({}, run)


CASES = [
    # item 1: the layout of y for "ode"
    ("y with 3 components for 2 states", fit_on(lambda X, y: (X, np.concatenate([y, y[..., :1]], -1))),
     ValueError, "y must have shape (n_samples, n_steps, 2)"),
    ("y with 1 component, observed not set", fit_on(lambda X, y: (X, y[..., :1])),
     ValueError, "say which with observed=[...]"),
    ("y transposed", fit_on(lambda X, y: (X, np.swapaxes(y, 1, 2))),
     ValueError, "looks transposed"),
    ("observed=[0] with every component in y", fit(observed=[0]),
     ValueError, "y holds every state component, but observed=[0]"),
    ("y flattened", fit_on(lambda X, y: (X, y.reshape(len(y), -1))),
     ValueError, "y.reshape(len(y), -1, 2)"),
    ("y with one value per sample", fit_on(lambda X, y: (X, y[:, 0, 0])),
     ValueError, "got a 1-D y"),
    # item 2: a refit that fails must not damage the earlier fit
    ("refit on X with another feature count", fit_on(lambda X, y: (np.c_[X, X[:, :1]], y)),
     ValueError, "state shape (3,) from X"),
    ("refit on X with NaN", fit_on(with_nan("X")), ValueError, "Input X contains NaN"),
    ("refit on y with NaN", fit_on(with_nan("y")), ValueError, "Input y contains NaN"),
    ("refit on no samples", fit_on(lambda X, y: (X[:0], y[:0])), ValueError, "0 sample(s)"),
    ("refit with unequal sample counts", fit_on(lambda X, y: (X, y[:-1])),
     ValueError, "inconsistent numbers of samples"),
    # items 3-6: what the science function does
    ("science writes into its input, float64", fit(science=in_place, dtype="float64"),
     ValueError, "modifies its input in place"),
    ("science writes into its input, float32", fit(science=in_place),
     ValueError, "modifies its input in place"),
    ("science cuts theta's gradient", fit(science=through_numpy),
     ValueError, "passes no gradient to parameter(s) ['omega']"),
    ("science cuts theta's gradient, additive", fit_on(lambda X, y: (X, X), science=through_numpy,
                                                      structure="additive"),
     ValueError, "passes no gradient to parameter(s) ['omega']"),
    ("science calls numpy on a tensor", fit(science=numpy_on_tensor),
     ValueError, "use the torch function (torch.sin)"),
    ("science NaN at the initial states", fit(science=nan_at_start),
     ValueError, "'nan_at_start' returned non-finite values for states"),
    ("science infinite along the trajectory", fit(science=grows),
     DivergenceError, "science function 'grows' returned"),
    ("science output transposed", fit(science=transposed),
     ValueError, "It looks transposed: stack the components along the last axis"),
    ("science raises", fit(science=raises),
     ValueError, "'raises' raised RuntimeError: division by the unknown"),
    ("science returns numpy", fit(science=returns_numpy), TypeError, "expected a torch.Tensor"),
    ("science clamps its input in place, values unchanged", fit(science=clamps_in_place),
     ValueError, "modifies its input in place"),
    ("science returns float64 in a float32 fit", fit(science=float64_constant),
     ValueError, "returned torch.float64 values for torch.float32 inputs"),
    ("science lacks y's trailing axis of length 1", fit_on(lambda X, y: (X, X[:, :1]), science=scalar_of_x,
                                                          structure="additive"),
     ValueError, "It lacks the trailing axis of length 1"),
    ("user composition returns (outputs, samples)", fit_on(lambda X, y: (X, X), science=lambda x, a=1.0: a * x,
                                                           structure=transposed_composition,
                                                           residual=lambda: torch.nn.Linear(2, 2)),
     ValueError, "'transposed_composition' returned (2, 6) for 6 samples"),
    # item 8: the signature reader
    ("tensor default", fit(science=tensor_default), TypeError, "'k' has a torch.Tensor default"),
    ("NaN bound", fit(theta_bounds={"omega": (np.nan, 2.0)}), ValueError, "contains NaN"),
    ("bound that is not a number", fit(theta_bounds={"omega": ("low", 2.0)}),
     ValueError, "must hold numbers"),
    ("unknown parameter name", fit(theta_init={"omgea": 1.0}),
     ValueError, "theta_init names unknown parameter(s) ['omgea']"),
    ("scalar parameter started as an array", fit(theta_init={"omega": np.array([0.6])}),
     ValueError, "theta_init['omega'] has shape (1,), the default has shape (): give a number"),
    ("initial value outside bounds", fit(theta_init={"omega": 3.0}, theta_bounds={"omega": (0, 2)}),
     ValueError, "outside its bounds"),
    ("theta_fixed and theta_init disagree", fit(theta_init={"omega": 0.5}, theta_fixed={"omega": 0.6}),
     ValueError, "theta_init['omega'] = 0.5 and theta_fixed['omega'] = 0.6 disagree"),
    ("theta_fixed value not a number", fit(theta_fixed={"omega": "0.6"}),
     ValueError, "theta_fixed['omega'] must be a number"),
    ("theta_fixed value outside bounds", fit(theta_fixed={"omega": 3.0}, theta_bounds={"omega": (0, 2)}),
     ValueError, "outside its bounds"),
    # item 9: raw or misleading messages
    ("observed=[]", fit(observed=[]), ValueError, "observed must list the observed state"),
    ("observed=[0, 0]", fit(observed=[0, 0]), ValueError, "lists a component twice"),
    ("observed=[5]", fit(observed=[5]), ValueError, "must index a vector state of length 2"),
    ("observed=[True]", fit(observed=[True]), ValueError, "non-negative integers"),
    ("residual module instance", fit(residual=torch.nn.Linear(2, 2)),
     TypeError, "residual=lambda: Linear(...)"),
    ("dt=True", fit(dt=True), ValueError, "dt must be a positive number"),
    ("n_substeps=True", fit(n_substeps=True), ValueError, "n_substeps must be a positive integer"),
    ("max_iter=0", fit(max_iter=0), ValueError, "max_iter must be a positive integer"),
    ("unknown method", fit(method="sgd"), ValueError, "Unknown method 'sgd'"),
    ("f-reg with a user composition", fit_on(lambda X, y: (X, X), method="f-reg",
                                            structure=lambda x, f, g: f(x) + g(x),
                                            residual=lambda: torch.nn.Linear(2, 2)),
     ValueError, "method='f-reg' needs a structure that defines a science-only reduction"),
    ("HybridRegressorCV seeds=[0, 1.5]", cv(seeds=[0, 1.5]),
     ValueError, "seeds must hold integers, got 1.5"),
    ("HybridRegressorCV n_jobs=0", cv(n_jobs=0), ValueError, "n_jobs must be a non-zero integer"),
    ("HybridRegressorCV n_jobs=1.5", cv(n_jobs=1.5), ValueError, "got 1.5"),
    ("predict on another per-sample shape", predict_on(lambda X: X[:, :, None]),
     ValueError, "X has per-sample shape (2, 1); this model was fitted on (2,)"),
    ("predict on another feature count", predict_on(lambda X: X[:, :1]),
     ValueError, "expecting 2 features"),
    ("predict on NaN", predict_on(lambda X: np.where(X > 0, np.nan, X)),
     ValueError, "Input X contains NaN"),
    # audit 3
    ("rho=inf", fit(method=SAM(rho=np.inf)), ValueError, "rho must be a positive number, got inf (finite"),
    ("lr=inf", fit(lr=np.inf), ValueError, "lr must be a positive number, got inf (finite"),
    ("random_state=-1", fit(random_state=-1), ValueError, "random_state must be None, a RandomState or an integer"),
    ("science without u, n_inputs=1", fit_on(lambda X, y: (np.concatenate([X, np.zeros((6, 6))], 1), y),
                                            n_inputs=1),
     ValueError, "takes the state 'v' alone, but n_inputs=1"),
    ("HybridRegressorCV seeds=[3, 3]", cv(seeds=[3, 3]), ValueError, "seeds holds a value more than once"),
    ("HybridRegressorCV seeds=[-1]", cv(seeds=[-1]), ValueError, "seeds must be integers in [0, 2**32 - 1]"),
    ("HybridRegressorCV rhos=[inf]", cv(rhos=[np.inf]), ValueError, "rhos must hold positive numbers, got inf"),
    ("residual='cnn' on a vector state", fit(residual="cnn"),
     ValueError, "The residual network fails on inputs of per-sample shape(s) [(2,)]"),
    ("residual factory with the wrong output size", fit(residual=lambda: torch.nn.Linear(2, 3)),
     ValueError, "returns (3,) per sample"),
    ("score on transposed y", Call({}, lambda est, X, y: est.score(X, np.swapaxes(y, 1, 2))),
     ValueError, "y has shape (6, 2, 5); the model predicts (6, 5, 2)"),
    # audit 4 (issue 40): a training that went bad is no fit
    ("lr=20: the loss ends 4e31 times its start", fit(lr=20, max_iter=30),
     DivergenceError, "The training diverged: the training loss ended at"),
    # a network wider than the default, which this lr throws out for good
    ("sam, lr=1 on the pendulum: trained through its spikes", fit_on(pendulum, method="sam", lr=1, max_iter=50,
                                                                    residual={"hidden": (128, 128)}),
     DivergenceError, "Lower lr (lr=1) or rho"),
    # audit 4: errors that blamed the wrong thing
    ("y * 1e300 in float32", fit_on(lambda X, y: (X, y * 1e300)),
     ValueError, "y holds values up to 9.94e+299, which overflow float32 (largest number 3.4e+38). Rescale y"),
    ("an X entry of 1e39 in float32", fit_on(one_large("X", 1e39)),
     ValueError, "X holds values up to 1e+39, which overflow float32 (largest number 3.4e+38). Fit with "
                 "dtype='float64'"),
    ("a y entry whose square overflows float32", fit_on(one_large("y", 1e20)),
     ValueError, "make the squared errors of the loss overflow float32"),
    ("dt=1e6: the science alone explodes", fit(dt=1e6),
     DivergenceError, "The integration step is too long for these dynamics"),
    ("a network start that blows 25 steps up", fit_on(lambda X, y: (X, np.repeat(y, 5, axis=1)),
                                                     residual=loud_network),
     DivergenceError, "the network's random start adds a force"),
    ("science=Pend.f, an unbound method", fit(science=Pend.f),
     TypeError, "science=Pend.f is a method taken from its class"),
    ("forced X packed with 8 input samples where y's 5 steps need 6", fit_on(packed_with(8), n_inputs=1,
                                                                          science=forced_two_states),
     ValueError, "y's 5 steps need 6 input samples of 1 input(s) (times 0 to 5 dt), 6 columns, which leaves 4"),
    ("the same, y observing one component", fit_on(lambda X, y: (packed_with(8)(X, y)[0], y[..., :1]),
                                                   n_inputs=1, observed=[0], science=forced_two_states),
     ValueError, "X holds more input samples than y's steps need"),
    ("n_substeps=10**6 (hung in the memory check)", fit(n_substeps=10**6),
     ValueError, "n_substeps must be at most 1000, got 1000000"),
    ("close_the_loop with y of another horizon", Call({}, lambda est, X, y: close_the_loop(est, X, y[:, :3])),
     ValueError, "y has per-sample shape (3, 2); the estimator was fitted on y of per-sample shape (5, 2)"),
    ("HybridRegressorCV.predict before fit", Call({}, lambda est, X, y: HybridRegressorCV(est).predict(X)),
     NotFittedError, "is not fitted yet"),
    # audit 4: ResidualDiagnosis judges its terms with y, as close_the_loop does
    ("ResidualDiagnosis with y of another horizon", diagnose(lambda X, y: (X, y[:, :3])),
     ValueError, "y has per-sample shape (3, 2); the estimator was fitted on y of per-sample shape (5, 2)"),
    ("ResidualDiagnosis with y of fewer samples", diagnose(lambda X, y: (X, y[:-1])),
     ValueError, "y has 5 samples and X 6"),
    ("ResidualDiagnosis with y of too few samples to judge", diagnose(lambda X, y: (X[:3], y[:3])),
     ValueError, "3 samples: a split needs 4 at least"),
    ("ResidualDiagnosis z=0", diagnose(lambda X, y: (X, y), evidence=Evidence(z=0)),
     ValueError, "z must be a positive number of standard errors, got 0"),
    ("ResidualDiagnosis judging a model with a theta encoder", diagnose(lambda X, y: (X, y), {"theta_encoder": "mlp"}),
     ValueError, "cannot judge terms of a model with a theta_encoder"),
    ("ResidualDiagnosis exact naming an unknown state", diagnose(lambda X, y: (X, y), exact=["omega"]),
     ValueError, "exact entry 'omega' is neither a state name of ['x0', 'x1'] nor an index below 2"),
    # issue 49: silent wrong results on the new surfaces
    ("fit_report with the profile of another fit", report_with_profile_of(theta_init={"omega": 0.7}),
     ValueError, "The profile was made for another fit (omega="),
    ("fit_report of a fit holding omega fixed, with a profile of omega",
     Call({}, report_of_fixed_fit_with_profile_of_earlier),
     ValueError, "which this fit held fixed (omega=0.8"),
    ("science_intervals with NaN in y", Call({}, intervals_with_nan_in_y),
     ValueError, "y contains NaN or infinite values"),
    ("plot_fit with y transposed", plot_on(lambda X, y: (X, np.swapaxes(y, 1, 2))),
     ValueError, "y has shape (6, 2, 5); the model predicts (6, 5, 2)"),
    ("plot_fit with y of other samples", plot_on(lambda X, y: (X, y[:-1])),
     ValueError, "y has shape (5, 5, 2); the model predicts (6, 5, 2)"),
    # issue 49: unclear errors
    ("close_the_loop(z=2), moved into Evidence", loop(z=2),
     TypeError, "z moved into Evidence: close_the_loop(..., evidence=Evidence(z=2))"),
    ("close_the_loop(max_terms=2, cv=3), moved into both", loop(max_terms=2, cv=3),
     TypeError, "cv moved into Evidence: close_the_loop(..., evidence=Evidence(cv=3)); max_terms moved into "
                "Candidates: close_the_loop(..., candidates=Candidates(max_terms=2))"),
    ("close_the_loop(term_kinds=...), now Candidates(kinds=...)", loop(term_kinds=["drag"]),
     TypeError, "candidates=Candidates(kinds=['drag'])"),
    ("close_the_loop with a misspelt keyword", loop(verbos=True),
     TypeError, "unexpected keyword argument 'verbos'; did you mean 'verbose'?"),
    ("Candidates(terms=['v_dot'])", candidates_of(["v_dot"]),
     TypeError, "terms holds 'v_dot' (a str); it must hold Term objects: a term by its name: named_terms("),
    ("Candidates(terms=[a plain function])", candidates_of([lambda d: d["x0"]]),
     TypeError, "(a function); it must hold Term objects"),
    ("close_the_loop with inf in y", loop(one_large("y", np.inf)),
     ValueError, "y is not finite: sample(s) [0] hold NaN or infinite values"),
    ("close_the_loop with y_test of one state of two", y_test_of(lambda y: y[..., :1]),
     ValueError, "y_test has per-sample shape (5, 1); y has (5, 2)"),
    ("close_the_loop with y_test of other steps", y_test_of(lambda y: y[:, :3]),
     ValueError, "y_test has per-sample shape (3, 2); y has (5, 2)"),
    ("y as a pandas Series of arrays", fit_on(lambda X, y: (X, __import__("pandas").Series(list(y)))),
     ValueError, "y holds one array per sample (ndarray of shape (5, 2) in an object array of shape (6,)"),
    ("science returns an int tensor", fit(science=returns_int),
     ValueError, "returned torch.int64 values for torch.float32 inputs: it computes in integers"),
]


def _same(a, b):
    """Equal values (arrays, containers, numbers), or the very same object."""
    if isinstance(a, np.ndarray):
        return isinstance(b, np.ndarray) and np.array_equal(a, b, equal_nan=True)
    if isinstance(a, dict):
        return isinstance(b, dict) and a.keys() == b.keys() and all(_same(a[k], b[k]) for k in a)
    if isinstance(a, (list, tuple)):
        return type(a) is type(b) and len(a) == len(b) and all(map(_same, a, b))
    if isinstance(a, (int, float, str, type(None))):
        return a == b or (a != a and b != b)
    return True  # functions, modules: objects we do not copy


@pytest.mark.parametrize("what, call, error, phrase", CASES, ids=[c[0] for c in CASES])
def test_bad_input_is_named_and_changes_nothing(earlier, what, call, error, phrase):
    est = copy.deepcopy(earlier.est).set_params(**call.params)
    X, y = _data()
    X_before, y_before = X.copy(), y.copy()
    params_before = copy.deepcopy(call.params)
    with pytest.raises(error) as info:
        call.run(est, X, y)
    assert phrase in str(info.value), f"{what}: {info.value}"
    # the user's arrays, and the parameter objects they passed, are unchanged
    np.testing.assert_array_equal(X, X_before)
    np.testing.assert_array_equal(y, y_before)
    assert _same(params_before, call.params)
    # the earlier fit is whole
    assert est.theta_ == earlier.theta
    assert est.n_features_in_ == earlier.n_features
    # predict refuses parameters that no longer describe the fitted model (a changed dt or
    # structure would be ignored): with the parameters set back, the earlier fit predicts as before
    est.set_params(**earlier.est.get_params())
    np.testing.assert_array_equal(est.predict(earlier.X), earlier.pred)


def test_table_size():
    """The closing note quotes this count; keep it in step with CASES."""
    assert len(CASES) == 95


def test_data_home_that_is_a_file(tmp_path, monkeypatch):
    file = tmp_path / "data.csv"
    file.write_text("x\n")
    with pytest.raises(NotADirectoryError, match="data_home points at .*which is a file"):
        get_data_home(file)
    monkeypatch.setenv("SKLEARN_HYBRID_DATA", str(file))
    with pytest.raises(NotADirectoryError, match="SKLEARN_HYBRID_DATA points at"):
        get_data_home()
    assert file.read_text() == "x\n"


def test_residual_factory_returning_one_network_twice():
    X, y = _data()
    net = torch.nn.Sequential(torch.nn.Linear(2, 2))
    est = HybridRegressor(science=pendulum_f, **{**FAST, "residual": lambda: net}).fit(X, y)
    theta = dict(est.theta_)
    with pytest.raises(ValueError, match="it had returned before; it must build a new network"):
        est.fit(X, y)
    assert est.theta_ == theta


def test_partial_binds_a_constant():
    def scaled(v, omega=0.5, k=1.0):
        return pendulum_f(v, omega) * k

    X, y = _data()
    est = HybridRegressor(science=functools.partial(scaled, k=2.0), **FAST).fit(X, y)
    assert set(est.theta_) == {"omega"}


def test_training_that_went_bad_is_not_usable():
    """fsam with rho=10 ends without error, but far worse than predicting the mean: the fit is returned with a
    ConvergenceWarning, and its report says first that it is not usable."""
    X, y = pendulum(None, None)
    est = HybridRegressor(science=pendulum_f, method=FisherSAM(rho=10), max_iter=30, dt=0.2, random_state=0,
                          residual={"hidden": (128, 128), "zero_init": False})  # a random start to undo
    with pytest.warns(ConvergenceWarning, match=r"not usable: its training R\^2 is -.*worse than predicting"):
        est.fit(X, y)
    report = est.fit_report().splitlines()
    assert report[1].strip().startswith("NOT USABLE: the training went bad: its training R^2 is")


def test_the_issues_fsam_with_rho_10_is_not_usable():
    """Issue 63, item 4: the default network with fsam at rho=10 for 100 iterations ended with a training R^2 of
    -2.46 and no word of it; it is flagged (theta never left its start), in the warning and the report."""
    X, y = pendulum(None, None)
    est = HybridRegressor(science=pendulum_f, method=FisherSAM(rho=10.0), max_iter=100, dt=0.2, random_state=0)
    with pytest.warns(ConvergenceWarning, match=r"not usable: its training R\^2 is -"):
        est.fit(X, y)
    assert est.score(X, y) < 0
    assert est.fit_report().splitlines()[1].strip().startswith("NOT USABLE: the training went bad")


def test_a_short_healthy_fit_is_not_flagged():
    X, y = pendulum(None, None)
    with warnings.catch_warnings():
        warnings.simplefilter("error", ConvergenceWarning)
        est = HybridRegressor(science=pendulum_f, max_iter=30, dt=0.2, random_state=0).fit(X, y)
    assert "NOT USABLE" not in est.fit_report()


@pytest.mark.parametrize("start, halved, phrase", [
    (0.1, [], "times its start"),          # ended above twice its start
    (10.0, [1, 2, 3, 4, 5], "after the loss spiked 5 times"),  # the guard's halvings spent
    (10.0, [1], None),                     # a short fit on noise: R^2 < 0 but nothing went bad
])
def test_verdict_on_a_model_worse_than_the_mean(start, halved, phrase):
    """The verdict's rules, on a short fit to noise (training R^2 < 0) with the history it read."""
    from sklearn_hybrid.training.verdict import judge_training

    X, y = _data()
    est = HybridRegressor(science=pendulum_f, **FAST).fit(X, y)
    inputs = est.model_.structure.tensors(X, torch.float32)
    y_t = torch.tensor(y.reshape(len(y), -1), dtype=torch.float32)
    history = {"loss": np.r_[start, np.ones(29)], "theta": {"omega": np.linspace(0.49, 0.48, 30)},
               "lr_halved_at": halved}
    verdict = judge_training(est.model_, history, inputs, y_t, theta_start={"omega": 0.5})
    assert verdict.r2 < 0
    if phrase is None:
        assert verdict.usable
    else:
        assert not verdict.usable and phrase in verdict.summary()


@pytest.mark.parametrize("fixed, omega", [({"omega": 0.6}, 0.6), ({"omega": None}, 0.5), (["omega"], 0.5)])
def test_theta_fixed_dict_fixes_at_its_value(fixed, omega):
    """theta_fixed={"omega": 0.6} holds omega at 0.6 (lmfit's vary=False with a value), not at the default."""
    X, y = _data()
    before = copy.deepcopy(fixed)
    est = HybridRegressor(science=pendulum_f, theta_fixed=fixed, **FAST).fit(X, y)
    assert est.theta_["omega"] == pytest.approx(omega, rel=1e-6)
    assert np.all(est.history_["theta"]["omega"] == est.theta_["omega"])
    assert "(fixed)" in est.fit_report()
    assert fixed == before


def test_zero_started_network_starts_from_the_science_alone():
    """residual={"zero_init": True}, offered where a random start blows a long integration up."""
    from sklearn_hybrid.residual import build_residual

    net = build_residual({"kind": "mlp", "zero_init": True}, ((2,),), (2,))
    assert torch.count_nonzero(net(torch.randn(4, 2))) == 0
    assert any(torch.count_nonzero(p) for p in net.parameters())  # the hidden layers are random


def test_data_file_replaced_by_a_folder(tmp_path):
    from sklearn_hybrid.datasets._base import RemoteFile, fetch_file

    (tmp_path / "sub" / "data.csv").mkdir(parents=True)
    with pytest.raises(IsADirectoryError, match=r"data.csv is a folder .* where the data file sub/data.csv should be"):
        fetch_file(RemoteFile("sub/data.csv", "https://example.invalid/data.csv", "0" * 64), tmp_path)
    assert (tmp_path / "sub" / "data.csv").is_dir()


def test_offline_download_fails_within_seconds(tmp_path, monkeypatch):
    """Offline, name resolution can hang for tens of seconds per address: the addresses get one short
    deadline together, and the same clear line comes at once."""
    import socket
    import threading
    import time

    from sklearn_hybrid.datasets import _base

    released, probes = threading.Event(), []

    def hangs(*args, **kwargs):  # as name resolution offline: no answer, then a failure
        probes.append(threading.current_thread())
        released.wait(60)
        raise OSError("name resolution timed out")

    monkeypatch.setattr(socket, "create_connection", hangs)
    remote = _base.RemoteFile("sub/data.csv", "https://example.invalid/a.csv", "0" * 64,
                              mirrors=("https://mirror.invalid/a.csv",))
    start = time.monotonic()
    try:
        with pytest.raises(FileNotFoundError, match=r"none of its 2 address\(es\) answered within 3 s"):
            _base.fetch_file(remote, tmp_path / "home")
        assert time.monotonic() - start < 2 * _base._REACH_TIMEOUT_S
    finally:  # the probes outlive the call by design; end them here, not in a later test
        released.set()
        for thread in probes:
            thread.join(5)
    assert len(probes) == 2 and not any(thread.is_alive() for thread in probes)
    assert not (tmp_path / "home").exists()


def test_a_probe_that_fails_oddly_raises_nothing_into_its_thread(monkeypatch):
    """A reachability probe runs in a thread that may outlive the call: whatever fails in it (here not an
    OSError) means the address did not answer, and nothing reaches threading's excepthook, which pytest
    reports as a stray PytestUnhandledThreadExceptionWarning in some later test."""
    import socket
    import threading

    from sklearn_hybrid.datasets import _base

    def odd(*args, **kwargs):
        raise RuntimeError("a resolver that fails in its own way")

    unhandled = []
    monkeypatch.setattr(socket, "create_connection", odd)
    monkeypatch.setattr(threading, "excepthook", unhandled.append)
    assert _base._answering(["https://example.invalid/a.csv"]) == set()
    assert unhandled == []


def test_a_smoke_test_of_two_iterations_is_not_judged():
    """One step on y = 0 may raise the loss a hundredfold from a start near zero: no divergence, no warning."""
    from sklearn_hybrid.training.verdict import judge_training

    X, y = _data()
    est = HybridRegressor(science=pendulum_f, **FAST).fit(X, y)
    inputs = est.model_.structure.tensors(X, torch.float32)
    y_t = torch.tensor(y.reshape(len(y), -1), dtype=torch.float32)
    history = {"loss": np.array([1e-6, 1e-6]), "theta": {"omega": np.array([0.5, 0.5])}, "lr_halved_at": []}
    assert judge_training(est.model_, history, inputs, y_t, theta_start={"omega": 0.5}).usable


def any_size(v, u, k=1.0):  # a forced science that works for a state of any size
    return -k * v + u


def test_forced_inputs_packed_beyond_ys_steps_cannot_be_told_from_a_larger_state():
    """X of a forced system is the state, then inputs at y's n_steps + 1 times; the state's size is what
    remains. Packed with 8 input samples where y's 5 steps need 6, the 2-state X is, column for column,
    the X of a 4-state system packed right: no rule can tell them apart. Where the science function
    or y fixes the state's size the surplus is refused (the rows above); where neither does (this
    function, observed=[0, 1]) the fit reads 4 states and warns, at fit, that a smaller state fits X
    too, and fit_report() says how X was read. What the user must pass: u with y's n_steps + 1
    samples, pack_inputs(x0, u[:, :n_steps + 1]). Packed right, the 2-state fit is silent: observed=[0, 1]
    rules out any smaller state."""
    X, y = _data()
    packed, _ = packed_with(8)(X, y)
    u = np.linspace(-1, 1, len(X) * 8).reshape(len(X), 8, 1)
    np.testing.assert_array_equal(packed, pack_inputs(packed[:, :4], packed[:, 4:].reshape(len(X), 6, 1)))
    params = {**FAST, "science": any_size, "n_inputs": 1, "observed": [0, 1]}
    with pytest.warns(UserWarning, match=r"X read as a state of 4 component\(s\), then 6 samples of 1 input\(s\)"
                                         r".*works for a state of 3 or 2 component\(s\) too.*"
                                         r"pack_inputs\(x0, u\[:, :6\]\)"):
        surplus = HybridRegressor(**params).fit(packed, y)
    assert surplus.model_.structure.state_shape == (4,)
    assert "X read as a state of 4 component(s), then 6 samples of 1 input(s)" in surplus.fit_report()
    with warnings.catch_warnings():
        warnings.simplefilter("error", UserWarning)
        right = HybridRegressor(**params).fit(pack_inputs(X, u[:, :6]), y)
    assert right.model_.structure.state_shape == (2,)
    assert "X read as a state of 2 component(s), then 6 samples" in right.fit_report()


def test_fit_report_refuses_a_profile_made_before_a_refit():
    """A refit on other data makes the profile of the earlier fit stale: refused, not printed as this fit's."""
    X, y = _data()
    est = HybridRegressor(science=pendulum_f, **FAST).fit(X, y)
    profile = short_profile(est, X, y)
    assert "(profile)" in est.fit_report(profile=profile) or "NOT IDENTIFIED" in est.fit_report(profile=profile)
    est.fit(X[:5], y[:5])
    with pytest.raises(ValueError, match=r"or for this estimator before it was refit.*profile_theta\(est, X, y\)"):
        est.fit_report(profile=profile)


def test_an_ode_fit_without_dt_says_it_guessed_the_time_step():
    """Data sampled every 0.2 fitted without dt would train at dt=1.0, every rate in theta scaled to match:
    the fit warns and says how to give dt; dt=1.0 given, or a structure without time, fits silently."""
    X, y = _data()
    params = {**FAST, "science": pendulum_f}
    del params["dt"]
    with pytest.warns(UserWarning, match=r"dt was not given: the ODE is integrated with dt=1.0.*dt=0.1"):
        guessed = HybridRegressor(**params).fit(X, y)
    with warnings.catch_warnings():
        warnings.simplefilter("error", UserWarning)
        given = HybridRegressor(**params, structure=OdeStructure(dt=1.0)).fit(X, y)
        HybridRegressor(science=scalar_of_x, structure="additive", max_iter=3, random_state=0).fit(X, X[:, 0])
    assert guessed.structure == "ode" and guessed.model_.structure.dt == 1.0
    assert guessed.theta_ == given.theta_
