"""What close_the_loop(cv=4) gives where the default held-out split could not settle a candidate.

The identification protocol judges each candidate on the last 12 of 50 training trajectories
(``validation_fraction=0.25``). ``results/inconclusive_candidates.md`` lists the records whose last step held a
candidate that lowered that held-out error by 5 % or more with z above 2 but under the threshold. With ``cv=4``
every trajectory judges (each of four blocks predicted by a refit on the other three), at the same z. This script
closes the loop again on those records and on every control (where a term added would be a false one), from
each case's stored first hybrid fit up to the network-free fit of the selected model, and scores that model as
the benchmark does. Each finished case is cached in ``results/runs/identification/more_validation/``.

    python benchmarks/bench_more_validation.py --cases NAME --noise LEVEL   # one case (or several)
    python benchmarks/bench_more_validation.py --list                       # the cases, in run order
    python benchmarks/bench_more_validation.py --render                     # results/more_validation.md
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path


HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
import bench_identification as bench  # noqa: E402
from _common import PACKAGE_COMMIT, RESULTS, machine_description, run_each_case  # noqa: E402
from _identification_systems import SYSTEMS  # noqa: E402
from check_selection_unchanged import record_terms, selection, stored_record, term_names  # noqa: E402
from inconclusive_candidates import inconclusive  # noqa: E402

CV = 4
CACHE = bench.cache_dir(False) / "more_validation"


def cases() -> list[tuple[str, float]]:
    """The inconclusive records' failures, then the controls, then the inconclusive records that were identified."""
    records = bench.load(fast=False)
    open_ = [r for r in records if inconclusive(r)]
    failed = [r for r in open_ if r.get("identified") is False]
    controls = [r for r in records if SYSTEMS[r["system"]].is_control]
    identified = [r for r in open_ if r.get("identified")]
    return [(r["system"], r["noise"]) for r in failed + controls + identified]


def run(name: str, noise: float) -> dict:
    system = SYSTEMS[name]
    record = stored_record(name, noise)
    data = bench.make_data(system, noise, 0, False)
    start = time.perf_counter()
    science, theta = selection(name, noise, data, cv=CV)
    scores = bench.score(system, science, theta, record["before_theta"], data["x_test"], data["u_test"])
    return {"system": name, "noise": noise, "cv": CV, "terms": term_names(science),
            "record_terms": record_terms(record), **scores,
            "record_score": record.get("rel_err", record.get("control_err")), "record_identified":
            record.get("identified"), "package_commit": PACKAGE_COMMIT, "seconds": time.perf_counter() - start,
            "machine": machine_description()}


def render() -> None:
    rows = [json.loads(p.read_text()) for p in sorted(CACHE.glob("*.json"))]
    effects = [r for r in rows if not SYSTEMS[r["system"]].is_control]
    controls = [r for r in rows if SYSTEMS[r["system"]].is_control]
    named = sum(r["rel_err"] <= bench.PROTOCOL["threshold"] for r in effects)
    before = sum(bool(r["record_identified"]) for r in effects)
    lines = ["# More validation samples: close_the_loop(cv=4) on the inconclusive records and the controls", "",
             (__doc__ or "").split("\n\n")[1].replace("\n", " "), "",
             f"Cases run: {len(rows)} of {len(cases())}. Effects within 10 %: {named} of {len(effects)} with cv={CV} "
             f"({before} of them in their records, one held-out split); controls with nothing added: "
             f"{sum(not r['terms'] for r in controls)} of {len(controls)}.", "",
             "| system | noise | score in the record | with cv=4 | terms in the record | with cv=4 | s |",
             "|---|---|---|---|---|---|---|"]
    for r in rows:
        score = r.get("rel_err", r.get("control_err"))
        lines.append(f"| {r['system']} | {r['noise']:g} | {r['record_score']:.3f} | {score:.3f} | "
                     f"{'; '.join(r['record_terms']) or 'nothing'} | {'; '.join(r['terms']) or 'nothing'} | "
                     f"{r['seconds']:.0f} |")
    # the same cases' selections with one held-out split, timed by check_selection_unchanged.py
    split = {(c["system"], c["noise"]): c["seconds"] for c in
             (json.loads(p.read_text()) for p in (bench.cache_dir(False) / "selection_checks").glob("*.json"))}
    timed = [r for r in rows if (r["system"], r["noise"]) in split]
    lines += ["", f"Time: the {len(timed)} of these cases that `selection_checks.md` also timed took "
              f"{sum(r['seconds'] for r in timed):.0f} s with cv={CV} against "
              f"{sum(split[r['system'], r['noise']] for r in timed):.0f} s with one split (selection up to the "
              "network-free fit; the first hybrid fit and the refit after it are the same either way)."]
    machines = sorted({r["machine"].get("cpu") for r in rows})
    commits = sorted({r["package_commit"] for r in rows})
    lines += ["", f"Scores as in `identification.md` (rel_err for an effect, |F - T|/|T| for a control). Machine: "
              f"{', '.join(machines)}; package commit {', '.join(commits)}.", "",
              "Command, once per case (`--list` prints them): `python benchmarks/bench_more_validation.py --cases "
              "NAME --noise LEVEL`; then `--render`."]
    (RESULTS / "more_validation.md").write_text("\n".join(lines) + "\n")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cases", nargs="*", default=[], help="system names")
    parser.add_argument("--noise", type=float, nargs="*", default=[0.01, 0.05])
    parser.add_argument("--list", action="store_true", help="print the cases, one 'NAME LEVEL' a line")
    parser.add_argument("--render", action="store_true", help="write more_validation.md from the cache")
    args = parser.parse_args()
    if args.list:
        print("\n".join(f"{name} {noise:g}" for name, noise in cases()))
        return
    if args.render:
        render()
        return
    run_each_case(CACHE, args.cases, args.noise, run,
                  lambda r: f"{'; '.join(r['terms']) or 'nothing'} "
                            f"({r.get('rel_err', r.get('control_err')):.3f}, {r['seconds']:.0f} s)")


if __name__ == "__main__":
    main()
