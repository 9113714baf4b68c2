"""Seconds of the README's Quick start: the fit, its report, the closed loop on that fit; and the profile.

Issue "The right answer in a minute": the Quick start path (``sklearn_hybrid.demo``: fit, ``fit_report()``
with its first screen, ``close_the_loop`` on the same fit) step by step, each timed with
``time.process_time`` (CPU seconds of this process, all its threads) and ``time.perf_counter`` (wall
clock), with torch at the package's default thread count; then the README's second block, the profile of
the fit's omega (optional on the path, timed beside it).  Each repeat is a fresh process state but the
same data and seeds, so the spread is the machine's.

    python benchmarks/speed/bench_quickstart.py [--repeats 2]
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # benchmarks/: the helpers, the studies' modules
from helpers import write_results  # noqa: E402


def one_run():
    from sklearn_hybrid import HybridRegressor, OdeStructure
    from sklearn_hybrid.datasets import make_pendulum
    from sklearn_hybrid.demo import pendulum_f
    from sklearn_hybrid.diagnosis import close_the_loop
    from sklearn_hybrid.identifiability import profile_theta

    steps, marks = {}, (time.process_time(), time.perf_counter())

    def mark(name):
        nonlocal marks
        now = (time.process_time(), time.perf_counter())
        steps[name] = {"cpu_s": now[0] - marks[0], "wall_s": now[1] - marks[1]}
        marks = now

    data = make_pendulum(random_state=0)
    X, y = data.X_train, data.y_train
    mark("data")
    est = HybridRegressor(science=pendulum_f, structure=OdeStructure(dt=0.2), random_state=0, verbose=False).fit(X, y)
    mark("fit")
    report = est.fit_report()
    mark("report")
    result = close_the_loop(est, X, y, state_names=["v", "v_dot"])
    mark("loop")
    profile = profile_theta(est, X, y, max_iter=2000)  # as the README's second block
    mark("profile (optional)")
    path = [k for k in steps if not k.endswith("(optional)")]
    return {"steps": steps, "n_iter": est.n_iter_, "n_substeps": est.n_substeps_, "omega": est.theta_["omega"],
            "network_share": est.network_share_, "added": [t["term"] for t in result.added],
            "loop_omega": result.science_theta["omega"], "loop_interval": list(result.intervals.intervals["omega"]),
            "loop_timings": result.timings, "profile_points": len(profile.values["omega"]),
            "profile_iterations": profile.n_iter, "verdict": profile.verdicts["omega"],
            "interval": list(profile.intervals["omega"]), "report_lines": len(report.splitlines()),
            "path_cpu_s": sum(steps[k]["cpu_s"] for k in path), "path_wall_s": sum(steps[k]["wall_s"] for k in path)}


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--repeats", type=int, default=2)
    args = parser.parse_args(argv)
    import torch

    runs = [one_run() for _ in range(args.repeats)]
    lines = ["# Seconds of the README's Quick start", "",
             f"torch threads: {torch.get_num_threads()}. CPU seconds are `process_time` (all threads of the "
             "process); wall seconds depend on what else the machine runs. The path is the Quick start: the fit, "
             "its report and the closed loop on that fit; the profile (the README's second block) is optional "
             "and shown beside it.", "",
             "| run | " + " | ".join(f"{k} CPU s (wall s)" for k in runs[0]["steps"]) + " | path CPU s (wall s) |",
             "|---" * (len(runs[0]["steps"]) + 2) + "|"]
    for i, r in enumerate(runs):
        lines.append(f"| {i} | " + " | ".join(f"{s['cpu_s']:.1f} ({s['wall_s']:.1f})" for s in r["steps"].values())
                     + f" | {r['path_cpu_s']:.1f} ({r['path_wall_s']:.1f}) |")
    r = runs[-1]
    lines += ["", f"Fit: {r['n_iter']} iterations, n_substeps {r['n_substeps']} (auto), omega {r['omega']:.6f}, "
              f"network share {r['network_share']:.1%}. Loop: added {r['added']}, omega {r['loop_omega']:.6f}, "
              f"interval [{r['loop_interval'][0]:.6f}, {r['loop_interval'][1]:.6f}]; its CPU seconds by stage "
              + ", ".join(f"{k} {v:.1f}" for k, v in r["loop_timings"].items()) + ". "
              f"Profile: {r['profile_points']} values of omega, {r['profile_iterations']} iterations, verdict "
              f"{r['verdict']}, interval [{r['interval'][0]:.5f}, {r['interval'][1]:.5f}]; "
              f"{r['steps']['profile (optional)']['cpu_s'] / r['steps']['fit']['cpu_s']:.2f} times the fit's CPU.",
              "Targets (issue \"The right answer in a minute\"): the path within 60 CPU s: "
              f"{'met' if max(x['path_cpu_s'] for x in runs) <= 60 else 'missed'} "
              f"(largest {max(x['path_cpu_s'] for x in runs):.0f} s); a profile costs at most its fit: "
              f"{'met' if all(x['steps']['profile (optional)']['cpu_s'] <= x['steps']['fit']['cpu_s'] for x in runs) else 'missed'}."]
    write_results("quickstart", {"runs": runs, "torch_threads": torch.get_num_threads()}, "\n".join(lines))
    print("\n".join(lines))


if __name__ == "__main__":
    main()
