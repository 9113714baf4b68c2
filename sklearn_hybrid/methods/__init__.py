"""Training methods, by name: ``erm``, ``p-reg``, ``f-reg``, ``sam``, ``asam``, ``fsam``.

Each method is one small object (see :class:`Method`) that owns its choices (its
hyperparameters, what it perturbs, whether it needs f-reg's map); adding a method
means adding one class and one registry entry, and nothing else in the package
names it.  The estimators take the object (``method=FisherSAM(rho=0.1)``), which
carries its settings, or its name as a shorthand for the object with its
defaults (``method="fsam"``), as scikit-learn takes ``kernel=RBF()`` or
``kernel="rbf"``; the flat ``rho``, ``lam`` and ``eta`` beside a name are
deprecated (``method_of``).
"""

from __future__ import annotations

import dataclasses
import warnings
from collections.abc import Mapping

from .._validation import DEPRECATED, check_positive, given_settings
from ._base import Method, per_member
from .regularized import ERM, FunctionalRegularization, ParameterRegularization
from .sharpness import (ASAM, GSAM, SAM, FisherSAM, asam_perturbation, fsam_perturbation,
                        sam_perturbation)

__all__ = ["METHODS", "make_method", "method_of", "FLAT_SETTINGS", "stackable_methods", "Method", "ERM",
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
            check_positive(f"{type(name).__name__}.{field}", getattr(name, field))
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


#: The estimators' deprecated flat copies of a method's settings, each at its "not given" value.
FLAT_SETTINGS = {"rho": DEPRECATED, "lam": DEPRECATED, "eta": DEPRECATED}


def method_of(settings: Mapping, *, fitted: bool = False) -> Method:
    """The method an estimator's settings name: ``settings["method"]`` (a name or a :class:`Method`) with
    the deprecated flat ``rho``, ``lam`` and ``eta`` of a method given by name.

    Parameters
    ----------
    settings : mapping
        The estimator's ``get_params()`` (or its parameters at fit): ``method`` and, where given, the
        flat settings (``"deprecated"`` or None: not given).
    fitted : bool, default=False
        The settings of a fit made already (a profile's, a sweep's members): its fit warned of flat
        settings, and a method object's own settings win, as they did when the flat ones had numbers
        for defaults (a fit pickled then). Otherwise flat settings warn (``FutureWarning``), and beside
        a method object they are an error.

    Raises
    ------
    ValueError
        For flat settings beside a method object, which carries its own (they would be ignored).
    """
    method = settings.get("method")
    flat = given_settings(settings, FLAT_SETTINGS, none_unset=FLAT_SETTINGS)
    if fitted and isinstance(method, Method):
        flat = {}
    if flat and isinstance(method, Method):
        given = ", ".join(f"{k}={v!r}" for k, v in flat.items())
        raise ValueError(f"method={method!r} carries its own settings: set {given} in it "
                         f"({type(method).__name__}({given})) and leave the estimator's {sorted(flat)} unset.")
    if flat and not fitted:
        given = ", ".join(f"{k}={v!r}" for k, v in flat.items())
        cls = METHODS.get(method) if isinstance(method, str) else None
        own = ", ".join(f"{k}={v!r}" for k, v in flat.items() if cls is None or k in cls.hyperparameters)
        warnings.warn(f"HybridRegressor({given}) is deprecated and will be removed: the method carries its "
                      f"settings, method={cls.__name__ if cls else 'FisherSAM'}({own}) (from sklearn_hybrid.methods; "
                      "a grid search reaches them as method__rho).", FutureWarning, stacklevel=4)
    return make_method(method, **flat)
