"""
====================================================
Pendulum images: physics inside an autoencoder
====================================================

The damped pendulum of the pendulum example, seen only through 48 x 48 grey
images (the paper's *pendulum images* task): from 10 frames, predict the
next 10.  The model nests a hybrid neural ODE between image encoders and a
decoder, a composition that none of the built-in structures covers, so it is
written as a callable structure ``structure(x, f, g) -> y``
(:class:`~sklearn_hybrid.models.PendulumImagesStructure`): one encoder gives
the initial [angle, velocity], a second one an appearance code, the ODE
``dv/dt = f_omega(v) + g_ode(v)`` (with
:func:`~sklearn_hybrid.models.pendulum_f`) runs forward, and the decoder
draws one image per predicted angle.  All networks live in one module
(:class:`~sklearn_hybrid.models.PendulumImagesNet`), built by the factory
passed as ``residual``.

The paper's decoder (hidden layers of 1152 units and 576 / 288 channels), its
48-pixel images and 20,000 iterations are out of reach of a laptop CPU; this
example uses 32-pixel images, a much smaller decoder and 250 iterations (about
ten minutes), so expect a rough fit.

Full-run results
----------------
A full run takes about 6 minutes for the two methods on a shared 2-core machine,
longer than the documentation build allows, so the build does not run this
example: below are the committed full-run numbers and figures
(run it yourself with ``python examples/pendulum_images/plot_pendulum_images.py``).

.. include:: /_generated/snippets/task_pendulum_images.rst
"""

# The gallery's thumbnail: a figure of this example's committed full run (the documentation build
# does not run it; see doc/conf.py), copied beside the snippets when the build starts.
# sphinx_gallery_thumbnail_path = "_generated/snippets/pendulum_images_1.png"

# %%
# Data and model
# --------------
import os
from functools import partial

import matplotlib.pyplot as plt
import numpy as np
import torch

from sklearn_hybrid import HybridRegressor, theta_error
from sklearn_hybrid.datasets import make_pendulum_images
from sklearn_hybrid.models import (PendulumImagesNet, PendulumImagesStructure,
                                   latent_trajectories, pendulum_f)

torch.set_num_threads(1)
FAST = os.environ.get("SKLEARN_HYBRID_FAST", "0") == "1"  # tiny run for tests and doc builds
if FAST:  # say so on the page: these numbers are not the method's results
    print("FAST MODE (SKLEARN_HYBRID_FAST=1): tiny data and a few iterations; the numbers below "
          "only show that the pipeline runs. Full-run results: benchmarks/results/tasks.md.")
if FAST:
    N_TRAIN, SIZE, M_X, MAX_ITER = 8, 16, 4, 3
    sizes = dict(latent_dim=2, encoder_channels=(4, 8), encoder_hidden=16, ode_hidden=(16, 16),
                 fc_hidden=(16,), conv_channels=(4,))
else:
    N_TRAIN, SIZE, M_X, MAX_ITER = 200, 32, 10, 250
    sizes = dict(latent_dim=4, encoder_channels=(16, 32, 32), encoder_hidden=128,
                 fc_hidden=(256, 256), conv_channels=(16, 8))

data = make_pendulum_images(N_TRAIN, N_TRAIN // 4, N_TRAIN // 4, n_input_steps=M_X,
                            image_size=SIZE, random_state=0)
network = partial(PendulumImagesNet, n_input_frames=M_X, image_size=SIZE, **sizes)
structure = PendulumImagesStructure(dt=data.dt, n_steps=data.y_train.shape[1], n_substeps=2)

# %%
# Fits
# ----
# Mini-batches of 50 and learning rate 1e-3, as in the paper.
estimators = {}
for method in ["erm", "fsam"]:
    est = HybridRegressor(science=pendulum_f, structure=structure, residual=network,
                          method=method, lr=1e-3, batch_size=50, max_iter=MAX_ITER,
                          random_state=0)
    estimators[method] = est.fit(data.X_train, data.y_train)

print("true omega = %.4f" % data.theta_true["omega"])
for method, est in estimators.items():
    y_error = np.sqrt(np.mean((est.predict(data.X_test) - data.y_test) ** 2))
    print(f"{method:5s} omega = {est.theta_['omega']:.4f}  "
          f"theta error = {theta_error(est.theta_, data.theta_true):.4f}  "
          f"y error (test RMSE per pixel) = {y_error:.4f}")

# %%
# Predicted frames
# ----------------
# A test sequence: the true future frames and each model's prediction.
i, frames = 0, range(0, data.y_test.shape[1], 2)
rows = [("data", data.y_test[i])]
rows += [(m, est.predict(data.X_test[i:i + 1])[0]) for m, est in estimators.items()]
fig, axes = plt.subplots(len(rows), len(frames), figsize=(1.6 * len(frames), 1.8 * len(rows)))
for r, (label, images) in enumerate(rows):
    for c, k in enumerate(frames):
        axes[r, c].imshow(images[k], cmap="gray", vmin=0, vmax=1)
        axes[r, c].set(xticks=[], yticks=[], title=f"t = {data.t[k]:.1f}" if r == 0 else "")
    axes[r, 0].set_ylabel(label)
fig.tight_layout()

# %%
# Latent angles and omega
# -----------------------
# Left: the angles inside the fsam model against the true angles (the encoder
# may choose any sign or offset; the frequency is what omega fixes).  Right:
# omega during training.
fig, (ax0, ax1) = plt.subplots(1, 2, figsize=(10, 3.8))
latent = latent_trajectories(estimators["fsam"], data.X_test[:3])
for j in range(len(latent)):
    ax0.plot(data.t, data.angles_y_test[j], "o", color=f"C{j}", ms=4)
    ax0.plot(data.t, latent[j, :, 0], "-", color=f"C{j}")
ax0.set(xlabel="time", ylabel="angle", title="true (dots) and latent (lines) angles, fsam")
for (method, est), colour in zip(estimators.items(), ["C0", "C1"]):
    ax1.plot(est.history_["theta"]["omega"], color=colour, label=method)
ax1.axhline(data.theta_true["omega"], color="k", ls="--", label="true omega")
ax1.set(xlabel="iteration", ylabel="omega", title="omega during training")
ax1.legend()
fig.tight_layout()
plt.show()
