"""From the residual a hybrid model learned to the physics its science model lacks.

Two wings over a shared floor. The closed loop (``loop/``) and the exploratory sparse reading
(``sparse/``) share the vocabulary of terms (``terms.py``, ``augment.py``, and the families that offer them,
``families/``), the network-free refits
(``science_fit.py``), the held-out test (``evidence.py``, ``judge.py``), the science helpers
(``sensitivity.py``), and the support selection (``supports.py``).

:func:`close_the_loop` is the one call: fit, rank candidate terms (:func:`physics_terms`, what
physics usually misses) by the residual the network learned, accept a term only when a
network-free refit (:class:`ScienceFit`) validates better on held-out samples by more than the
noise explains (:func:`evidence`), refit and compare; its results are typed (``results.py``:
:class:`Verdict`, :class:`Step`, :class:`AddedTerm`, :class:`Selection`) and read as the dicts the
records keep. :class:`ResidualDiagnosis` explains a fitted
model's residual by sparse regression on a :class:`CandidateLibrary` (an exploratory reading);
:func:`augment_science` adds chosen terms to a science function.

The loop's users also find here, under this one name, the networks it trains (:class:`MLPOn`,
:class:`ZeroResidual`, from :mod:`sklearn_hybrid.residual`) and the free runs it scores with
(:func:`free_run`, :func:`fit_initial_state`, from ``sklearn_hybrid/records.py``); they live beside the
networks and the recipes, so that nothing below the estimator imports the diagnosis.
"""

from .augment import AugmentedScience, augment_science, parameter_name
from .evidence import Evidence, critical_value, evidence, holm
from ..records import fit_initial_state, free_run
from ..residual import MLPOn, ZeroResidual
from .loop import Candidates, LoopResult, close_the_loop, format_table, plot_unexplained, prediction_metrics
from .results import AddedTerm, Selection, Step, Verdict
from .science_fit import ScienceFit
from .sensitivity import science_sensitivities
from .sparse import CandidateLibrary, ResidualDiagnosis, SparseTermRegression
from .families import TERM_FAMILIES, SymbolicDiscovery, TermContext, TermFamily, VariableFamily, physics_terms
from .terms import SCIENCE_OUTPUT, TERM_KINDS, Term, named_terms

__all__ = ["CandidateLibrary", "SparseTermRegression", "ResidualDiagnosis", "science_sensitivities",
           "augment_science", "AugmentedScience", "parameter_name", "close_the_loop", "free_run",
           "fit_initial_state", "MLPOn", "ZeroResidual", "LoopResult", "prediction_metrics", "format_table",
           "plot_unexplained", "Term", "physics_terms", "named_terms", "TERM_KINDS", "SCIENCE_OUTPUT", "ScienceFit",
           "Candidates", "Evidence", "evidence", "critical_value", "holm", "SymbolicDiscovery", "TermFamily",
           "VariableFamily", "TermContext", "TERM_FAMILIES", "Verdict", "Step", "AddedTerm", "Selection"]
