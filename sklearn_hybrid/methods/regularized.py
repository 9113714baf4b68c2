"""The paper's baselines: erm, parameter-norm (p-reg) and functional (f-reg) regularisation."""

from __future__ import annotations

from dataclasses import dataclass

from ._base import Method, per_member

__all__ = ["ERM", "ParameterRegularization", "FunctionalRegularization"]


@dataclass
class ERM(Method):
    """Empirical risk minimisation (with the estimator's slight weight decay)."""

    name = "erm"


@dataclass
class ParameterRegularization(Method):
    """``lam * ||phi||^2`` over every network parameter."""

    lam: float = 1e-3
    name = "p-reg"
    hyperparameters = ("lam",)

    def parameter_penalty(self, phi, n_batch_dims=0):
        squares = sum(p.pow(2).reshape(*p.shape[:n_batch_dims], -1).sum(-1) for p in phi)
        return per_member(self.lam, squares) * squares


@dataclass
class FunctionalRegularization(Method):
    """Functional norm of the network's contribution, as the structure defines it.

    Additive structures (APHYNITY): ``lam * mean ||g_phi||^2`` at the states the
    prediction visits.  Non-additive ones (Phys-VAE style): ``lam * mean
    ||h(x) - A f_theta(x)||^2`` with a learnable linear map ``A`` (identity when
    the science output and ``y`` share a shape).  The mean weighs the samples by
    ``sample_weight``, as the data loss does.  Not stackable: the penalty needs
    the structure's forward pass and the learnable map of one model.
    """

    lam: float = 1e-3
    name = "f-reg"
    hyperparameters = ("lam",)
    needs_reduction = True  # the learnable map A of a non-additive structure's penalty
    stackable = False

    def penalty(self, model, pred, extras, sample_weight=None):
        per_sample = model.structure.functional_penalty(model, pred, extras)
        if sample_weight is None:
            return self.lam * per_sample.mean()
        return self.lam * (per_sample * sample_weight).sum() / sample_weight.sum()
