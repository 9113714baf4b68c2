"""Check whether a change of the package changes the identification records' selections.

A change of the selection's numerics (for instance how a diverged simulation counts) can change any
record of ``bench_identification.py``, and rerunning all of them takes hours. The selection is the part
that can change: given the same terms and parameter values, the hybrid refit and the scoring after it are
what the record already holds. This script closes the loop on a case from its stored first hybrid fit up to
the network-free fit of the selected model, stops there (before the two hybrid fits, a third to half of a
case's time), and compares the terms and every parameter value with the stored record. A case whose
selection differs must be run again with ``bench_identification.py --rerun``.

Each finished check is cached as ``results/runs/identification/selection_checks/<system>_noise<level>.json`` (with the package
commit it checked); ``--render`` writes ``results/selection_checks.md`` from them.

    python benchmarks/check_selection_unchanged.py --cases radiating_body --noise 0.01
    python benchmarks/check_selection_unchanged.py --render
    python benchmarks/check_selection_unchanged.py --cases large_swing --into selection_checks_periodic
"""

from __future__ import annotations

import argparse
import importlib
import json
import pickle
import sys
import time
from pathlib import Path
from typing import Callable

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
import bench_identification as bench  # noqa: E402
from _common import PACKAGE_COMMIT, RESULTS, machine_description, run_each_case  # noqa: E402
from _identification_systems import SYSTEMS  # noqa: E402

CHECKS = bench.cache_dir(False) / "selection_checks"
# close_the_loop's module: the loop is stopped by replacing the function that starts its first hybrid fit
# after the selection, which receives the selected model and its network-free fit.
LOOP = importlib.import_module("sklearn_hybrid.diagnosis.loop")


class _Selected(Exception):
    def __init__(self, science, theta):
        super().__init__("selection done")
        self.science, self.theta = science, theta


def _stop(before, science, theta, X, y):
    raise _Selected(science, theta)


def selection(name: str, noise: float, data: dict | None = None, **options) -> tuple[Callable, dict]:
    """The science model (with ``.terms``) and network-free parameter values the loop selects today, from the
    case's stored first fit; ``data``: the case's ``bench.make_data`` if the caller has it already; ``options``
    go to close_the_loop beside the protocol's own arguments."""
    system = SYSTEMS[name]
    data = bench.make_data(system, noise, 0, False) if data is None else data
    est = pickle.loads((bench.cache_dir(False) / "fits" / f"{bench.case_name(name, noise, 0)}.pkl").read_bytes())
    original, LOOP._fixed_science = LOOP._fixed_science, _stop
    try:
        bench.close_the_loop(est, data["X"], data["y"], **bench.loop_arguments(system), **options)
    except _Selected as done:
        return done.science, {k: np.asarray(v, float).tolist() for k, v in done.theta.items()}
    finally:
        LOOP._fixed_science = original
    raise RuntimeError("the loop ended without reaching its network-free fit")


def term_names(science: Callable) -> list[str]:
    """The added terms as '<term> [component]' (none for the original science function)."""
    return [f"{term} [{component}]" for component, term, _ in getattr(science, "terms", [])]


def stored_record(name: str, noise: float) -> dict:
    """The case's record of ``bench_identification.py`` (seed 0), as committed."""
    return json.loads((bench.cache_dir(False) / f"{bench.case_name(name, noise, 0)}.json").read_text())


def record_terms(record: dict) -> list[str]:
    """The record's added terms as '<term> [component]', as :func:`term_names` gives them."""
    return [f"{t['term']} [{t['component']}]" for t in record["added"]]


def check(name: str, noise: float) -> dict:
    record = stored_record(name, noise)
    start = time.perf_counter()
    science, theta = selection(name, noise)
    terms = term_names(science)
    stored_terms = record_terms(record)
    stored = record["science_theta"]
    same_values = set(theta) == set(stored) and all(
        np.allclose(theta[k], stored[k], rtol=1e-7, atol=1e-12) for k in theta)
    return {"system": name, "noise": noise, "same": terms == stored_terms and same_values,
            "terms": terms, "stored_terms": stored_terms, "theta": theta, "stored_theta": stored,
            "record_commit": record.get("package_commit"), "package_commit": PACKAGE_COMMIT,
            "seconds": time.perf_counter() - start, "machine": machine_description()}


def render() -> None:
    rows = [json.loads(p.read_text()) for p in sorted(CHECKS.glob("*.json"))]
    lines = ["# Does the package change the identification records' selections?", "",
             "Each case closed from its stored first hybrid fit up to the network-free fit of the selected model "
             "(`check_selection_unchanged.py`), compared with its stored record: the same terms and every parameter "
             "value within 1e-7 relative.", "",
             f"{sum(r['same'] for r in rows)} of {len(rows)} checked cases select as their records "
             f"({sum(r['seconds'] for r in rows):.0f} s of checks, one case per process, two at a time).", "",
             "| system | noise | same | terms now | terms in the record | record made at | checked at | s |",
             "|---|---|---|---|---|---|---|---|"]
    for r in rows:
        lines.append(f"| {r['system']} | {r['noise']:g} | {'yes' if r['same'] else '**no**'} | "
                     f"{'; '.join(r['terms']) or 'nothing'} | {'; '.join(r['stored_terms']) or 'nothing'} | "
                     f"{r['record_commit']} | {r['package_commit']} | {r['seconds']:.0f} |")
    machines = sorted({json.dumps(r["machine"].get("cpu")) for r in rows})
    lines += ["", f"Machine: {', '.join(machines)}.", "",
              "Command, once per case: `python benchmarks/check_selection_unchanged.py --cases NAME --noise LEVEL`; "
              "then `--render`."]
    (RESULTS / "selection_checks.md").write_text("\n".join(lines) + "\n")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cases", nargs="*", default=[], help="system names")
    parser.add_argument("--noise", type=float, nargs="*", default=[0.01, 0.05])
    parser.add_argument("--render", action="store_true", help="write selection_checks.md from the cache")
    parser.add_argument("--into", default=CHECKS.name, metavar="FOLDER",
                        help="folder of results/runs/identification/ for the checks of one change, kept apart from the others "
                             "(selection_checks_periodic: the harmonics of an angle)")
    args = parser.parse_args()
    if args.render:
        render()
        return
    # a check made for another package commit is made again
    run_each_case(CHECKS.parent / args.into, args.cases, args.noise, check,
                  lambda r: f"{'same' if r['same'] else 'DIFFERS'} ({r['seconds']:.0f} s)",
                  cached=lambda r: r["package_commit"] == PACKAGE_COMMIT)


if __name__ == "__main__":
    main()
