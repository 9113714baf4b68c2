"""The scales a hybrid ODE's data carry: each state's spread, the rate it is observed to change at, the horizon.

A science function is written in the user's units: states as fractions or counts, time in days or milliseconds.
The defaults of a fit (the learning rate, the SAM radius, the network's first steps) are sized for data of order
one; when a fit goes bad, the advice prints these scales, so that a user sees at once whether units far from one
are the cause.
"""

from __future__ import annotations

import numpy as np
import torch
from sklearn.utils import Bunch

__all__ = ["ode_data_scales", "describe_scales", "set_network_scales"]


def _spread(values: torch.Tensor) -> np.ndarray:
    """Per column: the standard deviation, else the mean magnitude, else 1 (a column that never varies)."""
    values = values.detach().to(torch.float64)
    std = values.std(0, unbiased=False).cpu().numpy() if len(values) > 1 else np.zeros(values.shape[1:])
    size = values.abs().mean(0).cpu().numpy()
    finite = np.isfinite(std) & np.isfinite(size)
    return np.where(finite & (std > 0), std, np.where(finite & (size > 0), size, 1.0))


def ode_data_scales(structure, science, inputs: tuple, y: torch.Tensor) -> Bunch | None:
    """Per state: its mean and spread over the data, and the rate it changes at, for a hybrid ODE.

    Parameters
    ----------
    structure : OdeStructure
        Set up on the data (``state_shape``, ``n_steps``, ``observed``, ``dt``).
    science : ScienceModel
        At its starting theta: it gives the rates of the states ``y`` does not observe.
    inputs : tuple of Tensor
        The structure's tensors: initial states, and the inputs on the fine grid of a forced system.
    y : Tensor
        The targets, ``(n, n_steps, n_observed)`` or flattened per sample.

    Returns
    -------
    Bunch or None
        ``in_shift``, ``in_scale`` (one per flattened state entry, then per input channel),
        ``out_scale`` (the rate, one per state entry), ``state_spread``, ``rate`` and ``horizon``;
        None for a state that is not a vector.
    """
    if len(structure.state_shape) != 1:
        return None
    x0 = inputs[0].reshape(len(inputs[0]), -1)
    d = x0.shape[1]
    observed = list(range(d)) if structure.observed is None else list(structure.observed)
    y = y.reshape(len(y), structure.n_steps, len(observed))
    shift, scale = np.empty(d), np.empty(d)
    rate = np.full(d, np.nan)
    for j in range(d):
        if j in observed:
            path = torch.cat([x0[:, j:j + 1], y[..., observed.index(j)]], dim=1)  # (n, n_steps + 1)
            values = path.reshape(-1, 1)
            rate[j] = _spread((path.diff(dim=1) / structure.dt).reshape(-1, 1))[0]
        else:
            values = x0[:, j:j + 1]
        shift[j] = float(values.to(torch.float64).mean())
        scale[j] = _spread(values)[0]
    missing = np.isnan(rate)
    if missing.any():  # a state y does not observe changes at the science's own rate at the start
        with torch.no_grad():
            u0 = None if len(inputs) < 2 else inputs[1][:, 0]
            f0 = science(x0.reshape(len(x0), *structure.state_shape), *(() if u0 is None else (u0,)))
        spread = _spread(f0.reshape(len(x0), -1))
        seen = rate[~missing]
        # a science rate of 0 (nothing known of that state): the others' typical rate, else its own spread per step
        fallback = np.where(np.asarray(spread) == 1.0, np.median(seen) if seen.size else scale / structure.dt, spread)
        rate[missing] = fallback[missing]
    in_shift, in_scale = [shift], [scale]
    if len(inputs) > 1:  # a forced system: its input channels, over the fine grid
        u = inputs[1].reshape(-1, inputs[1].shape[-1])
        in_shift.append(u.to(torch.float64).mean(0).cpu().numpy())
        in_scale.append(_spread(u))
    return Bunch(in_shift=np.concatenate(in_shift), in_scale=np.concatenate(in_scale), out_scale=rate,
                 state_spread=scale, rate=rate, horizon=structure.n_steps * structure.dt)


def describe_scales(scales: Bunch | None) -> str:
    """The data's scales in a sentence, for the advice after a training that went bad."""
    if scales is None:
        return ""
    spread = ", ".join(f"{v:.3g}" for v in scales.state_spread)
    times = scales.horizon * scales.rate / np.maximum(scales.state_spread, np.finfo(float).tiny)
    return (f"The data's scales: state spread {spread}; horizon {scales.horizon:.3g} time units, over which the "
            f"fastest state moves {float(np.max(times)):.3g} times its spread at its observed rate.")
