"""The scales a hybrid's data carry, which the network trains in and the advice prints.

A science function is written in the user's units: states as fractions or counts, time in days or milliseconds.
The network need not be: in an ODE it reads each state standardised (minus its mean, over its spread) and writes
each rate in units of the rate that state is observed to change at; in a static model it reads each input (and,
composed, each science output) standardised and writes each target entry in units of its spread. So its weights,
the learning rate and the SAM radius mean the same in any units.  theta steps relative to its own size (see
:class:`~sklearn_hybrid.science.ScienceModel`).  When a fit goes bad, the advice prints these scales.
"""

from __future__ import annotations

import numpy as np
import torch
from sklearn.utils import Bunch

__all__ = ["ode_data_scales", "static_data_scales", "describe_scales", "set_network_scales", "moments"]


def moments(values: torch.Tensor, weight: torch.Tensor | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Per column: the weighted mean, and the weighted standard deviation, else the mean magnitude, else NaN.

    Parameters
    ----------
    values : Tensor of shape (m, c)
        One column per quantity.
    weight : Tensor of shape (m,), optional
        Each row's weight (a weight of 2 reads as a duplicated row); equal weights by default.

    Returns
    -------
    mean, spread : ndarray of shape (c,)
        ``spread`` is NaN for a column that is zero throughout (it says nothing of its scale), and the mean
        magnitude for a constant one.
    """
    values = values.detach().to(torch.float64)
    w = torch.ones(len(values), dtype=torch.float64, device=values.device) if weight is None else weight
    w = w / w.sum()
    mean = w @ values
    std = (w @ (values - mean).pow(2)).sqrt().cpu().numpy()
    size = (w @ values.abs()).cpu().numpy()
    # A constant column's standard deviation comes out as rounding (1e-16 of its size, not 0): no spread, so
    # that its mean magnitude is its scale (an unobserved state every sample starts at 0.5 is not read in
    # units of 1e-16).
    spread = np.where(np.isfinite(std) & (std > 1e-9 * size), std,
                      np.where(np.isfinite(size) & (size > 0), size, np.nan))
    return mean.cpu().numpy(), spread


def ode_data_scales(structure, science, inputs: tuple, y: torch.Tensor,
                    sample_weight: torch.Tensor | None = None) -> Bunch | None:
    """The network's input shift and scale and its output scale for a hybrid ODE, read from the data.

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
    sample_weight : Tensor of shape (n,), optional
        Each sample's weight, as the data loss weighs it (a weight of 2 reads as a duplicated sample).

    Returns
    -------
    Bunch or None
        ``in_shift``, ``in_scale`` (one per flattened state entry, then per input channel),
        ``out_scale`` (one per state entry) and ``state_spread``, ``rate`` and ``horizon`` (for
        messages); None for a state that is not a vector.
    """
    if len(structure.state_shape) != 1:
        return None
    x0 = inputs[0].reshape(len(inputs[0]), -1)
    n, d = x0.shape
    w = None if sample_weight is None else torch.as_tensor(sample_weight, dtype=torch.float64, device=x0.device)
    observed = list(range(d)) if structure.observed is None else list(structure.observed)
    y = y.reshape(n, structure.n_steps, len(observed))
    shift, scale, rate = np.zeros(d), np.full(d, np.nan), np.full(d, np.nan)
    for j in range(d):
        if j in observed:  # over the whole observed path, and its steps for the rate
            path = torch.cat([x0[:, j:j + 1], y[..., observed.index(j)]], dim=1).to(torch.float64)
            shift[j], scale[j] = (v[0] for v in moments(path.reshape(-1, 1), _repeat(w, path.shape[1])))
            steps = path.diff(dim=1) / structure.dt
            rate[j] = moments(steps.reshape(-1, 1), _repeat(w, steps.shape[1]))[1][0]
        else:
            shift[j], scale[j] = (v[0] for v in moments(x0[:, j:j + 1], w))
    scale = np.where(np.isnan(scale), 1.0, scale)  # a state that is zero throughout: its own unit
    missing = np.isnan(rate)
    if missing.any():  # a state y does not observe changes at the science's own rate at the start
        with torch.no_grad():
            u0 = None if len(inputs) < 2 else inputs[1][:, 0]
            f0 = science(x0.reshape(n, *structure.state_shape), *(() if u0 is None else (u0,)))
        rate = np.where(missing, moments(f0.reshape(n, -1), w)[1], rate)
    missing = np.isnan(rate)
    if missing.any():  # nothing known of its rate: the others' typical rate, else its spread per output step
        seen = rate[~missing]
        rate = np.where(missing, np.median(seen) if seen.size else scale / structure.dt, rate)
    in_shift, in_scale = [shift], [scale]
    if len(inputs) > 1:  # a forced system: its input channels, over the fine grid
        u = inputs[1].reshape(-1, inputs[1].shape[-1])
        u_shift, u_scale = moments(u, _repeat(w, inputs[1].shape[1]))
        in_shift.append(u_shift)
        in_scale.append(np.where(np.isnan(u_scale), 1.0, u_scale))
    return Bunch(in_shift=np.concatenate(in_shift), in_scale=np.concatenate(in_scale), out_scale=rate,
                 state_spread=scale, rate=rate, horizon=structure.n_steps * structure.dt)


def static_data_scales(structure, science, inputs: tuple, y: torch.Tensor,
                       sample_weight: torch.Tensor | None = None) -> Bunch:
    """The network's input shift and scale and its output scale for a static hybrid, read from the data.

    Parameters
    ----------
    structure : AdditiveStructure or ComposeStructure
        Set up on the data; a composition's network reads the science's output too.
    science : ScienceModel
        At its starting theta: a composition's network reads its output, at the scale it starts at.
    inputs : tuple of Tensor
        The structure's tensors (``X``).
    y : Tensor
        The targets.
    sample_weight : Tensor of shape (n,), optional
        Each sample's weight, as the data loss weighs it.

    Returns
    -------
    Bunch
        ``in_shift``, ``in_scale`` (one per flattened input entry: ``X``'s, then the science output's for a
        composition) and ``out_scale`` (one per flattened target entry); ``input_spread`` and ``target_spread``
        for messages.
    """
    x = inputs[0]
    n = len(x)
    w = None if sample_weight is None else torch.as_tensor(sample_weight, dtype=torch.float64, device=x.device)
    parts = [x.reshape(n, -1)]
    if not structure.additive:
        with torch.no_grad():
            parts.append(science(x).reshape(n, -1))
    in_shift, in_scale = moments(torch.cat(parts, dim=1), w)
    out_scale = moments(y.reshape(n, -1), w)[1]
    in_scale, out_scale = (np.where(np.isnan(v), 1.0, v) for v in (in_scale, out_scale))  # zero throughout
    return Bunch(in_shift=in_shift, in_scale=in_scale, out_scale=out_scale,
                 input_spread=in_scale[:parts[0].shape[1]], target_spread=out_scale)


def _repeat(weight: torch.Tensor | None, times: int) -> torch.Tensor | None:
    """Each sample's weight for each of its ``times`` values, flattened sample by sample."""
    return None if weight is None else weight.repeat_interleave(times)


def describe_scales(scales: Bunch | None) -> str:
    """The data's scales in a sentence, for the advice after a training that went bad."""
    if scales is None:
        return ""
    if "horizon" not in scales:  # a static model's
        return (f"The data's scales: input spread {_listed(scales.input_spread)}; target spread "
                f"{_listed(scales.target_spread)}.")
    spread = ", ".join(f"{v:.3g}" for v in scales.state_spread)
    times = scales.horizon * scales.rate / np.maximum(scales.state_spread, np.finfo(float).tiny)
    return (f"The data's scales: state spread {spread}; horizon {scales.horizon:.3g} time units, over which the "
            f"fastest state moves {float(np.max(times)):.3g} times its spread at its observed rate.")


def _listed(values: np.ndarray, most: int = 6) -> str:
    shown = ", ".join(f"{v:.3g}" for v in values[:most])
    return shown + (f", ... ({len(values)} in all)" if len(values) > most else "")


def set_network_scales(residual, scales: Bunch | None) -> bool:
    """Give the package's MLP the data's scales (see :func:`ode_data_scales`); False for another network,
    which reads the user's units as it is."""
    target = getattr(residual, "mlp", residual)  # a MaskedMLP's own MLP writes the components it changes
    if scales is None or not hasattr(target, "set_scales"):
        return False
    index = getattr(residual, "index", None)
    out_scale = scales.out_scale if index is None else scales.out_scale[index.cpu().numpy()]
    if target.in_shift.numel() != len(scales.in_shift) or target.out_scale.numel() != len(out_scale):
        return False
    target.set_scales(scales.in_shift, scales.in_scale, out_scale)
    return True
