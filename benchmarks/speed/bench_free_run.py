"""Free-run simulation speed: time per RK4 step of ``simulate`` with and without the frozen path.

Long free runs (the test records of a closed loop: 40,000 samples) call the right-hand side
tens of thousands of times, one small batch at a time, so module dispatch and re-deriving theta
through its bounded map at every call cost more than the arithmetic. Without gradients,
``simulate`` reads theta once and runs the MLP as bare ``addmm`` products (``frozen_rhs`` of
``sklearn_hybrid.integrate.fast``); ``fast.disabled()`` gives the module path it replaced. The model has the Silverbox recipe's
shape (2 states, 1 input, linear science with 4 parameters, MLP 32 x 32 on the acceleration),
fitted for a few iterations on random data (the speed does not depend on the weights).

Timing: process CPU time, one torch thread, contenders interleaved over rounds; median and best
round, and the median of the per-round ratios.

Usage: python benchmarks/speed/bench_free_run.py [--rounds 5] [--steps 5000]
Writes results/free_run.md and results/free_run.json.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np
import torch

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # benchmarks/: the helpers, the studies' modules
from helpers import write_results  # noqa: E402
from sklearn_hybrid import HybridRegressor, OdeStructure  # noqa: E402
from sklearn_hybrid.diagnosis import MLPOn, free_run  # noqa: E402
from sklearn_hybrid.integrate import fast  # noqa: E402
from sklearn_hybrid.recipes import silverbox_f  # noqa: E402


def _model() -> HybridRegressor:
    rng = np.random.default_rng(0)
    X = np.column_stack([rng.normal(size=(64, 2)), rng.normal(size=(64, 17))])  # x0, then u on 17 samples
    y = rng.normal(size=(64, 16, 1))
    return HybridRegressor(science=silverbox_f, structure=OdeStructure(observed=[0], n_inputs=1, dt=1.0, n_substeps=1),
                           residual=MLPOn([1], hidden=(32, 32)), max_iter=3, random_state=0).fit(X, y)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=int, default=5)
    parser.add_argument("--steps", type=int, default=5000)
    args = parser.parse_args()
    torch.set_num_threads(1)
    est = _model()
    u = np.random.default_rng(1).normal(size=args.steps + 1)

    def per_step(use_residual):  # microseconds of process time per RK4 step
        start = time.process_time()
        free_run(est, [0.1, 0.0], u=u, use_residual=use_residual)
        return 1e6 * (time.process_time() - start) / args.steps

    rows = []
    for use_residual in (True, False):
        times = {"modules": [], "frozen": []}
        for _ in range(args.rounds):
            with fast.disabled():
                times["modules"].append(per_step(use_residual))
            times["frozen"].append(per_step(use_residual))
        ratios = np.array(times["modules"]) / np.array(times["frozen"])
        rows.append({"model": "hybrid" if use_residual else "science only",
                     **{f"{k}_us_median": float(np.median(v)) for k, v in times.items()},
                     **{f"{k}_us_best": float(np.min(v)) for k, v in times.items()},
                     "speedup_median": float(np.median(ratios)), "speedup_range": [float(ratios.min()),
                                                                                   float(ratios.max())]})
        print(rows[-1], flush=True)
    md = ["# Free-run simulation: microseconds per RK4 step (one record, batch 1)", "",
          f"`python benchmarks/speed/bench_free_run.py --rounds {args.rounds} --steps {args.steps}`: process CPU time, "
          "one torch thread, contenders interleaved; *modules* = the path before `fast.frozen_rhs` "
          "(`fast.disabled()`), *frozen* = theta read once and the MLP as bare products.", "",
          "| model | modules (median / best) | frozen (median / best) | speed-up (median, range) |",
          "|---|---|---|---|"]
    md += [f"| {r['model']} | {r['modules_us_median']:.0f} / {r['modules_us_best']:.0f} | "
           f"{r['frozen_us_median']:.0f} / {r['frozen_us_best']:.0f} | {r['speedup_median']:.2f} "
           f"({r['speedup_range'][0]:.2f}-{r['speedup_range'][1]:.2f}) |" for r in rows]
    write_results("free_run", {"rounds": args.rounds, "steps": args.steps, "rows": rows}, "\n".join(md))


if __name__ == "__main__":
    main()
