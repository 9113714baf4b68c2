"""Why b is biased on the reaction-diffusion task: the missing reaction is not orthogonal to b's term.

The science model is diffusion only, ``v_t = b lap(v)``; the data add the reaction ``u - v``
(and ``u - u^3 - k - v`` to ``u_t``). On the task's fields (uniform noise per pixel at the start,
32 x 32 grid) the five-point Laplacian of a rough field is mostly ``-4 v / dx^2``, so the missing
``-v`` looks like extra diffusion: a least-squares fit can move b instead of leaving the reaction
to the network, and a CNN, which can represent a five-point Laplacian exactly, can take part of
b's own term. This script measures, on the cpu protocol's training data (``table1.py``), the
projection of each missing reaction term on the Laplacian of its field and their correlation, at
every time step of the windows. Usage: python benchmarks/paper/why_reaction_diffusion.py
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import torch

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # benchmarks/: the helpers, the studies' modules
from helpers import write_results  # noqa: E402
from sklearn_hybrid import datasets as ds  # noqa: E402
from sklearn_hybrid.models import laplacian  # noqa: E402

K = 5e-3  # the generator's constant reaction term


def _laplacian(f: np.ndarray, dx: float) -> np.ndarray:  # the science model's periodic stencil, as the data
    return laplacian(torch.as_tensor(f), dx).numpy()


def main() -> None:
    d = ds.make_reaction_diffusion(10, 10, 10, grid_size=32, random_state=0)  # table1.py --budget cpu
    states = np.concatenate([d.X_train[:, None], d.y_train], axis=1)  # (n, time, [u, v], G, G)
    u, v = states[:, :, 0], states[:, :, 1]
    dx = 2.0 / states.shape[-1]
    rows = []
    for field, missing, lap in (("v", u - v, _laplacian(v, dx)), ("u", u - u**3 - K - v, _laplacian(u, dx))):
        for t in range(states.shape[1]):
            m, lap_t = missing[:, t].ravel(), lap[:, t].ravel()
            m = m - m.mean()
            rows.append({"field": field, "step": t, "projection": float(m @ lap_t / (lap_t @ lap_t)),
                         "correlation": float(np.corrcoef(m, lap_t)[0, 1])})
    md = ["# Reaction-diffusion: the missing reaction against the diffusion term it is confused with", "",
          __doc__.split("\n\n")[1].replace("\n", " "), "",
          "projection: the diffusion coefficient a least-squares fit of the missing term alone would add "
          f"(true a = 1e-3, b = 5e-3; dx^2 / 5 = {dx**2 / 5:.2e} for white noise).", "",
          "| field | time step | projection on lap(field) | correlation |", "|---|---|---|---|"]
    md += [f"| {r['field']} | {r['step']} | {r['projection']:.2e} | {r['correlation']:.2f} |" for r in rows]
    print(write_results("why_reaction_diffusion", {"rows": rows}, "\n".join(md)).read_text())


if __name__ == "__main__":
    main()
