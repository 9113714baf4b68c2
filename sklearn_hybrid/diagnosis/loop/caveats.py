"""What the closed loop's intervals are conditional on: a model that may be incomplete, and a term's form.

The network-free model's intervals (:func:`~sklearn_hybrid.identifiability.science_intervals`) hold
the truth only if that model is the truth. Three things the selection itself knows can break that,
and each is said in the result instead of an interval that would read as certain:

- :func:`open_question`: the last step ended with a candidate that lowered the held-out error by
  ``min_gain``, short of the evidence;
- :func:`left_unexplained`: the final model leaves a clear share of what the hybrid learned on an
  equation (and the remainder varies with a variable the report names);
- :func:`worse_than_hybrid`: the hybrid fits the data far better than the final model (a share of the
  right-hand side too small to see there can add up along a trajectory, and no candidate may have
  captured it);
- :func:`weigh_rivals`: a term the held-out data could not tell from the chosen one (another form
  instead of it, or one more term) moves a science parameter outside its interval; the parameter
  is identified only given the chosen form, and its interval is widened to the rival values;
- :func:`mirror_trades`: a chosen term's form, placed on another uncertain equation (its mirror),
  would trade with a science parameter there: a flow between two states, or a force between two
  bodies, acts on both equations, and the part on the parameter's equation is absorbed by the
  parameter without a trace in the data.

A science parameter that trades with part of an added term in its own direction is found by
``science_intervals`` itself (its ``terms`` argument), from the sensitivities.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from typing import Any

import numpy as np
import torch

from ...identifiability.science_only import CONFOUNDED_R2
from ...science import read_signature
from ..evidence import Evidence, evidence, group_means
from ..families.inhibited import part_reader
from ..judge import FIT_FAILURES
from ..science_fit import ScienceFit
from ..sensitivity import parameter_jacobian, root_mean_square
from ..terms import TermVariables
from .candidates import augment_with, shape_bounds
from .placed import PlacedTerm

__all__ = ["open_question", "left_unexplained", "worse_than_hybrid", "weigh_rivals", "mirror_trades", "OPEN_Z",
           "UNEXPLAINED_SHARE", "HYBRID_GAIN", "MAX_RIVALS"]

#: A candidate left at the last step that lowered the held-out error by ``min_gain`` at this z (one
#: standard error) is evidence, short of the threshold, that the final model misses something.
OPEN_Z = 1.0
#: What the final model leaves of what the hybrid learned on an equation, to call it incomplete: this
#: share of the learned right-hand side, and this share of what the network carried there.
UNEXPLAINED_SHARE = (0.1, 0.3)
#: The share of the final model's error on the data the hybrid must remove (by more than the noise explains,
#: the selection's test on every sample) to call the final model incomplete. The hybrid is judged on the
#: samples it was trained on, so the share asked is large: a network does not halve the error of a complete
#: model on trajectories by fitting their noise.
HYBRID_GAIN = 0.5
#: Rivals refitted on every sample (the most competitive first) to see how far they move theta: this many
#: of each kind, forms in place of a chosen term and terms added to the final model.
MAX_RIVALS = 3


def open_question(steps: list[dict], min_gain: float) -> str | None:
    """Why the final science model may be incomplete (a candidate of the last step, or of its second
    look, that gained ``min_gain`` at z >= ``OPEN_Z`` without passing), or None."""
    numbered = [s["step"] for s in steps if isinstance(s["step"], int)]
    if not numbered:
        return None
    last = max(numbered)
    open_ = [s for s in steps if s["step"] in (last, f"{last}, second look") and not s["accepted"]
             and s.get("gain", -np.inf) >= min_gain and s.get("z", -np.inf) >= OPEN_Z]
    if not open_:
        return None
    best = max(open_, key=lambda s: s["gain"])
    return (f"the selection ended with a candidate, {best['term']}, that lowered the held-out error by "
            f"{best['gain']:.0%} at z {best['z']:.1f}, short of the evidence")


def left_unexplained(unexplained: Mapping[str, Any], network: np.ndarray, learned: np.ndarray,
                     outputs: Sequence[str]) -> str | None:
    """Why the final model is incomplete, if it leaves a clear share of what the hybrid learned.

    Parameters
    ----------
    unexplained : dict
        :func:`~sklearn_hybrid.diagnosis.loop.report.residual_profile` of the final model: ``share``
        per output (RMS of the remainder over RMS of the learned right-hand side) and ``profiles``
        (the remainder's bin means against each variable).
    network, learned : ndarray of shape (n_points, n_outputs)
        The network's part of the hybrid at the visited states, and science plus network there.
    outputs : list of str
        The outputs' names, in the columns' order.

    Returns
    -------
    str or None
        The equation, its shares, and the variable the remainder varies most with; None where every
        explained equation is left with less than ``UNEXPLAINED_SHARE``.
    """
    total = root_mean_square(learned)  # the scale residual_profile's shares are taken against
    carried = root_mean_square(network) / np.where(total > 0, total, np.nan)
    worst = None
    for j, name in enumerate(outputs):
        share = unexplained["share"].get(name)
        if name not in unexplained["components"] or share is None or not np.isfinite(share):
            continue
        if share >= UNEXPLAINED_SHARE[0] and share >= UNEXPLAINED_SHARE[1] * carried[j]:
            if worst is None or share > worst[1]:
                worst = (name, share, carried[j])
    if worst is None:
        return None
    name, share, carried_j = worst
    spread = {var: float(np.ptp(mean)) for (out, var), (_, mean) in unexplained["profiles"].items()
              if out == name and len(mean)}
    along = f", varying most with {max(spread, key=spread.get)}" if spread else ""
    return (f"the final model leaves {share:.0%} of what the hybrid learned on {name} unexplained ({share / carried_j:.0%} "
            f"of what its network carried){along}: an effect no added term captures (result.plot() shows the "
            "remainder against every variable)")


def worse_than_hybrid(errors_final: np.ndarray, errors_hybrid: np.ndarray, evidence_: Evidence,
                      codes: np.ndarray | None = None) -> str | None:
    """Why the final model is incomplete, if the hybrid fits the data far better than it does.

    Parameters
    ----------
    errors_final, errors_hybrid : ndarray of shape (n_samples,)
        Each sample's mean squared error of the final network-free model and of the hybrid.
    evidence_ : Evidence
        The selection's test (its ``z``); the gain asked is ``HYBRID_GAIN``.
    codes : ndarray of shape (n_samples,), optional
        Each sample's group (numbered ``0, 1, ...``): a group's mean error counts as one value.

    Returns
    -------
    str or None
        The two errors and the test, where the hybrid removes at least ``HYBRID_GAIN`` of the final
        model's error by more than the noise explains; None otherwise.
    """
    final, hybrid = (group_means(np.asarray(e, float), codes) for e in (errors_final, errors_hybrid))
    if len(final) < 2 or not np.all(np.isfinite(hybrid)):
        return None
    test = evidence(final, hybrid, z=evidence_.z, min_gain=HYBRID_GAIN)
    if not test["accepted"]:
        return None
    return (f"the hybrid fits the data with {1 - test['gain']:.0%} of the final model's error ({test['mse_after']:.4g} "
            f"against {test['mse_before']:.4g} over {len(final)} samples, z {test['z']:.1f}): it explains something "
            "the final model misses, which no added term captured")


def weigh_rivals(intervals: Any, rivals: Sequence[dict], science: Callable, added: list[PlacedTerm],
                 theta: Mapping[str, Any], fit: ScienceFit, variables: Sequence[str], n_states: int,
                 param_names: Mapping[str, str] | None, log: Callable[[str], None] = lambda s: None) -> list[dict]:
    """Refit the rival forms that move a science parameter, and call it conditional on the chosen form.

    A rival (see :func:`~sklearn_hybrid.diagnosis.loop.stepwise.forward_selection`) whose screening
    fit puts one of the original science parameters outside its interval is refitted on every sample
    (at most ``MAX_RIVALS`` of each role, the lowest held-out error first: another form in place of a
    chosen term, and a term added to the final model, answer two questions, and the second kind, judged
    against a model with more terms, would otherwise crowd out the first). Where the refit confirms it, the
    interval (in ``intervals``, changed in place) is widened to hold the rival's value, and where the
    rival moves it by more than the interval's width, the parameter becomes ``"conditional"``: the
    data leave it to the term's form. ``added`` are the final model's terms at their values in ``theta``.

    Returns
    -------
    list of dict
        Per rival refitted: ``model`` (its terms in words), ``theta`` (the science parameters'
        values) and ``moved`` (the labels it moved outside their intervals).
    """
    names = [k for k in read_signature(science)[1] if np.ndim(theta.get(k, 0.0)) == 0]
    labels = [k for k in names if intervals.verdicts.get(k) in ("identified", "conditional")]
    if not labels:
        return []
    final = {t.key for t in added}
    width = {k: intervals.intervals[k][1] - intervals.intervals[k][0] for k in labels}

    def outside(values):
        return [k for k in labels if k in values and np.isfinite(values[k])
                and not intervals.intervals[k][0] <= float(values[k]) <= intervals.intervals[k][1]]

    out, weighed = [], {"add": 0, "instead": 0}
    for rival in sorted(rivals, key=lambda r: r["mse"]):
        if weighed[rival["role"]] == MAX_RIVALS:
            continue
        entries = rival["cand"].entries()
        replaced = set(rival.get("of", ()))
        if not replaced <= final or any(e.key in final - replaced for e in entries):
            continue  # the final model no longer holds what it replaced, or holds it already
        if not outside(rival["theta"]):
            continue
        placed = [t for t in added if t.key not in replaced] + entries
        model = augment_with(science, placed, variables, n_states, param_names)
        start = dict(read_signature(model)[1])
        start.update({k: v for k, v in theta.items() if k in start})
        start.update({k: v for k, v in rival["theta"].items() if k in start and k not in theta})
        try:
            fitted = fit.fit(model, start, shape_bounds(model, placed))
        except FIT_FAILURES:
            continue
        what = " + ".join(e.name for e in entries)
        words = (f"with {what} instead of {' + '.join(term for _, term in sorted(replaced))}" if replaced
                 else f"with {what} added")
        moved = outside(fitted)
        for k in moved:
            value = float(fitted[k])
            # a rival that moves it by more than the interval's width decides it; a smaller move widens it
            if abs(value - intervals.estimate[k]) > width[k]:
                intervals.make_conditional(k, f"{words}: {value:.4g}", [value])
            else:
                intervals.widen(k, [value])
        log(f"  rival {words}: " + ", ".join(f"{k} = {float(fitted[k]):.4g}" for k in names if k in fitted))
        weighed[rival["role"]] += 1
        out.append({"model": words, "theta": {k: float(fitted[k]) for k in names if k in fitted}, "moved": moved})
    return out


def mirror_trades(intervals: Any, science: Callable, theta: Mapping[str, Any], added: list[PlacedTerm],
                  args: Sequence[np.ndarray], variables: Sequence[str], components: Sequence[int],
                  outputs: Sequence[str]) -> dict[str, str]:
    """Call conditional a science parameter that a chosen term's form would trade with on another equation.

    A term the loop added on one equation may also act, unseen, on another: a reaction that moves
    matter from B to A takes it from B, a spring between two pendula pulls on both. Its part on
    another equation is invisible to the data when a science parameter of that equation can absorb
    it: the parameter then holds its own value plus that part, with a narrow interval. So each
    chosen term's form (but a vector field's component) is placed on every other uncertain equation
    (``components``) where the model does not hold it already (its mirrors), and a science
    parameter whose sensitivity the mirrors
    explain to ``CONFOUNDED_R2`` or more (uncentred R^2, jointly, on the visited states ``args``) is
    made ``"conditional"`` in ``intervals`` (changed in place). Its interval is not widened: the data
    cannot say how much of the term acts there.

    Returns
    -------
    dict of str to str
        Per parameter made conditional, the reason in words.
    """
    names = [k for k in read_signature(science)[1] if np.ndim(theta.get(k, 0.0)) == 0]
    labels = [k for k in names if intervals.verdicts.get(k) in ("identified", "conditional")]
    placed = {t.key for t in added}
    own = {k: theta[k] for k in read_signature(science)[1]}
    values = TermVariables({name: torch.as_tensor(np.asarray(a, dtype=float))
                            for name, a in zip(variables, np.hstack([a.reshape(len(a), -1) for a in args]).T)},
                           part_reader(science, own, args))
    n = len(args[0])
    mirrors, where = [], []
    for t in added:
        # an offset has no form; a term made for its own equation (a scaled one, a discovered one reading f) stays; a
        # vector field's component has its partners on the other equations (the field's other components)
        if t.kind == "offset" or t.term.component is not None or t.term.field is not None:
            continue
        with torch.no_grad():
            col = np.broadcast_to(t.term(values, **{k: torch.tensor(v, dtype=torch.float64)
                                                     for k, v in t.shape.items()}).numpy(), (n,))
        for j in components:
            if (j, t.name) not in placed and j != t.component:
                mirror = np.zeros((n, len(outputs)))
                mirror[:, j] = col
                mirrors.append(mirror.ravel())
                where.append(f"{t.name} on {outputs[j]} (added on {outputs[t.component]})")
    if not labels or not mirrors:
        return {}
    jac, jac_names = parameter_jacobian(science, own, args)
    M = np.stack(mirrors, axis=1)
    out = {}
    for label in labels:
        column = jac[..., jac_names.index(label)].ravel()
        if not np.all(np.isfinite(column)) or column @ column <= 0:
            continue
        coef = np.linalg.lstsq(M, column, rcond=None)[0]
        r2 = 1.0 - float(np.sum((column - M @ coef) ** 2) / (column @ column))
        if r2 >= CONFOUNDED_R2:
            share = np.abs(coef) * np.linalg.norm(M, axis=0)  # each mirror's part in the fit: name those that count
            used = [w for w, s in zip(where, share) if s >= 0.1 * share.max()]
            out[label] = (f"trades with {' and '.join(used)}: a flow or a force between two states acts on both "
                          f"equations, R^2 {r2:.2f}")
            intervals.make_conditional(label, out[label])
    return out
