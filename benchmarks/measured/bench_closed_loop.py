"""Close the loop on measured and synthetic data: fit -> diagnose -> augment -> refit -> before/after.

Cases (``sklearn_hybrid.recipes``): Silverbox (linear science model, cubic stiffness
undeclared), Cascaded tanks (Torricelli, overflow undeclared), the real pendulum free swing
(friction undeclared), the Hudson's Bay hare and lynx pelts (Lotka-Volterra), and the synthetic
pendulum (damping undeclared) and Duffing (cubic term undeclared) tasks. Measured cases are
scored by free runs of their test records; the grey-box baselines of ``bench_greybox.py``
(results/greybox.json, run it first) are quoted beside them.

Usage: python benchmarks/measured/bench_closed_loop.py [--cases silverbox tanks ...] [--method erm] [--fast]
[--n-jobs 2]
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import torch

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # benchmarks/: the helpers, the studies' modules
from helpers import RESULTS, write_results  # noqa: E402
from sklearn_hybrid.recipes import CASES, run_case  # noqa: E402


def _baselines() -> dict:
    path = RESULTS / "greybox.json"
    if not path.exists():
        return {}
    data = json.loads(path.read_text())
    sb = {(r["model"], r["input"]): r for r in data["silverbox"]}
    tanks = {r["model"]: r for r in data["tanks"]}
    swing = [(f"grey-box {r['model']}", r) for r in data.get("pendulum_freeswing", [])]
    return {"silverbox": [(f"grey-box {m} ({i})", sb[(m, i)]) for m, i in
                          [("linear", "fft"), ("linear + cubic", "fft"), ("linear + cubic", "cubic"),
                           ("linear + cubic", "cubic, 1 RK4 step/sample"),
                           ("linear + cubic + quadratic", "cubic, 1 RK4 step/sample"),
                           ("linear + cubic + quadratic + cubic damping", "cubic, 1 RK4 step/sample"),
                           ("linear + cubic + quadratic + quintic", "cubic, 1 RK4 step/sample")] if (m, i) in sb],
            "tanks": [(f"grey-box {m}", tanks[m]) for m in tanks], "pendulum-freeswing": swing,
            "hare-lynx": [(f"grey-box {r['model']}", r) for r in data.get("hare_lynx", [])]}


def _markdown(results: dict, baselines: dict, method: str, n_jobs: int) -> str:
    md = [f"# Closing the loop (method={method!r}): residual -> missing term -> refit", "",
          "Rows: *before* = hybrid with the given science model; *after* = hybrid refitted with the terms "
          "the diagnosis added; *science only* = the augmented science model refitted without a network. "
          "`*_science_only_*` columns simulate the science part of each row alone; `network_share` = "
          "RMS(hybrid - science-only prediction) / RMS(hybrid prediction) on the test record; "
          "`network_share_rhs` = max over components of RMS(g) / (RMS(f) + RMS(g)) on the training states (RMS(g) / RMS(f + g) before issue 63). "
          f"Timings are wall-clock with n_jobs={n_jobs} (with 2, a second process scores the models on the "
          "test records while the first selects terms and refits); command: "
          f"`python benchmarks/measured/bench_closed_loop.py --n-jobs {n_jobs}`.", ""]
    for name, r in results.items():
        md += [f"## {name}", "", r["description"], "", r["report"], "",
               f"Fit + diagnosis + refit + evaluation: {r['seconds']:.0f} s.", ""]
        if name == "silverbox" and baselines.get("silverbox"):
            md += ["Grey-box baselines (bench_greybox.py, RMSE mV):", "",
                   "| model | test multisine | arrow full | arrow no-extrap. |", "|---|---|---|---|"]
            md += [f"| {label} | {b['test_multisine']:.3f} | {b['test_arrow_full']:.3f} | "
                   f"{b['test_arrow_no_extrapolation']:.3f} |" for label, b in baselines["silverbox"]]
            md.append("")
        if name == "tanks" and baselines.get("tanks"):
            md += ["Grey-box baselines (bench_greybox.py):", "", "| model | estimation | validation |", "|---|---|---|"]
            md += [f"| {label} | {b['estimation']:.3f} | {b['validation']:.3f} |" for label, b in baselines["tanks"]]
            md.append("")
        if name == "pendulum-freeswing" and baselines.get("pendulum-freeswing"):
            md += ["Grey-box baselines (bench_greybox.py, textbook friction laws fitted to one free run of the "
                   "first 3 s, RMSE mrad):", "", "| model | train | test |", "|---|---|---|"]
            md += [f"| {label} | {b['train']:.3f} | {b['test']:.3f} |" for label, b in baselines["pendulum-freeswing"]]
            md.append("")
        if name == "hare-lynx" and baselines.get("hare-lynx"):
            md += ["Grey-box baselines (bench_greybox.py, one free run fitted over 1900-1914, initial counts fitted "
                   "too, RMSE in thousands of pelts):", "", "| model | train | test |", "|---|---|---|"]
            md += [f"| {label} | {b['train']:.2f} | {b['test']:.2f} |" for label, b in baselines["hare-lynx"]]
            md.append("")
    return "\n".join(md)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cases", nargs="*", default=list(CASES), choices=list(CASES))
    parser.add_argument("--method", default="erm")
    parser.add_argument("--fast", action="store_true")
    parser.add_argument("--n-jobs", type=int, default=2, help="processes per case (a second one scores)")
    args = parser.parse_args()
    torch.set_num_threads(1)
    results = {}
    for name in args.cases:
        start = time.perf_counter()
        out = run_case(name, fast=args.fast, method=args.method, n_jobs=args.n_jobs, verbose=False)
        added = [{k: t[k] for k in ("output", "term", "kind", "coef", "param")} for t in out.added]
        steps = [{k: v for k, v in s.items() if k != "function"} for s in out.steps]
        results[name] = {"description": out.case.description, "table": out.table, "added": added,
                         "steps": steps, "report": out.report, "seconds": time.perf_counter() - start}
        print(f"== {name} ({results[name]['seconds']:.0f} s)\n{out.report}\n", flush=True)
    suffix = "_fast" if args.fast else ""
    tag = "" if set(args.cases) == set(CASES) else "_" + "_".join(c.replace("-", "") for c in args.cases)
    path = write_results(f"closed_loop{tag}{suffix}", {"method": args.method, "n_jobs": args.n_jobs,
                                                       "cases": results},
                         _markdown(results, _baselines(), args.method, args.n_jobs))
    print(path.read_text())


if __name__ == "__main__":
    main()
