"""
======================================================
Light tunnel: colour response of camera and polarisers
======================================================

The Causal Chambers light tunnel (Gamella, Peters and Buehlmann, 2025) shines
red, green and blue LEDs through two linear polarisers onto a camera.  The
task predicts the camera image from the five settings (R, G, B and the two
polariser angles).  The science model is F3 of the Causal Chambers paper,
rendered into the hexagon of the light source
(:func:`~sklearn_hybrid.models.make_light_tunnel_f`): per camera channel the
colour ``min(1, e w * (S x) * ((t_p - t_c) cos^2(a1 - a2) + t_c))`` with nine
unknown parameters w, t_p, t_c.  A small U-Net transforms the science image
into the camera image (:func:`~sklearn_hybrid.models.light_tunnel_unet`).
Only the direction of theta is identifiable, so it is compared with the
published calibration by cosine similarity.

**Data.** The measured images (``lt_camera_v1``, CC BY 4.0) are used when they
are in the data home (see :func:`~sklearn_hybrid.datasets.fetch_light_tunnel`);
otherwise the example falls back to the SIMULATED stand-in
:func:`~sklearn_hybrid.datasets.make_light_tunnel_simulated` and says so.
To run on a laptop CPU the images are reduced to 32 x 32 pixels and 2,000 of
the 10,000 samples are used (the paper: 100 x 100 pixels, 6,000 training
images).

Full-run results
----------------
A full run takes about 5 minutes for the two methods on a shared 2-core machine,
longer than the documentation build allows, so the build does not run this
example: below are the committed full-run numbers and figures
(run it yourself with ``python examples/light_tunnel/plot_light_tunnel.py``).

.. include:: /_generated/snippets/task_light_tunnel.rst
"""

# The gallery's thumbnail: a figure of this example's committed full run (the documentation build
# does not run it; see doc/conf.py), copied beside the snippets when the build starts.
# sphinx_gallery_thumbnail_path = "_generated/snippets/light_tunnel_1.png"

# %%
# Data
# ----
import os
from functools import partial

import matplotlib.pyplot as plt
import numpy as np
import torch
from torch.nn import functional as F

from sklearn_hybrid import HybridRegressor, theta_error
from sklearn_hybrid.datasets import fetch_light_tunnel, make_light_tunnel_simulated
from sklearn_hybrid.models import light_tunnel_unet, make_light_tunnel_f

torch.set_num_threads(1)
FAST = os.environ.get("SKLEARN_HYBRID_FAST", "0") == "1"  # tiny run for tests and doc builds
if FAST:  # say so on the page: these numbers are not the method's results
    print("FAST MODE (SKLEARN_HYBRID_FAST=1): tiny data and a few iterations; the numbers below "
          "only show that the pipeline runs. Full-run results: benchmarks/results/tasks.md.")
N_SAMPLES, SIZE, MAX_ITER, CHANNELS = (60, 16, 5, (4, 8)) if FAST else (2000, 32, 600, (8, 16, 32))

try:
    data = fetch_light_tunnel(download_if_missing=False, n_samples=N_SAMPLES)
    print("Using the MEASURED light-tunnel images (lt_camera_v1).")
    # average-pool the 100-pixel photographs down to the working size
    data.images = F.adaptive_avg_pool2d(torch.as_tensor(data.images), SIZE).numpy()
    for name, part in data.splits.items():
        data[f"images_{name}"] = data.images[part]
except (FileNotFoundError, OSError, ValueError) as exc:
    print(f"Measured data not found ({type(exc).__name__}); using the SIMULATED stand-in.\n"
          "The numbers below describe simulated images, NOT the real light tunnel.")
    data = make_light_tunnel_simulated(n_samples=N_SAMPLES, image_size=SIZE, random_state=0)
print(f"{len(data.X_train)} training and {len(data.X_test)} test images of {SIZE} x {SIZE}")

# %%
# Fits
# ----
# Mini-batches of 50 and learning rate 1e-3, as in the paper.
science = make_light_tunnel_f(SIZE)
estimators = {}
for method in ["erm", "fsam"]:
    est = HybridRegressor(science=science, structure="compose",
                          residual=partial(light_tunnel_unet, channels=CHANNELS), method=method,
                          lr=1e-3, batch_size=50, max_iter=MAX_ITER, random_state=0)
    estimators[method] = est.fit(data.X_train, data.images_train)

reference = data.theta_reference


def cosine_path(est):
    """Cosine similarity of theta with the reference at every iteration."""
    path = np.concatenate([est.history_["theta"][k] for k in reference], axis=1)
    ref = np.concatenate([reference[k] for k in reference])
    return path @ ref / (np.linalg.norm(path, axis=1) * np.linalg.norm(ref))


for method, est in estimators.items():
    y_error = np.sqrt(np.mean((est.predict(data.X_test) - data.images_test) ** 2))
    print(f"{method:5s} cosine similarity to the reference theta = "
          f"{theta_error(est.theta_, reference, metric='cosine'):.4f}  "
          f"y error (test RMSE) = {y_error:.4f}")

# %%
# Images: data, science part, hybrid
# ----------------------------------
# For each method, the science image ``z = f_theta(x)`` and the full prediction.
show = slice(0, 5)
rows = [("data", data.images_test[show])]
for method, est in estimators.items():
    rows += [(f"{method}: z", est.predict_science(data.X_test[show])),
             (f"{method}: y", est.predict(data.X_test[show]))]
fig, axes = plt.subplots(len(rows), 5, figsize=(8, 1.7 * len(rows)))
for r, (label, images) in enumerate(rows):
    for c in range(5):
        axes[r, c].imshow(np.clip(images[c].transpose(1, 2, 0), 0, 1))
        axes[r, c].set(xticks=[], yticks=[])
    axes[r, 0].set_ylabel(label, fontsize=8)
fig.tight_layout()

# %%
# The nine parameters
# -------------------
# Left: theta scaled to unit length, next to the reference.  Right: the cosine
# similarity during training.
fig, (ax0, ax1) = plt.subplots(1, 2, figsize=(11, 3.6))
labels = [f"{k}_{c}" for k in reference for c in "RGB"]
ref = np.concatenate([reference[k] for k in reference])
ax0.bar(np.arange(9) - 0.25, ref / np.linalg.norm(ref), 0.25, color="k", label="reference")
for j, ((method, est), colour) in enumerate(zip(estimators.items(), ["C0", "C1"])):
    theta = np.concatenate([est.theta_[k] for k in reference])
    ax0.bar(np.arange(9) + 0.25 * j, theta / np.linalg.norm(theta), 0.25, color=colour,
            label=method)
    ax1.plot(cosine_path(est), color=colour, label=method)
ax0.set_xticks(np.arange(9), labels, rotation=45, fontsize=8)
ax0.set(title="theta / |theta|")
ax0.legend(fontsize=8)
ax1.set(xlabel="iteration", ylabel="cosine similarity", title="theta vs reference")
ax1.legend()
fig.tight_layout()
plt.show()
