"""Demo: the README's Quick start, with the same settings and the same output.

Run ``python -m sklearn_hybrid.demo`` (or ``sklearn-hybrid demo``).  Data: a
damped pendulum (true omega = 2/3), 25 training trajectories; science model:
the undamped pendulum with unknown omega; network: the default MLP 128x2;
method: the default (Fisher SAM).  Prints the fit report with the profile's
verdict on omega, then the test error.  ``tests/test_readme.py`` checks that
this is the code of the README's Quick start.
"""

from __future__ import annotations

import numpy as np
import torch


def pendulum_f(v, omega=0.5):  # keyword defaults are the unknown parameters theta
    dv_dt = -(2 * torch.pi * omega) ** 2 * torch.sin(v[:, 0])  # no damping
    return torch.stack([v[:, 1], dv_dt], dim=-1)


def main():
    """Fit the pendulum, profile omega and print the report (about 1-2 minutes on one core).

    Returns
    -------
    HybridRegressor
        The fitted estimator.
    """
    from . import HybridRegressor
    from .datasets import make_pendulum
    from .identifiability import profile_theta

    data = make_pendulum(random_state=0)
    X, y = data.X_train, data.y_train
    est = HybridRegressor(science=pendulum_f, dt=0.2, random_state=0).fit(X, y)
    print(est.fit_report(profile=profile_theta(est, X, y)))
    rmse = np.sqrt(((est.predict(data.X_test) - data.y_test) ** 2).mean())
    print("test RMSE:", round(float(rmse), 4))
    return est


if __name__ == "__main__":
    main()
