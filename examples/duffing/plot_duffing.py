"""
====================================================
Duffing oscillator: the linear stiffness
====================================================

The data come from the softening Duffing oscillator ``v'' + alpha v - beta v^3 = 0``
with alpha = beta = 1 (the paper's *Duffing oscillator* task).  The science
model is the linear oscillator :func:`~sklearn_hybrid.models.duffing_f` with
unknown alpha; an MLP (two hidden layers of 128) learns the cubic term inside
the hybrid neural ODE.

The cubic force can be partly imitated by a linear one, so here plain
training (``erm``) leaves alpha far from 1 while the network explains the
motion; ``fsam`` moves alpha towards the truth.

Full-run results
----------------
A full run takes about 4 minutes for the two methods on a shared 2-core machine,
longer than the documentation build allows, so the build does not run this
example: below are the committed full-run numbers and figures
(run it yourself with ``python examples/duffing/plot_duffing.py``).

.. include:: /_generated/snippets/task_duffing.rst
"""

# The gallery's thumbnail: a figure of this example's committed full run (the documentation build
# does not run it; see doc/conf.py), copied beside the snippets when the build starts.
# sphinx_gallery_thumbnail_path = "_generated/snippets/duffing_1.png"

# %%
# Data and fits
# -------------
import os

import matplotlib.pyplot as plt
import numpy as np
import torch

from sklearn_hybrid import HybridRegressor, OdeStructure, theta_error
from sklearn_hybrid.datasets import make_duffing
from sklearn_hybrid.models import duffing_f

torch.set_num_threads(1)
FAST = os.environ.get("SKLEARN_HYBRID_FAST", "0") == "1"  # tiny run for tests and doc builds
if FAST:  # say so on the page: these numbers are not the method's results
    print("FAST MODE (SKLEARN_HYBRID_FAST=1): tiny data and a few iterations; the numbers below "
          "only show that the pipeline runs. Full-run results: benchmarks/results/tasks.md.")
N_TRAIN, MAX_ITER = (10, 10) if FAST else (100, 1500)

data = make_duffing(N_TRAIN, N_TRAIN, N_TRAIN, random_state=0)

estimators = {}
for method in ["erm", "fsam"]:
    est = HybridRegressor(science=duffing_f, method=method, structure=OdeStructure(dt=data.dt, n_substeps=1),
                          lr=3e-3, max_iter=MAX_ITER, residual={"hidden": (128, 128), "zero_init": False},
                          random_state=0)
    estimators[method] = est.fit(data.X_train, data.y_train)

print("true alpha = %.4f" % data.theta_true["alpha"])
for method, est in estimators.items():
    y_error = np.sqrt(np.mean((est.predict(data.X_test) - data.y_test) ** 2))
    best = np.min(np.abs(est.history_["theta"]["alpha"] - data.theta_true["alpha"]))
    print(f"{method:5s} alpha = {est.theta_['alpha']:.4f}  "
          f"theta error = {theta_error(est.theta_, data.theta_true):.4f} "
          f"(best along training {best:.4f})  y error (test RMSE) = {y_error:.4f}")

# %%
# What the network learned
# ------------------------
# The missing force is ``+beta v^3``.  The network's contribution to the
# acceleration along the predicted trajectories
# (:meth:`~sklearn_hybrid.HybridRegressor.residual_trace`) should follow it,
# shifted by the error in alpha that it compensates, ``(alpha_hat - 1) v``.
fig, (ax0, ax1) = plt.subplots(1, 2, figsize=(10, 3.8))
v = np.linspace(-0.9, 0.9, 100)
ax0.plot(v, v**3, "k--", label="missing force v^3")
for (method, est), colour in zip(estimators.items(), ["C0", "C1"]):
    trace = est.residual_trace(data.X_test)
    points, g = trace["points"].reshape(-1, 2), trace["residual"].reshape(-1, 2)
    ax0.plot(points[:, 0], g[:, 1], ".", ms=2, color=colour, label=f"{method} network")
    ax1.plot(est.history_["theta"]["alpha"], color=colour, label=method)
ax0.set(xlabel="position v", ylabel="network part of v''", title="learned residual force")
ax0.legend(fontsize=8, markerscale=4)
ax1.axhline(data.theta_true["alpha"], color="k", ls="--", label="true alpha")
ax1.set(xlabel="iteration", ylabel="alpha", title="alpha during training")
ax1.legend()
fig.tight_layout()
plt.show()
