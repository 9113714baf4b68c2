"""The neural part g_phi, built from a specification inside ``fit``.

The estimator never stores a module instance given by the user: it stores a
*specification* (a name, a dict, or a factory) and builds a fresh module in
every ``fit``, so ``clone`` and refits behave as scikit-learn users expect.
"""

from __future__ import annotations

import inspect
import math
from typing import Sequence

import torch
from torch import nn

__all__ = ["MLP", "MaskedMLP", "ConvNet", "MLPOn", "ZeroResidual", "build_residual", "RESIDUALS", "new_module",
           "from_registry", "refuse_instance", "is_zero_residual"]

_ACTIVATIONS = {"relu": nn.ReLU, "tanh": nn.Tanh, "elu": nn.ELU, "gelu": nn.GELU,
                "silu": nn.SiLU, "leaky_relu": nn.LeakyReLU, "softplus": nn.Softplus}


def make_activation(name: str) -> nn.Module:
    try:
        return _ACTIVATIONS[name]()
    except KeyError:
        raise ValueError(
            f"Unknown activation {name!r}; choose one of {sorted(_ACTIVATIONS)}."
        ) from None


class MLP(nn.Module):
    """Feed-forward network over one or more inputs, flattened and concatenated.

    Parameters
    ----------
    in_shapes : sequence of tuple
        Per-sample shape of each input (``((2,),)`` for a pendulum state,
        ``((200, 3), (200,))`` for features and a science output).
    out_shape : tuple
        Per-sample output shape.
    hidden : sequence of int, default=(64, 64)
        Hidden layer widths.  The missing effect of a hybrid ODE is usually a
        smooth function of a few states; a wider network costs more per
        iteration (``benchmarks/speed/bench_time_to_answer.py`` measures the
        default path).
    activation : str
        Activation between layers.
    zero_init : bool, default=True
        Start the last layer at zero, so that a hybrid starts from the
        science model alone: over a long integration a random start can add a
        force that blows the trajectories up before any training step, and a
        network that starts at zero has nothing to trade with theta at the
        start.  False keeps PyTorch's random last layer.

    Notes
    -----
    The network reads its inputs standardised and writes its output in units
    of the data (see ``set_scales``, which ``fit`` calls with the scales
    the data carry): its weights stay of order one whatever units the
    science function is written in, so that the learning rate and the SAM
    radius mean the same in seconds or milliseconds.
    """

    def __init__(self, in_shapes: Sequence[tuple], out_shape: tuple,
                 hidden: Sequence[int] = (64, 64), activation: str = "relu", zero_init: bool = True):
        super().__init__()
        self.out_shape = tuple(out_shape)
        widths = [sum(math.prod(s) for s in in_shapes), *hidden, math.prod(out_shape)]
        layers = []
        for i, (n_in, n_out) in enumerate(zip(widths[:-1], widths[1:])):
            layers.append(nn.Linear(n_in, n_out))
            if i < len(widths) - 2:
                layers.append(make_activation(activation))
        self.net = nn.Sequential(*layers)
        self.register_buffer("in_shift", torch.zeros(widths[0]))
        self.register_buffer("in_scale", torch.ones(widths[0]))
        self.register_buffer("out_scale", torch.ones(widths[-1]))
        if zero_init:  # after the random initialisation: the seeded draws of the other layers stay the same
            with torch.no_grad():
                self.net[-1].weight.zero_()
                self.net[-1].bias.zero_()

    def __setstate__(self, state):  # a network pickled before it read scaled inputs: the identity
        super().__setstate__(state)
        linears = [m for m in self.net if isinstance(m, nn.Linear)]
        for name, size, value in (("in_shift", linears[0].in_features, 0.0),
                                  ("in_scale", linears[0].in_features, 1.0),
                                  ("out_scale", linears[-1].out_features, 1.0)):
            if name not in self._buffers:
                self.register_buffer(name, torch.full((size,), value, dtype=linears[0].weight.dtype))

    def set_scales(self, in_shift, in_scale, out_scale) -> None:
        """Read inputs as ``(x - in_shift) / in_scale`` and scale the output by ``out_scale``.

        Each is a number or one value per flattened input (output) entry.
        """
        with torch.no_grad():
            for buffer, value in ((self.in_shift, in_shift), (self.in_scale, in_scale),
                                  (self.out_scale, out_scale)):
                buffer.copy_(torch.as_tensor(value, dtype=buffer.dtype).expand_as(buffer))

    def forward(self, *inputs: torch.Tensor) -> torch.Tensor:
        batch = inputs[0].shape[0]
        flat = torch.cat([x.reshape(batch, -1) for x in inputs], dim=-1)
        out = self.net((flat - self.in_shift) / self.in_scale) * self.out_scale
        return out.reshape(batch, *self.out_shape)


class MaskedMLP(nn.Module):
    """An :class:`MLP` that changes only some components of the output (zero on the others).

    The fast RK4 path serves it too (its last layer is widened with zero rows there).

    Parameters
    ----------
    mlp : MLP
        Network with one output per chosen component.
    components : sequence of int
        Components of the flattened output it writes.
    out_shape : tuple
        Per-sample shape of the whole output.
    """

    def __init__(self, mlp: MLP, components: Sequence[int], out_shape: tuple):
        super().__init__()
        self.mlp, self.out_shape = mlp, tuple(out_shape)
        self.size = math.prod(self.out_shape)
        self.register_buffer("index", torch.as_tensor(list(components), dtype=torch.long))

    def forward(self, *inputs: torch.Tensor) -> torch.Tensor:
        part = self.mlp(*inputs)
        out = part.new_zeros(len(part), self.size)
        return out.index_copy(1, self.index, part).reshape(len(part), *self.out_shape)


class ConvNet(nn.Module):
    """Convolutional network for field states ``(channels, height, width)``.

    Kernel 3, batch norm without running statistics (as in APHYNITY, so train
    and evaluation behave alike and the SAM second pass cannot corrupt them).

    Parameters
    ----------
    in_shapes : sequence of tuple
        ``((C, H, W),)``; several inputs are stacked along channels.
    out_shape : tuple
        ``(C_out, H, W)``.
    hidden : sequence of int
        Hidden channel counts.
    activation : str
        Activation between layers.
    padding_mode : str
        ``"circular"`` for periodic domains, ``"replicate"`` for zero-flux.
    batch_norm : bool
        Batch normalisation after each hidden convolution, with the statistics of the batch at hand
        in training and in prediction alike (APHYNITY's setting): a field's prediction then depends
        on the fields predicted with it. ``False`` makes every prediction depend on its own sample only.
    """

    def __init__(self, in_shapes: Sequence[tuple], out_shape: tuple,
                 hidden: Sequence[int] = (16, 16), activation: str = "relu",
                 padding_mode: str = "circular", batch_norm: bool = True):
        super().__init__()
        channels = [sum(s[0] for s in in_shapes), *hidden, out_shape[0]]
        layers = []
        for i, (c_in, c_out) in enumerate(zip(channels[:-1], channels[1:])):
            layers.append(nn.Conv2d(c_in, c_out, 3, padding=1, padding_mode=padding_mode))
            if i < len(channels) - 2:
                layers += [nn.BatchNorm2d(c_out, track_running_stats=False)] if batch_norm else []
                layers.append(make_activation(activation))
        self.net = nn.Sequential(*layers)

    def forward(self, *inputs: torch.Tensor) -> torch.Tensor:
        return self.net(torch.cat(inputs, dim=1))


RESIDUALS: dict[str, type[nn.Module]] = {"mlp": MLP, "cnn": ConvNet}


class MLPOn:
    """Residual factory: an MLP that acts on some state components only (zero on the others).

    Physics often fixes part of the right-hand side exactly (``d angle/dt = velocity``); letting
    the network change it would let it re-define the hidden state.

    Parameters
    ----------
    components : list of int
        Components of the (flattened) output the network may change.
    hidden : tuple of int, default=(64, 64)
        Hidden layer widths.
    activation : str, default="tanh"
        Activation (smooth activations give smooth residuals, easier to explain).
    zero_init : bool, default=True
        Start the last layer at zero, so that training starts from the science model alone rather
        than from a random force the optimiser must first undo.
    """

    def __init__(self, components: Sequence[int], hidden: Sequence[int] = (64, 64), activation: str = "tanh",
                 zero_init: bool = True):
        self.components, self.hidden, self.activation = list(components), tuple(hidden), activation
        self.zero_init = zero_init

    def __call__(self, in_shapes, out_shape) -> nn.Module:
        size = math.prod(out_shape)
        if not self.components or not all(0 <= c < size for c in self.components):
            raise ValueError(f"MLPOn components {self.components} must index an output of size {size}.")
        mlp = MLP(in_shapes, (len(self.components),), self.hidden, self.activation)
        if self.zero_init:
            with torch.no_grad():
                mlp.net[-1].weight.zero_()
                mlp.net[-1].bias.zero_()
        return MaskedMLP(mlp, self.components, out_shape)

    def __repr__(self) -> str:
        return (f"MLPOn({self.components}, hidden={self.hidden}, activation={self.activation!r}, "
                f"zero_init={self.zero_init})")


class _Zero(nn.Module):
    """No network: zeros of the output shape (one parameter, never trained, keeps the optimiser content;
    a training with every theta held then only evaluates the loss)."""

    def __init__(self, out_shape):
        super().__init__()
        self.out_shape = tuple(out_shape)
        self.unused = nn.Parameter(torch.zeros(1), requires_grad=False)

    def forward(self, *inputs):
        return torch.zeros(len(inputs[0]), *self.out_shape, dtype=inputs[0].dtype, device=inputs[0].device)


def is_zero_residual(module: nn.Module) -> bool:
    """Whether ``module`` is the network :class:`ZeroResidual` builds (no network: the science model alone).

    A network of another kind is not, even one whose output starts at zero (``MLP(zero_init=True)``).
    """
    return isinstance(module, _Zero)


class ZeroResidual:
    """Residual factory of a network that contributes nothing: fits the science model alone."""

    def __call__(self, in_shapes, out_shape) -> nn.Module:
        return _Zero(out_shape)

    def __repr__(self) -> str:
        return "ZeroResidual()"


def new_module(module, what: str) -> nn.Module:
    """Check what a ``what`` factory returned: a torch Module it has not returned before.

    Shared by the residual and theta-encoder specifications: ``lambda: net``
    would hand every fit (and every clone in a search) the same network.
    """
    name = type(module).__name__
    if not isinstance(module, nn.Module):
        raise TypeError(f"The {what} factory returned {name}, expected a torch.nn.Module.")
    if getattr(module, "_sklearn_hybrid_built", False):
        raise ValueError(
            f"The {what} factory returned a {name} it had returned before; it must build a new "
            f"network at each call (e.g. `lambda: {name}(...)`, not `lambda: net`)."
        )
    module._sklearn_hybrid_built = True
    return module


def refuse_instance(what: str, spec, example: str) -> None:
    """Raise a TypeError when ``spec`` is a module instance rather than a factory: a fit must start from a
    fresh network, and a clone must not share one.  ``example`` shows the factory's call, ``{name}`` standing
    for the instance's class.  Shared by the residual and theta-encoder specifications."""
    if isinstance(spec, nn.Module):
        name = type(spec).__name__
        raise TypeError(
            f"{what} is a {name} instance. Pass a factory rather than a module instance, "
            f"e.g. {example.format(name=name)}, so that every fit starts from a fresh network and "
            "the estimator stays clonable."
        )


def from_registry(what: str, spec, registry: dict, args: tuple, dtype: torch.dtype) -> nn.Module:
    """Build ``registry[kind](*args, **options)`` from a name or a dict ``{"kind": ..., **options}``.

    Shared by the residual and theta-encoder specifications; ``what`` names the
    parameter in the messages.
    """
    options = {"kind": spec} if isinstance(spec, str) else dict(spec) if isinstance(spec, dict) else None
    if options is None:
        raise TypeError(
            f"{what} must be a name {sorted(registry)}, a dict of options or a factory, "
            f"got {type(spec).__name__}. Pass a factory rather than a module instance, "
            "so that every fit starts from a fresh network."
        )
    kind = options.pop("kind", "mlp")
    if kind not in registry:
        raise ValueError(f"Unknown {what} kind {kind!r}; choose one of {sorted(registry)}.")
    try:
        return registry[kind](*args, **options).to(dtype)
    except TypeError as exc:
        raise ValueError(f"Invalid options for {what} {kind!r}: {exc}") from None


def _takes_arguments(factory) -> bool:
    """Whether a factory has required positional arguments (the shapes) or takes none."""
    try:
        params = inspect.signature(factory).parameters.values()
    except (TypeError, ValueError):  # no signature to read: the documented two-argument call
        return True
    return any(p.kind in (p.POSITIONAL_ONLY, p.POSITIONAL_OR_KEYWORD, p.VAR_POSITIONAL)
               and p.default is p.empty for p in params)


def build_residual(spec, in_shapes: Sequence[tuple] | None, out_shape: tuple | None,
                   dtype: torch.dtype = torch.float32) -> nn.Module:
    """Build the residual network from its specification.

    Parameters
    ----------
    spec : str, dict or callable
        ``"mlp"`` or ``"cnn"``; a dict such as ``{"kind": "mlp", "hidden":
        (64, 64), "activation": "tanh"}``; or a factory returning a new
        ``torch.nn.Module`` at each call.  A factory with required positional
        arguments is called as ``factory(in_shapes, out_shape)`` by the
        built-in structures; one without (``lambda: MyNet()``) with none, as
        always for a user-supplied composition (``in_shapes is None``).
    in_shapes, out_shape : tuple or None
        Per-sample shapes the structure feeds in and expects back.
    dtype : torch.dtype
        Floating point type of the parameters.

    Returns
    -------
    torch.nn.Module
    """
    refuse_instance("residual", spec, "`residual=lambda: {name}(...)` (a new network each call) or "
                    "`residual=lambda in_shapes, out_shape: ...`")
    if callable(spec):
        wants_shapes = in_shapes is not None and _takes_arguments(spec)
        module = spec(tuple(in_shapes), tuple(out_shape)) if wants_shapes else spec()
        module = new_module(module, "residual").to(dtype)
    elif in_shapes is None:
        raise ValueError(
            "A user-supplied structure needs `residual` to be a factory returning a "
            "torch.nn.Module (called with no arguments)."
        )
    else:
        module = from_registry("residual", spec, RESIDUALS, (in_shapes, out_shape), dtype)
    if in_shapes is not None:
        _check_output(module, in_shapes, out_shape, dtype)
    return module


def _check_output(residual: nn.Module, in_shapes, out_shape, dtype) -> None:
    """Run the network once on zeros, so that a network unfit for the structure's inputs or
    outputs is named here rather than by a reshape deep inside training."""
    probe = [torch.zeros((2, *shape), dtype=dtype) for shape in in_shapes]
    training = residual.training
    residual.eval()  # no BatchNorm statistics from the zeros
    try:
        with torch.no_grad(), torch.random.fork_rng(devices=[]):  # the seeded initialisation goes on as before
            out = residual(*probe)
    except Exception as error:
        raise ValueError(f"The residual network fails on inputs of per-sample shape(s) {list(in_shapes)}: "
                         f"{type(error).__name__}: {error}") from error
    finally:
        residual.train(training)
    if not torch.is_tensor(out) or out.shape[:1] != (2,) or out[0].numel() != math.prod(out_shape):
        got = tuple(out.shape[1:]) if torch.is_tensor(out) else type(out).__name__
        raise ValueError(f"The residual network returns {got} per sample for inputs of per-sample shape(s) "
                         f"{list(in_shapes)}; the structure adds it to an output of shape {tuple(out_shape)}.")
