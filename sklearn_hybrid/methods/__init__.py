"""Training methods, by name: ``erm``, ``p-reg``, ``f-reg``, ``sam``, ``asam``, ``fsam``.

Each method is one small object (see :class:`Method`) that owns its choices (its
hyperparameters, what it perturbs, whether it needs f-reg's map); adding a method
means adding one class and one registry entry, and nothing else in the package
names it.  The estimators take a name
(``method="fsam"``, with ``rho``/``lam``/``eta`` beside it) or the object
itself (``method=FisherSAM(rho=0.1)``), as scikit-learn takes
``kernel="rbf"`` or ``kernel=RBF()``.
"""

from __future__ import annotations

import dataclasses
import math

from .._validation import check_positive
from ._base import Method, per_member
from .regularized import ERM, FunctionalRegularization, ParameterRegularization
from .sharpness import (ASAM, GSAM, SAM, FisherSAM, asam_perturbation, fsam_perturbation,
                        sam_perturbation)

__all__ = ["METHODS", "make_method", "stackable_methods", "Method", "ERM",
           "ParameterRegularization", "FunctionalRegularization", "SAM", "ASAM", "FisherSAM", "GSAM",
           "per_member", "sam_perturbation", "asam_perturbation", "fsam_perturbation"]

METHODS: dict[str, type[Method]] = {
    "erm": ERM,
    "p-reg": ParameterRegularization,
    "f-reg": FunctionalRegularization,
    "sam": SAM,
    "asam": ASAM,
    "fsam": FisherSAM,
}


def _positive(name, value):
    check_positive(name, value)
    return float(value)


def stackable_methods() -> list[str]:
    """Names of the registered methods that train as stacked members (sweeps, profiles)."""
    return [name for name, cls in METHODS.items() if cls.stackable]


def make_method(name: str | Method, *, rho: float = 0.05, lam: float = 1e-3,
                eta: float | None = None) -> Method:
    """Build the method ``name`` with the hyperparameters it uses.

    Parameters
    ----------
    name : str or Method
        One of :data:`METHODS`, or a method object, which is returned as a copy
        (its own hyperparameters are used; ``rho``, ``lam`` and ``eta`` are ignored).
    rho : float
        Perturbation radius of the SAM family.
    lam : float
        Weight of the p-reg / f-reg penalty.
    eta : float or None
        ASAM offset / Fisher SAM damping; None takes the method's default.

    Returns
    -------
    Method
        A method given by name gets each of its ``hyperparameters`` from the
        keyword of the same name (a keyword it has no field for is ignored, like
        SVC's gamma for a linear kernel); a hyperparameter with no keyword, or
        ``None``, keeps the method's default.
    """
    if isinstance(name, Method):
        for field in type(name).hyperparameters:  # a hyperparameter of the object, checked as the names' are
            value = getattr(name, field)
            if not (isinstance(value, (int, float)) and not isinstance(value, bool)
                    and math.isfinite(value) and value > 0):
                raise ValueError(f"{type(name).__name__}.{field} must be a positive number, got {value!r}.")
        return dataclasses.replace(name)
    if not isinstance(name, str):
        raise TypeError(f"method must be a name ({list(METHODS)}) or a Method object such as "
                        f"FisherSAM(rho=0.05), got {type(name).__name__}.")
    if name not in METHODS:
        raise ValueError(f"Unknown method {name!r}; choose one of {list(METHODS)}.")
    cls = METHODS[name]
    given = {"rho": rho, "lam": lam, "eta": eta}
    return cls(**{field: _positive(field, given[field]) for field in cls.hyperparameters
                  if given.get(field) is not None})
