"""Rules that watch a fit: early stopping, and the guard against loss spikes.

Kept apart from the training loop so that each rule is one small object: the
loop reports every iteration's loss (and theta), and asks what to do.
"""

from __future__ import annotations

import copy
from collections import deque

import numpy as np
import torch

__all__ = ["EarlyStopping", "SpikeGuard", "target_variance", "weighted_variance", "theta_floor", "loss_trend"]


def target_variance(y) -> float:
    """The loss of predicting the mean target: the variance of ``y``'s outputs, averaged (1 for one sample).

    The scale of the stopping tests and of the divergence tests of every training.
    """
    return float(y.reshape(len(y), -1).var(0, unbiased=False).mean()) if len(y) > 1 else 1.0


def weighted_variance(y, sample_weight=None):
    """:func:`target_variance` with each sample weighted as the data loss weighs it (a weight of 2 equals a
    duplicated sample); with weights of shape ``(K, n)`` (the stacked members' resamples), one per member.

    The unit the training's gradients are taken in (see :func:`~sklearn_hybrid.training.engine.run_steps`).
    """
    if sample_weight is None:
        return target_variance(y) or 1.0  # constant targets: the loss in its own units
    flat = y.reshape(len(y), -1).to(torch.float64)
    w = torch.as_tensor(sample_weight, dtype=torch.float64, device=flat.device)
    w = w / w.sum(-1, keepdim=True)
    mean = w @ flat
    var = ((w @ flat.pow(2)) - mean.pow(2)).clamp_min(0).mean(-1)
    var = torch.where(var > 0, var, torch.ones_like(var))
    return float(var) if var.dim() == 0 else var.cpu().numpy()


def theta_floor(science) -> np.ndarray:
    """A thousandth of each theta entry's own scale (its size at the start), flattened in the order of
    ``science.names``: the floor of :class:`EarlyStopping`'s relative test of theta."""
    return np.concatenate([1e-3 * np.broadcast_to(science.transforms[n].scale.cpu().numpy(),
                                                  science.shapes[n]).ravel() for n in science.names])


class EarlyStopping:
    """Stopping rule on windows of ``n_iter_no_change`` iterations.

    At the end of every window the monitored value is the validation loss
    when a validation callable is given, else the mean training loss over the
    window (single iterations are too noisy to compare).  Training stops when,
    compared with the previous window's end,

    - the monitored value improved by less than ``tol * scale`` (``scale``:
      the variance of the targets, so that the test reads "R^2 improved by
      less than tol"), and
    - no component of theta moved by more than ``tol`` relative to
      ``max(|theta|, floor)`` (``floor``: a thousandth of theta's own scale,
      so that a theta that is small in its units is not called settled).

    Both must hold: a flat loss with a drifting theta (the network and the
    science trading the same effect) is not converged for the purpose of
    estimating theta.

    Parameters
    ----------
    tol : float
        Tolerance of both tests.
    n_iter_no_change : int
        Window length in iterations; the earliest stop is after two windows.
    scale : float
        Loss of predicting the mean target (mean variance of the outputs).
    validation_loss : callable or None
        ``validation_loss() -> float``, evaluated at the end of each window.
    theta_floor : float or ndarray, default=1e-3
        The smallest size theta's moves are relative to, per flattened entry.
    """

    def __init__(self, tol: float, n_iter_no_change: int, scale: float = 1.0, validation_loss=None,
                 theta_floor=1e-3):
        self.tol, self.window = float(tol), int(n_iter_no_change)
        self.theta_floor = theta_floor
        self.scale = float(scale) if scale > 0 else 1.0
        self.validation_loss = validation_loss
        self.previous = None
        self.validation_history: list[float] = []

    def should_stop(self, it: int, losses: np.ndarray, theta: np.ndarray) -> bool:
        """Whether to stop after iteration ``it`` (0-based), given the losses so far and flat theta."""
        if (it + 1) % self.window:
            return False
        if self.validation_loss is not None:
            monitored = float(self.validation_loss())
            self.validation_history.append(monitored)
        else:
            monitored = float(np.mean(losses[it + 1 - self.window:it + 1]))
        current = (monitored, np.array(theta, dtype=float))
        previous, self.previous = self.previous, current
        if previous is None:
            return False
        improved = monitored < previous[0] - self.tol * self.scale
        scale = np.maximum(np.abs(current[1]), self.theta_floor)
        moved = bool(np.any(np.abs(current[1] - previous[1]) > self.tol * scale))
        return not improved and not moved


def loss_trend(losses: np.ndarray, n_iter_no_change: int) -> tuple[float, float]:
    """How fast a training that has ended was still improving: the fall of its mean loss over the last
    window, and that fall carried on for as many iterations as were trained.

    A training that ran out of iterations ends wherever it is: its last loss is then only an upper bound of
    the minimum it was heading for (a profile member that must move another parameter a long way to
    compensate the one it holds is still falling when its budget ends).  The windows are those of
    :class:`EarlyStopping`, at most a quarter of the iterations each, so that the first half, where a
    warm-started member recovers from the value it was moved to, is left out.  Only the loss is read, not
    theta: a parameter drifting along a flat direction (traded with the network) leaves the loss where it is.

    Returns
    -------
    fall, carried : float
        Both at least 0; ``inf`` where fewer than four iterations were trained (nothing to compare).
    """
    n = len(losses)
    window = min(int(n_iter_no_change), n // 4)
    if window < 1:
        return np.inf, np.inf
    fall = max(float(np.mean(losses[n - 2 * window:n - window]) - np.mean(losses[n - window:])), 0.0)
    return fall, fall * n / window


class SpikeGuard:
    """Undo a loss spike: restore the last good state and halve the learning rates.

    Adam with a learning rate too large for the problem (a long rollout, a
    steep corner of the state space) can throw a fit out of a good basin in a
    few steps: the loss jumps by orders of magnitude and may become NaN (the
    first fit of the draining tank in ``benchmarks/identification/bench_identification.py``
    diverged so at the default ``lr=1e-2`` before this guard).  Every ``every``
    healthy iterations the guard keeps a copy of the model and the optimiser.
    A loss that is not finite, or above ``factor`` times the median of the last
    ``every`` accepted losses, is a spike: the copy is restored and every
    learning rate is halved (the cosine schedule goes on from the halved
    rates).  After ``max_halvings`` halvings a spike is a divergence.  The
    stacked members of sweeps, profiles and the bootstrap (``stacked.py``)
    share one optimiser, whose rates cannot be halved for one of them: a
    member that ends blown up (the verdict's test of a single fit) is marked
    diverged there, and its result is refused.

    Parameters
    ----------
    model : torch.nn.Module
        The model being trained (its ``state_dict`` is what is kept).
    optimizer : torch.optim.Optimizer
    scheduler : torch.optim.lr_scheduler.LRScheduler
        Its base rates are halved with the optimiser's.
    factor : float
        Spike threshold, relative to the median of recent losses.
    every : int
        Iterations between copies, and the length of the median's window.
    max_halvings : int
        Halvings allowed before :meth:`roll_back` reports failure.
    """

    def __init__(self, model, optimizer, scheduler, factor: float = 10.0, every: int = 25,
                 max_halvings: int = 5):
        self.model, self.optimizer, self.scheduler = model, optimizer, scheduler
        self.factor, self.every, self.max_halvings = float(factor), int(every), int(max_halvings)
        self.recent: deque = deque(maxlen=self.every)
        self.halved_at: list[int] = []
        self._save()

    def _save(self):
        self.saved = (copy.deepcopy(self.model.state_dict()), copy.deepcopy(self.optimizer.state_dict()))
        self.steps_since_save = 0

    @property
    def reference(self) -> float:
        """Median of the recent accepted losses (NaN before the first)."""
        return float(np.median(self.recent)) if self.recent else float("nan")

    def is_spike(self, loss: float) -> bool:
        """Whether ``loss`` (this iteration's, before the step) is a spike."""
        if not np.isfinite(loss):
            return True
        return len(self.recent) == self.every and loss > self.factor * self.reference

    def accept(self, it: int, loss: float) -> None:
        """Record a healthy iteration; keep a copy every ``every`` iterations while the loss is near its median."""
        self.recent.append(loss)
        if (it + 1) % self.every == 0 and loss <= 2 * self.reference:
            self._save()  # the state this loss was measured at, before its step
        self.steps_since_save += 1

    def roll_back(self, it: int) -> bool:
        """Restore the last copy with halved learning rates.

        False when no halving is left, or when no step was taken since the
        copy (the spike is the state itself, not a step: e.g. a science
        function that is not finite at the data).
        """
        if len(self.halved_at) >= self.max_halvings or self.steps_since_save == 0:
            return False
        rates = [group["lr"] for group in self.optimizer.param_groups]
        model_state, optimizer_state = self.saved
        self.model.load_state_dict(model_state)
        self.optimizer.load_state_dict(copy.deepcopy(optimizer_state))
        for group, rate in zip(self.optimizer.param_groups, rates):
            group["lr"] = rate / 2
        self.scheduler.base_lrs = [rate / 2 for rate in self.scheduler.base_lrs]
        self.halved_at.append(it)
        self.steps_since_save = 0
        return True
