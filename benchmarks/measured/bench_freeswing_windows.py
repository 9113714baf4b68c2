"""Real pendulum free swing: is the friction still named when the judged windows do not overlap?

The recipe cuts the 3 s of training into 50-sample windows with a stride of 5 samples: 50 windows
that overlap ten-fold (judged by groups since 2026-11-25, the last setting below), so that the
held-out errors of neighbouring windows are nearly the same numbers and a t statistic over them
overstates the evidence (and judged windows share samples with training windows). Here the same case
runs with other strides and with blocked cross-validated evidence (``cv=K``: every window judged by
a refit without its block); with a stride of 50 the five windows share no sample. A trailing ``g``
judges the windows by groups (``run_case(grouped=True)``: the non-overlapping stretch each starts
in; every overlapping window is fitted, each group's mean error counts once). Each row: the first
step's best candidates with their gain and z, the threshold z had to exceed, the terms added and the
free-run test RMSE.

Usage: python benchmarks/measured/bench_freeswing_windows.py [--settings 50/5 50/5/5 50/25/5 50/50/2 50/5/2g]
(data: $SKLEARN_HYBRID_DATA or --data-home)
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import torch

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # benchmarks/: the helpers, the studies' modules
from helpers import PACKAGE_COMMIT, selection_summary, write_results  # noqa: E402
from sklearn_hybrid.recipes import run_case  # noqa: E402


def _run(window: int, stride: int, cv: int | None, grouped: bool, data_home) -> dict:
    out = run_case("pendulum-freeswing", cv=cv, grouped=grouped, window=window, stride=stride,
                   data_home=data_home)
    rows = {r["stage"]: r for r in out.table}
    return {"window": window, "stride": stride, "cv": cv, "grouped": grouped, "n_windows": len(out.case.y),
            **selection_summary(out, ("term", "gain", "z")),
            "test_rmse_mrad": {k: r.get("test_rmse_mrad") for k, r in rows.items()},
            "seconds": out.seconds, "package_commit": PACKAGE_COMMIT}


def _markdown(runs: list[dict]) -> str:
    md = ["# Real pendulum free swing: the friction's evidence against the overlap of the judged windows", "",
          "`run_case('pendulum-freeswing', window=..., stride=..., cv=...)`, one process, one torch thread. "
          "*judged on*: the last quarter of the windows (the recipe until 2026-11-25), or every window with K "
          "blocks (`cv=K`); *by group*: each non-overlapping stretch's windows judged together, by their mean "
          "error (`grouped=True`; the recipe now: 50 / 5, 2 blocks, by group). *overlap*: how many windows cover "
          "a sample (window / stride). Test: RMSE (mrad) of a free run over the 3.5 s after training; grey-box "
          "Coulomb friction (`results/greybox.md`) 3.754, "
          "frictionless 15.161.", "",
          "| window / stride | overlap | judged on | windows | threshold | best first-step candidates: gain (z) | "
          "added | test before | after | science only | s |", "|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in runs:
        best = "; ".join(f"{b['term']}: {b['gain']:.0%} ({b['z']:.1f})" for b in r["best_first_step"])
        t = r["test_rmse_mrad"]

        def fmt(x):
            return "-" if x is None else f"{x:.3f}"

        split = "last quarter" if r["cv"] is None else f"{r['cv']} blocks"
        split += ", by group" if r.get("grouped") else ""
        md.append(f"| {r['window']} / {r['stride']} | {r['window'] / r['stride']:g} | {split} | {r['n_windows']} | "
                  f"{r['threshold']:.2f} | {best.replace('|', chr(92) + '|')} | "
                  f"{', '.join(r['added']).replace('|', chr(92) + '|') or 'nothing'} | {fmt(t.get('before'))} | "
                  f"{fmt(t.get('after'))} | {fmt(t.get('science only'))} | {r['seconds']:.0f} |")
    return "\n".join(md)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--settings", nargs="+", default=["50/5", "50/5/5", "50/25/5", "50/50/2", "50/5/2g"],
                        help="window/stride, or window/stride/K for K-fold blocked cross-validated evidence; "
                             "a trailing g judges by groups")
    parser.add_argument("--data-home", default=None)
    args = parser.parse_args()
    torch.set_num_threads(1)
    runs = []
    for setting in args.settings:
        grouped = setting.endswith("g")
        window, stride, *cv = (int(v) for v in setting.rstrip("g").rstrip("/").split("/"))
        runs.append(_run(window, stride, cv[0] if cv else None, grouped, args.data_home))
        print(runs[-1], flush=True)
    print(write_results("freeswing_windows", {"runs": runs}, _markdown(runs)).read_text())


if __name__ == "__main__":
    main()
