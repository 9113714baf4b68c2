"""
==================================================================
Silverbox: the network finds the cubic spring the model left out
==================================================================

The Silverbox is an electronic circuit that behaves as a mass-spring-damper
with a hardening (cubic) spring. We give the hybrid model only the linear
science model, ``y'' = b (u - u0) - k y - c y'`` (an input offset ``u0``
included), and an MLP acting on the acceleration. Then
:func:`~sklearn_hybrid.diagnosis.close_the_loop`

1. evaluates the network's contribution at the states it visits,
2. explains it by sparse regression over polynomials of ``y``, ``y_dot`` and
   ``u`` (plus the science parameters' own sensitivities ``df/dk``, ... which
   say "this much of the residual is a parameter correction"),
3. adds the terms it found as new named parameters, refits, and
4. scores both models by free-run simulations of the standard test records
   (the "arrow" and a multisine), RMSE in mV.

Units: y and u in 0.1 V, time in samples (so every parameter is of order one).
Set ``SKLEARN_HYBRID_FAST=1`` for a run of seconds (too short to find anything;
it only checks the pipeline). The full run takes several minutes on 2 cores.
"""

# %%
import os

import matplotlib.pyplot as plt
import torch

from sklearn_hybrid.diagnosis.cases import run_case

torch.set_num_threads(1)
FAST = os.environ.get("SKLEARN_HYBRID_FAST", "0") == "1"

out = run_case("silverbox", fast=FAST)
print(out.case.description)

# %%
# What the network learned, in named terms
# ----------------------------------------
# ``y^3`` is a new term; ``df/dk`` and ``df/du0`` are corrections of the
# linear stiffness and of the input offset that the network had absorbed.
print(out.diagnosis.summary())
if out.diagnosis.terms_:
    out.diagnosis.plot()
    plt.tight_layout()

# %%
# Before and after
# ----------------
# RMSE (mV) of the hybrid model and of its science part alone on free runs of
# the test records, the share of the prediction the network carries, and the
# parameters. The classical grey-box fit of the same linear + cubic model by
# simulation-error minimisation reaches about 0.35 mV (multisine) and 0.45 mV
# (full arrow); see ``benchmarks/bench_greybox.py``.
print(out.report)
plt.show()
