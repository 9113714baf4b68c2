"""
==========================================================================
Quick start: fit the pendulum, close the loop, plot, is omega identified?
==========================================================================

The README's Quick start at full size, with its two plots: the fit against
the data (:func:`~sklearn_hybrid.plot_fit`) and the profile of omega
(:func:`~sklearn_hybrid.identifiability.plot_profile`).  The data come from a
damped pendulum (true omega = 2/3); the science model ``pendulum_f`` is the
undamped one, so the network has the damping to learn.  About 20 s for the
fit, a few more for the loop, and about as much as the fit for the profile
on one core.
"""

# %%
# Fit with the defaults
# ---------------------
# The same code as ``python -m sklearn_hybrid.demo``: the default method is
# Fisher SAM (``method="fsam"``), which keeps the network from absorbing what
# the science model should explain; the fit stops once loss and theta settle.
import os

import matplotlib.pyplot as plt
import numpy as np
import torch

from sklearn_hybrid import HybridRegressor, OdeStructure, plot_fit
from sklearn_hybrid.datasets import make_pendulum
from sklearn_hybrid.diagnosis import close_the_loop
from sklearn_hybrid.identifiability import profile_theta

FAST = os.environ.get("SKLEARN_HYBRID_FAST", "0") == "1"  # tiny run for tests
if FAST:  # say so on the page: these numbers are not the method's results
    print("FAST MODE (SKLEARN_HYBRID_FAST=1): a few iterations; the numbers below only "
          "show that the pipeline runs. The full run is the README's Quick start.")


def pendulum_f(v, omega=0.5):  # keyword defaults are the unknown parameters theta
    dv_dt = -(2 * torch.pi * omega) ** 2 * torch.sin(v[:, 0])  # no damping
    return torch.stack([v[:, 1], dv_dt], dim=-1)


data = make_pendulum(random_state=0)
X, y = data.X_train, data.y_train
settings = {"max_iter": 20} if FAST else {}  # the defaults, as in the Quick start
est = HybridRegressor(science=pendulum_f, structure=OdeStructure(dt=0.2), random_state=0, **settings).fit(X, y)
print(est.fit_report())  # ends with the first screen: what the network's share implies

# %%
# Close the loop on the same fit
# ------------------------------
# The screen says the network makes a third of the prediction: the science
# model leaves something out.  ``close_the_loop`` names it from what the
# network learned and refits omega without the network.
result = close_the_loop(est, X, y, state_names=["v", "v_dot"])
print(result.report.splitlines()[-2])
print(result.intervals)

# %%
# The fit against the data
# ------------------------
# Three test trajectories (points), the hybrid's prediction (lines) and the
# science part alone with the fitted omega (dashes): the shaded band between
# them is what the network adds, here the damping.  Above, the residuals.
names = ["angle (rad)", "angular velocity (rad/s)"]
fig = plot_fit(est, data.X_test, data.y_test, names=names)
plt.show()

# %%
# Is the hybrid's own omega identified?
# -------------------------------------
# The profile holds omega at values around the fit and re-trains the network
# (and any other parameter) at each; where the data fit significantly worse
# (the horizontal threshold, an F-test) bounds the interval.  The report gives
# the verdict and that interval.
tiny = {"max_iter": 5, "n_points": 3, "refine": False} if FAST else {}  # defaults in full
profile = profile_theta(est, X, y, **tiny)
print(est.fit_report(profile=profile))
print("true omega:", round(data.theta_true["omega"], 4))
rmse = np.sqrt(((est.predict(data.X_test) - data.y_test) ** 2).mean())
print("test RMSE:", round(float(rmse), 4))
axes = profile.plot()
axes[0].figure.tight_layout()  # room for the axis labels
plt.show()
