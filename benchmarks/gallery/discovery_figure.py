"""The closed-loop guide's figure on discovery: each effect of the laws batch, before and with symbolic regression.

Reads the committed records of ``discovery/bench_discovery.py`` (``results/discovery.json``) and draws, per effect
case, the final model's error in function space (``rel_err``) for the loop with its term list, the loop with
discovery and UDE + SINDy, with the 1 % (law named, if theta is also right) and 10 % (field) lines. Nothing is
trained: the figure is the records drawn.

    python benchmarks/gallery/discovery_figure.py

Writes ``results/guide/discovery.png`` (the closed-loop guide shows it).
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # benchmarks/: the helpers
from helpers import RESULTS  # noqa: E402

ARMS = [("loop", "loop, term list", "o", "0.55"), ("loop_discovery", "loop + discovery", "s", "C0"),
        ("ude_sindy", "UDE + SINDy", "^", "C2")]


def main() -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    records = [r for r in json.loads((RESULTS / "discovery.json").read_text())["records"]
               if r.get("loop", {}).get("rel_err") is not None]
    records.sort(key=lambda r: r["loop"]["rel_err"])
    fig, ax = plt.subplots(figsize=(9, 3.6))
    x = np.arange(len(records))
    for key, label, marker, color in ARMS:
        y = [r.get(key, {}).get("rel_err", np.nan) for r in records]
        ax.semilogy(x, np.maximum(np.asarray(y, dtype=float), 1e-4), marker, color=color, ms=5, label=label,
                    linestyle="none")
    ax.axhline(0.01, color="C3", lw=1, ls=":", label="1 %: the law (with theta within 5 %)")
    ax.axhline(0.10, color="C3", lw=1, ls="--", label="10 %: the field")
    ax.set_xticks(x)
    ax.set_xticklabels([r["system"] for r in records], rotation=60, ha="right", fontsize=7)
    ax.set_ylabel("rel_err (final model vs truth)")
    ax.set_title("Laws outside the term list: the final model's error per case", fontsize=10)
    ax.legend(fontsize=7, loc="upper left")
    fig.tight_layout()
    out = RESULTS / "guide" / "discovery.png"
    fig.savefig(out, dpi=110)
    print(out)


if __name__ == "__main__":
    main()
