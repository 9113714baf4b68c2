"""Early stopping of a fit: stop when the monitored loss and theta have both stopped changing.

Kept apart from the training loop so that the rule is one small object: the
loop reports every iteration's loss and theta, and asks whether to go on.
"""

from __future__ import annotations

import numpy as np

__all__ = ["EarlyStopping"]


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
      ``max(|theta|, 1e-3)``.

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
    """

    def __init__(self, tol: float, n_iter_no_change: int, scale: float = 1.0, validation_loss=None):
        self.tol, self.window = float(tol), int(n_iter_no_change)
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
        scale = np.maximum(np.abs(current[1]), 1e-3)
        moved = bool(np.any(np.abs(current[1] - previous[1]) > self.tol * scale))
        return not improved and not moved
