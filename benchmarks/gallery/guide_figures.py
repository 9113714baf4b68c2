"""The figure that opens the closed-loop guide (doc/user_guide/closed_loop.rst), from the README's Quick start.

The Quick start's fit (defaults) and ``close_the_loop`` on the same fit, then one figure of two panels:
what the network learned on the velocity equation at the states the fit visited, with the term the loop
named from it; and one test trajectory, the science model alone with its fitted omega against the
network-free model with the named term.  Saved to ``results/guide/closed_loop.png``; ``results/guide.md``
and ``guide.json`` say when, on which machine, at which package commit and in how many CPU seconds.
About 35 CPU seconds (the Quick start's fit and loop).

Usage: python benchmarks/gallery/guide_figures.py
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import torch  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # benchmarks/: the helpers
from helpers import PACKAGE_COMMIT, RESULTS, write_results  # noqa: E402

FIGURES = RESULTS / "guide"


def pendulum_f(v, omega=0.5):  # the README's science model: no damping
    dv_dt = -(2 * torch.pi * omega) ** 2 * torch.sin(v[:, 0])
    return torch.stack([v[:, 1], dv_dt], dim=-1)


def main():
    from sklearn_hybrid import HybridRegressor, OdeStructure
    from sklearn_hybrid.datasets import make_pendulum
    from sklearn_hybrid.diagnosis import close_the_loop

    torch.set_num_threads(1)
    start = time.process_time()
    data = make_pendulum(random_state=0)  # a damped pendulum, true omega 2/3, damping -0.5 v_dot
    X, y = data.X_train, data.y_train
    est = HybridRegressor(science=pendulum_f, structure=OdeStructure(dt=0.2), random_state=0).fit(X, y)
    result = close_the_loop(est, X, y, state_names=["v", "v_dot"])
    seconds = time.process_time() - start

    (term,) = [t for t in result.added if t["output"] == "g[v_dot]"]
    trace = est.residual_trace(X)
    states = trace["points"].reshape(len(trace["points"]), -1)
    learned = trace["residual"].reshape(len(states), -1)[:, 1]
    omega_hybrid, omega_loop = est.theta_["omega"], result.science_theta["omega"]

    fig, (left, right) = plt.subplots(1, 2, figsize=(10, 4.4))
    left.scatter(states[:, 1], learned, s=6, alpha=0.5, label="what the network learned")
    grid = np.linspace(states[:, 1].min(), states[:, 1].max(), 50)
    left.plot(grid, term["coef"] * grid, "r-", lw=2, label=f"named term: {term['coef']:.3f} v_dot")
    left.set_xlabel("angular velocity v_dot (rad/s)")
    left.set_ylabel("network's term in d v_dot/dt")
    left.set_title("1. read what the network learned", fontsize=10)
    left.legend(fontsize=8, loc="upper center", bbox_to_anchor=(0.5, -0.2))

    k = int(np.argmax(np.abs(data.y_test[:, :, 0]).max(axis=1)))  # the widest test swing
    t = np.concatenate([[0.0], data.t])
    start_angle = data.X_test[k, 0]
    science = est.predict_science(data.X_test)[k, :, 0]
    augmented = result.science_only.predict(data.X_test)[k, :, 0]
    right.plot(data.t, data.y_test[k, :, 0], "ko", ms=4, label="test data (damped)")
    right.plot(t, np.r_[start_angle, science], "--", color="tab:gray",
               label=f"science model alone (omega {omega_hybrid:.3f})")
    right.plot(t, np.r_[start_angle, augmented], "-", color="tab:red",
               label=f"with the named term, no network (omega {omega_loop:.4f})")
    right.set_xlabel("time (s)")
    right.set_ylabel("angle v (rad)")
    right.set_title("2. refit the augmented science model, without the network", fontsize=10)
    right.legend(fontsize=8, loc="upper center", bbox_to_anchor=(0.5, -0.2))
    fig.tight_layout()
    FIGURES.mkdir(parents=True, exist_ok=True)
    fig.savefig(FIGURES / "closed_loop.png", dpi=80)

    payload = {"figure": "guide/closed_loop.png", "cpu_seconds": round(seconds, 1), "term": term["term"],
               "coef": term["coef"], "omega_hybrid": omega_hybrid, "omega_loop": omega_loop}
    markdown = "\n".join([
        "# The closed-loop guide's figure", "",
        "The README's Quick start (fit with the defaults, `close_the_loop` on the same fit), drawn by "
        "`benchmarks/guide_figures.py` into `results/guide/closed_loop.png`.", "",
        "| named term | coefficient | omega, hybrid fit | omega, network-free model | CPU seconds |",
        "|---|---|---|---|---|",
        f"| {term['term']} | {term['coef']:.4f} | {omega_hybrid:.4f} | {omega_loop:.4f} | {seconds:.0f} |"])
    write_results("guide", payload, markdown)
    print(payload, "package commit", PACKAGE_COMMIT)


if __name__ == "__main__":
    main()
