"""Profiles, the bootstrap and network-free intervals: verdicts that can be wrong, and are not."""

import distributed
import joblib
import matplotlib
import numpy as np
import pytest
import torch
from sklearn.base import clone
from sklearn.exceptions import NotFittedError

from sklearn_hybrid import DivergenceError, HybridRegressor
from sklearn_hybrid.diagnosis import ZeroResidual
from sklearn_hybrid.methods import ParameterRegularization
from sklearn_hybrid.identifiability import (IDENTIFIED, PRACTICAL, STRUCTURAL, UNSETTLED, ThetaProfile, bootstrap_theta,
                                            plot_profile, profile_theta, science_intervals)

matplotlib.use("Agg")


def line_f(x, a=1.5, b=0.2):
    return a * x[:, 0] + b


class Offset(torch.nn.Module):
    """A network that can only add a learnable constant: it absorbs ``b`` exactly, never ``a``."""

    def __init__(self):
        super().__init__()
        self.c = torch.nn.Parameter(torch.zeros(()))

    def forward(self, x):
        return self.c.expand(len(x))


@pytest.fixture(scope="module")
def line_data():
    rng = np.random.default_rng(0)
    X = rng.uniform(-1, 1, (40, 1))
    y = 2.0 * X[:, 0] + 0.5 + 0.1 * rng.normal(size=40)
    return X, y


@pytest.fixture(scope="module")
def offset_fit(line_data):
    X, y = line_data
    est = HybridRegressor(science=line_f, structure="additive", residual=lambda i, o: Offset(), method="erm",
                          lr=5e-2, max_iter=300, tol=None, dtype="float64", random_state=0)
    return est.fit(X, y)


@pytest.fixture(scope="module")
def offset_profile(offset_fit, line_data):
    return profile_theta(offset_fit, *line_data, n_points=7, max_iter=150, objective=True)


def test_a_parameter_the_network_absorbs_exactly_is_not_identified(offset_profile, offset_fit):
    """b trades exactly with the network's constant: flat. a is pinned, and its interval is the
    F-test interval of least squares (the network's constant stands in for b)."""
    prof = offset_profile
    assert prof.verdicts["b"] == STRUCTURAL
    assert prof.intervals["b"] == (-np.inf, np.inf)
    assert np.ptp(prof.loss["b"]) < prof.threshold - prof.best_loss
    assert prof.verdicts["a"] == IDENTIFIED
    low, high = prof.intervals["a"]
    assert low < offset_fit.theta_["a"] < high
    assert "NOT IDENTIFIED" in prof.verdict_text("b") and "close_the_loop" in prof.report()


def test_the_identified_interval_is_the_least_squares_profile_interval(offset_profile, line_data):
    from scipy import stats

    X, y = line_data
    n = len(y)
    A = np.column_stack([X[:, 0], np.ones(n)])
    coef, rss, *_ = np.linalg.lstsq(A, y, rcond=None)
    # J(a) = min_b mean (y - a x - b)^2 is a parabola: J_min + (a - a_hat)^2 * Sxx / n
    sxx = np.sum((X[:, 0] - X[:, 0].mean()) ** 2)
    dof = n - 2  # a and b are the free parameters the F-test counts
    threshold = rss[0] / n * (1 + stats.f.ppf(0.95, 1, dof) / dof)
    half = np.sqrt((threshold - rss[0] / n) * n / sxx)
    low, high = offset_profile.intervals["a"]
    # the grid is linear between points: a parabola's crossing is found to within its curvature
    assert low == pytest.approx(coef[0] - half, abs=0.02)
    assert high == pytest.approx(coef[0] + half, abs=0.02)
    assert offset_profile.threshold == pytest.approx(threshold, rel=1e-3)


def test_report_prints_the_verdict_and_no_interval_without_a_profile(offset_fit, offset_profile):
    plain = offset_fit.fit_report()
    assert "interval [" not in plain and "identified," not in plain  # no interval, no verdict without a profile
    assert "noise-only standard error" in plain and "profile_theta" in plain
    # the free first screen: the network's share, and where to go next
    assert f"the network makes {offset_fit.network_share_:.1%} of the prediction" in plain
    assert "close_the_loop(est, X, y)" in plain
    report = offset_fit.fit_report(profile=offset_profile)
    a_line = next(line for line in report.splitlines() if line.strip().startswith("a:"))
    b_line = next(line for line in report.splitlines() if line.strip().startswith("b:"))
    assert "identified, 95 % interval" in a_line and "NOT IDENTIFIED" in b_line
    with pytest.raises(TypeError, match="ThetaProfile"):
        offset_fit.fit_report(profile={"a": (1, 2)})


def test_plot_profile(offset_profile):
    axes = plot_profile(offset_profile)
    assert len(axes) == 2 and axes[0].get_xlabel() == "a"
    assert isinstance(offset_profile, ThetaProfile) and len(offset_profile.plot()) == 2


def test_bad_input(offset_fit, line_data):
    X, y = line_data
    with pytest.raises(ValueError, match="Unknown parameter 'c'.*'a', 'b'"):
        profile_theta(offset_fit, X, y, params=["c"])
    with pytest.raises(ValueError, match="outside the bounds"):
        bounded = clone(offset_fit).set_params(theta_bounds={"a": (0, 3)}, max_iter=2).fit(X, y)
        profile_theta(bounded, X, y, grid={"a": [1.0, 3.5]})
    with pytest.raises(ValueError, match="'b' is fixed"):
        fixed = clone(offset_fit).set_params(theta_fixed=["b"], max_iter=2).fit(X, y)
        profile_theta(fixed, X, y, params="b")
    for level in (0, 1, 1.5, "95%"):
        with pytest.raises(ValueError, match="level must be a number in"):
            profile_theta(offset_fit, X, y, level=level)
    with pytest.raises(NotFittedError):
        profile_theta(clone(offset_fit), X, y)
    with pytest.raises(ValueError, match="the model predicts"):
        profile_theta(offset_fit, X, y[:, None, None].repeat(2, axis=1))
    with pytest.raises(ValueError, match="f-reg"):
        freg = HybridRegressor(science=line_f, structure="additive", method="f-reg", max_iter=2,
                               residual={"hidden": (4,)}).fit(X, y)
        profile_theta(freg, X, y)
    with pytest.raises(ValueError, match="models without a network"):
        science_intervals(offset_fit, X, y)


def test_profile_leaves_the_fit_alone(offset_fit, line_data):
    before = {k: p.detach().clone() for k, p in offset_fit.model_.named_parameters()}
    X, y = line_data
    X0, y0 = X.copy(), y.copy()
    profile_theta(offset_fit, X, y, params="a", n_points=3, max_iter=5)
    for k, p in offset_fit.model_.named_parameters():
        assert torch.equal(p, before[k])
    np.testing.assert_array_equal(X, X0)
    np.testing.assert_array_equal(y, y0)


def test_bootstrap_member_is_a_weighted_fit_with_its_seed(line_data):
    """A member of the stacked bootstrap takes the steps of a separate fit on its resample."""
    X, y = line_data
    est = HybridRegressor(science=line_f, structure="additive", residual={"hidden": (8,)}, method="fsam",
                          max_iter=20, tol=None, dtype="float64", random_state=0).fit(X, y)
    boot = bootstrap_theta(est, X, y, n_resamples=3, random_state=7)
    # the draw the bootstrap reports is the one it made: 3 resamples of len(y) samples, integer counts
    assert len(boot.seeds) == 3 and boot.weights.shape == (3, len(y)) and np.all(boot.weights.sum(1) == len(y))
    alone = clone(est).set_params(random_state=boot.seeds[1]).fit(X, y, sample_weight=boot.weights[1])
    assert boot.samples["a"][1] == pytest.approx(alone.theta_["a"], rel=1e-9)
    assert np.ptp(boot.samples["a"]) > 0
    low, high = boot.intervals["a"]
    assert low < est.theta_["a"] < high and "3 fits on resampled samples" in boot.report()


def test_science_intervals_are_cluster_robust(line_data):
    """Errors shared by the values of one sample: the interval counts samples, not values."""
    rng = np.random.default_rng(3)
    n, m = 30, 8
    x = rng.uniform(-1, 1, (n, m))
    y = 2.0 * x + 0.5 + 0.3 * rng.normal(size=(n, 1)) + 0.05 * rng.normal(size=(n, m))

    def line_m(x, a=1.0, b=0.0):
        return a * x + b

    est = HybridRegressor(science=line_m, structure="additive", residual=ZeroResidual(), method="erm", lr=5e-2,
                          max_iter=600, tol=None, dtype="float64", random_state=0).fit(x, y)
    ci = science_intervals(est, x, y)
    A = np.column_stack([x.ravel(), np.ones(n * m)])
    coef = np.linalg.lstsq(A, y.ravel(), rcond=None)[0]
    assert est.theta_["a"] == pytest.approx(coef[0], abs=1e-4)
    r = (y.ravel() - A @ coef).reshape(n, m)
    bread = np.linalg.inv(A.T @ A)
    scores = np.stack([A.reshape(n, m, 2)[i].T @ r[i] for i in range(n)])
    cov = n / (n - 2) * bread @ scores.T @ scores @ bread
    assert ci.std["b"] == pytest.approx(np.sqrt(cov[1, 1]), rel=1e-3)
    assert ci.std["b"] > 2 * est.theta_std_["b"]  # the Gauss-Newton error counts every value as independent
    assert ci.verdicts == {"a": "identified", "b": "identified"}
    assert ci.intervals["b"][0] < 0.5 < ci.intervals["b"][1]


def test_profile_on_a_dask_cluster_matches_local(offset_fit, line_data):
    X, y = line_data
    local = profile_theta(offset_fit, X, y, params="a", n_points=3, max_iter=10)
    two = profile_theta(offset_fit, X, y, params="a", n_points=3, max_iter=10, n_jobs=2)
    with distributed.LocalCluster(n_workers=1, threads_per_worker=2, processes=False,
                                  dashboard_address=None) as cluster, distributed.Client(cluster):
        with joblib.parallel_backend("dask"):
            remote = profile_theta(offset_fit, X, y, params="a", n_points=3, max_iter=10, n_jobs=2)
    for other in (two, remote):
        np.testing.assert_allclose(other.loss["a"], local.loss["a"], rtol=1e-10)
        assert other.intervals == local.intervals


def test_science_intervals_differentiate_an_ode_in_one_vectorised_simulation(monkeypatch):
    """The central differences of a network-free ODE model run as one batched simulation (a long record
    integrates every step per simulation), with the intervals of one simulation per step."""
    rng = np.random.default_rng(0)
    X = rng.uniform(-1, 1, (12, 2))
    y = np.stack([X * np.cos(0.3 * t) for t in range(1, 9)], 1) + 0.01 * rng.normal(size=(12, 8, 2))

    def spring(v, k=1.0, c=0.1):
        return torch.stack([v[:, 1], -k * v[:, 0] - c * v[:, 1]], -1)

    est = HybridRegressor(science=spring, dt=0.3, residual=ZeroResidual(), method="erm", max_iter=20,
                          random_state=0, verbose=False).fit(X, y)
    calls = []
    hook = est.model_.register_forward_pre_hook(lambda module, args: calls.append(1))
    batched = science_intervals(est, X, y)
    vectorised_calls = len(calls)
    monkeypatch.setattr(torch.func, "vmap", lambda *a, **k: 1 / 0)  # the fallback: one simulation per step
    calls.clear()
    one_by_one = science_intervals(est, X, y)
    hook.remove()
    assert vectorised_calls == 2 and len(calls) == 1 + 2 * 2  # the base and one batch; one per step without
    for name in ("k", "c"):
        assert batched.std[name] == pytest.approx(one_by_one.std[name], rel=1e-9)
        assert batched.intervals[name] == pytest.approx(one_by_one.intervals[name], rel=1e-9)


def test_science_intervals_of_a_possibly_incomplete_model_are_not_backed(line_data):
    X, y = line_data
    est = HybridRegressor(science=line_f, structure="additive", residual=ZeroResidual(), method="erm", lr=5e-2,
                          max_iter=300, tol=None, dtype="float64", random_state=0).fit(X, y)
    complete = science_intervals(est, X, y)
    assert set(complete.verdicts.values()) == {"identified"}
    ci = science_intervals(est, X, y, incomplete="a candidate gained 40 % at z 1.7")
    assert set(ci.verdicts.values()) == {"not identified"}
    assert ci.intervals["a"] == (-np.inf, np.inf) and ci.std == complete.std
    assert "may be incomplete" in ci.report() and "40 %" in ci.report()


def test_the_objective_profile_trains_members_with_the_fit_s_method(line_data):
    """The plain profile's members minimise the loss alone; the objective's, p-reg's loss plus
    penalty, which the plain loss can only undercut."""
    X, y = line_data
    est = HybridRegressor(science=line_f, structure="additive", residual={"hidden": (8,)}, method=ParameterRegularization(lam=1e-2),
                          max_iter=40, tol=None, dtype="float64", random_state=0).fit(X, y)
    prof = profile_theta(est, X, y, params="a", n_points=3, max_iter=20, refine=False, objective=True)
    assert len(prof.objective["a"]) == len(prof.values["a"])
    assert np.all(prof.objective["a"] > prof.loss["a"])
    assert prof.objective_minimum["a"] in prof.values["a"] and "p-reg objective is lowest" in prof.report()
    assert profile_theta(est, X, y, params="a", n_points=3, max_iter=2, refine=False).objective == {}


def chain_f(v, k1=0.5, k2=0.5):
    """A -> B -> out, first order; only B is measured."""
    return torch.stack([-k1 * v[:, 0], k1 * v[:, 0] - k2 * v[:, 1]], dim=-1)


def test_science_intervals_count_the_fitted_initial_states():
    """Unmeasured initial states fitted per sample are parameters too: the interval is the theta block
    of the sandwich over theta and every sample's state, computed here from predictions alone."""
    from scipy.integrate import solve_ivp

    from sklearn_hybrid.diagnosis.science_fit import ScienceFit

    rng = np.random.default_rng(4)
    n, steps, dt = 25, 12, 0.2
    x0 = np.column_stack([rng.uniform(0.5, 1.5, n), rng.uniform(0.0, 0.5, n)])
    t = dt * np.arange(1, steps + 1)
    truth = np.stack([solve_ivp(lambda _, v: [-0.8 * v[0], 0.8 * v[0] - 0.3 * v[1]], (0, t[-1]), s, t_eval=t,
                                rtol=1e-10, atol=1e-12).y.T for s in x0])
    y = truth[..., 1:] + 0.01 * rng.normal(size=(n, steps, 1))
    X = np.column_stack([np.ones(n), x0[:, 1]])  # A0 unknown: a guess
    settings = dict(science=chain_f, dt=dt, observed=[1], residual=ZeroResidual(), method="erm", max_iter=1,
                    dtype="float64", n_substeps=4)
    fit = ScienceFit(HybridRegressor(**settings).fit(X, y), X, y, fit_initial_states=True)
    theta = fit.fit(chain_f, {"k1": 0.5, "k2": 0.5})
    X_fit = X.copy()
    X_fit[:, 0] = fit.initial_states[:, 0]
    est = HybridRegressor(**settings, theta_init=theta, theta_fixed=["k1", "k2"]).fit(X_fit, y)
    naive = science_intervals(est, X_fit, y)
    ci = science_intervals(est, X_fit, y, fitted_states=[0])
    X_given = X_fit.copy()

    def pred(theta_, X_):
        return HybridRegressor(**settings, theta_init=theta_, theta_fixed=["k1", "k2"]).fit(X_, y).predict(
            X_).reshape(n, -1)

    base, h = pred(theta, X_fit), 1e-6
    J = np.stack([(pred({**theta, k: theta[k] + h}, X_fit) - pred({**theta, k: theta[k] - h}, X_fit)) / (2 * h)
                  for k in ("k1", "k2")], axis=-1)
    up, down = X_fit.copy(), X_fit.copy()
    up[:, 0] += h
    down[:, 0] -= h
    K = (pred(theta, up) - pred(theta, down)) / (2 * h)  # sample i's own state moves only its own row
    full = np.zeros((n, steps, 2 + n))
    full[..., :2] = J
    full[np.arange(n), :, 2 + np.arange(n)] = K
    r = y.reshape(n, -1) - base
    A = np.einsum("imp,imq->pq", full, full)
    scores = np.einsum("imp,im->ip", full, r)
    bread = np.linalg.inv(A)
    cov = n / (n - 2) * bread @ scores.T @ scores @ bread
    for j, k in enumerate(("k1", "k2")):
        assert ci.std[k] == pytest.approx(np.sqrt(cov[j, j]), rel=1e-3)
    assert ci.std["k1"] > 1.5 * naive.std["k1"]  # the unmeasured start trades with k1
    assert ci.intervals["k1"][0] < 0.8 < ci.intervals["k1"][1]
    np.testing.assert_array_equal(X_fit, X_given)
    with pytest.raises(ValueError, match="distinct state components"):
        science_intervals(est, X_fit, y, fitted_states=[2])



def _singular_rate_f(v, k=0.9):
    """A decay whose rate k / (1.5 - k) is infinite at k = 1.5: a profile member held there diverges."""
    return -k / (1.5 - k) * v


def test_a_diverged_profile_member_is_left_out_and_named():
    """A member whose training diverged says nothing of how well the data fit at its value: the profile
    leaves it out and says so, instead of reading it as a crossing of the threshold."""
    rng = np.random.default_rng(0)
    X = rng.uniform(0.5, 1.5, (20, 1))
    y = (X[:, None, :] * np.exp(-2.0 * 0.1 * np.arange(1, 6))[None, :, None]
         * (1 + 0.01 * rng.normal(size=(20, 5, 1))))  # the rate is 2 at k = 1
    est = HybridRegressor(science=_singular_rate_f, dt=0.1, method="erm", max_iter=60, residual={"hidden": (8,)},
                          random_state=0).fit(X, y)
    profile = profile_theta(est, X, y, grid={"k": [0.7, 0.85, 1.0, 1.15, 1.5]}, refine=False)
    assert profile.dropped == {"k": [1.5]}
    assert 1.5 not in profile.values["k"] and np.all(np.isfinite(profile.loss["k"]))
    assert "1 value(s) left out, their training diverged: k at [1.5]" in profile.report()
    # members stop together once each has settled, within the fit's own budget
    assert profile.n_iter <= est.n_iter_


def test_an_interval_that_leaves_out_the_estimate_is_not_called_identified():
    """A fit stopped after 5 iterations, far from its optimum: the profile's members train on from it and
    find a sharp minimum away from the estimate. That interval is no interval of the fit's theta (the
    time-to-answer benchmark once called such a profile identified): the verdict is NOT SETTLED."""
    from sklearn_hybrid.datasets import make_pendulum
    from sklearn_hybrid.demo import pendulum_f

    d = make_pendulum(8, 2, 2, random_state=0)
    est = HybridRegressor(science=pendulum_f, dt=d.dt, residual=ZeroResidual(), method="erm", max_iter=5, tol=None,
                          random_state=0, verbose=False).fit(d.X_train, d.y_train)
    profile = profile_theta(est, d.X_train, d.y_train, max_iter=150, refine=False, verbose=False)
    low, high = profile.intervals["omega"]
    assert not low <= est.theta_["omega"] <= high and low <= d.theta_true["omega"] <= high
    assert profile.verdicts["omega"] == UNSETTLED
    assert "NOT SETTLED" in profile.report() and "larger max_iter" in profile.report()


def _even_f(x, a=1.9, b=0.0):
    return torch.cos(a * x[:, 0]) + b


def test_the_interval_spans_every_value_under_the_threshold():
    """cos(a x) fits as well at -a as at a: the profile falls back under the threshold beyond its first
    crossing. The confidence set is both regions, so the interval spans them, not only the one around the
    minimum (the uncertainty benchmark's noisy profiles were cut at a first crossing and missed the truth);
    where the profile is back under the threshold at the end of the range, that side is open."""
    rng = np.random.default_rng(0)
    X = rng.uniform(-2, 2, (40, 1))
    y = np.cos(2.0 * X[:, 0]) + 0.1 + 0.05 * rng.normal(size=40)
    est = HybridRegressor(science=_even_f, structure="additive", residual=ZeroResidual(), method="erm", lr=1e-2,
                          max_iter=300, dtype="float64", random_state=0, verbose=False).fit(X, y)
    assert est.theta_["a"] == pytest.approx(2.0, abs=0.05)
    both = profile_theta(est, X, y, params="a", grid={"a": [-2.6, -2.0, -1.4, 0.0, 1.4, 2.6]}, refine=False,
                         verbose=False)
    low, high = both.intervals["a"]
    assert both.verdicts["a"] == IDENTIFIED and -2.6 < low < -2.0 and 2.0 < high < 2.6
    open_low = profile_theta(est, X, y, params="a", grid={"a": [-2.0, -1.4, 0.0, 1.4, 2.6]}, refine=False,
                             verbose=False)
    assert open_low.verdicts["a"] == PRACTICAL and open_low.intervals["a"][0] == -np.inf


def _line_m(x, a=1.0, b=0.0):
    return a * x + b


@pytest.mark.parametrize("n", [1, 3])
def test_science_intervals_with_too_few_samples_give_no_cluster_robust_interval(n):
    """Issue 63: one trajectory is one cluster; at the least-squares fit its score is zero, so the
    cluster-robust error was zero too (omega 0.657334 +/- 1.12e-07, the truth 2/3 far outside). Fewer than
    p + 2 samples (two parameters here: 4) give no interval, and the report says why."""
    rng = np.random.default_rng(0)
    x = rng.uniform(-1, 1, (n, 8))
    y = 2.0 * x + 0.5 + 0.3 * rng.normal(size=(n, 1)) + 0.05 * rng.normal(size=(n, 8))
    est = HybridRegressor(science=_line_m, structure="additive", residual=ZeroResidual(), method="erm", lr=5e-2,
                          max_iter=300, tol=None, dtype="float64", random_state=0, verbose=False).fit(x, y)
    ci = science_intervals(est, x, y)
    assert set(ci.verdicts.values()) == {"not available"}
    assert all(ci.intervals[k] == (-np.inf, np.inf) for k in ("a", "b"))
    report = ci.report()
    assert "NO INTERVAL" in report and f"{n} sample(s)" in report and "at least 4" in report
    assert "+/-" not in report


def _root_m(x, a=1.0):
    return a * torch.sqrt(x)


def test_science_intervals_blame_a_model_that_is_not_finite_not_the_data():
    """Issue 63: a science function that returns NaN at the fitted theta on the data made every standard error
    NaN and the verdict 'NOT IDENTIFIED by these data': the data were blamed for the model's failure."""
    rng = np.random.default_rng(0)
    x = rng.uniform(0.1, 1, (20, 4))
    y = 2.0 * np.sqrt(x) + 0.05 * rng.normal(size=(20, 4))
    est = HybridRegressor(science=_root_m, structure="additive", residual=ZeroResidual(), method="erm", lr=5e-2,
                          max_iter=200, tol=None, dtype="float64", random_state=0, verbose=False).fit(x, y)
    x_bad = x.copy()
    x_bad[3, 1] = -0.5
    with pytest.raises(ValueError, match=r"predictions are not finite.*'_root_m'.*sample 3.*'a'"):
        science_intervals(est, x_bad, y)


def _product_f(x, a=1.5, b=1.0):
    """a and b enter only as their product: the data pin a * b, never a or b."""
    return a * b * x[:, 0]


@pytest.mark.parametrize("max_iter", [10, 40])
def test_parameters_that_enter_only_as_a_product_are_never_called_identified(max_iter):
    """Issue 63: each member holds one factor and must move the other a long way to compensate. Within a
    short budget it cannot, and its loss, still falling, read as a crossing: both came out identified
    (a: [1.63, 2.19], b: [1.12, 1.40] at 10 iterations, while a * b = 2 fits as well at a = 1). A crossing
    backed by a member that had not settled is no crossing: the verdict is not settled, never identified."""
    rng = np.random.default_rng(0)
    X = rng.uniform(-1, 1, (40, 1))
    y = 2.0 * X[:, 0] + 0.1 * rng.normal(size=40)
    est = HybridRegressor(science=_product_f, structure="additive", residual=ZeroResidual(), method="erm", lr=5e-2,
                          max_iter=300, dtype="float64", random_state=0, verbose=False).fit(X, y)
    profile = profile_theta(est, X, y, max_iter=max_iter, verbose=False)
    for label in ("a", "b"):
        low, high = profile.intervals[label]
        assert low <= high
        assert profile.verdicts[label] != IDENTIFIED
    assert "still falling when their training ended" in profile.report()


def test_a_profile_whose_members_all_lie_over_the_threshold_gives_no_reversed_interval():
    """Issue 63: the threshold comes from the best member of any profile; one whose own members all lie over
    it was extrapolated backwards on both sides, e.g. a: (1.21725, 0.96132)."""
    from sklearn_hybrid.identifiability._interval import read_interval

    values = np.array([0.8, 1.0, 1.2, 1.4])
    (low, high), verdict, _ = read_interval(values, np.array([3.0, 1.5, 1.2, 2.0]), threshold=1.0)
    assert low <= high and verdict != IDENTIFIED


def test_the_profile_plot_draws_what_it_leaves_out(offset_profile):
    """Issue 63: the plot silently left out the values whose members diverged (near the truth, in a new
    user's SIRS), and its title gave a verdict over a curve with gaps. Diverged values are drawn as dashed
    lines and crossings by members still falling as triangles, each counted in the title."""
    import copy

    label = next(iter(offset_profile.verdicts))
    values = offset_profile.values[label]
    profile = copy.deepcopy(offset_profile)
    profile.dropped = {label: [float(values[1])]}
    profile.unsettled = {label: [float(values[-1])]}
    ax = plot_profile(profile)[list(profile.verdicts).index(label)]
    assert "1 value(s) diverged" in ax.get_title() and "no bound backed" in ax.get_title()
    assert any(line.get_label() == "member diverged (no loss)" for line in ax.get_lines())
    assert any(line.get_label() == "member still falling" for line in ax.get_lines())
    plain = plot_profile(offset_profile)[0]
    assert "(" not in plain.get_title()


def _domain_f(v, omega=0.7):
    return torch.stack([v[..., 1], -omega ** 2 * torch.sin(v[..., 0]) + 0 * torch.log(omega - 0.62)], dim=-1)


def test_a_profile_outside_the_sciences_domain_says_so_not_lower_lr():
    """Audit (issue 63): members held where the science is NaN were dropped with the advice of a lower lr; their
    loss is not finite before any step, which the error now says (and points to the span)."""
    from sklearn_hybrid.datasets import make_pendulum

    d = make_pendulum(8, 2, 2, dt=0.2, n_steps=5, random_state=0)
    est = HybridRegressor(science=_domain_f, method="erm", dt=0.2, max_iter=30, residual={"hidden": (8,)},
                          random_state=0).fit(d.X_train, d.y_train)
    with pytest.raises(DivergenceError, match=r"at \{'omega': \[0.3, 0.4, 0.5\]\} the model's loss is not finite "
                                              r"before the first training step.*a lower lr cannot help"):
        profile_theta(est, d.X_train, d.y_train, grid={"omega": [0.3, 0.4, 0.5, 0.7]}, max_iter=10, refine=False)
