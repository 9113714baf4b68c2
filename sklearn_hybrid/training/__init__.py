"""Training a hybrid model: the loop, its watchers and the verdict on what it produced.

- ``engine.py``: the training loop (full or mini-batch), whose step asks the method for its
  gradients (``Method.descent``, the one place a method's rule is applied);
- ``schedule.py``: its settings, Adam with cosine annealing, theta's drift at the end;
- ``progress.py``: the progress bar of a training that runs long;
- ``stacked.py``: K configurations trained as one stacked model (sweeps, profiles, bootstrap),
  through the same loop body and ``Method.descent``;
- ``stopping.py``: early stopping and the loss-spike guard;
- ``memory.py``: the memory a fit will need, checked before training;
- ``verdict.py``: a training that diverged or never trained is refused, not handed back.

The methods themselves stay in :mod:`sklearn_hybrid.methods`: they are a choice the user
makes (``method="fsam"`` or ``FisherSAM(rho=0.1)``), this package is how the choice is run.
"""

from .engine import DivergenceError, train
from .schedule import TrainConfig

__all__ = ["train", "TrainConfig", "DivergenceError"]
