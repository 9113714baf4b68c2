"""What a training optimises with: the settings, Adam with a cosine-annealed learning rate, and how much theta
still moved at the end of that schedule."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import torch

__all__ = ["TrainConfig", "make_optimizer", "cosine_lr", "theta_drift", "THETA_LR_FACTOR"]

#: theta's default learning rate over the network's.  theta steps relative to its size (a raw step of 0.02 is 2 %
#: of it), which for a parameter of order 0.5 is the absolute step of ``lr`` it took before it was relative.
THETA_LR_FACTOR = 2.0


@dataclass
class TrainConfig:
    """Optimisation settings (validated by the estimator)."""

    lr: float = 1e-2
    lr_theta: float | None = None
    max_iter: int = 1000
    batch_size: int | None = None
    weight_decay: float = 1e-5
    perturb: str = "residual"
    min_lr: float = 1e-6
    verbose: bool | str = False  # "auto": a bar once the fit has run ``progress.AUTO_DELAY`` seconds
    tol: float | None = None
    n_iter_no_change: int = 100
    theta_lr_factor: float = THETA_LR_FACTOR  # for theta's raw values; 1 for a theta encoder's weights

    @property
    def theta_lr(self) -> float:
        """theta's initial learning rate: ``lr_theta``, else ``theta_lr_factor * lr``."""
        return self.lr_theta or self.theta_lr_factor * self.lr


def make_optimizer(theta: list, phi: list, config: TrainConfig):
    """Adam with a cosine-annealed learning rate (one period over ``max_iter``).

    theta gets no weight decay (decay would bias the physics) and its own
    learning rate when ``config.lr_theta`` is set; the network gets the slight
    ``weight_decay``.  Parameter tensors may carry a leading member axis.
    """
    optimizer = torch.optim.Adam(
        [{"params": theta, "weight_decay": 0.0, "lr": config.theta_lr},
         {"params": phi, "weight_decay": config.weight_decay}], lr=config.lr)
    scheduler = torch.optim.lr_scheduler.CosineAnnealingLR(
        optimizer, T_max=config.max_iter, eta_min=min(config.min_lr, config.lr))
    return optimizer, scheduler


def cosine_lr(base_lr: float, n_iter: int, config: TrainConfig) -> np.ndarray:
    """The learning rate of a parameter group over its first ``n_iter`` iterations.

    Closed form of :func:`make_optimizer`'s schedule: ``base_lr`` (``config.lr``
    or ``config.lr_theta``) cosine-annealed over ``config.max_iter`` to
    ``min(config.min_lr, config.lr)``.
    """
    eta_min = min(config.min_lr, config.lr)
    t = np.arange(n_iter)
    return eta_min + (base_lr - eta_min) * (1 + np.cos(np.pi * t / config.max_iter)) / 2


def theta_drift(theta: dict, lr: np.ndarray, fraction: float = 0.1) -> dict:
    """How much theta still moved at the end of training, independently of the schedule.

    The window is the last iterations in which ``fraction`` of theta's summed
    learning rate was spent (under a cosine schedule to ~0 that is about the
    last 30 % of the iterations for ``fraction=0.1``; under a constant rate,
    the last 10 %).  Adam moves a parameter by about its learning rate per
    step, so a theta pushed steadily in one direction moves about ``fraction``
    of its whole travel there however the rate was annealed, while a theta
    that has settled moves by much less.  A window of plain iterations would
    not tell the two apart: the cosine schedule makes every theta look still
    in its last 10 % of iterations (they hold 0.2 % of the summed rate).

    Parameters
    ----------
    theta : dict of str to ndarray
        ``name -> (n_iter, ...)``: theta after each iteration (``history_["theta"]``).
    lr : ndarray of shape (n_iter,)
        theta's learning rate at each iteration (see :func:`cosine_lr`).
    fraction : float, default=0.1
        Share of the summed learning rate that the window holds.

    Returns
    -------
    dict of str to float
        ``name -> `` the largest relative change ``|theta_end - theta_start| /
        |theta_end|`` over the parameter's entries, ``theta_start`` the value
        at the window's start (NaN for an empty history).
    """
    lr = np.asarray(lr, dtype=float)
    out = {}
    for name, path in theta.items():
        path = np.reshape(np.asarray(path, dtype=float), (len(path), -1))
        if len(path) == 0:
            out[name] = float("nan")
            continue
        cum = np.cumsum(lr[:len(path)])
        start = min(int(np.searchsorted(cum, (1 - fraction) * cum[-1])), len(path) - 1)
        change = np.abs(path[-1] - path[start]) / np.maximum(np.abs(path[-1]), 1e-12)
        out[name] = float(change.max())
    return out
