"""How far the README's printed numbers move on another CPU: its snippets under other float paths.

Issue "Your units, your machine". float32 training rounds differently on another CPU (vector width, BLAS code
path, thread count), and a fit amplifies it: an early stop a window sooner, another last digit of theta. On one
machine the paths another CPU would take can be forced: PyTorch reads ``ATEN_CPU_CAPABILITY`` (``default``,
``avx2``, ``avx512``) for its kernels' vector width, Intel MKL reads ``MKL_CBWR`` for a code path that does not
depend on the CPU, ``torch.backends.mkldnn`` switches oneDNN off, and the thread count changes how sums split.
Each README snippet is run under each setting in a fresh process, as ``tests/test_readme.py`` runs it; the page
gives, for every number of every documented output line, the spread over the settings, which the README check's
tolerances are set from (``tests/test_readme.py`` reads ``results/float_paths.json``).

    python benchmarks/units/check_float_paths.py [--settings ...] [--jobs 2] [--beside-other-cpus]

``--beside-other-cpus`` keeps the runs of the last record that were made on a CPU of another model (each setting
named with its CPU), so the spreads cover both makes of the project's machines, not only the forced paths of one.
"""

from __future__ import annotations

import argparse
import json
import os
import re
import subprocess
import sys
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # benchmarks/: the helpers
from helpers import PACKAGE_COMMIT, RESULTS, ROOT, cpu_model, runs_folder, write_results  # noqa: E402

README = ROOT / "README.md"
BLOCK = re.compile(r"```python\n(.*?)```(?:(?:(?!```).)*?```text\n(.*?)```)?", re.S)  # as tests/test_readme.py
CPU = cpu_model()  # the runs are cached and kept by it
NUMBER = re.compile(r"-?\d+(?:\.\d+)?(?:e-?\d+)?")

#: name -> (environment, torch settings made before the snippet runs)
SETTINGS = {
    "native": ({}, ""),
    "avx2": ({"ATEN_CPU_CAPABILITY": "avx2"}, ""),
    "default (no vector kernels)": ({"ATEN_CPU_CAPABILITY": "default"}, ""),
    "MKL compatible, avx2": ({"MKL_CBWR": "COMPATIBLE", "ATEN_CPU_CAPABILITY": "avx2"}, ""),
    "MKL compatible, default": ({"MKL_CBWR": "COMPATIBLE", "ATEN_CPU_CAPABILITY": "default"}, ""),
    "MKL AVX2 path": ({"MKL_CBWR": "AVX2"}, ""),
    "oneDNN off": ({}, "torch.backends.mkldnn.enabled = False"),
    "2 threads": ({"OMP_NUM_THREADS": "2"}, "torch.set_num_threads(2)"),
    "4 threads": ({"OMP_NUM_THREADS": "4"}, "torch.set_num_threads(4)"),
}


def snippets() -> list[tuple[str, str]]:
    return BLOCK.findall(README.read_text())


def numbered_lines(text: str) -> list[str]:
    return [line for line in text.splitlines() if NUMBER.search(line)]


def run_setting(name: str) -> dict:
    """Every README snippet in a fresh process under one setting: the printed lines with numbers. Each run is
    cached as it ends (``results/runs/float_paths/``, by CPU, package commit and setting), for these snippets."""
    cache = runs_folder("float_paths") / re.sub(r"\W+", "_", f"{CPU}_{PACKAGE_COMMIT}_{name}").strip("_")
    cache = cache.with_suffix(".json")
    if cache.exists():
        cached = json.loads(cache.read_text())
        if cached["snippets"] == snippets():
            return {"setting": name, "blocks": {int(k): b for k, b in cached["blocks"].items()}}
    env, torch_code = SETTINGS[name]
    out = {}
    for k, (code, _) in enumerate(snippets()):
        program = f"import torch\n{torch_code}\n" + code
        done = subprocess.run([sys.executable, "-c", program], env=dict(os.environ, **env), capture_output=True,
                              text=True, cwd=ROOT)
        out[k] = {"lines": numbered_lines(done.stdout), "returncode": done.returncode,
                  "stderr": done.stderr[-1500:] if done.returncode else ""}
    cache.parent.mkdir(parents=True, exist_ok=True)
    cache.write_text(json.dumps({"snippets": snippets(), "blocks": out}, indent=1))
    return {"setting": name, "blocks": out}


def shape(line: str) -> str:
    """A printed line without its numbers: what must not move at all (the words, a verdict)."""
    return NUMBER.sub("#", line.strip())


def other_shapes(runs: list[dict]) -> list[dict]:
    """Each documented line that a setting printed in another shape (other words, another verdict)."""
    out = []
    for k, (_, documented) in enumerate(snippets()):
        want = numbered_lines(documented)
        for run in runs:
            got = run["blocks"][k]["lines"]
            for i, line in enumerate(want):
                if i >= len(got) or shape(got[i]) != shape(line):
                    out.append({"block": k, "line": i, "setting": run["setting"],
                                "printed": got[i].strip() if i < len(got) else ""})
    return out


def spreads(runs: list[dict]) -> list[dict]:
    """Per README block, line and number: the documented value, each setting's (where it printed the line in
    the documented shape), and the spread."""
    table = []
    for k, (_, documented) in enumerate(snippets()):
        for i, line in enumerate(numbered_lines(documented)):
            shown = [float(x) for x in NUMBER.findall(line)]
            for j, value in enumerate(shown):
                got = {}
                for run in runs:
                    lines = run["blocks"][k]["lines"]
                    if i < len(lines) and shape(lines[i]) == shape(line):
                        got[run["setting"]] = float(NUMBER.findall(lines[i])[j])
                values = list(got.values())
                spread = (max(values) - min(values)) if values else float("nan")
                table.append({"block": k, "line": i, "index": j, "text": line.strip()[:90], "documented": value,
                              "values": got, "spread": spread,
                              "relative_spread": spread / abs(value) if value else float("nan")})
    return table


def other_cpu_runs(cpu: str) -> list[dict]:
    """The last record's runs made on another CPU model (a record before runs carried their CPU: its machine's)."""
    path = RESULTS / "float_paths.json"
    if not path.exists():
        return []
    record = json.loads(path.read_text())
    out = []
    for run in record["runs"]:
        made_on = run.get("cpu", record["machine"]["cpu"])
        if made_on != cpu:
            name = run["setting"] if run["setting"].endswith(f"({made_on})") else f"{run['setting']} ({made_on})"
            blocks = {int(k): b for k, b in run["blocks"].items()}  # JSON keeps the block numbers as strings
            out.append(dict(run, setting=name, cpu=made_on, blocks=blocks,
                            package_commit=run.get("package_commit", record["package_commit"])))
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--settings", nargs="+", default=list(SETTINGS), choices=list(SETTINGS))
    parser.add_argument("--jobs", type=int, default=2)
    parser.add_argument("--beside-other-cpus", action="store_true",
                        help="keep the last record's runs made on another CPU model")
    args = parser.parse_args()
    cpu = CPU
    with ThreadPoolExecutor(args.jobs) as pool:
        runs = [dict(run, cpu=cpu, package_commit=PACKAGE_COMMIT) for run in pool.map(run_setting, args.settings)]
    if args.beside_other_cpus:
        runs = [dict(run, setting=f"{run['setting']} ({cpu})") for run in runs] + other_cpu_runs(cpu)
    failed = [f"{r['setting']} block {k + 1}: {b['stderr']}" for r in runs for k, b in r["blocks"].items()
              if b["returncode"]]
    table = spreads(runs)
    shapes = other_shapes(runs)
    lines = ["# The README's numbers under other float paths", "",
             "Each README snippet run in a fresh process under each setting (another CPU's vector width, MKL's "
             "CPU-independent path, oneDNN off, more threads); per documented number, the values and their spread. "
             f"Settings: {', '.join(run['setting'] for run in runs)}.", ""]
    kept = sorted({(run["cpu"], run["package_commit"]) for run in runs if run["cpu"] != cpu})
    lines += [f"Runs on another CPU, kept from an earlier record: {c}, package commit {p}." for c, p in kept]
    lines += [""] if kept else []
    lines += [f"Failed: {f}" for f in failed] + ([""] if failed else [])
    lines += ["Lines printed in another shape than the README's (other words or verdict; their numbers are left "
              "out of the spreads below):", ""] + [
        f"- block {d['block'] + 1}, line {d['line']}, {d['setting']}: `{d['printed'][:200]}`" for d in shapes
    ] + ["" if shapes else "- none", ""]
    lines += ["| block | line | number | documented | min | max | relative spread |", "|---" * 7 + "|"]
    for row in table:
        values = list(row["values"].values())
        lines.append(f"| {row['block'] + 1} | `{row['text'][:60]}` | {row['index']} | {row['documented']:g} | "
                     f"{min(values) if values else float('nan'):g} | {max(values) if values else float('nan'):g} | "
                     f"{row['relative_spread']:.2%} |")
    write_results("float_paths", {"settings": [run["setting"] for run in runs], "readme": README.read_text(), "numbers": table,
                                  "other_shapes": shapes, "failed": failed, "runs": runs}, "\n".join(lines))
    print("\n".join(lines))


if __name__ == "__main__":
    main()
