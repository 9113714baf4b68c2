"""Integrating a hybrid ODE on the output grid.

:func:`integrate` (``solve.py``) is the one entry: fixed-step RK4 on the output grid or
torchdiffeq's solvers, with measured inputs reconstructed between samples
(:func:`upsample_inputs`). ``fast.py`` is the same RK4 for an MLP over a small state with a
hand-written backward pass, and ``kernels.py`` its loops for one member or K stacked members;
the structures choose it where it applies, and users never call it.
"""

from .solve import INPUT_INTERPOLATIONS, integrate, upsample_inputs

__all__ = ["integrate", "upsample_inputs", "INPUT_INTERPOLATIONS"]
