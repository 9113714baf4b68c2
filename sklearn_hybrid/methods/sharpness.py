"""Sharpness-aware methods (SAM, ASAM, Fisher SAM) that perturb the network only.

The perturbation rules are pure functions of (parameters, gradients,
hyperparameters).  With ``n_batch_dims=1`` every tensor carries a leading
member axis and norms are taken per member, so K configurations trained as
one stacked model get exactly the update each would get alone.
"""

from __future__ import annotations

from dataclasses import dataclass

import torch

from ._base import Method, per_member

__all__ = ["SAM", "ASAM", "FisherSAM", "GSAM", "sam_perturbation", "asam_perturbation",
           "fsam_perturbation"]

_XI = 1e-12  # added to the norm, as in the reference implementations


def _member_sum(tensors, n_batch_dims):
    return sum(t.reshape(*t.shape[:n_batch_dims], -1).sum(-1) for t in tensors)


def _radius(rho, like):
    """``rho`` as a tensor: a number, or one radius per member of shape ``(K,)``."""
    return torch.as_tensor(rho, dtype=like.dtype, device=like.device)


def sam_perturbation(grads, rho, *, n_batch_dims=0):
    """SAM: ``eps = rho * g / ||g||``."""
    scale = _radius(rho, grads[0]) / (_member_sum([g * g for g in grads], n_batch_dims).sqrt() + _XI)
    return [g * per_member(scale, g) for g in grads]


def asam_perturbation(params, grads, rho, eta, is_weight, *, n_batch_dims=0):
    """Adaptive SAM (official form): ``eps = rho * T^2 g / ||T g||``.

    ``T = |w| + eta`` on weight tensors and 1 on biases (Kwon et al. 2021).
    """
    scales = [p.abs() + eta if w else torch.ones_like(p) for p, w in zip(params, is_weight)]
    norm = _member_sum([(t * g) ** 2 for t, g in zip(scales, grads)], n_batch_dims).sqrt()
    scale = _radius(rho, norm) / (norm + _XI)
    return [t * t * g * per_member(scale, g) for t, g in zip(scales, grads)]


def fsam_perturbation(grads, rho, eta, *, n_batch_dims=0):
    """Fisher SAM: ``eps = rho * F^-1 g / sqrt(g^T F^-1 g)``, ``F = diag(1 + eta g^2)``."""
    scaled = [g / (1.0 + eta * g * g) for g in grads]
    denom = _member_sum([g * u for g, u in zip(grads, scaled)], n_batch_dims).sqrt()
    scale = _radius(rho, denom) / (denom + _XI)
    return [u * per_member(scale, u) for u in scaled]


@dataclass
class SAM(Method):
    """Sharpness-aware minimisation with radius ``rho``."""

    rho: float = 0.05
    name = "sam"
    hyperparameters = ("rho",)
    perturbs = True

    def perturbation(self, params, grads, is_weight, n_batch_dims=0):
        return sam_perturbation(grads, self.rho, n_batch_dims=n_batch_dims)


@dataclass
class ASAM(Method):
    """Adaptive SAM with radius ``rho`` and offset ``eta`` (default 0.01)."""

    rho: float = 0.05
    eta: float = 0.01
    name = "asam"
    hyperparameters = ("rho", "eta")
    perturbs = True

    def perturbation(self, params, grads, is_weight, n_batch_dims=0):
        return asam_perturbation(params, grads, self.rho, self.eta, is_weight, n_batch_dims=n_batch_dims)


@dataclass
class FisherSAM(Method):
    """Fisher SAM with radius ``rho`` (the paper's gamma) and damping ``eta`` (default 1)."""

    rho: float = 0.05
    eta: float = 1.0
    name = "fsam"
    hyperparameters = ("rho", "eta")
    perturbs = True

    def perturbation(self, params, grads, is_weight, n_batch_dims=0):
        return fsam_perturbation(grads, self.rho, self.eta, n_batch_dims=n_batch_dims)


@dataclass
class GSAM(SAM):
    """Surrogate-gap guided SAM (Zhuang et al. 2022): SAM's step less ``alpha`` times the part of the
    gradient at the unperturbed point that is orthogonal to the gradient at the perturbed one.

    Descending along that orthogonal part lowers the surrogate gap (the loss at the perturbed point less
    the loss at the point) without undoing the descent of the perturbed loss.  A method whose step
    combines two gradients is this one class: it overrides ``Method.descent``, the one place a
    method's rule is applied, so single fits and stacked members take the same step.  Only the network's
    tensors (the perturbed ones) are decomposed; theta steps along its gradient at the perturbed point,
    as with SAM.  Give it as an object, ``method=GSAM(rho=0.05, alpha=0.1)``.
    """

    rho: float = 0.05
    alpha: float = 0.1
    name = "gsam"
    hyperparameters = ("rho", "alpha")

    def descent(self, params, perturbed, grads, is_weight, recompute, n_batch_dims=0):
        out = list(super().descent(params, perturbed, grads, is_weight, recompute, n_batch_dims))
        where = {id(p): i for i, p in enumerate(params)}
        at = [where[id(p)] for p in perturbed]
        there = [out[i] for i in at]  # the gradients at the perturbed point
        coef = (_member_sum([g * h for g, h in zip(grads, there)], n_batch_dims)
                / (_member_sum([h * h for h in there], n_batch_dims) + _XI))
        alpha = _radius(self.alpha, coef)
        for i, g, h in zip(at, grads, there):
            orthogonal = g - per_member(coef, h) * h
            out[i] = h - per_member(alpha, h) * orthogonal
        return out
