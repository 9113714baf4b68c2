"""make_windows and estimate_derivative: training data from a user's own recordings."""

import doctest

import numpy as np
import pytest
from scipy.signal import savgol_filter

from sklearn_hybrid import pack_inputs
from sklearn_hybrid.datasets import _windows, estimate_derivative, make_windows


def _record(n=60, seed=0):
    rng = np.random.default_rng(seed)
    return rng.standard_normal(n).cumsum(), rng.standard_normal(n)


def _hand_written(y, u, starts, length):
    """The windowing the closed-loop cases wrote by hand before make_windows."""
    idx = starts[:, None] + np.arange(length + 1)[None]
    return y[idx[:, 1:]], None if u is None else u[idx]


def test_unforced_windows_match_the_hand_written_ones():
    y, _ = _record()
    velocity = estimate_derivative(y, method="central")
    w = make_windows(y, length=5, stride=3, stop=50, states=np.column_stack([y, velocity]))
    starts = np.arange(0, 50 - 5, 3)
    Y, _ = _hand_written(y, None, starts, 5)
    np.testing.assert_array_equal(w.starts, starts)
    np.testing.assert_array_equal(w.y, Y[:, :, None])
    np.testing.assert_array_equal(w.X, np.column_stack([y[starts], velocity[starts]]))
    assert w.u is None
    assert w.starts[-1] + 5 <= 49  # the last target lies before stop


def test_forced_windows_are_packed_as_the_hand_written_ones():
    y, u = _record()
    states = np.column_stack([y, 2 * y])
    w = make_windows(y, u, length=4, stride=2, start=3, stop=len(y) - 4, states=states)
    starts = np.arange(3, len(y) - 4 - 4, 2)
    Y, U = _hand_written(y, u, starts, 4)
    np.testing.assert_array_equal(w.starts, starts)
    np.testing.assert_array_equal(w.y, Y[:, :, None])
    np.testing.assert_array_equal(w.u, U[:, :, None])
    np.testing.assert_array_equal(w.X, pack_inputs(states[starts], U[:, :, None]))
    assert w.X.shape == (len(starts), 2 + 5 * 1)


def test_states_default_to_the_observed_signals_and_channels_are_kept():
    y = np.arange(40.0).reshape(20, 2)
    u = np.ones((20, 3))
    w = make_windows(y, u, length=3)
    assert w.y.shape == (17, 3, 2) and w.u.shape == (17, 4, 3)  # starts 0 .. 16
    np.testing.assert_array_equal(w.X[:, :2], y[:17])
    np.testing.assert_array_equal(w.y[0], y[1:4])
    assert len(make_windows(y, length=19).starts) == 1  # the shortest record for one window


@pytest.mark.parametrize("kwargs, message", [
    ({"length": 0}, "length must be an integer >= 1"),
    ({"length": 2.5}, "length must be an integer"),
    ({"length": 3, "stride": 0}, "stride must be an integer >= 1"),
    ({"length": 3, "start": -1}, "start must be an integer >= 0"),
    ({"length": 3, "stop": 99}, "beyond the end of the record"),
    ({"length": 30}, "too short for one window"),
    ({"length": 3, "start": 18}, "too short for one window"),
    ({"length": 3, "u": np.ones(19)}, "u has 19 samples but y has 20"),
    ({"length": 3, "states": np.ones((21, 2))}, "states has 21 samples but y has 20"),
    ({"length": 3, "u": np.ones((20, 2, 2))}, "u must be a 1-D record or a 2-D array"),
])
def test_make_windows_names_the_problem(kwargs, message):
    kwargs = {"y": np.arange(20.0), **kwargs}
    with pytest.raises(ValueError, match=message):
        make_windows(**kwargs)


def test_nan_is_refused_where_windows_use_it():
    y, u = _record(30)
    y[12] = np.nan
    with pytest.raises(ValueError, match=r"y contains NaN or infinity \(1 samples, the first at sample 12\)"):
        make_windows(y, length=3)
    assert len(make_windows(y, length=3, start=13).starts) == 14  # a gap outside [start, stop) is fine
    u[5] = np.inf
    with pytest.raises(ValueError, match="u contains NaN or infinity"):
        make_windows(np.zeros(30), u, length=3)
    with pytest.raises(ValueError, match="y must be a 1-D record or a 2-D array"):
        make_windows(np.zeros((5, 4, 3)), length=1)


def test_central_derivative_is_the_seven_point_stencil_and_accurate():
    y, _ = _record(40)
    weights = np.array([-1, 9, -45, 0, 45, -9, 1]) / 60.0
    idx = np.arange(3, 37)
    hand = sum(w * y[idx + k - 3] for k, w in enumerate(weights))
    np.testing.assert_array_equal(estimate_derivative(y, method="central")[3:-3], hand)
    t = np.arange(100) * 0.05
    rate = estimate_derivative(np.column_stack([np.sin(t), t**2]), dt=0.05, method="central")
    assert rate.shape == (100, 2)
    np.testing.assert_allclose(rate[:, 0], np.cos(t), atol=2e-3)  # ends: second order
    np.testing.assert_allclose(rate[3:-3, 0], np.cos(t)[3:-3], atol=1e-8)
    np.testing.assert_allclose(rate[:, 1], 2 * t, atol=1e-9)


def test_savgol_derivative_is_scipys_per_time_unit():
    y, _ = _record(50)
    np.testing.assert_allclose(estimate_derivative(y, dt=0.04, window_length=15, polyorder=2),
                               savgol_filter(y, 15, 2, deriv=1) * 25.0, rtol=1e-12, atol=1e-12)
    t = np.linspace(0, 1, 200)
    assert estimate_derivative(np.column_stack([t, t]), dt=t[1]).shape == (200, 2)
    np.testing.assert_allclose(estimate_derivative(3 * t, dt=t[1]), 3.0)


@pytest.mark.parametrize("args, kwargs, message", [
    ((np.r_[1.0, np.nan, 2.0] * np.ones((20, 1)),), {}, "y contains NaN or infinity"),
    ((np.ones(20),), {"dt": 0.0}, "dt must be a positive number"),
    ((np.ones(20),), {"dt": -1.0}, "dt must be a positive number"),
    ((np.ones(20),), {"method": "spline"}, "Unknown method 'spline'"),
    ((np.ones(20),), {"window_length": 14}, "window_length must be odd and larger than polyorder"),
    ((np.ones(20),), {"window_length": 5, "polyorder": 5}, "window_length must be odd and larger"),
    ((np.ones(10),), {}, "needs at least window_length=15 samples; the record has 10"),
    ((np.ones(6),), {"method": "central"}, "needs at least 7 samples; the record has 6"),
    ((np.ones((3, 3, 3)),), {}, "y must be a 1-D record or a 2-D array"),
])
def test_estimate_derivative_names_the_problem(args, kwargs, message):
    with pytest.raises(ValueError, match=message):
        estimate_derivative(*args, **kwargs)


def test_docstring_examples_run():
    assert doctest.testmod(_windows, raise_on_error=False).failed == 0


def test_recipes_live_outside_the_diagnosis_package():
    import importlib

    import sklearn_hybrid.diagnosis as diagnosis
    from sklearn_hybrid import recipes

    from sklearn_hybrid.cli import DATASETS

    assert set(recipes.CASES) == {"silverbox", "tanks", "pendulum-freeswing", "hare-lynx", "pendulum", "duffing"}
    assert set(DATASETS) == set(recipes.CASES)  # the command line offers every recipe
    assert not hasattr(diagnosis, "run_case")
    with pytest.raises(ModuleNotFoundError):
        importlib.import_module("sklearn_hybrid.diagnosis.cases")


def test_freeswing_recipe_takes_window_and_stride(shared_data):
    from sklearn_hybrid import recipes

    default = recipes.pendulum_freeswing_case(data_home=shared_data)
    side_by_side = recipes.pendulum_freeswing_case(data_home=shared_data, stride=50)
    assert len(default.y) == 50 and len(side_by_side.y) == 5  # 3 s of 0.01 s samples, 50-sample windows
    assert side_by_side.y.shape[1:] == default.y.shape[1:] == (50, 1)
    np.testing.assert_array_equal(side_by_side.X, default.X[::10])  # the same windows, every tenth


def test_hare_lynx_recipe_trains_on_one_year_steps_and_scores_the_last_six_years(shared_data):
    from sklearn_hybrid import recipes
    from sklearn_hybrid.datasets import fetch_hare_lynx

    data = fetch_hare_lynx(shared_data)
    counts = np.column_stack([data.hare, data.lynx]) / 10
    case = recipes.hare_lynx_case(data_home=shared_data, fast=True)
    assert case.X.shape == (14, 2) and case.y.shape == (14, 1, 2)  # 1900-1914: 14 steps of a year
    np.testing.assert_array_equal(case.X, counts[:14])
    np.testing.assert_array_equal(case.y[:, 0], counts[1:15])
    out = recipes.run_case("hare-lynx", fast=True, max_iter=5, data_home=shared_data)
    before = out.table[0]
    assert before["stage"] == "before" and np.isfinite(before["test_rmse_thousands"])
    assert before["test_rmse_thousands"] > 0 and set(before["theta"]) == {"a", "b", "c", "d"}
    assert before["test_science_only_rmse_thousands"] > 0 and "Selection" in out.report
