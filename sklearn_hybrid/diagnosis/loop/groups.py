"""Candidates judged together: one term on several equations, a flow between two, a vector field's terms.

A flux enters every balance it converts, a flow moves matter from one state to another, a drag acts along
the speed on each velocity: alone on one equation such a term explains little, since the other balance
stays wrong. Each function here turns :func:`~sklearn_hybrid.diagnosis.loop.candidates.rank_by_residual`'s
placements into candidates that place the term on all its equations at once
(:class:`~sklearn_hybrid.diagnosis.loop.placed.PlacedGroup`, or a flow: one
:class:`~sklearn_hybrid.diagnosis.loop.placed.PlacedTerm` with an ``opposite``), judged by
:mod:`~sklearn_hybrid.diagnosis.loop.stepwise` like any candidate.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import replace

from .placed import PlacedGroup, PlacedTerm

__all__ = ["candidate_groups", "first_placements", "flow_candidates", "flow_groups", "join_shape_groups",
           "field_groups"]


def candidate_groups(ranked: list[PlacedTerm]) -> list[PlacedGroup]:
    """One candidate per term that stands on two or more components among ``ranked``: the term on all of
    them at once, each with its own coefficient.

    A reaction's flux enters the balance of every species it converts (``-k A B`` on A, ``+k A B`` on
    B); alone on either component the term explains little, since the other balance stays wrong, and
    at high noise neither single passes although the pair explains nearly everything. Judged like any
    candidate, and costing one coefficient per component (its shape parameters, one set shared by the
    members, as one flux has one shape), a group wins only where it validates better
    than each of its single terms by more than ``min_gain`` (see :func:`~sklearn_hybrid.diagnosis.loop.second_look.simplest_of_the_best`).
    """
    by_term: dict[str, list[PlacedTerm]] = {}
    for cand in ranked:
        by_term.setdefault(cand.name, []).append(cand)
    # one flux, one shape: the members share the shape parameters, starting from the first-ranked member's
    return [PlacedGroup(tuple(replace(e, shape=entries[0].shape, shape_group=name) for e in entries),
                        gain=entries[0].gain) for name, entries in by_term.items() if len(entries) > 1]


def flow_candidates(scored: list[PlacedTerm], pairs: Sequence[tuple[int, int]], n: int) -> list[PlacedTerm]:
    """The ``n`` best flows: a term that ``scored`` (:func:`~sklearn_hybrid.diagnosis.loop.candidates.rank_by_residual`'s whole ranking) places on both
    components of a pair with coefficients of opposite signs, as one term with one coefficient, ``+c`` on the
    first and ``-c`` on the second.

    A waning immunity moves ``w R`` from the recovered to the susceptible; two free coefficients (``+0.35 R``
    on dS, ``-0.35 R`` on dR) say nothing of their agreeing, and cost a parameter more. ``pairs`` are the
    components whose states may exchange (states in one unit). A pair's two orientations are one model (the
    coefficient's sign turns it around): each flow is offered once, on the component it enters (``+c``).
    """
    best = _best_placements(scored)
    out = []
    for i, j in pairs:
        for (component, name), a in best.items():
            b = best.get((j, name))
            if component != i or b is None or a.term.component is not None or not a.coef > 0 > b.coef:
                continue
            out.append(replace(a, gain=a.gain + b.gain, ranked_by="flow", opposite=j))
    return sorted(out, key=lambda t: -t.gain)[:n]


def first_placements(scored: list[PlacedTerm], names: set[str]) -> list[PlacedTerm]:
    """The best-ranked placement in ``scored`` of each term named in ``names``: one candidate per term,
    on the equation where it explains most (a term ``scored`` does not hold, none)."""
    out: dict[str, PlacedTerm] = {}
    for cand in scored:
        if cand.name in names:
            out.setdefault(cand.name, cand)
    return list(out.values())


def join_shape_groups(added: Sequence[PlacedTerm], candidates: list) -> list:
    """``candidates`` with each single term whose term the model already holds on another component, with
    shape parameters, placed as a member of that term's shape group: its shape is the held term's, and it adds
    a coefficient only.

    One flux has one shape. The selection may take a flux's term on one equation first (a predation on the
    prey's) and only later on another (the predator's); there, alone, it would fit a shape of its own, and cost
    as many parameters as another form that trades with a science parameter.
    """
    held = {t.name: t for t in added if t.shape and t.kind != "offset"}
    out = []
    for cand in candidates:
        t = held.get(cand.name) if isinstance(cand, PlacedTerm) else None
        if t is not None and t.component != cand.component and t.shape_group in (None, t.name):
            cand = replace(cand, shape=dict(t.shape), shape_group=t.name, shares_shape=True)
        out.append(cand)
    return out


def flow_groups(flows: list[PlacedTerm], scored: list[PlacedTerm]) -> list[PlacedGroup]:
    """Each flow also as a group: its term on both components, a coefficient each (:func:`candidate_groups`).

    A flux may enter the second balance with a yield other than one: half the prey eaten becomes predator,
    one mole of A makes two of B. Alone, the flow (``+c``, ``-c``) fits such a flux only with a second term
    beside it, and a group of the term is offered only where the term ranks among the best on both
    equations. Judged like any group; where the yield is one, the flow is the simpler of the two.
    """
    best = _best_placements(scored)
    out = []
    for flow in flows:
        pair = [best[(flow.component, flow.name)], best[(flow.opposite, flow.name)]]
        out += [replace(g, gain=flow.gain) for g in candidate_groups(pair)]
    return out


def _best_placements(scored: list[PlacedTerm]) -> dict[tuple[int, str], PlacedTerm]:
    """Each (component, term)'s best-ranked placement in ``scored``."""
    best: dict[tuple[int, str], PlacedTerm] = {}
    for cand in scored:
        best.setdefault((cand.component, cand.name), cand)
    return best


def field_groups(ranked: list[PlacedTerm], scored: list[PlacedTerm]) -> list[PlacedGroup]:
    """One candidate per vector field with a term among ``ranked``: every term of the field at once, each
    on the equation where it explains most of the residual (``scored``, :func:`~sklearn_hybrid.diagnosis.loop.candidates.rank_by_residual`'s whole
    ranking), no two on one equation, each with its own coefficient.

    A drag along the speed, ``-c |v| (vx, vz)``, acts on both velocity equations; where the science
    already has a linear drag ``-k (vx, vz)`` with one ``k``, the term on one equation alone explains
    little, since ``k``, held by the other equation, keeps standing in for part of the drag there.
    Judged like :func:`candidate_groups`.
    """
    fields = list(dict.fromkeys(c.term.field for c in ranked if c.term.field is not None))
    out = []
    for field in fields:
        members: list[PlacedTerm] = []
        for cand in sorted(scored, key=lambda t: -t.gain):
            if (cand.term.field == field and cand.name not in {m.name for m in members}
                    and cand.component not in {m.component for m in members}):
                members.append(cand)
        if len(members) > 1:
            out.append(PlacedGroup(tuple(members), gain=sum(m.gain for m in members)))
    return out
