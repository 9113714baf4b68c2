"""How often does the second look accept a term where nothing is missing?

``close_the_loop``'s second look (``second_look=4``) judges a candidate again on folds of the training
trajectories when the validation trajectories found it promising (gain >= 5 %, z above 2) but not proven. No
control of the identification benchmark ever got that far (``results/inconclusive_candidates.md``), so the
benchmark cannot say how often the second look accepts a useless term. This stress test removes its gate: on
every control, at every step where no candidate passes, *every* candidate gets a second look (whatever its gain
and z on the validation trajectories), which is then the only judge. It runs each control from its stored first
hybrid fit up to the network-free fit of the selected model (as ``check_selection_unchanged.py`` does) and records
every second-look verdict and the terms added. With the gate in place (the default) a useless term must pass both tests.

    python benchmarks/bench_second_look_null.py --cases control_rlc --noise 0.01   # one case, cached
    python benchmarks/bench_second_look_null.py --render                            # results/second_look_null.md
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path


HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
from _common import PACKAGE_COMMIT, RESULTS, machine_description, run_each_case, runs_folder  # noqa: E402
from _identification_systems import SYSTEMS  # noqa: E402
from check_selection_unchanged import selection, term_names  # noqa: E402

from sklearn_hybrid.diagnosis import stepwise  # noqa: E402

CACHE = runs_folder("identification/second_look_null")
CONTROLS = [name for name, system in SYSTEMS.items() if system.is_control]


def run(name: str, noise: float) -> dict:
    """The control's selection with every candidate of 5 % gain looked at again; its second-look rows."""
    looked: list[dict] = []
    original_look, original_gate = stepwise._second_look, stepwise._promising

    def recording(recheck, tried, current, theta, added, steps, *args):
        n = len(steps)
        best = original_look(recheck, tried, current, theta, added, steps, *args)
        looked.extend({k: steps[i][k] for k in ("step", "component", "term", "gain", "z", "threshold")}
                      | {"kept": best is not None and best[5] == i} for i in range(n, len(steps)))
        return best

    stepwise._second_look, stepwise._promising = recording, lambda verdict, min_gain: True
    start = time.perf_counter()
    try:
        science, _ = selection(name, noise)
    finally:
        stepwise._second_look, stepwise._promising = original_look, original_gate
    passed = [r for r in looked if r["z"] > r["threshold"] and r["gain"] >= 0.05]
    return {"system": name, "noise": noise, "looked": looked, "n_looked": len(looked), "n_passed": len(passed),
            "added": term_names(science), "seconds": time.perf_counter() - start, "package_commit": PACKAGE_COMMIT,
            "machine": machine_description()}


def render() -> str:
    records = [json.loads(p.read_text()) for p in sorted(CACHE.glob("*.json"))]
    n_looked = sum(r["n_looked"] for r in records)
    n_passed = sum(r["n_passed"] for r in records)
    spoiled = [r for r in records if r["added"]]
    md = ["# The second look on controls, without its gate", "",
          __doc__.split("\n\n")[1].replace("\n", " "), "",
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
           "`python benchmarks/bench_second_look_null.py --cases NAME --noise LEVEL`, then `--render`."]
    return "\n".join(md) + "\n"


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cases", nargs="*", default=CONTROLS, choices=CONTROLS)
    parser.add_argument("--noise", nargs="*", type=float, default=[0.01, 0.05])
    parser.add_argument("--render", action="store_true", help="write the results from the cache only")
    args = parser.parse_args(argv)
    if not args.render:
        run_each_case(CACHE, args.cases, args.noise, run,
                      lambda r: f"{r['n_looked']} looked at, {r['n_passed']} passed, "
                                f"added {r['added'] or 'nothing'} ({r['seconds']:.0f} s)")
    (RESULTS / "second_look_null.md").write_text(render())
    print((RESULTS / "second_look_null.md").read_text())


if __name__ == "__main__":
    main()
