"""Time to theta: CPU seconds and theta error of a default fit on three small systems.

A new user writes ``HybridRegressor(science=f, structure=OdeStructure(dt=dt)).fit(X, y)`` and waits.
This measures, on three systems of two states written for this benchmark (``speed/time_to_theta_systems.py``:
population dynamics, an electric circuit, a chemical reactor; 30-50 trajectories of 15-20 steps), the CPU
seconds of that fit (``time.process_time``, one torch thread) and its theta error (RMS relative
error against the true theta), with today's defaults and with candidate defaults.  Target of
issue 41: at most 60 s of CPU per fit, theta no worse than today's defaults.

Each fit's result is cached in ``results/runs/time_to_theta/`` as soon as it ends, so a run that is
stopped resumes where it was.

Usage: python benchmarks/speed/bench_time_to_theta.py [--seeds 2] [--settings default proposed substeps2]
"""

from __future__ import annotations

import argparse
import inspect
import json
import os
import sys
import time
from pathlib import Path

import numpy as np
import torch

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # benchmarks/: the helpers, the studies' modules
from helpers import PACKAGE_COMMIT, runs_folder, write_results  # noqa: E402
from speed.time_to_theta_systems import SYSTEMS, simulate  # noqa: E402
from sklearn_hybrid import HybridRegressor, OdeStructure  # noqa: E402

#: ``verbose=False`` everywhere: the progress bar is not what is timed (and costs nothing measurable).
SETTINGS = {
    "default": {},
    # half the RK4 steps per output interval and a 64x64 network: about a third of the cost per iteration
    "proposed": {"n_substeps": 2, "residual": {"hidden": (64, 64)}},
    # half the RK4 steps only (the network as by default): the larger part of the saving
    "substeps2": {"n_substeps": 2},
}
RUNS = runs_folder("time_to_theta")


def relative_error(theta: dict, truth: dict) -> float:
    return float(np.sqrt(np.mean([((theta[k] - v) / v) ** 2 for k, v in truth.items()])))


def run(system_name: str, setting: str, seed: int) -> dict:
    system = SYSTEMS[system_name]
    X, y = simulate(system, seed)
    settings = dict(SETTINGS[setting])
    ode = {k: settings.pop(k) for k in ("n_substeps",) if k in settings}  # the structure's options
    est = HybridRegressor(science=system.science, structure=OdeStructure(dt=system.dt, **ode), random_state=seed,
                          verbose=False, **settings)
    load = os.getloadavg()[0]
    cpu, wall = time.process_time(), time.perf_counter()
    est.fit(X, y)
    cpu, wall = time.process_time() - cpu, time.perf_counter() - wall
    start = {k: p.default for k, p in inspect.signature(system.science).parameters.items()
             if k in system.theta_true}
    return {"system": system_name, "setting": setting, "seed": seed, "cpu_s": cpu, "wall_s": wall,
            "n_iter": int(est.n_iter_), "stopped_early": bool(est.stopped_early_),
            "ms_per_iter": 1000 * cpu / est.n_iter_,
            "theta": {k: float(v) for k, v in est.theta_.items()}, "theta_true": system.theta_true,
            "theta_start": start, "theta_error": relative_error(est.theta_, system.theta_true),
            "package_commit": PACKAGE_COMMIT,
            "shape": list(y.shape), "load_before": load}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=2)
    parser.add_argument("--settings", nargs="+", default=list(SETTINGS), choices=list(SETTINGS))
    args = parser.parse_args()
    torch.set_num_threads(1)
    RUNS.mkdir(parents=True, exist_ok=True)
    rows = []
    for seed in range(args.seeds):
        for name in SYSTEMS:
            for setting in args.settings:
                path = RUNS / f"{name}_{setting}_seed{seed}.json"
                if path.exists():
                    rows.append(json.loads(path.read_text()))
                    continue
                row = run(name, setting, seed)
                path.write_text(json.dumps(row, indent=1) + "\n")
                print({k: row[k] for k in ("system", "setting", "seed", "cpu_s", "n_iter", "theta_error")},
                      flush=True)
                rows.append(row)
    write_results("time_to_theta", {"settings": SETTINGS, "runs": rows}, markdown(rows, args.seeds))


def markdown(rows: list, n_seeds: int) -> str:
    lines = [f"# Time to theta: a default fit on three small systems ({n_seeds} seed(s))", "",
             "CPU seconds (`time.process_time`, one torch thread) of `HybridRegressor(science=f, "
             "structure=OdeStructure(dt=dt), random_state=seed).fit(X, y)` and its theta error (RMS relative "
             "error against the true theta). "
             "Target: at most 60 s of CPU, theta no worse than today's defaults.", "",
             "Settings: " + "; ".join(f"`{k}`: {v or 'the defaults of HybridRegressor'}"
                                      for k, v in SETTINGS.items()), "",
             "Theta starts at the science function's defaults, 25-35 % from the truth: *start error* is the theta "
             "error of doing nothing.", "",
             "| system | shape (n, steps, states) | setting | seed | CPU s | iterations | stopped early | "
             "ms CPU / iteration | theta | theta error | start error |", "|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in sorted(rows, key=lambda r: (r["system"], r["setting"], r["seed"])):
        theta = ", ".join(f"{k} {v:.4g} (true {r['theta_true'][k]:g})" for k, v in r["theta"].items())
        lines.append(f"| {r['system']} | {tuple(r['shape'])} | {r['setting']} | {r['seed']} | {r['cpu_s']:.1f} | "
                     f"{r['n_iter']} | {'yes' if r['stopped_early'] else 'no'} | {r['ms_per_iter']:.1f} | {theta} | "
                     f"{r['theta_error']:.4f} | {relative_error(r['theta_start'], r['theta_true']):.4f} |")
    lines += ["", "| setting | mean CPU s | max CPU s | fits within 60 s | mean iterations | mean ms CPU / iteration | "
              "mean theta error |", "|---|---|---|---|---|---|---|"]
    for setting in dict.fromkeys(r["setting"] for r in rows):
        sel = [r for r in rows if r["setting"] == setting]
        cpu = [r["cpu_s"] for r in sel]
        lines.append(f"| {setting} | {np.mean(cpu):.1f} | {max(cpu):.1f} | {sum(c <= 60 for c in cpu)} of {len(sel)} | "
                     f"{np.mean([r['n_iter'] for r in sel]):.0f} | {np.mean([r['ms_per_iter'] for r in sel]):.1f} | "
                     f"{np.mean([r['theta_error'] for r in sel]):.4f} |")
    commits = {}
    for r in rows:
        commits.setdefault(r["setting"], set()).add(r.get("package_commit", "unknown"))
    lines += ["", "Package commit of each setting's runs (cached runs keep the commit they ran at): "
              + "; ".join(f"{k} {', '.join(sorted(v))}" for k, v in commits.items()) + "."]
    lines += ["", "The arithmetic: CPU seconds = iterations x ms per iteration.  Early stopping ends these fits after "
              "most of `max_iter` (2,000), so the cost per iteration decides; with the defaults it is "
              "samples x steps x `n_substeps` (4) RK4 steps of 4 evaluations, forward and backward, doubled by "
              "fsam's second gradient, dominated by the 128x128 layer of the default network."]
    return "\n".join(lines)


if __name__ == "__main__":
    main()
