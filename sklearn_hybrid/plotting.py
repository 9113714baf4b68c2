"""Plots of a hybrid fit, in the style of lmfit's ``ModelResult.plot``.

- :func:`plot_fit`: the data against the hybrid's prediction and the science
  part alone, with the network's share between them and the residuals above.
- :func:`plot_profile`: the profiles of theta (also
  :func:`~sklearn_hybrid.identifiability.plot_profile` and ``ThetaProfile.plot``).

matplotlib is optional: ``pip install "sklearn_hybrid[plot]"``.
"""

from __future__ import annotations

import numpy as np

from ._fitting import ode_structure
from .metrics import network_share

__all__ = ["plot_fit", "plot_profile"]


def plot_profile(profile, ax=None):
    """Plot each profile: the data loss (and the method's objective, if profiled) against the parameter.

    The threshold of the interval is drawn as a horizontal line, the fit's
    estimate and the interval as vertical ones; values whose members diverged
    as dashed red lines (their loss is unknown, so the curve has a gap there)
    and crossings made by members still falling as triangles, each counted in
    the title beside the verdict.  Needs matplotlib (the ``plot`` extra).

    Parameters
    ----------
    profile : ThetaProfile
        From :func:`~sklearn_hybrid.identifiability.profile_theta`.
    ax : matplotlib Axes or array of Axes, optional
        One axes per profiled entry (new ones by default).

    Returns
    -------
    array of matplotlib Axes
    """
    plt = _pyplot("plot_profile")
    labels = list(profile.verdicts)
    if ax is None:
        _, ax = plt.subplots(1, len(labels), figsize=(4 * len(labels), 3.2), squeeze=False)
    axes = np.ravel(ax)
    if len(axes) != len(labels):
        raise ValueError(f"ax holds {len(axes)} axes for {len(labels)} profiles.")
    for a, label in zip(axes, labels):
        values = profile.values[label]
        a.plot(values, profile.loss[label], "o-", label="data loss")
        if label in profile.objective:
            a.plot(values, profile.objective[label], "s--", alpha=0.7, label=f"{profile.method} objective")
        a.axhline(profile.threshold, color="grey", lw=1, label=f"{100 * profile.level:.0f} % threshold")
        a.axvline(profile.estimate[label], color="k", lw=1, ls=":", label="fit")
        for side in profile.intervals[label]:
            if np.isfinite(side):
                a.axvline(side, color="C2", lw=1)
        # what the profile leaves out is drawn, not dropped silently: values whose members diverged (their
        # loss is unknown, not high) and crossings made by members still falling (no bound backed there)
        dropped = list(getattr(profile, "dropped", {}).get(label, []))
        for k, v in enumerate(dropped):
            a.axvline(v, color="C3", lw=1, ls="--", label="member diverged (no loss)" if k == 0 else None)
        unsettled = list(getattr(profile, "unsettled", {}).get(label, []))
        if unsettled:
            at = np.interp(unsettled, values, profile.loss[label])
            a.plot(unsettled, at, "^", color="C1", ms=8, label="member still falling")
        notes = ([f"{len(dropped)} value(s) diverged"] if dropped else []) + (["no bound backed"] if unsettled else [])
        a.set_xlabel(label)
        a.set_title(profile.verdicts[label] + (f" ({'; '.join(notes)})" if notes else ""), fontsize=9)
    axes[0].set_ylabel("mean squared error")
    axes[0].legend(fontsize=7)
    return axes


def _pyplot(caller: str):
    try:
        import matplotlib.pyplot as plt
    except ImportError as error:  # an optional dependency
        raise ImportError(f"{caller} needs matplotlib: pip install 'sklearn_hybrid[plot]'.") from error
    return plt


def plot_fit(estimator, X, y, *, samples=3, components=None, names=None, fig=None):
    """Plot a fitted hybrid model against the data: the fit, the science part alone, the network's share.

    For an ODE (``structure="ode"``) each observed component gets a column:
    below, the measured trajectories of a few samples (points), the hybrid's
    prediction (solid line) and the science part integrated alone with the
    fitted theta (dashed), the band between the two shaded as the network's
    share; above, the residuals (data minus hybrid), as in lmfit's
    ``ModelResult.plot``.  Other structures get the same two panels as a
    parity plot (predicted against measured, every output value).

    Parameters
    ----------
    estimator : HybridRegressor
        A fitted estimator.
    X, y : array-like
        Inputs and targets, shaped as in ``fit`` (training or test data).
    samples : int or sequence of int, default=3
        How many samples to draw (the first ones), or which.
    components : sequence of int, optional
        Which observed components to draw (default: all, at most 4).
    names : sequence of str, optional
        A name per observed component, for the axis labels.
    fig : matplotlib Figure, optional
        Where to draw; a new figure otherwise.

    Returns
    -------
    matplotlib Figure
        With one column of two axes (residuals above, fit below) per component.
    """
    from sklearn.utils.validation import check_is_fitted

    from ._validation import check_target_layout

    check_is_fitted(estimator)
    plt = _pyplot("plot_fit")
    X = np.asarray(X)
    idx = np.arange(min(int(samples), len(X))) if np.isscalar(samples) else np.asarray(samples, dtype=int)
    if idx.size == 0 or idx.min() < 0 or idx.max() >= len(X):
        raise ValueError(f"samples must pick at least one of the {len(X)} samples, got {samples!r}.")
    hybrid = estimator.predict(X)
    science = estimator.predict_science(X)
    # as score reads it: flattened per sample is accepted, another layout or sample count is refused
    # (a reshape would draw a transposed y as data)
    y = check_target_layout(y, hybrid)
    ode = ode_structure(estimator)
    trajectories = ode is not None and hybrid.ndim in (2, 3)
    if trajectories and hybrid.ndim == 2:  # one observed component: (n, n_steps)
        hybrid, science, y = hybrid[..., None], science[..., None], y[..., None]
    if not trajectories:
        hybrid, science, y = (a.reshape(len(a), -1) for a in (hybrid, science, y))
    n_out = hybrid.shape[-1]
    if components is None:
        components = list(range(min(n_out, 4)))
    components = [int(c) for c in components]
    if not components or min(components) < 0 or max(components) >= n_out:
        raise ValueError(f"components must be indices of the {n_out} outputs, got {components!r}.")
    if names is None:
        names = [f"y[{c}]" for c in range(n_out)]
    elif len(names) != n_out:
        raise ValueError(f"names gives {len(names)} names for {n_out} outputs.")
    if fig is None:
        fig = plt.figure(figsize=(4.2 * len(components), 4.6), constrained_layout=True)
    grid = fig.add_gridspec(2, len(components), height_ratios=(1, 3))
    for col, c in enumerate(components):
        top = fig.add_subplot(grid[0, col])
        main = fig.add_subplot(grid[1, col], sharex=top)
        if trajectories:
            dt = estimator.model_.structure.dt  # the fit's, whatever set_params says since
            _trajectories(top, main, dt, y[idx, :, c], hybrid[idx, :, c], science[idx, :, c])
            main.set_xlabel("time")
        else:
            _parity(top, main, y[idx][:, c], hybrid[idx][:, c], science[idx][:, c])
            main.set_xlabel(f"measured {names[c]}")
        main.set_ylabel(names[c])
        top.set_ylabel("data - fit")
        top.axhline(0, color="grey", lw=0.8)
        top.tick_params(labelbottom=False)
        if col == 0:
            main.legend(fontsize=7, loc="best")
    # the network's share of the prediction, over every sample given: how much of the fit is not science
    share = network_share(hybrid, science)
    fig.suptitle(f"{type(estimator).__name__}: the network's share of the prediction, RMS {share:.1%}",
                 fontsize=10)
    return fig


def _trajectories(top, main, dt, data, hybrid, science):
    """Data points, hybrid line, science-only dashes and the band between them, per sample."""
    t = dt * np.arange(1, data.shape[1] + 1)
    for k in range(len(data)):
        color = f"C{k % 10}"
        first = k == 0  # one legend entry per kind of line
        main.plot(t, data[k], "o", ms=3, color=color, label="data" if first else None)
        main.plot(t, hybrid[k], "-", color=color, label="hybrid fit" if first else None)
        main.plot(t, science[k], "--", color=color, lw=1, label="science part alone" if first else None)
        main.fill_between(t, science[k], hybrid[k], color=color, alpha=0.15, lw=0,
                          label="network's share" if first else None)
        top.plot(t, data[k] - hybrid[k], "o", ms=3, color=color)


def _parity(top, main, data, hybrid, science):
    """Predicted against measured; the residuals above."""
    main.plot(data.ravel(), science.ravel(), "x", ms=3, color="C1", alpha=0.6, label="science part alone")
    main.plot(data.ravel(), hybrid.ravel(), "o", ms=3, color="C0", label="hybrid fit")
    low, high = np.nanmin(data), np.nanmax(data)
    main.plot([low, high], [low, high], color="grey", lw=0.8, label="measured = predicted")
    top.plot(data.ravel(), (data - hybrid).ravel(), "o", ms=3, color="C0")
