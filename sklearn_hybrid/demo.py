"""Demo: the README's Quick start, with the same settings and the same output.

Run ``python -m sklearn_hybrid.demo`` (or ``sklearn-hybrid demo``).  Data: a
damped pendulum (true omega = 2/3), 25 training trajectories; science model:
the undamped pendulum with unknown omega; network: the default MLP 128x2;
method: the default (Fisher SAM).  Prints the fit report, whose first screen
reads the network's share, then closes the loop on that fit: the term the
science misses, and the network-free model's omega with its interval.
``tests/test_readme.py`` checks that this is the code of the README's Quick
start.
"""

from __future__ import annotations

import torch


def pendulum_f(v, omega=0.5):  # keyword defaults are the unknown parameters theta
    dv_dt = -(2 * torch.pi * omega) ** 2 * torch.sin(v[:, 0])  # no damping
    return torch.stack([v[:, 1], dv_dt], dim=-1)


def main():
    """Fit the pendulum, read the report, close the loop and print its answer (well under a minute on one core).

    Returns
    -------
    LoopResult
        What :func:`~sklearn_hybrid.diagnosis.close_the_loop` returned (its ``before`` is the fit).
    """
    from . import HybridRegressor, OdeStructure
    from .datasets import make_pendulum
    from .diagnosis import close_the_loop

    data = make_pendulum(random_state=0)
    X, y = data.X_train, data.y_train
    est = HybridRegressor(science=pendulum_f, structure=OdeStructure(dt=0.2), random_state=0).fit(X, y)
    print(est.fit_report())
    result = close_the_loop(est, X, y, state_names=["v", "v_dot"])
    print(result.report.splitlines()[-2])
    print(result.intervals)
    return result


if __name__ == "__main__":
    main()
