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
