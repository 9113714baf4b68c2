"""Why theta stalls or drifts on the wind-tunnel task (issue 10, item 1): one probe per hypothesis.

Every probe fits the wind-tunnel task of ``table1.py`` (cpu budget: the SIMULATED stand-in
where the measured files are absent; 1,500 iterations, lr 1e-3, seed 0 unless a probe says
otherwise) and is cached as one JSON file in ``results/runs/theta_convergence/``;
``results/theta_convergence.md`` renders them. Hypotheses and the probe that tests each:

* **data** -- does the stand-in identify r at all, and at which value? The science-only least
  squares fit ``y ~ (1 - r) S_max (l_in^2 - l_out^2)`` in closed form (no training), overall
  and per hatch position; the stand-in is generated with r(H) = 0.75 + 0.15 H / 45.
* **reach** -- the bounded reparametrisation ``r = sigmoid(raw)`` and Adam: Adam moves raw by
  at most about lr per step, so over a cosine schedule raw travels at most ``lr * max_iter / 2``
  and r at most ``sigmoid(raw0 + that)``. Probe: a science-only fit through the training loop
  (a callable structure that ignores the network), at lr_theta = lr and larger.
* **adam** -- how much of Adam's possible travel theta uses: ``|raw_end - raw_0| / sum(lr_t)``
  (1: a steady push in one direction; near 0: a gradient that changes sign).
* **schedule** -- does theta end settled or frozen? Twice the iterations at the same settings:
  a settled theta ends at the same value; a theta stopped by the schedule ends further on.
  drift_iter: largest relative change over the last 10 % of iterations (what table1 reports);
  drift_lr: over the last 10 % of the summed learning rate (schedule-independent).

Usage::

    python benchmarks/paper/bench_theta_convergence.py            # runs what is not cached, renders
    python benchmarks/paper/bench_theta_convergence.py --render   # only renders
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np
import torch

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # benchmarks/: the helpers, the studies' modules
from helpers import runs_folder, write_results  # noqa: E402
from paper.tasks import TASKS, wind_tunnel_spec  # noqa: E402
from sklearn_hybrid import HybridRegressor, models  # noqa: E402

CACHE = runs_folder("theta_convergence")
BASE = dict(lr=1e-3, max_iter=1500, seed=0)

#: name -> settings (method, rho, lr_theta, max_iter, science_only, bounded)
PROBES = {
    "science-only, lr_theta=lr": dict(method="erm", science_only=True),
    "science-only, lr_theta=4 lr": dict(method="erm", science_only=True, lr_theta=4e-3),
    "science-only, lr_theta=10 lr": dict(method="erm", science_only=True, lr_theta=1e-2),
    "erm, lr_theta=lr": dict(method="erm"),
    "erm, lr_theta=4 lr": dict(method="erm", lr_theta=4e-3),
    "fsam rho=0.05, lr_theta=lr": dict(method="fsam", rho=0.05),
    "fsam rho=0.05, lr_theta=4 lr": dict(method="fsam", rho=0.05, lr_theta=4e-3),
    "fsam rho=0.05, lr_theta=4 lr, 3000 it": dict(method="fsam", rho=0.05, lr_theta=4e-3,
                                                  max_iter=3000),
}


def _science_only(x, f, g):
    return f(x)


def _unused_net():
    return torch.nn.Linear(1, 1)


def _slug(name):
    return "".join(c if c.isalnum() else "_" for c in name).strip("_")


def _cosine_lr(lr, n, eta_min=1e-6):
    """The learning rate at each iteration of the engine's schedule (CosineAnnealingLR)."""
    t = np.arange(n)
    return eta_min + (lr - eta_min) * (1 + np.cos(np.pi * t / n)) / 2


def _drift_iter(r):
    start = r[int(0.9 * len(r))]
    return float(abs(r[-1] - start) / abs(r[-1]))


def _drift_lr(r, lr_t):
    cum = np.cumsum(lr_t)
    start = int(np.searchsorted(cum, 0.9 * cum[-1]))
    return float(abs(r[-1] - r[start]) / abs(r[-1]))


def data_probe() -> dict:
    """Closed-form science-only least squares of r on the training split."""
    d = wind_tunnel_spec("cpu").data
    b = models.wind_tunnel_f(torch.tensor(d.X_train), r=0.0).numpy()
    y, hatch = d.y_train, d.X_train[..., 2]
    out = {}
    for name, m in (("all", np.ones_like(y, bool)), ("hatch 0", hatch == 0),
                    ("hatch 45", hatch == 45)):
        c = (b[m] * y[m]).sum() / (b[m] * b[m]).sum()
        out[name] = {"r": float(1 - c), "share": float(m.mean())}
    out["rmse"] = {f"{r:g}": float(np.sqrt(np.mean((y - (1 - r) * b) ** 2)))
                   for r in (0.5, 0.7, 0.75, 0.8, 0.835, 0.9)}
    return out


#: the paper's learning rate per task (20,000 iterations each; table1.py's docstring)
PAPER_LR = {"pendulum": 1e-4, "duffing": 1e-4, "reaction_diffusion": 1e-4, "wind_tunnel": 3e-4,
            "pendulum_images": 1e-3, "light_tunnel": 1e-3}


def budget_probe() -> list[dict]:
    """theta's reach per task: ``lr_theta * max_iter / 2`` against the raw distance to its reference."""
    from sklearn_hybrid.science import read_signature

    rows = []
    for task in TASKS:
        kw, reference = TASKS[task]("cpu").kw, TASKS[task]("smoke").theta
        _, start = read_signature(kw["science"])
        bounds = kw.get("theta_bounds") or {}
        distance = 0.0
        for name, ref in reference.items():
            a, b = np.ravel(start[name]), np.ravel(ref)
            if name in bounds:  # two finite bounds: raw is the logit of the position
                low, high = bounds[name]
                a, b = ((v - low) / (high - low) for v in (a, b))
                a, b = np.log(a / (1 - a)), np.log(b / (1 - b))
            distance = max(distance, float(np.max(np.abs(b - a))))
        rows.append({"task": task, "distance": distance,
                     "paper": PAPER_LR[task] * 20000 / 2,
                     "cpu": (kw.get("lr_theta") or kw["lr"]) * kw["max_iter"] / 2})
    return rows


def run_probe(name: str) -> dict:
    path = CACHE / f"{_slug(name)}.json"
    if path.exists():
        return json.loads(path.read_text())
    torch.set_num_threads(1)
    cfg = {**BASE, **PROBES[name]}
    spec = wind_tunnel_spec("cpu")
    d = spec.data
    kw = dict(spec.kw, lr=cfg["lr"], max_iter=cfg["max_iter"], random_state=cfg["seed"],
              method=cfg["method"], tol=None)
    if "rho" in cfg:
        kw["rho"] = cfg["rho"]
    if "lr_theta" in cfg:
        kw["lr_theta"] = cfg["lr_theta"]
    if cfg.get("science_only"):
        kw.update(structure=_science_only, residual=_unused_net)
    if not cfg.get("bounded", True):
        kw["theta_bounds"] = None
    start = time.perf_counter()
    est = HybridRegressor(**kw).fit(d.X_train, d.y_train)
    seconds = time.perf_counter() - start
    r = np.ravel(est.history_["theta"]["r"])
    lr_t = _cosine_lr(kw.get("lr_theta") or kw["lr"], len(r))
    raw = np.log(r) - np.log1p(-r) if cfg.get("bounded", True) else r
    raw0 = 0.0 if cfg.get("bounded", True) else 0.5
    record = {"name": name, "settings": cfg, "r_end": float(r[-1]), "r_max": float(r.max()),
              "r_at": {f"{q}": float(r[int(q * len(r)) - 1]) for q in (0.25, 0.5, 0.75, 1.0)},
              "adam_use": float(abs(raw[-1] - raw0) / lr_t.sum()),
              "raw_budget": float(lr_t.sum()),
              "drift_iter": _drift_iter(r), "drift_lr": _drift_lr(r, lr_t),
              "val_rmse": float(np.sqrt(np.mean((est.predict(d.X_val) - d.y_val) ** 2))),
              "seconds": seconds, "path": r[:: max(1, len(r) // 100)].tolist()}
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(record, indent=1))
    return record


def render(data: dict, runs: list[dict], budgets: list[dict] | None = None) -> str:
    lines = ["# Theta convergence on the wind-tunnel task (issue 10, item 1)", "",
             "`python benchmarks/paper/bench_theta_convergence.py` (hypotheses in its docstring). "
             "Wind-tunnel task of `table1.py`, cpu budget, SIMULATED stand-in, lr 1e-3, "
             "1,500 iterations, seed 0, r starts at 0.5, cosine schedule to 1e-6.", "",
             "## Data: what the stand-in says about r (closed-form science-only least squares)",
             "", "| samples | share | r |", "|---|---|---|"]
    for k in ("all", "hatch 0", "hatch 45"):
        lines.append(f"| {k} | {data[k]['share']:.2f} | {data[k]['r']:.3f} |")
    lines += ["", "Science-only RMSE (Pa) at r: " + ", ".join(
        f"{k}: {v:.2f}" for k, v in data["rmse"].items()), "",
        "## Training probes", "",
        "adam use: |raw_end - raw_0| / sum of theta's learning rates (1: Adam pushed r the "
        "whole way in one direction). drift (iter): relative change of r over the last 10 % "
        "of iterations; drift (lr): over the last 10 % of the summed learning rate.", "",
        "| probe | iters | r at 25 % | 50 % | 75 % | end | adam use | drift (iter) | "
        "drift (lr) | val RMSE | s |", "|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in runs:
        a = r["r_at"]
        lines.append(f"| {r['name']} | {r['settings']['max_iter']} | {a['0.25']:.3f} | "
                     f"{a['0.5']:.3f} | {a['0.75']:.3f} | {a['1.0']:.3f} | {r['adam_use']:.2f} | "
                     f"{r['drift_iter']:.2g} | {r['drift_lr']:.2g} | {r['val_rmse']:.3g} | "
                     f"{r['seconds']:.0f} |")
    if budgets:
        lines += ["", "## Reach: theta's learning-rate budget per task (no training)", "",
                  "Adam moves theta's raw value by at most about its learning rate per step, "
                  "so over the cosine schedule by at most `lr_theta * max_iter / 2`. distance: "
                  "the largest raw distance from the science function's default to the "
                  "reference theta (logit units for a theta with two bounds, theta's own units "
                  "otherwise). A budget below the distance cannot get there.", "",
                  "| task | distance | budget, paper protocol | budget, cpu protocol |",
                  "|---|---|---|---|"]
        for b in budgets:
            short = " (short)" if b["cpu"] < b["distance"] else ""
            lines.append(f"| {b['task']} | {b['distance']:.3g} | {b['paper']:.3g} | "
                         f"{b['cpu']:.3g}{short} |")
    lines += ["", "## Findings", "", *findings(data, {r["name"]: r for r in runs}), "",
              "Batch-norm statistics in SAM's perturbed pass (not a probe run): the engine sets "
              "every batch-norm layer's momentum to 0 there, which keeps the running mean and "
              "variance, but the batch counter still advanced, and a layer with momentum=None "
              "(cumulative average) divides by it: over 3 SAM steps its running mean ended at "
              "0.78 instead of 1.09. Fixed (the counter is restored; "
              "`tests/test_methods.py::test_perturbed_pass_leaves_batchnorm_statistics_alone`). "
              "The package's own networks use batch norm without running statistics "
              "(track_running_stats=False) except the theta encoder's CNN, which the SAM "
              "family perturbs only with perturb='all'; the wind tunnel's network has none."]
    return "\n".join(lines)


def findings(data: dict, runs: dict) -> list[str]:
    """The conclusions, each with the numbers of the probe that shows it."""
    def r(name, key="r_end"):
        return f"{runs[name][key]:.3g}" if name in runs else "(not run)"

    out = [
        f"- **The stand-in does not contain the paper's r = 0.7.** Its science-only least "
        f"squares r is {data['all']['r']:.3f} ({data['hatch 0']['r']:.3f} with the hatch "
        f"closed, {data['hatch 45']['r']:.3f} open); it is generated with r = 0.75 closed and "
        "0.9 open, and its fan dynamics (model A2) give a steady pressure in L^3 where the "
        "science model has L^2. table1 now scores the stand-in against 0.75 (the value that "
        "generates it); a perfect r would still be 0.05 from the paper's 0.7.",
        "- **Reach: with lr_theta = lr the schedule cannot take r there.** Adam moves raw = "
        "logit(r) by at most about lr per step, i.e. by lr * max_iter / 2 = 0.75 over 1,500 "
        "cosine-annealed steps at lr 1e-3, so r <= sigmoid(0.75) = 0.68 from 0.5. The "
        "science-only fit through the training loop ends at "
        f"{r('science-only, lr_theta=lr')} (adam use {r('science-only, lr_theta=lr', 'adam_use')}: "
        "pushed the whole way, still moving: drift (lr) "
        f"{r('science-only, lr_theta=lr', 'drift_lr')}); with lr_theta = 4 lr at "
        f"{r('science-only, lr_theta=4 lr')}, with 10 lr at {r('science-only, lr_theta=10 lr')} "
        f"= the closed form, settled (drift (lr) {r('science-only, lr_theta=10 lr', 'drift_lr')}). "
        "Fix: the rule in `lr_theta`'s docstring (budget lr_theta * max_iter / 2 above the raw "
        "distance); the cpu protocol of table1 keeps the paper's budget for the wind tunnel "
        "(lr_theta 3e-3 x 2,000 = 3e-4 x 20,000). The budget table below shows the pendulum-"
        "images and light-tunnel cpu protocols short as well (not yet run).",
        "- **erm has no pull on r.** With the network reading z = f(x) next to x (compose), it "
        "absorbs any factor (1 - r): the erm gradient on r changes sign, Adam uses "
        f"{r('erm, lr_theta=lr', 'adam_use')} of its budget at lr_theta = lr and "
        f"{r('erm, lr_theta=4 lr', 'adam_use')} at 4 lr, and r ends at "
        f"{r('erm, lr_theta=lr')} / {r('erm, lr_theta=4 lr')}. A small drift here means "
        "'not pushed', not 'identified'.",
        "- **fsam pushes r up, slowly, and r does not settle within these budgets.** Adam "
        "uses about 5-6 % of theta's budget in every fsam run (a weak pull that keeps its "
        f"sign): r ends at {r('fsam rho=0.05, lr_theta=lr')} (budget 0.75, adam use "
        f"{r('fsam rho=0.05, lr_theta=lr', 'adam_use')}), {r('fsam rho=0.05, lr_theta=4 lr')} "
        f"(budget 3, {r('fsam rho=0.05, lr_theta=4 lr', 'adam_use')}) and "
        f"{r('fsam rho=0.05, lr_theta=4 lr, 3000 it')} with twice the iterations (budget 6, "
        f"{r('fsam rho=0.05, lr_theta=4 lr, 3000 it', 'adam_use')}); drift (lr) grows from "
        f"{r('fsam rho=0.05, lr_theta=4 lr', 'drift_lr')} to "
        f"{r('fsam rho=0.05, lr_theta=4 lr, 3000 it', 'drift_lr')}, where a settled r would "
        "end at the same value with twice the budget. The issue's runs (lr_theta 0.01 / 0.05, "
        "budgets 7.5 / 37.5) ended at 0.612 / 0.801. So fsam's end value on the stand-in is "
        "set by theta's budget, not by an optimum, at least up to r = 0.8; whether its pull "
        "vanishes somewhere below 1 these runs do not show. erm, by contrast, has no pull at "
        "all (above): fsam does separate from erm, but a user cannot read r off its end value "
        "without the drift.",
        "- **The drift table1 reported cannot tell.** Over the last 10 % of iterations the "
        "cosine schedule spends 0.2 % of the summed learning rate, so every run looks settled "
        "there (drift (iter) column, e.g. "
        f"{r('science-only, lr_theta=lr', 'drift_iter')} for the science-only fit stopped on "
        "its way). `theta_drift_` (new) measures over the last 10 % of the summed rate "
        "instead: a theta still pushed one way moves about a tenth of its travel there.",
    ]
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--render", action="store_true")
    parser.add_argument("--probes", nargs="+", default=list(PROBES), choices=list(PROBES))
    args = parser.parse_args()
    data = data_probe()
    runs = []
    for name in args.probes:
        path = CACHE / f"{_slug(name)}.json"
        if args.render and not path.exists():
            continue
        runs.append(run_probe(name))
        print(name, {k: runs[-1][k] for k in ("r_end", "adam_use", "drift_lr", "seconds")},
              flush=True)
    budgets = budget_probe()
    text = render(data, runs, budgets)
    print(text)
    print("written", write_results("theta_convergence",
                                   {"data": data, "budgets": budgets, "runs": runs}, text))


if __name__ == "__main__":
    main()
