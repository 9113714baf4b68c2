"""What a training method is: extra loss terms plus an optional perturbation of the network."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np
import torch

__all__ = ["Method", "per_member", "gradients_at_perturbed", "RADIUS_HALVINGS"]

#: Halvings of a perturbation at which the loss is not finite (see :meth:`Method.descent`).
RADIUS_HALVINGS = 5


def per_member(value, like: torch.Tensor) -> torch.Tensor:
    """``value`` (a number, or one number per member of shape ``(K,)``) shaped to broadcast
    against ``like``, whose leading axes are the member axes."""
    value = torch.as_tensor(value, dtype=like.dtype, device=like.device)
    return value.reshape(value.shape + (1,) * (like.dim() - value.dim()))


def gradients_at_perturbed(perturbed: list, eps: list, loss_and_grads):
    """``loss_and_grads()`` at ``perturbed + eps``; the parameters are then restored exactly from a copy.

    Restoring by copy rather than by subtracting ``eps`` keeps the parameters
    bit-identical (``p + e - e`` can round), also if the second pass raises.
    """
    with torch.no_grad():
        saved = [p.detach().clone() for p in perturbed]
        for p, e in zip(perturbed, eps):
            p.add_(e)
    try:
        return loss_and_grads()
    finally:
        with torch.no_grad():
            for p, s in zip(perturbed, saved):
                p.copy_(s)


@dataclass
class Method:
    """Base class: plain empirical risk minimisation.

    A method adds a penalty to the data loss and, for the sharpness-aware
    family, returns a ``perturbation`` of the perturbed parameters from their
    gradients; the training loop evaluates the gradient at the perturbed
    point, restores the parameters exactly and takes one optimiser step.

    The same object trains a single model and K models stacked along a
    leading member axis (``n_batch_dims=1``): a hyperparameter (``rho``,
    ``lam``) may then hold one value per member (see :meth:`for_members`), so
    every member takes the step a separate fit with its value would take.
    A subclass that overrides only :meth:`parameter_penalty` and
    :meth:`perturbation` trains in sweeps and profiles as it does alone;
    one whose penalty needs the whole model (f-reg) sets ``stackable = False``.

    A method owns its choices, so that adding one is one class and one line of
    :data:`~sklearn_hybrid.methods.METHODS`: its ``name``; its
    ``hyperparameters``, the names of its fields (positive numbers, checked at
    fit), which a method given by name reads from the estimator's keyword of
    the same name (``rho``, ``lam``, ``eta``) and which stacked members carry
    (one value per member where the rule takes one, as ``rho`` and ``lam``);
    whether it ``perturbs`` and which tensors
    (:meth:`perturbed`); whether it ``needs_reduction``, the learnable map of
    f-reg's penalty, which the estimator then builds.
    """

    name = "erm"
    hyperparameters = ()  # a class attribute, not a dataclass field
    perturbs = False
    needs_reduction = False
    stackable = True  # trains as stacked members (HybridRegressorCV, profiles, bootstrap)

    def penalty(self, model, pred: torch.Tensor, extras: dict,
                sample_weight: torch.Tensor | None = None) -> torch.Tensor | float:
        """Regularisation added to a single model's data loss: by default
        :meth:`parameter_penalty` of the network's parameters."""
        return self.parameter_penalty(list(model.residual.parameters()))

    def parameter_penalty(self, phi: list[torch.Tensor], n_batch_dims: int = 0) -> torch.Tensor | float:
        """Penalty on the network's parameters ``phi`` (none for erm); with ``n_batch_dims=1``
        one value per member."""
        return 0.0

    def perturbed(self, phi: list[torch.Tensor], theta: list[torch.Tensor], phi_is_weight: list[bool],
                  theta_is_weight: list[bool], scope: str = "residual") -> tuple[list[torch.Tensor], list[bool]]:
        """The tensors the perturbation moves, and which of them are weights (ASAM scales those).

        Parameters
        ----------
        phi, theta : list of Tensor
            The network's and the science's trained tensors (a single model's or the stacked members').
        phi_is_weight, theta_is_weight : list of bool
            Which of them are weight tensors.
        scope : {"residual", "all"}, default="residual"
            The estimator's ``perturb``: the network only (the paper's methods), or theta too.

        Returns
        -------
        perturbed : list of Tensor
        is_weight : list of bool
        """
        if scope == "all":
            return phi + theta, phi_is_weight + theta_is_weight
        return list(phi), list(phi_is_weight)

    def descent(self, params: list[torch.Tensor], perturbed: list[torch.Tensor], grads: list[torch.Tensor],
                is_weight: list[bool], recompute, n_batch_dims: int = 0) -> list[torch.Tensor]:
        """The gradients a training step takes, one per tensor of ``params``: the one place a method's rule
        is applied, for a single fit and stacked members alike (``n_batch_dims=1``, one norm per member).

        For a method that does not perturb, ``grads`` are those of ``params`` and are returned as they
        are.  For the sharpness-aware family ``grads`` are the gradients of the ``perturbed`` tensors
        alone; they give the ascent step ``eps`` (:meth:`perturbation`), and the gradients of every
        tensor are taken at ``perturbed + eps`` by ``recompute()`` (which returns ``(loss, grads)``), the
        tensors then being restored exactly.  A method whose step combines the gradients at both points
        (GSAM) overrides this.

        A perturbation at which the loss is not finite (the radius is absolute in the network's
        parameters: over a long integration of slow dynamics a network moved by ``rho`` can blow the
        trajectories up) is outside the model's domain, not a measure of sharpness: it is halved, member by
        member, up to :data:`RADIUS_HALVINGS` times, for this step only.  Otherwise its NaN gradients would
        reach theta, and the spike guard's halving of the learning rates could not help.
        """
        if not self.perturbs:
            return grads
        with torch.no_grad():
            eps = self.perturbation(perturbed, grads, is_weight, n_batch_dims=n_batch_dims)
        for _ in range(RADIUS_HALVINGS):
            loss, out = gradients_at_perturbed(perturbed, eps, recompute)
            bad = ~torch.isfinite(loss.reshape(-1)[0] if n_batch_dims == 0 else loss)
            if n_batch_dims == 0:
                bad = bad | ~torch.stack([torch.isfinite(g).all() for g in out]).all()
            if not bad.any():
                return out
            with torch.no_grad():  # halve the radius of the members (or the fit) that blew up
                half = torch.where(bad, 0.5, 1.0).to(eps[0].dtype)
                eps = [e * (half if n_batch_dims == 0 else half.reshape(-1, *(1,) * (e.dim() - 1))) for e in eps]
        return gradients_at_perturbed(perturbed, eps, recompute)[1]

    def perturbation(self, params: list[torch.Tensor], grads: list[torch.Tensor],
                     is_weight: list[bool], n_batch_dims: int = 0) -> list[torch.Tensor]:
        """Ascent step epsilon for each perturbed parameter (SAM family only); with
        ``n_batch_dims=1`` norms are taken per member."""
        raise NotImplementedError

    def get_params(self, deep: bool = True) -> dict:
        """The method's settings (its dataclass fields), as scikit-learn reads an estimator's: so that
        ``GridSearchCV(HybridRegressor(method=SAM()), {"method__rho": [...]})`` searches a setting of the
        method object and ``clone`` copies it."""
        return {f.name: getattr(self, f.name) for f in dataclasses.fields(self)}

    def set_params(self, **params) -> "Method":
        """Set settings by name, as scikit-learn's ``set_params``; an unknown name is an error that lists
        the method's settings."""
        fields = {f.name for f in dataclasses.fields(self)}
        unknown = sorted(set(params) - fields)
        if unknown:
            raise ValueError(f"Invalid parameter {unknown[0]!r} for method {type(self).__name__}; its "
                             f"settings are {sorted(fields)}.")
        for name, value in params.items():
            setattr(self, name, value)
        return self

    def for_members(self, **values) -> "Method":
        """A copy with per-member hyperparameters, e.g. ``for_members(rho=[0.01, 0.1])``
        (a single number sets it for all).

        Names the method does not use are ignored (a sweep over ``lam`` of a SAM
        method changes nothing), as scikit-learn ignores ``gamma`` for a linear SVC.
        """
        fields = {f.name for f in dataclasses.fields(self)}
        arrays = {k: np.asarray(v, dtype=float) for k, v in values.items() if k in fields}
        return dataclasses.replace(self, **{k: float(v) if v.ndim == 0 else v for k, v in arrays.items()})
