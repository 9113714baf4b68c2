"""The package on a CUDA GPU beside the same machine's CPU: does every path run there, agree, and how fast?

Three parts, each on ``device="cpu"`` and ``device="cuda"`` in the same process (fixed iterations,
``tol=None``, so both sides do the same work):

* **single fit**: the Quick start's pendulum (``make_pendulum``), 300 iterations; theta and predictions
  compared; then ``close_the_loop`` and ``profile_theta`` (the stacked engine) on each fit;
* **stacked sweep**: ``HybridRegressorCV`` over 3 rhos x 5 seeds (15 members as one batched model),
  300 iterations; each member's theta compared between the devices;
* **members**: the same sweep with more seeds on the GPU alone (15, 60, 240 members), seconds per iteration:
  what stacking buys on a GPU.

Each part records its traceback instead of stopping the script, so one failure still leaves the others.

    python benchmarks/speed/bench_gpu.py [--iters 300] [--out DIR]
"""

from __future__ import annotations

import argparse
import json
import sys
import time
import traceback
from pathlib import Path

import numpy as np
import torch

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # benchmarks/: the helpers, the studies' modules
from helpers import PACKAGE_COMMIT, RESULTS, machine_description  # noqa: E402


def _pendulum():
    from sklearn_hybrid.datasets import make_pendulum
    from sklearn_hybrid.demo import pendulum_f

    data = make_pendulum(random_state=0)
    return pendulum_f, data


def _timed(fn):
    start = time.perf_counter()
    out = fn()
    if torch.cuda.is_available():
        torch.cuda.synchronize()
    return out, time.perf_counter() - start


def single_fit(devices, iters):
    from sklearn_hybrid import HybridRegressor, OdeStructure
    from sklearn_hybrid.diagnosis import close_the_loop
    from sklearn_hybrid.identifiability import profile_theta

    science, data = _pendulum()
    X, y = data.X_train, data.y_train
    out, fits = {}, {}
    for dev in devices:
        est, seconds = _timed(lambda: HybridRegressor(science=science, structure=OdeStructure(dt=0.2), random_state=0,
                                                      max_iter=iters, tol=None, verbose=False,
                                                      device=dev).fit(X, y))
        fits[dev] = est
        row = {"fit_s": seconds, "ms_per_iteration": 1000 * seconds / est.n_iter_, "n_iter": int(est.n_iter_),
               "omega": float(est.theta_["omega"]), "device_": str(est.device_)}
        for name, step in (("loop", lambda: close_the_loop(est, X, y, state_names=["v", "v_dot"])),
                           ("profile", lambda: profile_theta(est, X, y, verbose=False))):
            try:
                result, seconds = _timed(step)
                row[f"{name}_s"] = seconds
                if name == "loop":
                    row["loop_added"] = [t["term"] for t in result.added]
                    row["loop_omega"] = float(result.science_theta["omega"])
                else:
                    row["profile_verdict"] = result.verdicts["omega"]
                    row["profile_interval"] = [float(v) for v in result.intervals["omega"]]
            except Exception:  # noqa: BLE001 - a finding of this benchmark, recorded
                row[f"{name}_error"] = traceback.format_exc()[-1500:]
        out[dev] = row
    if len(fits) == 2:
        a, b = fits.values()
        out["max_abs_omega_difference"] = abs(float(a.theta_["omega"]) - float(b.theta_["omega"]))
        out["max_abs_prediction_difference"] = float(np.max(np.abs(a.predict(data.X_test) - b.predict(data.X_test))))
    return out


def _sweep(dev, iters, seeds):
    from sklearn_hybrid import HybridRegressor, HybridRegressorCV, OdeStructure

    science, data = _pendulum()
    base = HybridRegressor(science=science, structure=OdeStructure(dt=0.2), max_iter=iters, verbose=False, device=dev)
    cv = HybridRegressorCV(base, rhos=[0.01, 0.05, 0.2], seeds=list(seeds))
    _, seconds = _timed(lambda: cv.fit(data.X_train, data.y_train))
    return cv, seconds


def stacked_sweep(devices, iters):
    out, thetas = {}, {}
    for dev in devices:
        cv, seconds = _sweep(dev, iters, range(5))
        thetas[dev] = np.asarray(cv.cv_results_["theta_omega"], dtype=float)
        out[dev] = {"members": len(thetas[dev]), "fit_s": seconds, "ms_per_iteration": 1000 * seconds / iters,
                    "best_params": {k: float(v) for k, v in cv.best_params_.items()},
                    "omega_best": float(cv.theta_["omega"]), "omega_members": thetas[dev].tolist()}
    if len(thetas) == 2:
        a, b = thetas.values()
        out["max_abs_member_omega_difference"] = float(np.max(np.abs(a - b)))
    return out


def member_scaling(dev, iters, n_seeds=(5, 20, 80)):
    rows = []
    for n in n_seeds:
        cv, seconds = _sweep(dev, iters, range(n))
        rows.append({"members": 3 * n, "fit_s": seconds, "ms_per_iteration": 1000 * seconds / iters,
                     "ms_per_member_iteration": 1000 * seconds / iters / (3 * n)})
    return rows


def _part(name, fn, results):
    print(f"--- {name}", flush=True)
    start = time.perf_counter()
    try:
        results[name] = fn()
    except Exception:  # noqa: BLE001 - recorded, the other parts still run
        results[name] = {"error": traceback.format_exc()[-3000:]}
    results[name + "_wall_s"] = time.perf_counter() - start
    print(json.dumps(results[name], indent=1, default=str)[:3000], flush=True)


def render(results) -> str:
    lines = ["# The package on a CUDA GPU beside the same machine's CPU", "",
             "`benchmarks/speed/bench_gpu.py`: the same work on `device=\"cpu\"` and `device=\"cuda\"` in one "
             "process (fixed iterations, no early stopping).", ""]
    fit = results.get("single_fit", {})
    if "error" not in fit:
        lines += ["## Single fit (Quick start pendulum), its closed loop and profile", "",
                  "| device | fit s | ms/iteration | omega | loop s | loop added | loop omega | profile s | verdict | interval |",
                  "|---|---|---|---|---|---|---|---|---|---|"]
        for dev, r in fit.items():
            if not isinstance(r, dict):
                continue
            lines.append(f"| {dev} | {r['fit_s']:.1f} | {r['ms_per_iteration']:.1f} | {r['omega']:.5f} | "
                         f"{r.get('loop_s', float('nan')):.1f} | {', '.join(r.get('loop_added', [])) or '-'} | "
                         f"{r.get('loop_omega', float('nan')):.5f} | {r.get('profile_s', float('nan')):.1f} | "
                         f"{r.get('profile_verdict', 'error')} | {r.get('profile_interval', '-')} |")
            for key in ("loop_error", "profile_error"):
                if key in r:
                    lines += ["", f"{dev} {key}: `{r[key].strip().splitlines()[-1]}`"]
        if "max_abs_omega_difference" in fit:
            lines += ["", f"cpu vs cuda: |omega difference| {fit['max_abs_omega_difference']:.2e}, largest "
                      f"|prediction difference| {fit['max_abs_prediction_difference']:.2e} (float32)."]
    sweep = results.get("stacked_sweep", {})
    if "error" not in sweep:
        lines += ["", "## Stacked sweep (HybridRegressorCV, 3 rhos x 5 seeds)", "",
                  "| device | members | s | ms/iteration | best | omega (best) |", "|---|---|---|---|---|---|"]
        for dev, r in sweep.items():
            if isinstance(r, dict):
                lines.append(f"| {dev} | {r['members']} | {r['fit_s']:.1f} | {r['ms_per_iteration']:.1f} | "
                             f"{r['best_params']} | {r['omega_best']:.5f} |")
        if "max_abs_member_omega_difference" in sweep:
            lines += ["", f"Largest |omega difference| of a member between the devices: "
                      f"{sweep['max_abs_member_omega_difference']:.2e}."]
    scaling = results.get("member_scaling")
    if isinstance(scaling, list):
        lines += ["", "## Members stacked on the GPU", "", "| members | s | ms/iteration | ms per member-iteration |",
                  "|---|---|---|---|"]
        lines += [f"| {r['members']} | {r['fit_s']:.1f} | {r['ms_per_iteration']:.1f} | "
                  f"{r['ms_per_member_iteration']:.2f} |" for r in scaling]
    for name in ("single_fit", "stacked_sweep", "member_scaling"):
        part = results.get(name)
        if isinstance(part, dict) and "error" in part:
            lines += ["", f"**{name} failed**:", "", "```text", part["error"].strip(), "```"]
    return "\n".join(lines)


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--iters", type=int, default=300)
    parser.add_argument("--out", type=Path, default=RESULTS)
    parser.add_argument("--devices", nargs="+", default=["cpu", "cuda"])
    args = parser.parse_args(argv)
    torch.set_num_threads(1)
    results = {"machine": machine_description(), "package_commit": PACKAGE_COMMIT, "iters": args.iters}
    if torch.cuda.is_available():
        results["machine"]["gpu"] = torch.cuda.get_device_name(0)
    args.out.mkdir(parents=True, exist_ok=True)
    for name, part in (("single_fit", lambda: single_fit(args.devices, args.iters)),
                       ("stacked_sweep", lambda: stacked_sweep(args.devices, args.iters)),
                       ("member_scaling", lambda: member_scaling(args.devices[-1], args.iters))):
        _part(name, part, results)
        # written after every part: a run stopped by a time limit keeps what it finished
        (args.out / "gpu.json").write_text(json.dumps(results, indent=2, default=str))
        text = render(results) + "\n\nMachine: " + ", ".join(f"{k} {v}" for k, v in results["machine"].items())
        text += (f"\n\nCommand: `python benchmarks/speed/bench_gpu.py --iters {args.iters}`; "
                 f"package commit {PACKAGE_COMMIT}.\n")
        (args.out / "gpu.md").write_text(text)
    print(text)


if __name__ == "__main__":
    main()
