"""The identification benchmark's checks and side studies: the options of ``bench_identification.py``.

Each works from the benchmark's stored records (``results/runs/identification/*.json``) and, where it closes
the loop again, from their stored first hybrid fits (``fits/`` beside them, outside git). Each keeps its own
run records in a folder beside the benchmark's and writes its own page in ``results/``:

``--check-selection`` (``runs/identification/selection_checks/``, ``results/selection_checks.md``)
    Does a change of the package change the records' selections? A change of the selection's numerics (for
    instance how a diverged simulation counts) can change any record, and rerunning all of them takes hours.
    The selection is the part that can change: given the same terms and parameter values, the hybrid refit and
    the scoring after it are what the record already holds. The check closes the loop on a case from its stored
    first hybrid fit up to the network-free fit of the selected model, stops there (before the two hybrid fits,
    a third to half of a case's time), and compares the terms and every parameter value with the stored record.
    A case whose selection differs must be run again with ``--rerun``. ``--into FOLDER`` keeps the checks of
    one change apart from the others (``selection_checks_periodic``: the harmonics of an angle).
``--second-look-null`` (``runs/identification/second_look_null/``, ``results/second_look_null.md``)
    How often does the second look accept a term where nothing is missing? Its gate removed, every candidate
    of every control gets a second look, which is then the only judge (:data:`SECOND_LOOK_NULL`).
``--inconclusive`` (``results/inconclusive_candidates.md``, from the stored records only)
    Which records stopped on a candidate the held-out test could not settle: a candidate that lowered the
    held-out error by at least ``min_gain`` (5 %) with z above 2 but under the threshold (3.85 standard errors
    for the 12 validation trajectories of the protocol) was neither supported nor ruled out, and more
    validation samples could accept it. The page overwritten is the one the second look was made from; the
    identification page's "Rerun with the second look" section tells that story.
``--more-validation`` (``runs/identification/more_validation/``, ``results/more_validation.md``)
    ``close_the_loop(cv=4)`` on the inconclusive records and on every control (:data:`MORE_VALIDATION`).

Each case runs in one process, one torch thread, and is cached as ``<system>_noise<level>.json`` the moment it
ends (:func:`helpers.run_each_case`).
"""

from __future__ import annotations

import json
import re
import time
from typing import Callable

import numpy as np

from helpers import PACKAGE_COMMIT, RESULTS, machine_description, run_each_case
from identification import protocol
from identification.systems import SYSTEMS

from sklearn_hybrid.diagnosis import Evidence, close_the_loop
from sklearn_hybrid.diagnosis.loop.second_look import SECOND_LOOK_Z as MIN_Z
from sklearn_hybrid.diagnosis.loop.second_look import worth_a_second_look
from sklearn_hybrid.diagnosis.loop.watch import LoopWatch, watching

CHECKS = protocol.cache_dir(False) / "selection_checks"
NULL_RUNS = protocol.cache_dir(False) / "second_look_null"
MORE_VALIDATION_RUNS = protocol.cache_dir(False) / "more_validation"
CONTROLS = [name for name, system in SYSTEMS.items() if system.is_control]
MIN_GAIN = 0.05  # close_the_loop's min_gain, as the benchmark runs it
CV = 4

#: What ``--second-look-null`` does (the first paragraph of its page).
SECOND_LOOK_NULL = (
    "``close_the_loop``'s second look (``second_look=4``) judges a candidate again on folds of the training "
    "trajectories when the validation trajectories found it promising (gain >= 5 %, z above 2) but not proven. No "
    "control of the identification benchmark ever got that far (``results/inconclusive_candidates.md``), so the "
    "benchmark cannot say how often the second look accepts a useless term. This stress test removes its gate: on "
    "every control, at every step where no candidate passes, *every* candidate gets a second look (whatever its "
    "gain and z on the validation trajectories), which is then the only judge. It runs each control from its "
    "stored first hybrid fit up to the network-free fit of the selected model (as ``--check-selection`` does) and "
    "records every second-look verdict and the terms added. With the gate in place (the default) a useless term "
    "must pass both tests.")

#: What ``--more-validation`` does (the first paragraph of its page).
MORE_VALIDATION = (
    "The identification protocol judges each candidate on the last 12 of 50 training trajectories "
    "(``validation_fraction=0.25``). ``results/inconclusive_candidates.md`` lists the records whose last step held "
    "a candidate that lowered that held-out error by 5 % or more with z above 2 but under the threshold. With "
    "``cv=4`` every trajectory judges (each of four blocks predicted by a refit on the other three), at the same "
    "z. ``--more-validation`` closes the loop again on those records and on every control (where a term added "
    "would be a false one), from each case's stored first hybrid fit up to the network-free fit of the selected "
    "model, and scores that model as the benchmark does. Each finished case is cached in "
    "``results/runs/identification/more_validation/``.")


# --- the selection, stopped before its hybrid fits (--check-selection, and the two studies built on it) ---

class _Selected(Exception):
    """Raised by the loop's watch once the selection is made: the loop stops there (see :func:`selection`)."""

    def __init__(self, science, theta, steps):
        super().__init__("selection done")
        self.science, self.theta, self.steps = science, theta, steps


def _stop(science, theta, steps):
    raise _Selected(science, theta, steps)


def selection(name: str, noise: float, data: dict | None = None, second_look_gate: bool = True,
              **options) -> tuple[Callable, dict, list]:
    """The science model (with ``.terms``), network-free parameter values and steps the loop selects today, from
    the case's stored first fit, stopped before the network-free estimator, its intervals and the hybrid refit
    (the loop's public watch, ``sklearn_hybrid.diagnosis.loop.watch``); ``data``: the case's
    ``protocol.make_data`` if the caller has it already; ``second_look_gate=False``: every candidate of a step
    where none passes gets the second look; ``options`` go to close_the_loop beside the protocol's own
    arguments."""
    system = SYSTEMS[name]
    data = protocol.make_data(system, noise, 0, False) if data is None else data
    fits = protocol.cache_dir(False) / "fits"
    est = protocol.load_fit(fits / f"{protocol.case_name(name, noise, 0)}.pkl")
    try:
        with watching(LoopWatch(on_selection=_stop, second_look_gate=second_look_gate)):
            close_the_loop(est, data["X"], data["y"], **protocol.loop_arguments(system), **options)
    except _Selected as done:
        return done.science, {k: np.asarray(v, float).tolist() for k, v in done.theta.items()}, done.steps
    raise RuntimeError("the loop ended without reaching its network-free fit")


def term_names(science: Callable) -> list[str]:
    """The added terms as '<term> [component]' (none for the original science function)."""
    return [f"{term} [{component}]" for component, term, _ in getattr(science, "terms", [])]


def stored_record(name: str, noise: float) -> dict:
    """The case's record of ``bench_identification.py`` (seed 0), as committed."""
    return json.loads((protocol.cache_dir(False) / f"{protocol.case_name(name, noise, 0)}.json").read_text())


def record_terms(record: dict) -> list[str]:
    """The record's added terms as '<term> [component]', as :func:`term_names` gives them."""
    return [f"{t['term']} [{t['component']}]" for t in record["added"]]


def check_selection(name: str, noise: float) -> dict:
    """The case's selection today against its stored record: the same terms, every value within 1e-7."""
    record = stored_record(name, noise)
    start = time.perf_counter()
    science, theta, _ = selection(name, noise)
    terms = term_names(science)
    stored_terms = record_terms(record)
    stored = record["science_theta"]
    same_values = set(theta) == set(stored) and all(
        np.allclose(theta[k], stored[k], rtol=1e-7, atol=1e-12) for k in theta)
    return {"system": name, "noise": noise, "same": terms == stored_terms and same_values,
            "terms": terms, "stored_terms": stored_terms, "theta": theta, "stored_theta": stored,
            "record_commit": record.get("package_commit"), "package_commit": PACKAGE_COMMIT,
            "seconds": time.perf_counter() - start, "machine": machine_description()}


def render_selection_checks() -> None:
    """``results/selection_checks.md`` from the checks in :data:`CHECKS`."""
    rows = [json.loads(p.read_text()) for p in sorted(CHECKS.glob("*.json"))]
    lines = ["# Does the package change the identification records' selections?", "",
             "Each case closed from its stored first hybrid fit up to the network-free fit of the selected model "
             "(`bench_identification.py --check-selection`), compared with its stored record: the same terms and "
             "every parameter value within 1e-7 relative.", "",
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
              "Command, once per case: `python benchmarks/identification/bench_identification.py --check-selection "
              "--cases NAME --noise LEVEL`; then `--check-selection --render`."]
    (RESULTS / "selection_checks.md").write_text("\n".join(lines) + "\n")


# --- the second look without its gate (--second-look-null) ---

def second_look_null(name: str, noise: float) -> dict:
    """The control's selection with every candidate looked at again, whatever its gain and z; its second-look
    rows (``kept``: the one a step accepted)."""
    start = time.perf_counter()
    science, _, steps = selection(name, noise, second_look_gate=False)
    looked = [{k: s[k] for k in ("step", "component", "term", "gain", "z", "threshold")} | {"kept": s["accepted"]}
              for s in steps if _is_second_look(s)]
    passed = [r for r in looked if r["z"] > r["threshold"] and r["gain"] >= 0.05]
    return {"system": name, "noise": noise, "looked": looked, "n_looked": len(looked), "n_passed": len(passed),
            "added": term_names(science), "seconds": time.perf_counter() - start, "package_commit": PACKAGE_COMMIT,
            "machine": machine_description()}


def _is_second_look(step: dict) -> bool:
    """A step's row is a second look at a candidate (``"<n>, second look"``; a drop judged on the second look's
    folds reads ``"drop, second look"``)."""
    label = step["step"]
    return isinstance(label, str) and label.endswith(", second look") and label.split(",")[0].isdigit()


def render_second_look_null() -> str:
    """The page of ``--second-look-null`` from the runs in :data:`NULL_RUNS`."""
    records = [json.loads(p.read_text()) for p in sorted(NULL_RUNS.glob("*.json"))]
    n_looked = sum(r["n_looked"] for r in records)
    n_passed = sum(r["n_passed"] for r in records)
    spoiled = [r for r in records if r["added"]]
    md = ["# The second look on controls, without its gate", "", SECOND_LOOK_NULL, "",
          f"{len(records)} of {2 * len(CONTROLS)} controls run: {n_looked} candidates looked at again, {n_passed} "
          f"passed the second look alone (gain >= 5 % and z above the threshold for the training trajectories); "
          f"{len(spoiled)} controls got a term.", "",
          "| system | noise | candidates looked at | passed | highest z (threshold) | terms added | s | commit |",
          "|---|---|---|---|---|---|---|---|"]
    for r in records:
        top = max(r["looked"], key=lambda s: s["z"], default=None)
        best = "" if top is None else f"{top['z']:.1f} ({top['threshold']:.2f}), {top['term']}".replace("|", "\\|")
        terms = "; ".join(r["added"]).replace("|", "\\|") or "nothing"
        md.append(f"| {r['system']} | {r['noise']:g} | {r['n_looked']} | {r['n_passed']} | {best} | {terms} | "
                  f"{r['seconds']:.0f} | {r['package_commit']} |")
    machines = sorted({f"{r['machine']['cpu']}, {r['machine']['cores']} cores" for r in records})
    commits = sorted({r["package_commit"] for r in records})
    md += ["", f"Machine: {'; '.join(machines)}. Package commit {', '.join(commits)}. Command: "
           "`python benchmarks/identification/bench_identification.py --second-look-null --cases NAME --noise "
           "LEVEL`, then `--second-look-null --render`."]
    return "\n".join(md) + "\n"


# --- records that ended on an inconclusive candidate (--inconclusive) ---

def _rows(report: str) -> list[list[str]]:
    """The selection table's rows as cells (an escaped ``\\|`` inside a term is not a separator)."""
    return [[c.strip() for c in re.split(r"(?<!\\)\|", line)[1:-1]]
            for line in report.splitlines() if re.match(r"\| \d+ \|", line)]


def inconclusive(record: dict) -> list[tuple[str, float, float]]:
    """(term, gain, z) of each candidate of the last step with gain >= MIN_GAIN and MIN_Z < z < its threshold."""
    threshold = re.search(r"by more than ([\d.]+) standard errors", record["report"])
    rows = _rows(record["report"])
    if not rows or threshold is None:
        return []
    last = max(int(row[0]) for row in rows)
    out = []
    for row in rows:
        step, term, gain, z, accepted = int(row[0]), row[2], row[-3], row[-2], row[-1]
        if step != last or accepted != "no" or not gain.endswith("%"):
            continue
        gain, z = float(gain.rstrip("%")) / 100, float(z)
        if worth_a_second_look({"gain": gain, "z": z}, MIN_GAIN) and z < float(threshold.group(1)):
            out.append((term.replace("\\|", "|"), gain, z))
    return out


def write_inconclusive() -> None:
    """``results/inconclusive_candidates.md`` from the stored records as they stand now."""
    records = protocol.load(fast=False)
    hits = [(r, inconclusive(r)) for r in records]
    hits = [(r, c) for r, c in hits if c]
    failed = [r for r, _ in hits if r.get("identified") is False]
    failed_names = ", ".join(f"`{r['system']}` {r['noise']:g}" for r in failed)
    md = ["# Records whose last selection step held an inconclusive candidate", "",
          f"Of the {len(records)} records of `results/identification.md`, {len(hits)} end on a step where a candidate "
          f"lowered the held-out error by at least {MIN_GAIN:.0%} with z above {MIN_Z:g} but under the threshold; "
          f"{len(failed)} of them are failures of the benchmark ({failed_names}). "
          "A rule that judges such a candidate again on more validation samples (and only such a candidate: z "
          f"above {MIN_Z:g}) could change these records and no other: every earlier step accepted a term, so the "
          "rule would not have been asked there.", "",
          "| system | noise | score | identified | candidates (gain, z) |", "|---|---|---|---|---|"]
    for r, cands in hits:
        score = r.get("rel_err") if r.get("rel_err") is not None else r.get("control_err")
        md.append(f"| {r['system']} | {r['noise']:g} | {score:.3f} | {r.get('identified', 'control')} | "
                  + "; ".join(f"{t.replace('|', chr(92) + '|')} ({g:.0%}, {z:.1f})" for t, g, z in cands) + " |")
    md += ["", "Command: `python benchmarks/identification/bench_identification.py --inconclusive` (reads the stored "
           "records only)."]
    (RESULTS / "inconclusive_candidates.md").write_text("\n".join(md) + "\n")
    print(f"{len(hits)} of {len(records)} records; {len(failed)} failures")


# --- more validation samples, close_the_loop(cv=4) (--more-validation) ---

def more_validation_cases() -> list[tuple[str, float]]:
    """The inconclusive records' failures, then the controls, then the inconclusive records that were identified."""
    records = protocol.load(fast=False)
    open_ = [r for r in records if inconclusive(r)]
    failed = [r for r in open_ if r.get("identified") is False]
    controls = [r for r in records if SYSTEMS[r["system"]].is_control]
    identified = [r for r in open_ if r.get("identified")]
    return [(r["system"], r["noise"]) for r in failed + controls + identified]


def more_validation(name: str, noise: float) -> dict:
    """The case's selection with ``cv=CV``, scored as the benchmark scores it."""
    system = SYSTEMS[name]
    record = stored_record(name, noise)
    data = protocol.make_data(system, noise, 0, False)
    start = time.perf_counter()
    science, theta, _ = selection(name, noise, data, evidence=Evidence(cv=CV))
    scores = protocol.score(system, science, theta, record["before_theta"], data["x_test"], data["u_test"])
    return {"system": name, "noise": noise, "cv": CV, "terms": term_names(science),
            "record_terms": record_terms(record), **scores,
            "record_score": record.get("rel_err", record.get("control_err")), "record_identified":
            record.get("identified"), "package_commit": PACKAGE_COMMIT, "seconds": time.perf_counter() - start,
            "machine": machine_description()}


def render_more_validation() -> None:
    """``results/more_validation.md`` from the runs in :data:`MORE_VALIDATION_RUNS`."""
    rows = [json.loads(p.read_text()) for p in sorted(MORE_VALIDATION_RUNS.glob("*.json"))]
    effects = [r for r in rows if not SYSTEMS[r["system"]].is_control]
    controls = [r for r in rows if SYSTEMS[r["system"]].is_control]
    named = sum(r["rel_err"] <= protocol.PROTOCOL["threshold"] for r in effects)
    before = sum(bool(r["record_identified"]) for r in effects)
    lines = ["# More validation samples: close_the_loop(cv=4) on the inconclusive records and the controls", "",
             MORE_VALIDATION, "",
             f"Cases run: {len(rows)} of {len(more_validation_cases())}. Effects within 10 %: {named} of "
             f"{len(effects)} with cv={CV} ({before} of them in their records, one held-out split); controls with "
             f"nothing added: {sum(not r['terms'] for r in controls)} of {len(controls)}.", "",
             "| system | noise | score in the record | with cv=4 | terms in the record | with cv=4 | s |",
             "|---|---|---|---|---|---|---|"]
    for r in rows:
        score = r.get("rel_err", r.get("control_err"))
        lines.append(f"| {r['system']} | {r['noise']:g} | {r['record_score']:.3f} | {score:.3f} | "
                     f"{'; '.join(r['record_terms']) or 'nothing'} | {'; '.join(r['terms']) or 'nothing'} | "
                     f"{r['seconds']:.0f} |")
    # the same cases' selections with one held-out split, timed by --check-selection
    split = {(c["system"], c["noise"]): c["seconds"] for c in
             (json.loads(p.read_text()) for p in CHECKS.glob("*.json"))}
    timed = [r for r in rows if (r["system"], r["noise"]) in split]
    lines += ["", f"Time: the {len(timed)} of these cases that `selection_checks.md` also timed took "
              f"{sum(r['seconds'] for r in timed):.0f} s with cv={CV} against "
              f"{sum(split[r['system'], r['noise']] for r in timed):.0f} s with one split (selection up to the "
              "network-free fit; the first hybrid fit and the refit after it are the same either way)."]
    machines = sorted({r["machine"].get("cpu") for r in rows})
    commits = sorted({r["package_commit"] for r in rows})
    lines += ["", f"Scores as in `identification.md` (rel_err for an effect, |F - T|/|T| for a control). Machine: "
              f"{', '.join(machines)}; package commit {', '.join(commits)}.", "",
              "Command, once per case (`--more-validation --list` prints them): `python benchmarks/"
              "identification/bench_identification.py --more-validation --cases NAME --noise LEVEL`; then "
              "`--more-validation --render`."]
    (RESULTS / "more_validation.md").write_text("\n".join(lines) + "\n")


def main(args) -> None:
    """Run the option that ``args`` (parsed by ``bench_identification.main``) names.

    Parameters
    ----------
    args : argparse.Namespace
        With ``check_selection``, ``second_look_null``, ``inconclusive`` or ``more_validation`` set, and
        ``cases`` (None: no case, or every control for ``--second-look-null``), ``batch``, ``noise``,
        ``render``, ``into`` and ``list``.
    """
    if args.inconclusive:
        write_inconclusive()
        return
    if args.more_validation and args.list:
        print("\n".join(f"{name} {noise:g}" for name, noise in more_validation_cases()))
        return
    cases = args.cases if args.cases is not None else (CONTROLS if args.second_look_null else [])
    if args.batch:
        cases = [c for c in cases if SYSTEMS[c].batch in args.batch]
    if args.check_selection:
        if args.render:
            render_selection_checks()
            return
        # a check made for another package commit is made again
        run_each_case(CHECKS.parent / args.into, cases, args.noise, check_selection,
                      lambda r: f"{'same' if r['same'] else 'DIFFERS'} ({r['seconds']:.0f} s)",
                      cached=lambda r: r["package_commit"] == PACKAGE_COMMIT)
    elif args.second_look_null:
        if not set(cases) <= set(CONTROLS):
            raise SystemExit(f"--second-look-null runs controls only, not {sorted(set(cases) - set(CONTROLS))}")
        if not args.render:
            run_each_case(NULL_RUNS, cases, args.noise, second_look_null,
                          lambda r: f"{r['n_looked']} looked at, {r['n_passed']} passed, "
                                    f"added {r['added'] or 'nothing'} ({r['seconds']:.0f} s)")
        (RESULTS / "second_look_null.md").write_text(render_second_look_null())
        print((RESULTS / "second_look_null.md").read_text())
    elif args.more_validation:
        if args.render:
            render_more_validation()
            return
        run_each_case(MORE_VALIDATION_RUNS, cases, args.noise, more_validation,
                      lambda r: f"{'; '.join(r['terms']) or 'nothing'} "
                                f"({r.get('rel_err', r.get('control_err')):.3f}, {r['seconds']:.0f} s)")
