"""Residual diagnosis: explain what the neural part of a hybrid model learned with named terms."""

from .library import CandidateLibrary
from .sparse import SparseTermRegression

__all__ = ["CandidateLibrary", "SparseTermRegression"]
from .augment import augment_science, parameter_name, term_to_torch
from .loop import MLPOn, ZeroResidual, close_the_loop, fit_initial_state, format_table, free_run, prediction_metrics
from .residual import ResidualDiagnosis, science_sensitivities

__all__ += ["ResidualDiagnosis", "science_sensitivities", "augment_science", "term_to_torch", "parameter_name",
            "close_the_loop", "free_run", "fit_initial_state", "MLPOn", "ZeroResidual", "prediction_metrics",
            "format_table"]
