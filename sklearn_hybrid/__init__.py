"""sklearn_hybrid: hybrid models (science + neural network) that estimate physical parameters.

The main entry point is :class:`HybridRegressor`; :func:`make_theta_scorer`
and :func:`theta_error` compare estimated parameters with reference values.

The public names are imported on first use (PEP 562), so that importing the
package, and the command line's ``--help`` and ``--version``, do not pay for
importing torch.
"""

import importlib

__version__ = "0.1.0"

_LAZY = {"HybridRegressor": "._estimator", "HybridRegressorCV": "._cv",
         "DivergenceError": ".training", "make_theta_scorer": ".metrics",
         "make_per_sample_theta_scorer": ".metrics", "make_flat_scorer": ".metrics",
         "theta_error": ".metrics", "network_share": ".metrics", "rate_share": ".metrics", "pack_inputs": ".structures", "OdeStructure": ".structures",
         "plot_fit": ".plotting"}

__all__ = ["HybridRegressor", "HybridRegressorCV", "DivergenceError", "make_theta_scorer",
           "make_per_sample_theta_scorer", "make_flat_scorer", "theta_error", "network_share", "rate_share", "pack_inputs", "OdeStructure",
           "plot_fit"]


def __getattr__(name):
    if name in _LAZY:
        value = getattr(importlib.import_module(_LAZY[name], __name__), name)
        globals()[name] = value  # later look-ups skip this function
        return value
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def __dir__():
    return sorted(list(globals()) + __all__)
