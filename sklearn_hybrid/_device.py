"""Where a fit runs: ``device="cpu" | "cuda" | "cuda:N" | "auto"`` resolved once, at fit."""

from __future__ import annotations

import torch

__all__ = ["resolve_device"]


def resolve_device(spec) -> torch.device:
    """Turn the estimator's ``device`` parameter into a :class:`torch.device`.

    Parameters
    ----------
    spec : str or torch.device
        ``"cpu"``; ``"cuda"`` or ``"cuda:N"`` (an NVIDIA GPU, which must be
        present); ``"auto"`` (the first GPU if torch finds one, else the CPU).

    Returns
    -------
    torch.device

    Raises
    ------
    ValueError
        For an unknown name, or a CUDA device torch cannot see.
    """
    if spec == "auto":
        return torch.device("cuda" if torch.cuda.is_available() else "cpu")
    try:
        device = torch.device(spec)
    except (RuntimeError, TypeError):
        raise ValueError(
            f"device must be 'cpu', 'cuda', 'cuda:N' or 'auto', got {spec!r}."
        ) from None
    if device.type not in ("cpu", "cuda"):
        raise ValueError(f"device must be 'cpu', 'cuda', 'cuda:N' or 'auto', got {spec!r}.")
    if device.type == "cuda":
        if not torch.cuda.is_available():
            raise ValueError(
                f"device={spec!r} asks for a CUDA GPU, but torch finds none (torch "
                f"{torch.__version__}, torch.cuda.is_available() is False: no GPU, no driver, "
                "or a CPU-only build). Use device='cpu', or 'auto' to take a GPU when present."
            )
        if device.index is not None and device.index >= torch.cuda.device_count():
            raise ValueError(
                f"device={spec!r}: torch sees {torch.cuda.device_count()} CUDA device(s).")
    return device
