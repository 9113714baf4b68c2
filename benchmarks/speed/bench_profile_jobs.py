"""Does a profile gain from both cores?  ``profile_theta(..., n_jobs=1)`` against ``n_jobs=2``.

Issue "The right answer in a minute" asks for profile members spread over both cores by default.  On
four systems of ``speed/time_to_answer_systems.py`` (kept out of the tests) the default fit is made once,
then profiled with its stacked members in one group in this process (``n_jobs=1``) and in two worker
processes (``n_jobs=2``, joblib's loky workers; the first call of the run starts them), each timed in
wall-clock seconds and CPU seconds of the process and its workers, with the verdicts and intervals it
gives (two groups stop on their own stopping rule, so they may train a different number of iterations).

    python benchmarks/speed/bench_profile_jobs.py [--systems stage sir drug drag_mass]
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # benchmarks/: the helpers, the studies' modules
from helpers import cpu_seconds, write_results  # noqa: E402

DEFAULT_SYSTEMS = ("stage", "sir", "drug", "drag_mass")


def run(name: str) -> list[dict]:
    from sklearn_hybrid import HybridRegressor, OdeStructure
    from sklearn_hybrid.identifiability import profile_theta

    from speed.time_to_answer_systems import SYSTEMS, simulate

    system = SYSTEMS[name]
    X, y = simulate(system, 0)
    start = cpu_seconds()
    est = HybridRegressor(science=system.science, structure=OdeStructure(dt=system.dt), random_state=0,
                          verbose=False).fit(X, y)
    fit_cpu = cpu_seconds() - start
    rows = []
    for n_jobs in (1, 2):
        wall, cpu = time.perf_counter(), cpu_seconds()
        prof = profile_theta(est, X, y, n_jobs=n_jobs, verbose=False)
        rows.append({"system": name, "n_jobs": n_jobs, "fit_cpu": fit_cpu, "wall": time.perf_counter() - wall,
                     "cpu": cpu_seconds() - cpu, "n_iter": prof.n_iter,
                     "verdicts": {k: [prof.verdicts[k], [float(v) for v in prof.intervals[k]]] for k in prof.verdicts}})
        print(rows[-1], flush=True)
    return rows


def render(rows: list[dict]) -> str:
    lines = ["# A profile on one core or two", "",
             "`profile_theta(est, X, y, n_jobs=...)` after the default fit, on systems of "
             "`speed/time_to_answer_systems.py`; CPU seconds of the process and its workers (torch's own "
             "thread count left as the fit set it). The first `n_jobs=2` call starts the worker processes.", "",
             "| system | fit CPU s | n_jobs | profile wall s | profile CPU s | iterations | verdicts (interval) |",
             "|---|---|---|---|---|---|---|"]
    for r in rows:
        verdicts = "; ".join(f"{k}: {v} [{lo:.4g}, {hi:.4g}]" for k, (v, (lo, hi)) in r["verdicts"].items())
        lines.append(f"| {r['system']} | {r['fit_cpu']:.0f} | {r['n_jobs']} | {r['wall']:.1f} | {r['cpu']:.1f} | "
                     f"{r['n_iter']} | {verdicts} |")
    one = {r["system"]: r for r in rows if r["n_jobs"] == 1}
    two = [r for r in rows if r["n_jobs"] == 2]
    if two:
        wall = [one[r["system"]]["wall"] / r["wall"] for r in two]
        cpu = [r["cpu"] / one[r["system"]]["cpu"] for r in two]
        lines += ["", f"Two workers against one group: wall-clock {min(wall):.2f}-{max(wall):.2f} times faster, "
                      f"CPU seconds {min(cpu):.2f}-{max(cpu):.2f} times as many (per system, this run)."]
    return "\n".join(lines)


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--systems", nargs="*", default=list(DEFAULT_SYSTEMS))
    args = parser.parse_args()
    rows = [row for name in args.systems for row in run(name)]
    write_results("profile_jobs", {"rows": rows}, render(rows))
