"""Hyperparameter sensitivity on the pendulum task (the paper's Figure 2a): f-reg lambda, fsam rho.

Trains on the 25 training trajectories for every value and seed and reports
theta error and test y error (mean over seeds), with erm as the reference.

Usage: python benchmarks/paper/bench_sensitivity.py [--iters 1500] [--seeds 2] [--jobs 2]
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # benchmarks/: the helpers, the studies' modules
from helpers import RESULTS, write_results  # noqa: E402
from sklearn_hybrid import HybridRegressor, OdeStructure  # noqa: E402
from sklearn_hybrid.datasets import make_pendulum  # noqa: E402
from sklearn_hybrid.model_selection import plot_sensitivity, sensitivity_curve  # noqa: E402
from sklearn_hybrid.models import pendulum_f  # noqa: E402


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--iters", type=int, default=1500)
    parser.add_argument("--seeds", type=int, default=2)
    parser.add_argument("--jobs", type=int, default=2)
    args = parser.parse_args()
    d = make_pendulum(random_state=0)
    data = (d.X_train, d.y_train, d.X_test, d.y_test)
    # tol=None: every fit trains args.iters iterations (no early stopping)
    common = dict(science=pendulum_f, structure=OdeStructure(dt=0.2, n_substeps=2), lr=3e-3, max_iter=args.iters,
                  tol=None)
    seeds = list(range(args.seeds))
    sweeps = {
        "erm": (HybridRegressor(method="erm", **common), "weight_decay", [1e-5]),
        "f-reg": (HybridRegressor(method="f-reg", **common), "lam", [1e-4, 1e-3, 1e-2, 1e-1]),
        "fsam": (HybridRegressor(method="fsam", **common), "rho", [0.01, 0.05, 0.2, 1.0]),
    }
    results = {name: sensitivity_curve(est, p, values, *data, theta_true=d.theta_true,
                                       seeds=seeds, n_jobs=args.jobs)
               for name, (est, p, values) in sweeps.items()}
    lines = ["# Pendulum task: sensitivity to lambda (f-reg) and rho (fsam)", "",
             f"Command: `python benchmarks/paper/bench_sensitivity.py --iters {args.iters} "
             f"--seeds {args.seeds} --jobs {args.jobs}` (lr 3e-3, 2 RK4 sub-steps per output)", "",
             "| method | parameter | value | theta error (mean) | test y RMSE (mean) |",
             "|---|---|---|---|---|"]
    for name, res in results.items():
        for value, te, ye in zip(res.param_range, res.theta_error.mean(1), res.y_error.mean(1)):
            lines.append(f"| {name} | {res.param_name} | {value:g} | {te:.4f} | {ye:.4f} |")
    fig, axes = plt.subplots(2, 2, figsize=(8, 6), constrained_layout=True)
    for row, name in zip(axes, ("f-reg", "fsam")):
        plot_sensitivity(results[name], reference=results["erm"], axes=row)
        row[0].set_title(name)
    fig.savefig(RESULTS / "sensitivity_pendulum.png", dpi=80)
    payload = {name: {"param": r.param_name, "values": r.param_range,
                      "theta_error": r.theta_error.tolist(), "y_error": r.y_error.tolist()}
               for name, r in results.items()}
    print(write_results("sensitivity_pendulum", payload, "\n".join(lines)).read_text())


if __name__ == "__main__":
    main()
