"""Check that merging the benchmark's twin science functions (f1b9ec7) changed no identification record.

Before f1b9ec7, several science functions of ``_identification_systems.py`` differed only in their keyword
defaults, the user's guesses; since, one function serves each model and a system passes its guesses as
``theta_init`` (``System.theta_guess``). The stored records were not re-run. This script takes the module as
it was before the merge (``git show f1b9ec7~1:...``) and, for every system with a ``theta_guess``, at noise
0.01, compares the data and the first hybrid fit (30 iterations) of the two versions; with ``--loops`` it also
closes the loop again on the given systems and compares with their stored records.

    python benchmarks/check_merged_science_functions.py --loops control_declared_gauges allee
"""

from __future__ import annotations

import argparse
import importlib.util
import json
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np
import torch

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
import bench_identification as bench  # noqa: E402
from _common import RESULTS, write_results  # noqa: E402
from _identification_systems import SYSTEMS  # noqa: E402

from sklearn_hybrid import HybridRegressor  # noqa: E402

BEFORE = "f1b9ec7~1"


def _old_module():
    text = subprocess.run(["git", "show", f"{BEFORE}:benchmarks/_identification_systems.py"], cwd=HERE,
                          capture_output=True, text=True, check=True).stdout
    path = Path(tempfile.mkdtemp()) / "old_identification_systems.py"
    path.write_text(text)
    spec = importlib.util.spec_from_file_location("old_identification_systems", path)
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module  # dataclasses look their module up while the class is made
    spec.loader.exec_module(module)
    return module


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--loops", nargs="*", default=[], help="systems to close the loop on again (noise 0.01)")
    args = parser.parse_args()
    torch.set_num_threads(1)
    old = _old_module()
    rows = []
    for name in [n for n, s in SYSTEMS.items() if s.theta_guess]:
        before, now = old.SYSTEMS[name], SYSTEMS[name]
        data_before, data_now = bench.make_data(before, 0.01, 0), bench.make_data(now, 0.01, 0)
        fits = [HybridRegressor(science=s.science, dt=s.dt, method="erm", n_inputs=int(s.forced), theta_init=guess,
                                random_state=0, max_iter=30).fit(data_before["X"], data_before["y"])
                for s, guess in ((before, None), (now, dict(now.theta_guess)))]
        rows.append({"system": name, "function before": before.science.__name__, "function now": now.science.__name__,
                     "data identical": all(np.array_equal(data_before[k], data_now[k]) for k in ("X", "y", "x_test")),
                     "theta identical": fits[0].theta_ == fits[1].theta_,
                     "predictions identical": bool(np.array_equal(fits[0].predict(data_before["X"][:10]),
                                                                  fits[1].predict(data_before["X"][:10])))})
        print(rows[-1], flush=True)
    loops = []
    for name in args.loops:
        record = bench.run_case(SYSTEMS[name], 0.01, 0, False, "check_merged_science_functions")
        stored = json.loads((bench.cache_dir(False) / f"{name}_noise0.01_seed0.json").read_text())
        keys = [k for k in ("rel_err", "control_err", "before_err", "before_control_err") if k in stored]
        loops.append({"system": name, "errors identical": all(stored[k] == record[k] for k in keys),
                      "science_theta identical": stored["science_theta"] == record["science_theta"],
                      "terms identical": [a["term"] for a in stored["added"]] == [a["term"] for a in record["added"]]})
        print(loops[-1], flush=True)
    md = ["# The merged science functions of the identification benchmark", "",
          f"Module before the merge: `{BEFORE}`; noise 0.01, seed 0; first fits of 30 iterations.", "",
          "| system | function before | function now | data identical | theta identical | predictions identical |",
          "|---|---|---|---|---|---|"]
    md += [f"| {r['system']} | {r['function before']} | {r['function now']} | {r['data identical']} | "
           f"{r['theta identical']} | {r['predictions identical']} |" for r in rows]
    if loops:
        md += ["", "Closed end to end again, against the stored records:", "",
               "| system | errors identical | science_theta identical | terms identical |", "|---|---|---|---|"]
        md += [f"| {r['system']} | {r['errors identical']} | {r['science_theta identical']} | {r['terms identical']} |"
               for r in loops]
    write_results("merged_science_functions", {"fits": rows, "loops": loops}, "\n".join(md))


if __name__ == "__main__":
    main()
