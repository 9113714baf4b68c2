"""Default fit of the pendulum task: early stopping (the new defaults) against 2,000 fixed iterations.

"before": the defaults until issue 12, ``lr=1e-3``, 2,000 iterations, no early stopping;
"default": ``HybridRegressor(science=pendulum_f, structure=OdeStructure(dt=0.2))`` as it is now (``lr=1e-2``, early
stopping with ``tol=1e-3`` over ``n_iter_no_change=100`` iterations, at most 2,000).
Both with the default method (fsam, rho 0.05) on ``make_pendulum(random_state=seed)``, one torch
thread, fits run one after the other (the wall-clock times are those of a shared 2-core machine:
the load average is recorded).

Usage: python benchmarks/speed/bench_early_stopping.py [--seeds 3] [--settings default]
(``--settings`` reruns only those settings and keeps the other rows from the last results file.)
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # benchmarks/: the helpers, the studies' modules
from helpers import RESULTS, write_results  # noqa: E402
from sklearn_hybrid import HybridRegressor, OdeStructure, theta_error  # noqa: E402
from sklearn_hybrid.datasets import make_pendulum  # noqa: E402
from sklearn_hybrid.models import pendulum_f  # noqa: E402

SETTINGS = {"before": {"lr": 1e-3, "max_iter": 2000, "tol": None}, "default": {}}


def run(name, seed):
    data = make_pendulum(random_state=seed)
    load = os.getloadavg()[0]
    start = time.perf_counter()
    est = HybridRegressor(science=pendulum_f, structure=OdeStructure(dt=0.2), random_state=seed, **SETTINGS[name])
    est.fit(data.X_train, data.y_train)
    seconds = time.perf_counter() - start
    rmse = float(np.sqrt(np.mean((est.predict(data.X_test) - data.y_test) ** 2)))
    row = {"setting": name, "seed": seed, "seconds": seconds, "n_iter": est.n_iter_,
           "omega": est.theta_["omega"], "omega_std": est.theta_std_["omega"],
           "theta_error": theta_error(est.theta_, data.theta_true), "test_rmse": rmse,
           "load_before": load}
    print(row, flush=True)
    return row


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=3)
    parser.add_argument("--settings", nargs="+", default=list(SETTINGS), choices=list(SETTINGS))
    args = parser.parse_args()
    kept = []
    if set(args.settings) != set(SETTINGS):  # the other settings' rows from the last run
        previous = json.loads((RESULTS / "early_stopping.json").read_text())["runs"]
        kept = [dict(r, kept=True) for r in previous if r["setting"] not in args.settings]
    rows = kept + [run(name, seed) for seed in range(args.seeds) for name in args.settings]
    lines = [f"# Pendulum default fit: early stopping vs 2,000 iterations ({args.seeds} seeds)", "",
             f"Command: `python benchmarks/speed/bench_early_stopping.py --seeds {args.seeds}"
             + ("" if not kept else f" --settings {' '.join(args.settings)}") + "`"
             + ("" if not kept else " (rows marked * kept from the previous run)"), "",
             "before: lr 1e-3, 2,000 iterations (the defaults until issue 12); default: lr 1e-2, "
             "early stopping (tol 1e-3, n_iter_no_change 100). Method fsam (rho 0.05), one thread.", "",
             "| setting | seed | iterations | seconds | omega | theta std (Gauss-Newton) | "
             "abs(omega - 2/3) | test RMSE | load avg before |", "|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        lines.append(f"| {r['setting']}{'*' if r.get('kept') else ''} | {r['seed']} | {r['n_iter']} | {r['seconds']:.1f} | "
                     f"{r['omega']:.4f} | {r['omega_std']:.4f} | {r['theta_error']:.4f} | "
                     f"{r['test_rmse']:.4f} | {r['load_before']:.2f} |")
    lines += ["", "| setting | mean iterations | mean seconds | max seconds | mean abs(omega - 2/3) | "
              "mean test RMSE |", "|---|---|---|---|---|---|"]
    summary = {}
    for name in SETTINGS:
        sel = [r for r in rows if r["setting"] == name]
        summary[name] = {k: float(np.mean([r[k] for r in sel]))
                         for k in ("n_iter", "seconds", "theta_error", "test_rmse")}
        summary[name]["max_seconds"] = float(max(r["seconds"] for r in sel))
        s = summary[name]
        lines.append(f"| {name} | {s['n_iter']:.0f} | {s['seconds']:.1f} | {s['max_seconds']:.1f} | "
                     f"{s['theta_error']:.4f} | {s['test_rmse']:.4f} |")
    path = write_results("early_stopping", {"runs": rows, "summary": summary}, "\n".join(lines))
    print(path.read_text())


if __name__ == "__main__":
    main()
