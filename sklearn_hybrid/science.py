"""The science model: a plain user function whose numeric keyword defaults are theta.

As in lmfit, the parameters are read from the function's signature: arguments
without a default are the inputs the structure passes in (a state ``v``, an
input ``u`` or features ``x``), arguments with a numeric default (a number or
a sequence of numbers) are the unknown physical parameters.  Bounds are
enforced by a smooth reparametrisation of an unconstrained raw value, so the
optimiser never sees a clipped gradient.
"""

from __future__ import annotations

import functools
import inspect
import numbers
from collections.abc import Mapping
from typing import Callable

import numpy as np
import torch
from torch import nn

__all__ = ["ScienceModel", "read_signature"]


def _as_numeric(value) -> np.ndarray | None:
    """Return ``value`` as a float array if it is a number or numeric sequence."""
    if isinstance(value, bool):
        return None
    if isinstance(value, numbers.Real):
        return np.asarray(float(value))
    if isinstance(value, (list, tuple, np.ndarray)):
        arr = np.asarray(value)
        if arr.size and np.issubdtype(arr.dtype, np.number):
            return arr.astype(float)
    return None


def read_signature(func: Callable) -> tuple[list[str], dict[str, np.ndarray]]:
    """Split a science function's arguments into inputs and parameters.

    Parameters
    ----------
    func : callable
        The science function.

    Returns
    -------
    inputs : list of str
        Names of the arguments without a default, in order.
    defaults : dict of str to ndarray
        The arguments with a numeric default, mapped to that default.
    """
    if not callable(func):
        raise TypeError(f"science must be a callable, got {type(func).__name__}.")
    # functools.partial(f, k=1.0) is how users fix a constant: its keywords are not theta
    bound = set(func.keywords) if isinstance(func, functools.partial) else set()
    inputs, defaults = [], {}
    params = list(inspect.signature(func).parameters.values())
    qualname = getattr(func, "__qualname__", "")
    if params and params[0].name == "self" and "." in qualname.replace(".<locals>.", ""):
        # Pend.f taken from the class: 'self' would be read as the state and 'v' as an input u
        owner, name = qualname.replace(".<locals>.", ":").rsplit(":", 1)[-1].rsplit(".", 1)
        raise TypeError(
            f"science={owner}.{name} is a method taken from its class, so its first argument 'self' "
            f"has no value. Pass it from an instance, science={owner}(...).{name}, or make it a "
            "@staticmethod without 'self'.")
    for p in params:
        if p.kind in (p.VAR_POSITIONAL, p.VAR_KEYWORD) or p.name in bound:
            continue
        if p.default is p.empty:
            inputs.append(p.name)
            continue
        if isinstance(p.default, torch.Tensor):
            raise TypeError(
                f"The science function's argument {p.name!r} has a torch.Tensor default. Write "
                "it as a number or a list of numbers to estimate it, or bind it as a constant "
                f"with functools.partial(f, {p.name}=...) or a closure."
            )
        value = _as_numeric(p.default)
        if value is not None:
            defaults[p.name] = value
    return inputs, defaults


class _Bounded(nn.Module):
    """Map an unconstrained raw tensor to a value inside ``(low, high)``, in steps relative to its scale.

    Two finite bounds use a scaled sigmoid (a raw step moves theta by a
    fraction of the span), one bound a softplus times the starting distance
    to it, no bound a multiple of ``scale`` (theta's size at its start).  So
    an optimiser step of a given size in raw moves theta by the same
    *fraction* of its size whatever its units: Adam moves every raw value by
    about its learning rate per step, which would throw a theta of 1e-6 away
    in one step and leave one of 1e4 in place for a thousand.  All maps are
    smooth and invertible on the open set.
    """

    def __init__(self, low: np.ndarray, high: np.ndarray, scale: np.ndarray | float = 1.0):
        super().__init__()
        self.register_buffer("low", torch.as_tensor(low, dtype=torch.float64))
        self.register_buffer("high", torch.as_tensor(high, dtype=torch.float64))
        self.register_buffer("scale", torch.as_tensor(np.broadcast_to(scale, np.shape(low)).copy(),
                                                      dtype=torch.float64))
        self.has_low = bool(np.all(np.isfinite(low)))
        self.has_high = bool(np.all(np.isfinite(high)))

    def __setstate__(self, state):  # a fit pickled before theta stepped relative to its scale: scale 1
        super().__setstate__(state)
        if "scale" not in self._buffers:
            self.register_buffer("scale", torch.ones_like(self.low))

    def forward(self, raw: torch.Tensor) -> torch.Tensor:
        return self.map(raw, self.low, self.high, self.scale)

    def map(self, raw: torch.Tensor, low: torch.Tensor, high: torch.Tensor, scale: torch.Tensor) -> torch.Tensor:
        """:meth:`forward` with the bounds and scale given (stacked members carry their own, on a leading axis)."""
        low, high, scale = (t.to(raw.dtype) for t in (low, high, scale))
        if self.has_low and self.has_high:
            return low + (high - low) * torch.sigmoid(raw)
        if self.has_low:
            return low + scale * nn.functional.softplus(raw)
        if self.has_high:
            return high - scale * nn.functional.softplus(raw)
        return scale * raw

    def inverse(self, value: np.ndarray) -> np.ndarray:
        low, high, scale = self.low.cpu().numpy(), self.high.cpu().numpy(), self.scale.cpu().numpy()
        if self.has_low and self.has_high:
            p = (value - low) / (high - low)
            return np.log(p) - np.log1p(-p)
        if self.has_low:
            return _inverse_softplus((value - low) / scale)
        if self.has_high:
            return _inverse_softplus((high - value) / scale)
        return value / scale


def theta_scale(value: np.ndarray, low: np.ndarray, high: np.ndarray) -> np.ndarray:
    """The size a parameter's steps are relative to: its distance from its one bound, else its size.

    A parameter that starts at 0 (a coefficient with no prior size) has no size
    of its own: it takes the largest size among the other entries of the
    same parameter, else 1 (the units of its science function).
    """
    value = np.asarray(value, dtype=float)
    if np.all(np.isfinite(low)) and not np.all(np.isfinite(high)):
        size = np.abs(value - low)
    elif np.all(np.isfinite(high)) and not np.all(np.isfinite(low)):
        size = np.abs(high - value)
    else:
        size = np.abs(value)
    fallback = float(size.max()) if size.size and size.max() > 0 else 1.0
    return np.where(size > 0, size, fallback)


def _inverse_softplus(x: np.ndarray) -> np.ndarray:
    """``log(expm1(x))`` written so that it does not overflow: a start 1000 above its bound is common
    (a stiffness in N/m, a pressure in Pa) and ``expm1(1000)`` is infinite."""
    return x + np.log(-np.expm1(-x))


class ScienceModel(nn.Module):
    """The science function with its parameters as trainable torch tensors.

    Parameters
    ----------
    func : callable
        ``func(*inputs, **theta)`` written with torch operations.
    theta_init : dict, optional
        Initial values overriding the signature defaults.
    theta_bounds : dict, optional
        ``name -> (low, high)``; use ``None`` or ``inf`` for an open side.
    theta_fixed : iterable of str or dict, optional
        Parameters kept constant during training: names, kept at their
        initial value (``theta_init`` or the default), or ``name -> value``,
        kept at that value (lmfit's ``vary=False`` with a value; ``None``
        keeps the initial value).
    dtype : torch.dtype
        Floating point type of the parameters.
    """

    def __init__(self, func, theta_init=None, theta_bounds=None, theta_fixed=None,
                 dtype=torch.float32):
        super().__init__()
        self.func = func
        self.inputs, defaults = read_signature(func)
        if not defaults:
            raise ValueError(
                f"The science function {getattr(func, '__name__', func)!r} has no "
                "keyword argument with a numeric default, so there is no parameter "
                "theta to estimate. Declare them as e.g. `def f(v, omega=1.0): ...`."
            )
        theta_init, theta_bounds = dict(theta_init or {}), dict(theta_bounds or {})
        # a dict's values are where to fix (a list would keep only its keys and drop them silently)
        fixed_at = {k: v for k, v in theta_fixed.items() if v is not None} if isinstance(theta_fixed, Mapping) else {}
        theta_fixed = [theta_fixed] if isinstance(theta_fixed, str) else list(theta_fixed or [])
        for what, names in (("theta_init", theta_init), ("theta_bounds", theta_bounds),
                            ("theta_fixed", theta_fixed)):
            unknown = sorted(set(names) - set(defaults))
            if unknown:
                raise ValueError(
                    f"{what} names unknown parameter(s) {unknown}; the science function's "
                    f"parameters are {sorted(defaults)}."
                )
        for name, value in fixed_at.items():
            if name in theta_init and not np.array_equal(np.asarray(theta_init[name], dtype=object),
                                                         np.asarray(value, dtype=object)):
                raise ValueError(
                    f"theta_init[{name!r}] = {theta_init[name]!r} and theta_fixed[{name!r}] = {value!r} "
                    "disagree: give the value once, in theta_fixed.")
        theta_init.update(fixed_at)
        self.names = list(defaults)
        self.shapes = {}
        self.raw = nn.ParameterDict()
        self.transforms = nn.ModuleDict()
        for name, default in defaults.items():
            given = theta_init.get(name, default)
            source = "theta_fixed" if name in fixed_at else "theta_init"  # where the value was given
            if given is None or isinstance(given, (str, bool)):  # np.asarray would make None a NaN, "0.5" a number
                raise ValueError(f"{source}[{name!r}] must be a number (or an array of numbers), got {given!r}.")
            try:
                value = np.asarray(given, dtype=float)
            except (TypeError, ValueError):
                raise ValueError(f"{source}[{name!r}] must be a number (or an array of numbers), "
                                 f"got {given!r}.") from None
            if value.shape != default.shape:  # a scalar given as [0.6] would turn theta_[name] into an array
                raise ValueError(
                    f"{source}[{name!r}] has shape {value.shape}, the default has shape "
                    f"{default.shape}" + (": give a number." if default.ndim == 0 else ".")
                )
            if not np.all(np.isfinite(value)):
                raise ValueError(f"{source}[{name!r}] = {value} is not finite.")
            low, high = self._bounds(name, theta_bounds.get(name), value)
            transform = _Bounded(low, high, theta_scale(value, low, high))
            raw = torch.as_tensor(transform.inverse(value), dtype=dtype)
            self.shapes[name] = value.shape
            self.transforms[name] = transform
            self.raw[name] = nn.Parameter(raw, requires_grad=name not in theta_fixed)

    @staticmethod
    def _bounds(name, bounds, value):
        if bounds is None:
            return np.full(value.shape, -np.inf), np.full(value.shape, np.inf)
        try:
            low, high = bounds
        except (TypeError, ValueError):
            raise ValueError(
                f"theta_bounds[{name!r}] must be a pair (low, high), got {bounds!r}."
            ) from None
        try:
            low = np.broadcast_to(np.asarray(-np.inf if low is None else low, float), value.shape)
            high = np.broadcast_to(np.asarray(np.inf if high is None else high, float), value.shape)
        except (TypeError, ValueError):
            raise ValueError(
                f"theta_bounds[{name!r}] = {bounds!r} must hold numbers (or None for an open "
                f"side) matching the parameter's shape {value.shape}."
            ) from None
        if np.isnan(low).any() or np.isnan(high).any():
            raise ValueError(
                f"theta_bounds[{name!r}] = {bounds!r} contains NaN; use None or inf for an "
                "open side."
            )
        if np.any(low >= high):
            raise ValueError(f"theta_bounds[{name!r}] = {bounds!r} has low >= high.")
        if np.any(value <= low) or np.any(value >= high):
            raise ValueError(
                f"The initial value of {name!r} ({value}) lies outside its bounds "
                f"{bounds!r}; it must be strictly inside."
            )
        return low.copy(), high.copy()

    @property
    def name(self) -> str:
        """The science function's name, for messages."""
        return getattr(self.func, "__name__", type(self.func).__name__)

    def values(self) -> dict[str, torch.Tensor]:
        """Current parameter values (differentiable), keyed by name."""
        return {name: self.transforms[name](self.raw[name]) for name in self.names}

    def forward(self, *inputs: torch.Tensor) -> torch.Tensor:
        return self.func(*inputs, **self.values())

    def as_dict(self) -> dict[str, float | np.ndarray]:
        """Parameter values as Python floats (scalars) or numpy arrays (vectors)."""
        with torch.no_grad():
            out = {}
            for name, value in self.values().items():
                value = value.detach().cpu().numpy().astype(float)
                out[name] = float(value) if value.ndim == 0 else value
            return out
