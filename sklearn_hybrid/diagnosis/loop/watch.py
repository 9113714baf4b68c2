"""A seam for studies of the closed loop itself: see the model it selects, stop it there, stress its second look.

A user never needs this module. The identification benchmark does (``benchmarks/identification/checks.py``):
to check that a change of the package leaves its records' selections alone, it closes the loop again from a
stored first fit and stops once the selection is made (the intervals and the hybrid refit after it are what
the records already hold); to measure how often the second look accepts a useless term, it looks at every
candidate again. Inside ``with watching(LoopWatch(...)):`` :func:`~sklearn_hybrid.diagnosis.close_the_loop`
does both on request, so that no study has to replace the loop's functions. Outside such a block the loop
runs exactly as it does without this module.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from contextlib import contextmanager
from contextvars import ContextVar
from dataclasses import dataclass

__all__ = ["LoopWatch", "watching", "current_watch"]


@dataclass(frozen=True)
class LoopWatch:
    """What a study asks of ``close_the_loop`` while it watches (see :func:`watching`).

    Parameters
    ----------
    on_selection : callable, optional
        Called as ``on_selection(science, theta, steps)`` once the selection has chosen its model and
        refitted it on every sample, before the network-free estimator, its intervals, the scoring and
        any hybrid refit: ``science`` is the chosen science function (with ``.terms`` when terms were
        added), ``theta`` its fitted parameter values and ``steps`` every candidate judged, second looks
        included (rows whose ``step`` reads ``"<n>, second look"``). It may raise to stop the loop there.
    second_look_gate : bool, default=True
        False: at a step where no candidate passes, every candidate gets the second look, whatever its
        gain and z on the validation samples, so that the second look is the only judge (a stress test;
        see :func:`~sklearn_hybrid.diagnosis.loop.second_look.worth_a_second_look` for the gate).
    """

    on_selection: Callable | None = None
    second_look_gate: bool = True

    def __post_init__(self) -> None:
        # checked here, not when the loop calls it: a wrong callback would otherwise fail only after the
        # whole selection has run, as "'int' object is not callable"
        if self.on_selection is not None and not callable(self.on_selection):
            raise TypeError(f"LoopWatch: on_selection must be a callable or None, got "
                            f"{type(self.on_selection).__name__} {self.on_selection!r}; it is called as "
                            "on_selection(science, theta, steps)")
        # a string such as "no" would read as True and leave the gate on without a word
        if not isinstance(self.second_look_gate, bool):
            raise TypeError(f"LoopWatch: second_look_gate must be True or False, got "
                            f"{type(self.second_look_gate).__name__} {self.second_look_gate!r}")

    def selected(self, science: Callable, theta: dict, steps: list) -> None:
        """Hand the selected model to ``on_selection``, if any (called by ``close_the_loop``)."""
        if self.on_selection is not None:
            self.on_selection(science, theta, steps)


# A context variable, not a module attribute: a watch holds only inside its own ``with`` block (and thread).
_WATCH: ContextVar[LoopWatch] = ContextVar("loop_watch", default=LoopWatch())


@contextmanager
def watching(watch: LoopWatch) -> Iterator[LoopWatch]:
    """Let ``close_the_loop`` calls inside the block follow ``watch``; the previous watch holds again after.

    Parameters
    ----------
    watch : LoopWatch
        What the loop reports and how it judges while the block runs. ``LoopWatch()`` watches nothing: the
        loop runs inside the block as it does without this module, even within another ``watching`` block.

    Yields
    ------
    LoopWatch
        ``watch`` itself.

    Raises
    ------
    TypeError
        If ``watch`` is not a :class:`LoopWatch`. None is refused rather than read as "no watch": it could
        as well mean "keep the outer block's watch", and ``LoopWatch()`` says which without doubt.
    """
    # refused here: the loop would otherwise fail far from this line, on an attribute None lacks
    if not isinstance(watch, LoopWatch):
        raise TypeError(f"watching() needs a LoopWatch, got {type(watch).__name__} {watch!r}; pass "
                        "LoopWatch(on_selection=..., second_look_gate=...), or LoopWatch() to run the loop "
                        "unwatched inside the block")
    token = _WATCH.set(watch)
    try:
        yield watch
    finally:
        _WATCH.reset(token)


def current_watch() -> LoopWatch:
    """The watch in force: the innermost :func:`watching` block's, else one that changes nothing."""
    return _WATCH.get()
