"""sklearn_hybrid: hybrid models (science + neural network) that estimate physical parameters.

The main entry point is :class:`HybridRegressor`; :func:`make_theta_scorer`
and :func:`theta_error` compare estimated parameters with reference values.
"""

from ._cv import HybridRegressorCV
from ._estimator import HybridRegressor
from .engine import DivergenceError
from .metrics import make_flat_scorer, make_per_sample_theta_scorer, make_theta_scorer, theta_error
from .structures import pack_inputs

__all__ = ["HybridRegressor", "HybridRegressorCV", "DivergenceError", "make_theta_scorer",
           "make_per_sample_theta_scorer", "make_flat_scorer", "theta_error", "pack_inputs"]
__version__ = "0.1.0"
