"""Memory of a fit, estimated before training, and allocator failures explained.

Training keeps every intermediate value of the forward pass for the backward
pass, so memory grows as samples x steps x network width; a fit that cannot
fit in memory should say so, and what to change, before it starts.
"""

from __future__ import annotations

from contextlib import contextmanager

import torch

from ..integrate import fast

__all__ = ["fit_memory_bytes", "available_memory_bytes", "check_fit_memory",
           "explained_memory_errors"]

_GB = 1024 ** 3
#: Peak memory of a fit over the bytes autograd saves for its backward pass, measured on the
#: pendulum task (500 and 100 trajectories x 200 steps, fast RK4 path, peak resident memory
#: less the ~0.6 GB of the interpreter and libraries): 2.1 and 2.2.
_PEAK_OVER_SAVED = 2.2
#: Most samples per forward pass without gradients: beyond this a pass of a small model is no
#: faster per sample, and memory grows with it.
PASS_SIZE_MAX = 512


def fit_memory_bytes(model, inputs: tuple[torch.Tensor, ...], n_batch: int) -> int:
    """Estimated peak bytes of training on batches of ``n_batch`` samples.

    Measured, not modelled: one forward pass on two samples through plain
    autograd records the storage of every tensor saved for the backward
    pass, counted once each; the per-sample share is scaled to ``n_batch``
    and by the peak-to-saved ratio measured on the pendulum task (gradients,
    the optimiser and the fast path's own buffers come on top).

    An RK4 ODE is probed over one and two substeps, and the bytes the second
    added are counted once per further substep of the horizon
    (:func:`_rk4_substeps`): every substep saves the same tensors, and a
    plain autograd pass over a long horizon costs a large part of a training
    iteration on the fast path, whatever the batch.
    """
    # copies: a slice shares the storage of every sample's tensor, which would be counted whole
    probe = tuple(t[:2].clone() for t in inputs)
    structure, substeps = model.structure, _rk4_substeps(model.structure)
    if substeps is None:
        saved = _saved_bytes(model, probe)
    else:
        with _horizon(structure, 1, 1):
            one = _saved_bytes(model, probe)
        with _horizon(structure, 1, 2):
            two = _saved_bytes(model, probe)
        saved = one + max(two - one, 0) * (substeps - 1)
    return int(_PEAK_OVER_SAVED * saved / len(probe[0]) * n_batch)


def _saved_bytes(model, probe: tuple[torch.Tensor, ...]) -> int:
    """Bytes of the distinct storages autograd saves in a forward pass on ``probe``."""
    storages = {}

    def pack(t):
        storage = t.untyped_storage()
        storages[storage.data_ptr()] = storage.nbytes()
        return t

    buffers = list(model.buffers())  # batch-norm running statistics: the probe must not move them
    saved = [b.clone() for b in buffers]
    try:
        with torch.autograd.graph.saved_tensors_hooks(pack, lambda t: t), fast.disabled():
            model(*probe)
    finally:
        with torch.no_grad():
            for b, s in zip(buffers, saved):
                b.copy_(s)
    return sum(storages.values())


@contextmanager
def _horizon(structure, n_steps: int, n_substeps: int):
    """The structure integrating ``n_steps`` output steps of ``n_substeps`` for the block."""
    kept = structure.n_steps, structure.n_substeps
    structure.n_steps, structure.n_substeps = n_steps, n_substeps
    try:
        yield
    finally:
        structure.n_steps, structure.n_substeps = kept


def _rk4_substeps(structure) -> int | None:
    """RK4 substeps of an ODE's whole horizon, where it is worth probing a shorter one (more than
    two); None for other structures, other solvers and short horizons.

    Over the short horizons the inputs' grid is read at other times, which changes no tensor's
    size.  An adaptive solver takes as many steps as the dynamics ask, more where they are
    faster, so its first steps do not tell the rest: it is probed over the whole horizon, a
    forward pass on two samples, less than one of its iterations (the same plain autograd,
    forwards and backwards, on a batch).
    """
    if getattr(structure, "solver", None) != "rk4" or not isinstance(getattr(structure, "n_steps", None), int):
        return None
    total = structure.n_steps * structure.n_substeps
    return total if total > 2 else None


def available_memory_bytes(device: torch.device | None = None) -> int | None:
    """Free memory of a GPU, or what the system can give without swapping (Linux
    ``MemAvailable``); None where it cannot be read."""
    if device is not None and device.type == "cuda":
        return torch.cuda.mem_get_info(device)[0]
    try:
        with open("/proc/meminfo") as f:
            for line in f:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except OSError:
        pass
    return None


def _advice(setup, per_sample: float, budget: float) -> str:
    fitting = max(1, int(budget // max(per_sample, 1)))
    batch = 1 << (fitting.bit_length() - 1)  # a power of two below what fits
    return (f"Train on mini-batches with batch_size={batch} (about "
            f"{per_sample * batch / _GB:.2f} GB), or shorten the trajectories, lower n_substeps "
            "or narrow the network.")


def check_fit_memory(setup, n_models: int = 1) -> int:
    """Raise a MemoryError that says what to change if a fit cannot fit in memory.

    Parameters
    ----------
    setup : Bunch
        What ``prepare_fit`` builds (``model``, ``inputs``,
        ``y``, ``config``).
    n_models : int, default=1
        How many such models train at once (the stacked members of a sweep):
        measured once, counted that many times.

    Returns
    -------
    samples_per_pass : int
        Samples per forward pass without gradients after the fit (``predict``
        and the float64 pass of theta's standard errors): as many as half the
        free memory holds at the training bytes per sample in float64, at most
        ``PASS_SIZE_MAX``.  A training pass bounds one without gradients, so
        this never asks for more than training did; decided here, once, from
        the same measurement.
    """
    available = available_memory_bytes(setup.y.device)
    if available is None:
        return PASS_SIZE_MAX
    n = len(setup.y)
    n_batch = min(setup.config.batch_size or n, n)
    per_sample = max(fit_memory_bytes(setup.model, setup.inputs, 1), 1)
    needed = n_models * per_sample * n_batch
    if needed > 0.8 * available:
        models = "" if n_models == 1 else f"{n_models} models trained together, "
        raise MemoryError(
            f"This fit would need about {needed / _GB:.1f} GB "
            f"({models}{n_batch} samples of shape {tuple(setup.y_shape)} per batch), more than "
            f"the {available / _GB:.1f} GB available on {setup.y.device}. "
            + _advice(setup, needed / n_batch, 0.5 * available)
        )
    in_float64 = per_sample * 8 / setup.y.element_size()
    return max(1, min(PASS_SIZE_MAX, int(0.5 * available / in_float64)))


@contextmanager
def explained_memory_errors(setup):
    """Turn the allocator's failure inside the block into a MemoryError with advice."""
    try:
        yield
    except RuntimeError as exc:
        text = str(exc)
        if "allocate" not in text and "out of memory" not in text:
            raise
        n = len(setup.y)
        raise MemoryError(
            f"The fit ran out of memory ({text.splitlines()[0]}). "
            + _advice(setup, fit_memory_bytes(setup.model, setup.inputs, 1),
                      0.5 * (available_memory_bytes(setup.y.device) or 0) or 2 * _GB)
            + f" (now {min(setup.config.batch_size or n, n)} samples per batch)"
        ) from exc
