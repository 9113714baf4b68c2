"""
==========================================================
A level gauge with a shifted zero: an offset, not a term
==========================================================

A tank drains through an orifice at its bottom (Torricelli: ``h' = -a sqrt(h)``),
and the gauge that measures its level reads 0.3 m high. The data are the
readings ``z = h + 0.3``. Written in the readings, the true law is
``z' = -a sqrt(z - 0.3)``: no term added to ``-a sqrt(z)`` equals it for every
level, and a hybrid's network would learn the difference as a force.

Declaring the gauge as possibly offset, ``close_the_loop(..., offsets=["h"])``,
makes the offset one more candidate, judged like every term by how much better
the network-free science model predicts held-out trajectories. Accepted, the
science model reads ``h - offset_h`` wherever it uses the level, and the offset
is fitted with the other parameters. Declare only sensors you suspect: an
offset that is not there is screened and left out, but each declared one costs
one refit per step.

Set ``SKLEARN_HYBRID_FAST=1`` for a run of seconds.
"""

# %%
import os

import matplotlib.pyplot as plt
import numpy as np
import torch
from scipy.integrate import solve_ivp

from sklearn_hybrid import HybridRegressor, OdeStructure
from sklearn_hybrid.diagnosis import close_the_loop, free_run

torch.set_num_threads(1)
FAST = os.environ.get("SKLEARN_HYBRID_FAST", "0") == "1"
if FAST:
    print("FAST MODE (SKLEARN_HYBRID_FAST=1): fewer training iterations.")


def tank_f(v, a=1.0):
    """Torricelli outflow; the level is never negative (the guard keeps sqrt defined)."""
    return -a * torch.sqrt(torch.clamp(v, min=1e-6))


# %%
# Readings of a gauge that reads 0.3 m high
# -----------------------------------------
# 40 draining trajectories from levels between 0.5 and 3 m, read every 0.25 s
# (12 readings each) with 1 cm of noise; the true outflow coefficient is 0.6.
rng = np.random.default_rng(0)
n, dt, n_steps, offset = 40, 0.25, 12, 0.3
t = dt * np.arange(n_steps + 1)
levels = np.stack([solve_ivp(lambda _, h: -0.6 * np.sqrt(np.clip(h, 0, None)), (0, t[-1]), [h0], t_eval=t,
                             rtol=1e-8).y.T for h0 in rng.uniform(0.5, 3.0, n)])
readings = levels + offset + 0.01 * rng.standard_normal(levels.shape)
X, y = readings[:, 0], readings[:, 1:]

# %%
# Close the loop with the gauge declared
# --------------------------------------
est = HybridRegressor(science=tank_f, structure=OdeStructure(dt=dt), method="erm", max_iter=20 if FAST else 200, random_state=0)
out = close_the_loop(est, X, y, state_names=["h"], units={"h": "m"}, offsets=["h"])
print(out.report)
print({k: round(v, 3) for k, v in out.science_theta.items()})

# %%
# Free runs of one trajectory: the first hybrid's science part, and the science
# model the loop kept (with its fitted offset, and no network)
z0 = readings[0, :1]
before = free_run(out.before, z0, n_steps=n_steps, use_residual=False)[0, :, 0]
kept = free_run(out.science_only, z0, n_steps=n_steps, use_residual=False)[0, :, 0]
fig, ax = plt.subplots(figsize=(6, 3.5))
ax.plot(t, readings[0, :, 0], "k.", label="gauge readings")
ax.plot(t, levels[0, :, 0] + offset, "k-", lw=0.8, label="true level + 0.3 m")
ax.plot(t, before, "--", label="first hybrid's science part")
ax.plot(t, kept, "-", label="science model kept (offset fitted)")
ax.set(xlabel="time (s)", ylabel="reading (m)")
ax.legend()
fig.tight_layout()
plt.show()
