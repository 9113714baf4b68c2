"""What a family of terms is: a name and ``terms(context)``; the context it reads."""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field

import numpy as np

from ..terms import Term

__all__ = ["TermContext", "TermFamily", "VariableFamily"]


@dataclass(frozen=True, eq=False)
class TermContext:
    """What a family may read to choose its terms.

    Parameters
    ----------
    variables : tuple of str
        States, then inputs.
    values : ndarray of shape (n_points, n_variables)
        Where the variables were visited.
    units : dict of str to str
        Units by variable name (missing: unknown).
    n_states : int
        How many of ``variables`` are states.
    positive : frozenset of str
        Variables that are never negative.
    scaled : dict of int to str
        Output components whose science output may vary with a state or an input, with their labels.
    learned : ndarray of shape (n_points, n_outputs), optional
        What the network learned at ``values``, beyond the science output (a family that reads the residual,
        such as symbolic regression).
    science_output : ndarray of shape (n_points, n_outputs), optional
        The science model's output at ``values``.
    directions : ndarray of shape (n_points, n_outputs, n_parameters), optional
        The science output's sensitivities to its parameters at ``values``: what theta can take.
    components : tuple of int
        The outputs that may receive terms.
    """

    variables: tuple[str, ...]
    values: np.ndarray
    units: Mapping[str, str] = field(default_factory=dict)
    n_states: int = 0
    positive: frozenset = frozenset()
    scaled: Mapping[int, str] = field(default_factory=dict)
    learned: np.ndarray | None = None
    science_output: np.ndarray | None = None
    directions: np.ndarray | None = None
    components: tuple[int, ...] = ()

    @property
    def states(self) -> tuple[str, ...]:
        return self.variables[:self.n_states]

    @property
    def inputs(self) -> tuple[str, ...]:
        return self.variables[self.n_states:]


class TermFamily:
    """A family of terms built from the whole context: ``build(context) -> list of Term``."""

    def __init__(self, name: str, build: Callable[[TermContext], list[Term]]) -> None:
        self.name, self.build = name, build

    def terms(self, context: TermContext) -> list[Term]:
        return self.build(context)

    def __repr__(self) -> str:
        return f"{type(self).__name__}({self.name!r})"


class VariableFamily(TermFamily):
    """A family of terms of one variable at a time: ``build(x, column, scale, unit, positive) -> list of Term``,
    its starting shapes set by the variable's root-mean-square ``scale`` and the quantiles of its ``column``."""

    def terms(self, context: TermContext) -> list[Term]:
        return [t for i in range(len(context.variables)) for t in self.terms_of(context, i)]

    def terms_of(self, context: TermContext, i: int) -> list[Term]:
        x, col = context.variables[i], context.values[:, i]
        scale = float(np.sqrt(np.mean(col ** 2))) or 1.0
        return self.build(x, col, scale, context.units.get(x, ""), x in context.positive)
