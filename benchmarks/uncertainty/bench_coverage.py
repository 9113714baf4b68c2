"""How often does the 95 % interval of ``fit_report()`` (theta +/- 1.96 theta_std_) hold the true theta?

Each repeat draws a new pendulum data set (new initial states, new noise: ``make_pendulum(random_state=r)``)
and fits (erm, lr 1e-2, early stopping, at most 400 iterations) in three cases:

- "science alone": undamped data (gamma = 0) and the science model without a network
  (``residual=ZeroResidual()``): ordinary nonlinear least squares, where the interval should hold the truth
  about 95 % of the time;
- "complete science": the same data, now a hybrid with an MLP 32x32 that has nothing to learn;
- "missing damping": the paper's task (gamma = 0.5); the network must absorb the damping, and the
  estimate is biased by what it takes from the physics, which a noise-only standard error cannot see.

Usage: python benchmarks/uncertainty/bench_coverage.py [--repeats 20] [--cases "science alone" ...]
(with ``--cases``, the rows of the other cases are kept from the committed results/coverage.json)
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # benchmarks/: the helpers, the studies' modules
from helpers import RESULTS, write_results  # noqa: E402
from sklearn_hybrid import HybridRegressor, OdeStructure  # noqa: E402
from sklearn_hybrid.datasets import make_pendulum  # noqa: E402
from sklearn_hybrid.diagnosis import ZeroResidual  # noqa: E402
from sklearn_hybrid.models import pendulum_f  # noqa: E402

CASES = {"science alone": 0.0, "complete science": 0.0, "missing damping": 0.5}


def run(case, gamma, seed):
    data = make_pendulum(gamma=gamma, random_state=seed)
    residual = ZeroResidual() if case == "science alone" else {"hidden": (32, 32)}
    est = HybridRegressor(science=pendulum_f, structure=OdeStructure(dt=0.2), method="erm", lr=1e-2, max_iter=400,
                          residual=residual, random_state=seed)
    est.fit(data.X_train, data.y_train)
    omega, std = est.theta_["omega"], est.theta_std_["omega"]
    truth = data.theta_true["omega"]
    return {"case": case, "seed": seed, "omega": omega, "std": std, "n_iter": est.n_iter_,
            "error": omega - truth, "covered": bool(abs(omega - truth) <= 1.96 * std)}


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=20)
    parser.add_argument("--cases", nargs="*", default=list(CASES), choices=list(CASES))
    args = parser.parse_args()
    start = time.perf_counter()
    rows = [run(case, CASES[case], seed) for case in args.cases for seed in range(args.repeats)]
    seconds = time.perf_counter() - start
    kept = []
    if set(args.cases) != set(CASES) and (RESULTS / "coverage.json").exists():
        kept = [r for r in json.loads((RESULTS / "coverage.json").read_text())["runs"]
                if r["case"] not in args.cases]
    rows = kept + rows
    lines = [f"# Coverage of the 95 % interval of a single fit ({args.repeats} repeats per case)", "",
             f"Command: `python benchmarks/uncertainty/bench_coverage.py --repeats {args.repeats}` ({seconds:.0f} s"
             + (f" for {', '.join(args.cases)}; the other cases' rows are kept from the previous run)"
                if kept else ")"), "",
             "Interval: omega +/- 1.96 theta_std_ (Gauss-Newton standard error, network held fixed). "
             "Each repeat: new data and noise (make_pendulum(random_state=r)), erm, lr 1e-2, "
             "early stopping, at most 400 iterations; the hybrids with an MLP 32x32.", "",
             "| case | coverage | mean std | sd of the estimates | mean error (bias) | RMS error | "
             "mean iterations |", "|---|---|---|---|---|---|---|"]
    summary = {}
    for case in CASES:
        sel = [r for r in rows if r["case"] == case]
        if not sel:
            continue
        err = np.array([r["error"] for r in sel])
        s = {"coverage": float(np.mean([r["covered"] for r in sel])),
             "mean_std": float(np.mean([r["std"] for r in sel])),
             "sd_estimates": float(np.std([r["omega"] for r in sel], ddof=1)),
             "bias": float(err.mean()), "rms_error": float(np.sqrt(np.mean(err**2))),
             "n_iter": float(np.mean([r["n_iter"] for r in sel]))}
        summary[case] = s
        lines.append(f"| {case} | {s['coverage']:.0%} | {s['mean_std']:.2e} | {s['sd_estimates']:.2e} | "
                     f"{s['bias']:+.2e} | {s['rms_error']:.2e} | {s['n_iter']:.0f} |")
    lines += ["", "Reading: the interval holds the truth as often as promised only when its standard error "
              "matches the actual spread of the estimates (compare the two middle columns) and the bias is "
              "small against it. In a hybrid the network trades part of the dynamics with theta (even when "
              "the science is complete), which a standard error with the network held fixed cannot see: "
              "read it as the noise-only part of the uncertainty, and judge the rest by the spread across "
              "seeds (HybridRegressorCV), the residual diagnosis and held-out data."]
    path = write_results("coverage", {"runs": rows, "summary": summary, "seconds": seconds}, "\n".join(lines))
    print(path.read_text())


if __name__ == "__main__":
    main()
