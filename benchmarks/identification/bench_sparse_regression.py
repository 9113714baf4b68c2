"""Sparse residual regression: our SparseTermRegression against pysindy's optimizers, on known truths.

Each problem: states Z (n=500 samples of 3 variables), the library ``CandidateLibrary(degree=3,
include_bias=True)`` on them (20 terms), a true support of 1-4 random terms with coefficients of
magnitude 0.5-2 (per unit-RMS column, random sign), and a residual ``r = Theta_S beta + noise`` with
noise standard deviation = level x RMS(Theta_S beta). Two state families: "independent" (uniform
on [-1.5, 1.5]^3: the usual monomial collinearity only, e.g. x vs x^3) and "collinear" (Gaussian
states with pairwise correlation 0.95). Every method sees the same unit-RMS columns (as ours
scales them inside) and reports coefficients of the original columns.

Methods
-------
- ours: ``SparseTermRegression()`` with default settings (EBIC over lasso-path and
  backward-elimination supports, relevance floor, least-squares refit, 50 bootstrap resamples
  for inclusion frequencies); ``ours, no bootstrap``: the same selection (identical support and
  coefficients) without the bootstrap, for the time; ``ours, min_explained=0``: without the
  relevance floor (the criterion's support as it is).
- STLSQ (pysindy), threshold by 5-fold CV over a 16-value grid (relative to RMS(r)), either the
  minimum CV error or the one-standard-error rule (sparsest threshold within 1 SE of the
  minimum); the unregularised refit on the support (``unbias=True``).
- SR3 (pysindy, L0 regulariser, ``unbias=True``), weight chosen the same two ways.
- STLSQ, oracle threshold: the grid value with the best support given the truth. Not a usable
  method: an upper bound of what the thresholding family can do with a perfect tuner.
- MIOSR (pysindy) needs gurobipy (a commercial solver) and is left out when it is absent.

Metrics per problem: exact support recovery, false terms (selected, not true), missed terms,
coefficient relative error ||b_hat - b|| / ||b||, and seconds (tuning included).

Usage: python benchmarks/identification/bench_sparse_regression.py [--problems 20] [--n-samples 500]
"""

from __future__ import annotations

import argparse
import csv
import sys
import time
import warnings
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # benchmarks/: the helpers, the studies' modules
from helpers import RESULTS, RUNS, write_results  # noqa: E402
from identification.sparse_grid import GRID, cv_choice  # noqa: E402
from sklearn_hybrid.diagnosis import CandidateLibrary, SparseTermRegression  # noqa: E402

try:
    import pysindy
except ImportError:  # optional: pip install pysindy (or the [sindy] extra)
    pysindy = None

NOISE_LEVELS = (0.05, 0.2, 0.5)
FAMILIES = ("independent", "collinear")


def make_problem(family: str, noise: float, n: int, rng: np.random.Generator) -> dict:
    """Library matrix, residual and true coefficients (original columns) of one problem."""
    if family == "independent":
        Z = rng.uniform(-1.5, 1.5, size=(n, 3))
    else:
        cov = np.full((3, 3), 0.95) + 0.05 * np.eye(3)
        Z = rng.multivariate_normal(np.zeros(3), cov, size=n)
    library = CandidateLibrary(degree=3, include_bias=True)
    Theta = library.fit_transform(Z, feature_names=["x", "y", "z"])
    scale = np.sqrt(np.mean(Theta**2, axis=0))
    p = Theta.shape[1]
    support = rng.choice(p, size=rng.integers(1, 5), replace=False)
    beta_scaled = np.zeros(p)
    beta_scaled[support] = rng.uniform(0.5, 2.0, size=len(support)) * rng.choice([-1, 1], size=len(support))
    signal = (Theta / scale) @ beta_scaled
    r = signal + noise * np.sqrt(np.mean(signal**2)) * rng.standard_normal(n)
    return {"Theta": Theta, "scale": scale, "r": r, "beta": beta_scaled / scale,
            "names": list(library.get_feature_names_out())}


def _stlsq(threshold: float):
    return pysindy.STLSQ(threshold=threshold, unbias=True)


def _sr3(threshold: float):  # L0 with nu = 1: coefficients below sqrt(2 lam nu) = threshold are cut
    return pysindy.SR3(reg_weight_lam=threshold**2 / 2, regularizer="L0", unbias=True, max_iter=100)


def fit_methods(problem: dict) -> dict:
    """Coefficients (original columns) and seconds of every method on one problem."""
    Theta, r, scale = problem["Theta"], problem["r"], problem["scale"]
    Xs, rms = Theta / scale, np.sqrt(np.mean(r**2))
    out = {}
    for label, params in (("ours", {}), ("ours, no bootstrap", {"n_bootstrap": 0}),
                          ("ours, min_explained=0, no bootstrap", {"n_bootstrap": 0, "min_explained": 0.0})):
        start = time.perf_counter()
        coef = SparseTermRegression(random_state=0, **params).fit(Theta, r).coef_.ravel()
        out[label] = (coef, time.perf_counter() - start)
    if pysindy is None:
        return out
    values = GRID * rms
    for name, make in (("STLSQ", _stlsq), ("SR3 (L0)", _sr3)):
        for one_se in (False, True):
            start = time.perf_counter()
            v = cv_choice(make, Xs, r, values, one_se)
            coef = make(v).fit(Xs, r).coef_.ravel() / scale
            out[f"{name}, 5-fold CV{' 1-SE' if one_se else ''}"] = (coef, time.perf_counter() - start)
    truth = problem["beta"] != 0
    start = time.perf_counter()
    fits = [_stlsq(v).fit(Xs, r).coef_.ravel() / scale for v in values]
    best = min(fits, key=lambda c: (np.sum((c != 0) != truth), np.linalg.norm(c - problem["beta"])))
    out["STLSQ, oracle threshold"] = (best, time.perf_counter() - start)
    if getattr(pysindy, "MIOSR", None) is not None:
        try:
            start = time.perf_counter()
            k = int(np.sum(truth))  # MIOSR takes the number of terms; given the true one (an upper bound)
            coef = pysindy.MIOSR(target_sparsity=k, unbias=True).fit(Xs, r).coef_.ravel() / scale
            out["MIOSR, true sparsity"] = (coef, time.perf_counter() - start)
        except Exception as exc:  # noqa: BLE001 - gurobipy licence or install problems
            print(f"MIOSR skipped: {exc}", file=sys.stderr)
    return out


def score(coef: np.ndarray, beta: np.ndarray) -> dict:
    chosen, truth = coef != 0, beta != 0
    return {"exact": bool(np.array_equal(chosen, truth)), "false_terms": int(np.sum(chosen & ~truth)),
            "missed_terms": int(np.sum(truth & ~chosen)),
            "coef_rel_error": float(np.linalg.norm(coef - beta) / np.linalg.norm(beta))}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--problems", type=int, default=20, help="random problems per family and noise level")
    parser.add_argument("--n-samples", type=int, default=500)
    args = parser.parse_args()
    if pysindy is None:
        print("pysindy is not installed: only SparseTermRegression is measured "
              "(pip install pysindy, or pip install -e '.[sindy]', to compare).", file=sys.stderr)
    warnings.filterwarnings("ignore", module="pysindy")
    rows = []
    start_all = time.perf_counter()
    for family in FAMILIES:
        for noise in NOISE_LEVELS:
            rng = np.random.default_rng([FAMILIES.index(family), int(noise * 1000)])
            for i in range(args.problems):
                problem = make_problem(family, noise, args.n_samples, rng)
                for method, (coef, seconds) in fit_methods(problem).items():
                    rows.append({"family": family, "noise": noise, "problem": i, "method": method,
                                 "n_true": int(np.sum(problem["beta"] != 0)), "seconds": seconds,
                                 **score(coef, problem["beta"])})
            print(f"{family}, noise {noise}: done ({time.perf_counter() - start_all:.0f} s)", flush=True)
    methods = list(dict.fromkeys(r["method"] for r in rows))
    summary = []
    for family in FAMILIES:
        for noise in NOISE_LEVELS:
            for method in methods:
                sel = [r for r in rows if r["family"] == family and r["noise"] == noise and r["method"] == method]
                summary.append({"family": family, "noise": noise, "method": method,
                                "exact_support": float(np.mean([r["exact"] for r in sel])),
                                "false_terms": float(np.mean([r["false_terms"] for r in sel])),
                                "missed_terms": float(np.mean([r["missed_terms"] for r in sel])),
                                "coef_rel_error_median": float(np.median([r["coef_rel_error"] for r in sel])),
                                "seconds_mean": float(np.mean([r["seconds"] for r in sel]))})
    command = (f"python benchmarks/identification/bench_sparse_regression.py --problems {args.problems} "
               f"--n-samples {args.n_samples}")
    md = ["# Sparse residual regression: SparseTermRegression vs pysindy", "",
          f"Command: `{command}` ({time.perf_counter() - start_all:.0f} s; pysindy "
          f"{getattr(pysindy, '__version__', 'not installed')}). {args.problems} random problems per row, "
          f"{args.n_samples} samples, 3 variables, degree-3 library with bias (20 terms), 1-4 true terms. "
          "See the script's docstring for the problems and the methods' tuning. Timings: wall-clock on a "
          "2-core machine shared with other jobs (niced); compare them within this table only."
          + ("" if getattr(pysindy, "MIOSR", None) is not None else
             " MIOSR: not measured (pysindy.MIOSR needs gurobipy, a commercial solver, not installed)."), "",
          "| states | noise | method | exact support | false terms | missed terms | coef. rel. error (median) "
          "| seconds |", "|---|---|---|---|---|---|---|---|"]
    md += [f"| {s['family']} | {s['noise']:g} | {s['method']} | {s['exact_support']:.0%} | {s['false_terms']:.2f} | "
           f"{s['missed_terms']:.2f} | {s['coef_rel_error_median']:.3g} | {s['seconds_mean']:.3f} |" for s in summary]
    runs = RUNS / "sparse_regression.csv"  # one row per (problem, method), beside the other studies' run records
    runs.parent.mkdir(parents=True, exist_ok=True)
    with open(runs, "w", newline="") as fh:
        writer = csv.DictWriter(fh, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows({k: f"{v:.4g}" if isinstance(v, float) else v for k, v in r.items()} for r in rows)
    path = write_results("sparse_regression", {"command": command, "summary": summary,
                                               "runs": runs.relative_to(RESULTS).as_posix(),
                                               "pysindy": getattr(pysindy, "__version__", None)}, "\n".join(md))
    print(path.read_text())


if __name__ == "__main__":
    main()
