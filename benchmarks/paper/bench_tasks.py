"""The paper's six tasks with erm and fsam, at a size a 2-core CPU runs in about 20 minutes.

Each task is run once per method (seed 0) with the science models and networks
of :mod:`sklearn_hybrid.models`; fits run in parallel processes with one torch
thread each.  Printed and written to ``results/tasks.md`` (and ``.json``):
theta at the end of training, its error (RMSE; cosine similarity for the light
tunnel), the best error along training (the paper's oracle model selection,
which uses the true theta), the test y error (RMSE) and the time per iteration.

Sizes here versus the paper (which trains 20,000 iterations with lr 1e-4 to 1e-3):

=================  =============================  ==============================================
task               paper                          here
=================  =============================  ==============================================
pendulum           25/25/25, 20k it, lr 1e-4      25/25/25, 2000 it, lr 3e-3
duffing            100/100/100, 20k it, lr 1e-4   100/100/100, 1500 it, lr 3e-3
reaction-diffusion 100/100/100, 20k it, lr 1e-4   10/10/10 (32 x 32), 300 it, lr 1e-3
pendulum images    200/200/200, 48 px, 20k it     200/50/50, 32 px, 250 it, small decoder
wind tunnel        600/150/235, 20k it, lr 3e-4   600/150/235, 2000 it, lr 1e-3
light tunnel       6000/1000/2500, 100 px, 20k    1263/210/527, 32 px, 600 it, U-Net 8/16/32
=================  =============================  ==============================================

The wind and light tunnel use the measured Causal Chamber data when they are in
the data home and the SIMULATED stand-ins otherwise (the table says which).

Usage: python benchmarks/paper/bench_tasks.py [--tasks pendulum duffing ...] [--jobs 2] [--max-iter N]
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np
import torch
from joblib import Parallel, delayed

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # benchmarks/: the helpers, the studies' modules
from helpers import write_results  # noqa: E402
from paper.tasks import CPU_TASKS as TASKS  # noqa: E402
from sklearn_hybrid import HybridRegressor, theta_error  # noqa: E402


def _errors(path: dict, reference: dict, metric: str) -> np.ndarray:
    """theta error at every iteration (RMSE over entries, or cosine similarity)."""
    est = np.concatenate([np.reshape(path[k], (len(path[k]), -1)) for k in reference], axis=1)
    ref = np.concatenate([np.ravel(reference[k]) for k in reference])
    if metric == "cosine":
        return est @ ref / (np.linalg.norm(est, axis=1) * np.linalg.norm(ref))
    return np.sqrt(np.mean((est - ref) ** 2, axis=1))


def run(task: str, method: str, max_iter: int | None = None) -> dict:
    torch.set_num_threads(1)
    X, y, X_test, y_test, reference, kw, source = TASKS[task]()
    if max_iter is not None:  # a quick check of the whole pipeline
        kw["max_iter"] = max_iter
    metric = "cosine" if task == "light_tunnel" else "rmse"
    start = time.perf_counter()
    # tol=None: each task trains its stated number of iterations (no early stopping)
    est = HybridRegressor(method=method, random_state=0, tol=None, **kw).fit(X, y)
    seconds = time.perf_counter() - start
    path = _errors(est.history_["theta"], reference, metric)
    best = path.max() if metric == "cosine" else path.min()
    theta = {k: np.round(np.ravel(v), 5).tolist() for k, v in est.theta_.items()}
    return {"task": task, "method": method, "source": source, "metric": metric,
            "n_train": len(X), "max_iter": est.max_iter, "theta": theta,
            "theta_error": theta_error(est.theta_, reference, metric), "theta_error_best": best,
            "y_error": float(np.sqrt(np.mean((est.predict(X_test) - y_test) ** 2))),
            "seconds": seconds, "ms_per_iter": 1e3 * seconds / est.max_iter}


def _markdown(rows: list[dict], wall: float) -> str:
    lines = ["# The paper's tasks at CPU size: erm vs fsam", "",
             "`python benchmarks/paper/bench_tasks.py` (sizes vs the paper in its docstring). One seed.",
             "theta error: RMSE to the true / reference theta (light tunnel: cosine similarity, "
             "higher is better); *best* = best value along training (the paper's oracle "
             "selection); y error: test RMSE.",
             "Start values (the science functions' defaults): omega 0.5 (true 2/3), alpha 0.5 "
             "(true 1), a = b = 0.01 (true 1e-3, 5e-3), r 0.5 (reference 0.7), light tunnel "
             "w = 1, t_p = 0.5, t_c = 0.1 (cosine 0.899 with the reference already).", "",
             "| task | data | n_train | iters | method | theta | theta error | best | y error "
             "| ms/it |", "|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        theta = "; ".join(f"{k}={v[0]:.4g}" if len(v) == 1 else
                          f"{k}=[{', '.join(f'{x:.3g}' for x in v)}]" for k, v in r["theta"].items())
        lines.append(f"| {r['task']} | {r['source']} | {r['n_train']} | {r['max_iter']} | "
                     f"{r['method']} | {theta} | {r['theta_error']:.4g} | "
                     f"{r['theta_error_best']:.4g} | {r['y_error']:.4g} | {r['ms_per_iter']:.0f} |")
    lines += ["", f"Total wall time {wall / 60:.1f} min."]
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--tasks", nargs="+", default=list(TASKS), choices=list(TASKS))
    parser.add_argument("--jobs", type=int, default=2)
    parser.add_argument("--max-iter", type=int, default=None,
                        help="override every task's iterations (quick check; no result file)")
    args = parser.parse_args()
    # the slowest fits first, so that the two workers finish together
    order = ["pendulum_images", "reaction_diffusion", "wind_tunnel", "light_tunnel", "pendulum",
             "duffing"]
    jobs = [(t, m) for t in order if t in args.tasks for m in ("fsam", "erm")]
    start = time.perf_counter()
    rows = Parallel(n_jobs=args.jobs)(delayed(run)(t, m, args.max_iter) for t, m in jobs)
    wall = time.perf_counter() - start
    rows.sort(key=lambda r: (list(TASKS).index(r["task"]), r["method"]))
    text = _markdown(rows, wall)
    print(text)
    if args.max_iter is None:
        path = write_results("tasks", {"rows": rows, "wall_seconds": wall}, text)
        print(f"written {path}")


if __name__ == "__main__":
    main()
