"""Laplace intervals of theta (network integrated out) beside the profiles: coverage over repeated data sets.

Item 3 of issue "Is theta identified?": measure the Laplace approximation
over theta and the network jointly (``uncertainty/laplace_intervals.py``) beside the profile and
the bootstrap of ``bench_uncertainty.py``, and keep it only if it earns its
place.  The same systems, repeats, data, settings and seeds as
``bench_uncertainty.py``: every hybrid fit here is that benchmark's fit again
(the script checks theta equals the cached record's), so the Laplace interval
and the profile interval of one row come from the same fit.  Methods erm and
fsam (p-reg's penalty is part of its objective, not of the data's likelihood).

Each repeat is cached as ``results/runs/laplace/small/<system>/<repeat>.json``;
a rerun resumes.  ``--render`` writes ``results/laplace.md`` and ``.json``.

``--network default``: the package's default network and training (what the
Quick start fits; fsam only, no profile to compare with), on four of the
systems, cached in ``results/runs/laplace/default/``: does the Laplace step
hold with a network of about 17,000 weights instead of 1,200?  (The first 10
repeats of the small network were made with a dense version of the same
algebra, the rest with the eigendecomposition of ``uncertainty/laplace_intervals.py``, which holds
no matrix of the network's size; the two agree to the digits printed where
compared.)

    python benchmarks/uncertainty/bench_laplace.py              # all systems, 20 repeats
    python benchmarks/uncertainty/bench_laplace.py --network default --repeats 10
    python benchmarks/uncertainty/bench_laplace.py --render
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # benchmarks/: the helpers, the studies' modules
from helpers import PACKAGE_COMMIT, runs_folder, write_results  # noqa: E402
from uncertainty.protocol import RUNS, SETTINGS, member_row  # noqa: E402
from uncertainty.systems import SYSTEMS  # noqa: E402

METHODS = ("erm", "fsam")
LAPLACE_RUNS = runs_folder("laplace/small")
DEFAULT_RUNS = runs_folder("laplace/default")
DEFAULT_SYSTEMS = ("pendulum", "duffing", "heated_body", "damped_spring")


def run_default(repeats):
    """fsam at the package's defaults (one thread), Laplace after it."""
    import torch

    from uncertainty.laplace_intervals import laplace_theta
    from sklearn_hybrid import HybridRegressor, OdeStructure

    torch.set_num_threads(1)
    for repeat in range(repeats):
        for name in DEFAULT_SYSTEMS:
            path = DEFAULT_RUNS / name / f"{repeat:02d}.json"
            if path.exists():
                continue
            system = SYSTEMS[name]
            X, y, dt = system.make(repeat)
            start = time.perf_counter()
            est = HybridRegressor(science=system.science, structure=OdeStructure(dt=dt), method="fsam",
                                  theta_init=system.theta_init, random_state=repeat, n_threads=1,
                                  verbose=False).fit(X, y)
            fit_s = time.perf_counter() - start
            start = time.perf_counter()
            lap = laplace_theta(est, X, y)
            record = {"system": name, "repeat": repeat, "package_commit": PACKAGE_COMMIT, "methods": {"fsam": {
                "theta": {k: est.theta_[k] for k in system.theta_true}, "n_iter": est.n_iter_, "fit_s": fit_s,
                "intervals": {k: list(lap.intervals[k]) for k in system.theta_true},
                "verdicts": {k: lap.verdicts[k] for k in system.theta_true},
                "prior_precision": lap.prior_precision, "laplace_s": time.perf_counter() - start}}}
            path.parent.mkdir(parents=True, exist_ok=True)
            path.write_text(json.dumps(record, indent=1, default=float) + "\n")
            print(f"default network, {name} {repeat}: {record['methods']['fsam']['verdicts']}", flush=True)


def run_repeat(system, repeat):
    import torch

    from uncertainty.laplace_intervals import laplace_theta
    from sklearn_hybrid import HybridRegressor, OdeStructure

    torch.set_num_threads(1)
    X, y, dt = system.make(repeat)
    cached = json.loads((RUNS / system.name / f"{repeat:02d}.json").read_text())["methods"]
    out = {"system": system.name, "repeat": repeat, "package_commit": PACKAGE_COMMIT, "methods": {}}
    for method in METHODS:
        if "error" in cached[method]:
            out["methods"][method] = {"error": cached[method]["error"]}
            continue
        est = HybridRegressor(science=system.science, structure=OdeStructure(dt=dt), method=method,
                              theta_init=system.theta_init, random_state=repeat, **SETTINGS).fit(X, y)
        same = all(abs(est.theta_[k] - cached[method]["theta"][k]) <= 1e-6 * max(1, abs(est.theta_[k]))
                   for k in system.theta_true)
        start = time.perf_counter()
        lap = laplace_theta(est, X, y)
        out["methods"][method] = {"theta": {k: est.theta_[k] for k in system.theta_true}, "same_fit": same,
                                  "intervals": {k: list(lap.intervals[k]) for k in system.theta_true},
                                  "verdicts": {k: lap.verdicts[k] for k in system.theta_true},
                                  "prior_precision": lap.prior_precision,
                                  "laplace_s": time.perf_counter() - start,
                                  "fit_s": cached[method]["fit_s"], "profile_s": cached[method]["profile_s"],
                                  "profile": cached[method]["profile"]}
    return out


def run(systems, repeats):
    for repeat in range(repeats):
        for name in systems:
            path = LAPLACE_RUNS / name / f"{repeat:02d}.json"
            if path.exists() or not (RUNS / name / f"{repeat:02d}.json").exists():
                continue
            result = run_repeat(SYSTEMS[name], repeat)
            path.parent.mkdir(parents=True, exist_ok=True)
            path.write_text(json.dumps(result, indent=1, default=float) + "\n")
            print(f"{name} {repeat}: " + "; ".join(
                f"{m} {r.get('verdicts')} same fit {r.get('same_fit')}" for m, r in result["methods"].items()),
                flush=True)


def _laplace_row(system, method, label, true, got):
    as_profile = [{"theta": r["theta"], "fit_s": r["fit_s"], "profile_s": r["laplace_s"],
                   "profile": {label: {"interval": r["intervals"][label], "verdict": r["verdicts"][label]}}}
                  for r in got]
    return member_row(system, method, label, true, as_profile)


def render():
    rows, counts = [], {}
    for name, system in SYSTEMS.items():
        records = [json.loads(p.read_text()) for p in sorted((LAPLACE_RUNS / name).glob("*.json"))]
        counts[name] = len(records)
        for method in METHODS:
            got = [r["methods"][method] for r in records if "error" not in r["methods"][method]]
            if not got:
                continue
            for label, true in system.theta_true.items():
                for kind, row in (("laplace", _laplace_row(system, f"{method} laplace", label, true, got)),
                                  ("profile", member_row(system, f"{method} profile", label, true, got))):
                    row["kind"] = kind
                    rows.append(row)
    for name in DEFAULT_SYSTEMS:
        got = [json.loads(p.read_text())["methods"]["fsam"] for p in sorted((DEFAULT_RUNS / name).glob("*.json"))]
        for label, true in SYSTEMS[name].theta_true.items() if got else ():
            row = _laplace_row(SYSTEMS[name], "fsam laplace, default network", label, true, got)
            row["kind"] = "laplace, default network"
            rows.append(row)
    totals = {}
    for kind in ("laplace", "profile", "laplace, default network"):
        sel = [r for r in rows if r["kind"] == kind]
        if not sel:
            continue
        all_n = sum(r["n"] for r in sel)
        ident = sum(r["verdict_identified"] for r in sel)
        held = sum(round(r["coverage_identified"] * r["verdict_identified"]) for r in sel if r["verdict_identified"])
        misses = sum(round(r["miss_identified"] * r["n"]) for r in sel)
        absorb = [r for r in sel if r["expected_not_identified"]]
        totals[kind] = {"identified": ident, "held": held, "misses_called_identified": misses, "n": all_n,
                        "absorbable_not": sum(r["verdict_not"] for r in absorb),
                        "absorbable_n": sum(r["n"] for r in absorb)}
    lines = ["# Laplace intervals of theta beside the profiles", "",
             "Command: `python benchmarks/uncertainty/bench_laplace.py` then `--render`. The fits are "
             "`bench_uncertainty.py`'s, run again (same data, settings and seeds; `same fit` counts the repeats "
             "whose theta equals the cached record's). Machine: this project's 2-core CPU, shared.", "",
             f"Repeats per system: {counts}.", "",
             "| | identified | held the truth where identified | misses called identified (of all) "
             "| absorbable parameter called not identified |",
             "|---|---|---|---|---|"]
    for kind, t in totals.items():
        lines.append(f"| {kind} | {t['identified']} | {t['held']} of {t['identified']} "
                     f"({100 * t['held'] / max(t['identified'], 1):.0f} %) | {t['misses_called_identified']} "
                     f"of {t['n']} ({100 * t['misses_called_identified'] / max(t['n'], 1):.1f} %) | "
                     f"{t['absorbable_not']} of {t['absorbable_n']} |")
    lines += ["", "| system | method | param | n | mean rel. error | identified | coverage where identified "
              "| misses called identified | width / RMS error | seconds |", "|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        cov = "" if r["coverage_identified"] is None else f"{100 * r['coverage_identified']:.0f} %"
        width = "" if r["width_over_rms"] is None else f"{r['width_over_rms']:.2g}"
        lines.append(f"| {r['system']} | {r['method']} | {r['param']} | {r['n']} | {r['mean_rel_error']:.3f} | "
                     f"{r['verdict_identified']} | {cov} | {100 * r['miss_identified']:.0f} % | {width} | "
                     f"{r['seconds']:.1f} |")
    lines += ["", "Seconds: the fit plus the Laplace step (laplace rows) or the profile (profile rows)."]
    return "\n".join(lines) + "\n", {"rows": rows, "totals": totals, "counts": counts}


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--systems", nargs="*", default=list(SYSTEMS))
    parser.add_argument("--repeats", type=int, default=20)
    parser.add_argument("--render", action="store_true")
    parser.add_argument("--network", choices=("small", "default"), default="small")
    args = parser.parse_args(argv)
    if not args.render:
        run_default(args.repeats) if args.network == "default" else run(args.systems, args.repeats)
    text, data = render()
    write_results("laplace", data, text)
    print(text)


if __name__ == "__main__":
    main()
