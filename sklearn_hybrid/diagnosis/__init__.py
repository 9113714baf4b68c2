"""Residual diagnosis: explain what the neural part of a hybrid model learned with named terms.

:class:`ResidualDiagnosis` explains a fitted model's residual with a sparse
combination of :class:`CandidateLibrary` terms (:class:`SparseTermRegression`);
:func:`augment_science` adds the chosen terms to the science function, and
:func:`close_the_loop` runs fit -> diagnose -> augment -> refit -> compare.
"""

from .augment import augment_science, parameter_name, term_to_torch
from .library import CandidateLibrary
from .loop import (MLPOn, ZeroResidual, close_the_loop, fit_initial_state, format_table,
                   free_run, prediction_metrics)
from .residual import ResidualDiagnosis, science_sensitivities
from .sparse import SparseTermRegression

__all__ = ["CandidateLibrary", "SparseTermRegression", "ResidualDiagnosis",
           "science_sensitivities", "augment_science", "term_to_torch", "parameter_name",
           "close_the_loop", "free_run", "fit_initial_state", "MLPOn", "ZeroResidual",
           "prediction_metrics", "format_table"]
