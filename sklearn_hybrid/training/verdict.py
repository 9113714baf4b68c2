"""After training, before a fit is handed back: did the run diverge, or never train?

The spike guard of the training loop (``stopping.SpikeGuard``) restores the
last good state after a loss spike, but once its halvings are spent it trains
through, and a run can then end far worse than it began (a training R^2 of
-1e24 after ``lr=1``).  A run can also end without error and still be no model
at all: with a SAM radius far too large, theta never leaves its start.  This
module reads what training shows and says which it was, so that such a model
is refused, or at least marked as not usable, instead of being returned as a fit.
"""

from __future__ import annotations

import inspect

import numpy as np
import torch

from ..residual import is_zero_residual
from .stopping import SpikeGuard
from .engine import DivergenceError, data_loss, explain_nonfinite

__all__ = ["TrainingVerdict", "judge_training", "explain_start"]

#: A final training loss this many times above the larger of the loss at the start and the
#: variance of y (a training R^2 below about -(factor - 1)) is a diverged run: refused.
DIVERGED_FACTOR = 100.0
#: A model worse than predicting the mean of y (training R^2 < 0) that also ended this many times
#: above its start, or above its own science part alone, went bad: the training made it worse, or
#: the network spoils the science.  The margins keep short fits apart (a few iterations on noise
#: end at up to 1.0 times their start and 2.1 times the science alone in the test suite).
WORSE_THAN_START = 2.0
WORSE_THAN_SCIENCE = 10.0
#: Halvings after which the spike guard trains through a spike (``SpikeGuard``'s ``max_halvings``).
_GUARD_HALVINGS = inspect.signature(SpikeGuard).parameters["max_halvings"].default
#: Fewer iterations than the spike guard's window are too few to judge whether a run went bad: a
#: fit of 1 to 5 iterations (the smoke tests of the suite, the gallery's quick runs) may still end
#: above its start.
_GUARD_WINDOW = inspect.signature(SpikeGuard).parameters["every"].default
#: Samples the verdict predicts after a mini-batch fit: about a batch's forward pass, a
#: fraction of one training iteration, however many samples there are.
_CHECK_SAMPLES_MIN = 256


class TrainingVerdict:
    """What the verdict found: the numbers it read and, if any, why the model is not usable.

    Attributes
    ----------
    loss, start, science_loss, baseline : float
        The final data loss on the training samples checked, the loss at the first
        iteration, the loss of the science part alone with the fitted theta (NaN
        where the structure has no science-only prediction) and the loss of
        predicting the mean of ``y``.
    r2 : float
        Training R^2 over every output value (as ``score`` computes it).
    problems : list of str
        Why the model is not usable (empty for a usable fit).
    """

    def __init__(self, loss, start, science_loss, baseline, r2, problems):
        self.loss, self.start, self.science_loss = loss, start, science_loss
        self.baseline, self.r2, self.problems = baseline, r2, problems

    @property
    def usable(self) -> bool:
        return not self.problems

    def summary(self) -> str:
        """One sentence: why the model is not usable, with the numbers."""
        return "; ".join(self.problems)


def _check_rows(n: int, batch_size: int | None) -> np.ndarray:
    """Which training samples the verdict predicts: all after a full-batch fit (one forward pass
    costs less than an iteration), else evenly spaced ones, as many as a batch or 256."""
    if batch_size is None or batch_size >= n:
        return np.arange(n)
    return np.unique(np.linspace(0, n - 1, min(n, max(batch_size, _CHECK_SAMPLES_MIN))).round().astype(int))


def _predict(model, inputs, chunk, use_residual=True):
    n = len(inputs[0])
    with torch.no_grad():
        return torch.cat([model(*(t[s:s + chunk] for t in inputs), use_residual=use_residual)[0]
                          for s in range(0, n, chunk)])


def _r2(pred, y, weight):
    """R^2 averaged over the output values, as sklearn.metrics.r2_score (uniform average) gives it."""
    pred, y = pred.reshape(len(y), -1).double(), y.reshape(len(y), -1).double()
    w = torch.ones(len(y), dtype=y.dtype, device=y.device) if weight is None else weight.double()
    w = w[:, None] / w.sum()
    mean = (w * y).sum(0)
    total = (w * (y - mean) ** 2).sum(0)
    resid = (w * (y - pred) ** 2).sum(0)
    varies = total > 0
    if not varies.any():
        return float("nan"), 0.0
    r2 = 1 - resid[varies] / total[varies]
    return float(r2.mean()), float(total.mean())


def judge_training(model, history: dict, inputs, y, sample_weight=None, *, theta_start=None,
                   batch_size=None, chunk=512, advice="") -> TrainingVerdict:
    """Judge a finished training run from the loss, the training R^2 and theta's history.

    Parameters
    ----------
    model : HybridModule
        The trained model (put in evaluation mode).
    history : dict
        What :func:`~sklearn_hybrid.training.engine.train` returned.
    inputs : tuple of Tensor
        The trained samples' structure inputs.
    y : Tensor
        Their targets.
    sample_weight : Tensor, optional
        Their weights.
    theta_start : dict, optional
        ``name -> value`` of the free parameters before training: a theta that
        never left it was not estimated.
    batch_size : int, optional
        The fit's mini-batch size: the verdict then predicts a subset of the samples.
    chunk : int, default=512
        Samples per forward pass.
    advice : str, default=""
        What to change, ending the message of a divergence.

    Returns
    -------
    TrainingVerdict
        ``problems`` lists why the model is not usable (judged from the
        spike guard's window of 25 iterations on): its training R^2 is
        negative (worse than predicting the mean of ``y``) while its loss ended
        ``WORSE_THAN_START`` times above the loss it started from or
        ``WORSE_THAN_SCIENCE`` times above its science part alone, or after the
        spike guard spent its halvings, or while theta never moved; or theta
        never moved at all.

    Raises
    ------
    DivergenceError
        If the predictions on the training data are not finite, or the loss
        spiked (the guard halved the learning rates) and ended more than
        ``DIVERGED_FACTOR`` times the larger of the loss at the start and the
        variance of ``y``: the run diverged.
    """
    rows = _check_rows(len(y), batch_size)
    index = torch.as_tensor(rows, device=y.device)
    inputs = tuple(t[index] for t in inputs)
    y = y[index]
    weight = None if sample_weight is None else sample_weight[index]
    model.eval()
    pred = _predict(model, inputs, chunk)
    loss = float(data_loss(pred, y, weight))
    r2, baseline = _r2(pred, y, weight)
    start = float(history["loss"][0]) if len(history["loss"]) else float("nan")
    halved = history.get("lr_halved_at") or []
    spikes = (f" The loss spiked at iteration(s) {halved} and the learning rates were halved each time. "
              if halved else " ")
    if not np.isfinite(loss):
        raise DivergenceError(
            f"The training diverged: the trained model's predictions on the training data are not finite "
            f"(the loss was {start:.4g} at the start).{spikes}{advice}")
    reference = max(start, baseline) if np.isfinite(start) else baseline
    # with the spike guard at work: a loss that only rose from a start near zero (one step on y = 0) is no divergence
    if halved and reference > 0 and loss > DIVERGED_FACTOR * reference:
        raise DivergenceError(
            f"The training diverged: the training loss ended at {loss:.4g}, {loss / max(start, 1e-300):.3g} "
            f"times its start ({start:.4g}); the training R^2 is {r2:.4g}.{spikes}{advice}")
    if is_zero_residual(getattr(model, "residual", None)):  # no network: the prediction is the science's
        science_loss = loss
    else:
        try:
            science_loss = float(data_loss(_predict(model, inputs, chunk, use_residual=False), y, weight))
        except ValueError:  # a structure without a science-only prediction (a user composition)
            science_loss = float("nan")
    problems = []
    if len(history["loss"]) < _GUARD_WINDOW:  # a smoke test of a few iterations: too short to judge
        return TrainingVerdict(loss, start, science_loss, baseline, r2, problems)
    still = _never_moved(history, theta_start)
    if r2 < 0:
        worse = []
        if np.isfinite(start) and loss > WORSE_THAN_START * start:
            worse.append(f"{loss / start:.3g} times its start ({start:.4g})")
        if np.isfinite(science_loss) and loss > WORSE_THAN_SCIENCE * science_loss:
            worse.append(f"{loss / science_loss:.3g} times the loss of the science part alone with the "
                         f"fitted theta ({science_loss:.4g})")
        if len(halved) >= _GUARD_HALVINGS:  # the guard gave up: the last spikes were trained through
            worse.append(f"after the loss spiked {len(halved)} times (iterations {halved})")
        if worse or still:
            problems.append(f"its training R^2 is {r2:.3g} (worse than predicting the mean of y), the loss "
                            f"ended at {loss:.4g}" + (", " + " and ".join(worse) if worse else ""))
    if still:
        problems.append(f"theta never moved from its start ({', '.join(still)}): it was not estimated")
    return TrainingVerdict(loss, start, science_loss, baseline, r2, problems)


def _never_moved(history, theta_start) -> list[str]:
    """The free parameters whose every recorded value is their start (``name=value``)."""
    if not theta_start or len(history["loss"]) < 2:
        return []
    still = []
    for name, start in theta_start.items():
        path = np.asarray(history["theta"][name], dtype=float).reshape(len(history["loss"]), -1)
        if np.array_equal(path, np.broadcast_to(np.asarray(start, dtype=float).reshape(1, -1), path.shape)):
            still.append(f"{name}={np.asarray(start).tolist()}")
    return still


def _blows_up(pred, y) -> bool:
    """Predictions that are not finite, whose squared errors are not, or that exceed the range of
    ``y`` a thousandfold (an integration that grew without bound, still finite in float32)."""
    scale = float(y.abs().max())
    return (not torch.isfinite(pred).all() or not np.isfinite(float(data_loss(pred, y)))
            or (scale > 0 and float(pred.abs().max()) > _BLOWN_UP * scale))


#: Predictions this many times beyond the largest target have blown up.
_BLOWN_UP = 1e3


def explain_start(model, initial_state: dict, inputs, y, chunk=512) -> str | None:
    """Why a training diverged, if its model blew up before any step; None otherwise.

    The training loop can only say that the loss was not finite and suggest a
    lower learning rate, which cannot help when the model at its start already
    blows up.  Restored to ``initial_state``, the model is run on the training
    ``inputs``: if the science part alone blows up, an ODE's integration step
    (``dt / n_substeps``) is too long for the dynamics (or theta's start makes
    them unstable); if only the hybrid does, the network's random start blows
    a long integration up.  A science function that is itself not finite at
    finite inputs is named by the loop already (None here).
    """
    model.load_state_dict(initial_state)
    model.eval()
    s = model.structure
    if not hasattr(s, "n_steps"):  # not an ODE: nothing integrated, the loop's message stands
        return None
    if not _blows_up(_predict(model, inputs, chunk), y) or explain_nonfinite(model, inputs) is not None:
        return None
    science_blows_up = _blows_up(_predict(model, inputs, chunk, use_residual=False), y)
    span = (f"{s.n_steps} steps of dt={s.dt:g} ({s.n_steps * s.dt:.4g} time units; solver={s.solver!r}, "
            f"n_substeps={s.n_substeps}: integration steps of {s.dt / s.n_substeps:.3g})")
    if science_blows_up:
        return (f"The science model alone, with its initial theta {model.science.as_dict()}, blows up along "
                f"the training trajectories before any training step (integrated over {span}, it grows "
                f"beyond {_BLOWN_UP:g} times the largest |y|), although the science function is finite "
                "wherever it is called. The integration step is too long for these dynamics: give dt as "
                "the time between the samples of y, in the time unit of the science function, or raise "
                "n_substeps (or start theta where the dynamics are stable, with theta_init).")
    return (f"The hybrid model blows up along the training trajectories before any training step, while "
            f"the science model alone does not: the network's random start adds a force that the "
            f"integration over {span} amplifies beyond {_BLOWN_UP:g} times the largest |y|. Trajectories "
            "this long are hard to train from any start (their gradients blow up too): cut them into "
            "shorter windows (sklearn_hybrid.datasets.make_windows), or start the network at zero, so that "
            "training starts from the science model alone (residual={'kind': 'mlp', 'zero_init': True, "
            "'activation': 'tanh'}).")
