"""The RK4 loops of :mod:`sklearn_hybrid.integrate.fast`: one member, or K stacked members in one pass.

One member (:func:`forward_one`, :func:`backward_one`) runs on 2-D tensors,
where every operation's cost is dispatch.  With K members
(:func:`forward_stacked`, :func:`backward_stacked`) every operation carries
K small problems, so the cost moves to arithmetic and memory traffic.  Hence:

* explicit batched products (``baddbmm``), not ``vmap``, in the stage loop,
  with every skinny matrix stored with its long axis contiguous
  (:func:`long_axis_contiguous`: MKL multiplies them several times faster so);
* two layouts, each where it saves copies: per-stage tensors (states,
  science Jacobians, rhs cotangents) *stage-major* ``(n_steps, C, K, B,
  ...)``, so each stage's ``K * B`` rows are one contiguous block the
  science function and the tiny Jacobian products take without a copy; the
  hidden layers *member-major* per output interval ``(n_steps, K, C, B,
  w)``, so the wide layers' weight gradients are accumulated once per
  interval by products with an inner dimension of ``C * B``;
* the stored stages in buffers reused within a fit (:func:`take`,
  :func:`reusing_buffers`);
* the science function called once per stage on the ``K * B`` states with
  theta repeated per row when it broadcasts that way (checked on probe
  values with distinct theta per member), through :func:`torch.func.vmap`
  otherwise.
"""

from __future__ import annotations

import weakref
from contextlib import contextmanager

import torch

__all__ = ["forward_one", "backward_one", "forward_stacked", "backward_stacked", "rk4_step", "take",
           "release", "reusing_buffers", "long_axis_contiguous", "accumulate_weight_grad"]

_relu_backward_out = torch.ops.aten.threshold_backward.grad_input
_ROWWISE = weakref.WeakKeyDictionary()  # science function -> {shape key: broadcasts per row}
_POOL: dict = {}  # (shape, dtype) -> free buffers
_POOL_DEPTH = 4


def long_axis_contiguous(m: torch.Tensor) -> torch.Tensor:
    """The same matrices (last two axes), stored with the longer axis contiguous.

    MKL multiplies a skinny matrix such as a (128, 2) weight block two to
    three times faster when its long axis has stride 1.
    """
    if m.shape[-1] >= m.shape[-2]:
        return m if m.stride(-1) == 1 else m.contiguous()
    return m if m.stride(-2) == 1 else m.transpose(-1, -2).contiguous().transpose(-1, -2)


def weight_grad_buffer(weight: torch.Tensor) -> torch.Tensor:
    """Zeros shaped like ``weight`` (K, out, in), laid out for :func:`accumulate_weight_grad`."""
    return long_axis_contiguous(torch.zeros_like(weight, memory_format=torch.contiguous_format))


def accumulate_weight_grad(acc: torch.Tensor, delta: torch.Tensor, inputs: torch.Tensor) -> None:
    """``acc += delta^T inputs`` for delta (K, R, out) and inputs (K, R, in), in place.

    The product is taken with the output's long axis last (``inputs^T delta``
    into the transposed view when ``in < out``): 7x faster for a (128, 2) block.
    """
    if acc.shape[-2] > acc.shape[-1]:
        acc.transpose(-1, -2).baddbmm_(inputs.transpose(-1, -2), delta)
    else:
        acc.baddbmm_(delta.transpose(-1, -2), inputs)


def take(shape, dtype):
    """An uninitialised buffer, reused from :func:`release` when one of that shape is free.

    Fresh large allocations cost a page fault per 4 KiB on first touch
    (about 1.5 us each on the machines measured, several ms per gradient
    evaluation for the stored stages).
    """
    free = _POOL.get((tuple(shape), dtype))
    if free:
        return free.pop()
    with torch.inference_mode(False):  # an ordinary tensor, which autograd may save
        return torch.empty(shape, dtype=dtype)


@contextmanager
def reusing_buffers():
    """Keep released buffers for reuse inside this block (a fit); free them all at its end."""
    try:
        yield
    finally:
        _POOL.clear()


def release(*buffers):
    """Return buffers of :func:`forward_stacked` for reuse (once backward no longer needs them)."""
    for t in buffers:
        free = _POOL.setdefault((tuple(t.shape), t.dtype), [])
        if len(free) < _POOL_DEPTH:
            free.append(t)


def _rowwise_call(cfg, thetas, B):
    rows = dict(zip(cfg.names, (t.repeat_interleave(B, 0) for t in thetas)))

    def call(v, u):
        K, _, d = v.shape
        args = (v.reshape(K * B, d),) if u is None else (v.reshape(K * B, d), u.reshape(K * B, -1))
        return cfg.func(*args, **rows).view(K, B, d)

    return call


def _rowwise_ok(cfg, thetas, x0, u0):
    """Whether ``func(v_flat, **theta_per_row)`` equals the per-member (vmap) call."""
    K, B, d = x0.shape
    key = (K, B, d, x0.dtype, tuple(tuple(t.shape) for t in thetas), u0 is None)
    try:
        known = _ROWWISE.setdefault(cfg.func, {})
    except TypeError:  # not weak-referenceable: decide every time
        known = {}
    if key not in known:
        # distinct theta per member, so that a wrong broadcast cannot agree by chance
        spread = torch.arange(1, K + 1, dtype=x0.dtype) / (7 * K)
        probe = [t * (1 + spread.view(-1, *[1] * (t.dim() - 1))) + spread.view(-1, *[1] * (t.dim() - 1))
                 for t in thetas]
        expected = cfg.science(x0, u0, probe)
        try:
            got = _rowwise_call(cfg, probe, B)(x0, u0)
            known[key] = bool(got.shape == expected.shape
                              and torch.allclose(got, expected, rtol=1e-5, atol=1e-6))
        except Exception:  # noqa: BLE001 - any failure means: use vmap
            known[key] = False
    return known[key]


def _science_caller(cfg, thetas, x0, u_fine):
    u0 = None if u_fine is None else u_fine[:, :, 0]
    if _rowwise_ok(cfg, thetas, x0, u0):
        return _rowwise_call(cfg, thetas, x0.shape[1])
    return lambda v, u: cfg.science(v, u, thetas)


def rk4_step(rhs, x, st, c, j, h):
    """One classic RK4 step from ``x`` (the arithmetic of ``integrate._rk4``, fused multiply-adds).

    The four stage inputs are written into ``st[c:c + 4]``; ``rhs(c, j)``
    evaluates the right-hand side at stage input ``st[c]`` and the input grid
    point ``j`` (steps are half a sub-step apart on that grid).
    """
    st[c].copy_(x)
    k1 = rhs(c, j)
    torch.add(x, k1, alpha=0.5 * h, out=st[c + 1])
    k2 = rhs(c + 1, j + 1)
    torch.add(x, k2, alpha=0.5 * h, out=st[c + 2])
    k3 = rhs(c + 2, j + 1)
    torch.add(x, k3, alpha=h, out=st[c + 3])
    k4 = rhs(c + 3, j + 2)
    k = torch.add(k1, k2.add_(k3), alpha=2.0).add_(k4)
    return torch.add(x, k, alpha=h / 6.0)


def forward_one(cfg, x, u, p_in, thetas, weights, biases):
    """RK4 of one member: x (B, d); u (B, F, n_u) or None; p_in (B, F, w1) or None.

    ``p_in`` is the inputs' contribution to the first layer (bias included),
    computed for the whole input grid at once.  Returns the outputs per
    output time (a list, stacked by the caller outside inference mode), the
    states per stage (S, B, d) and, per hidden layer, its activations (ReLU)
    or pre-activations per stage (S, B, w), in buffers of the pool.
    """
    B, d = x.shape
    S = 4 * cfg.n_steps * cfg.n_substeps
    theta = dict(zip(cfg.names, thetas))
    w_t = [long_axis_contiguous(w.t()) for w in weights]
    w1v_t = w_t[0][:d]  # first-layer rows that see the state
    n_hidden = len(weights) - 1
    relu = cfg.relu
    # the function, not the module: a module call costs as much as the ReLU itself
    act_fns = [torch.relu if r else a for r, a in zip(relu, cfg.acts)]
    states = take((S, B, d), x.dtype)
    hidden = [take((S, B, w.shape[0]), x.dtype) for w in weights[:-1]]
    st, hid = states.unbind(0), [t.unbind(0) for t in hidden]
    # views per input grid point, taken once rather than per stage
    u_at = None if u is None else u.unbind(1)
    p_at = None if p_in is None else p_in.unbind(1)

    def rhs(c, j):
        v = st[c]
        if u is None:
            z = torch.addmm(biases[0], v, w_t[0])
            f = cfg.func(v, **theta)
        else:
            z = torch.addmm(p_at[j], v, w1v_t)
            f = cfg.func(v, u_at[j], **theta)
        for layer in range(n_hidden):
            if relu[layer]:
                a = torch.clamp_min(z, 0, out=hid[layer][c])
            else:
                hid[layer][c].copy_(z)  # backward needs the pre-activations
                a = act_fns[layer](z)
            z = torch.addmm(biases[layer + 1], a, w_t[layer + 1])
        return f + z

    h = cfg.dt / cfg.n_substeps
    outputs = []
    for n in range(cfg.n_steps):
        for sub in range(cfg.n_substeps):
            step = n * cfg.n_substeps + sub
            x = rk4_step(rhs, x, st, 4 * step, 2 * step, h)
        outputs.append(x)
    return outputs, states, hidden


def backward_one(grad_out, jac, acts, slopes, weights, cots, h, n_substeps):
    """Backpropagate one member through the RK4 steps, filling ``cots``; returns d loss / d x0.

    ``jac`` is (S, B, d, d); ``acts[l]``/``slopes[l]`` hold hidden layer l's
    activations and derivatives (``slopes[l]`` None for ReLU, whose
    activations decide); ``cots[l]`` (S, B, w_l)
    receives the cotangent of layer l's output at every stage (the last
    layer's is that of the whole rhs).  The loop's cost is dispatch, not
    arithmetic, so it uses only primitive operations and no Python scalars.
    """
    B, d = jac.shape[1], jac.shape[-1]
    jac, cots = jac.unbind(0), [t.unbind(0) for t in cots]
    acts = [t.unbind(0) for t in acts]
    slopes = [None if t is None else t.unbind(0) for t in slopes]
    w_state = long_axis_contiguous(weights[0][:, :d])
    n_hidden = len(weights) - 1
    # d x' / d k_i of x' = x + h/6 (k1 + 2 k2 + 2 k3 + k4), as tensors: a Python
    # scalar costs a tensor construction in every operation
    coef = [torch.tensor(c, dtype=grad_out.dtype) for c in (h / 6, h / 3, h / 3, h / 6)]
    back = [None, 0.5 * h, 0.5 * h, h]  # stage i's input is x + back[i] * k_{i-1}
    outputs = grad_out.unbind(1)
    adj = torch.zeros_like(outputs[0])
    s = len(jac)
    for n in reversed(range(len(outputs))):
        adj = adj + outputs[n]
        for _ in range(n_substeps):
            s -= 4
            cs = [torch.mul(adj, coef[i], out=cots[-1][s + i]) for i in range(4)]
            for i in (3, 2, 1, 0):
                g = torch.bmm(jac[s + i], cs[i].view(B, d, 1)).view(B, d)  # tiny per-sample products
                delta = cs[i]
                for layer in reversed(range(n_hidden)):
                    delta = torch.mm(delta, weights[layer + 1], out=cots[layer][s + i])
                    if slopes[layer] is None:
                        _relu_backward_out(delta, acts[layer][s + i], 0.0, grad_input=delta)
                    else:
                        delta.mul_(slopes[layer][s + i])
                g = torch.addmm(g, delta, w_state)  # d loss / d (stage input)
                adj = adj + g
                if i:
                    cs[i - 1].add_(g, alpha=back[i])
    return adj


def forward_stacked(cfg, x0, u_fine, p_in, thetas, weights, biases):
    """RK4 of K members; returns outputs (K, B, n_steps, d), states and hidden buffers.

    ``states`` is stage-major (n_steps, C, K, B, d) with ``C = 4 n_substeps``;
    ``hidden[l]`` is member-major (n_steps, K, C, B, w_l) and holds layer l's
    activations where ``cfg.relu[l]``, its pre-activations otherwise.
    """
    K, B, d = x0.shape
    n_hidden, C = len(weights) - 1, 4 * cfg.n_substeps
    relu, acts = cfg.relu, cfg.acts
    states = take((cfg.n_steps, C, K, B, d), x0.dtype)
    hidden = [take((cfg.n_steps, K, C, B, w.shape[1]), x0.dtype) for w in weights[:-1]]
    science = _science_caller(cfg, thetas, x0, u_fine)
    w_t = [long_axis_contiguous(w.transpose(1, 2)) for w in weights]
    w_state = w_t[0][:, :d]
    bias = [b[:, None] for b in biases]
    p_at = None if p_in is None else p_in.unbind(2)
    u_at = None if u_fine is None else u_fine.unbind(2)
    h = cfg.dt / cfg.n_substeps
    x, outputs = x0, []
    for n in range(cfg.n_steps):
        st, hid = states[n], [t[n].unbind(1) for t in hidden]

        def rhs(c, j):
            v = st[c]
            z = torch.baddbmm(bias[0] if p_at is None else p_at[j], v, w_state)
            for layer in range(n_hidden):
                if relu[layer]:
                    a = torch.clamp_min(z, 0, out=hid[layer][c])
                else:
                    hid[layer][c].copy_(z)
                    a = acts[layer](z)
                z = torch.baddbmm(bias[layer + 1], a, w_t[layer + 1])
            return science(v, None if u_at is None else u_at[j]) + z

        for sub in range(cfg.n_substeps):
            x = rk4_step(rhs, x, st, 4 * sub, 2 * (n * cfg.n_substeps + sub), h)
        outputs.append(x)
    return torch.stack(outputs, 2), states, hidden


def backward_stacked(cfg, grad_out, states, acts, slopes, jac, weights, u_stage):
    """Reverse sweep of K members, accumulating the network's gradients on the way.

    ``states`` and ``jac`` (the science Jacobian, (n_steps, C, K, B, d, d))
    are stage-major; ``acts[l]``/``slopes[l]`` are hidden layer l's
    activations and derivatives (``slopes[l]`` None for ReLU, whose
    activations decide), member-major like the hidden buffers of
    :func:`forward_stacked`; ``u_stage`` the inputs per stage (n_steps, K, C, B, n_u)
    or None.  Returns d loss / d x0, the stage-major cotangents of the rhs
    (n_steps, C, K, B, d) and the weight and bias gradients per layer.

    The first and last layers' weight gradients (skinny products, a small
    state on one side) are accumulated stage by stage, while their operands
    are still in cache; the wide layers' once per output interval, with an
    inner dimension of ``C * B``.
    """
    n_steps, C, K, B, d = states.shape
    n_layers, h = len(weights), cfg.dt / cfg.n_substeps
    grad_w = [weight_grad_buffer(w) for w in weights]
    grad_b = [grad_out.new_zeros(K, w.shape[1]) for w in weights]
    grad_w_state, grad_w_inputs = grad_w[0][..., :d], grad_w[0][..., d:]
    cots = grad_out.new_empty(n_steps, C, K, B, d)
    wide = range(1, n_layers - 1)
    # cotangents of the hidden layers' outputs: over one output interval for the
    # wide layers, one stage at a time for the first
    chunk = {layer: take((K, C, B, weights[layer].shape[1]), grad_out.dtype) for layer in wide}
    chunk_at = {layer: t.unbind(1) for layer, t in chunk.items()}
    if n_layers > 1:
        chunk_at[0] = [grad_out.new_empty(K, B, weights[0].shape[1])] * C
    w_state = long_axis_contiguous(weights[0][:, :, :d])
    w_next = [long_axis_contiguous(w) for w in weights[1:]]
    coef = [torch.tensor(c, dtype=grad_out.dtype) for c in (h / 6, h / 3, h / 3, h / 6)]
    back = [None, 0.5 * h, 0.5 * h, h]
    outputs = grad_out.unbind(2)
    adj = torch.zeros_like(outputs[0])
    for n in reversed(range(n_steps)):
        adj = adj + outputs[n]
        ja, ct, v_at = jac[n].view(C, K * B, d, d), cots[n], states[n]
        u_at = None if u_stage is None else u_stage[n].unbind(1)
        act_at = [t[n].unbind(1) for t in acts]
        slope_at = [None if t is None else t[n].unbind(1) for t in slopes]
        for sub in reversed(range(cfg.n_substeps)):
            s = 4 * sub
            cs = [torch.mul(adj, coef[i], out=ct[s + i]) for i in range(4)]
            for i in (3, 2, 1, 0):
                c = s + i
                delta = cs[i]
                # the science part's vector-Jacobian product: K * B tiny products
                g = torch.bmm(ja[c], delta.view(K * B, d, 1)).view(K, B, d)
                if n_layers > 1:
                    accumulate_weight_grad(grad_w[-1], delta, act_at[-1][c])
                for layer in reversed(range(n_layers - 1)):
                    delta = torch.bmm(delta, w_next[layer])
                    if slope_at[layer] is None:
                        delta = _relu_backward_out(delta, act_at[layer][c], 0.0,
                                                   grad_input=chunk_at[layer][c])
                    else:
                        delta = torch.mul(delta, slope_at[layer][c], out=chunk_at[layer][c])
                accumulate_weight_grad(grad_w_state, delta, v_at[c])
                if u_at is not None:
                    accumulate_weight_grad(grad_w_inputs, delta, u_at[c])
                grad_b[0].add_(delta.sum(1))
                g = torch.baddbmm(g, delta, w_state)
                adj = adj + g
                if i:
                    cs[i - 1].add_(g, alpha=back[i])
        if n_layers > 1:
            grad_b[-1].add_(ct.sum((0, 2)))
        # the wide layers' share of this interval: inner dimension C * B
        for layer in wide:
            delta = chunk[layer].view(K, C * B, -1)
            accumulate_weight_grad(grad_w[layer], delta, acts[layer - 1][n].view(K, C * B, -1))
            grad_b[layer].add_(delta.sum(1))
    release(*chunk.values())
    return adj, cots, [g.contiguous() for g in grad_w], grad_b
