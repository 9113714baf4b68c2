"""plot_fit: what it draws is the data, the hybrid's prediction and the science part alone."""

import sys
import matplotlib
import numpy as np
import pytest
import torch

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

import sklearn_hybrid  # noqa: E402
from sklearn_hybrid import HybridRegressor, plot_fit  # noqa: E402
from sklearn_hybrid.plotting import plot_profile  # noqa: E402

FAST = dict(max_iter=20, residual={"hidden": (8, 8)}, random_state=0, verbose=False)


def leak_f(v, k=0.3):  # two tanks in series; the second one's own leak is what the network learns
    return torch.stack([-k * v[:, 0], k * v[:, 0]], dim=-1)


def tanks_data(n=6, steps=7, dt=0.5):
    rng = np.random.default_rng(1)
    X = rng.uniform(0.5, 2.0, size=(n, 2))
    out, v = [], X.copy()
    for _ in range(steps):
        for _ in range(20):  # Euler with a fine step is enough for a smooth, slow system
            v = v + dt / 20 * np.stack([-0.4 * v[:, 0], 0.4 * v[:, 0] - 0.2 * v[:, 1]], -1)
        out.append(v)
    return X, np.stack(out, axis=1)


@pytest.fixture(scope="module")
def fitted():
    X, y = tanks_data()
    return HybridRegressor(science=leak_f, dt=0.5, **FAST).fit(X, y), X, y


def lines_of(ax):
    return {line.get_label(): line for line in ax.get_lines()}


def test_plot_fit_draws_data_fit_and_science_part_per_component(fitted):
    est, X, y = fitted
    fig = plot_fit(est, X, y, samples=[1, 4], names=["h1", "h2"])
    try:
        assert len(fig.axes) == 4  # residuals above, fit below, for each of the two components
        main = fig.axes[3]  # the second component's fit panel
        assert main.get_ylabel() == "h2" and main.get_xlabel() == "time"
        # the first sample drawn is sample 1: its data, prediction and science-only run, at t = dt .. 7 dt
        drawn = lines_of(fig.axes[1])
        np.testing.assert_allclose(drawn["data"].get_xdata(), 0.5 * np.arange(1, 8))
        np.testing.assert_allclose(drawn["data"].get_ydata(), y[1, :, 0])
        np.testing.assert_allclose(drawn["hybrid fit"].get_ydata(), est.predict(X)[1, :, 0], rtol=1e-6)
        np.testing.assert_allclose(drawn["science part alone"].get_ydata(), est.predict_science(X)[1, :, 0],
                                   rtol=1e-6)
        # the residual panel holds data minus fit, one line per sample
        residual = [r for r in fig.axes[0].get_lines() if len(r.get_xdata()) == 7]  # not the zero line
        assert len(residual) == 2
        np.testing.assert_allclose(residual[-1].get_ydata(), y[4, :, 0] - est.predict(X)[4, :, 0], rtol=1e-5)
        share = np.sqrt(np.mean((est.predict(X) - est.predict_science(X)) ** 2) / np.mean(est.predict(X) ** 2))
        assert f"{share:.1%}" in fig._suptitle.get_text()
    finally:
        plt.close(fig)


def test_plot_fit_of_a_regression_is_a_parity_plot():
    def line_f(x, a=1.0):
        return a * x

    rng = np.random.default_rng(0)
    X = rng.uniform(-1, 1, size=(20, 1))
    y = 2 * X + 0.3 * X ** 2
    est = HybridRegressor(science=line_f, structure="additive", **FAST).fit(X, y)
    fig = plot_fit(est, X, y, samples=20)
    try:
        assert len(fig.axes) == 2
        drawn = lines_of(fig.axes[1])
        np.testing.assert_allclose(drawn["hybrid fit"].get_xdata(), y.ravel())
        np.testing.assert_allclose(drawn["hybrid fit"].get_ydata(), est.predict(X).ravel(), rtol=1e-6)
        assert fig.axes[1].get_xlabel() == "measured y[0]"
    finally:
        plt.close(fig)


def test_plot_fit_refuses_what_it_cannot_draw(fitted):
    est, X, y = fitted
    with pytest.raises(ValueError, match="samples"):
        plot_fit(est, X, y, samples=[6])
    with pytest.raises(ValueError, match="components"):
        plot_fit(est, X, y, components=[2])
    with pytest.raises(ValueError, match="names"):
        plot_fit(est, X, y, names=["h1"])
    from sklearn.exceptions import NotFittedError

    with pytest.raises(NotFittedError):
        plot_fit(HybridRegressor(science=leak_f), X, y)


def test_plot_fit_says_how_to_get_matplotlib(fitted, monkeypatch):
    import builtins

    real_import = builtins.__import__

    def no_matplotlib(name, *args, **kwargs):
        if name.startswith("matplotlib"):
            raise ImportError("No module named 'matplotlib'")
        return real_import(name, *args, **kwargs)

    monkeypatch.setattr(builtins, "__import__", no_matplotlib)
    est, X, y = fitted
    with pytest.raises(ImportError, match=r"sklearn_hybrid\[plot\]"):
        plot_fit(est, X, y)


def test_plots_are_found_at_the_top_and_in_plotting():
    assert "plot_fit" in sklearn_hybrid.__all__ and sklearn_hybrid.plot_fit is plot_fit
    from sklearn_hybrid.identifiability import plot_profile as original

    assert plot_profile.__doc__ and callable(original)


def test_a_plot_without_matplotlib_names_itself_and_the_extra(fitted, monkeypatch):
    monkeypatch.setitem(sys.modules, "matplotlib.pyplot", None)  # import matplotlib.pyplot now fails
    extra = r"needs matplotlib: pip install 'sklearn_hybrid\[plot\]'"
    with pytest.raises(ImportError, match="plot_fit " + extra):
        plot_fit(*fitted)
    with pytest.raises(ImportError, match="plot_profile " + extra):
        plot_profile(None)
