"""Accept a term on evidence: is a held-out error lower by more than the noise explains?

:class:`Evidence` holds the settings of that test for :func:`~sklearn_hybrid.diagnosis.close_the_loop`
(which samples judge, how strong the evidence must be, the second look); :func:`evidence` compares
the per-sample validation errors of two network-free refits
(:class:`~sklearn_hybrid.diagnosis.science_fit.ScienceFit`) of the science model, with and without
a term; :func:`held_out_splits` says which samples fit and which judge, keeping overlapping windows
of one stretch of a record together.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from numbers import Real
from typing import Any

import numpy as np
from scipy.stats import norm
from scipy.stats import t as student_t

from .results import Verdict

__all__ = ["Evidence", "evidence", "critical_value", "holm", "group_means"]


#: ``Evidence(window="auto")``: records longer than ``LONG_RECORD`` steps are judged on windows of
#: ``AUTO_WINDOW`` steps (long enough for a missing effect to build up over a window, short enough that a
#: refit's sequential integration stays short).
LONG_RECORD = 100
AUTO_WINDOW = 25


@dataclass(frozen=True, eq=False)
class Evidence:
    """What a candidate term must show on held-out samples to be added: the closed loop's test.

    Parameters
    ----------
    validation_fraction : float, default=0.25
        The last share of the samples (of the groups, with ``groups``) that validate; the others fit.
    cv : int, optional
        Instead of one split, ``cv`` contiguous blocks of samples: each block is predicted by the
        science model refitted on the others, and every sample judges (slower; for records too short
        to spare a quarter).
    second_look : int or None, default=4
        With one split: a candidate that lowered the validation error by ``min_gain`` with z above 2
        but not past the threshold is judged again by ``second_look`` contiguous folds of the
        *training* samples, each predicted by a refit on the others, with the same test at the same
        threshold; None: no second look.
    groups : array-like of shape (n_samples,), optional
        A label per sample: samples that share one (overlapping windows of one stretch of a record)
        are never split between fitting and validation and count as one value.
    z : float, default=3.0
        The evidence asked for, a quantile of the standard normal (read through Student's t for the
        number of validation samples, :func:`critical_value`), corrected by Holm's rule for the
        number of candidates judged at a step (:func:`holm`).
    min_gain : float, default=0.05
        The least share of the held-out error a term must remove, however sure the test.
    window : int, "auto" or None, default="auto"
        Long records of an unforced, fully observed ODE: the selection fits and judges its
        candidates on non-overlapping windows of this many steps cut from the records, each started
        from the record at its beginning, so that every refit integrates ``window`` steps for all
        windows at once instead of every step of the record in sequence (its cost no longer grows
        with the record's length).  A start is the record smoothed there (a local cubic whose width
        cross-validation chooses; as measured where the record varies too fast for its sampling):
        a measured start carries its noise into every step of its window, and a candidate that
        damps more than the truth would be rewarded for removing it.  The chosen model is refitted on the
        whole records, and its intervals are theirs.  ``"auto"``: windows of 25 steps for records longer than 100
        steps; an integer: windows of that length for records more than twice as long; None: whole
        records always.  ``groups`` then label the records, and each window takes its record's.
    """

    validation_fraction: float = 0.25
    cv: int | None = None
    second_look: int | None = 4
    groups: Any = None
    z: float = 3.0
    min_gain: float = 0.05
    window: int | str | None = "auto"

    def check(self) -> None:
        """Raise ``ValueError`` naming the setting that is out of range."""
        fraction = self.validation_fraction
        if isinstance(fraction, bool) or not isinstance(fraction, Real) or not 0 < fraction < 1:
            raise ValueError(f"validation_fraction must be in (0, 1), got {fraction!r}.")
        z, min_gain, cv, second_look = self.z, self.min_gain, self.cv, self.second_look
        if isinstance(z, bool) or not isinstance(z, Real) or not 0 < z < np.inf:
            raise ValueError(f"z must be a positive number of standard errors, got {z!r}.")
        if isinstance(min_gain, bool) or not isinstance(min_gain, Real) or not 0 <= min_gain < 1:
            raise ValueError(f"min_gain must be in [0, 1) (a share of the held-out error), got {min_gain!r}.")
        if cv is not None and (isinstance(cv, bool) or not isinstance(cv, (int, np.integer)) or cv < 2):
            raise ValueError(f"cv must be None or an integer of at least 2, got {cv!r}.")
        if second_look is not None and (isinstance(second_look, bool) or not isinstance(second_look, (int, np.integer))
                                        or second_look < 2):
            raise ValueError(f"second_look must be None or a number of folds of at least 2, got {second_look!r}.")
        window = self.window
        if not (window is None or (isinstance(window, str) and window == "auto")
                or (isinstance(window, (int, np.integer)) and not isinstance(window, bool) and window >= 2)):
            raise ValueError(f"window must be 'auto', None or a number of steps of at least 2, got {window!r}.")

    def window_for(self, n_steps: int) -> int | None:
        """The window length the selection uses on records of ``n_steps`` steps (None: whole records)."""
        if self.window is None:
            return None
        if isinstance(self.window, str):  # "auto"
            return AUTO_WINDOW if n_steps > LONG_RECORD else None
        return int(self.window) if n_steps > 2 * self.window else None

    def splits(self, n: int) -> tuple[list[tuple[np.ndarray, np.ndarray]], np.ndarray | None]:
        """The (training rows, validation rows) pairs and the group codes (``held_out_splits``)."""
        return held_out_splits(n, self.validation_fraction, self.cv, self.groups)

    def verdict(self, errors_before: np.ndarray, errors_after: np.ndarray) -> Verdict:
        """:func:`evidence` of these held-out errors, asked with this ``z`` and ``min_gain``."""
        return evidence(errors_before, errors_after, z=self.z, min_gain=self.min_gain)


def group_means(errors: np.ndarray, codes: np.ndarray | None) -> np.ndarray:
    """Each group's mean of per-sample errors: a group's samples count as one value in a test.

    Parameters
    ----------
    errors : ndarray of shape (n_samples,)
        One error per sample.
    codes : ndarray of int, shape (n_samples,), or None
        Each sample's group, numbered ``0, 1, ...`` (:func:`group_codes`); None: every sample its own.

    Returns
    -------
    ndarray
        One mean per group, in the codes' order (``errors`` as given where ``codes`` is None).
    """
    if codes is None:
        return errors
    return np.bincount(codes, weights=errors) / np.bincount(codes)


def critical_value(z: float, n: int) -> float:
    """What the mean log-ratio of ``n`` paired samples must exceed, in standard errors, for ``z``.

    ``z`` is read as a normal quantile (3: a false acceptance once in ~740 candidates); since the
    standard error is itself estimated from the ``n`` samples, the threshold is Student's t quantile
    with ``n - 1`` degrees of freedom at the same tail probability (3.85 for 12 samples, 3.03 for
    250). With a dozen validation trajectories the plain ``z`` accepted terms on chance alignments.

    Parameters
    ----------
    z : float
        The evidence asked for, as a quantile of the standard normal distribution.
    n : int
        Number of paired validation samples.

    Returns
    -------
    float
        The threshold in standard errors (infinite for fewer than two samples).
    """
    return float(student_t.ppf(norm.cdf(z), df=n - 1)) if n > 1 else math.inf


def held_out_splits(n: int, validation_fraction: float, cv: int | None = None,
                    groups: Any = None) -> tuple[list[tuple[np.ndarray, np.ndarray]], np.ndarray | None]:
    """The (training rows, validation rows) pairs a selection is judged by.

    Without ``cv``: the last ``validation_fraction`` of the samples validate (2 at least, and 2 left
    to fit; 4 samples at least). With ``cv``: ``cv`` contiguous blocks of 2 samples at least, each
    validated by a fit on the other rows.
    ``groups`` (one label per sample, e.g. the non-overlapping stretch of a record a window starts
    in): samples that share a label are kept on one side of every split, and the selection compares
    their mean error as one value -- overlapping windows of one record are nearly the same numbers,
    and counted one by one they would overstate the evidence.

    Parameters
    ----------
    n : int
        Number of samples.
    validation_fraction : float
        Share of the samples (or groups), the last ones, that validate when ``cv`` is None.
    cv : int, optional
        Number of contiguous blocks, each validated by a fit on the others.
    groups : array-like of shape (n,), optional
        A label per sample (see :func:`group_codes`).

    Returns
    -------
    splits : list of (ndarray, ndarray)
        Training and validation row indices of each split.
    codes : ndarray of shape (n,) or None
        Each sample's group, numbered in order of first appearance (None without ``groups``).
    """
    codes = np.arange(n) if groups is None else group_codes(groups, n)
    m, unit = int(codes.max()) + 1, "samples" if groups is None else "groups"
    if cv is not None and cv > m // 2:
        raise ValueError(f"cv={cv} blocks of {m} {unit}: give at most {m // 2} (two {unit} a block at least).")
    if cv is None and m < 4:
        raise ValueError(f"{m} {unit}: a split needs 4 at least (2 to fit, 2 to judge).")
    if cv is None:
        n_val = int(np.clip(round(validation_fraction * m), 2, m - 2))
        blocks = [np.arange(m - n_val, m)]
    else:
        blocks = np.array_split(np.arange(m), cv)
    splits = [(np.flatnonzero(~np.isin(codes, b)), np.flatnonzero(np.isin(codes, b))) for b in blocks]
    return splits, (None if groups is None else codes)


def group_codes(groups: Any, n: int) -> np.ndarray:
    """Group labels as 0, 1, ... in order of first appearance.

    Parameters
    ----------
    groups : array-like of shape (n,)
        Any hashable labels (numbers or strings); NaN or infinite numbers are refused.
    n : int
        Number of samples the labels must cover.

    Returns
    -------
    ndarray of int, shape (n,)

    Raises
    ------
    ValueError
        For a shape other than ``(n,)`` or non-finite labels.
    """
    labels = np.asarray(groups)
    if labels.shape != (n,):
        raise ValueError(f"groups must hold one label per sample ({n}), got an array of shape {labels.shape}.")
    if labels.dtype.kind in "fc" and not np.all(np.isfinite(labels)):
        raise ValueError("groups contains NaN or infinite labels.")
    _, first, inverse = np.unique(labels, return_index=True, return_inverse=True)
    rank = np.empty(len(first), dtype=int)
    rank[np.argsort(first)] = np.arange(len(first))
    return rank[inverse.ravel()]


def evidence(errors_before: np.ndarray, errors_after: np.ndarray, z: float = 3.0,
             min_gain: float = 0.05) -> Verdict:
    """Does a change lower the held-out error by more than the noise explains?

    Paired comparison of the per-sample validation errors on a log scale (a sample's error ratio
    does not depend on how large its trajectory is): the mean log-ratio must exceed
    :func:`critical_value` ``(z, n)`` standard errors of the mean (``z`` read as a normal
    quantile, the threshold Student's t for ``n`` samples) -- the spread of the ratios across
    samples is what noise alone would produce -- and the mean squared error must drop by at least
    ``min_gain`` (a real but negligible gain is not worth a parameter).

    Returns
    -------
    Verdict
        ``mse_before``, ``mse_after``, ``gain`` (relative drop of the mean squared error), ``z``
        (mean log-ratio in standard errors), ``threshold`` (what ``z`` had to exceed) and
        ``accepted``; it reads as a dict of them too.
    """
    before, after = np.asarray(errors_before, float), np.asarray(errors_after, float)
    threshold = critical_value(z, len(before))
    if not np.all(np.isfinite(after)):
        return Verdict(float(before.mean()), float("inf"), -np.inf, -np.inf, threshold, False)
    if np.any(np.isposinf(before)) and not np.any(np.isnan(before)):
        # the change repairs a sample whose simulation blew up: better however the others scatter (the
        # spread of ratios with an infinite one is NaN, which numpy warns about; said here, not left to it)
        return Verdict(float("inf"), float(after.mean()), 1.0, np.inf, threshold, True)
    tiny = 1e-300
    ratio = np.log(np.maximum(before, tiny)) - np.log(np.maximum(after, tiny))
    se = ratio.std(ddof=1) / math.sqrt(len(ratio)) if len(ratio) > 1 else np.inf
    score = float(ratio.mean() / se) if se > 0 else (np.inf if ratio.mean() > 0 else 0.0)
    gain = float(1.0 - after.mean() / before.mean()) if before.mean() > 0 else 0.0
    return Verdict(float(before.mean()), float(after.mean()), gain, score, threshold,
                   bool(score > threshold and gain >= min_gain))


def holm(verdicts: list[Verdict], n: int, z: float = 3.0, min_gain: float = 0.05,
         m: int | None = None) -> list[Verdict]:
    """The verdicts of a family of candidates judged on the same samples, corrected by Holm's step-down rule.

    Each verdict of :func:`evidence` holds its own test at the tail probability ``alpha`` of the
    normal ``z``. Judging ``m`` candidates each so would accept a useless one up to ``m`` times as
    often; Holm's rule holds the family's false-alarm rate at ``alpha``: the candidate with the
    ``i``-th smallest p-value (``i`` from 0) must have one below ``alpha / (m - i)``, and all those
    with smaller p-values must have passed too. The p-value is Student's t tail of the verdict's
    ``z`` for ``n`` samples, the distribution :func:`critical_value` reads its threshold from.

    Parameters
    ----------
    verdicts : list of Verdict
        Verdicts of :func:`evidence` (``z``, ``gain``), one per candidate.
    n : int
        Number of paired samples each verdict was judged on.
    z, min_gain : float, default=3.0 and 0.05
        The evidence asked of one candidate, as in :func:`evidence`.
    m : int, optional
        Size of the family, when candidates whose refit failed belong to it too; default
        ``len(verdicts)``.

    Returns
    -------
    list of Verdict
        The verdicts in their order, with ``threshold`` (the z each had to exceed, at its rank) and
        ``accepted`` replaced.
    """
    m = len(verdicts) if m is None else max(m, len(verdicts))
    alpha = float(norm.sf(z))
    p = [float(student_t.sf(v.z, df=n - 1)) if n > 1 and np.isfinite(v.z) else
         (0.0 if v.z == np.inf else 1.0) for v in verdicts]
    out = list(verdicts)
    holding = True  # Holm's step-down stops at the first p-value above its level
    for rank, i in enumerate(np.argsort(p, kind="stable")):
        level = alpha / (m - rank)
        holding = holding and p[i] <= level
        out[i] = replace(out[i], threshold=float(student_t.isf(level, df=n - 1)) if n > 1 else math.inf,
                         accepted=bool(holding and out[i].gain >= min_gain))
    return out
