"""The paper's six tasks: data, science model, network and optimisation, as its benchmarks run them.

:data:`TASKS` (``table1.py``, ``bench_theta_convergence.py``): each task at three budgets, ``"paper"`` (the
paper's sizes), ``"cpu"`` and ``"smoke"``, as a Bunch of ``data``, the estimator's keyword arguments ``kw``,
the reference ``theta`` and the data's ``source``.

:data:`CPU_TASKS` (``bench_tasks.py``): each task once, at a size a 2-core CPU runs in about 20 minutes, as
``(X_train, y_train, X_test, y_test, theta reference, kw, source)``. Written before Table 1's ``"cpu"``
budget, which is close to them but not the same (it gives some tasks theta's own ``lr_theta``); kept as
they ran, since ``results/tasks.md`` quotes them.

The wind and light tunnel use the measured Causal Chamber data when they are in the data home and the
SIMULATED stand-ins otherwise (``source`` says which).
"""

from __future__ import annotations

from functools import partial

import torch
from sklearn.utils import Bunch

from sklearn_hybrid import OdeStructure
from sklearn_hybrid import datasets as ds
from sklearn_hybrid import models


# The network of the paper protocol's ODE tasks and of its committed results (the package's default
# "mlp" until the defaults became two layers of 64 started at zero)
PAPER_MLP = {"hidden": (128, 128), "zero_init": False}


# --- Table 1: every task at three budgets --------------------------------------------------------------

def _size(budget, paper, cpu, smoke):
    return {"paper": paper, "cpu": cpu, "smoke": smoke}[budget]


def _pendulum(budget):
    n = _size(budget, 25, 25, 8)
    d = ds.make_pendulum(n, n, n, random_state=0)
    kw = dict(science=models.pendulum_f, structure=OdeStructure(dt=d.dt, n_substeps=2), residual=PAPER_MLP,
              lr=_size(budget, 1e-4, 3e-3, 3e-3), max_iter=_size(budget, 20000, 2000, 30))
    return Bunch(data=d, kw=kw, theta=d.theta_true, source="synthetic")


def _duffing(budget):
    n = _size(budget, 100, 100, 10)
    d = ds.make_duffing(n, n, n, random_state=0)
    kw = dict(science=models.duffing_f, structure=OdeStructure(dt=d.dt, n_substeps=1), residual=PAPER_MLP,
              lr=_size(budget, 1e-4, 3e-3, 3e-3), max_iter=_size(budget, 20000, 1500, 30))
    return Bunch(data=d, kw=kw, theta=d.theta_true, source="synthetic")


def _reaction_diffusion(budget):
    n = _size(budget, 100, 10, 3)
    d = ds.make_reaction_diffusion(n, n, n, grid_size=_size(budget, 32, 32, 8), random_state=0)
    kw = dict(science=models.diffusion_f, residual="cnn", structure=OdeStructure(dt=d.dt, n_substeps=1),
              lr=_size(budget, 1e-4, 1e-3, 1e-3), max_iter=_size(budget, 20000, 300, 30))
    return Bunch(data=d, kw=kw, theta=d.theta_true, source="synthetic")


def _pendulum_images(budget):
    size = _size(budget, 48, 32, 16)
    n = _size(budget, 200, 200, 8)
    d = ds.make_pendulum_images(n, n if budget == "paper" else 50, n if budget == "paper" else 50,
                                image_size=size, random_state=0)
    small = dict(latent_dim=4, encoder_channels=(16, 32, 32), encoder_hidden=128,
                 fc_hidden=(256, 256), conv_channels=(16, 8))
    net = partial(models.PendulumImagesNet, n_input_frames=10, image_size=size,
                  **({} if budget == "paper" else small))
    kw = dict(science=models.pendulum_f, structure=models.PendulumImagesStructure(dt=d.dt),
              residual=net, lr=1e-3, batch_size=50, max_iter=_size(budget, 20000, 250, 10))
    if budget == "cpu":  # with lr 1e-3, omega could move 1e-3 * 250 / 2 = 0.125 at most, less than
        kw["lr_theta"] = 1e-2  # 0.5 -> 2/3; the README's rule: lr_theta * max_iter / 2 >= theta's range (~1)
    return Bunch(data=d, kw=kw, theta=d.theta_true, source="synthetic")


def wind_tunnel_spec(budget):
    try:
        raw, source = ds.fetch_wind_tunnel(download_if_missing=False), "MEASURED"
    except (FileNotFoundError, OSError):
        raw, source = ds.make_wind_tunnel_simulated(random_state=0), "SIMULATED stand-in"
    gauge = raw.y - raw.pressure_ambient  # pressure above ambient, as the model predicts it
    d = Bunch(**{f"{a}_{s}": (raw.X if a == "X" else gauge)[raw.splits[s]]
                 for a in ("X", "y") for s in ("train", "val", "test")})
    if budget == "smoke":
        d = Bunch(**{k: v[:20] for k, v in d.items()})
    kw = dict(science=models.wind_tunnel_f, structure="compose", residual=models.wind_tunnel_net,
              theta_bounds={"r": (0.0, 1.0)}, lr=_size(budget, 3e-4, 1e-3, 1e-3),
              max_iter=_size(budget, 20000, 2000, 30))
    if budget == "cpu":  # keep the paper's budget for theta: lr_theta * max_iter = 3e-4 * 20,000
        kw["lr_theta"] = 3e-3  # = 3e-4 * 20,000 / 2,000 (lr alone reaches r <= 0.73 from 0.5)
    # the stand-in is generated with r = 0.75 (hatch closed; the publisher's value), not the
    # paper's 0.7 for the measured chamber: its error is measured against what made the data
    theta = raw.theta_reference_code if raw.simulated else raw.theta_reference
    return Bunch(data=d, kw=kw, theta=theta, source=source)


def _light_tunnel(budget, n_samples=None):
    size = _size(budget, 100, 32, 16)
    n = n_samples or _size(budget, 10000, 2000, 60)
    try:
        raw, source = ds.fetch_light_tunnel(download_if_missing=False, n_samples=n), "MEASURED"
        pooled = torch.nn.functional.adaptive_avg_pool2d(torch.as_tensor(raw.images), size).numpy()
        d = Bunch(X_train=raw.X_train, X_val=raw.X_val, X_test=raw.X_test,
                  **{f"y_{s}": pooled[raw.splits[s]] for s in ("train", "val", "test")})
        reference = raw.theta_reference
    except (FileNotFoundError, OSError, ValueError):
        raw = ds.make_light_tunnel_simulated(n_samples=n, image_size=size, random_state=0)
        d = Bunch(X_train=raw.X_train, X_val=raw.X_val, X_test=raw.X_test,
                  y_train=raw.images_train, y_val=raw.images_val, y_test=raw.images_test)
        reference, source = raw.theta_reference, "SIMULATED stand-in"
    kw = dict(science=models.make_light_tunnel_f(size), structure="compose",
              residual=partial(models.light_tunnel_unet,
                               channels=(16, 32, 64) if budget == "paper" else (8, 16, 32)),
              lr=1e-3, batch_size=50, max_iter=_size(budget, 20000, 600, 10))
    if budget == "cpu":  # the same rule: lr 1e-3 lets theta move 0.3 in 600 iterations; the
        kw["lr_theta"] = 1e-2  # light's parameters range over ~1-3 (lr_theta * max_iter / 2 = 3)
    return Bunch(data=d, kw=kw, theta=reference, source=source)


TASKS = {"pendulum": _pendulum, "reaction_diffusion": _reaction_diffusion, "duffing": _duffing,
         "pendulum_images": _pendulum_images, "wind_tunnel": wind_tunnel_spec,
         "light_tunnel": _light_tunnel}


# --- bench_tasks.py: every task at CPU size -----------------------------------------------------------

def _cpu_pendulum():
    d = ds.make_pendulum(25, 25, 25, random_state=0)
    kw = dict(science=models.pendulum_f, structure=OdeStructure(dt=d.dt, n_substeps=2), residual=PAPER_MLP,
              lr=3e-3, max_iter=2000)
    return d.X_train, d.y_train, d.X_test, d.y_test, d.theta_true, kw, "synthetic"


def _cpu_duffing():
    d = ds.make_duffing(100, 100, 100, random_state=0)
    kw = dict(science=models.duffing_f, structure=OdeStructure(dt=d.dt, n_substeps=1), residual=PAPER_MLP,
              lr=3e-3, max_iter=1500)
    return d.X_train, d.y_train, d.X_test, d.y_test, d.theta_true, kw, "synthetic"


def _cpu_reaction_diffusion():
    d = ds.make_reaction_diffusion(10, 10, 10, random_state=0)
    kw = dict(science=models.diffusion_f, residual="cnn", structure=OdeStructure(dt=d.dt, n_substeps=1),
              lr=1e-3, max_iter=300)
    return d.X_train, d.y_train, d.X_test, d.y_test, d.theta_true, kw, "synthetic"


def _cpu_pendulum_images():
    d = ds.make_pendulum_images(200, 50, 50, image_size=32, random_state=0)
    net = partial(models.PendulumImagesNet, n_input_frames=10, image_size=32, latent_dim=4,
                  encoder_channels=(16, 32, 32), encoder_hidden=128, fc_hidden=(256, 256),
                  conv_channels=(16, 8))
    kw = dict(science=models.pendulum_f, structure=models.PendulumImagesStructure(dt=d.dt),
              residual=net, lr=1e-3, batch_size=50, max_iter=250)
    return d.X_train, d.y_train, d.X_test, d.y_test, d.theta_true, kw, "synthetic"


def _cpu_wind_tunnel():
    try:
        d, source = ds.fetch_wind_tunnel(download_if_missing=False), "MEASURED"
    except (FileNotFoundError, OSError):
        d, source = ds.make_wind_tunnel_simulated(random_state=0), "SIMULATED stand-in"
    y = d.y - d.pressure_ambient
    tr, te = d.splits["train"], d.splits["test"]
    kw = dict(science=models.wind_tunnel_f, structure="compose", residual=models.wind_tunnel_net,
              theta_bounds={"r": (0.0, 1.0)}, lr=1e-3, max_iter=2000)
    return d.X[tr], y[tr], d.X[te], y[te], d.theta_reference, kw, source


def _cpu_light_tunnel():
    size = 32
    try:
        d, source = ds.fetch_light_tunnel(download_if_missing=False, n_samples=2000), "MEASURED"
        pooled = torch.nn.functional.adaptive_avg_pool2d(torch.as_tensor(d.images), size).numpy()
        d.images_train, d.images_test = pooled[d.splits["train"]], pooled[d.splits["test"]]
    except (FileNotFoundError, OSError, ValueError):
        d = ds.make_light_tunnel_simulated(n_samples=2000, image_size=size, random_state=0)
        source = "SIMULATED stand-in"
    kw = dict(science=models.make_light_tunnel_f(size), structure="compose",
              residual=partial(models.light_tunnel_unet, channels=(8, 16, 32)), lr=1e-3,
              batch_size=50, max_iter=600)
    return d.X_train, d.images_train, d.X_test, d.images_test, d.theta_reference, kw, source


CPU_TASKS = {"pendulum": _cpu_pendulum, "duffing": _cpu_duffing, "reaction_diffusion": _cpu_reaction_diffusion,
             "pendulum_images": _cpu_pendulum_images, "wind_tunnel": _cpu_wind_tunnel,
             "light_tunnel": _cpu_light_tunnel}
