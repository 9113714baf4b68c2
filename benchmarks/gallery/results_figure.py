"""The results page's figure: what the closed loop does to the science model's error, case by case.

Reads the committed identification records (``results/identification.json``, written by
``identification/bench_identification.py``) and draws, for every effect case, the science model's error in
function space before the loop (at the hybrid fit's theta) and after it (the final network-free model), with
the 10 % line the benchmark counts as identified.  Nothing is trained: the figure is the records drawn.

    python benchmarks/gallery/results_figure.py

Writes ``results/results_overview.png`` (the results page shows it) and ``results/results_overview.json``.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # benchmarks/: the helpers
from helpers import RESULTS, write_results  # noqa: E402


def main() -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    cases = [c for c in json.loads((RESULTS / "identification.json").read_text())["cases"]
             if c.get("rel_err") is not None and c.get("before_err") is not None]
    cases.sort(key=lambda c: c["rel_err"])
    before = np.array([c["before_err"] for c in cases])
    after = np.array([c["rel_err"] for c in cases])
    fig, ax = plt.subplots(figsize=(9, 3.4))
    x = np.arange(len(cases))
    ax.semilogy(x, before, ".", color="0.6", ms=4, label="science model at the hybrid fit's theta (before the loop)")
    ax.semilogy(x, np.maximum(after, 1e-4), ".", color="C0", ms=4, label="final network-free model (after the loop)")
    ax.axhline(0.10, color="C3", lw=1, ls="--", label="10 %: counted as identified")
    ax.set_xlabel(f"effect cases of the identification benchmark, sorted by the error after the loop ({len(cases)})")
    ax.set_ylabel("error in function space / missing effect")
    ax.set_title(f"The closed loop on effects nobody tuned it to: {np.sum(after <= 0.10)} of {len(cases)} within 10 %",
                 fontsize=10)
    ax.legend(fontsize=7, loc="upper left")
    fig.tight_layout()
    fig.savefig(RESULTS / "results_overview.png", dpi=110)
    write_results("results_overview", {"n_cases": len(cases), "within_10": int(np.sum(after <= 0.10)),
                                       "median_before": float(np.median(before)),
                                       "median_after": float(np.median(after))},
                  f"# The results page's figure\n\n{np.sum(after <= 0.10)} of {len(cases)} effect cases within 10 % "
                  f"after the loop (median error before {np.median(before):.3g}, after {np.median(after):.3g}); "
                  "`results_overview.png`.")


if __name__ == "__main__":
    main()
