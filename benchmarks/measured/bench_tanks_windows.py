"""Cascaded tanks: does the closed loop's evidence for the overflow depend on the window length?

The tanks recipe cuts the one 1024-sample estimation record into windows; the last quarter of
them judge each candidate term (``close_the_loop``'s validation samples). Longer windows let an
overflow act longer inside a window but leave fewer, and fewer validation windows need a larger
t statistic. For each (window, stride) this records the number of validation windows, the
threshold, the best candidates by gain with their z, the terms added and the free-run RMSE of
the validation record (before / after / science only). A second table gives, for each setting,
how many judged windows hold a visible overflow (the lower tank at its cap) and the largest z a
term acting only there could reach.

Usage: python benchmarks/measured/bench_tanks_windows.py [--settings 64/32 128/16 256/16 64/64/4 128/32/4]
(data: $SKLEARN_HYBRID_DATA or --data-home)
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
from pathlib import Path

import numpy as np
import torch

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # benchmarks/: the helpers, the studies' modules
from helpers import PACKAGE_COMMIT, RESULTS, as_run_today, selection_summary, write_results  # noqa: E402
from sklearn_hybrid.datasets import fetch_cascaded_tanks, make_windows  # noqa: E402
from sklearn_hybrid.diagnosis.evidence import critical_value  # noqa: E402
from sklearn_hybrid.recipes import run_case  # noqa: E402

CAP = 9.9  # the lower tank's level sits at the top of its range (10 V) while it overflows


def _run(window: int, stride: int, cv: int | None, fitted_states: bool, data_home) -> dict:
    out = run_case("tanks", cv=cv, grouped=False, fit_initial_states=fitted_states, window=window, stride=stride,
                   data_home=data_home)
    rows = {r["stage"]: r for r in out.table}
    return {"window": window, "stride": stride, "cv": cv, "fit_initial_states": fitted_states,
            "n_windows": len(out.case.y), **selection_summary(out),
            # the recipe's declared sensor offset, judged at every step until accepted
            "offset_steps": [{k: s[k] for k in ("step", "gain", "z", "accepted")} for s in out.steps
                             if s.get("kind") == "offset" and "gain" in s],
            "validation_rmse": {k: r.get("validation_rmse") for k, r in rows.items()},
            "seconds": out.seconds, "package_commit": PACKAGE_COMMIT,
            "command": "python " + " ".join(["benchmarks/measured/bench_tanks_windows.py", *sys.argv[1:]]),
            "date": time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime())}


# Runs stored before their records held the command and the date
_EARLIER = {"3b80ab2": ("`python benchmarks/measured/bench_tanks_windows.py`", "2026-11-24 20:37 UTC"),
            "5cf8863": ("`python benchmarks/measured/bench_tanks_windows.py --settings 64/32/f 128/16/f`",
                        "2026-11-24 22:57 UTC, two other jobs on the 2 cores"),
            "eb9feea": ("`python benchmarks/measured/bench_tanks_windows.py --settings 128/16/f 128/32/f 128/64/f`",
                        "2026-11-24 23:41 UTC, two other jobs on the 2 cores")}


def _commands(runs: list[dict]) -> str:
    """Each package commit's command and date, from the runs' records (or ``_EARLIER``)."""
    seen = {}
    for r in runs:
        c = r["package_commit"]
        seen.setdefault(c, (f"`{as_run_today(r['command'])}`", r["date"]) if "command" in r  # the path it runs at now
                        else _EARLIER.get(c, ("?", "?")))
    return "Rows by package commit: " + "; ".join(f"{c}: {cmd} ({date})" for c, (cmd, date) in seen.items()) + "."


def _markdown(runs: list[dict]) -> str:
    md = ["# Cascaded tanks: the closed loop's evidence against the window length and the kind of held-out judgement", "",
          "`python benchmarks/measured/bench_tanks_windows.py` (one process, one torch thread; another benchmark "
          "shared "
          "the machine's second core). Each row: `run_case('tanks', cv=..., grouped=False, window=..., "
          "stride=...)`; the last quarter "
          "of the windows judge each term (*last quarter*), or, with K blocks, every window, predicted by a "
          "refit without its block (`close_the_loop(..., cv=K)`); *threshold* is the t quantile a term's z must exceed (and a gain of "
          "at least 5 %); with a stride below the window length the windows overlap, their errors are "
          "correlated and z overstates the evidence. Validation RMSE (V) of free runs of the validation record: hybrid before, hybrid "
          "after (when a term was added), augmented science alone. Grey-box references "
          "(`results/greybox.md`): plain Torricelli 0.683, + sensor offset 0.672, + overflow 0.536, + overflow + "
          "sensor offset 0.472, + overflow + sensor offset + free tank-2 level 0.360. *offset(x2)*: the gain and z "
          "of the level gauge's offset, a candidate at every step (`offsets=['x2']`, rows from 03c1325 on). "
          "*initial x1*: the unobserved upper-tank level at each window's start, "
          "estimated from the lower tank's balance (the recipe) or fitted per window with the network-free "
          "refits (`fit_initial_states=True`; the hybrid refit then starts from the fitted levels).", "",
          "| window / stride | judged on | initial x1 | windows | threshold | best first-step candidates: gain (z) | "
          "offset(x2) by step: gain (z) | added | validation before | after | science only | s | package commit |",
          "|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in runs:
        best = "; ".join(f"{b['term']} on {b['output']}: {b['gain']:.0%} ({b['z']:.1f})"
                         for b in r["best_first_step"]).replace("|", "\\|")
        v = r["validation_rmse"]

        def fmt(x):
            return "-" if x is None else f"{x:.3f}"

        added = ", ".join(r["added"]).replace("|", "\\|") or "nothing"
        thr = "-" if r["threshold"] is None else f"{r['threshold']:.2f}"
        split = "last quarter" if r.get("cv") is None else f"{r['cv']} blocks"
        x1 = "fitted" if r.get("fit_initial_states") else "balance"
        offset = "; ".join(f"{o['step']}: {o['gain']:.0%} ({o['z']:.1f})" for o in r.get("offset_steps", [])) or "-"
        md.append(f"| {r['window']} / {r['stride']} | {split} | {x1} | {r['n_windows']} | {thr} | {best} | "
                  f"{offset} | {added} | {fmt(v.get('before'))} | {fmt(v.get('after'))} | "
                  f"{fmt(v.get('science only'))} | {r['seconds']:.0f} | {r['package_commit']} |")
    md += ["", _commands(runs)]
    return "\n".join(md)


def _episodes(y: np.ndarray) -> list[tuple[int, int]]:
    """(first, last) sample of every run of the lower tank's level at its cap (the visible overflow)."""
    hit = np.r_[False, y >= CAP, False].astype(int)
    edges = np.flatnonzero(np.diff(hit))
    return [(int(a), int(b) - 1) for a, b in zip(edges[::2], edges[1::2])]


def _reach(runs: list[dict], data_home) -> list[str]:
    """How much held-out evidence the visible overflow can give each setting, whatever the term.

    A term that acts only in the k judged windows that hold an overflow, and changes nothing in the
    other n - k, gives a t statistic of exactly sqrt(k (n - 1) / (n - k)) on the windows' error
    ratios, however much it helps there (the ratios are r on k windows and 0 elsewhere; r cancels).
    """
    data = fetch_cascaded_tanks(data_home)
    y = data.y_est
    episodes = _episodes(y)
    md = ["", "## How much evidence the overflow can give", "",
          f"The lower tank sits at its cap (y >= {CAP} V) in {len(episodes)} episodes of the estimation record: "
          + ", ".join(f"samples {a}-{b}" for a, b in episodes) + ". Windows holding the same episode "
          "share one event; the upper tank's level is not measured, and its own overflow may act in windows "
          "this table does not count. *z reachable*: the t statistic of a term that acts only in the judged windows "
          "holding an overflow and changes no other window, sqrt(k (n - 1) / (n - k)) for k of n judged "
          "windows, whatever its gain there; with noise in the other windows it is lower.", "",
          "| window / stride | judged on | judged windows n | holding an overflow k | episodes among them | "
          "z reachable | threshold |", "|---|---|---|---|---|---|---|"]
    for window, stride, cv in sorted({(r["window"], r["stride"], r.get("cv")) for r in runs},
                                     key=lambda setting: (setting[0], setting[1], setting[2] or 0)):
        # the recipe's windows: window s holds samples s, ..., s + window
        starts = make_windows(y, data.u_est, length=window, stride=stride, stop=len(y) - 1).starts
        n_val = len(starts) if cv else int(np.clip(round(0.25 * len(starts)), 2, len(starts) - 2))
        judged = starts[len(starts) - n_val:]
        touched = [[i for i, (a, b) in enumerate(episodes) if s <= b and a <= s + window] for s in judged]
        k = sum(bool(t) for t in touched)
        reach = "inf" if k == n_val else f"{math.sqrt(k * (n_val - 1) / (n_val - k)):.2f}"
        split = "last quarter" if cv is None else f"{cv} blocks"
        md.append(f"| {window} / {stride} | {split} | {n_val} | {k} | {len({e for t in touched for e in t})} | "
                  f"{reach} | {critical_value(3.0, n_val):.2f} |")
    return md


def _key(run: dict) -> tuple:  # a rerun replaces a run of the same setting and package commit only
    return (run["window"], run["stride"], run.get("cv"), bool(run.get("fit_initial_states")),
            run["package_commit"])


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--settings", nargs="+", default=["64/32", "128/16", "256/16", "64/64/4", "128/32/4"],
                        help="window/stride, or window/stride/K for K-fold blocked cross-validated evidence; "
                             "a trailing /f fits the windows' initial upper-tank levels (close_the_loop's "
                             "fit_initial_states) instead of estimating them from the lower tank's balance. "
                             "Runs of other settings or package commits already in results/tanks_windows.json "
                             "are kept.")
    parser.add_argument("--data-home", default=None)
    parser.add_argument("--render", action="store_true", help="only rewrite the table from results/tanks_windows.json")
    args = parser.parse_args()
    if args.render:
        runs = json.loads((RESULTS / "tanks_windows.json").read_text())["runs"]
        text = (RESULTS / "tanks_windows.md").read_text()
        md = "\n".join([_markdown(runs), *_reach(runs, args.data_home)])
        (RESULTS / "tanks_windows.md").write_text(md + text[text.index("\n\nMachine:"):])
        return
    torch.set_num_threads(1)
    path = RESULTS / "tanks_windows.json"
    runs = json.loads(path.read_text())["runs"] if path.exists() else []
    for setting in args.settings:
        parts = setting.split("/")
        fitted = parts[-1] == "f"
        window, stride, *cv = (int(v) for v in parts[:len(parts) - fitted])
        run = _run(window, stride, cv[0] if cv else None, fitted, args.data_home)
        runs = [r for r in runs if _key(r) != _key(run)] + [run]
        print(run, flush=True)
    path = write_results("tanks_windows", {"runs": runs}, "\n".join([_markdown(runs), *_reach(runs, args.data_home)]))
    print(path.read_text())


if __name__ == "__main__":
    main()
