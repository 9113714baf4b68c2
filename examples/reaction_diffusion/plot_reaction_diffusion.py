"""
====================================================
Reaction-diffusion: two diffusion coefficients
====================================================

FitzHugh-Nagumo fields ``u_t = a lap(u) + u - u^3 - k - v``,
``v_t = b lap(v) + u - v`` on a periodic 32 x 32 grid over ``[-1, 1]^2``
(a = 1e-3, b = 5e-3, k = 5e-3; the paper's *reaction-diffusion* task).  The
science model is diffusion only, :func:`~sklearn_hybrid.models.diffusion_f`;
a CNN with two hidden layers of 16 channels and batch norm (``residual="cnn"``,
circular padding to match the periodic boundary) learns the reactions.

This example trains on 10 fields instead of the paper's 100 so that it runs on
a laptop CPU in minutes.

Full-run results
----------------
A full run takes about 9 minutes for the two methods on a shared 2-core machine,
longer than the documentation build allows, so the build does not run this
example: below are the committed full-run numbers and figures
(run it yourself with ``python examples/reaction_diffusion/plot_reaction_diffusion.py``).

.. include:: /_generated/snippets/task_reaction_diffusion.rst
"""

# The gallery's thumbnail: a figure of this example's committed full run (the documentation build
# does not run it; see doc/conf.py), copied beside the snippets when the build starts.
# sphinx_gallery_thumbnail_path = "_generated/snippets/reaction_diffusion_1.png"

# %%
# Data and fits
# -------------
import os

import matplotlib.pyplot as plt
import numpy as np
import torch

from sklearn_hybrid import HybridRegressor, OdeStructure, theta_error
from sklearn_hybrid.datasets import make_reaction_diffusion
from sklearn_hybrid.models import diffusion_f

torch.set_num_threads(1)
FAST = os.environ.get("SKLEARN_HYBRID_FAST", "0") == "1"  # tiny run for tests and doc builds
if FAST:  # say so on the page: these numbers are not the method's results
    print("FAST MODE (SKLEARN_HYBRID_FAST=1): tiny data and a few iterations; the numbers below "
          "only show that the pipeline runs. Full-run results: benchmarks/results/tasks.md.")
N_TRAIN, GRID, MAX_ITER = (3, 16, 5) if FAST else (10, 32, 300)

data = make_reaction_diffusion(N_TRAIN, N_TRAIN, N_TRAIN, grid_size=GRID, random_state=0)

estimators = {}
for method in ["erm", "fsam"]:
    est = HybridRegressor(science=diffusion_f, residual="cnn", method=method, structure=OdeStructure(dt=data.dt, n_substeps=1), lr=1e-3, max_iter=MAX_ITER, random_state=0)
    estimators[method] = est.fit(data.X_train, data.y_train)

print("true a = %.2e, b = %.2e" % (data.theta_true["a"], data.theta_true["b"]))
for method, est in estimators.items():
    y_error = np.sqrt(np.mean((est.predict(data.X_test) - data.y_test) ** 2))
    print(f"{method:5s} a = {est.theta_['a']:.2e}  b = {est.theta_['b']:.2e}  "
          f"theta error (RMSE over a, b) = {theta_error(est.theta_, data.theta_true):.2e}  "
          f"y error (test RMSE) = {y_error:.4f}")

# %%
# Fields and estimates
# --------------------
# Top: the u field of a test sample at the last output time, as measured and as
# predicted.  Bottom: a and b during training.
fig, axes = plt.subplot_mosaic([["f0", "f0", "f1", "f1", "f2", "f2"],
                                 ["a", "a", "a", "b", "b", "b"]], figsize=(10, 6))
i, last = 0, -1
panels = [("data", data.y_test[i, last, 0])]
panels += [(m, est.predict(data.X_test[i:i + 1])[0, last, 0]) for m, est in estimators.items()]
for k, (title, field) in enumerate(panels):
    ax = axes[f"f{k}"]
    ax.imshow(field, cmap="viridis", extent=(-1, 1, -1, 1))
    ax.set(title=f"u at t = {data.t[last]:.1f}: {title}", xticks=[], yticks=[])
for name in ["a", "b"]:
    ax = axes[name]
    for (method, est), colour in zip(estimators.items(), ["C0", "C1"]):
        ax.plot(est.history_["theta"][name], color=colour, label=method)
    ax.axhline(data.theta_true[name], color="k", ls="--", label=f"true {name}")
    ax.set(xlabel="iteration", ylabel=name, yscale="log")
    ax.legend()
fig.tight_layout()
plt.show()
