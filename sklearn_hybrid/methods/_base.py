"""What a training method is: extra loss terms plus an optional perturbation of the network."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np
import torch

__all__ = ["Method", "per_member"]


def per_member(value, like: torch.Tensor) -> torch.Tensor:
    """``value`` (a number, or one number per member of shape ``(K,)``) shaped to broadcast
    against ``like``, whose leading axes are the member axes."""
    value = torch.as_tensor(value, dtype=like.dtype, device=like.device)
    return value.reshape(value.shape + (1,) * (like.dim() - value.dim()))


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
    """

    name = "erm"
    perturbs = False
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

    def perturbation(self, params: list[torch.Tensor], grads: list[torch.Tensor],
                     is_weight: list[bool], n_batch_dims: int = 0) -> list[torch.Tensor]:
        """Ascent step epsilon for each perturbed parameter (SAM family only); with
        ``n_batch_dims=1`` norms are taken per member."""
        raise NotImplementedError

    def for_members(self, **values) -> "Method":
        """A copy with per-member hyperparameters, e.g. ``for_members(rho=[0.01, 0.1])``
        (a single number sets it for all).

        Names the method does not use are ignored (a sweep over ``lam`` of a SAM
        method changes nothing), as scikit-learn ignores ``gamma`` for a linear SVC.
        """
        fields = {f.name for f in dataclasses.fields(self)}
        arrays = {k: np.asarray(v, dtype=float) for k, v in values.items() if k in fields}
        return dataclasses.replace(self, **{k: float(v) if v.ndim == 0 else v for k, v in arrays.items()})
