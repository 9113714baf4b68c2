"""
====================================================
Pendulum: the frequency of a damped pendulum
====================================================

The data come from a damped pendulum ``v'' + gamma v' + (2 pi omega)^2 sin v = 0``
with gamma = 0.5 and omega = 2/3 (the paper's *pendulum time-series* task).
The scientist knows only the undamped part, :func:`~sklearn_hybrid.models.pendulum_f`,
and wants omega.  A hybrid neural ODE ``dv/dt = f_omega(v) + g_phi(v)`` lets an
MLP with two hidden layers of 64 units (``residual="mlp"``, its last layer
starting at zero) learn the damping.

Plain training (``erm``) lets the network absorb part of the physics, which
biases omega; Fisher sharpness-aware minimisation (``fsam``) keeps the
network flat and leaves more of the explanation to the science model.
"""

# %%
# Data
# ----
# 25 trajectories for training, validation and test each; the input is the
# initial state, the output the next 10 states (dt = 0.2).
import os

import matplotlib.pyplot as plt
import numpy as np
import torch

from sklearn_hybrid import HybridRegressor, OdeStructure, theta_error
from sklearn_hybrid.datasets import make_pendulum
from sklearn_hybrid.models import pendulum_f

torch.set_num_threads(1)
FAST = os.environ.get("SKLEARN_HYBRID_FAST", "0") == "1"  # tiny run for tests
if FAST:  # say so on the page: these numbers are not the method's results
    print("FAST MODE (SKLEARN_HYBRID_FAST=1): tiny data and a few iterations; the numbers below "
          "only show that the pipeline runs. Full-run results: the documentation's gallery page.")
N_TRAIN = 8 if FAST else 25

data = make_pendulum(N_TRAIN, N_TRAIN, N_TRAIN, random_state=0)
print(data.DESCR)

# %%
# Fit with erm and fsam
# ---------------------
# The Quick start's settings: the defaults (at most 1,000 iterations, stopped
# once loss and theta settle), only the method differs.  The fsam fit is the
# Quick start's fit, with the same omega.  (``benchmarks/paper/bench_tasks.py`` runs
# the paper's protocol instead: 2,000 iterations at lr 3e-3, no early stop.)
estimators = {}
for method in ["erm", "fsam"]:
    est = HybridRegressor(science=pendulum_f, method=method, structure=OdeStructure(dt=data.dt), random_state=0,
                          **({"max_iter": 10} if FAST else {}))
    estimators[method] = est.fit(data.X_train, data.y_train)

print("true omega = %.4f" % data.theta_true["omega"])
for method, est in estimators.items():
    y_error = np.sqrt(np.mean((est.predict(data.X_test) - data.y_test) ** 2))
    path = est.history_["theta"]["omega"]
    best = np.min(np.abs(path - data.theta_true["omega"]))  # the paper's oracle selection
    print(f"{method:5s} omega = {est.theta_['omega']:.4f}  "
          f"theta error = {theta_error(est.theta_, data.theta_true):.4f} "
          f"(best along training {best:.4f})  y error (test RMSE) = {y_error:.4f}  "
          f"iterations = {est.n_iter_}")

# %%
# Trajectories and the estimate during training
# ---------------------------------------------
# Left: a test trajectory, the hybrid predictions and what the science model
# alone predicts with each estimated omega.  Right: omega over the iterations.
fig, (ax0, ax1) = plt.subplots(1, 2, figsize=(10, 3.8))
i = 0
t = np.concatenate([[0.0], data.t])
truth = np.concatenate([data.X_test[i:i + 1], data.y_test[i]])
ax0.plot(t, truth[:, 0], "ko", label="data (angle)")
for (method, est), colour in zip(estimators.items(), ["C0", "C1"]):
    hybrid = np.concatenate([data.X_test[i:i + 1], est.predict(data.X_test[i:i + 1])[0]])
    science = np.concatenate([data.X_test[i:i + 1], est.predict_science(data.X_test[i:i + 1])[0]])
    ax0.plot(t, hybrid[:, 0], "-", color=colour, label=f"{method} hybrid")
    ax0.plot(t, science[:, 0], ":", color=colour, label=f"{method} science only")
    ax1.plot(est.history_["theta"]["omega"], color=colour, label=method)
ax0.set(xlabel="time", ylabel="angle (rad)", title="test trajectory")
ax0.legend(fontsize=8)
ax1.axhline(data.theta_true["omega"], color="k", ls="--", label="true omega")
ax1.set(xlabel="iteration", ylabel="omega", title="omega during training")
ax1.legend()
fig.tight_layout()
plt.show()

# %%
# Tuning fsam's strength with scikit-learn
# ----------------------------------------
# The method is an object with its settings, so a grid search reaches them as
# ``method__rho`` (as ``kernel__length_scale`` for a Gaussian process).  Here
# the truth is known (a simulation), so the scorer is theta's error:
# :func:`~sklearn_hybrid.make_theta_scorer`.  On measured data the truth is
# not known: choose by a sweep's test error and the profile instead
# (:doc:`/user_guide/methods`).
from sklearn.model_selection import GridSearchCV

from sklearn_hybrid import make_theta_scorer
from sklearn_hybrid.methods import FisherSAM

search = GridSearchCV(
    HybridRegressor(science=pendulum_f, method=FisherSAM(), structure=OdeStructure(dt=data.dt), random_state=0,
                    max_iter=10 if FAST else 300),
    {"method__rho": [0.01, 0.05, 0.2]}, scoring=make_theta_scorer(data.theta_true), cv=2)
search.fit(data.X_train, data.y_train)
for rho, score in zip(search.cv_results_["param_method__rho"], search.cv_results_["mean_test_score"]):
    print(f"rho = {rho:<5} mean theta error over the folds = {-score:.4f}")
print("chosen:", search.best_params_, " omega refitted on all data =",
      round(search.best_estimator_.theta_["omega"], 4))
