"""A candidate of the selection: a term placed on a component, or several judged as one.

:class:`PlacedTerm` keeps the :class:`~sklearn_hybrid.diagnosis.Term` itself beside where it stands
(``component``), its starting (or fitted) ``shape`` and ``coef``, the ranking's ``gain`` and, once
accepted, the names of its parameters in the augmented model. :class:`PlacedGroup` is several placed
terms judged together: one term on several components (a flux that enters every balance it converts)
or a joint set of terms on one equation (the two terms of a limit cycle). Both answer the questions the
selection asks of a candidate: which terms it places (:meth:`~PlacedTerm.entries`), how many parameters
it costs (:meth:`~PlacedTerm.n_parameters`), where it acts (:meth:`~PlacedTerm.where`) and the fields of
its row in the selection's log (:meth:`~PlacedTerm.row`).

What leaves the loop stays a dict: :meth:`PlacedTerm.record` is an accepted term as
:attr:`~sklearn_hybrid.diagnosis.LoopResult.added` holds it, and a row is a dict of the selection's steps.
"""

from __future__ import annotations

import math
import numbers
from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from typing import Any, Union

from ..terms import Term

__all__ = ["PlacedTerm", "PlacedGroup", "Candidate", "offset_term", "label_joined_shapes"]


def offset_term(name: str) -> Term:
    """The term of a sensor offset: it has no function of its own (it shifts the state every part of the
    right-hand side sees, :func:`~sklearn_hybrid.diagnosis.augment_science`), no shape and no unit."""
    return Term(name, None, "offset")


@dataclass(frozen=True, eq=False)
class PlacedTerm:
    """A term placed on one component of the science model: a candidate, or an accepted term once fitted.

    Parameters
    ----------
    term : Term
        The term (for a sensor offset, :func:`offset_term`).
    component : int
        The output the term is added to (for an offset: the state whose sensor reads with it).
    shape : dict of str to float
        Its shape parameters' values: the starting ones of a candidate, the fitted ones of an accepted term.
    coef : float
        Its coefficient: the ranking's estimate, or the fitted value.
    gain : float, default=nan
        The share its ranking says it explains (nan for a declared offset).
    ranked_by : str, default="residual"
        Which ranking proposed it: ``"residual"``, ``"fit"`` or ``"declared"`` (an offset).
    param : str, optional
        Once fitted: the name of its coefficient in the augmented model.
    shape_params : dict of str to str, optional
        Once fitted: the names of its shape parameters there, by the term's own names.
    second_look : bool, default=False
        Accepted on a second look (judged by folds of the training samples).
    opposite : int, optional
        A flow: the term also enters this component with the opposite sign and the same coefficient (what
        leaves one compartment enters the other; ``ranked_by`` ``"flow"``).
    shape_group : str, optional
        A member of a group of one term on several components (:class:`PlacedGroup`): the members with this
        label share one set of shape parameters (see :func:`~sklearn_hybrid.diagnosis.augment_science`).
    shares_shape : bool, default=False
        It joins the shape group of the same term already in the model on another component
        (:func:`~sklearn_hybrid.diagnosis.loop.groups.join_shape_groups`): it adds a coefficient only.
    """

    term: Term
    component: int
    shape: Mapping[str, float] = field(default_factory=dict)
    coef: float = 0.0
    gain: float = math.nan
    ranked_by: str = "residual"
    param: str | None = None
    shape_params: Mapping[str, str] | None = None
    second_look: bool = False
    opposite: int | None = None
    shape_group: str | None = None
    shares_shape: bool = False

    def __post_init__(self) -> None:
        # checked here: a name or an index in place of the Term failed only where ``.name`` was first read
        if not isinstance(self.term, Term):
            raise TypeError(f"PlacedTerm needs a Term (from physics_terms, named_terms or Term(...)) as its "
                            f"first argument, got {type(self.term).__name__} {self.term!r}")
        if isinstance(self.component, bool) or not isinstance(self.component, numbers.Integral):
            raise TypeError(f"PlacedTerm: component must be an int (the output the term is added to), got "
                            f"{type(self.component).__name__} {self.component!r}")

    @property
    def name(self) -> str:
        return self.term.name

    @property
    def kind(self) -> str:
        return self.term.kind

    @property
    def key(self) -> tuple[int, str]:
        """``(component, term name)``: at most one of each in a model."""
        return self.component, self.term.name

    @property
    def covers(self) -> set[tuple[int, str]]:
        """``(component, term name)`` of every equation it changes: a flow's two."""
        return {self.key} | ({(self.opposite, self.term.name)} if self.opposite is not None else set())

    def entries(self) -> list[PlacedTerm]:
        """The single terms this candidate places: itself."""
        return [self]

    def n_parameters(self) -> int:
        """Coefficients and shape parameters the candidate adds."""
        return 1 + (0 if self.shares_shape else len(self.shape))

    def where(self) -> str:
        """Where it acts, in words for the log."""
        if self.kind == "offset":
            return f"the sensor of state {self.component}"
        if self.opposite is not None:
            return f"components {self.component} and {self.opposite} (a flow, one coefficient)"
        return f"component {self.component}"

    def row(self) -> dict[str, Any]:
        """Its fields in a row of the selection's steps."""
        where = self.component if self.opposite is None else [self.component, self.opposite]
        return {"ranked_by": self.ranked_by, "component": where, "term": self.name, "kind": self.kind,
                "gain": self.gain, "shape": self.shape}

    def with_fitted(self, augmented: Any, theta: Mapping[str, Any], i: int) -> PlacedTerm:
        """The term as the ``i``-th of the ``augmented`` model fitted at ``theta``: its fitted coefficient and
        shape, and the names of its parameters there."""
        _, _, coef_name = augmented.terms[i]
        names = dict(augmented.shape_names[i])
        return replace(self, coef=float(theta[coef_name]), shape={loc: float(theta[g]) for loc, g in names.items()},
                       param=coef_name, shape_params=names)

    def with_values(self, theta: Mapping[str, Any]) -> PlacedTerm:
        """A fitted term with its coefficient and shape read from ``theta`` by its parameter names (another
        fit of the same model).

        Raises
        ------
        ValueError
            If the term was never fitted (it has no parameter names: see :meth:`with_fitted`).
        KeyError
            If ``theta`` lacks one of its parameters; the message names those it needs.
        """
        if self.param is None or self.shape_params is None:
            raise ValueError(f"with_values needs a fitted term (one made by with_fitted, which names its "
                             f"parameters); {self.name!r} on {self.where()} has no parameter names")
        needed = [self.param, *self.shape_params.values()]
        missing = [g for g in needed if g not in theta]
        if missing:
            raise KeyError(f"theta lacks {', '.join(missing)} of term {self.name!r} on {self.where()}; it needs "
                           f"{', '.join(needed)}")
        return replace(self, coef=float(theta[self.param]),
                       shape={loc: float(theta[g]) for loc, g in self.shape_params.items()})

    def parameter_bounds(self) -> dict[str, tuple[float, float]]:
        """A fitted term's shape parameters' bounds, by their names in the model."""
        return {g: self.term.shape[loc][1] for loc, g in (self.shape_params or {}).items()}

    def record(self) -> dict[str, Any]:
        """The accepted term as :attr:`~sklearn_hybrid.diagnosis.LoopResult.added` holds it.

        The keys are those the dicts of the selection had before it used this class (the benchmarks store
        them): a term the residual ranked has no ``ranked_by``, every other has one.
        """
        out = {"component": self.component, "term": self.name, "kind": self.kind, "unit": self.term.unit,
               "function": self.term.func, "shape": dict(self.shape), "bounds": self.term.shape, "coef": self.coef,
               "gain": self.gain}
        if self.ranked_by != "residual":
            out["ranked_by"] = self.ranked_by
        out.update(param=self.param, shape_params=dict(self.shape_params or {}), second_look=self.second_look)
        if self.opposite is not None:  # a flow: the same term, with the opposite sign, on this component
            out["opposite"] = self.opposite
        if self.term.consistent is not None:  # a discovered form: dimensionally consistent in the units given
            out["consistent"] = self.term.consistent
        if self.shape_group is not None:
            out["shape_group"] = self.shape_group
        return out


def label_joined_shapes(placed: list[PlacedTerm]) -> list[PlacedTerm]:
    """``placed`` with each term that another joins (one with ``shares_shape``) labelled its shape group.

    A term placed while the same term is held on another equation joins the held one's shape
    (:func:`~sklearn_hybrid.diagnosis.loop.groups.join_shape_groups`); the held term, placed before any
    joined it, carries no group yet, and takes its own name as the group's label here, so that the augmented
    model gives both one set of shape parameters.
    """
    joined = {t.shape_group for t in placed if t.shares_shape}
    return [replace(t, shape_group=t.name) if t.name in joined and t.shape_group is None else t for t in placed]


@dataclass(frozen=True, eq=False)
class PlacedGroup:
    """Several placed terms judged as one candidate, each with its own coefficient.

    Parameters
    ----------
    members : tuple of PlacedTerm
        The terms it places.
    joint : bool, default=False
        False: one term on several components, or the terms of one vector field each on its own
        (``ranked_by`` ``"group"``, see :func:`~sklearn_hybrid.diagnosis.loop.groups.candidate_groups`
        and :func:`~sklearn_hybrid.diagnosis.loop.groups.field_groups`); True: a set of terms on one
        equation that explain the residual only together (kind ``"joint"``, see
        :func:`~sklearn_hybrid.diagnosis.loop.joint.joint_candidates`).
    gain : float, default=nan
        The share of the residual its ranking says it explains.
    """

    members: tuple[PlacedTerm, ...]
    joint: bool = False
    gain: float = math.nan

    def __post_init__(self) -> None:
        # a list is kept as a tuple, as the package builds its groups (a frozen group holds no mutable list)
        object.__setattr__(self, "members", tuple(self.members))
        # checked here: an empty group failed only where its first member was read (IndexError)
        if not self.members:
            raise ValueError("PlacedGroup needs at least one member (a PlacedTerm); got none")
        for i, m in enumerate(self.members):
            if not isinstance(m, PlacedTerm):
                raise TypeError(f"PlacedGroup members must be PlacedTerm objects; member {i} is "
                                f"{type(m).__name__} {m!r}")

    @property
    def name(self) -> str:
        """A joint set's terms joined by ``+``; a group's one term, or the vector field its terms make up."""
        if self.joint:
            return " + ".join(m.name for m in self.members)
        if len({m.name for m in self.members}) > 1:
            return self.members[0].term.field or " + ".join(m.name for m in self.members)
        return self.members[0].name

    @property
    def kind(self) -> str:
        return "joint" if self.joint else self.members[0].kind

    @property
    def component(self) -> int | list[int]:
        """A joint set's one equation; a group's components, in a list."""
        return self.members[0].component if self.joint else [m.component for m in self.members]

    @property
    def ranked_by(self) -> str:
        return "joint" if self.joint else "group"

    def entries(self) -> list[PlacedTerm]:
        """The single terms it places."""
        return list(self.members)

    def n_parameters(self) -> int:
        """Coefficients and shape parameters the candidate adds (a shape group's shape counted once)."""
        shapes = {m.shape_group if m.shape_group is not None else i: len(m.shape) for i, m in enumerate(self.members)}
        return len(self.members) + sum(shapes.values())

    def where(self) -> str:
        """Where it acts, in words for the log."""
        if self.joint:
            return f"component {self.component}"
        return f"components {', '.join(map(str, self.component))}"

    def row(self) -> dict[str, Any]:
        """Its fields in a row of the selection's steps (a group's shape is its first member's)."""
        return {"ranked_by": self.ranked_by, "component": self.component, "term": self.name, "kind": self.kind,
                "gain": self.gain, "shape": {} if self.joint else self.members[0].shape}


#: What the selection screens and judges.
Candidate = Union[PlacedTerm, PlacedGroup]
