"""The closed loop's typed results: a verdict, a step of the selection, an added term, the selection.

Each is a frozen dataclass with its fields by attribute, and reads as the dict that the loop's records
have always held (``step["gain"]``, ``{**verdict}``, ``as_dict()`` for JSON): the report, the
benchmarks' stored records and users' code read them unchanged, while the code that makes them says
what each holds.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator, Mapping
from dataclasses import dataclass, field, fields
from typing import Any

import numpy as np

__all__ = ["Result", "Verdict", "Step", "AddedTerm", "Selection"]


class Result(Mapping):
    """A typed result that reads as a dict: ``result[key]``, ``key in result``, ``{**result}``.

    A subclass is a frozen dataclass; :meth:`as_dict` gives its fields (a subclass may lay them out
    as its records hold them).
    """

    def as_dict(self) -> dict[str, Any]:
        """The fields as a plain dict (for JSON records and ``json.dumps``)."""
        return {f.name: getattr(self, f.name) for f in fields(self)}

    def __getitem__(self, key: str) -> Any:
        return self.as_dict()[key]

    def __iter__(self) -> Iterator[str]:
        return iter(self.as_dict())

    def __len__(self) -> int:
        return len(self.as_dict())


@dataclass(frozen=True, eq=False)
class Verdict(Result):
    """Whether a change lowered the held-out error by more than noise explains
    (:func:`~sklearn_hybrid.diagnosis.evidence`).

    ``threshold`` is what ``z`` had to exceed (None where no test was made: a replacement is judged by
    its error alone).
    """

    mse_before: float
    mse_after: float
    gain: float
    z: float
    threshold: float | None
    accepted: bool

    def as_dict(self) -> dict[str, Any]:
        out = super().as_dict()
        if self.threshold is None:
            del out["threshold"]
        return out


@dataclass(frozen=True, eq=False)
class Step(Result):
    """A candidate judged during the selection: what it was, where, its verdict and whether it was taken.

    ``step`` is the step's number, or a label (``"3, second look"``, ``"drop"``, ``"replace"``, ``"simplify"``);
    ``rank_gain`` the share of the residual the candidate explained when ranked; ``verdict`` None
    where its refit failed (``failed`` says why); ``accepted`` whether the selection took it (not the
    verdict's own yes: among several that pass, one is taken).
    """

    step: int | str
    term: str
    kind: str
    component: Any
    ranked_by: str
    shape: Mapping[str, float]
    rank_gain: float
    verdict: Verdict | None = None
    failed: str | None = None
    accepted: bool = False
    output: str | None = None
    replaces: list[str] | None = None  # a replacement: the terms it stands for
    dropped: bool = False  # a backward step: the term dropped

    @classmethod
    def of(cls, step: int | str, row: Mapping[str, Any], **values: Any) -> "Step":
        """The step of a candidate from its row (``PlacedTerm.row()``)."""
        return cls(step=step, term=row["term"], kind=row["kind"], component=row["component"],
                   ranked_by=row["ranked_by"], shape=row["shape"], rank_gain=row["gain"], **values)

    def as_dict(self) -> dict[str, Any]:
        out = {"step": self.step, "ranked_by": self.ranked_by, "component": self.component, "term": self.term,
               "kind": self.kind, "gain": self.rank_gain, "shape": self.shape}
        if self.failed is not None:
            out["failed"] = self.failed
        if self.verdict is not None:
            out.update({k: v for k, v in self.verdict.items() if k != "accepted"})
        out["accepted"] = self.accepted
        if self.replaces is not None:
            out["replaces"] = list(self.replaces)
        if self.dropped:
            out["dropped"] = True
        if self.output is not None:
            out["output"] = self.output
        return out


@dataclass(frozen=True, eq=False)
class AddedTerm(Result):
    """A term the loop added, fitted on every sample: where, its form, coefficient and parameters.

    ``output`` names the equation (``g[v]``), or the measured state of a sensor offset; a flow adds
    the same term with the opposite sign on ``opposite`` (``opposite_output``); ``consistent`` says
    whether a discovered form adds quantities of one unit (None for a listed term).
    """

    component: int
    term: str
    kind: str
    unit: str | None
    function: Callable
    shape: Mapping[str, float]
    bounds: Any
    coef: float
    gain: float
    param: str
    shape_params: Mapping[str, str]
    second_look: bool
    output: str
    ranked_by: str | None = None  # None: ranked by the residual
    opposite: int | None = None
    opposite_output: str | None = None
    consistent: bool | None = None
    shape_group: str | None = None  # shares its shape parameters with the other terms of this label

    def as_dict(self) -> dict[str, Any]:
        # the keys in the order, and with the presence, that the records kept before this class
        fields_ = super().as_dict()
        order = ("component", "term", "kind", "unit", "function", "shape", "bounds", "coef", "gain", "ranked_by",
                 "param", "shape_params", "second_look", "opposite", "consistent", "shape_group", "output",
                 "opposite_output")
        return {k: fields_[k] for k in order if fields_[k] is not None
                or k not in ("ranked_by", "opposite", "opposite_output", "consistent", "shape_group")}


@dataclass(frozen=True, eq=False)
class Selection(Result):
    """What the forward selection chose: the augmented science, its parameters, its terms and its path.

    ``added`` holds the accepted terms as the selection placed them (``loop.placed.PlacedTerm``); ``rivals``
    the candidates the held-out data could not tell from the choice; ``errors`` the chosen model's
    held-out errors, ``base_errors`` the science's alone.
    """

    science: Callable
    theta: dict
    added: list
    steps: list[Step]
    rivals: list[dict]
    base_errors: np.ndarray
    errors: np.ndarray
    seconds: float = field(default=0.0)
