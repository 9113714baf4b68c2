"""From the residual a hybrid model learned to the physics its science model lacks.

:func:`close_the_loop` is the one call: fit, rank candidate terms (:func:`physics_terms`, what
physics usually misses) by the residual the network learned, accept a term only when a
network-free refit (:class:`ScienceFit`) validates better on held-out samples by more than the
noise explains (:func:`evidence`), refit and compare. :class:`ResidualDiagnosis` explains a fitted
model's residual by sparse regression on a :class:`CandidateLibrary` (an exploratory reading);
:func:`augment_science` adds chosen terms to a science function.
"""

from .augment import AugmentedScience, augment_science, parameter_name
from .evidence import critical_value, evidence, holm
from .library import CandidateLibrary
from .loop import MLPOn, ZeroResidual, close_the_loop
from .records import fit_initial_state, free_run
from .report import LoopResult, format_table, plot_unexplained, prediction_metrics
from .residual_diagnosis import ResidualDiagnosis
from .sensitivity import science_sensitivities
from .science_fit import ScienceFit
from .sparse import SparseTermRegression
from .terms import SCIENCE_OUTPUT, TERM_KINDS, Term, named_terms, physics_terms

__all__ = ["CandidateLibrary", "SparseTermRegression", "ResidualDiagnosis", "science_sensitivities",
           "augment_science", "AugmentedScience", "parameter_name", "close_the_loop", "free_run",
           "fit_initial_state", "MLPOn", "ZeroResidual", "LoopResult", "prediction_metrics", "format_table",
           "plot_unexplained", "Term", "physics_terms", "named_terms", "TERM_KINDS", "SCIENCE_OUTPUT", "ScienceFit", "evidence",
           "critical_value", "holm"]
