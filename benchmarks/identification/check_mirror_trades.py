"""The closed loop's mirror check replayed on the identification records: which verdicts would it change?

``close_the_loop`` calls a science parameter conditional when a chosen term's form, placed on another
uncertain equation, would trade with it (``sklearn_hybrid.diagnosis.loop.caveats.mirror_trades``): a
reaction that feeds A from B also drains B, and the elimination rate of B absorbs the drain unseen.
This replays that check, without training anything, on every stored record of the identification
benchmark: the record's final terms (rebuilt from the default term library by name, at the record's
shape and coefficient) and science parameters, on the noise-free test states of the record's system
(``make_data``'s; the loop itself uses the hybrid's visited states of the training data). It counts the
parameters the records call identified that it would make conditional, split by whether their
interval holds the truth: a parameter made conditional while its interval held the truth is a cost (a
verdict lost), one whose interval missed the truth is an answer no longer confidently wrong.

It reads records made before the check existed, so it measures what the check would change, not a
rerun: a rerun at the package commit with the check gives the benchmark's own figures.

Usage: python benchmarks/identification/check_mirror_trades.py
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # benchmarks/: the helpers, the studies' modules
from helpers import write_results  # noqa: E402
from identification.protocol import PROTOCOL, load, loop_arguments  # noqa: E402
from identification.systems import SYSTEMS, simulate  # noqa: E402
from sklearn_hybrid.diagnosis import Candidates  # noqa: E402
from sklearn_hybrid.diagnosis.loop.caveats import mirror_trades  # noqa: E402
from sklearn_hybrid.diagnosis.loop.placed import PlacedTerm  # noqa: E402
from sklearn_hybrid.diagnosis.sensitivity import parameter_jacobian  # noqa: E402
from sklearn_hybrid.identifiability import ScienceIntervals  # noqa: E402


def replay(record: dict) -> list[dict]:
    """One row per science parameter with an interval: its verdict, whether it holds, and the check's."""
    system = SYSTEMS[record["system"]]
    x, u = simulate(system, PROTOCOL["n_test"], record["seed"], stream=1)  # make_data's test states
    args = [x.reshape(-1, x.shape[-1])] + ([u.reshape(-1, 1)] if system.forced else [])
    arguments = loop_arguments(system)
    variables = arguments["state_names"] + (arguments["input_names"] or [])
    n_states = len(system.state_names)
    values = np.hstack(args)
    library = {t.name: t for t in Candidates().library(variables, values, arguments["units"], None, n_states)}
    theta = {**system.theta_true, **record["science_theta"]}
    jac, names = parameter_jacobian(system.science, {k: theta[k] for k in system.theta_true}, args)
    components = [j for j in range(jac.shape[1]) if np.any(jac[:, j, :])]  # close_the_loop's exact="auto"
    added, unknown = [], []
    for a in record["added"]:
        if a["kind"] in ("offset", "scaled"):
            continue
        if a["term"] not in library:  # a term of another library than the default one rebuilt here
            unknown.append(a["term"])
            continue
        added.append(PlacedTerm(library[a["term"]], a["component"], a["shape"], a["coef"]))
    intervals = record["intervals"]
    ci = ScienceIntervals(estimate={k: theta[k] for k in intervals}, std={k: np.nan for k in intervals},
                          intervals={k: tuple(v["interval"]) for k, v in intervals.items()},
                          verdicts={k: v["verdict"] for k, v in intervals.items()}, level=0.95, n_samples=0)
    why = mirror_trades(ci, system.science, theta, added, args, variables, components,
                        [f"g[{s}]" for s in system.state_names])
    rows = []
    for k, v in intervals.items():
        true = system.theta_true[k]
        if np.ndim(true):
            continue
        low, high = v["interval"]
        rows.append({"case": f"{record['system']} {record['noise']}", "param": k, "verdict": v["verdict"],
                     "holds": bool(low <= true <= high), "off": abs(theta[k] - true) / max(abs(true), 1e-12),
                     "control": system.is_control, "mirror": why.get(k), "unknown_terms": unknown})
    return rows


def main() -> None:
    rows = []
    for record in load(fast=False):
        placed = [a for a in record.get("added", []) if a["kind"] not in ("offset", "scaled")]
        if record.get("intervals") and placed and record["system"] in SYSTEMS:  # no term placed: no mirror
            rows.extend(replay(record))
    # the records without a placed term are left out: the check cannot change their verdicts
    lines = ["| records with a term placed | parameters | holding the truth | made conditional | of them holding "
             "| of them > 10 % off |", "|---|---|---|---|---|---|"]
    for what, sel in [("effects, identified", [r for r in rows if not r["control"] and r["verdict"] == "identified"]),
                      ("controls, identified", [r for r in rows if r["control"] and r["verdict"] == "identified"])]:
        made = [r for r in sel if r["mirror"]]
        lines.append(f"| {what} | {len(sel)} | {sum(r['holds'] for r in sel)} | {len(made)} | "
                     f"{sum(r['holds'] for r in made)} | {sum(r['off'] > 0.1 for r in made)} |")
    wrong = [r for r in rows if r["verdict"] == "identified" and r["off"] > 0.1]
    made = [r for r in rows if r["verdict"] == "identified" and r["mirror"]]
    unknown = sorted({t for r in rows for t in r["unknown_terms"]})
    md = "\n".join([
        "# The mirror check replayed on the identification records (benchmarks/identification/check_mirror_trades.py)",
        "", __doc__.split("\n\n")[1].replace("\n", " "), "", *lines, "",
        f"Called identified while more than 10 % off the truth: {len(wrong)}; the check makes "
        f"{sum(bool(r['mirror']) for r in wrong)} of them conditional.", "",
        "Every parameter the check makes conditional:", "",
        *[f"- {r['case']} {r['param']} ({r['off']:.0%} off, interval {'holds' if r['holds'] else 'misses'} the truth): "
          f"{r['mirror']}" for r in made],
        "", "Identified, more than 10 % off, and left identified by the check:", "",
        *[f"- {r['case']} {r['param']} ({r['off']:.0%} off)" for r in wrong if not r["mirror"]],
        "", "Terms of the records not in the default library rebuilt here (left out): "
        f"{', '.join(unknown) or 'none'}."])
    write_results("mirror_trades", {"rows": rows}, md)
    print(md)


if __name__ == "__main__":
    main()
