"""The exploratory reading: a fitted model's residual explained by sparse regression on a library.

``library.py`` holds :class:`CandidateLibrary` (its columns are the closed loop's own
:class:`~sklearn_hybrid.diagnosis.Term` objects), ``regression.py`` :class:`SparseTermRegression`
(bootstrapped sparse fits with inclusion frequencies), ``residual_diagnosis.py``
:class:`ResidualDiagnosis`, which reads a fitted hybrid's residual this way and holds every new term
to the closed loop's held-out test.
"""

from .library import CandidateLibrary, numpy_term
from .regression import SparseTermRegression
from .residual_diagnosis import ResidualDiagnosis

__all__ = ["CandidateLibrary", "SparseTermRegression", "ResidualDiagnosis", "numpy_term"]
