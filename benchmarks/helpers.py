"""Shared helpers of the benchmark scripts: machine description, result files, run records, data of the studies'
own systems.

Every script of ``benchmarks/<question>/`` runs by its path (``python benchmarks/speed/bench_speed.py``) and
first puts ``benchmarks/`` on ``sys.path``; every import between benchmark files is then made from there: this
module as ``helpers``, a study's own modules as ``identification.systems``, ``uncertainty.protocol``, ... No
driver imports another driver. Results stay in ``benchmarks/results/`` (:data:`RESULTS`), whatever folder the
script that writes them lives in.
"""

from __future__ import annotations

import json
import os
import platform
import re
import subprocess
import sys
import time
from datetime import datetime, timezone
from pathlib import Path
from typing import Callable

#: The repository, and the benchmarks' own folder in it.
ROOT = Path(__file__).resolve().parents[1]
BENCHMARKS = ROOT / "benchmarks"
RESULTS = BENCHMARKS / "results"
#: Every study's run records, one folder per study (``runs/<study>/``); the summary pages stay in ``RESULTS``,
#: where the documentation build reads them.
RUNS = RESULTS / "runs"


def _read_package_commit() -> str:
    """The last commit that changed the package (not the benchmarks' own result commits), with
    ``+uncommitted`` when the package differs from it."""
    try:
        def git(*args):  # an absolute path: a relative one would be read from the script's folder
            return subprocess.run(["git", *args, "--", str(ROOT / "sklearn_hybrid")], capture_output=True,
                                  text=True, cwd=ROOT).stdout.strip()
        commit = git("log", "-1", "--format=%h") or "unknown"
        return commit + ("+uncommitted" if git("status", "--porcelain") else "")
    except OSError:
        return "unknown"


#: Read once, when a benchmark starts: a commit made while a long run goes on is not the code
#: that run executes.
PACKAGE_COMMIT = _read_package_commit()


def reference_seconds() -> float:
    """Seconds a fixed small workload takes here: 1000 Adam steps of a 32x32 MLP, one torch thread.

    Machines of the same kind differ in speed by up to ~3x (the same closed-loop run took 217 s
    one day and 78 s the next); this figure, beside a benchmark's timings, tells which it was.
    Measured in a fresh ``torch.set_num_threads(1)`` state and restored afterwards.
    """
    import time

    import torch

    threads = torch.get_num_threads()
    torch.set_num_threads(1)
    try:
        gen = torch.Generator().manual_seed(0)
        x = torch.randn(512, 2, generator=gen, dtype=torch.float64)
        net = torch.nn.Sequential(torch.nn.Linear(2, 32), torch.nn.Tanh(), torch.nn.Linear(32, 32),
                                  torch.nn.Tanh(), torch.nn.Linear(32, 1)).double()
        opt = torch.optim.Adam(net.parameters(), lr=1e-3)
        start = time.perf_counter()
        for _ in range(1000):
            opt.zero_grad()
            loss = (net(x) - x[:, :1] ** 3).pow(2).mean()
            loss.backward()
            opt.step()
        return round(time.perf_counter() - start, 3)
    finally:
        torch.set_num_threads(threads)


def cpu_model() -> str:
    """The CPU's model name (``/proc/cpuinfo``'s, else the platform's)."""
    cpu = platform.processor() or "unknown"
    try:
        with open("/proc/cpuinfo") as fh:
            cpu = next(line.split(":", 1)[1].strip() for line in fh if line.startswith("model name"))
    except (OSError, StopIteration):
        pass
    return cpu


def machine_description() -> dict:
    """CPU model, core count, memory, library versions and speed (:func:`reference_seconds`)."""
    import numpy
    import sklearn
    import torch

    cpu = cpu_model()
    try:
        mem = os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES") / 2**30
    except (ValueError, OSError):
        mem = float("nan")
    return {"cpu": cpu, "cores": os.cpu_count(), "memory_gib": round(mem, 1),
            "python": platform.python_version(), "torch": torch.__version__,
            "torch_threads": torch.get_num_threads(), "numpy": numpy.__version__,
            "scikit-learn": sklearn.__version__, "reference_s": reference_seconds(),
            "date": datetime.now(timezone.utc).strftime("%Y-%m-%d %H:%M UTC")}


def cpu_seconds() -> float:
    """CPU seconds of this process and its worker processes (joblib's loky workers stay alive between calls)."""
    import psutil

    total = time.process_time()
    for child in psutil.Process().children(recursive=True):
        try:
            t = child.cpu_times()
            total += t.user + t.system
        except psutil.Error:  # ended meanwhile
            pass
    return total


def rk4_trajectories(rhs: Callable, X, dt: float, n_steps: int, substeps: int = 64):
    """States of ``dv/dt = rhs(v)`` (numpy, batch first) at ``dt, ..., n_steps * dt`` from ``X``, by a fine
    classic RK4 (``substeps`` steps per output interval): the data generator of the benchmarks' own systems.

    Returns an ndarray of shape ``(n, n_steps, *X.shape[1:])``.
    """
    import numpy as np

    v, h, out = np.array(X, dtype=float), dt / substeps, []
    for _ in range(n_steps):
        for _ in range(substeps):
            k1 = rhs(v)
            k2 = rhs(v + h / 2 * k1)
            k3 = rhs(v + h / 2 * k2)
            k4 = rhs(v + h * k3)
            v = v + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
        out.append(v)
    return np.stack(out, axis=1)


def selection_summary(out, fields: tuple = ("output", "term", "gain", "z")) -> dict:
    """What a ``close_the_loop`` result's selection did: the threshold z had to exceed, the three
    best first-step candidates by gain (``fields`` of each) and the terms added."""
    first = [s for s in out.steps if s.get("step") == 1 and "gain" in s]
    best = sorted(first, key=lambda s: -s["gain"])[:3]
    return {"threshold": first[0]["threshold"] if first else None,
            "best_first_step": [{k: s[k] for k in fields} for s in best],
            "added": [f"{t['term']} [{t['output']}]" for t in out.added]}


def runs_folder(study: str) -> Path:
    """The folder of one study's run records, ``results/runs/<study>`` (``study`` may name a sub-folder)."""
    return RUNS / study


def script_path(path: str | Path) -> str:
    """A script's path from the repository root, as the pages quote it (``benchmarks/speed/bench_speed.py``)."""
    path = Path(path).resolve()
    return path.relative_to(ROOT).as_posix() if path.is_relative_to(ROOT) else path.as_posix()


def as_run_today(command: str) -> str:
    """``command`` with each ``benchmarks/<script>.py`` of the one flat folder the benchmarks had until issue 50
    replaced by that script's path now: the records keep the command they ran, the pages quote one that runs."""
    def moved(match: re.Match) -> str:
        found = sorted(BENCHMARKS.glob(f"*/{match.group(1)}"))
        return script_path(found[0]) if len(found) == 1 else match.group(0)

    return re.sub(r"benchmarks/(\w+\.py)", moved, command)


def write_results(name: str, payload: dict, markdown: str) -> Path:
    """Write ``results/<name>.json`` and ``results/<name>.md`` (with the machine description)."""
    RESULTS.mkdir(exist_ok=True)
    machine = machine_description()
    (RESULTS / f"{name}.json").write_text(json.dumps({"machine": machine, "package_commit": PACKAGE_COMMIT,
                                                      **payload}, indent=2))
    script = getattr(sys.modules["__main__"], "__file__", sys.argv[0])  # absolute, whatever the cwd is by now
    command = "python " + " ".join([script_path(script), *sys.argv[1:]])
    lines = [markdown.rstrip(), "", "Machine: " + ", ".join(f"{k} {v}" for k, v in machine.items()),
             "", f"Command: `{command}`; package commit {PACKAGE_COMMIT}."]
    path = RESULTS / f"{name}.md"
    path.write_text("\n".join(lines) + "\n")
    return path


def run_each_case(folder: Path, cases: list[str], noises: list[float], run: Callable[[str, float], dict],
                  summary: Callable[[dict], str], cached: Callable[[dict], bool] = lambda result: True) -> None:
    """Run ``run(name, noise)`` for every case and noise level, one torch thread, caching each result as
    ``folder/<name>_noise<level>.json`` as soon as it ends (a long sweep resumes where it stopped); a case whose
    cached result satisfies ``cached`` is skipped. ``summary(result)`` is printed after each run."""
    import torch

    torch.set_num_threads(1)
    folder.mkdir(parents=True, exist_ok=True)
    for name in cases:
        for noise in noises:
            path = folder / f"{name}_noise{noise:g}.json"
            if path.exists() and cached(json.loads(path.read_text())):
                print(f"{name} {noise:g}: cached", flush=True)
                continue
            result = run(name, noise)
            path.write_text(json.dumps(result, indent=1, default=float) + "\n")
            print(f"{name} {noise:g}: {summary(result)}", flush=True)
