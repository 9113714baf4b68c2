"""Which part of training in the data's scales moves the hybrid's own theta: an ablation on the pendulum.

Issue "Your units, your machine" made the package's MLP read each state standardised and write each rate in
units of the rate that state is observed to change at (``structures/scales.py``). The rerun of
``bench_uncertainty`` then showed the hybrid fits' omega further from the truth at its settings (a 32x32
network with a random last layer, at most 300 iterations): erm 0.60 where it had been 0.66. This check fits the
same data with the network's scales as the package sets them, with the input scaling alone, the output scaling
alone, and neither (the network in the user's units, as before the issue), for erm and fsam, on

- the README's pendulum (``make_pendulum(random_state=0)``, the package's defaults), and
- the first repeats of ``bench_uncertainty``'s pendulum (its ``SETTINGS``).

    python benchmarks/units/check_network_scales.py [--repeats 2]

Writes ``results/network_scales.md`` and ``.json``.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # benchmarks/: the helpers, the studies' modules
from helpers import write_results  # noqa: E402

VARIANTS = ("as the package sets them", "inputs only", "outputs only", "neither (user's units)")


def _with_variant(variant: str):
    """Patch the one place a fit gives the network its scales (``_fitting.set_network_scales``)."""
    import sklearn_hybrid._fitting as fitting
    from sklearn_hybrid.structures.scales import set_network_scales

    def patched(residual, scales):
        if scales is None or variant == VARIANTS[0]:
            return set_network_scales(residual, scales)
        if variant == VARIANTS[3]:
            return False
        scales = type(scales)(**scales)
        if variant == VARIANTS[1]:
            scales.out_scale = np.ones_like(scales.out_scale)
        else:
            scales.in_shift, scales.in_scale = np.zeros_like(scales.in_shift), np.ones_like(scales.in_scale)
        return set_network_scales(residual, scales)

    fitting.set_network_scales = patched


def main(argv=None) -> None:
    import torch

    from sklearn_hybrid import HybridRegressor, OdeStructure
    from sklearn_hybrid.datasets import make_pendulum
    from sklearn_hybrid.models import pendulum_f
    from uncertainty.protocol import SETTINGS
    from uncertainty.systems import SYSTEMS

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=2)
    args = parser.parse_args(argv)
    torch.set_num_threads(1)
    readme = make_pendulum(random_state=0)
    cases = [("README pendulum (defaults)", readme.X_train, readme.y_train, 0.2, {}, 0)]
    system = SYSTEMS["pendulum"]
    for repeat in range(args.repeats):
        X, y, dt = system.make(repeat)
        cases.append((f"bench_uncertainty pendulum, repeat {repeat}", X, y, dt,
                      {**SETTINGS, "theta_init": system.theta_init}, repeat))
    rows = []
    for variant in VARIANTS:
        _with_variant(variant)
        for name, X, y, dt, settings, seed in cases:
            for method in ("erm", "fsam"):
                start = time.process_time()
                est = HybridRegressor(science=pendulum_f, structure=OdeStructure(dt=dt), method=method,
                                      random_state=seed, verbose=False, **settings).fit(X, y)
                rows.append({"variant": variant, "case": name, "method": method,
                             "omega": float(est.theta_["omega"]), "error": abs(est.theta_["omega"] - 2 / 3),
                             "n_iter": int(est.n_iter_), "cpu_s": time.process_time() - start})
                print(rows[-1], flush=True)
    lines = ["# Which part of the network's scaling moves the hybrid's own theta (pendulum)", "",
             "`benchmarks/units/check_network_scales.py`: the same fits with the network's scales as the package "
             "sets them (inputs standardised, outputs in units of each state's observed rate), with one part of "
             "them alone, and with neither (the network in the user's units, as before issue \"Your units, your "
             "machine\"). True omega 2/3.", "",
             "| case | method | " + " | ".join(VARIANTS) + " |", "|---|---|" + "---|" * len(VARIANTS)]
    for name, *_ in cases:
        for method in ("erm", "fsam"):
            got = {r["variant"]: r for r in rows if r["case"] == name and r["method"] == method}
            lines.append(f"| {name} | {method} | " + " | ".join(
                f"{got[v]['omega']:.4f} ({got[v]['n_iter']} it.)" for v in VARIANTS) + " |")
    write_results("network_scales", {"rows": rows}, "\n".join(lines))
    print("\n".join(lines))


if __name__ == "__main__":
    main()
