"""Theta error on the paper's pendulum time-series task: erm vs sam vs fsam.

Damped data (gamma 0.5, omega 2/3), undamped science model, 25 training
trajectories, MLP 2-128-128-2, rk4 with 4 sub-steps per 0.2 output interval,
Adam lr 1e-3 cosine-annealed, omega initialised at 0.5.  Several seeds per
configuration; fits run in parallel processes, one torch thread each.

Usage: python benchmarks/paper/bench_pendulum_theta.py [--iters 3000] [--seeds 3] [--jobs 2]
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np
from joblib import Parallel, delayed

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # benchmarks/: the helpers, the studies' modules
from helpers import write_results  # noqa: E402
from sklearn_hybrid import HybridRegressor, OdeStructure, theta_error  # noqa: E402
from sklearn_hybrid.datasets import make_pendulum  # noqa: E402
from sklearn_hybrid.models import pendulum_f  # noqa: E402

CONFIGS = [("erm", {}), ("sam", {"rho": 0.05}), ("sam", {"rho": 0.2}),
           ("fsam", {"rho": 0.05, "eta": 1.0})]


def run(method, params, seed, iters):
    data = make_pendulum(random_state=seed)
    start = time.perf_counter()
    # tol=None: the protocol is a fixed number of iterations (no early stopping)
    est = HybridRegressor(science=pendulum_f, method=method, structure=OdeStructure(dt=0.2, n_substeps=4), lr=1e-3,
                          tol=None, max_iter=iters, random_state=seed, **params).fit(data.X_train, data.y_train)
    y_err = float(np.sqrt(np.mean((est.predict(data.X_test) - data.y_test) ** 2)))
    return {"method": method, **params, "seed": seed, "omega": est.theta_["omega"],
            "theta_error": theta_error(est.theta_, data.theta_true), "y_error": y_err,
            "seconds": time.perf_counter() - start}


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--iters", type=int, default=3000)
    parser.add_argument("--seeds", type=int, default=3)
    parser.add_argument("--jobs", type=int, default=2)
    args = parser.parse_args()
    jobs = [(m, p, s) for m, p in CONFIGS for s in range(args.seeds)]
    rows = Parallel(n_jobs=args.jobs)(delayed(run)(m, p, s, args.iters) for m, p, s in jobs)
    lines = [f"# Pendulum task: theta error ({args.iters} iterations, {args.seeds} seeds)", "",
             f"Command: `python benchmarks/paper/bench_pendulum_theta.py --iters {args.iters} "
             f"--seeds {args.seeds} --jobs {args.jobs}`", "",
             "| method | rho | |omega - 2/3| mean | sd | test y RMSE | s/fit |",
             "|---|---|---|---|---|---|"]
    summary = []
    for method, params in CONFIGS:
        sel = [r for r in rows if r["method"] == method and r.get("rho") == params.get("rho")]
        err = np.array([r["theta_error"] for r in sel])
        summary.append({"method": method, **params, "theta_error_mean": err.mean(),
                        "theta_error_sd": err.std(ddof=1) if len(err) > 1 else 0.0})
        lines.append(f"| {method} | {params.get('rho', '-')} | {err.mean():.4f} | "
                     f"{summary[-1]['theta_error_sd']:.4f} | "
                     f"{np.mean([r['y_error'] for r in sel]):.4f} | "
                     f"{np.mean([r['seconds'] for r in sel]):.0f} |")
    path = write_results("pendulum_theta", {"runs": rows, "summary": summary}, "\n".join(lines))
    print(path.read_text())


if __name__ == "__main__":
    main()
