"""Train K configurations of one hybrid model as a single stacked model.

Every parameter tensor of the K member models is stacked along a new leading
*member* axis.  Each member's loss depends only on its own slice, so the
gradient of the summed loss is, slice by slice, the gradient each member
would get alone; the perturbation rules of the SAM family take per-member
norms (``n_batch_dims=1``) and a per-member ``rho``; Adam and weight decay act
element by element.  A member therefore takes exactly the steps a separate
:class:`~sklearn_hybrid.HybridRegressor` fit with the same seed takes (up to
floating-point summation order), while the K small problems share each
operation, which amortises per-operation overhead and fills the matrix units.

Three forward paths: hybrid ODEs with an MLP over a small state use the
stacked RK4 of :mod:`sklearn_hybrid.integrate.fast`; other models run under
:func:`torch.func.vmap` with :func:`torch.func.functional_call`, except
convolutional ones, which ``vmap`` would turn into slow grouped
convolutions: those run member by member (already arithmetic-bound, they
gain nothing from stacking).
"""

from __future__ import annotations

import numpy as np
import torch
from torch import nn

from joblib import Parallel, delayed

from ..integrate import fast
from ..integrate.kernels import reusing_buffers
from .._validation import torch_threads
from ..methods import per_member
from .engine import DivergenceError, MiniBatches, STEP, STOP, run_steps, train
from .schedule import TrainConfig, make_optimizer
from .stopping import EarlyStopping, target_variance, theta_floor, weighted_variance
from .verdict import DIVERGED_FACTOR

__all__ = ["train_batched", "train_members", "train_one_by_one", "evaluate_members"]


class _StackedModel:
    """The K members' parameters stacked, and their per-member losses."""

    def __init__(self, models: list, inputs: tuple):
        self.base = models[0]
        names = [n for n, _ in self.base.named_parameters()]
        self.names = names
        self.params = {}
        for name in names:
            members = [dict(m.named_parameters())[name] for m in models]
            stacked = torch.stack([p.detach() for p in members]).clone()
            self.params[name] = stacked.requires_grad_(members[0].requires_grad)
        # floating buffers (theta's bounds and scale, the network's data scales) per member: a member built on
        # other data or from another start has its own, as it would alone
        self.shared, self.buffers = {}, {}
        for name, buffer in self.base.named_buffers():
            if buffer.is_floating_point():
                self.buffers[name] = torch.stack([dict(m.named_buffers())[name] for m in models])
            else:
                self.shared[name] = buffer
        structure = self.base.structure
        self.fast = (getattr(structure, "solver", None) is not None
                     and fast.supports(self.base.residual, tuple(structure.state_shape),
                                        structure.solver)
                     and fast.row_by_row(self.base.science.func, inputs[0],
                                           inputs[1] if len(inputs) > 1 else None,
                                           self.base.science.values()))
        if not self.fast and any(isinstance(m, nn.modules.batchnorm._BatchNorm) and m.track_running_stats
                                 for m in self.base.modules()):
            raise ValueError(
                "Batched training cannot update batch-norm running statistics per member; "
                "use track_running_stats=False or fit the configurations separately."
            )
        self.n_inputs = len(inputs)
        self.convolutional = any(isinstance(m, nn.modules.conv._ConvNd) for m in self.base.modules())

    def group(self, prefix):
        return [self.params[n] for n in self.names if n.startswith(prefix) and self.params[n].requires_grad]

    def theta_values(self) -> dict:
        """Every member's theta, ``name -> (K, ...)``, each through its own bounds and scale."""
        science = self.base.science
        return {n: science.transforms[n].map(self.params[f"science.raw.{n}"],
                                             *(self.buffers[f"science.transforms.{n}.{b}"]
                                               for b in ("low", "high", "scale")))
                for n in science.names}

    def _fast_predictions(self, inputs):
        science, structure = self.base.science, self.base.structure
        values = self.theta_values()
        thetas = [values[n] for n in science.names]
        layers = [n for n in self.names if n.startswith("residual.")]
        weights = [self.params[n] for n in layers if n.endswith("weight")]
        biases = [self.params[n] for n in layers if n.endswith("bias")]
        _, _, acts = fast.mlp_parts(self.base.residual)
        mlp = "residual.mlp." if hasattr(self.base.residual, "mlp") else "residual."  # a MaskedMLP's own MLP
        scales = tuple(self.buffers[mlp + b] for b in ("in_shift", "in_scale", "out_scale"))
        weights, biases = fast.full_output(self.base.residual, weights, biases, scales)
        x0, u_fine = inputs[0], (inputs[1] if len(inputs) > 1 else None)
        states = fast.ode_states(science.func, science.names, thetas, weights, biases, acts,
                                  x0, u_fine, structure.n_steps, structure.dt, structure.n_substeps)
        return states if structure.observed is None else states[..., structure.observed]

    def predictions(self, inputs):
        """Predictions of every member, ``(K, batch, ...)``; inputs carry the member axis."""
        if self.fast:
            return self._fast_predictions(inputs)

        def member(params, buffers, *member_inputs):
            pred, _ = torch.func.functional_call(self.base, (params, buffers, self.shared), member_inputs)
            return pred

        if self.convolutional:  # vmap turns convolutions into slow grouped ones: one by one
            K = len(inputs[0])
            return torch.stack([member({n: p[k] for n, p in self.params.items()},
                                       {n: b[k] for n, b in self.buffers.items()},
                                       *(t[k] for t in inputs)) for k in range(K)])
        with fast.disabled():  # the custom autograd function does not run under vmap
            return torch.func.vmap(member)(self.params, self.buffers, *inputs)


def _member_loss(pred, y, weight=None):
    """Mean squared error per member (the data loss of :func:`engine.data_loss`), each sample
    weighted by its member's ``weight`` (K, batch) when given."""
    per_sample = (pred.reshape(y.shape) - y).pow(2).reshape(*y.shape[:2], -1).mean(-1)
    if weight is None:
        return per_sample.mean(1)
    return (per_sample * weight).sum(1) / weight.sum(1)


def _check_stackable(method):
    if not method.stackable:
        raise ValueError(
            f"Method {method.name!r} cannot train as stacked members (its penalty needs the whole "
            "model); fit the configurations separately.")


def _trained_groups(stacked, method, config, held):
    """theta and phi tensors of the stacked model, the ones the method perturbs, and a gradient mask
    per held theta (a profile holds one parameter at a grid value in every member)."""
    theta, phi = stacked.group("science."), stacked.group("residual.")
    residual_names = [n for n in stacked.names if n.startswith("residual.") and stacked.params[n].requires_grad]
    perturbed, is_weight = method.perturbed(phi, theta, ["weight" in n for n in residual_names],
                                            [False] * len(theta), config.perturb)
    names = [n for n in stacked.names if n.startswith("science.") and stacked.params[n].requires_grad]
    masks = {}
    for name, mask in (held or {}).items():
        key = f"science.raw.{name}"
        if key in names:
            free = ~torch.as_tensor(mask, dtype=torch.bool, device=theta[0].device)
            masks[names.index(key)] = free.to(theta[0].dtype)
    return theta, phi, perturbed, is_weight, masks


def train_batched(models: list, method, inputs: tuple, y: torch.Tensor, config: TrainConfig,
                  generators: list, sample_weight: torch.Tensor | None = None,
                  held: dict | None = None) -> dict:
    """Train K member models (built as separate fits would build them) as one.

    Parameters
    ----------
    models : list of HybridModule
        The K members, freshly initialised or warm-started from a fit; their
        parameters receive the result.
    method : Method
        The training method, its hyperparameters one value for all members or
        one per member (:meth:`Method.for_members`).
    inputs : tuple of Tensor
        Structure inputs shared by the members, samples first.
    y : Tensor
        Targets, samples first.
    config : TrainConfig
        Shared optimisation settings (``verbose`` shows a progress bar).
    generators : list of torch.Generator
        Each member's mini-batch generator (seeded as a separate fit seeds it).
    sample_weight : Tensor of shape (K, n_samples), optional
        Each member's weights of the samples (a bootstrap resample per member).
    held : dict of str to bool array, optional
        ``name -> mask`` over a science parameter's entries held at their
        value in every member (a profile: the members start at different
        values of the held entries, which receive no update).

    Returns
    -------
    dict
        ``"loss"``: (n_iter, K) the training objective; ``"theta"``: name ->
        (n_iter, K, ...); ``"diverged_at"``: (K,) first iteration with a
        non-finite loss, or -1; ``"n_iter"``.  A diverged member's values go
        on as NaN without touching the others.  Training stops early when
        every member has diverged, and, with ``config.tol`` set, once every
        member that has not diverged meets the single fit's stopping rule
        (:class:`~sklearn_hybrid.training.stopping.EarlyStopping` on its own
        loss and theta): a member warm-started from a fit settles long
        before the fit's budget.
    """
    _check_stackable(method)
    K = len(models)
    stacked = _StackedModel(models, inputs)
    theta, phi, perturbed, is_weight, masks = _trained_groups(stacked, method, config, held)
    params = theta + phi

    optimizer, scheduler = make_optimizer(theta, phi, config)
    batches = [MiniBatches(len(y), config.batch_size, g) for g in generators]
    weight = None if sample_weight is None else torch.as_tensor(sample_weight, dtype=y.dtype, device=y.device)
    full = tuple(t.expand(K, *t.shape) for t in inputs), y.expand(K, *y.shape), weight
    watch = _MembersWatch(stacked, config, y, masks, K)

    def next_batch():
        idx = [b.next() for b in batches]
        if idx[0] is None:
            return full
        idx = torch.stack(idx)
        return (tuple(t[idx] for t in inputs), y[idx],
                None if weight is None else torch.gather(weight, 1, idx))

    def loss_and_grads(batch, wrt):
        xb, yb, wb = batch
        loss = _member_loss(stacked.predictions(xb), yb, wb) + method.parameter_penalty(phi, n_batch_dims=1)
        grads = torch.autograd.grad(loss.sum(), wrt, allow_unused=True)
        return loss.detach(), [torch.zeros_like(p) if g is None else g for p, g in zip(wrt, grads)]

    n_iter = run_steps(method, config, optimizer, scheduler, params, perturbed, is_weight, next_batch,
                       loss_and_grads, watch, n_batch_dims=1, desc=f"{K} members",
                       loss_scale=weighted_variance(y, weight))
    watch.judge_end(n_iter)

    with torch.no_grad():  # hand each member its slice
        for k, model in enumerate(models):
            for name, p in model.named_parameters():
                p.copy_(stacked.params[name][k])
    return {"loss": watch.losses[:n_iter], "theta": {n: v[:n_iter] for n, v in watch.thetas.items()},
            "diverged_at": watch.diverged, "n_iter": n_iter}


class _MembersWatch:
    """The stacked members' watcher: records, divergence per member, held entries, early stopping.

    A member diverged (``diverged_at``) when its loss becomes non-finite, or when it ends blown up:
    ``DIVERGED_FACTOR`` times above the larger of its first loss and the variance of ``y``, the single
    fit's test of a training that diverged (:func:`~sklearn_hybrid.training.verdict.judge_training`).  A single fit
    would have rolled back and halved its learning rates at the spike, which the members' shared
    optimiser cannot do for one of them; so the member's result is refused rather than used (a profile
    leaves its value out, a sweep and the bootstrap skip it).  Its values go on without touching the
    others; training ends when every member has diverged, or, with ``config.tol``, once every other
    member meets the fit's stopping rule.
    """

    def __init__(self, stacked, config, y, masks, K):
        self.stacked, self.masks = stacked, masks
        science = stacked.base.science
        self.science = science
        self.losses = np.empty((config.max_iter, K))
        self.thetas = {n: np.empty((config.max_iter, K, *science.shapes[n])) for n in science.names}
        self.diverged = np.full(K, -1)
        self.scale = target_variance(y)
        floor = theta_floor(science)
        self.stoppers = None if config.tol is None else [
            EarlyStopping(config.tol, config.n_iter_no_change, self.scale, theta_floor=floor) for _ in range(K)]
        self.bar = None

    def check(self, it, loss, batch):
        values = loss.cpu().numpy()
        self.diverged[~np.isfinite(values) & (self.diverged < 0)] = it
        if (self.diverged >= 0).all():  # nothing left to train
            self.losses[it:] = np.nan
            for v in self.thetas.values():
                v[it:] = np.nan
            return STOP
        self.values = values
        return STEP

    def judge_end(self, n_iter: int) -> None:
        """Mark the members that ended blown up (see the class) as diverged at their largest loss."""
        losses = self.losses[:n_iter]
        with np.errstate(invalid="ignore"):
            blown = (losses[-1] > DIVERGED_FACTOR * np.maximum(losses[0], self.scale)) & (self.diverged < 0)
        for k in np.flatnonzero(blown):
            self.diverged[k] = int(np.nanargmax(losses[:, k]))

    def masked(self, grads):
        for i, mask in self.masks.items():  # held entries: no gradient, so Adam leaves them exactly
            grads[i] = grads[i] * mask
        return grads

    def stepped(self, it, loss, rate) -> bool:
        self.losses[it] = self.values
        with torch.no_grad():
            for n, value in self.stacked.theta_values().items():
                self.thetas[n][it] = value.cpu().numpy()
        return self.stoppers is not None and _all_settled(self.stoppers, it, self.losses, self.thetas,
                                                           self.diverged)


def _all_settled(stoppers, it, losses, thetas, diverged) -> bool:
    """Every member's stopping rule asked at once (each keeps its own windows); diverged members do not wait."""
    settled = True
    for k, stopper in enumerate(stoppers):
        theta = np.concatenate([v[:it + 1, k].reshape(it + 1, -1)[-1] for v in thetas.values()])
        stops = stopper.should_stop(it, losses[:, k], theta)
        settled &= bool(stops or diverged[k] >= 0)
    return settled


def evaluate_members(models: list, method, inputs: tuple, y: torch.Tensor, config: TrainConfig,
                     sample_weight: torch.Tensor | None = None) -> dict:
    """Each member's data loss and training objective on every sample (full batch).

    The objective is what the method minimises: the data loss plus its
    penalty, or for the SAM family the loss at the perturbed network (one
    ascent step of the method's rule from the full-batch gradient), the
    sharpness-aware loss.

    Returns
    -------
    dict
        ``"loss"`` and ``"objective"``: ndarrays of shape (K,).
    """
    _check_stackable(method)
    K = len(models)
    stacked = _StackedModel(models, inputs)
    theta, phi, perturbed, is_weight, _ = _trained_groups(stacked, method, config, None)
    xb, yb = tuple(t.expand(K, *t.shape) for t in inputs), y.expand(K, *y.shape)
    wb = None if sample_weight is None else torch.as_tensor(sample_weight, dtype=y.dtype, device=y.device)
    data = _member_loss(stacked.predictions(xb), yb, wb)
    objective = data + method.parameter_penalty(phi, n_batch_dims=1)
    if method.perturbs:
        grads = torch.autograd.grad(objective.sum(), perturbed, allow_unused=True)
        scale = weighted_variance(y, wb)  # the gradients the training's rule saw (see engine.run_steps)
        grads = [torch.zeros_like(p) if g is None else g / per_member(scale, g) for p, g in zip(perturbed, grads)]
        at = {}

        def loss_there():  # the loss where the method's step would take its gradients; those are not needed
            with torch.no_grad():
                at["loss"] = _member_loss(stacked.predictions(xb), yb, wb)
            return at["loss"], [torch.zeros_like(p) for p in perturbed]

        method.descent(perturbed, perturbed, grads, is_weight, loss_there, n_batch_dims=1)
        objective = at["loss"]
    return {"loss": data.detach().cpu().numpy().astype(float),
            "objective": objective.detach().cpu().numpy().astype(float)}


def _train_group(models, method, inputs, y, config, seeds, n_threads, sample_weight, held):
    """Train one group of members as one stacked model; returns its history and the models.

    Run in a worker process when there are several groups (processes, not
    threads: the stage loop dispatches thousands of small operations, and
    threads would queue for the interpreter lock between them).
    """
    with torch_threads(n_threads), reusing_buffers():
        history = train_batched(models, method, inputs, y, config,
                                [torch.Generator().manual_seed(s) for s in seeds],
                                sample_weight=sample_weight, held=held)
    return history, models


def _member_slice(value, group):
    """A per-member hyperparameter (array) restricted to a group; a shared one as it is."""
    return value[group] if isinstance(value, np.ndarray) and value.ndim else value


def train_members(models: list, method, inputs: tuple, y: torch.Tensor, config: TrainConfig,
                  seeds: list, *, sample_weight=None, held: dict | None = None, n_jobs: int = 1,
                  n_threads: int | None = 1) -> tuple[dict, list]:
    """Train K members in ``n_jobs`` stacked groups at once, through joblib.

    Each group is one :func:`train_batched` call in its own worker process
    (under ``joblib.parallel_backend("dask")``, on a Dask cluster); the
    members' per-member settings (the method's hyperparameters,
    ``sample_weight`` rows, ``held`` masks of shape ``(K, ...)``) travel
    with their group.

    Returns
    -------
    history : dict
        As :func:`train_batched` returns it, over all K members in order.
    models : list of HybridModule
        The trained members (copies when they come from a worker process).
    """
    groups = [g for g in np.array_split(np.arange(len(models)), max(1, n_jobs)) if len(g)]
    fields = type(method).hyperparameters  # the method's own names, whatever they are

    def part(group):
        member_method = method.for_members(**{f: _member_slice(getattr(method, f), group) for f in fields})
        weight = None if sample_weight is None else sample_weight[group]
        masks = None if held is None else {n: m[group] for n, m in held.items()}
        return ([models[k] for k in group], member_method, inputs, y, config, [seeds[k] for k in group],
                n_threads, weight, masks)

    parts = Parallel(n_jobs=len(groups))(delayed(_train_group)(*part(g)) for g in groups)
    n_iter = max(h["n_iter"] for h, _ in parts)  # groups that settled sooner stopped sooner: their last row held

    def held(a):
        return np.concatenate([a, np.repeat(a[-1:], n_iter - len(a), axis=0)]) if len(a) < n_iter else a

    history = {"loss": np.concatenate([held(h["loss"]) for h, _ in parts], axis=1),
               "theta": {n: np.concatenate([held(h["theta"][n]) for h, _ in parts], axis=1)
                         for n in parts[0][0]["theta"]},
               "diverged_at": np.concatenate([h["diverged_at"] for h, _ in parts]), "n_iter": n_iter}
    return history, [m for _, group_models in parts for m in group_models]


def _train_alone(model, method, inputs, y, config, seed, n_threads):
    """Train one member as a separate fit would; its history in the stacked format (a diverged member:
    NaN, and ``diverged_at`` 0, since a single fit does not report where it diverged)."""
    with torch_threads(n_threads), reusing_buffers():
        try:
            history = train(model, method, inputs, y, config, torch.Generator().manual_seed(seed))
            history["diverged_at"] = -1
        except DivergenceError:
            shapes = model.science.shapes
            history = {"loss": np.full(config.max_iter, np.nan), "diverged_at": 0,
                       "theta": {n: np.full((config.max_iter, *shapes[n]), np.nan) for n in shapes}}
    return history, model


def train_one_by_one(members: list, *, n_jobs: int = 1, n_threads: int | None = 1) -> tuple[dict, list]:
    """Train members that do not stack (a theta encoder's) one by one, as separate fits, through joblib.

    ``members`` are ``(model, method, inputs, y, config, seed)`` tuples.  Returns the history in
    :func:`train_members`' format (``loss`` of shape ``(max_iter, K)``, ``theta``, ``diverged_at``) and the
    trained models (copies when they come from a worker).
    """
    parts = Parallel(n_jobs=min(n_jobs, len(members)))(
        delayed(_train_alone)(*member, n_threads) for member in members)
    histories = [h for h, _ in parts]
    history = {"loss": np.stack([h["loss"] for h in histories], axis=1),
               "theta": {n: np.stack([h["theta"][n] for h in histories], axis=1) for n in histories[0]["theta"]},
               "diverged_at": np.array([h["diverged_at"] for h in histories])}
    return history, [m for _, m in parts]
