"""The same physics in any units: the recommended path on six systems, each in eight unit systems.

Issue "Your units, your machine". Each system of ``units/systems.py`` (written for this benchmark, kept out of
the tests) is measured in its reference units (states and rates of order one) and in seven others: time and
state scales from 1e-3 to 1e3, alone and combined, one with every state in its own unit. The data are the
reference data converted, the science function the same code with its parameters' values converted, so each unit
system must give the same answer. The path is the README's:
``HybridRegressor(science=f, structure=OdeStructure(dt=dt)).fit(X, y)``, ``fit_report()``,
``close_the_loop(est, X, y, state_names=...)``.

Each run records the fit's verdict (usable or not), the hybrid's theta and the loop's final theta and intervals
converted back to the reference units, the terms the loop added, any error (its type: a bare numeric error
such as ``OverflowError`` is a failure of its own) and its CPU seconds. The page compares each unit system with
the reference run: the fit usable in both or neither, the same terms, the loop's theta within 1 % of the
reference's and (where the loop names the effect) within 5 % of the truth, the cost within 1.5 times.

    python benchmarks/units/bench_units.py [--systems ...] [--units ...] [--seeds 0] [--jobs 2] [--rerun]
    python benchmarks/units/bench_units.py --render

Each (system, unit system, seed) runs in its own process (fresh imports, its own CPU clock) and is cached
under ``results/runs/units/`` as soon as it ends.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # benchmarks/: the helpers, the studies' modules
from helpers import PACKAGE_COMMIT, cpu_seconds, machine_description, runs_folder, write_results  # noqa: E402

FOLDER = runs_folder("units")
SAME_THETA = 0.01  # a unit system's final theta within 1 % of the reference run's
TRUTH = 0.05  # and within 5 % of the truth where the loop names the effect
COST = 1.5  # CPU seconds within 1.5 times the reference run's
NUMERIC_ERRORS = ("OverflowError", "FloatingPointError", "ZeroDivisionError", "RuntimeWarning")


def _safe(name: str) -> str:
    return "".join(c if c.isalnum() else "_" for c in name).strip("_")


def _case_path(system: str, units: str, seed: int) -> Path:
    return FOLDER / system / f"{_safe(units)}_seed{seed}.json"


def run_one(system_name: str, units_name: str, seed: int) -> dict:
    """The recommended path on one system in one unit system, in this process; returns the record."""
    import torch

    from units.systems import SYSTEMS, UNIT_SYSTEMS, convert_back, make_data, science_in

    torch.set_num_threads(1)
    system, units = SYSTEMS[system_name], UNIT_SYSTEMS[units_name]
    X, y, dt = make_data(system, units, seed)
    record = {"system": system_name, "units": units_name, "seed": seed, "T": units.T,
              "S": units.state_factors(system).tolist(), "package_commit": PACKAGE_COMMIT,
              "machine": machine_description()}
    start = cpu_seconds()
    try:
        _path(system, units, X, y, dt, seed, record, convert_back, science_in)
    except Exception as error:  # noqa: BLE001 -- what the user meets is the result
        import traceback

        record.update(failed=f"{type(error).__name__}: {error}"[:600], error_type=type(error).__name__,
                      traceback=traceback.format_exc()[-3000:])
    record["cpu_s"] = cpu_seconds() - start
    return record


def _path(system, units, X, y, dt, seed, record, convert_back, science_in) -> None:
    import warnings

    from sklearn_hybrid import HybridRegressor, OdeStructure
    from sklearn_hybrid.diagnosis import close_the_loop

    from units.systems import test_states, true_rhs_in

    science = science_in(system, units)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        est = HybridRegressor(science=science, structure=OdeStructure(dt=dt), random_state=seed,
                              verbose=False).fit(X, y)
    report = est.fit_report()
    record.update(usable="NOT USABLE" not in report, fit_iterations=int(est.n_iter_),
                  fit_theta=convert_back(system, units, est.theta_), network_share=est.network_share_,
                  fit_warnings=sorted({type(w.message).__name__ for w in caught}))
    loop = close_the_loop(est, X, y, state_names=system.state_names)
    # the science's own parameters converted back; an added term's coefficients have no known dimension
    theta = convert_back(system, units, {k: v for k, v in loop.science_theta.items() if k in system.dims})
    record["added_theta"] = {k: float(np.ravel(v)[0]) for k, v in loop.science_theta.items() if k not in system.dims}
    # a flow (the term on two equations, +c on one, -c on the other) is one model whichever equation its
    # record names first: written with both, in a fixed order
    record["added"] = [f"{a.term} [{' <-> '.join(sorted([a.output, a.opposite_output]))}]" if a.opposite_output
                       else f"{a.term} [{a.output}]" for a in loop.added]
    record["loop_theta"] = theta
    record["theta_rel_err"] = {k: abs(theta[k] - v) / abs(v) for k, v in system.theta_true.items()}
    intervals = {}
    for k, v in system.theta_true.items():
        if k in getattr(loop.intervals, "verdicts", {}):
            one = convert_back(system, units, {k: 1.0})[k]
            low, high = sorted(float(b) * one for b in loop.intervals.intervals[k])
            intervals[k] = {"verdict": loop.intervals.verdicts[k], "interval": [low, high],
                            "holds": bool(low <= v <= high)}
    record["intervals"] = intervals
    # the final model's right-hand side against the truth on test states, relative to the missing effect
    import torch

    x = test_states(system, units, seed)
    final_science = loop.science if loop.science is not None else science
    with torch.no_grad():
        final = final_science(torch.as_tensor(x), **{k: torch.as_tensor(np.asarray(v, dtype=float))
                                                     for k, v in loop.science_theta.items()}).numpy()
    truth = true_rhs_in(system, units)(x)
    at_truth = science(torch.as_tensor(x), **{k: torch.tensor(v) for k, v in
                                              _converted(system, units).items()}).numpy()
    scale = np.linalg.norm(truth - at_truth) if not system.complete else np.linalg.norm(truth)
    record["rel_err"] = float(np.linalg.norm(final.reshape(truth.shape) - truth) / scale)


def _converted(system, units) -> dict:
    from units.systems import convert

    return convert(system, units, system.theta_true)


def _run_case(args) -> str:
    system, units, seed, rerun = args
    out = _case_path(system, units, seed)
    if out.exists() and not rerun:
        return f"{system} / {units} seed {seed}: cached"
    env = dict(os.environ, OMP_NUM_THREADS="1")
    done = subprocess.run([sys.executable, __file__, "--one", system, units, str(seed)], env=env,
                          capture_output=True, text=True, cwd=Path(__file__).parent)
    if done.returncode:
        return f"{system} / {units} seed {seed}: CRASHED\n{done.stderr[-2000:]}"
    record = json.loads(done.stdout.strip().splitlines()[-1])
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(json.dumps(record, indent=1, default=float) + "\n")
    what = record.get("failed") or f"usable {record['usable']}, added {record['added']}, " \
                                    f"theta {record['loop_theta']}"
    return f"{system} / {units} seed {seed}: {record['cpu_s']:.0f} CPU s, {what}"


def run_all(systems, units, seeds, jobs, rerun) -> None:
    """The reference unit system first (the others are compared with it), ``jobs`` processes at a time."""
    cases = [(s, u, seed, rerun) for seed in seeds for s in systems for u in units]
    cases.sort(key=lambda c: c[1] != "reference")
    with ThreadPoolExecutor(jobs) as pool:
        for line in pool.map(_run_case, cases):
            print(line, flush=True)


def _load() -> list[dict]:
    return [json.loads(p.read_text()) for p in sorted(FOLDER.glob("*/*.json"))]


def _compare(r: dict, ref: dict | None) -> dict:
    """The targets of one run against its system's reference run."""
    if "failed" in r or ref is None or "failed" in ref:
        return {}
    same_terms = sorted(r["added"]) == sorted(ref["added"])
    theta_gap = max(abs(r["loop_theta"][k] - ref["loop_theta"][k]) / abs(ref["loop_theta"][k])
                    for k in ref["loop_theta"] if k in r["loop_theta"] and k in r["theta_rel_err"])
    return {"same_verdict": r["usable"] == ref["usable"], "same_terms": same_terms, "theta_gap": theta_gap,
            "cost_ratio": r["cpu_s"] / ref["cpu_s"]}


def render() -> None:
    from units.systems import SYSTEMS, UNIT_SYSTEMS

    records = _load()
    if not records:
        print("no records yet")
        return
    refs = {(r["system"], r["seed"]): r for r in records if r["units"] == "reference"}
    order = list(UNIT_SYSTEMS)
    lines = ["# The same physics in any units", "",
             "The recommended path (fit, report, `close_the_loop`) on each system in its reference units and in "
             "seven others (`benchmarks/units/systems.py`); theta converted back to the reference units. "
             f"Targets against the reference run: the fit usable in both or neither, the same terms, the loop's "
             f"theta within {SAME_THETA:.0%} of the reference's, within {TRUTH:.0%} of the truth where the loop "
             f"names the effect, no bare numeric error, CPU within {COST} times.", "",
             "| system | units | T | S | usable | added | loop theta error (truth) | gap to reference | "
             "intervals held | rel_err | CPU s | cost ratio | targets met |", "|---" * 13 + "|"]
    met_all, counted = 0, 0
    for r in sorted(records, key=lambda r: (r["system"], r["seed"], order.index(r["units"])
                                            if r["units"] in order else 99)):
        ref = refs.get((r["system"], r["seed"]))
        c = _compare(r, ref)
        S = " / ".join(f"{v:g}" for v in r["S"])
        if "failed" in r:
            numeric = r.get("error_type") in NUMERIC_ERRORS
            lines.append(f"| {r['system']} | {r['units']} | {r['T']:g} | {S} | | failed: "
                         f"{r['failed'][:160].replace('|', '/')}{' (bare numeric error)' if numeric else ''} | | | | | "
                         f"{r['cpu_s']:.0f} | | no |")
            counted += r["units"] != "reference"
            continue
        err = max(r["theta_rel_err"].values())
        iv = r["intervals"].values()
        held = f"{sum(v['holds'] for v in iv)} of {len(iv)}"
        if r["units"] == "reference" or not c:
            met = ""
        else:
            named = bool(r["added"]) or SYSTEMS[r["system"]].complete
            ok = (c["same_verdict"] and c["same_terms"] and c["theta_gap"] <= SAME_THETA
                  and (err <= TRUTH or not named) and c["cost_ratio"] <= COST)
            met = "yes" if ok else "no"
            met_all += ok
            counted += 1
        gap = "" if not c else f"{c['theta_gap']:.2%}"
        ratio = "" if not c else f"{c['cost_ratio']:.2f}"
        lines.append(f"| {r['system']} | {r['units']} | {r['T']:g} | {S} | {'yes' if r['usable'] else 'NO'} | "
                     f"{'; '.join(r['added']) or 'nothing'} | {err:.3f} | {gap} | {held} | {r['rel_err']:.3f} | "
                     f"{r['cpu_s']:.0f} | {ratio} | {met} |")
    commits = sorted({r["package_commit"] for r in records})
    machines = sorted({r["machine"].get("cpu", "?") if isinstance(r["machine"], dict) else str(r["machine"])
                       for r in records})
    lines[4:4] = [f"Unit systems meeting every target: **{met_all} of {counted}**. Package commit(s): "
                  f"{', '.join(commits)}; machine(s): {'; '.join(machines)}. Made by "
                  "`python benchmarks/units/bench_units.py`.", ""]
    write_results("units", {"records": len(records), "met": met_all, "counted": counted}, "\n".join(lines) + "\n")


def main() -> None:
    from units.systems import SYSTEMS, UNIT_SYSTEMS

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--systems", nargs="+", default=list(SYSTEMS), choices=list(SYSTEMS))
    parser.add_argument("--units", nargs="+", default=list(UNIT_SYSTEMS), choices=list(UNIT_SYSTEMS))
    parser.add_argument("--seeds", nargs="+", type=int, default=[0])
    parser.add_argument("--jobs", type=int, default=2, help="processes at a time (one torch thread each)")
    parser.add_argument("--rerun", action="store_true", help="run cached cases again")
    parser.add_argument("--render", action="store_true", help="only write the page from the records")
    parser.add_argument("--one", nargs=3, metavar=("SYSTEM", "UNITS", "SEED"), help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.one:
        print(json.dumps(run_one(args.one[0], args.one[1], int(args.one[2])), default=float))
        return
    if not args.render:
        started = time.time()
        run_all(args.systems, args.units, args.seeds, args.jobs, args.rerun)
        print(f"{time.time() - started:.0f} s elapsed")
    render()


if __name__ == "__main__":
    main()
