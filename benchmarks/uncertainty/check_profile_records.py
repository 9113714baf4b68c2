"""The uncertainty benchmark's records against the same repeats at an earlier git revision: the profiles'
members (values and losses), verdicts and intervals, and how many identified intervals hold the truth.

Where the members are equal, what differs is only how the package reads a profile (its interval rule).
Writes ``results/uncertainty_against_<rev>.md``.  Run after ``bench_uncertainty.py --rerun``.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # benchmarks/: the helpers, the studies' modules
from helpers import ROOT, write_results  # noqa: E402
from uncertainty.protocol import HYBRID_METHODS, RUNS  # noqa: E402
from uncertainty.systems import SYSTEMS  # noqa: E402


def compare(rev: str) -> str:
    same = differ = 0
    score = {"then": [0, 0], "now": [0, 0]}
    changed, commits = [], set()
    for name, system in SYSTEMS.items():
        for path in sorted((RUNS / name).glob("*.json")):
            now = json.loads(path.read_text())
            shown = subprocess.run(["git", "-C", str(ROOT), "show", f"{rev}:{path.relative_to(ROOT).as_posix()}"],
                                   capture_output=True, text=True)
            if shown.returncode or json.loads(shown.stdout)["package_commit"] == now["package_commit"]:
                continue
            then = json.loads(shown.stdout)
            commits.add(now["package_commit"])
            for method in HYBRID_METHODS:
                for label, new in now["methods"][method]["profile"].items():
                    if label.startswith("_"):
                        continue
                    old = then["methods"][method]["profile"][label]
                    equal = old["values"] == new["values"] and old["loss"] == new["loss"]
                    same, differ = same + equal, differ + (not equal)
                    true = system.theta_true[label]
                    for key, rec in (("then", old), ("now", new)):
                        if rec["verdict"] == "identified":
                            score[key][0] += 1
                            score[key][1] += rec["interval"][0] <= true <= rec["interval"][1]
                    if (old["verdict"], old["interval"]) != (new["verdict"], new["interval"]):
                        changed.append(f"| {name} | {path.stem} | {method} | {label} | {old['verdict']} "
                                       f"{_span(old)} | {new['verdict']} {_span(new)} | {true:g} |")
    return "\n".join([
        f"# The uncertainty benchmark's profiles against the same repeats at {rev}", "",
        f"Profiles compared: {same + differ} (records made at {', '.join(sorted(commits)) or 'none'}); members equal "
        f"(values and losses) in {same}, different in {differ}.", "",
        f"Called identified, holding the truth: at {rev} {score['then'][0]}, {score['then'][1]}; now "
        f"{score['now'][0]}, {score['now'][1]}.", "",
        "| system | repeat | method | param | then | now | truth |", "|---|---|---|---|---|---|---|", *changed])


def _span(rec: dict) -> str:
    return "[" + ", ".join(f"{v:.4g}" for v in rec["interval"]) + "]"


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--against", required=True, help="the git revision whose records are compared with")
    args = parser.parse_args()
    md = compare(args.against)
    write_results(f"uncertainty_against_{args.against}", {}, md)
    print(md.split("\n\n")[1:3])
