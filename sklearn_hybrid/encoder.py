"""Theta that varies from sample to sample: an encoder network infers each sample's parameters.

The paper's appendix "Learning with Varying Scientific Parameters": every
sample ``x`` (an input window) has its own theta, and an encoder network
``theta = e_psi(x)`` is trained jointly with the hybrid model.  Here:

- :func:`build_encoder` turns a specification (``"mlp"``: the paper's MLP
  256x2 over the flattened window; ``"cnn"``: its convolutional encoder with
  batch norm and a dense head, for fields; a dict of options; or a factory
  returning a ``torch.nn.Module``) into a network with one output per free
  scalar of theta;
- :class:`ThetaEncoder` adds that output to the *raw* (unconstrained) initial
  value of every free parameter and applies the science model's bound
  transform, so ``theta_bounds`` hold for every sample and the presets, whose
  last layer starts at zero, start every sample at ``theta_init``; parameters
  in ``theta_fixed`` keep their value for every sample;
- :class:`PerSampleScience` calls the user's science function once per sample
  with that sample's scalar theta, vectorised by ``torch.func.vmap``, so
  science functions written for one shared theta (``a * lap[:, 0]`` over
  fields) need no change.  When a probe at fit time shows that the function
  already gives the per-sample result with theta of shape ``(n, *shape)``
  passed directly (``omega * torch.sin(v[:, 0])`` does), that cheaper call is
  used instead (1.7x faster per iteration with erm, 2.1x with fsam, on the
  pendulum).

The encoder belongs to theta, not to the network g_phi: it gets theta's
learning rate (``lr_theta``), no weight decay, and the SAM family perturbs it
only with ``perturb="all"``.
"""

from __future__ import annotations

import math
import os
import traceback
from typing import Sequence

import torch
from torch import nn

from .residual import from_registry, make_activation, new_module, refuse_instance

__all__ = ["ThetaEncoder", "PerSampleScience", "build_encoder", "make_theta_encoder", "ENCODERS",
           "MLPEncoder", "ConvEncoder"]


class MLPEncoder(nn.Module):
    """Feed-forward encoder over the flattened input window (the paper's MLP 256x2, ReLU).

    Parameters
    ----------
    in_shape : tuple
        Per-sample shape of the window, e.g. ``(10, 2)``.
    n_out : int
        Number of free scalars of theta.
    hidden : sequence of int, default=(256, 256)
        Hidden layer widths.
    activation : str, default="relu"
        Activation between layers.
    """

    def __init__(self, in_shape: tuple, n_out: int, hidden: Sequence[int] = (256, 256),
                 activation: str = "relu"):
        super().__init__()
        widths = [math.prod(in_shape), *hidden]
        layers = []
        for n_in, n_hid in zip(widths[:-1], widths[1:]):
            layers += [nn.Linear(n_in, n_hid), make_activation(activation)]
        self.body = nn.Sequential(*layers)
        self.head = nn.Linear(widths[-1], n_out)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        return self.head(self.body(x.reshape(len(x), -1)))


class ConvEncoder(nn.Module):
    """Convolutional encoder of field windows (the paper's: conv 288, 144 with batch norm, dense 256).

    The window ``(m_x, C, H, W)`` enters as ``m_x * C`` channels (time folded
    into channels, as in the paper).  The feature maps are averaged over
    space before the dense head (the paper does not say how it flattens;
    averaging keeps the head small whatever the grid).  Batch norm keeps
    running statistics, so ``predict_theta`` of a sample does not depend on
    the other samples of its batch.

    Parameters
    ----------
    in_shape : tuple
        Per-sample window shape ``(m_x, C, H, W)`` or ``(C, H, W)``.
    n_out : int
        Number of free scalars of theta.
    hidden : sequence of int, default=(288, 144)
        Channels of the convolutional layers (kernel 3).
    dense : sequence of int, default=(256,)
        Hidden widths of the dense head.
    activation : str, default="relu"
        Activation between layers.
    padding_mode : str, default="circular"
        Padding of the convolutions (``"replicate"`` for non-periodic fields).
    """

    def __init__(self, in_shape: tuple, n_out: int, hidden: Sequence[int] = (288, 144),
                 dense: Sequence[int] = (256,), activation: str = "relu",
                 padding_mode: str = "circular"):
        super().__init__()
        if len(in_shape) not in (3, 4):
            raise ValueError(
                f"The 'cnn' encoder reads windows of fields (m_x, C, H, W) or (C, H, W); "
                f"got per-sample shape {tuple(in_shape)}."
            )
        channels = [math.prod(in_shape[:-2]), *hidden]
        layers = []
        for c_in, c_out in zip(channels[:-1], channels[1:]):
            layers += [nn.Conv2d(c_in, c_out, 3, padding=1, padding_mode=padding_mode),
                       nn.BatchNorm2d(c_out), make_activation(activation)]
        self.body = nn.Sequential(*layers)
        widths = [channels[-1], *dense]
        head = []
        for n_in, n_hid in zip(widths[:-1], widths[1:]):
            head += [nn.Linear(n_in, n_hid), make_activation(activation)]
        self.dense = nn.Sequential(*head)
        self.head = nn.Linear(widths[-1], n_out)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        x = x.reshape(len(x), -1, *x.shape[-2:])
        features = self.body(x).mean(dim=(-2, -1))
        return self.head(self.dense(features))


ENCODERS: dict[str, type[nn.Module]] = {"mlp": MLPEncoder, "cnn": ConvEncoder}


def build_encoder(spec, in_shape: tuple, n_out: int,
                  dtype: torch.dtype = torch.float32) -> nn.Module:
    """Build the theta encoder network from its specification.

    Parameters
    ----------
    spec : str, dict or callable
        ``"mlp"`` or ``"cnn"``; a dict such as ``{"kind": "mlp", "hidden":
        (64, 64)}`` or ``{"kind": "cnn", "hidden": (32, 16), "dense": (64,)}``;
        or a factory called as ``factory(in_shape, n_out)`` that returns a
        ``torch.nn.Module`` mapping a batch of windows ``(n, *in_shape)`` to
        ``(n, n_out)``.  The presets start their last layer at zero.
    in_shape : tuple
        Per-sample shape of the encoder's input (the whole sample ``X[i]``).
    n_out : int
        Number of free scalars of theta.
    dtype : torch.dtype
        Floating point type of the parameters.

    Returns
    -------
    torch.nn.Module
    """
    refuse_instance("theta_encoder", spec, "`theta_encoder=lambda in_shape, n_out: {name}(...)` (a new encoder "
                    "each call)")
    if callable(spec):
        return new_module(spec(tuple(in_shape), int(n_out)), "theta_encoder").to(dtype)
    module = from_registry("theta_encoder", spec, ENCODERS, (tuple(in_shape), int(n_out)), dtype)
    with torch.no_grad():  # every sample starts at theta_init; the body still learns (see module doc)
        module.head.weight.zero_()
        module.head.bias.zero_()
    return module


class ThetaEncoder(nn.Module):
    """Per-sample theta ``transform(raw_init + net(x))`` for the free parameters.

    Parameters
    ----------
    net : torch.nn.Module
        Maps ``(n, *in_shape)`` to ``(n, n_free)``.
    science : ScienceModel
        Gives the names, shapes, bound transforms, initial values and the
        fixed parameters.  Its free raw parameters are frozen here: the
        encoder replaces them.
    """

    def __init__(self, net: nn.Module, science: nn.Module):
        super().__init__()
        self.net = net
        self.names = [n for n in science.names if science.raw[n].requires_grad]
        self.shapes = {n: tuple(science.shapes[n]) for n in science.names}
        self.sizes = [math.prod(self.shapes[n]) for n in self.names]
        raw = [science.raw[n].detach().reshape(-1) for n in self.names]
        self.register_buffer("raw_init", torch.cat(raw) if raw else torch.zeros(0))
        for n in self.names:
            science.raw[n].requires_grad_(False)
        self.last_mean = None  # batch mean of the last forward pass, for the training history
        self.direct = False  # set by probe_per_sample: theta (n, ...) can be passed as it is

    @property
    def n_out(self) -> int:
        return sum(self.sizes)

    def forward(self, window: torch.Tensor, science: nn.Module) -> dict[str, torch.Tensor]:
        """Per-sample theta, ``name -> (n, *shape)``; fixed parameters are shared (not batched)."""
        n = len(window)
        raw = self.net(window)
        if raw.shape != (n, self.n_out):
            raise ValueError(
                f"The theta encoder returned shape {tuple(raw.shape)} for {n} samples; it must "
                f"return ({n}, {self.n_out}): one column per free scalar of theta {self.names}."
            )
        raw = raw + self.raw_init.to(raw.dtype)
        values, start = {}, 0
        for name, size in zip(self.names, self.sizes):
            part = raw[:, start:start + size].reshape(n, *self.shapes[name])
            values[name] = science.transforms[name](part)
            start += size
        if self.training:
            self.last_mean = {k: v.detach().mean(0) for k, v in values.items()}
        return values


class PerSampleScience:
    """The science function with a batch of per-sample thetas bound (a transient callable).

    ``func(*inputs, **theta)`` is called for each sample with a batch of one
    and that sample's theta, vectorised with ``torch.func.vmap``: the
    function must use torch operations without data-dependent Python control
    flow or ``.item()``, as ``torch.func.vmap`` requires.
    """

    per_sample = True

    def __init__(self, science: nn.Module, theta: dict[str, torch.Tensor], direct: bool = False):
        self.func = science.func
        self.theta, self.direct = theta, direct
        values = science.values()
        self.shared = {n: values[n] for n in science.names if n not in theta}

    def __call__(self, *inputs: torch.Tensor) -> torch.Tensor:
        shared = self.shared
        if self.direct:
            return self.func(*inputs, **self.theta, **shared)

        def one(theta, *args):
            out = self.func(*(a.unsqueeze(0) for a in args), **theta, **shared)
            return out.squeeze(0)

        return torch.func.vmap(one)(self.theta, *inputs)


class BoundModel:
    """What a structure sees of a :class:`HybridModule` whose theta varies per sample."""

    per_sample_theta = True

    def __init__(self, model: nn.Module, theta: dict[str, torch.Tensor], direct: bool | None = None):
        direct = model.encoder.direct if direct is None else direct
        self.science = PerSampleScience(model.science, theta, direct)
        self.residual, self.reduction = model.residual, model.reduction
        self.structure = model.structure


def split_window(ode: bool, X):
    """The structure's ``X`` from the encoder's: the last state of each window for an ODE.

    Parameters
    ----------
    ode : bool
        Whether the estimator's structure is an ODE.
    X : ndarray of shape (n_samples, ...)
        Encoder input (for an ODE: windows ``(n, m_x, *state_shape)``).

    Returns
    -------
    ndarray
        What the structure reads: ``X[:, -1]`` for an ODE, ``X`` otherwise.
    """
    if ode:
        if X.ndim < 3:
            raise ValueError(
                "With theta_encoder and structure='ode', X must hold input windows of shape "
                f"(n_samples, n_window_steps, *state_shape); got X of shape {X.shape}. The "
                "last state of each window is the initial state (for a window of one state "
                "use X[:, None])."
            )
        return X[:, -1]
    return X


def make_theta_encoder(spec, science: nn.Module, in_shape: tuple,
                       dtype: torch.dtype = torch.float32) -> ThetaEncoder:
    """Build the network from ``spec`` and wrap it as a :class:`ThetaEncoder` of ``science``.

    Raises
    ------
    ValueError
        If every parameter is in ``theta_fixed`` (nothing left to encode).
    """
    n_free = sum(math.prod(science.shapes[n]) for n in science.names if science.raw[n].requires_grad)
    if n_free == 0:
        raise ValueError("theta_encoder needs at least one parameter outside theta_fixed.")
    return ThetaEncoder(build_encoder(spec, in_shape, n_free, dtype), science)


def _under_vmap(exc: BaseException) -> bool:
    """Whether ``exc`` was raised inside torch.func.vmap (or names what vmap refuses)."""
    files = [frame.f_code.co_filename for frame, _ in traceback.walk_tb(exc.__traceback__)]
    return (any("_functorch" in f or f"torch{os.sep}func" in f for f in files)
            or any(word in str(exc) for word in ("vmap", ".item()", "data-dependent", "BatchedTensor")))


def probe_per_sample(model: nn.Module, inputs: tuple) -> None:
    """Run the model on two samples: fail early, and choose the direct call where it is exact.

    With two distinct thetas, the prediction through the vmapped science
    function is compared with the one that passes theta ``(n, *shape)`` to the
    function as it is; ``model.encoder.direct`` is set where both agree.
    """
    probe = tuple(t[:2] for t in inputs)
    *struct_inputs, window = probe
    training = model.training
    model.eval()  # batch norm of the encoder would need more than one value per channel
    model.encoder.direct = False
    try:
        with torch.no_grad():
            model(*probe)
            theta = model.encoder(window, model.science)
            spread = torch.tensor([0.8, 1.2], dtype=window.dtype, device=window.device)[:len(window)]
            theta = {k: v * spread.reshape(-1, *([1] * (v.dim() - 1))) + 0.01 * (spread - 1).reshape(
                -1, *([1] * (v.dim() - 1))) for k, v in theta.items()}
            structure = model.structure
            reference, _ = structure.forward(BoundModel(model, theta, direct=False), *struct_inputs)
            try:
                direct, _ = structure.forward(BoundModel(model, theta, direct=True), *struct_inputs)
                model.encoder.direct = bool(direct.shape == reference.shape and torch.allclose(
                    direct, reference, rtol=1e-5, atol=1e-6 * float(reference.abs().max()) + 1e-12))
            except Exception:  # the function does not broadcast per-sample theta: keep vmap
                pass
    except Exception as exc:
        # the vmap advice only where vmap was at work: a network's own shape error needs none
        hint = (" With theta_encoder the science function is called once per sample under torch.func.vmap, so "
                "it must use torch operations only (no .item(), no Python branching on tensor values) and "
                "accept a batch of one." if _under_vmap(exc) else "")
        raise ValueError(f"The hybrid model with per-sample theta failed on two samples: {type(exc).__name__}: "
                         f"{str(exc).rstrip('.')}.{hint}") from exc
    finally:
        model.train(training)
        if model.encoder is not None:
            model.encoder.last_mean = None


def summarize(theta: dict[str, torch.Tensor]) -> dict:
    """Mean over the samples of per-sample theta: floats for scalars, arrays for vectors."""
    out = {}
    for name, value in theta.items():
        mean = value.mean(0).cpu().numpy().astype(float)
        out[name] = float(mean) if mean.ndim == 0 else mean
    return out
