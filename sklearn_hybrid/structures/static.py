"""Static structures: ``y = g_phi(x, f_theta(x))``, ``y = f_theta(x) + g_phi(x)``, and a user's callable
``structure(x, f, g) -> y`` for anything more nested."""

from __future__ import annotations

import math
from typing import Callable

import torch
from torch import nn

from .._probe import call_science, probe_batch

__all__ = ["ComposeStructure", "AdditiveStructure", "CallableStructure"]


class ComposeStructure:
    """General composition ``y = g_phi(x, f_theta(x))``; g sees x and z = f(x)."""

    additive = False

    def __init__(self, **_):
        pass

    def __repr__(self) -> str:
        return f"{type(self).__name__}()"

    def setup(self, X, y_shape):
        self.x_shape, self.y_shape = X.shape[1:], tuple(y_shape)

    def tensors(self, X, dtype):
        return (torch.tensor(X, dtype=dtype),)  # a copy: the science never sees the caller's memory

    def probe(self, science, inputs):
        x = probe_batch(inputs, (*self.x_shape, *self.y_shape))[0]
        self.z_shape = tuple(call_science(science, (x,), None, "X").shape[1:])

    def residual_shapes(self):
        return (tuple(self.x_shape), self.z_shape), self.y_shape

    def forward(self, model, x, use_residual=True):
        z = model.science(x)
        if use_residual:
            return model.residual(x, z).reshape(len(x), *self.y_shape), {"z": z}
        if model.reduction is not None:
            return model.reduction(z.reshape(len(x), -1)).reshape(len(x), *self.y_shape), {"z": z}
        if self.z_shape != self.y_shape:
            raise ValueError(
                f"The science output has shape {self.z_shape} and y has {self.y_shape}: without "
                "the linear map A of method='f-reg' there is no science-only prediction of y."
            )
        return z, {"z": z}

    def trace(self, model, inputs, pred, extras):
        science_only, _ = self.forward(model, *inputs, use_residual=False)
        n = len(pred)
        return {"points": inputs[0], "inputs": None,
                "residual": (pred - science_only).reshape(n, *self.y_shape)}

    def make_reduction(self, dtype):
        """The learnable linear map A of f-reg (identity when z and y share a shape)."""
        if self.z_shape == self.y_shape:
            return None
        return nn.Linear(math.prod(self.z_shape), math.prod(self.y_shape), bias=False).to(dtype)

    def functional_penalty(self, model, pred, extras):
        z = extras["z"].reshape(len(pred), -1)
        reduced = z if model.reduction is None else model.reduction(z)
        return (pred.reshape(len(pred), -1) - reduced).pow(2).sum(-1)


class AdditiveStructure(ComposeStructure):
    """Static additive model ``y = f_theta(x) + g_phi(x)``."""

    additive = True

    def probe(self, science, inputs):
        x = probe_batch(inputs, (*self.x_shape, *self.y_shape))[0]
        call_science(science, (x,), (len(x), *self.y_shape), "X")

    def residual_shapes(self):
        return (tuple(self.x_shape),), self.y_shape

    def forward(self, model, x, use_residual=True):
        if not use_residual:
            return model.science(x), {}
        g = model.residual(x).reshape(len(x), *self.y_shape)
        return model.science(x) + g, {"g": g}

    def trace(self, model, inputs, pred, extras):
        return {"points": inputs[0], "inputs": None, "residual": extras["g"]}

    def make_reduction(self, dtype):
        return None

    def functional_penalty(self, model, pred, extras):
        return extras["g"].pow(2).reshape(len(pred), -1).sum(-1)


class CallableStructure(ComposeStructure):
    """A user composition ``func(x, f, g) -> y`` (f: science with theta bound, g: network)."""

    additive = False

    def __init__(self, func: Callable):
        self.func = func

    def probe(self, science, inputs):
        pass

    def residual_shapes(self):
        return None, None

    def forward(self, model, x, use_residual=True):
        if not use_residual:
            raise ValueError("A user-supplied composition has no science-only prediction.")
        out = self.func(x, model.science, model.residual)
        # a transposed (outputs, samples) result reshaped anyway would mix the samples' values
        if (not torch.is_tensor(out) or out.ndim == 0 or out.shape[0] != len(x)
                or math.prod(out.shape[1:]) != math.prod(self.y_shape)):
            got = tuple(out.shape) if torch.is_tensor(out) else type(out).__name__
            raise ValueError(f"The structure {getattr(self.func, '__name__', self.func)!r} returned {got} for "
                             f"{len(x)} samples; it must return a tensor of shape {(len(x), *self.y_shape)}, "
                             "one row per sample, like y.")
        return out.reshape(len(x), *self.y_shape), {}

    def trace(self, model, inputs, pred, extras):
        raise ValueError("A user-supplied composition does not say where its network acts.")

    def make_reduction(self, dtype):
        raise ValueError(self._NO_REDUCTION)

    def functional_penalty(self, model, pred, extras):
        raise ValueError(self._NO_REDUCTION)

    _NO_REDUCTION = ("method='f-reg' needs a structure that defines a science-only reduction "
                     "('ode', 'compose' or 'additive'); a user-supplied composition has none.")
