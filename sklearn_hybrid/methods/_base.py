"""What a training method is: extra loss terms plus an optional perturbation of the network."""

from __future__ import annotations

from dataclasses import dataclass

import torch

__all__ = ["Method"]


@dataclass
class Method:
    """Base class: plain empirical risk minimisation.

    A method adds a ``penalty`` to the data loss and, for the sharpness-aware
    family, returns a ``perturbation`` of the perturbed parameters from their
    gradients; the engine evaluates the gradient at the perturbed point,
    restores the parameters exactly and takes one optimiser step.
    """

    name = "erm"
    perturbs = False

    def penalty(self, model, pred: torch.Tensor, extras: dict,
                sample_weight: torch.Tensor | None = None) -> torch.Tensor | float:
        """Regularisation added to the data loss (none for erm); a penalty summed over
        samples weighs them by ``sample_weight``, as the data loss does."""
        return 0.0

    def perturbation(self, params: list[torch.Tensor], grads: list[torch.Tensor],
                     is_weight: list[bool]) -> list[torch.Tensor]:
        """Ascent step epsilon for each perturbed parameter (SAM family only)."""
        raise NotImplementedError
