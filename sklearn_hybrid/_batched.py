"""Train K configurations of one hybrid model as a single stacked model.

Every parameter tensor of the K member models is stacked along a new leading
*member* axis.  Each member's loss depends only on its own slice, so the
gradient of the summed loss is, slice by slice, the gradient each member
would get alone; the perturbation rules of the SAM family take per-member
norms (``n_batch_dims=1``) and a per-member ``rho``; Adam and weight decay act
element by element.  A member therefore takes exactly the steps a separate
:class:`~sklearn_hybrid.HybridRegressor` fit with the same seed takes (up to
floating-point summation order), while the K small problems share each
operation, which amortises per-operation overhead and fills the matrix units.

Three forward paths: hybrid ODEs with an MLP over a small state use the
stacked RK4 of :mod:`sklearn_hybrid._fast`; other models run under
:func:`torch.func.vmap` with :func:`torch.func.functional_call`, except
convolutional ones, which ``vmap`` would turn into slow grouped
convolutions: those run member by member (already arithmetic-bound, they
gain nothing from stacking).
"""

from __future__ import annotations

import numpy as np
import torch
from torch import nn

from . import _fast
from .engine import TrainConfig, _Batches, gradients_at_perturbed, make_optimizer
from .methods import asam_perturbation, fsam_perturbation, sam_perturbation

__all__ = ["train_batched", "BATCHABLE_METHODS"]

BATCHABLE_METHODS = ("erm", "p-reg", "sam", "asam", "fsam")


def _perturbation(method, params, grads, is_weight, rho):
    """The method's ascent step with a per-member radius ``rho`` of shape (K,)."""
    if method.name == "sam":
        return sam_perturbation(grads, rho, n_batch_dims=1)
    if method.name == "asam":
        return asam_perturbation(params, grads, rho, method.eta, is_weight, n_batch_dims=1)
    return fsam_perturbation(grads, rho, method.eta, n_batch_dims=1)


class _StackedModel:
    """The K members' parameters stacked, and their per-member losses."""

    def __init__(self, models: list, inputs: tuple):
        self.base = models[0]
        names = [n for n, _ in self.base.named_parameters()]
        self.names = names
        self.params = {}
        for name in names:
            members = [dict(m.named_parameters())[name] for m in models]
            stacked = torch.stack([p.detach() for p in members]).clone()
            self.params[name] = stacked.requires_grad_(members[0].requires_grad)
        self.buffers = {n: b for n, b in self.base.named_buffers()}
        structure = self.base.structure
        self.fast = (getattr(structure, "solver", None) is not None
                     and _fast.supports(self.base.residual, tuple(structure.state_shape),
                                        structure.solver)
                     and _fast._row_by_row(self.base.science.func, inputs[0],
                                           inputs[1] if len(inputs) > 1 else None,
                                           self.base.science.values()))
        if not self.fast and any(isinstance(m, nn.modules.batchnorm._BatchNorm) and m.track_running_stats
                                 for m in self.base.modules()):
            raise ValueError(
                "Batched training cannot update batch-norm running statistics per member; "
                "use track_running_stats=False or fit the configurations separately."
            )
        self.n_inputs = len(inputs)
        self.convolutional = any(isinstance(m, nn.modules.conv._ConvNd) for m in self.base.modules())

    def group(self, prefix):
        return [self.params[n] for n in self.names if n.startswith(prefix) and self.params[n].requires_grad]

    def _fast_predictions(self, inputs):
        science, structure = self.base.science, self.base.structure
        thetas = [science.transforms[n](self.params[f"science.raw.{n}"]) for n in science.names]
        layers = [n for n in self.names if n.startswith("residual.")]
        weights = [self.params[n] for n in layers if n.endswith("weight")]
        biases = [self.params[n] for n in layers if n.endswith("bias")]
        _, _, acts = _fast.mlp_parts(self.base.residual)
        weights, biases = _fast.full_output(self.base.residual, weights, biases)
        x0, u_fine = inputs[0], (inputs[1] if len(inputs) > 1 else None)
        states = _fast.ode_states(science.func, science.names, thetas, weights, biases, acts,
                                  x0, u_fine, structure.n_steps, structure.dt, structure.n_substeps)
        return states if structure.observed is None else states[..., structure.observed]

    def predictions(self, inputs):
        """Predictions of every member, ``(K, batch, ...)``; inputs carry the member axis."""
        if self.fast:
            return self._fast_predictions(inputs)

        def member(params, *member_inputs):
            pred, _ = torch.func.functional_call(self.base, (params, self.buffers), member_inputs)
            return pred

        if self.convolutional:  # vmap turns convolutions into slow grouped ones: one by one
            K = len(inputs[0])
            return torch.stack([member({n: p[k] for n, p in self.params.items()},
                                       *(t[k] for t in inputs)) for k in range(K)])
        with _fast.disabled():  # the custom autograd function does not run under vmap
            return torch.func.vmap(member)(self.params, *inputs)


def _member_loss(pred, y):
    """Mean squared error per member (the data loss of :func:`engine.data_loss`)."""
    return (pred.reshape(y.shape) - y).pow(2).reshape(len(y), -1).mean(1)


def train_batched(models: list, method, inputs: tuple, y: torch.Tensor, config: TrainConfig,
                  generators: list, rho: np.ndarray, lam: np.ndarray) -> dict:
    """Train K member models (built as separate fits would build them) as one.

    Parameters
    ----------
    models : list of HybridModule
        The K members, freshly initialised; their parameters receive the result.
    method : Method
        The shared training method (its ``rho``/``lam`` are replaced per member).
    inputs : tuple of Tensor
        Structure inputs shared by the members, samples first.
    y : Tensor
        Targets, samples first.
    config : TrainConfig
        Shared optimisation settings.
    generators : list of torch.Generator
        Each member's mini-batch generator (seeded as a separate fit seeds it).
    rho, lam : ndarray of shape (K,)
        Per-member SAM radius and penalty weight.

    Returns
    -------
    dict
        ``"loss"``: (max_iter, K); ``"theta"``: name -> (max_iter, K, ...);
        ``"diverged_at"``: (K,) first iteration with a non-finite loss, or -1.
        A diverged member's values go on as NaN without touching the others;
        training stops early when every member has diverged.
    """
    if method.name not in BATCHABLE_METHODS:
        raise ValueError(
            f"Batched training supports methods {list(BATCHABLE_METHODS)}, not "
            f"{method.name!r} (its penalty is model-specific); fit the configurations separately."
        )
    K = len(models)
    stacked = _StackedModel(models, inputs)
    theta, phi = stacked.group("science."), stacked.group("residual.")
    params = theta + phi
    perturbed = phi + theta if config.perturb == "all" else phi
    residual_names = [n for n in stacked.names if n.startswith("residual.")]
    is_weight = ["weight" in n for n in residual_names] + [False] * (len(perturbed) - len(phi))
    dtype = y.dtype
    rho_t = torch.as_tensor(rho, dtype=dtype, device=y.device)
    lam_t = torch.as_tensor(lam, dtype=dtype, device=y.device)

    optimizer, scheduler = make_optimizer(theta, phi, config)
    batches = [_Batches(len(y), config.batch_size, g) for g in generators]
    science = stacked.base.science
    losses = np.empty((config.max_iter, K))
    thetas = {n: np.empty((config.max_iter, K, *science.shapes[n])) for n in science.names}
    diverged = np.full(K, -1)
    full = tuple(t.expand(K, *t.shape) for t in inputs), y.expand(K, *y.shape)

    def loss_and_grads(xb, yb, wrt):
        pred = stacked.predictions(xb)
        loss = _member_loss(pred, yb)
        if method.name == "p-reg":
            loss = loss + lam_t * sum(p.pow(2).reshape(K, -1).sum(1) for p in phi)
        grads = torch.autograd.grad(loss.sum(), wrt, allow_unused=True)
        return loss.detach(), [torch.zeros_like(p) if g is None else g for p, g in zip(wrt, grads)]

    for it in range(config.max_iter):
        idx = [b.next() for b in batches]
        if idx[0] is None:
            xb, yb = full
        else:
            idx = torch.stack(idx)
            xb, yb = tuple(t[idx] for t in inputs), y[idx]
        # the SAM family needs only the perturbed tensors' gradients at the first point
        loss, grads = loss_and_grads(xb, yb, perturbed if method.perturbs else params)
        bad = ~torch.isfinite(loss).numpy() & (diverged < 0)
        diverged[bad] = it
        if (diverged >= 0).all():  # nothing left to train
            losses[it:], thetas = np.nan, {n: np.full_like(v, np.nan) for n, v in thetas.items()}
            break
        if method.perturbs:
            with torch.no_grad():
                eps = _perturbation(method, perturbed, grads, is_weight, rho_t)
            _, grads = gradients_at_perturbed(perturbed, eps, lambda: loss_and_grads(xb, yb, params))
        for p, g in zip(params, grads):
            p.grad = g
        optimizer.step()
        scheduler.step()
        losses[it] = loss.numpy()
        with torch.no_grad():
            for n in science.names:
                thetas[n][it] = science.transforms[n](stacked.params[f"science.raw.{n}"]).numpy()

    with torch.no_grad():  # hand each member its slice
        for k, model in enumerate(models):
            for name, p in model.named_parameters():
                p.copy_(stacked.params[name][k])
    return {"loss": losses, "theta": thetas, "diverged_at": diverged}
