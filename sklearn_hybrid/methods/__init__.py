"""Training methods, by name: ``erm``, ``p-reg``, ``f-reg``, ``sam``, ``asam``, ``fsam``.

Each method is one small object (see :class:`Method`); adding a method means
adding one class and one registry entry.
"""

from __future__ import annotations

from .._validation import check_positive
from ._base import Method
from .regularized import ERM, FunctionalRegularization, ParameterRegularization
from .sharpness import (ASAM, SAM, FisherSAM, asam_perturbation, fsam_perturbation,
                        sam_perturbation)

__all__ = ["METHODS", "make_method", "Method", "sam_perturbation", "asam_perturbation",
           "fsam_perturbation"]

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


def make_method(name: str, *, rho: float = 0.05, lam: float = 1e-3,
                eta: float | None = None) -> Method:
    """Build the method ``name`` with the hyperparameters it uses.

    Parameters
    ----------
    name : str
        One of :data:`METHODS`.
    rho : float
        Perturbation radius of the SAM family.
    lam : float
        Weight of the p-reg / f-reg penalty.
    eta : float or None
        ASAM offset / Fisher SAM damping; None takes the method's default.

    Returns
    -------
    Method
    """
    if name not in METHODS:
        raise ValueError(f"Unknown method {name!r}; choose one of {list(METHODS)}.")
    cls = METHODS[name]
    if cls.perturbs:
        kwargs = {"rho": _positive("rho", rho)}
        if eta is not None and cls is not SAM:  # like SVC's gamma, ignored where unused
            kwargs["eta"] = _positive("eta", eta)
        return cls(**kwargs)
    if name in ("p-reg", "f-reg"):
        return cls(lam=_positive("lam", lam))
    return cls()
