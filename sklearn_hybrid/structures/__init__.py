"""How the science model f_theta and the network g_phi combine: a name-to-structure registry.

A structure learns the per-sample shapes from the training data (``setup``),
turns arrays into tensors (``tensors``), checks the science function on a
few samples (``probe``), names the shapes its network needs
(``residual_shapes``), computes predictions (``forward``), and defines the
functional regulariser of ``method="f-reg"`` (``functional_penalty``, one value per sample).

==============  =========================================================
``"ode"``       hybrid neural ODE ``dv/dt = f_theta(v[, u]) + g_phi(v[, u])``
``"compose"``   general composition ``y = g_phi(x, f_theta(x))``
``"additive"``  static additive model ``y = f_theta(x) + g_phi(x)``
callable        ``structure(x, f, g) -> y`` for anything more nested
==============  =========================================================

The estimator takes the object itself or its name, as scikit-learn takes
``kernel=RBF()`` or ``kernel="rbf"``: ``structure=OdeStructure(dt=0.1,
observed=[0])`` carries the ODE's options, ``structure="ode"`` is the ODE with
its defaults.  The estimator's flat ``dt``, ``n_substeps``, ``solver``,
``observed``, ``n_inputs`` and ``input_interp`` are deprecated
(``structure_of``).  A fit sets up a fresh copy, never the object given.
"""

from __future__ import annotations

import copy
import warnings
from collections.abc import Mapping

import numpy as np
import torch
from torch import nn

from .._validation import DEPRECATED, given_settings
from .ode import ODE_DEFAULTS, OdeStructure, pack_inputs
from .static import AdditiveStructure, CallableStructure, ComposeStructure

__all__ = ["HybridModule", "make_structure", "STRUCTURES", "pack_inputs", "OdeStructure", "ComposeStructure",
           "AdditiveStructure", "ode_options", "ODE_DEFAULTS", "structure_of", "ODE_FLAT_SETTINGS"]


class HybridModule(nn.Module):
    """Science part, network and structure in one module (what training updates).

    With a theta ``encoder`` (see :mod:`sklearn_hybrid.encoder`) the last
    input is the encoder's window: each sample's theta is inferred from it and
    the structure runs on the other inputs with that theta bound.
    """

    def __init__(self, science: nn.Module, residual: nn.Module, structure,
                 reduction: nn.Module | None = None, encoder: nn.Module | None = None):
        super().__init__()
        self.science = science
        self.residual = residual
        self.reduction = reduction
        self.structure = structure
        self.encoder = encoder

    def bind(self, inputs):
        """The model the structure sees and the structure's inputs (per-sample theta bound)."""
        if self.encoder is None:
            return self, inputs
        from ..encoder import BoundModel

        *inputs, window = inputs
        return BoundModel(self, self.encoder(window, self.science)), tuple(inputs)

    def forward(self, *inputs: torch.Tensor, use_residual: bool = True):
        model, inputs = self.bind(inputs)
        return self.structure.forward(model, *inputs, use_residual=use_residual)

    def trace(self, inputs, pred, extras):
        """Where the network acts and what it contributes (see ``HybridRegressor.residual_trace``)."""
        model, inputs = self.bind(inputs)
        return self.structure.trace(model, inputs, pred, extras)

    def theta_parameters(self) -> list:
        """Trainable tensors of theta: free science parameters, or the encoder's weights."""
        own = [p for p in self.science.parameters() if p.requires_grad]
        return own + ([] if self.encoder is None else list(self.encoder.parameters()))

    def theta_values(self) -> dict:
        """Current theta; with an encoder, the batch mean of its last forward pass."""
        values = self.science.values()
        if self.encoder is not None and self.encoder.last_mean is not None:
            values.update(self.encoder.last_mean)
        return values


STRUCTURES = {"ode": OdeStructure, "compose": ComposeStructure, "additive": AdditiveStructure}


def ode_options(structure: OdeStructure, **keywords) -> dict:
    """The options of ``structure`` with the estimator's keywords of the same names.

    A keyword left at its default defers to the object; one given must agree with it, since two
    values of ``dt`` would leave the reader to guess which one the fit used.

    Parameters
    ----------
    structure : OdeStructure
        The estimator's ``structure``.
    **keywords
        The estimator's ``dt``, ``n_substeps``, ``solver``, ``observed``, ``n_inputs``, ``input_interp``.

    Returns
    -------
    dict
        The options a fresh OdeStructure is built from.

    Raises
    ------
    ValueError
        If a keyword given differs from the object's option.
    """
    options = structure.options()
    for name, value in keywords.items():
        if value is ODE_DEFAULTS[name] or (not isinstance(value, np.ndarray) and value == ODE_DEFAULTS[name]):
            continue
        stored = OdeStructure(**{name: value}).options()[name]  # as the object stores it: dt a float...
        if stored != options[name]:
            raise ValueError(f"structure={structure!r} and {name}={value!r} disagree: give {name} once, in "
                             f"OdeStructure({name}=...) or as the estimator's {name}.")
    return options


def make_structure(spec, **options):
    """A fresh structure from its name (with ``options``, an ODE's), from a structure object (a copy,
    which a fit sets up; an OdeStructure's options merged with ``options`` by ``ode_options``), or from
    a callable ``structure(x, f, g) -> y``."""
    if isinstance(spec, OdeStructure):
        return OdeStructure(**ode_options(spec, **options))
    if isinstance(spec, ComposeStructure):
        return copy.deepcopy(spec)
    if callable(spec) and not isinstance(spec, type):
        return CallableStructure(spec)
    if spec not in STRUCTURES:
        raise ValueError(
            f"Unknown structure {spec!r}; choose one of {sorted(STRUCTURES)}, pass a structure object such "
            "as OdeStructure(dt=0.1) or a callable structure(x, f, g) -> y."
        )
    if spec == "ode":
        return OdeStructure(**options)
    return STRUCTURES[spec]()


#: The estimators' deprecated flat copies of an ODE structure's options, each at its "not given" value.
ODE_FLAT_SETTINGS = {name: DEPRECATED for name in ("dt", "n_substeps", "solver", "observed", "n_inputs",
                                                    "input_interp")}


def structure_of(settings: Mapping, *, warn: bool = False):
    """The structure an estimator's settings name: ``settings["structure"]`` (a name, a structure object or a
    callable) with the deprecated flat ODE options beside it.

    Parameters
    ----------
    settings : mapping
        The estimator's ``get_params()`` (or its parameters at fit).
    warn : bool, default=False
        Warn (``FutureWarning``) that flat options are deprecated: a fit does, once; the package's own
        reads of a structure (the diagnosis, the profile) do not.

    Returns
    -------
    A fresh structure (see :func:`make_structure`); flat options given beside ``"ode"`` apply, beside an
    ``OdeStructure`` they must agree with it (:func:`ode_options`).
    """
    flat = given_settings(settings, ODE_FLAT_SETTINGS, none_unset=("dt",))  # dt=None: not given, before
    spec = settings.get("structure", "ode")
    if flat and warn:
        given = ", ".join(f"{k}={v!r}" for k, v in flat.items())
        warnings.warn(f"HybridRegressor({given}) is deprecated and will be removed: the structure carries its "
                      f"options, structure=OdeStructure({given}) (from sklearn_hybrid).", FutureWarning,
                      stacklevel=4)
    return make_structure(spec, **flat)
