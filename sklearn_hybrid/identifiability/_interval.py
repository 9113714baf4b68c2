"""The interval reader of profiles: where a profile crosses its threshold, and what that backs.

Every profile's interval and verdict is read here (and nowhere else), so that the rules that keep an
interval honest hold for all of them: an interval is never reversed, and a crossing of the threshold
counts only where the member that crossed had settled.
"""

from __future__ import annotations

import numpy as np

__all__ = ["IDENTIFIED", "PRACTICAL", "STRUCTURAL", "UNSETTLED", "read_interval", "refinement"]

IDENTIFIED = "identified"
PRACTICAL = "practically non-identifiable"
STRUCTURAL = "structurally non-identifiable"
#: An interval no converged profile backs: it leaves out the fit's own estimate (the members, trained from the fit
#: with its budget, moved theta on, so the fit had not converged), or a crossing of the threshold was made by a
#: member still moving when its training ended (its loss an upper bound of the profile there, not the profile).
UNSETTLED = "not settled"


def read_interval(values, loss, threshold, fall=None, carried=None):
    """The interval spanning every value of sorted ``values`` whose profile ``loss`` is under ``threshold``
    (linear interpolation at the outermost crossings), the verdict, and the crossings not backed.

    The confidence set is every value the data allow, not only those next to the minimum: a profile that
    rises over the threshold and falls back under it further out (members that settled unevenly, or a
    second region that fits as well) is not cut at its first crossing, and where it is back under the
    threshold at the end of the profiled range that side is open.

    A member's loss is the profile's value only where its training settled; one still falling when it
    ended (another parameter compensating the held one a long way off, within the fit's budget) gives an
    upper bound of the profile, whose true value may lie under the threshold.  A crossing is backed only
    by a member whose loss fell over its last window by at most the resolution the verdict is read at (a
    tenth of the threshold's margin over the minimum), or whose fall, carried on as long again as it was
    trained, would still leave it over the threshold; any other crossing backs no bound, and the verdict
    is :data:`UNSETTLED` (parameters that enter only as a product read as both identified otherwise).

    Parameters
    ----------
    values, loss : ndarray of shape (n,)
        The profile, ``values`` sorted.
    threshold : float
    fall, carried : ndarray of shape (n,), optional
        Each value's member's fall of loss over its last window, and that fall carried on
        (:func:`~sklearn_hybrid.training.stopping.loss_trend`); default: 0 (every member settled).

    Returns
    -------
    interval : tuple of float
        ``(low, high)``, ``low <= high`` always; ``-inf`` / ``inf`` for an open side.
    verdict : str
    unsettled : list of float
        The values beyond the interval whose members crossed the threshold without having settled.
    """
    values, loss = np.asarray(values, dtype=float), np.asarray(loss, dtype=float)
    fall = np.zeros_like(loss) if fall is None else np.asarray(fall, dtype=float)
    carried = fall if carried is None else np.asarray(carried, dtype=float)
    under = np.flatnonzero(loss <= threshold)
    if not under.size:
        # the threshold comes from the best member of any profile: none of this one's own reached it, so its
        # members had not found the profile's minimum, and interpolating towards a threshold every point lies
        # over would run backwards (low > high). The bracket of the least bad value is all there is.
        m = int(np.argmin(loss))
        return ((float(values[max(m - 1, 0)]), float(values[min(m + 1, len(values) - 1)])), UNSETTLED,
                [float(values[m])])
    # a fall to come under a tenth of the threshold's margin over the minimum is settled at the resolution the
    # verdict is read at: refinement puts members right at a crossing, where any fall at all would reach it
    resolution = 0.1 * (threshold - float(np.min(loss)))
    sides, unsettled = [], []
    for i, step, end in ((under[0], -1, -1), (under[-1], 1, len(values))):
        if i + step == end:
            sides.append(None)  # under the threshold at the end of the range
            continue
        a, b = loss[i], loss[i + step]
        t = 1.0 if not np.isfinite(b) else (threshold - a) / (b - a)
        sides.append(values[i] + t * (values[i + step] - values[i]))
        j = i + step
        if np.isfinite(b) and fall[j] > resolution and b - carried[j] <= threshold:
            unsettled.append(float(values[i + step]))
    low = -np.inf if sides[0] is None else float(sides[0])
    high = np.inf if sides[1] is None else float(sides[1])
    open_sides = (sides[0] is None) + (sides[1] is None)
    verdict = IDENTIFIED if open_sides == 0 else STRUCTURAL if open_sides == 2 else PRACTICAL
    if unsettled:
        verdict = UNSETTLED
    return (low, high), verdict, unsettled


def refinement(rows, threshold):
    """Values that pin the profile's crossings of ``threshold`` between two coarse points.

    Near its minimum a profile is a parabola; through the minimum and the first
    point beyond the threshold on a side it puts the crossing at ``c``; the
    points ``c`` and ``c +/- 10 %`` of its distance from the minimum (inside
    the bracket) are trained next, so that the crossing is interpolated
    between near points rather than across a coarse grid step.

    ``rows`` are ``(value, loss, ...)`` tuples of one profile.
    """
    values, loss = (np.array(c) for c in list(zip(*sorted(rows)))[:2])
    m = int(np.argmin(loss))
    out = []
    for step in (-1, 1):
        i = m
        while 0 <= i + step < len(values) and loss[i + step] <= threshold:
            i += step
        if not 0 <= i + step < len(values) or not np.isfinite(loss[i + step]):
            continue  # open on this side, or a diverged member beyond: nothing to pin
        inside, outside = values[i], values[i + step]
        curvature = (loss[i + step] - loss[m]) / (outside - values[m]) ** 2
        if curvature <= 0:
            continue
        c = values[m] + step * np.sqrt(max(threshold - loss[m], 0.0) / curvature)
        lo, hi = sorted((inside, outside))
        delta = 0.1 * abs(c - values[m])
        out += [v for v in (c - delta, c, c + delta) if lo < v < hi]
    return out
