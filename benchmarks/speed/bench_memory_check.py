"""The memory check of a fit against one training iteration, at ordinary and extreme settings.

``HybridRegressor.fit`` measures, before training, the bytes autograd saves for the backward pass
(``_memory.check_fit_memory``).  Issue 40 asks that this cost a small fraction of one training
iteration whatever the settings.  Each setting here is fitted for one iteration (CPU seconds of
the memory check and of the training loop, timed by wrapping the functions ``fit`` calls, one
torch thread): long trajectories, one sample a batch, many samples in large batches, 1,000 RK4
substeps, a forced system, and an adaptive solver.

To compare with an earlier package version::

    git archive <commit> sklearn_hybrid | tar -x -C /tmp/old
    PYTHONPATH=/tmp/old python benchmarks/speed/bench_memory_check.py --name memory_check_before \
        --package "<commit>, exported to /tmp/old"

(the package commit the results name is the working tree's; ``--package`` says which ran).

Usage: python benchmarks/speed/bench_memory_check.py [--name memory_check] [--package TEXT]
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np
import torch

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # benchmarks/: the helpers, the studies' modules
from helpers import write_results  # noqa: E402
import sklearn_hybrid._estimator as estimator_module  # noqa: E402
from sklearn_hybrid import HybridRegressor, pack_inputs  # noqa: E402
from sklearn_hybrid.models import pendulum_f  # noqa: E402

#: name, trajectories, steps per trajectory, estimator settings ("forced": a forced system)
SETTINGS = [
    ("short: 25 x 10, full batch", 25, 10, {}),
    ("long: 5 x 2000, full batch", 5, 2000, {}),
    ("long, batch_size=1: 20 x 2000", 20, 2000, {"batch_size": 1}),
    ("many samples, batch_size=2000: 5000 x 20", 5000, 20, {"batch_size": 2000}),
    ("n_substeps=1000: 4 x 2", 4, 2, {"n_substeps": 1000}),
    ("n_substeps=1000, batch_size=1: 4 x 20", 4, 20, {"n_substeps": 1000, "batch_size": 1}),
    ("forced, many samples: 5000 x 50, batch_size=64", 5000, 50, {"forced": True, "batch_size": 64}),
    ("dopri5, batch_size=1: 20 x 100", 20, 100, {"solver": "dopri5", "batch_size": 1}),
]


def forced(v, u, k=1.0):
    return torch.stack([v[:, 1], -k * v[:, 0] + u[:, 0]], dim=-1)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--name", default="memory_check", help="results file name")
    parser.add_argument("--package", default="this working tree's", help="which package version ran")
    args = parser.parse_args()
    torch.set_num_threads(1)
    clock: dict[str, float] = {}

    def timed(function, name):
        def wrapper(*a, **k):
            start = time.process_time()
            try:
                return function(*a, **k)
            finally:
                clock[name] = time.process_time() - start
        return wrapper

    estimator_module.train = timed(estimator_module.train, "train")
    estimator_module.check_fit_memory = timed(estimator_module.check_fit_memory, "check")
    rng = np.random.default_rng(0)
    rows = []
    for name, n, steps, settings in SETTINGS:
        settings = dict(settings)
        X, y = rng.uniform(-1, 1, (n, 2)), 0.1 * rng.uniform(-1, 1, (n, steps, 2))
        # a zero-started network: a random start blows long integrations up before any step
        # flat dt kept: run on older exports too (fb93ee4), whose HybridRegressor takes no OdeStructure
        params = dict(science=pendulum_f, dt=0.02, max_iter=1, random_state=0, verbose=False,
                      residual={"zero_init": True})
        if settings.pop("forced", False):
            X, params["science"], params["n_inputs"] = pack_inputs(X, rng.uniform(-1, 1, (n, steps + 1, 1))), forced, 1
        HybridRegressor(**params, **settings).fit(X, y)
        rows.append({"setting": name, "check_s": clock["check"], "iteration_s": clock["train"],
                     "ratio": clock["check"] / clock["train"]})
        print(f"{name}: check {clock['check']:.4f} s, one iteration {clock['train']:.3f} s, "
              f"ratio {rows[-1]['ratio']:.3f}", flush=True)
    table = "\n".join(f"| {r['setting']} | {1000 * r['check_s']:.1f} | {r['iteration_s']:.2f} | {r['ratio']:.3f} |"
                      for r in rows)
    md = f"""# The memory check against one training iteration (benchmarks/speed/bench_memory_check.py)

CPU seconds of `check_fit_memory` and of one training iteration (`max_iter=1`, the first
iteration), pendulum science, default network started at zero, one torch thread.

| setting | memory check (ms CPU) | one iteration (s CPU) | check / iteration |
|---|---|---|---|
{table}
"""
    md += f"\nPackage that ran: {args.package}.\n"
    write_results(args.name, {"package": args.package, "rows": rows}, md)


if __name__ == "__main__":
    main()
