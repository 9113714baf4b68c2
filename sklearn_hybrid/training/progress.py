"""A training's progress bar: shown where someone watches it run, after a delay for the default."""

from __future__ import annotations

import sys

__all__ = ["progress_bar", "is_interactive", "AUTO_DELAY"]

#: Seconds a fit with ``verbose="auto"`` (the default) runs before its progress bar appears: a
#: short fit prints nothing, a longer one shows signs of life and its estimated time.
AUTO_DELAY = 5.0


def progress_bar(n_iter: int, verbose, desc: str):
    """The iterations of a training, as a tqdm bar where ``verbose`` asks for one.

    ``verbose=True`` shows it, ``False`` does not, ``"auto"`` shows it once
    the training has run ``AUTO_DELAY`` seconds, and only where it is seen as
    it runs (a terminal or a notebook).  A single fit and stacked members
    (sweeps, profiles, the bootstrap) take it from here alike.
    """
    from tqdm.auto import tqdm

    stream = sys.stderr or sys.stdout  # both are None under pythonw and some services
    auto = verbose == "auto"
    return tqdm(range(n_iter), disable=stream is None or not (is_interactive(stream) if auto else verbose),
                desc=desc, file=stream, delay=AUTO_DELAY if auto else 0.0)


def is_interactive(stream) -> bool:
    """Whether a progress bar on ``stream`` is seen as it runs: a terminal or a notebook, not a log,
    a captured output (pytest, a documentation build) or a missing stream (pythonw)."""
    if stream is None:
        return False
    try:
        return stream.isatty() or "ipykernel" in sys.modules
    except (AttributeError, ValueError):  # a stream without isatty, or a closed one
        return False
