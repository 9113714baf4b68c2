"""The science function tried once on a few samples before training: what it must return.

A fit that misreads the science function gives a wrong theta with no warning; calling it once,
on a batch that cannot be confused with a state axis, turns each such misreading into an error
that names it.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
import torch

__all__ = ["probe_batch", "call_science", "check_finite_model"]


def probe_batch(inputs, avoid) -> tuple:
    """The first samples of ``inputs``, as many as no per-sample axis has.

    A probe batch whose size equals a state dimension cannot tell a transposed
    output ``(d, n)`` from ``(n, d)``; rows are repeated if there are too few.
    """
    k = next(k for k in range(3, 100) if k not in avoid)
    rows = torch.arange(k) % len(inputs[0])
    return tuple(t[rows] for t in inputs)


def call_science(science, args, expected_shape, what, differentiable=False):
    """Run the science function on a probe batch and check what it returns.

    Besides the output's type and shape, the probe checks that the function
    leaves its inputs alone, returns finite values, and passes a gradient to
    every free parameter (numpy calls, ``.item()`` or ``.detach()`` inside it
    cut the graph, and theta would silently stay at its start).  With
    ``differentiable`` the inputs require a gradient, as ODE states do in
    training, so that numpy calls on them fail here rather than later.
    """
    name = science.name
    before = [a.clone() for a in args]
    if differentiable:  # non-leaf copies: in-place writes reach the mutation check below
        args = tuple(a.clone().requires_grad_() * 1 for a in args)
    # an in-place write that changes nothing on these rows (`v[:, 0].clamp_(min=0)`) still breaks
    # training's autograd: torch counts every in-place write in the tensor's version
    versions = [a._version for a in args]
    try:
        with torch.enable_grad():
            out = science(*args)
    except Exception as exc:
        shapes = ", ".join(str(tuple(a.shape)) for a in args)
        hint = ("It calls numpy on a tensor (e.g. np.sin): use the torch function (torch.sin); "
                "detaching would cut the gradient of theta. " if "numpy()" in str(exc) else "")
        raise ValueError(
            f"The science function {name!r} raised {type(exc).__name__}: {exc} (called with "
            f"{what} of shape(s) {shapes}). {hint}It must accept torch tensors with a "
            "leading batch dimension and use torch operations."
        ) from exc
    if not isinstance(out, torch.Tensor):
        raise TypeError(
            f"The science function {name!r} returned {type(out).__name__}, expected a torch.Tensor.")
    if any(not torch.equal(a.detach(), b) or a._version != v for a, b, v in zip(args, before, versions)):
        raise ValueError(
            f"The science function {name!r} modifies its input in place (e.g. `v[:, 0] *= k`, "
            "`v.mul_(k)` or `v[:, 0].clamp_(min=0)`); it would rewrite the data at every call. Use "
            "out-of-place operations (`v = v * k`, `v[:, 0].clamp(min=0)`, `torch.stack`)."
        )
    if out.dtype != args[0].dtype and not out.dtype.is_floating_point:  # no fit computes in it
        raise ValueError(
            f"The science function {name!r} returned {out.dtype} values for {args[0].dtype} inputs: it computes "
            "in integers or booleans (a constant such as torch.tensor(2), a comparison, .long() or .round() "
            "to an integer type), which carry no gradient to theta. Return floats of the inputs' dtype: "
            "write constants as floats (torch.tensor(2.0)) or convert with .to(v.dtype)."
        )
    if out.dtype != args[0].dtype:
        fits = str(out.dtype).removeprefix("torch.")
        raise ValueError(
            f"The science function {name!r} returned {out.dtype} values for {args[0].dtype} inputs: make its "
            "constants with the inputs' dtype (`torch.tensor(c, dtype=v.dtype)`)"
            + (f", or fit with dtype={fits!r} when it must compute in that precision." if fits in ("float32", "float64")
               else " (fits compute in float32 or float64).")
        )
    batch = args[0].shape[0]
    if expected_shape is not None and tuple(out.shape) != tuple(expected_shape):
        hint = ""
        if tuple(out.shape) == tuple(expected_shape)[::-1]:
            hint = " It looks transposed: stack the components along the last axis (dim=-1)."
        elif tuple(out.shape) + (1,) == tuple(expected_shape):
            hint = (" It lacks the trailing axis of length 1: return `out[:, None]`, or, where the "
                    "structure takes that axis from y (an (n, 1) y), fit y as a 1-D array.")
        raise ValueError(
            f"The science function {name!r} returned shape {tuple(out.shape)} for {what} of "
            f"shape {tuple(args[0].shape)}; the structure needs {tuple(expected_shape)}.{hint}"
        )
    if out.ndim == 0 or out.shape[0] != batch:
        raise ValueError(
            f"The science function {name!r} returned shape {tuple(out.shape)}; its first axis "
            f"must be the batch axis of length {batch}."
        )
    bad = ~torch.isfinite(out.detach()).reshape(batch, -1).all(dim=1)
    if bad.any():
        i = int(bad.nonzero()[0])
        raise ValueError(
            f"The science function {name!r} returned non-finite values for {what} "
            f"{[a[i].tolist() for a in before]} (theta {science.as_dict()}). Make it finite "
            "on the data's range (bound theta with theta_bounds or guard its domain)."
        )
    free = [(n, p) for n, p in science.raw.items() if p.requires_grad]
    grads = (torch.autograd.grad(out.sum(), [p for _, p in free], allow_unused=True)
             if free and out.requires_grad else [None] * len(free))
    cut = [n for (n, _), g in zip(free, grads) if g is None]
    if cut:
        raise ValueError(
            f"The science function {name!r} passes no gradient to parameter(s) {cut}: its "
            "output does not depend on them through torch operations (numpy calls, .item(), "
            "float(), .detach() or torch.as_tensor of a computed value cut the graph), so "
            "they would stay at their initial value. Write it with torch operations, or keep "
            "them constant with theta_fixed."
        )
    return out


def check_finite_model(values, name: str, theta: Mapping, what: str = "predictions") -> None:
    """Refuse a model whose own ``values`` (predictions, or their derivatives by theta; samples first) are
    not finite at its ``theta`` on the data (``name``: the science function's).

    Without this a NaN prediction turns every residual, standard error and verdict that follows into NaN,
    which reads as the data's failure ("not identified by these data"); the error names the function, its
    parameters and the samples instead.
    """
    values = np.asarray(values)
    bad = ~np.isfinite(values.reshape(len(values), -1)).all(axis=1)
    if bad.any():
        rows = np.flatnonzero(bad)
        theta = {k: float(v) if np.ndim(v) == 0 else np.asarray(v).tolist() for k, v in theta.items()}
        raise ValueError(
            f"The science model's {what} are not finite: the science function {name!r} gives NaN or "
            f"infinite values on {len(rows)} of {len(values)} samples (first: sample {int(rows[0])}) at theta "
            f"{theta}. This is the model's failure, not the data's: make the function finite on the "
            "data's range (bound theta with theta_bounds or guard its domain), or leave out the samples where "
            "it is not defined."
        )
