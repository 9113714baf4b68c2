"""ResidualDiagnosis on a complete science model: does it add anything?

Issue 40's audit: on an undamped pendulum with noise, fitted with its complete science model
(``pendulum_f``), ``ResidualDiagnosis`` added terms with bootstrap inclusion 1.0, one of them on the
kinematic equation ``d angle/dt = velocity``.  This fits the default hybrid on such data (100
trajectories of 10 steps, noise 0.05) for a few seeds and reads the residual twice: as before
(``exact=None``, no ``y``: no held-out judge) and as now (``fit(est, X, y)``: exact equations left
alone, every new term held to ``close_the_loop``'s test).  One torch thread.

Usage: python benchmarks/identification/check_residual_diagnosis_complete.py [--seeds 0 1]
"""

from __future__ import annotations

import argparse
import sys
import time
import warnings
from pathlib import Path

import torch

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # benchmarks/: the helpers, the studies' modules
from helpers import write_results  # noqa: E402
from sklearn_hybrid import HybridRegressor, OdeStructure  # noqa: E402
from sklearn_hybrid.datasets import make_pendulum  # noqa: E402
from sklearn_hybrid.diagnosis import ResidualDiagnosis  # noqa: E402
from sklearn_hybrid.models import pendulum_f  # noqa: E402


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, nargs="+", default=[0, 1])
    args = parser.parse_args()
    torch.set_num_threads(1)
    rows = []
    for seed in args.seeds:
        start = time.process_time()
        data = make_pendulum(n_train=100, gamma=0.0, noise=0.05, random_state=seed)
        X, y = data.X_train, data.y_train
        est = HybridRegressor(science=pendulum_f, structure=OdeStructure(dt=0.2), random_state=seed,
                              verbose=False).fit(X, y)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # the unjudged reading warns that it is unjudged
            unjudged = ResidualDiagnosis(exact=None, random_state=0).fit(est, X)
        judged = ResidualDiagnosis(random_state=0).fit(est, X, y)
        rows.append({
            "seed": seed, "omega": float(est.theta_["omega"]),
            "unjudged": [f"{t['term']} [{t['output']}] inclusion {t['inclusion']:.2f}" for t in unjudged.new_terms_],
            "judged": [f"{t['term']} [{t['output']}] gain {t['evidence']['gain']:.1%} z {t['evidence']['z']:.2f}"
                       for t in judged.terms_ if t["kind"] == "term"],
            "kept": [f"{t['term']} [{t['output']}]" for t in judged.new_terms_],
            "exact": judged.exact_, "cpu_s": time.process_time() - start})
        print(rows[-1], flush=True)
    lines = "\n".join(f"| {r['seed']} | {r['omega']:.4f} | {len(r['unjudged'])}: {', '.join(r['unjudged'])} | "
                      f"{', '.join(r['judged']) or 'none'} | {', '.join(r['kept']) or 'none'} |" for r in rows)
    md = f"""# ResidualDiagnosis on a complete science model (benchmarks/identification/check_residual_diagnosis_complete.py)

Undamped pendulum (`make_pendulum(n_train=100, gamma=0, noise=0.05)`), its complete science model
`pendulum_f`, the default hybrid (`dt=0.2`). Before: `ResidualDiagnosis(exact=None).fit(est, X)`,
no held-out judge. Now: `ResidualDiagnosis().fit(est, X, y)`: exact equations (here g[x0], the
kinematic d angle/dt = velocity) left alone, every new term held to `close_the_loop`'s test
(z 3, min_gain 5 %, the last quarter of the trajectories judging).

| seed | omega | terms without the judge | terms judged (held-out gain, z) | kept |
|---|---|---|---|---|
{lines}
"""
    write_results("residual_diagnosis_complete", {"rows": rows}, md)


if __name__ == "__main__":
    main()
