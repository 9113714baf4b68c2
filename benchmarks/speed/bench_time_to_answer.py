"""Time to the answer: the path from data to a trustworthy theta, end to end, with its CPU seconds.

Issue "The right answer in a minute".  On seven small systems of ``speed/time_to_answer_systems.py``
(written for this benchmark, kept out of the tests), a new user's path is run step by step in a fresh
process, each step's CPU seconds measured (``time.process_time`` of the process plus its worker
processes), and the answer scored:

- ``recommended``: the path the README shows now: ``est = HybridRegressor(science=f, dt=dt).fit(X, y)``;
  ``est.fit_report()`` (its first screen says what the network's share implies and points to the
  loop); ``close_the_loop(est, X, y, state_names=...)`` on that fit; the profile of the hybrid's
  theta (``profile_theta(est, X, y)``) is timed beside it, as the optional step it now is.
- ``discovery``: the recommended path with ``close_the_loop(..., candidates=Candidates(discovery=True))``:
  what the open-ended search (issue "Name the law") costs where the term list already explains the
  residual (it searches only an equation that no listed term explains).
- ``today``: the path the README showed at 5e6a3bf: the same fit, ``est.fit_report(profile=profile_theta(est,
  X, y))``, then ``close_the_loop(HybridRegressor(science=f, dt=dt, method="erm"), X, y, ...)``, which
  fits the hybrid again and refits it after adding the term.  Run it with ``--package DIR``, a
  checkout of that commit (``git worktree add DIR 5e6a3bf``), to measure the old code side by side.

Scores: the final theta (the network-free model's) within 5 % of the truth (largest relative error of
the science's parameters); the final model's right-hand side against the truth on the states of 20
noise-free test trajectories, relative to the missing effect (``rel_err``; for the complete system
relative to the right-hand side itself); the loop's intervals (``science_intervals``) per parameter:
called identified or not, and whether they hold the truth; and every verdict on the way that is
confidently wrong: a parameter called identified whose interval misses the truth (profile or loop).

    python benchmarks/speed/bench_time_to_answer.py [--systems ...] [--seeds 0] [--paths recommended]
    python benchmarks/speed/bench_time_to_answer.py --paths today --package ../old     # the old code
    python benchmarks/speed/bench_time_to_answer.py --package ../prev --label "at bf8d06e"  # same path, older code
    python benchmarks/speed/bench_time_to_answer.py --render

Each (path, system, seed) runs in its own process and is cached under
``results/runs/time_to_answer/<path>/`` as soon as it ends (``--rerun`` runs it again).
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
from helpers import cpu_seconds, machine_description, runs_folder, write_results  # noqa: E402

FOLDER = runs_folder("time_to_answer")
PATHS = ("recommended", "today", "discovery")
TOLERANCE = 0.05  # theta within 5 % of the truth


class Steps:
    """CPU and wall seconds of consecutive steps."""

    def __init__(self):
        self.steps, self.marks = {}, (cpu_seconds(), time.perf_counter())

    def mark(self, name: str) -> None:
        now = (cpu_seconds(), time.perf_counter())
        self.steps[name] = {"cpu_s": now[0] - self.marks[0], "wall_s": now[1] - self.marks[1]}
        self.marks = now


def _rel_errors(theta: dict, truth: dict) -> dict:
    return {k: abs(float(np.ravel(theta[k])[0]) - v) / abs(v) for k, v in truth.items() if k in theta}


def _profile_verdicts(profile, truth: dict) -> dict:
    out = {}
    for k, v in truth.items():
        if k not in profile.verdicts:
            continue
        low, high = (float(b) for b in profile.intervals[k])
        out[k] = {"verdict": profile.verdicts[k], "interval": [low, high],
                  "identified": profile.verdicts[k] == "identified", "holds": bool(low <= v <= high)}
    return out


def run_one(path: str, name: str, seed: int) -> dict:
    """One path on one system and seed, in this process; returns the record."""
    import torch

    from speed.time_to_answer_systems import SYSTEMS, simulate

    torch.set_num_threads(1)
    system = SYSTEMS[name]
    X, y = simulate(system, seed)
    clock = Steps()
    record = {"path": path, "system": name, "seed": seed}
    try:
        return _path(path, system, X, y, seed, clock, record)
    except Exception as error:  # noqa: BLE001 -- a step that fails is what the user meets: a result
        import traceback

        step = f"after {list(clock.steps)[-1]}" if clock.steps else "in the fit"
        clock.mark("failed step")
        record.update(failed=f"{step}: {type(error).__name__}: {error}"[:600], traceback=traceback.format_exc(),
                      steps=clock.steps, path_cpu_s=sum(s["cpu_s"] for s in clock.steps.values()),
                      theta_within=False, confidently_wrong=[])
        return record


def _provenance(record: dict) -> dict:
    import sklearn_hybrid

    record["package"] = str(Path(sklearn_hybrid.__file__).parent)
    record["package_commit"] = _commit_of(Path(sklearn_hybrid.__file__).parents[1])
    record["machine"] = machine_description()
    return record


def _path(path, system, X, y, seed, clock, record) -> dict:
    """The steps of ``path``, timed by ``clock``, scored into ``record``."""
    from sklearn_hybrid import HybridRegressor
    from sklearn_hybrid.diagnosis import Candidates, close_the_loop
    from sklearn_hybrid.identifiability import profile_theta

    from speed.time_to_answer_systems import call_science, interval_verdicts, test_states

    # flat dt kept: --package runs this on 5e6a3bf, whose HybridRegressor takes no OdeStructure
    est = HybridRegressor(science=system.science, dt=system.dt, random_state=seed, verbose=False).fit(X, y)
    clock.mark("fit")
    record.update(fit_iterations=int(est.n_iter_), fit_theta={k: float(np.ravel(v)[0]) for k, v in est.theta_.items()})
    if path in ("recommended", "discovery"):
        report = est.fit_report()
        clock.mark("report")
        # discovery: the symbolic search joins the term list where no listed term explains an equation
        candidates = Candidates(discovery=True) if path == "discovery" else None
        loop = close_the_loop(est, X, y, state_names=system.state_names, candidates=candidates)
        clock.mark("loop")
        profile = profile_theta(est, X, y)
        clock.mark("profile (optional)")
        record["profile_members"] = int(sum(len(v) for v in profile.values.values()))
    else:
        profile = profile_theta(est, X, y)
        clock.mark("profile")
        report = est.fit_report(profile=profile)
        clock.mark("report")
        # flat dt kept: the today path runs on 5e6a3bf (--package), whose HybridRegressor takes no OdeStructure
        loop = close_the_loop(HybridRegressor(science=system.science, dt=system.dt, method="erm",
                                              random_state=seed, verbose=False), X, y,
                              state_names=system.state_names)
        clock.mark("loop")
    record["report"] = report
    record["screen_points_to_loop"] = "close_the_loop" in report
    record["network_share"] = getattr(est, "network_share_", None)
    record["profile"] = _profile_verdicts(profile, system.theta_true)
    record["loop_timings"] = getattr(loop, "timings", None)
    record["loop_after_refit"] = loop.after is not None
    science = loop.science if loop.science is not None else system.science
    theta = loop.science_theta
    x = test_states(system, seed)
    final = call_science(science, x, theta)
    truth = system.true_rhs(x)
    scale = np.linalg.norm(system.missing_rhs(x)) if not system.complete else np.linalg.norm(truth)
    errors = _rel_errors(theta, system.theta_true)
    record.update({"added": [f"{a['term']} [{a['output']}]" for a in loop.added],
                   "science_theta": {k: float(np.ravel(v)[0]) for k, v in theta.items()},
                   "theta_rel_err": errors, "theta_max_rel_err": max(errors.values()),
                   "theta_within": bool(max(errors.values()) <= TOLERANCE),
                   "rel_err": float(np.linalg.norm(final - truth) / scale),
                   "intervals": interval_verdicts(loop.intervals, system.theta_true)})
    wrong = [f"profile {k}" for k, v in record["profile"].items() if v["identified"] and not v["holds"]]
    wrong += [f"loop {k}" for k, v in record["intervals"].items() if v["identified"] and not v["holds"]]
    record["confidently_wrong"] = wrong
    record["steps"] = clock.steps
    counted = [k for k in clock.steps if not k.endswith("(optional)")]
    record["path_cpu_s"] = sum(clock.steps[k]["cpu_s"] for k in counted)
    record["path_wall_s"] = sum(clock.steps[k]["wall_s"] for k in counted)
    return record


def _commit_of(root: Path) -> str:
    out = subprocess.run(["git", "log", "-1", "--format=%h", "--", "sklearn_hybrid"], capture_output=True,
                         text=True, cwd=root).stdout.strip()
    dirty = subprocess.run(["git", "status", "--porcelain", "--", "sklearn_hybrid"], capture_output=True,
                           text=True, cwd=root).stdout.strip()
    return (out or "unknown") + ("+uncommitted" if dirty else "")


def _case_path(path: str, name: str, seed: int) -> Path:
    return FOLDER / path.replace(" ", "_") / f"{name}_seed{seed}.json"


def run_all(paths, names, seeds, package, rerun, label=None) -> None:
    """Each case in its own process (fresh imports, its own CPU clock), interleaved over the paths;
    ``label`` files the records of ``package`` apart, as ``PATH LABEL`` (e.g. the path at an earlier commit)."""
    for seed in seeds:
        for name in names:
            for path in paths:
                out = _case_path(f"{path} {label}" if label else path, name, seed)
                if out.exists() and not rerun:
                    print(f"{path} {name} seed {seed}: cached", flush=True)
                    continue
                env = dict(os.environ, OMP_NUM_THREADS="1")
                if package:
                    env["PYTHONPATH"] = str(Path(package).resolve()) + os.pathsep + env.get("PYTHONPATH", "")
                command = [sys.executable, __file__, "--one", path, name, str(seed)]
                done = subprocess.run(command, env=env, capture_output=True, text=True,
                                      cwd=Path(__file__).parent)
                if done.returncode:
                    print(f"{path} {name} seed {seed}: FAILED\n{done.stderr[-3000:]}", flush=True)
                    continue
                record = json.loads(done.stdout.strip().splitlines()[-1])
                if label:
                    record["path"] = f"{path} {label}"
                out.parent.mkdir(parents=True, exist_ok=True)
                out.write_text(json.dumps(record, indent=1, default=float) + "\n")
                print(f"{path} {name} seed {seed}: {record['path_cpu_s']:.0f} CPU s, "
                      + (record["failed"] if "failed" in record else
                         f"theta error {record['theta_max_rel_err']:.3f}, added {record['added']}"), flush=True)


def _load() -> list[dict]:
    return [json.loads(p.read_text()) for p in sorted(FOLDER.glob("*/*.json"))]


def render() -> None:
    records = _load()
    if not records:
        print("no records yet")
        return
    lines = ["# Time to the answer: data to a trustworthy theta, end to end", "",
             "CPU seconds (the process and its workers) of each step of a new user's path, one torch thread; "
             "`path` is the sum of the steps the path needs (the profile is optional on the recommended path "
             "and is shown beside it). theta: the final network-free model's largest relative error. "
             "`rel_err`: its right-hand side against the truth on test states, relative to the missing effect "
             "(complete system: to the right-hand side). Intervals: the loop's (`science_intervals`), called "
             "identified / holding the truth. Confidently wrong: called identified, interval misses the truth "
             "(the profile's or the loop's).", "",
             "| path | system | seed | fit | profile | loop | path CPU s | fit iterations | network share | "
             "added | theta error | within 5 % | rel_err | identified / held | confidently wrong | commit |",
             "|---" * 16 + "|"]
    for r in sorted(records, key=lambda r: (r["system"], r["seed"], r["path"])):
        s = r["steps"]
        if "failed" in r:
            fit = f"{s['fit']['cpu_s']:.0f}" if "fit" in s else f"{s['failed step']['cpu_s']:.0f} (failed)"
            lines.append(f"| {r['path']} | {r['system']} | {r['seed']} | {fit} | | | **{r['path_cpu_s']:.0f}** | | | "
                         f"failed {r['failed'][:200].replace('|', '/')} | | no | | | | {r['package_commit']} |")
            continue
        prof = s.get("profile", s.get("profile (optional)", {})).get("cpu_s", float("nan"))
        iv = r["intervals"].values()
        share = r.get("network_share")
        lines.append(
            f"| {r['path']} | {r['system']} | {r['seed']} | {s['fit']['cpu_s']:.0f} | {prof:.0f}"
            f"{'' if 'profile' in s else ' (opt.)'} | {s['loop']['cpu_s']:.0f} | **{r['path_cpu_s']:.0f}** | "
            f"{r['fit_iterations']} | {'' if share is None else f'{share:.1%}'} | "
            f"{'; '.join(r['added']) or 'nothing'} | {r['theta_max_rel_err']:.3f} | "
            f"{'yes' if r['theta_within'] else 'no'} | {r['rel_err']:.3f} | "
            f"{sum(v['identified'] for v in iv)} / {sum(v['identified'] and v['holds'] for v in iv)} of {len(iv)} | "
            f"{', '.join(r['confidently_wrong']) or 'none'} | {r['package_commit']} |")
    lines += ["", "| path | runs | median path CPU s | max path CPU s | theta within 5 % | intervals held where "
              "identified | confidently wrong verdicts | median profile CPU s / fit CPU s |", "|---" * 8 + "|"]
    for path in sorted({r["path"] for r in records}, key=lambda p: (p.split()[0] != PATHS[0], p)):
        rs = [r for r in records if r["path"] == path]
        if not rs:
            continue
        cost = [r["path_cpu_s"] for r in rs]
        ident = [v for r in rs for v in r.get("intervals", {}).values() if v["identified"]]
        ratio = [s.get("profile", s.get("profile (optional)", {})).get("cpu_s", np.nan) / s["fit"]["cpu_s"]
                 for s in (r["steps"] for r in rs) if "fit" in s] or [np.nan]
        failed = sum("failed" in r for r in rs)
        lines.append(f"| {path} | {len(rs)}{f' ({failed} failed)' if failed else ''} | {np.median(cost):.0f} | "
                     f"{max(cost):.0f} | {sum(r['theta_within'] for r in rs)} of {len(rs)} | "
                     f"{sum(v['holds'] for v in ident)} of {len(ident)} | "
                     f"{sum(len(r['confidently_wrong']) for r in rs)} | {np.nanmedian(ratio):.2f} |")
    for other in sorted({r["path"] for r in records} - {"recommended"}):
        pairs = [(a, b) for a in records if a["path"] == "recommended" and "failed" not in a for b in records
                 if b["path"] == other and "failed" not in b and (b["system"], b["seed"]) == (a["system"], a["seed"])]
        if pairs:
            ratios = [b["path_cpu_s"] / a["path_cpu_s"] for a, b in pairs]
            fits = [b["steps"]["fit"]["cpu_s"] / a["steps"]["fit"]["cpu_s"] for a, b in pairs]
            dates = sorted({r["machine"].get("date", "")[:10] for pair in pairs for r in pair} - {""})
            lines += ["", f"Side by side on {len(pairs)} system(s) (same data and seeds, each path in a fresh process; "
                      f"run on {', '.join(dates)}): the path '{other}' costs {np.median(ratios):.1f} times the "
                      f"recommended one (median; range {min(ratios):.1f}-{max(ratios):.1f}), its fit "
                      f"{np.median(fits):.1f} times (range {min(fits):.1f}-{max(fits):.1f})."]
    lines += ["", "Targets (issue \"The right answer in a minute\"): median path <= 60 CPU s and every system <= 120; "
              "theta within 5 % with intervals that hold wherever the loop names the effect; no confidently wrong "
              "verdict; a profile costs at most its fit."]
    write_results("time_to_answer", {"records": [{k: v for k, v in r.items() if k != "report"} for r in records]},
                  "\n".join(lines))
    print("\n".join(lines))


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--paths", nargs="+", default=["recommended"], choices=PATHS)
    parser.add_argument("--systems", nargs="+", default=None)
    parser.add_argument("--seeds", nargs="+", type=int, default=[0])
    parser.add_argument("--package", default=None, help="a checkout whose sklearn_hybrid the cases import")
    parser.add_argument("--rerun", action="store_true")
    parser.add_argument("--label", default=None,
                        help="with --package: file its records as 'PATH LABEL' (the same path at another commit)")
    parser.add_argument("--render", action="store_true")
    parser.add_argument("--one", nargs=3, metavar=("PATH", "SYSTEM", "SEED"), help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.one:
        path, name, seed = args.one
        print(json.dumps(_provenance(run_one(path, name, int(seed))), default=float))
        return
    if args.render:
        render()
        return
    from speed.time_to_answer_systems import SYSTEMS

    run_all(args.paths, args.systems or list(SYSTEMS), args.seeds, args.package, args.rerun, args.label)
    render()


if __name__ == "__main__":
    main()
