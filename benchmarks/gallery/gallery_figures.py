"""The figures of the gallery examples that the documentation build does not run, from a full run of each.

The build runs only the examples whose full run takes at most about two minutes; the pages of the
others show committed numbers (``tasks.md``, ``closed_loop.md``) and, from this script, the figures
of a full run of the example itself: each example runs as a script at full size
(``SKLEARN_HYBRID_FAST=0``, from its own folder, as sphinx-gallery runs it), and every figure it
shows or leaves open is saved to ``results/gallery/<example>_<k>.png``.  ``results/gallery.json``
and ``gallery.md`` say for each example when, on which machine, at which package commit and in how
many seconds its figures were made; running a few examples updates their entries only.

Usage: python benchmarks/gallery/gallery_figures.py [duffing reaction_diffusion ...]  (default: all of them)
"""

from __future__ import annotations

import argparse
import json
import os
import runpy
import sys
import time
from pathlib import Path

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # benchmarks/: the helpers, the studies' modules
from helpers import PACKAGE_COMMIT, RESULTS, machine_description, write_results  # noqa: E402

EXAMPLES_DIR = Path(__file__).resolve().parents[2] / "examples"
#: The examples the documentation build does not run (doc/conf.py's RUN_IN_DOCS holds those it runs);
#: the name is the one their page's snippet reads (doc/_results.py).
EXAMPLES = {"duffing": "duffing/plot_duffing.py",
            "light_tunnel": "light_tunnel/plot_light_tunnel.py",
            "pendulum_images": "pendulum_images/plot_pendulum_images.py",
            "wind_tunnel": "wind_tunnel/plot_wind_tunnel.py",
            "reaction_diffusion": "reaction_diffusion/plot_reaction_diffusion.py",
            "silverbox_loop": "closed_loop/plot_silverbox_loop.py"}
FIGURES = RESULTS / "gallery"


def run_example(name: str) -> dict:
    """Run one example at full size; save its figures; return their file names and the seconds it took."""
    FIGURES.mkdir(parents=True, exist_ok=True)
    for old in FIGURES.glob(f"{name}_*.png"):  # a rerun may draw fewer figures: none of the last run stays
        old.unlink()
    saved = []

    def save_open_figures(*args, **kwargs):  # plt.show of the example, and once more at its end
        for number in plt.get_fignums():
            path = FIGURES / f"{name}_{len(saved) + 1}.png"
            plt.figure(number).savefig(path, dpi=80)
            saved.append(path.name)
        plt.close("all")

    script = EXAMPLES_DIR / EXAMPLES[name]
    show, cwd = plt.show, os.getcwd()
    os.environ["SKLEARN_HYBRID_FAST"] = "0"
    plt.show = save_open_figures
    os.chdir(script.parent)
    start = time.perf_counter()
    try:
        runpy.run_path(str(script), run_name="__main__")
        save_open_figures()
    finally:
        plt.show = show
        os.chdir(cwd)
    return {"figures": saved, "seconds": round(time.perf_counter() - start)}


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("examples", nargs="*", help=f"some of {list(EXAMPLES)} (default: all)")
    args = parser.parse_args()
    unknown = sorted(set(args.examples) - set(EXAMPLES))
    if unknown:
        parser.error(f"unknown example(s) {unknown}; choose from {list(EXAMPLES)}")
    path = RESULTS / "gallery.json"
    entries = json.loads(path.read_text())["examples"] if path.is_file() else {}
    for name in args.examples or EXAMPLES:
        machine = machine_description()
        entries[name] = {**run_example(name), "example": f"examples/{EXAMPLES[name]}",
                         "date": machine["date"], "cpu": machine["cpu"], "reference_s": machine["reference_s"],
                         "package_commit": PACKAGE_COMMIT}
        print(name, entries[name], flush=True)
        rows = ["| example | figures | seconds | date | cpu | reference_s | package commit |", "|---" * 7 + "|"]
        rows += [f"| {e['example']} | {', '.join(e['figures'])} | {e['seconds']} | {e['date']} | {e['cpu']} | "
                 f"{e['reference_s']} | {e['package_commit']} |" for e in entries.values()]
        markdown = "\n".join(["# Figures of the gallery examples the documentation build does not run", "",
                              "Each example run at full size by `benchmarks/gallery/gallery_figures.py`; its "
                              "figures are "
                              "in `results/gallery/` and on its gallery page.", "", *rows])
        write_results("gallery", {"examples": entries}, markdown)  # after each example: a long run keeps its part


if __name__ == "__main__":
    main()
