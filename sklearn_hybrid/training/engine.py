"""The training loop: Adam with cosine annealing, full or mini-batch, one method's rule.

One iteration (Algorithm 1 of the paper, with Adam): gradients of the loss at
(theta, phi); for the SAM family, phi (or every parameter with
``perturb="all"``) is moved by the method's perturbation, the gradients of
theta *and* phi are taken there, and phi is restored from a copy (exactly,
not by subtraction); then one Adam step on all parameters.
"""

from __future__ import annotations

from contextlib import contextmanager

import numpy as np
import torch
from torch import nn

from ..integrate import fast
from ..methods import per_member
from .progress import progress_bar
from .schedule import TrainConfig, make_optimizer
from .stopping import EarlyStopping, SpikeGuard, target_variance, theta_floor, weighted_variance

__all__ = ["train", "run_steps", "STEP", "SKIP", "STOP", "DivergenceError", "data_loss", "MiniBatches",
           "explain_nonfinite"]


class DivergenceError(FloatingPointError):
    """The training loss became NaN or infinite."""


def data_loss(pred: torch.Tensor, y: torch.Tensor, sample_weight: torch.Tensor | None = None
              ) -> torch.Tensor:
    """Mean squared error over every output value (what all methods minimise).

    With ``sample_weight`` (one non-negative weight per sample) each sample's
    mean squared error counts in proportion to its weight, so a weight of 2
    equals a duplicated sample.
    """
    sq = (pred.reshape(y.shape) - y).pow(2)
    if sample_weight is None:
        return sq.mean()
    return (sq.reshape(len(y), -1).mean(1) * sample_weight).sum() / sample_weight.sum()


@contextmanager
def _frozen_batchnorm_stats(module: nn.Module):
    """Keep BN running statistics from being updated twice per SAM iteration.

    Momentum 0 leaves the running mean and variance as they are; the batch
    counter, which a layer with ``momentum=None`` (cumulative average) divides
    by, is restored too, so the perturbed pass does not count as a batch.
    """
    norms = [m for m in module.modules() if isinstance(m, nn.modules.batchnorm._BatchNorm)]
    saved = [m.momentum for m in norms]
    counts = [None if m.num_batches_tracked is None else m.num_batches_tracked.clone()
              for m in norms]
    for m in norms:
        m.momentum = 0.0
    try:
        yield
    finally:
        for m, momentum, count in zip(norms, saved, counts):
            m.momentum = momentum
            if count is not None:
                m.num_batches_tracked.copy_(count)


class _ScienceNotFinite(Exception):
    def __init__(self, args, out):
        self.args, self.out = args, out


def explain_nonfinite(model: nn.Module, inputs: tuple[torch.Tensor, ...]) -> str | None:
    """Say whether the science function is where non-finite values start, and for which input.

    Runs the model once more on ``inputs`` (without gradients, on the plain
    autograd path, so the science is called through its module) and stops at
    the first science call that turns finite inputs into NaN or infinity.

    Returns
    -------
    str or None
        A message naming the science function, the offending input row and
        theta; None if the science stays finite there (the network or the
        optimiser produced the non-finite values).
    """
    def check(module, args, out):
        if all(torch.isfinite(a).all() for a in args) and not torch.isfinite(out).all():
            raise _ScienceNotFinite(args, out)

    hook = model.science.register_forward_hook(check)
    try:
        with torch.no_grad(), fast.disabled():  # the fast path calls science.func directly
            model(*inputs)
    except _ScienceNotFinite as found:
        bad = ~torch.isfinite(found.out).reshape(len(found.out), -1).all(dim=1)
        row = int(bad.nonzero()[0])
        values = ", ".join(f"{n}={a[row].tolist()}" for n, a in zip(model.science.inputs, found.args))
        return (f"The science function {model.science.name!r} returned {found.out[row].tolist()} for {values} "
                f"({int(bad.sum())} of {len(bad)} rows of that call non-finite; theta "
                f"{model.science.as_dict()}). Make it finite over the range the data and the "
                "model visit (guard its domain, or bound theta with theta_bounds).")
    except Exception:  # the diagnosis must never hide the divergence it explains
        return None
    finally:
        hook.remove()
    return None


def _loss_and_grads(model, method, inputs, y, weight, params):
    wanted = [p for p in params if p.requires_grad]
    if not wanted:  # nothing to differentiate (a science model held at its values): the loss, without a graph
        with torch.no_grad():
            pred, extras = model(*inputs)
            loss = data_loss(pred, y, weight) + method.penalty(model, pred, extras, weight)
        return loss, [torch.zeros_like(p) for p in params]
    pred, extras = model(*inputs)
    loss = data_loss(pred, y, weight) + method.penalty(model, pred, extras, weight)
    grads = iter(torch.autograd.grad(loss, wanted, allow_unused=True))
    grads = [next(grads) if p.requires_grad else None for p in params]
    return loss.detach(), [torch.zeros_like(p) if g is None else g for p, g in zip(params, grads)]


class MiniBatches:
    """Mini-batch indices from a private generator (full batch when size is None)."""

    def __init__(self, n, batch_size, generator):
        self.n, self.size, self.gen = n, batch_size, generator
        self.order, self.pos = None, n

    def next(self):
        if self.size is None or self.size >= self.n:
            return None
        if self.pos + self.size > self.n:
            self.order, self.pos = torch.randperm(self.n, generator=self.gen), 0
        idx = self.order[self.pos:self.pos + self.size]
        self.pos += self.size
        return idx


#: What a watcher tells the loop after the first gradient of an iteration: take the step, skip it (the
#: watcher undid something), or end the training.
STEP, SKIP, STOP = "step", "skip", "stop"


def run_steps(method, config: TrainConfig, optimizer, scheduler, params: list, perturbed: list, is_weight: list,
              next_batch, loss_and_grads, watch, n_batch_dims: int = 0, desc: str | None = None,
              at_perturbed=None, loss_scale=1.0) -> int:
    """The loop body of every training: a single fit and the stacked members of sweeps, profiles and the
    bootstrap.

    Each iteration takes a batch (``next_batch()``), the loss and the gradients at the current point
    (``loss_and_grads(batch, wrt)``, of the perturbed tensors alone for the SAM family), asks the
    watcher (``watch.check(it, loss, batch)``: :data:`STEP`, :data:`SKIP` or :data:`STOP`), takes the
    method's gradients (:meth:`~sklearn_hybrid.methods.Method.descent`; the second pass by
    ``at_perturbed(batch)``), lets the
    watcher mask them (``watch.masked(grads)``), steps the optimiser and the schedule, and asks the
    watcher whether to stop (``watch.stepped(it, loss, rate)``, ``rate`` theta's learning rate of the
    step).  The watcher keeps the records, the guards and the stopping rules; ``watch.bar`` is the
    progress bar.

    Every gradient is divided by ``loss_scale`` (the variance of ``y``, one per stacked member:
    :func:`~sklearn_hybrid.training.stopping.weighted_variance`) before the
    method and the optimiser see it, as if the loss were in units of the data's own spread: Adam's ``eps``, the
    network's weight decay and Fisher SAM's damping then weigh the same in any units of ``y``.  The losses
    recorded stay in the user's units.

    Returns
    -------
    int
        The iterations run.
    """
    if not np.all(np.asarray(loss_scale) == 1.0):
        loss_and_grads = _scaled_gradients(loss_and_grads, loss_scale)
        at_perturbed = None if at_perturbed is None else _scaled_gradients(at_perturbed, loss_scale)
    if at_perturbed is None:
        def at_perturbed(batch):
            return loss_and_grads(batch, params)
    bar = progress_bar(config.max_iter, config.verbose, desc or method.name)
    watch.bar = bar
    n_iter = config.max_iter
    try:
        for it in bar:
            rate = optimizer.param_groups[0]["lr"]  # theta's, for theta_drift
            batch = next_batch()
            # the SAM family needs only the perturbed tensors' gradients at the first point
            loss, grads = loss_and_grads(batch, perturbed if method.perturbs else params)
            action = watch.check(it, loss, batch)
            if action == SKIP:
                scheduler.step()
                continue
            if action == STOP:
                n_iter = it + 1
                break
            grads = method.descent(params, perturbed, grads, is_weight, lambda: at_perturbed(batch),
                                   n_batch_dims=n_batch_dims)
            grads = watch.masked(grads)
            for p, g in zip(params, grads):
                p.grad = g
            optimizer.step()
            scheduler.step()
            if watch.stepped(it, loss, rate):
                n_iter = it + 1
                break
    finally:
        bar.close()
    return n_iter


def _scaled_gradients(loss_and_grads, scale):
    """``loss_and_grads`` whose gradients are divided by ``scale`` (a number, or one per stacked member);
    the loss as it was."""
    def scaled(*args):
        loss, grads = loss_and_grads(*args)
        return loss, [g / per_member(scale, g) for g in grads]

    return scaled


class _FitWatch:
    """A single fit's watcher: the records, the spike guard, divergence and early stopping."""

    def __init__(self, model, config, optimizer, scheduler, y, validation):
        self.model, self.config = model, config
        self.names = model.science.names
        self.losses, self.lr_theta = np.empty(config.max_iter), np.empty(config.max_iter)
        self.thetas = {n: np.empty((config.max_iter, *model.science.shapes[n])) for n in self.names}
        self.stopper = _make_stopper(model, config, y, validation)
        with torch.no_grad():  # where theta started, for the message of a theta that diverges
            self.start = {n: v.detach().cpu().numpy().copy() for n, v in model.theta_values().items()}
        self.guard = SpikeGuard(model, optimizer, scheduler)
        self.bar = None

    def record(self, it, loss_value, rate):
        self.losses[it], self.lr_theta[it] = loss_value, rate
        with torch.no_grad():
            for n, v in self.model.theta_values().items():
                self.thetas[n][it] = v.cpu().numpy()

    def check(self, it, loss, batch):
        loss_value = self.loss_value = float(loss)
        guard = self.guard
        if guard.is_spike(loss_value):
            if guard.roll_back(it):  # no step this iteration; it records the loss level it returned to
                self.record(it, guard.reference if guard.recent else loss_value, 0.0)
                return SKIP
            if not np.isfinite(loss_value):
                cause = self.theta_diverged(it) or explain_nonfinite(self.model, batch[0])
                raise DivergenceError(
                    f"The training loss became {loss_value} at iteration {it}"
                    + (f" (after halving the learning rates {len(guard.halved_at)} times)"
                       if guard.halved_at else "") + ". " + (cause or (
                        "Lower lr or rho, check the data scale, or bound theta with theta_bounds.")))
        guard.accept(it, loss_value)  # out of halvings, a finite spike is trained through
        return STEP

    def theta_diverged(self, it) -> str | None:
        """Say that theta itself diverged (became non-finite, or a million times its starting size), from
        where, or None: such a theta makes any science function return NaN, and blaming the science for it
        would send the user to the wrong place."""
        with torch.no_grad():
            now = {n: v.detach().cpu().numpy() for n, v in self.model.theta_values().items()}
        bad = [n for n, v in now.items() if not np.all(np.isfinite(v))
               or np.any((self.start[n] != 0) & (np.abs(v) > 1e6 * np.abs(self.start[n])))]
        if not bad:
            return None
        last = {n: self.thetas[n][it - 1].tolist() for n in bad} if it > 0 else None
        return (f"theta diverged: {', '.join(f'{n} became {now[n].tolist()}' for n in bad)}, from "
                f"{ {n: self.start[n].tolist() for n in bad} } at the start"
                + (f" ({last} at iteration {it - 1})" if it > 0 else "")
                + "; the science function is not the cause. The steps were too large for the data: lower lr "
                  "(or lr_theta), or bound theta with theta_bounds.")

    def masked(self, grads):
        return grads

    def stepped(self, it, loss, rate) -> bool:
        self.record(it, self.loss_value, rate)
        if self.config.verbose and (it % 25 == 0 or it == self.config.max_iter - 1):
            self.bar.set_postfix(refresh=False, loss=f"{self.loss_value:.3g}", **{  # a refresh would skip the delay
                n: np.array2string(self.thetas[n][it], precision=4) for n in self.names})
        return self.stopper is not None and self.stopper.should_stop(
            it, self.losses, np.concatenate([self.thetas[n][it].ravel() for n in self.names]))


def train(model: nn.Module, method, inputs: tuple[torch.Tensor, ...], y: torch.Tensor,
          config: TrainConfig, generator: torch.Generator,
          sample_weight: torch.Tensor | None = None, validation: tuple | None = None) -> dict:
    """Train ``model`` in place and return its history.

    Parameters
    ----------
    model : HybridModule
        Science part, residual network and structure.
    method : Method
        The training method (penalty and perturbation rule).
    inputs : tuple of Tensor
        Structure inputs, each with the samples on the first axis.
    y : Tensor
        Targets, samples on the first axis.
    config : TrainConfig
        Optimisation settings.
    generator : torch.Generator
        Source of randomness for mini-batches.
    sample_weight : Tensor of shape (n_samples,), optional
        Per-sample weights of the data loss.
    validation : tuple, optional
        ``(inputs, y, sample_weight)`` of held-out samples whose data loss
        early stopping monitors (see :class:`~sklearn_hybrid.training.stopping.EarlyStopping`).

    Returns
    -------
    dict
        ``{"loss": ndarray (n_iter,), "theta": {name: ndarray (n_iter, ...)},
        "n_iter": int, "stopped_early": bool, "lr_theta": ndarray (n_iter,),
        "lr_halved_at": list of int}`` (plus ``"validation_loss"``,
        one value per stopping window, when ``validation`` is given); the loss
        is the training objective at the unperturbed parameters, ``lr_theta``
        theta's learning rate of each step (0 where a loss spike was undone)
        and ``lr_halved_at`` the iterations of those spikes (see
        :class:`~sklearn_hybrid.training.stopping.SpikeGuard`: the last good state is
        restored and the learning rates are halved).  With
        ``config.tol`` set, training stops before ``max_iter`` once the loss and
        theta have stopped changing.

    Raises
    ------
    DivergenceError
        If the loss or a parameter becomes NaN or infinite after the
        guard's last halving of the learning rates.
    """
    theta = model.theta_parameters()  # with a theta encoder: its weights
    phi = list(model.residual.parameters())
    extra = [] if model.reduction is None else list(model.reduction.parameters())
    params = theta + phi + extra
    phi_is_weight = ["weight" in name for name, _ in model.residual.named_parameters()]
    theta_is_weight = [False] * len(theta)
    if model.encoder is not None:  # ASAM scales the encoder's weights too (perturbed with perturb="all")
        encoder = list(model.encoder.named_parameters())
        theta_is_weight = [False] * (len(theta) - len(encoder)) + ["weight" in n for n, _ in encoder]
    perturbed, is_weight = method.perturbed(phi, theta, phi_is_weight, theta_is_weight, config.perturb)

    optimizer, scheduler = make_optimizer(theta, phi + extra, config)
    batches = MiniBatches(len(y), config.batch_size, generator)
    watch = _FitWatch(model, config, optimizer, scheduler, y, validation)

    def next_batch():
        idx = batches.next()
        if idx is None:
            return inputs, y, sample_weight
        return (tuple(t[idx] for t in inputs), y[idx],
                None if sample_weight is None else sample_weight[idx])

    def loss_and_grads(batch, wrt):
        return _loss_and_grads(model, method, *batch, wrt)

    def at_perturbed(batch):
        with _frozen_batchnorm_stats(model):
            return _loss_and_grads(model, method, *batch, params)

    model.train()
    n_iter = run_steps(method, config, optimizer, scheduler, params, perturbed, is_weight, next_batch,
                       loss_and_grads, watch, at_perturbed=at_perturbed,
                       loss_scale=weighted_variance(y, sample_weight))
    if not all(torch.isfinite(p).all() for p in params):
        raise DivergenceError(f"A parameter became NaN or infinite at iteration {n_iter - 1}.")
    history = {"loss": watch.losses[:n_iter], "theta": {n: v[:n_iter] for n, v in watch.thetas.items()},
               "n_iter": n_iter, "stopped_early": n_iter < config.max_iter,
               "lr_theta": watch.lr_theta[:n_iter], "lr_halved_at": list(watch.guard.halved_at)}
    if watch.stopper is not None and validation is not None:
        history["validation_loss"] = np.array(watch.stopper.validation_history)
    return history


def _make_stopper(model, config, y, validation):
    """The early-stopping rule of ``config`` (None when ``tol`` is None)."""
    if config.tol is None:
        return None
    scale, floor = target_variance(y), theta_floor(model.science)
    if validation is None:
        return EarlyStopping(config.tol, config.n_iter_no_change, scale, theta_floor=floor)
    inputs, y, weight = validation

    def validation_loss():
        was_training = model.training
        model.eval()
        try:
            with torch.no_grad():
                pred, _ = model(*inputs)
                return float(data_loss(pred, y, weight))
        finally:
            model.train(was_training)

    return EarlyStopping(config.tol, config.n_iter_no_change, scale, validation_loss, theta_floor=floor)
