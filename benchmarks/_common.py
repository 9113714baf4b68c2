"""Shared helpers of the benchmark scripts: machine description and result files."""

from __future__ import annotations

import json
import os
import platform
import subprocess
import sys
from datetime import datetime, timezone
from pathlib import Path

RESULTS = Path(__file__).resolve().parent / "results"


def _read_package_commit() -> str:
    """The last commit that changed the package (not the benchmarks' own result commits), with
    ``+uncommitted`` when the package differs from it."""
    root = Path(__file__).resolve().parents[1]  # a relative path would be read from benchmarks/
    try:
        def git(*args):
            return subprocess.run(["git", *args, "--", str(root / "sklearn_hybrid")], capture_output=True,
                                  text=True, cwd=root).stdout.strip()
        commit = git("log", "-1", "--format=%h") or "unknown"
        return commit + ("+uncommitted" if git("status", "--porcelain") else "")
    except OSError:
        return "unknown"


#: Read once, when a benchmark starts: a commit made while a long run goes on is not the code
#: that run executes.
PACKAGE_COMMIT = _read_package_commit()


def machine_description() -> dict:
    """CPU model, core count, memory and library versions of this machine."""
    import numpy
    import sklearn
    import torch

    cpu = platform.processor() or "unknown"
    try:
        with open("/proc/cpuinfo") as fh:
            cpu = next(line.split(":", 1)[1].strip() for line in fh if line.startswith("model name"))
    except (OSError, StopIteration):
        pass
    try:
        mem = os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES") / 2**30
    except (ValueError, OSError):
        mem = float("nan")
    return {"cpu": cpu, "cores": os.cpu_count(), "memory_gib": round(mem, 1),
            "python": platform.python_version(), "torch": torch.__version__,
            "torch_threads": torch.get_num_threads(), "numpy": numpy.__version__,
            "scikit-learn": sklearn.__version__,
            "date": datetime.now(timezone.utc).strftime("%Y-%m-%d %H:%M UTC")}


def write_results(name: str, payload: dict, markdown: str) -> Path:
    """Write ``results/<name>.json`` and ``results/<name>.md`` (with the machine description)."""
    RESULTS.mkdir(exist_ok=True)
    machine = machine_description()
    (RESULTS / f"{name}.json").write_text(json.dumps({"machine": machine, "package_commit": PACKAGE_COMMIT,
                                                      **payload}, indent=2))
    command = "python " + " ".join(["benchmarks/" + Path(sys.argv[0]).name, *sys.argv[1:]])
    lines = [markdown.rstrip(), "", "Machine: " + ", ".join(f"{k} {v}" for k, v in machine.items()),
             "", f"Command: `{command}`; package commit {PACKAGE_COMMIT}."]
    path = RESULTS / f"{name}.md"
    path.write_text("\n".join(lines) + "\n")
    return path
