"""The candidates one step judged, the simplest of the best among them, and a second look at the promising.

A step of :func:`~sklearn_hybrid.diagnosis.loop.stepwise.forward_selection` records each candidate it
judged as a :class:`Screened`; :func:`simplest_of_the_best` picks among those that passed, and
:func:`look_again` judges once more, on folds of the training samples, those that one validation split
found promising but could not prove (:func:`worth_a_second_look`). Joint candidates are judged as one
family per step (:func:`correct_joint`).
"""

from __future__ import annotations

from dataclasses import replace
from typing import Any, NamedTuple

import numpy as np

from ..evidence import Evidence, holm
from ..judge import FIT_FAILURES, Judge
from ..results import Verdict
from .candidates import shape_bounds
from .placed import Candidate, PlacedTerm
from .report import format_gain
from .watch import current_watch

# worth_a_second_look and SECOND_LOOK_Z are public: the identification benchmark finds with them, in its
# stored records, the candidates a second look would see (--inconclusive)
__all__ = ["Screened", "SECOND_LOOK_Z", "worth_a_second_look", "look_again", "correct_joint",
           "simplest_of_the_best"]


class Screened(NamedTuple):
    """A candidate judged at a step: its screening fit, verdict and held-out errors.

    A tuple, so that code that watches the selection (the identification benchmark's
    ``--second-look-null``) can read ``index`` as its sixth item.
    """

    cand: Candidate
    theta: dict  # the screening fit of the model with the candidate
    verdict: Verdict  # evidence's verdict on its held-out errors
    errors: np.ndarray  # its held-out errors, one per judged sample (or group)
    science: Any  # the augmented science function with the candidate
    index: int  # its row in the selection's steps
    second_look: bool = False  # judged again by folds of the training samples


# A candidate gets a second look when the first split's z is above this (and its gain is enough).
SECOND_LOOK_Z = 2.0


def worth_a_second_look(verdict: dict, min_gain: float) -> bool:
    """Worth a second look: the gain is enough and z above 2. With 12 validation samples a useless
    term gets there about once in 28 candidates (Student's t, 11 degrees of freedom): often enough to
    be worth the folds' refits, far too often to be a term."""
    return verdict["gain"] >= min_gain and verdict["z"] > SECOND_LOOK_Z


def look_again(recheck: Judge, tried: list[Screened], current, theta: dict, added: list[PlacedTerm], steps: list,
               evidence: Evidence, log, n_joint: int = 0) -> Screened | None:
    """Judge again, on the training samples, the candidates one split found promising but not proven.

    Twelve validation trajectories tell a real term from chance only when its gain is large next to
    their spread (the t threshold for 12 samples is 3.85): in the identification benchmark, 31 of
    196 selections ended on a candidate with a gain of 5 % or more at z between 2 and the threshold,
    8 of them failures of the benchmark (28 of the 31 effects within 10 % with the second look, 23
    without). Those candidates are refitted on all but one fold of the
    training samples and judged on that fold, fold by fold, by the same test at the threshold for
    the number of training samples. The validation samples take no part, so this second test is
    not the first one repeated, and a candidate must have passed z > 2 on them to be looked at.
    Joint candidates are judged with the threshold corrected for the ``n_joint`` sets the step
    judged (:func:`correct_joint`). Returns the simplest of the best that pass (as
    :func:`simplest_of_the_best`), marked ``second_look``, or None.
    """
    promising = [t for t in tried if worth_a_second_look(t.verdict, evidence.min_gain)
                 or not current_watch().second_look_gate]  # a study may look at all again (watch.py)
    if not promising:
        return None
    recheck.settle(current, theta)
    base = recheck.errors(current, theta, shape_bounds(current, added) if added else None)
    looked = []
    for cand, fitted, _, _, candidate_science, index, _ in promising:
        try:
            bounds = shape_bounds(candidate_science, [*added, *cand.entries()])
            errors = recheck.errors(candidate_science, fitted, bounds, screening=True)
        except FIT_FAILURES:
            continue
        verdict = evidence.verdict(base, errors)
        steps.append(replace(steps[index], step=f"{steps[index].step}, second look", verdict=verdict, accepted=False))
        log(f"  second look at {cand.name} on {cand.where()}: training-fold MSE {verdict['mse_after']:.4g} "
            f"(gain {format_gain(verdict['gain'])}, z {verdict['z']:.1f})")
        looked.append(Screened(cand, fitted, verdict, errors, candidate_science, len(steps) - 1, second_look=True))
    correct_joint(looked, steps, n_joint, evidence, log)
    return simplest_of_the_best(looked, evidence.min_gain)


def correct_joint(tried: list[Screened], steps: list, m: int, evidence: Evidence, log) -> None:
    """Judge the joint candidates among ``tried`` as one family of ``m`` (Holm's rule, in place).

    Each single term keeps its own test, as before joint candidates existed; the sets a step adds
    are one family whose false-alarm rate Holm's rule holds at that of one single term
    (:func:`~sklearn_hybrid.diagnosis.evidence.holm`). A step then accepts a useless term at most
    about as often as with one more single candidate, however many sets it judges.
    """
    at = [i for i, t in enumerate(tried) if t.cand.kind == "joint"]
    if not at:
        return
    verdicts = holm([tried[i].verdict for i in at], len(tried[at[0]].errors), evidence.z, evidence.min_gain, m)
    for i, verdict in zip(at, verdicts):
        tried[i] = tried[i]._replace(verdict=verdict)
        steps[tried[i].index] = replace(steps[tried[i].index], verdict=verdict)  # a row says yes when chosen
        log(f"  {tried[i].cand.name} judged as one of {max(m, len(at))} sets: threshold {verdict['threshold']:.2f}, "
            f"{'passed' if verdict['accepted'] else 'not passed'}")


def simplest_of_the_best(tried: list[Screened], min_gain: float) -> Screened | None:
    """The simplest candidate among those the data cannot tell from the best.

    ``c tanh(v/w)`` with a large ``w`` mimics ``v^3`` once the linear part is absorbed, and over a
    small range ``v|v|`` and ``v^3`` fit alike; when the held-out error of one is within
    ``min_gain`` of the best (the margin below which a term is not worth a parameter either), the
    reading a physicist would keep is the one with fewer parameters, and among those a polynomial
    (a Taylor term). A paired test is no judge here: the samples' noise is shared by both models,
    so a 3 % difference from noise in the fitted parameters looks "significant".
    """
    passed = [t for t in tried if t.verdict["accepted"]]  # each candidate is judged on its own evidence
    if not passed:
        return None
    best = min(passed, key=lambda t: t.verdict["mse_after"])
    alike = [t for t in passed if t.verdict["mse_after"] <= (1 + min_gain) * best.verdict["mse_after"]]
    def taylor(t):  # a set of monomials is a polynomial too
        return all(e.kind == "polynomial" for e in t.cand.entries())
    return min(alike, key=lambda t: (t.cand.n_parameters(), not taylor(t), t.verdict["mse_after"]))
