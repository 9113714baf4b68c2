"""Does offering flows (one term, one coefficient, +c on one equation and -c on another) change the loop's answers?

Issue "No silent wrong answer", the flow item. On the identification benchmark's systems whose uncertain equations
exchange a flow (waning immunity, conduction between two bodies, an enzyme's conversion) and on controls of that
shape, the same first hybrid fit (made as the benchmark makes it; the stored fits are not kept in the repository)
goes through ``close_the_loop`` twice, with ``Candidates(flows=True)`` (the default) and ``flows=False`` (the loop
before flows), and the page lists the terms, the number of coefficients and the function-space score of each.

    python benchmarks/identification/check_flows.py
    python benchmarks/identification/check_flows.py --rerun   # every case again, at this package
    python benchmarks/identification/check_flows.py --render

Each case is cached in ``results/runs/flows/<case>.json``.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import torch

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # benchmarks/: the helpers, the studies' modules
from helpers import PACKAGE_COMMIT, runs_folder, write_results  # noqa: E402
from identification.protocol import first_hybrid_fit, loop_arguments, make_data, score  # noqa: E402
from identification.systems import SYSTEMS  # noqa: E402

RUNS = runs_folder("flows")
CASES = ["waning_immunity", "waning_sir", "conducting_bodies", "enzymatic_conversion", "control_sirs",
         "control_reaction_chain"]


def run_case(name: str, noise: float = 0.01) -> dict:
    from sklearn_hybrid.diagnosis import Candidates, close_the_loop

    torch.set_num_threads(1)
    system = SYSTEMS[name]
    data = make_data(system, noise, 0)
    est, _ = first_hybrid_fit(system, data)
    out = {"system": name, "noise": noise, "package_commit": PACKAGE_COMMIT}
    for flows in (True, False):
        start = time.process_time()
        res = close_the_loop(est, data["X"], data["y"], candidates=Candidates(flows=flows), verbose=False,
                             **loop_arguments(system))
        science = res.science if res.science is not None else system.science
        scores = score(system, science, res.science_theta, est.theta_, data["x_test"], data["u_test"])
        out["flows" if flows else "no_flows"] = {
            **scores, "terms": [f"{t['coef']:+.4g} * {t['term']} [{t['output']}"
                                + (f", -c on {t['opposite_output']}" if "opposite_output" in t else "") + "]"
                                for t in res.added],
            "n_coefficients": len(res.added), "cpu_seconds": time.process_time() - start}
    return out


def render() -> None:
    recs = [json.loads(p.read_text()) for p in sorted(RUNS.glob("*.json"))]
    lines = ["# Flows between compartments: the loop with and without them", "",
             "`benchmarks/identification/check_flows.py` (its docstring says what it runs). Score: the identification "
             "benchmark's `rel_err` (a control: `control_err`). Records made at package commit(s) "
             + ", ".join(sorted({r["package_commit"] for r in recs})) + ".", "",
             "| system | effect | with flows: terms | score | without: terms | score |", "|---|---|---|---|---|---|"]
    for r in recs:
        s = SYSTEMS[r["system"]]
        key = "control_err" if s.is_control else "rel_err"
        cells = []
        for arm in ("flows", "no_flows"):
            a = r[arm]
            cells += [("; ".join(a["terms"]) or "nothing").replace("|", "\\|"), f"{a[key]:.3f}"]
        lines.append(f"| {s.name} | {s.effect} | " + " | ".join(cells) + " |")
    write_results("flows", {"records": recs}, "\n".join(lines))


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--cases", nargs="*", default=CASES, choices=list(SYSTEMS))
    parser.add_argument("--render", action="store_true")
    parser.add_argument("--rerun", action="store_true", help="run the cases again, over their records")
    args = parser.parse_args(argv)
    if not args.render:
        RUNS.mkdir(parents=True, exist_ok=True)
        for name in args.cases:
            path = RUNS / f"{name}.json"
            if path.exists() and not args.rerun:
                continue
            rec = run_case(name)
            path.write_text(json.dumps(rec, indent=1, default=float) + "\n")
            print(name, {k: rec[k]["terms"] for k in ("flows", "no_flows")}, flush=True)
    render()


if __name__ == "__main__":
    main()
