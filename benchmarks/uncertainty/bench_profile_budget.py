"""Can a profile's members train less?  Its verdicts and intervals at shorter budgets, side by side.

Issue "The right answer in a minute" asks a profile to cost at most its fit.  A profile of p parameters
trains about 4 p + 1 members, then up to 6 per parameter near the crossings, each for at most as many
iterations as the fit took (the setting whose coverage ``bench_uncertainty.py`` measured); the stacked
members' iterations are arithmetic-bound (batched matrix products), so a cheaper profile has to train
fewer iterations.  Here each fit of the uncertainty study (``uncertainty/systems.py``, its protocol's
settings) is profiled three times in one process: members at most as many iterations as the fit
(``full``, today), half of them (``half``) and a quarter (``quarter``), with the same stopping rule.

Scored per budget: CPU seconds of the profile; entries called identified, and of those how many
intervals miss the truth; entries whose verdict differs from the full budget's.  A member trained too
little has not let the network take over what a held parameter does: its loss stays high, the profile
rises, and the verdict says "identified" where the full budget said the network trades with theta.

    python benchmarks/uncertainty/bench_profile_budget.py [--repeats 0 1 2] [--methods erm fsam]
    python benchmarks/uncertainty/bench_profile_budget.py --render

Each (system, repeat, method) is cached under ``results/runs/profile_budget/`` as soon as it ends.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # benchmarks/: the helpers, the studies' modules
from helpers import PACKAGE_COMMIT, machine_description, runs_folder, write_results  # noqa: E402
from uncertainty.protocol import SETTINGS  # noqa: E402
from uncertainty.systems import SYSTEMS  # noqa: E402

FOLDER = runs_folder("profile_budget")
BUDGETS = {"full": 1.0, "half": 0.5, "quarter": 0.25}
PROFILE = {"n_points": 5, "span": 0.5}  # bench_uncertainty's


def run_case(name: str, repeat: int, method: str) -> dict:
    import torch

    from sklearn_hybrid import HybridRegressor, OdeStructure
    from sklearn_hybrid.identifiability import profile_theta

    torch.set_num_threads(1)
    system = SYSTEMS[name]
    X, y, dt = system.make(repeat)
    est = HybridRegressor(science=system.science, structure=OdeStructure(dt=dt), method=method,
                          theta_init=system.theta_init, random_state=repeat, **SETTINGS).fit(X, y)
    record = {"system": name, "repeat": repeat, "method": method, "fit_iterations": est.n_iter_,
              "truth": system.theta_true, "package_commit": PACKAGE_COMMIT, "budgets": {}}
    for budget, share in BUDGETS.items():
        start = time.process_time()
        prof = profile_theta(est, X, y, max_iter=max(1, int(share * est.n_iter_)), **PROFILE)
        record["budgets"][budget] = {
            "cpu_s": time.process_time() - start, "member_iterations": prof.n_iter,
            "intervals": {k: list(v) for k, v in prof.intervals.items()}, "verdicts": dict(prof.verdicts)}
    return record


def run(systems, repeats, methods) -> None:
    FOLDER.mkdir(parents=True, exist_ok=True)
    for repeat in repeats:
        for name in systems:
            for method in methods:
                path = FOLDER / f"{name}_{method}_{repeat:02d}.json"
                if path.exists():
                    continue
                record = run_case(name, repeat, method)
                record["machine"] = machine_description()
                path.write_text(json.dumps(record, indent=1, default=float) + "\n")
                print(name, repeat, method, {b: (f"{r['cpu_s']:.1f} s", r["verdicts"])
                                             for b, r in record["budgets"].items()}, flush=True)


def render() -> None:
    records = [json.loads(p.read_text()) for p in sorted(FOLDER.glob("*.json"))]
    if not records:
        sys.exit("no runs yet")
    lines = ["# Can a profile's members train less?", "",
             f"{len(records)} fits of the uncertainty study's systems "
             f"({', '.join(sorted({r['system'] for r in records}))}; "
             f"methods {', '.join(sorted({r['method'] for r in records}))}; repeats "
             f"{', '.join(str(x) for x in sorted({r['repeat'] for r in records}))}), each profiled with its members "
             "trained at most a share of the fit's iterations (5 points, +/- 50 %, refined near the crossings). "
             "Entries: every profiled parameter of every fit.", "",
             "| members' budget | profile CPU s (sum) | of the full budget's | entries | called identified | "
             "of those missing the truth | verdicts unlike the full budget's |", "|---|---|---|---|---|---|---|"]
    full_cpu = sum(r["budgets"]["full"]["cpu_s"] for r in records)
    for budget, share in BUDGETS.items():
        cpu = sum(r["budgets"][budget]["cpu_s"] for r in records)
        entries = identified = missed = changed = 0
        for r in records:
            got, full = r["budgets"][budget], r["budgets"]["full"]
            for label, verdict in got["verdicts"].items():
                entries += 1
                changed += verdict != full["verdicts"][label]
                if verdict == "identified":
                    identified += 1
                    low, high = got["intervals"][label]
                    missed += not low <= r["truth"][label] <= high
        lines.append(f"| {budget} ({share:g} of the fit's iterations) | {cpu:.0f} | {cpu / full_cpu:.2f} | {entries} | "
                     f"{identified} | {missed} | {changed} |")
    lines += ["", "Reading: a verdict that changes with the members' budget is the budget's, not the data's; the "
              "profile keeps the full budget, whose coverage `bench_uncertainty.py` measured.", "",
              "Runs: `python benchmarks/uncertainty/bench_profile_budget.py --repeats "
              f"{' '.join(str(x) for x in sorted({r['repeat'] for r in records}))} --methods "
              f"{' '.join(sorted({r['method'] for r in records}))}` at package commit "
              f"{', '.join(sorted({r['package_commit'] for r in records}))}."]
    write_results("profile_budget", {"records": records}, "\n".join(lines))
    print("\n".join(lines))


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--systems", nargs="*", default=list(SYSTEMS), choices=list(SYSTEMS))
    parser.add_argument("--repeats", nargs="*", type=int, default=[0, 1, 2])
    parser.add_argument("--methods", nargs="*", default=["erm", "fsam"])
    parser.add_argument("--render", action="store_true", help="only write the results page")
    args = parser.parse_args(argv)
    if not args.render:
        run(args.systems, args.repeats, args.methods)
    render()


if __name__ == "__main__":
    main()
