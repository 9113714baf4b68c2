"""Joint candidates: small sets of terms that explain an effect only together.

A limit cycle ``mu (1 - x^2) x'`` is two terms, ``x'`` and ``x^2 x'``; on the cycle the first alone
explains nothing (the energy it feeds in over a period is what the second takes out) and the
second alone little, so a selection that adds one term at a time never starts. The same holds for a
polynomial with a linear and a cubic part that nearly cancel over the visited states, or a rational
law expanded into a few monomials. :func:`joint_candidates` proposes, per uncertain equation, the
sets a least-squares fit of the network's residual favours: the best-ranked terms in pairs, each of
them with the partners that explain most of what it leaves, and the support a sparse fit of the residual chooses
(:func:`~sklearn_hybrid.diagnosis.supports.select_support`). A set is proposed only when together
its terms explain clearly more than the sum of what each explains alone; the selection
(:mod:`~sklearn_hybrid.diagnosis.loop.stepwise`) refits each without the network and judges it by the
same evidence as a single term, with the threshold corrected for the number of sets judged
(:func:`~sklearn_hybrid.diagnosis.evidence.holm`).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import replace
from itertools import combinations

import numpy as np

from ..sensitivity import parameter_basis
from ..supports import select_support, support_stats
from .placed import PlacedGroup, PlacedTerm

__all__ = ["joint_candidates"]

# Least squares of a sparse fit: supports chosen by the extended BIC (which pays for the number of
# candidate terms), of at most this many terms, each explaining 1 % of the residual at least.
_SPARSE = {"criterion": "ebic", "max_terms": 3, "min_explained": 0.01}


def joint_candidates(columns: list[tuple], remaining: np.ndarray, jac: np.ndarray, components: Sequence[int],
                     taken: set, *, n: int = 4, n_leads: int = 3, n_partners: int = 2,
                     min_share: float = 0.05) -> list[PlacedGroup]:
    """Sets of two or three terms on one equation that explain the residual only together.

    Parameters
    ----------
    columns : list of (Term, dict, ndarray)
        Every term at every starting shape on the visited states
        (:func:`~sklearn_hybrid.diagnosis.loop.candidates.term_columns`).
    remaining : ndarray of shape (n_points, n_outputs)
        What the hybrid learned beyond the current science model.
    jac : ndarray of shape (n_points, n_outputs, n_params)
        Sensitivities of the current science model to its free parameters: a set is fitted together
        with them, so that a mere parameter shift counts for nothing.
    components : list of int
        The equations that may receive terms.
    taken : set of (int, str)
        ``(component, term)`` pairs already in the model (or refused): not proposed again.
    n : int, default=4
        At most this many sets, those that explain the largest share first.
    n_leads, n_partners : int, default=3 and 2
        The ``n_leads`` best-ranked terms of an equation are paired with each other and each with the
        ``n_partners`` terms that explain most of what it leaves.
    min_share : float, default=0.05
        A set is proposed only when it explains at least this share of the residual more than its
        terms alone, added up (otherwise one term at a time finds it, and a set only costs refits).

    Returns
    -------
    list of PlacedGroup
        Joint candidates (kind ``"joint"``) on one component each, whose ``members`` are the single
        terms (each placed as :func:`~sklearn_hybrid.diagnosis.loop.candidates.rank_by_residual`
        places them, with its coefficient from the joint fit); ``gain`` is the share the set explains.
    """
    found: dict[frozenset, PlacedGroup] = {}
    for j in components:
        pool, U, r = _pool(columns, remaining[:, j], jac[:, j, :], j, taken)
        if len(pool) < 2:
            continue
        alone = (U.T @ r) ** 2  # the share of the residual (of unit norm) each term explains alone
        leads = np.argsort(-alone)[:n_leads]
        sets = {frozenset([int(a), int(b)]) for a in leads for b in _partners(U, r, a, n_partners)}
        sets |= {frozenset([int(a), int(b)]) for a, b in combinations(leads, 2)}  # the best-ranked, in pairs
        sparse = select_support(support_stats(U, r[:, None], np.ones(len(r))), [], 0, _SPARSE)
        if len(sparse) >= 2:
            sets.add(frozenset(int(k) for k in sparse))
        for members in sets:
            idx = sorted(members)
            beta, *_ = np.linalg.lstsq(U[:, idx], r, rcond=None)
            share = 1.0 - float(np.sum((r - U[:, idx] @ beta) ** 2))
            if share - float(alone[idx].sum()) < min_share:
                continue
            group = tuple(replace(pool[k], coef=float(b) * pool[k].coef) for k, b in zip(idx, beta))
            found[frozenset(e.key for e in group)] = PlacedGroup(group, joint=True, gain=share)
    return sorted(found.values(), key=lambda c: -c.gain)[:n]


def _pool(columns: list[tuple], residual: np.ndarray, S: np.ndarray, j: int, taken: set):
    """Every term that may go on equation ``j`` at its best starting shape, as unit columns orthogonal
    to the parameters' sensitivities, and the residual likewise (of unit norm).

    Each entry's ``coef`` is the factor from its unit column back to the term's own scale.
    """
    Q = parameter_basis(S)
    r = residual - Q @ (Q.T @ residual)
    norm = float(np.sqrt(r @ r))
    if norm == 0:
        return [], np.zeros((len(r), 0)), r
    r = r / norm
    best: dict[str, tuple] = {}
    for term, shape, col in columns:
        if (j, term.name) in taken or term.component not in (None, j):
            continue
        c = col - Q @ (Q.T @ col)
        cc = float(c @ c)
        if cc < 1e-3 * float(col @ col):  # within the parameters' span: a shift, not a term
            continue
        u = c / np.sqrt(cc)
        score = float(u @ r) ** 2
        if term.name not in best or score > best[term.name][0]:
            best[term.name] = (score, PlacedTerm(term, j, shape, norm / np.sqrt(cc), score), u)
    pool = [entry for _, entry, _ in best.values()]
    U = np.column_stack([u for *_, u in best.values()]) if best else np.zeros((len(r), 0))
    return pool, U, r


def _partners(U: np.ndarray, r: np.ndarray, a: int, k: int) -> list[int]:
    """The ``k`` terms that explain most of what term ``a`` leaves of the residual."""
    ua = U[:, a]
    rest = r - ua * (ua @ r)
    V = U - np.outer(ua, ua @ U)  # every column made orthogonal to term a
    vv = np.sum(V ** 2, axis=0)
    score = np.where(vv > 1e-3, (V.T @ rest) ** 2 / np.maximum(vv, 1e-300), -np.inf)
    score[a] = -np.inf
    return [int(b) for b in np.argsort(-score)[:k] if np.isfinite(score[b])]
