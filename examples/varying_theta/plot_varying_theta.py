"""
===============================================================
Varying parameters: an encoder infers each pendulum's frequency
===============================================================

Real data rarely share one theta: every pendulum of this data set has its own
frequency ``omega ~ U(0.1, 1.0)`` (the paper's appendix "Learning with Varying
Scientific Parameters").  The input of each sample is a window of the last 10
states; an encoder network (``theta_encoder="mlp"``: two hidden layers of 256
units over the flattened window) reads it and outputs that sample's omega,
trained jointly with the hybrid neural ODE ``dv/dt = f_omega(v) + g_phi(v)``.
The last state of each window is the initial state of the ODE.

``predict_theta(X)`` gives each sample's omega; ``theta_`` keeps their mean
over the training samples.  The SAM family perturbs the residual network
only (the encoder is part of theta); ``perturb="all"`` perturbs the encoder
too.

Full-run results
----------------
A full run takes several minutes per method and seed on a 2-core machine,
longer than the documentation build allows, so the build does not run this
example: below are the committed full-run numbers
(run it yourself with ``python examples/varying_theta/plot_varying_theta.py``).

.. include:: /_generated/snippets/varying_theta.rst
"""

# The gallery's thumbnail: a figure of this example's committed full run (the documentation build
# does not run it; see doc/conf.py), copied beside the snippets when the build starts.
# sphinx_gallery_thumbnail_path = "_generated/snippets/varying_theta.png"

# %%
# Data
# ----
# 25 samples per split; X has shape (n, 10, 2): ten states ``[angle,
# velocity]`` before time 0; y the next 10 states.  ``data.theta_train`` holds
# each sample's true omega.
import os

import matplotlib.pyplot as plt
import numpy as np
import torch

from sklearn_hybrid import HybridRegressor, OdeStructure, theta_error
from sklearn_hybrid.datasets import make_pendulum
from sklearn_hybrid.models import pendulum_f

torch.set_num_threads(1)
FAST = os.environ.get("SKLEARN_HYBRID_FAST", "0") == "1"  # tiny run for tests and doc builds
if FAST:  # say so on the page: these numbers are not the method's results
    print("FAST MODE (SKLEARN_HYBRID_FAST=1): tiny data and a few iterations; the numbers below "
          "only show that the pipeline runs. Full-run results: benchmarks/results/varying_theta.md.")
N_TRAIN, MAX_ITER = (8, 10) if FAST else (25, 1500)

data = make_pendulum(N_TRAIN, N_TRAIN, N_TRAIN, omega=(0.1, 1.0), n_input_steps=10, random_state=0)
print(data.DESCR)

# %%
# Fit with erm and fsam
# ---------------------
# ``theta_bounds`` keeps every sample's omega inside (0, 2) through a smooth
# reparametrisation of the encoder's output.
estimators = {}
for method in ["erm", "fsam"]:
    est = HybridRegressor(science=pendulum_f, theta_encoder="mlp", theta_bounds={"omega": (0.0, 2.0)},
                          method=method, structure=OdeStructure(dt=data.dt, n_substeps=2), lr=3e-3, max_iter=MAX_ITER,
                          random_state=0)
    estimators[method] = est.fit(data.X_train, data.y_train)

for method, est in estimators.items():
    omega = est.predict_theta(data.X_test)["omega"]
    y_error = np.sqrt(np.mean((est.predict(data.X_test) - data.y_test) ** 2))
    print(f"{method:5s} per-sample theta error (test RMSE) = "
          f"{theta_error({'omega': omega}, data.theta_test):.4f}  "
          f"mean omega = {est.theta_['omega']:.3f}  y error (test RMSE) = {y_error:.4f}")

# %%
# Inferred against true omega
# ---------------------------
# The paper's figure: each test sample's inferred omega against the value that
# generated it; on the diagonal the encoder is exact.
fig, axes = plt.subplots(1, 2, figsize=(8, 3.8), sharey=True)
for ax, (method, est) in zip(axes, estimators.items()):
    omega = est.predict_theta(data.X_test)["omega"]
    ax.scatter(data.theta_test["omega"], omega, s=15)
    ax.plot([0.1, 1.0], [0.1, 1.0], "k--", lw=0.8)
    ax.set(xlabel="true omega", title=f"{method}: RMSE {theta_error({'omega': omega}, data.theta_test):.3f}")
axes[0].set_ylabel("inferred omega")
fig.tight_layout()
plt.show()
