"""Fast RK4 for hybrid ODEs whose network is an MLP over a small state.

Backpropagating through ``n_steps * n_substeps * 4`` small network
evaluations with autograd costs far more in per-operation overhead than in
arithmetic (about 2.5x on one CPU core for the pendulum).  This module
computes exactly the same gradient with a different schedule (the loops are
in :mod:`sklearn_hybrid.integrate.kernels`):

1. forward: the classic RK4 loop (the same arithmetic as
   :func:`sklearn_hybrid.integrate.integrate`), storing each stage's state and
   the network's activations in reused buffers, without an autograd graph;
2. backward: the science function's per-sample Jacobians ``d f / d v`` of
   every stage come from one vectorised call over all stages (cheap when the
   state has only a few components), so the sequential reverse sweep through
   the RK4 steps is a handful of small products per stage; the network's
   weight gradients are accumulated in large products over many stages, and
   theta's gradient is one vector-Jacobian product over all stages.

Every tensor carries a leading *member* axis ``K``: ``K = 1`` is a single
fit, ``K > 1`` trains K independent configurations as one stacked model (see
:class:`sklearn_hybrid.HybridRegressorCV`), each getting exactly the
gradient it would get alone.

Requirements (checked by :func:`supports`): the network is the package's
:class:`~sklearn_hybrid.residual.MLP` with biases, the state is a vector of at
most :data:`MAX_STATE` components, and the science function treats the
samples of a batch independently (row-wise), as physical models do.
"""

from __future__ import annotations

import threading
import weakref
from contextlib import contextmanager
from dataclasses import dataclass, field
from typing import Callable

import torch
from torch import nn

from . import kernels
from .solve import integrate
from ..residual import MLP, MaskedMLP

__all__ = ["supports", "mlp_parts", "mlp_scales", "full_output", "ode_states", "disabled", "row_by_row"]

#: Largest state size served (the Jacobians cost ``MAX_STATE`` forward passes).
MAX_STATE = 8

# per thread: fits run side by side in threads (joblib's threading and Dask backends), and
# one thread's disabled() must neither reach nor, on exit, undo another's
_STATE = threading.local()


@contextmanager
def disabled():
    """Use the generic autograd integrator inside this block, in this thread."""
    previous, _STATE.enabled = getattr(_STATE, "enabled", True), False
    try:
        yield
    finally:
        _STATE.enabled = previous


def mlp_parts(module: nn.Module):
    """Weights, biases and activations of an :class:`MLP` (or the one inside a
    :class:`MaskedMLP`, see :func:`full_output`), or None if it has another layout."""
    if type(module) is MaskedMLP:
        module = module.mlp
    if type(module) is not MLP:
        return None
    layers = list(module.net)
    linears, acts = layers[0::2], layers[1::2]
    if not all(isinstance(m, nn.Linear) and m.bias is not None for m in linears):
        return None
    if any(isinstance(m, nn.Linear) or list(m.parameters()) for m in acts):
        return None  # only parameter-free, elementwise activations between layers
    return [m.weight for m in linears], [m.bias for m in linears], acts


def mlp_scales(module: nn.Module) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
    """The input shift and scale and the output scale of an :class:`MLP` (or the one in a :class:`MaskedMLP`)."""
    mlp = module.mlp if type(module) is MaskedMLP else module
    return mlp.in_shift, mlp.in_scale, mlp.out_scale


def full_output(residual: nn.Module, weights: list, biases: list, scales: tuple | None = None
                ) -> tuple[list, list]:
    """The layers the kernels compute with: the network's scales folded in, a :class:`MaskedMLP`'s last
    layer widened to the whole output (zero rows elsewhere).

    ``(W x - ...)`` over standardised inputs is ``W / s`` over raw ones with the bias shifted, and an output
    scale multiplies the last layer's rows: folded here differentiably, so the gradients reach the network's
    own weights.  ``scales`` are :func:`mlp_scales` with a leading member axis (stacked members, each its
    own), default the network's own.  Widening is differentiable (``index_copy``), so the exact components
    get no output and their rows no gradient; works with a leading member axis.
    """
    shift, scale, out = mlp_scales(residual) if scales is None else scales
    first_W = weights[0] / scale.unsqueeze(-2)
    first_b = biases[0] - (first_W @ shift.unsqueeze(-1)).squeeze(-1)
    weights, biases = [first_W, *weights[1:]], [first_b, *biases[1:]]
    weights[-1], biases[-1] = weights[-1] * out.unsqueeze(-1), biases[-1] * out
    if type(residual) is not MaskedMLP:
        return weights, biases
    W, b, index = weights[-1], biases[-1], residual.index
    wide_W = W.new_zeros(*W.shape[:-2], residual.size, W.shape[-1]).index_copy(-2, index, W)
    wide_b = b.new_zeros(*b.shape[:-1], residual.size).index_copy(-1, index, b)
    return [*weights[:-1], wide_W], [*biases[:-1], wide_b]


def supports(residual: nn.Module, state_shape: tuple, solver: str) -> bool:
    """Whether the fast path serves this network, state and solver.

    CPU only: its kernels are laid out for a CPU's matrix library; on a GPU
    the plain autograd loop runs (batched products are what a GPU is good at).
    """
    parts = mlp_parts(residual)
    return (getattr(_STATE, "enabled", True) and solver == "rk4" and len(state_shape) == 1
            and state_shape[0] <= MAX_STATE and parts is not None
            and parts[0][0].device.type == "cpu")


@dataclass
class _Config:
    func: Callable
    names: list
    acts: list
    n_steps: int
    dt: float
    n_substeps: int
    n_theta: int
    #: per hidden layer: ReLU, whose output alone determines its derivative
    relu: list = field(init=False)

    def __post_init__(self):
        self.relu = [type(a) is nn.ReLU for a in self.acts]

    def science(self, v, u, thetas):
        """``func`` on member-stacked states ``v`` (K, N, d) with per-member theta."""
        K = v.shape[0]
        if K == 1:
            args = (v[0],) if u is None else (v[0], u[0])
            return self.func(*args, **dict(zip(self.names, (t[0] for t in thetas))))[None]

        def one(v_, u_, *th):
            args = (v_,) if u_ is None else (v_, u_)
            return self.func(*args, **dict(zip(self.names, th)))

        in_u = None if u is None else 0
        return torch.func.vmap(one, in_dims=(0, in_u) + (0,) * len(thetas))(v, u, *thetas)


def _stage_input_index(n_steps, n_substeps):
    """Index on the half-step input grid of each RK4 stage, in order."""
    idx = []
    for s in range(n_steps * n_substeps):
        idx += [2 * s, 2 * s + 1, 2 * s + 1, 2 * s + 2]
    return torch.tensor(idx)


def _science_jacobian(cfg, v_all, u_all, thetas, need_theta):
    """Per-sample Jacobian ``jac[k, n, j, i] = d f_i / d v_j`` of the science part (it acts
    row by row), and its output with a graph back to theta for the theta gradient."""
    K, N, d = v_all.shape
    with torch.enable_grad():
        v = v_all.detach().requires_grad_()
        leaves = [t.detach().requires_grad_(need_theta) for t in thetas]
        f = cfg.science(v, u_all, leaves)
        jac = v.new_empty(K, N, d, d)
        for i in range(d):
            # allow_unused: a science that reads only the inputs (a cart pushed by a thrust) does not use v
            (grad,) = torch.autograd.grad(f[..., i].sum(), v, retain_graph=True, allow_unused=True)
            jac[..., i] = 0.0 if grad is None else grad
    return jac, f, leaves


def _activations(hidden, cfg):
    """Per hidden layer, the activations and (None for ReLU, decided by its output) slopes."""
    acts, slopes = [], []
    for z, act, relu in zip(hidden, cfg.acts, cfg.relu):
        if relu:
            acts.append(z)
            slopes.append(None)
            continue
        with torch.enable_grad():
            z = z.detach().requires_grad_()
            a = act(z)
            (slope,) = torch.autograd.grad(a, z, torch.ones_like(a))
        acts.append(a.detach())
        slopes.append(slope)
    return acts, slopes


class _OdeMLP(torch.autograd.Function):
    """States at the output times; gradients by the schedule in the module docstring."""

    @staticmethod
    def forward(ctx, cfg, x0, u_fine, *tensors):
        thetas = tensors[: cfg.n_theta]
        weights, biases = tensors[cfg.n_theta::2], tensors[cfg.n_theta + 1::2]
        K, d = x0.shape[0], x0.shape[-1]
        p_in = None
        if u_fine is not None:  # inputs' share of the first layer, for every grid point
            w_u = weights[0][:, None, :, d:].transpose(-1, -2)  # (K, 1, n_inputs, w1)
            p_in = torch.matmul(u_fine, w_u) + biases[0][:, None, None]
        if K == 1:
            with torch.inference_mode():  # lighter per-operation bookkeeping than no_grad
                out, states, hidden = kernels.forward_one(
                    cfg, x0[0], None if u_fine is None else u_fine[0],
                    None if p_in is None else p_in[0], [t[0] for t in thetas],
                    [w[0] for w in weights], [b[0] for b in biases])
            # stacked outside inference mode: an ordinary tensor, which autograd may keep
            out = torch.stack(out, 1)[None]
        else:
            with torch.no_grad():
                out, states, hidden = kernels.forward_stacked(cfg, x0, u_fine, p_in, thetas,
                                                               weights, biases)
        ctx.cfg, ctx.released = cfg, False
        ctx.save_for_backward(x0, u_fine, states, *hidden, *tensors)
        ctx.n_hidden = len(hidden)
        return out

    @staticmethod
    @torch.autograd.function.once_differentiable
    def backward(ctx, grad_out):
        cfg = ctx.cfg
        x0, u_fine, states, *rest = ctx.saved_tensors
        hidden, tensors = rest[: ctx.n_hidden], rest[ctx.n_hidden:]
        thetas = tensors[: cfg.n_theta]
        weights = tensors[cfg.n_theta::2]
        K, B, d = x0.shape
        S = 4 * cfg.n_steps * cfg.n_substeps
        N = S * B
        if ctx.released:
            raise RuntimeError("The fast RK4 cannot be backpropagated twice.")
        # states are stage-major: (S, B, d) for one member, (n_steps, C, K, B, d) for several
        v_all = states.reshape(S, K, B, d).transpose(0, 1).reshape(K, N, d)
        u_all = None  # inputs at every stage, member-major
        if u_fine is not None:
            u_all = u_fine[:, :, _stage_input_index(cfg.n_steps, cfg.n_substeps)]
            u_all = u_all.transpose(1, 2).reshape(K, N, -1)
        need_theta = any(ctx.needs_input_grad[3:3 + cfg.n_theta])
        jac, f, leaves = _science_jacobian(cfg, v_all, u_all, thetas, need_theta)
        acts, slopes = _activations(hidden, cfg)
        h = cfg.dt / cfg.n_substeps

        if K == 1:  # 2-D tensors; weight gradients as one product over all stages
            deltas = [kernels.take((S, B, w.shape[1]), grad_out.dtype) for w in weights[:-1]]
            deltas.append(grad_out.new_empty(S, B, d))
            with torch.inference_mode():
                adj = kernels.backward_one(grad_out[0], jac.view(S, B, d, d), acts, slopes,
                                            [w[0] for w in weights], deltas, h, cfg.n_substeps)
            adj = adj[None].clone()
            layer_inputs = [v_all if u_all is None else torch.cat([v_all, u_all], -1)]
            layer_inputs += [a.view(1, N, -1) for a in acts]
            net_grads = []
            for delta, inputs, w in zip(deltas, layer_inputs, weights):
                delta = delta.view(1, N, -1)
                grad_w = kernels.weight_grad_buffer(w)
                kernels.accumulate_weight_grad(grad_w, delta, inputs)
                net_grads += [grad_w.contiguous(), delta.sum(1)]
            cots = deltas[-1].view(1, N, d)
            kernels.release(*deltas[:-1])
        else:
            C = 4 * cfg.n_substeps

            def interval_major(t):  # member-major (K, N, ...) -> (n_steps, K, C, B, ...)
                return t.reshape(K, cfg.n_steps, C, B, *t.shape[2:]).transpose(0, 1)

            with torch.no_grad():
                u_stage = None if u_all is None else interval_major(u_all)
                stage_jac = jac.view(K, S, B, d, d).transpose(0, 1).contiguous().view(
                    cfg.n_steps, C, K, B, d, d)
                adj, cots, grad_w, grad_b = kernels.backward_stacked(
                    cfg, grad_out, states, acts, slopes, stage_jac, weights, u_stage)
            net_grads = [g for pair in zip(grad_w, grad_b) for g in pair]
            cots = cots.view(S, K, B, d).transpose(0, 1).reshape(K, N, d)
        kernels.release(states, *hidden)
        ctx.released = True

        grads = [None] * cfg.n_theta
        if need_theta:
            with torch.enable_grad():
                grads = list(torch.autograd.grad(f, leaves, cots, allow_unused=True))
        grad_x0 = adj if ctx.needs_input_grad[1] else None
        return (None, grad_x0, None, *grads, *net_grads)


def ode_states(func: Callable, names: list, thetas: list, weights: list, biases: list,
               acts: list, x0: torch.Tensor, u_fine: torch.Tensor | None, n_steps: int,
               dt: float, n_substeps: int) -> torch.Tensor:
    """RK4 states of ``dv/dt = func(v[, u], **theta) + mlp(v[, u])`` for K stacked members.

    Parameters
    ----------
    func : callable
        The science function.
    names : list of str
        Names of theta, in the order of ``thetas``.
    thetas : list of Tensor of shape (K, ...)
        Parameter values per member.
    weights, biases : list of Tensor of shape (K, out, in) and (K, out)
        The MLP's layers per member.
    acts : list of nn.Module
        Elementwise activations between the layers.
    x0 : Tensor of shape (K, B, d)
        Initial states.
    u_fine : Tensor of shape (K, B, 2 * n_substeps * n_steps + 1, n_inputs) or None
        Inputs on the half-step grid.
    n_steps, dt, n_substeps
        Output grid and RK4 steps per output interval.

    Returns
    -------
    Tensor of shape (K, B, n_steps, d)
    """
    cfg = _Config(func, list(names), list(acts), n_steps, float(dt), n_substeps, len(thetas))
    tensors = list(thetas)
    for w, b in zip(weights, biases):
        tensors += [w, b]
    return _OdeMLP.apply(cfg, x0, u_fine, *tensors)


_ROW_BY_ROW = weakref.WeakKeyDictionary()  # science function -> acts on rows independently


def row_by_row(func, x0, u_fine, theta) -> bool:
    """Whether the science function treats samples independently (checked once, on two rows)."""
    try:
        return _ROW_BY_ROW[func]
    except (KeyError, TypeError):
        pass
    if len(x0) < 2:
        return True
    with torch.no_grad():
        args = (x0[:2],) if u_fine is None else (x0[:2], u_fine[:2, 0])
        both = func(*args, **theta)
        alone = torch.cat([func(*(a[i:i + 1] for a in args), **theta) for i in range(2)])
    result = bool(both.shape == alone.shape and torch.allclose(both, alone, rtol=1e-5, atol=1e-7))
    try:
        _ROW_BY_ROW[func] = result
    except TypeError:  # not weak-referenceable: check every time
        pass
    return result


def hybrid_states(science: nn.Module, residual: nn.Module, x0: torch.Tensor,
                  u_fine: torch.Tensor | None, n_steps: int, dt: float,
                  n_substeps: int) -> torch.Tensor:
    """:func:`ode_states` for one fitted model (a ScienceModel and an MLP); (B, n_steps, d).

    A science function that mixes samples (against the row-by-row contract
    the Jacobians rely on) is integrated with plain autograd instead.
    """
    values = science.values()
    if not row_by_row(science.func, x0, u_fine, values):
        def rhs(v, u):
            return science(*_args(v, u)) + residual(*_args(v, u))

        return integrate(rhs, x0, n_steps, dt, n_substeps=n_substeps, u_fine=u_fine)
    weights, biases, acts = mlp_parts(residual)
    weights, biases = full_output(residual, weights, biases)
    thetas = [values[n][None] for n in science.names]
    return ode_states(science.func, science.names, thetas, [w[None] for w in weights],
                      [b[None] for b in biases], acts, x0[None],
                      None if u_fine is None else u_fine[None], n_steps, dt, n_substeps)[0]


_ELEMENTWISE = {nn.Tanh: torch.tanh, nn.ReLU: torch.relu, nn.Sigmoid: torch.sigmoid,
                nn.SiLU: nn.functional.silu, nn.GELU: nn.functional.gelu}


def frozen_rhs(science: nn.Module, residual: nn.Module | None,
               mask: torch.Tensor | None = None) -> Callable | None:
    """``rhs(v, u)`` for integration without gradients (simulate, predict), or None if not served
    (gradients on, the fast path disabled, or a science model without a shared theta).

    Long free runs call the right-hand side tens of thousands of times; module dispatch and
    re-deriving theta through its bounded map at every call cost more than the arithmetic
    (about half of each call for the Silverbox model). Here theta is read once and the MLP is
    a chain of ``addmm`` (other networks are called as modules). ``residual`` None: the science
    part alone; ``mask``: the network's output times it (per sample: 1 hybrid, 0 science alone).
    """
    if (torch.is_grad_enabled() or not getattr(_STATE, "enabled", True)
            or not (hasattr(science, "func") and hasattr(science, "values"))):
        return None
    theta = {k: v.detach() for k, v in science.values().items()}
    func = science.func
    if residual is None:
        return lambda v, u: func(*_args(v, u), **theta)
    parts = mlp_parts(residual)
    if parts is None:  # another network: called as a module, theta still read once
        if mask is not None:
            return lambda v, u: func(*_args(v, u), **theta) + mask * residual(*_args(v, u))
        return lambda v, u: func(*_args(v, u), **theta) + residual(*_args(v, u))
    weights, biases = full_output(residual, *parts[:2])
    weights_t = [w.detach().t().contiguous() for w in weights]
    biases = [b.detach() for b in biases]
    acts = [_ELEMENTWISE.get(type(a), a) for a in parts[2]]
    out_shape = residual.out_shape

    def rhs(v, u):
        args = _args(v, u)
        h = torch.cat([a.reshape(len(v), -1) for a in args], dim=-1)
        for i, (w, b) in enumerate(zip(weights_t, biases)):
            h = torch.addmm(b, h, w)
            if i < len(acts):
                h = acts[i](h)
        h = h.reshape(len(v), *out_shape)
        return func(*args, **theta) + (h if mask is None else mask * h)

    return rhs


def _args(v, u):
    """The right-hand side's inputs: the state, and the input of a forced system."""
    return (v,) if u is None else (v, u)
