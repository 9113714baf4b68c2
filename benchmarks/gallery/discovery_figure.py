"""The closed-loop guide's figure on discovery: each effect of the five laws batches, before and with discovery.

Reads the committed records of ``discovery/bench_discovery.py`` (``results/discovery.json``, the first batch,
``results/discovery_2.json``, the second, written after the first had been seen, ``results/discovery_3.json``, the
third, written after both, ``results/discovery_4.json``, the fourth, written after the three, and
``results/discovery_5.json``, the fifth, written after the four) and draws, per
effect case, the final model's error in function space (``rel_err``) for the loop with its term list
(``loop_learned`` where it ran), the loop with discovery as the package now runs it (``discovery/arms.py``: the
latest of its arms from ``loop_discovery_judged`` on that ran) and UDE + SINDy, with the 1 % (law named, if theta
is also right) and 10 % (field) lines; a filled marker where theta is also within 5 %.
Nothing is trained: the figure is the records drawn.

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
from discovery.arms import package_now  # noqa: E402

ARMS = [("loop", "loop, term list", "o", "0.55"), ("loop_discovery_judged", "loop + discovery", "s", "C0"),
        ("ude_sindy", "UDE + SINDy", "^", "C2")]
BATCHES = [("discovery", "first laws batch"), ("discovery_2", "second (written after the first was seen)"),
           ("discovery_3", "third (written after both)"), ("discovery_4", "fourth (written after the three)"),
           ("discovery_5", "fifth (written after the four)")]


def _term_list(record: dict) -> dict:
    """The loop with its term list: ``loop_learned`` where it ran (the fourth batch ran it alone), else ``loop``."""
    return record.get("loop_learned", record.get("loop", {}))


def main() -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 5, figsize=(21, 4.8), sharey=True,
                             gridspec_kw={"width_ratios": [17, 9, 10, 12, 12]})
    for ax, (name, title) in zip(axes, BATCHES):
        records = [r for r in json.loads((RESULTS / f"{name}.json").read_text())["records"]
                   if _term_list(r).get("rel_err") is not None]
        records.sort(key=lambda r: _term_list(r)["rel_err"])
        x = np.arange(len(records))
        for key, label, marker, color in ARMS:
            got = [(package_now(r) or {}) if key == "loop_discovery_judged" else
                   _term_list(r) if key == "loop" else r.get(key, {}) for r in records]
            y = np.maximum(np.asarray([g.get("rel_err", np.nan) for g in got], dtype=float), 1e-4)
            right = np.array([(g.get("theta_error") is not None and g["theta_error"] <= 0.05) for g in got], dtype=bool)
            ax.semilogy(x[right], y[right], marker, color=color, ms=5, linestyle="none",
                        label=f"{label} (theta within 5 %)")
            ax.semilogy(x[~right], y[~right], marker, color=color, ms=5, linestyle="none", mfc="none",
                        label=f"{label} (theta off)")
        ax.axhline(0.01, color="C3", lw=1, ls=":", label="1 %: the law (with theta within 5 %)")
        ax.axhline(0.10, color="C3", lw=1, ls="--", label="10 %: the field")
        ax.set_xticks(x)
        ax.set_xticklabels([r["system"] for r in records], rotation=60, ha="right", fontsize=7)
        ax.set_title(title, fontsize=9)
    axes[0].set_ylabel("rel_err (final model vs truth)")
    handles, labels = axes[0].get_legend_handles_labels()
    fig.suptitle("Laws outside the term list: the final model's error per case", fontsize=10)
    fig.tight_layout(rect=(0, 0.12, 1, 1))
    fig.legend(handles, labels, fontsize=7, loc="lower center", ncol=4, frameon=False)
    out = RESULTS / "guide" / "discovery.png"
    fig.savefig(out, dpi=110)
    print(out)


if __name__ == "__main__":
    main()
