"""The closed loop on long records: CPU seconds of the selection, against a kept copy of the old code.

Issue "The right answer in a minute": ``close_the_loop`` on 6 trajectories of 1,500 steps spent
816 of 840 CPU seconds in the selection's network-free refits, each integrating every record step
by step.  Here: an oscillator whose science model lacks its damping (``x'' = -k x``, truth
``-1.5 x - 0.1 x'``, a system of this benchmark's own), 6 records of 1,500 steps at dt = 0.1 with
noise 0.01; the hybrid is fitted once per process with a small budget (erm, a 32x32 network on the
acceleration, 30 iterations, 4 RK4 steps per interval: the same fit in both codes), then
``close_the_loop(est, X, y)`` is timed (``time.process_time``).  Each code runs in its own process:

    python benchmarks/speed/bench_long_record.py                       # the package of this checkout
    python benchmarks/speed/bench_long_record.py --package ../old      # a checkout of the old code
    python benchmarks/speed/bench_long_record.py --package ../prev --label bf8d06e  # another commit, its own row
    python benchmarks/speed/bench_long_record.py --control             # the same records, nothing missing
    python benchmarks/speed/bench_long_record.py --render

``--control`` gives the science its damping (``x'' = -k x - c x'``), so nothing is missing: on such a long
record an audit saw the loop add ``sign(x_dot)`` at a tiny coefficient (its held-out gain passed the test,
which sharpens with the record's length) and then withheld every interval.  Its row says what the loop adds
(target: nothing) and whether each interval holds the truth.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # benchmarks/: the helpers, the studies' modules
from helpers import machine_description, rk4_trajectories, runs_folder, write_results  # noqa: E402
from speed.time_to_answer_systems import interval_verdicts  # noqa: E402

FOLDER = runs_folder("long_record")
N_RECORDS, N_STEPS, DT, NOISE = 6, 1500, 0.1, 0.01
TRUTH = {"k": 1.5, "c_x_dot": -0.1}


def simulate(seed: int = 0):
    rng = np.random.default_rng(seed)
    X = rng.uniform(-1, 1, (N_RECORDS, 2))
    y = rk4_trajectories(lambda s: np.stack([s[:, 1], -1.5 * s[:, 0] - 0.1 * s[:, 1]], -1), X, DT, N_STEPS,
                         substeps=16)
    return X, y + NOISE * rng.standard_normal(y.shape)


def oscillator_f(v, k=1.0):
    import torch

    return torch.stack([v[:, 1], -k * v[:, 0]], -1)


def damped_oscillator_f(v, k=1.0, c=0.0):
    import torch

    return torch.stack([v[:, 1], -k * v[:, 0] - c * v[:, 1]], -1)


#: the control's truth, in the damped science's parameters
CONTROL_TRUTH = {"k": 1.5, "c": 0.1}


def run_one(control: bool = False) -> dict:
    import torch

    import sklearn_hybrid
    from sklearn_hybrid import HybridRegressor
    from sklearn_hybrid.diagnosis import MLPOn, close_the_loop

    torch.set_num_threads(1)
    X, y = simulate()
    start = time.process_time()
    science = damped_oscillator_f if control else oscillator_f
    # flat dt kept: --package runs this on the old code (78165d5), whose HybridRegressor takes no OdeStructure
    est = HybridRegressor(science=science, dt=DT, method="erm", max_iter=30, n_substeps=4,
                          residual=MLPOn([1], hidden=(32, 32)), random_state=0, verbose=False).fit(X, y)
    fitted = time.process_time()
    res = close_the_loop(est, X, y, state_names=["x", "x_dot"])
    done = time.process_time()
    theta = {k: float(v) for k, v in res.science_theta.items() if np.ndim(v) == 0}
    truth = CONTROL_TRUTH if control else TRUTH
    root = Path(sklearn_hybrid.__file__).parents[1]
    commit = subprocess.run(["git", "log", "-1", "--format=%h", "--", "sklearn_hybrid"], capture_output=True,
                            text=True, cwd=root).stdout.strip()
    return {"package": str(root), "package_commit": commit, "fit_cpu_s": fitted - start, "loop_cpu_s": done - fitted,
            "loop_timings": res.get("timings"), "added": [f"{t['term']} [{t['output']}]" for t in res.added],
            "theta": theta, "theta_rel_err": {k: abs(theta.get(k, np.nan) - v) / abs(v) for k, v in truth.items()},
            "intervals": interval_verdicts(res.intervals, truth), "control": control,
            "conditional": dict(getattr(res.intervals, "conditional", {})),
            "windows": "windows of" in res.report, "machine": machine_description()}


def render() -> None:
    every = {p.stem: json.loads(p.read_text()) for p in sorted(FOLDER.glob("*.json"))}
    records = {name: r for name, r in every.items() if not r.get("control")}
    controls = {name: r for name, r in every.items() if r.get("control")}
    lines = ["# The closed loop on long records", "",
             f"{N_RECORDS} records of {N_STEPS} steps (dt {DT}, noise {NOISE}) of an oscillator whose science lacks "
             "its damping (truth k = 1.5, c = -0.1 x_dot); the hybrid fitted once per process (erm, 32x32 network on "
             "the acceleration, 30 iterations); `close_the_loop(est, X, y)` timed in CPU seconds of its process. "
             "The new code fits and judges the candidates on windows of 25 steps (`Evidence(window='auto')`), each "
             "started from the record smoothed there (since 7ed13e7; from the raw measurement before, a start whose "
             "noise rewarded a candidate that damps it away), and refits the chosen model on the whole records.", "",
             "| code | package commit | loop CPU s | of which selection | fit CPU s | added | k | c_x_dot | windows "
             "| CPU |",
             "|---|---|---|---|---|---|---|---|---|---|"]
    for name, r in records.items():
        sel = (r.get("loop_timings") or {}).get("selection")
        lines.append(f"| {name} | {r['package_commit']} | {r['loop_cpu_s']:.0f} | "
                     f"{'' if sel is None else f'{sel:.0f}'} | {r['fit_cpu_s']:.0f} | "
                     f"{'; '.join(r['added']) or 'nothing'} | {r['theta'].get('k', float('nan')):.4f} | "
                     f"{r['theta'].get('c_x_dot', float('nan')):.4f} | {'yes' if r['windows'] else 'no'} | "
                     f"{r['machine']['cpu']} |")
    if {"old", "new"} <= set(records):
        ratio = records["old"]["loop_cpu_s"] / records["new"]["loop_cpu_s"]
        lines += ["", f"The old code's loop takes {ratio:.1f} times the new one's CPU seconds on the same records "
                  "(each in a fresh process of one run of this script). Target: at most 60 CPU s."]
    for name in sorted(set(records) - {"old", "new"}):
        if "new" in records:
            lines.append(f"The loop {name} takes {records[name]['loop_cpu_s'] / records['new']['loop_cpu_s']:.1f} times "
                         "the new one's CPU seconds.")
    if controls:
        lines += ["", "## Nothing missing", "",
                  "`python benchmarks/speed/bench_long_record.py --control`: the same records, the science given its "
                  "damping (`x'' = -k x - c x'`, truth k = 1.5, c = 0.1): the "
                  "loop should add nothing and its intervals should hold the truth.", "",
                  "| code | package commit | loop CPU s | added | k | c | intervals | CPU |",
                  "|---|---|---|---|---|---|---|---|"]
        for name, r in controls.items():
            intervals = "; ".join(f"{k} [{v['interval'][0]:.5g}, {v['interval'][1]:.5g}] {v['verdict']}, "
                                  f"{'holds' if v['holds'] else 'misses'}" for k, v in r["intervals"].items())
            lines.append(f"| {name} | {r['package_commit']} | {r['loop_cpu_s']:.0f} | "
                         f"{'; '.join(r['added']) or 'nothing'} | {r['theta'].get('k', float('nan')):.4f} | "
                         f"{r['theta'].get('c', float('nan')):.4f} | {intervals or 'none'} | {r['machine']['cpu']} |")
        for name, r in controls.items():
            lines += [f"- {name}, {k} conditional: {why}" for k, why in r.get("conditional", {}).items()]
    lines += ["", "Each row's CPU is the machine that made its record; the line below names the one that wrote "
              "this page."]
    write_results("long_record", {"records": every}, "\n".join(lines))
    print("\n".join(lines))


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--package", default=None, help="a checkout of the old code (recorded as 'old')")
    parser.add_argument("--label", default=None, help="with --package: the record's name instead of 'old'")
    parser.add_argument("--control", action="store_true",
                        help="the science given its damping: nothing missing (recorded as 'control')")
    parser.add_argument("--render", action="store_true")
    parser.add_argument("--one", action="store_true", help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.one:
        print(json.dumps(run_one(args.control), default=float))
        return
    if not args.render:
        env = dict(os.environ, OMP_NUM_THREADS="1")
        if args.package:
            env["PYTHONPATH"] = str(Path(args.package).resolve()) + os.pathsep + env.get("PYTHONPATH", "")
        done = subprocess.run([sys.executable, __file__, "--one", *(["--control"] if args.control else [])], env=env,
                              capture_output=True, text=True,
                              cwd=Path(__file__).parent)
        if done.returncode:
            sys.exit(done.stderr[-3000:])
        FOLDER.mkdir(parents=True, exist_ok=True)
        name = (args.label or "old") if args.package else "new"
        name = f"control_{name}" if args.control else name
        (FOLDER / f"{name}.json").write_text(done.stdout.strip().splitlines()[-1] + "\n")
    render()


if __name__ == "__main__":
    main()
