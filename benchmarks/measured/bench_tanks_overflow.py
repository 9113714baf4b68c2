"""Cascaded tanks: what naming the overflow would give, and whether the loop's evidence could name it.

The closed loop adds nothing on the tanks (``results/closed_loop.md``), and ``results/tanks_windows.md``
bounds the evidence the lower tank's two overflow episodes can give. This script asks the question
from the other end, with the overflow law written by hand (an oracle the loop does not have):

1. *Worth*: the recipe's first hybrid fit (``tanks_case``: 64-sample windows, stride 32, erm, 200
   iterations) with three science models, scored by free runs of the estimation and validation
   records: plain Torricelli (the recipe's ``tanks_f``); the lower tank capped at 10 V; both tanks
   overflowing at 10 V with a fitted share ``k5`` of the upper tank's overflow falling into the lower
   one (the grey-box law of ``bench_greybox.py`` with its levels fixed at 10 V).
2. *Evidence*: the judge ``close_the_loop`` applies to a candidate (network-free refits on the
   training blocks, per-group validation errors, :func:`~sklearn_hybrid.diagnosis.evidence.evidence`),
   here applied to each overflow law against plain Torricelli, at the recipe's setting and a few others,
   with the upper tank's level at each window start from the lower tank's balance (the recipe) or
   fitted per window (``fit_initial_states``).

Usage: python benchmarks/measured/bench_tanks_overflow.py  (data: $SKLEARN_HYBRID_DATA or --data-home)
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np
import torch
from sklearn.base import clone

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # benchmarks/: the helpers, the studies' modules
from helpers import write_results  # noqa: E402
from sklearn_hybrid.diagnosis.evidence import evidence, held_out_splits  # noqa: E402
from sklearn_hybrid.diagnosis.science_fit import ScienceFit  # noqa: E402
from sklearn_hybrid.recipes import tanks_case, tanks_f  # noqa: E402

TOP = 10.0  # V: both tanks overflow at the top of the gauge's range (the record's maximum)


def tanks_cap_f(v, u, k1=4.0, k3=4.0, k4=4.0):
    """``tanks_f`` with the lower tank held at TOP while it would rise above it."""
    out = tanks_f(v, u, k1=k1, k3=k3, k4=k4)
    rise = torch.where((v[:, 1] >= TOP) & (out[:, 1] > 0), torch.zeros_like(out[:, 1]), out[:, 1])
    return torch.stack([out[:, 0], rise], dim=-1)


def tanks_overflow_f(v, u, k1=4.0, k3=4.0, k4=4.0, k5=0.5):
    """Both tanks overflow at TOP; a share ``k5`` of the upper tank's overflow falls into the lower."""
    r1, r2 = torch.sqrt(torch.clamp(v[:, 0], min=1e-4)), torch.sqrt(torch.clamp(v[:, 1], min=1e-4))
    d1 = -k1 * r1 + k4 * u[:, 0]
    spill = torch.where((v[:, 0] >= TOP) & (d1 > 0), d1, torch.zeros_like(d1))
    d2 = k1 * r1 - k3 * r2 + k5 * spill
    d2 = torch.where((v[:, 1] >= TOP) & (d2 > 0), torch.zeros_like(d2), d2)
    return torch.stack([d1 - spill, d2], dim=-1)


LAWS = {"plain Torricelli": tanks_f, "+ lower tank capped": tanks_cap_f, "+ both tanks overflow": tanks_overflow_f}
BOUNDS = {k: (0.0, 50.0) for k in ("k1", "k3", "k4")}
# (window, stride, blocks): the recipe's setting first, then the settings of results/tanks_windows.md
SETTINGS = [(64, 32, 4), (64, 64, 4), (128, 32, 3), (64, 32, None), (128, 16, None)]


def worth(data_home) -> list[dict]:
    """The recipe's first hybrid fit with each law, scored as the recipe scores it."""
    case, rows = tanks_case(data_home=data_home), []
    for name, law in LAWS.items():
        start = time.perf_counter()
        bounds = {**BOUNDS, "k5": (0.0, 1.0)} if law is tanks_overflow_f else BOUNDS
        est = clone(case.estimator).set_params(science=law, theta_bounds=bounds).fit(case.X, case.y)
        rows.append({"law": name, **case.test_scorer(est), "theta": {k: float(v) for k, v in est.theta_.items()},
                     "seconds": time.perf_counter() - start})
    return rows


def judged(window: int, stride: int, blocks: int | None, fit_states: bool, data_home) -> list[dict]:
    """Each overflow law against plain Torricelli, by the judge of ``close_the_loop``."""
    case = tanks_case(data_home=data_home, window=window, stride=stride)
    # the judge needs a fitted estimator only for its structure (grid, inputs, observed state)
    est = clone(case.estimator).set_params(max_iter=1).fit(case.X, case.y)
    fit = ScienceFit(est, case.X, case.y, fit_initial_states=fit_states)
    splits, codes = held_out_splits(len(case.X), 0.25, cv=blocks, groups=case.groups)
    errors = {}
    for name, law in LAWS.items():
        per_group = []
        for train, val in splits:
            theta = fit.subset(train).fit(law, {}, extra_bounds={"k5": (0.0, 1.0)})
            err, group = fit.subset(val).errors(law, theta), codes[val]
            per_group += [err[group == g].mean() for g in np.unique(group)]
        errors[name] = np.array(per_group)
    plain = errors.pop("plain Torricelli")
    return [{"window": window, "stride": stride, "blocks": blocks, "fit_initial_states": fit_states,
             "law": name, "n_groups": len(plain), **evidence(plain, err)} for name, err in errors.items()]


def markdown(worth_rows: list[dict], judge_rows: list[dict]) -> str:
    md = ["# Cascaded tanks: what naming the overflow would give, and whether the evidence could name it", "",
          __doc__.split("\n\n", 1)[1].split("\n\nUsage")[0], "",
          "## Worth: the recipe's hybrid with each law (free-run RMSE, V)", "",
          "| science model | estimation | validation | validation, science part alone | theta | s |",
          "|---|---|---|---|---|---|"]
    for r in worth_rows:
        theta = ", ".join(f"{k} {v:.3f}" for k, v in r["theta"].items())
        md.append(f"| {r['law']} | {r['estimation_rmse']:.3f} | {r['validation_rmse']:.3f} | "
                  f"{r['validation_science_only_rmse']:.3f} | {theta} | {r['seconds']:.0f} |")
    md += ["", "## Evidence: each law against plain Torricelli, judged as close_the_loop judges a term", "",
           "*judged on*: K contiguous blocks of groups (each predicted by a refit on the others) or, with none, "
           "the last quarter of the groups; a group is the non-overlapping stretch of the record a window starts in "
           "(the recipe's `groups`). Accepted when z exceeds the threshold and the gain is at least 5 %.", "",
           "| window / stride | judged on | upper level at a window's start | groups | law | gain | z | threshold | "
           "accepted |", "|---|---|---|---|---|---|---|---|---|"]
    for r in judge_rows:
        judged_on = f"{r['blocks']} blocks" if r["blocks"] else "last quarter"
        start = "fitted" if r["fit_initial_states"] else "balance"
        md.append(f"| {r['window']} / {r['stride']} | {judged_on} | {start} | {r['n_groups']} | {r['law']} | "
                  f"{100 * r['gain']:.0f}% | {r['z']:.2f} | {r['threshold']:.2f} | "
                  f"{'yes' if r['accepted'] else 'no'} |")
    return "\n".join(md)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--data-home", default=None)
    args = parser.parse_args()
    torch.set_num_threads(1)
    worth_rows = worth(args.data_home)
    for r in worth_rows:
        print(r["law"], round(r["validation_rmse"], 3), flush=True)
    judge_rows = []
    for window, stride, blocks in SETTINGS:
        for fit_states in (False, True):
            judge_rows += judged(window, stride, blocks, fit_states, args.data_home)
            print(judge_rows[-2:], flush=True)
    print(write_results("tanks_overflow", {"worth": worth_rows, "judged": judge_rows},
                        markdown(worth_rows, judge_rows)))


if __name__ == "__main__":
    main()
