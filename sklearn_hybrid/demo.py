"""Demo: the paper's pendulum task, erm against Fisher SAM, in about a minute.

Run ``python -m sklearn_hybrid.demo``.  Data: damped pendulum (gamma = 0.5,
omega = 2/3), 25 training trajectories; science model: the undamped pendulum
with unknown omega; network: MLP 128x2.  Prints |omega - 2/3| per method.
"""

from __future__ import annotations

import time

import numpy as np

from . import HybridRegressor, theta_error
from .datasets import make_pendulum
from .models import pendulum_f


def main(max_iter: int = 1000, seed: int = 0) -> dict:
    """Fit erm and fsam on the pendulum task and print theta and prediction errors."""
    data = make_pendulum(random_state=seed)
    print(f"pendulum task: {len(data.X_train)} training trajectories, true omega = 2/3")
    print(f"{'method':>6} {'omega':>8} {'|omega-2/3|':>12} {'test RMSE':>10} {'time':>6}")
    results = {}
    for method in ("erm", "fsam"):
        start = time.perf_counter()
        est = HybridRegressor(science=pendulum_f, method=method, rho=0.2, dt=float(data.dt),
                              n_substeps=2, lr=3e-3, max_iter=max_iter, random_state=seed)
        est.fit(data.X_train, data.y_train)
        rmse = float(np.sqrt(np.mean((est.predict(data.X_test) - data.y_test) ** 2)))
        error = theta_error(est.theta_, data.theta_true)
        results[method] = error
        print(f"{method:>6} {est.theta_['omega']:8.4f} {error:12.4f} {rmse:10.4f} "
              f"{time.perf_counter() - start:5.0f}s")
    return results


if __name__ == "__main__":
    main()
