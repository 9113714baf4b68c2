"""Training speed: a plain PyTorch reference loop vs HybridRegressor, batched sweeps, peak use.

Measured in one run (issue 4), on the pendulum configuration (25 samples, MLP
2-128-128-2, 10 outputs at dt 0.2, RK4 at step 0.05 = 4 sub-steps per output
interval, for every contender):

1. ms per iteration of the reference loop (``torchdiffeq.odeint`` rk4 with the
   same step, Adam, Fisher SAM written out by hand) and of ``HybridRegressor``
   for erm and fsam, and their ratios;
2. a 25-configuration fsam sweep (5 rho x 5 seeds): 25 reference fits, 25
   ``HybridRegressor`` fits, ``GridSearchCV(n_jobs=2)`` and the batched
   ``HybridRegressorCV`` (1 and 2 threads), per iteration of all 25;
3. reaction-diffusion at the paper's size (32 x 32, 100 samples, CNN 16 x 2,
   5 outputs at dt 0.1, one RK4 step per output), per iteration;
4. achieved GFLOP/s (network FLOPs: forward plus twice that for the backward
   pass) beside the measured matrix-multiply peak;
5. the projected wall time of the paper's protocol (20,000 iterations, 25
   members) for the pendulum, Duffing and reaction-diffusion tasks.

Timing: one-thread contenders are timed in process CPU time (on a shared
machine this ignores time spent waiting for a core), multi-process and
multi-threaded ones (``n_jobs=2``, 2 threads) in wall time; every contender
runs in interleaved rounds.  The tables quote the best and the median round;
ratios are the median over rounds of the two contenders' times *in the same
round* (with their range), which holds when the machine's speed drifts.
A fit's per-iteration time is the difference between fits of two lengths,
so set-up cost cancels.

Usage: python benchmarks/speed/bench_speed.py [--rounds 5]  (about 8 minutes)
Writes results/speed.md and results/speed.json.
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

import numpy as np
import torch
import torchdiffeq
from sklearn.model_selection import GridSearchCV
from torch import nn

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # benchmarks/: the helpers, the studies' modules
from helpers import write_results  # noqa: E402
from sklearn_hybrid import HybridRegressor, HybridRegressorCV, OdeStructure, make_theta_scorer  # noqa: E402
from sklearn_hybrid import datasets as ds  # noqa: E402
from sklearn_hybrid import models  # noqa: E402

RHOS, SEEDS = [0.01, 0.02, 0.05, 0.1, 0.2], [0, 1, 2, 3, 4]
PROTOCOL_ITERS, MEMBERS = 20_000, 25


def rounds(contenders: dict, n_rounds: int) -> dict:
    """Interleaved rounds; each contender returns seconds per iteration; best, median, all."""
    times = {k: [] for k in contenders}
    for _ in range(n_rounds):
        for name, fn in contenders.items():
            times[name].append(fn())
    return {k: {"best_ms": 1e3 * min(v), "median_ms": 1e3 * float(np.median(v)),
                "rounds_ms": [1e3 * t for t in v]} for k, v in times.items()}


def paired_ratio(res: dict, a: str, b: str) -> dict:
    """``time(a) / time(b)`` round by round: median, min and max."""
    r = np.array(res[a]["rounds_ms"]) / np.array(res[b]["rounds_ms"])
    return {"median": float(np.median(r)), "min": float(r.min()), "max": float(r.max())}


def _ratio_text(r: dict, digits: int = 2) -> str:
    return f"{r['median']:.{digits}f}x (rounds {r['min']:.{digits}f}-{r['max']:.{digits}f})"


def per_iteration(make_fit, lo: int, hi: int, wall: bool = False):
    """Seconds per iteration of ``make_fit(max_iter)()``, set-up cancelled.

    Wall-clock contenders (worker processes, threads) warm up before every
    round: another contender may have replaced the worker pool in between,
    and a restart paid by the short fit alone would flatter the difference.
    """
    clock = time.perf_counter if wall else time.process_time
    warm = []

    def run():
        if wall or not warm:  # first calls pay for lazy imports, caches, buffers, workers
            make_fit(lo)()
            warm.append(True)
        spent = []
        for n in (lo, hi):
            t = clock()
            make_fit(n)()
            spent.append(clock() - t)
        return (spent[1] - spent[0]) / (hi - lo)

    return run


# ----------------------------------------------------------------- reference loop
class _RefODE(nn.Module):
    """``dv/dt = f_theta(v) + g_phi(v)`` as a user writes it for torchdiffeq."""

    def __init__(self, science, net):
        super().__init__()
        self.science, self.net = science, net
        self.omega = nn.Parameter(torch.tensor(0.5))

    def forward(self, t, v):
        return self.science(v, self.omega) + self.net(v)


def reference_loop(X, y, dt, step, method, n_iter, eta=1.0, rho=0.05):
    """Seconds per iteration of the plain loop (erm, or Fisher SAM perturbing the net)."""
    torch.manual_seed(0)
    net = nn.Sequential(nn.Linear(2, 128), nn.ReLU(), nn.Linear(128, 128), nn.ReLU(),
                        nn.Linear(128, 2))
    func = _RefODE(models.pendulum_f, net)
    opt = torch.optim.Adam(func.parameters(), lr=1e-3)
    x0, yt = torch.as_tensor(X, dtype=torch.float32), torch.as_tensor(y, dtype=torch.float32)
    t = torch.arange(y.shape[1] + 1, dtype=torch.float32) * dt

    def loss_fn():
        pred = torchdiffeq.odeint(func, x0, t, method="rk4", options={"step_size": step})
        return (pred[1:].transpose(0, 1) - yt).pow(2).mean()

    def iteration():
        opt.zero_grad()
        loss_fn().backward()
        if method == "fsam":
            with torch.no_grad():
                grads = [p.grad for p in net.parameters()]
                scaled = [g / (1 + eta * g * g) for g in grads]
                norm = torch.sqrt(sum((g * s).sum() for g, s in zip(grads, scaled)))
                eps = [rho * s / (norm + 1e-12) for s in scaled]
                for p, e in zip(net.parameters(), eps):
                    p.add_(e)
            opt.zero_grad()
            loss_fn().backward()
            with torch.no_grad():
                for p, e in zip(net.parameters(), eps):
                    p.sub_(e)
        opt.step()

    def run():
        iteration()
        t0 = time.process_time()
        for _ in range(n_iter):
            iteration()
        return (time.process_time() - t0) / n_iter

    return run


# --------------------------------------------------------------------- FLOP counts
def mlp_flops(widths, n_stages, batch):
    """Network FLOPs of one gradient evaluation: forward plus a backward of twice that."""
    return 3 * 2 * batch * n_stages * sum(a * b for a, b in zip(widths[:-1], widths[1:]))


def cnn_flops(channels, grid, n_stages, batch):
    return 3 * 2 * batch * n_stages * grid * grid * 9 * sum(
        a * b for a, b in zip(channels[:-1], channels[1:]))


def matmul_peak(threads: int, n: int = 2048, reps: int = 12, dtype=torch.float32) -> float:
    """GFLOP/s of a large matrix product (best of ``reps``)."""
    previous = torch.get_num_threads()
    torch.set_num_threads(threads)
    a, b = torch.randn(n, n, dtype=dtype), torch.randn(n, n, dtype=dtype)
    a @ b
    best = min(_timed(lambda: a @ b) for _ in range(reps))
    torch.set_num_threads(previous)
    return 2 * n ** 3 / best / 1e9


def _timed(fn):
    t = time.perf_counter()
    fn()
    return time.perf_counter() - t


# ------------------------------------------------------------------------ sections
def pendulum_section(n_rounds):
    d = ds.make_pendulum(25, 1, 1, random_state=0)
    X, y = d.X_train, d.y_train
    out = {}
    for sub in (4, 10):  # the configurations: step 0.05 (main) and 0.02
        kw = dict(science=models.pendulum_f, structure=OdeStructure(dt=0.2, n_substeps=sub), random_state=0)
        # about a second per measurement, so that a burst of load on the shared machine
        # moves a round by a few per cent only
        contenders = {
            "reference erm": reference_loop(X, y, 0.2, 0.2 / sub, "erm", 40 // sub),
            "HybridRegressor erm": per_iteration(lambda n: lambda: HybridRegressor(
                method="erm", max_iter=n, **kw).fit(X, y), 4, 4 + 160 // sub)}
        if sub == 4:
            contenders["reference fsam"] = reference_loop(X, y, 0.2, 0.2 / sub, "fsam", 8)
            contenders["HybridRegressor fsam"] = per_iteration(lambda n: lambda: HybridRegressor(
                method="fsam", max_iter=n, **kw).fit(X, y), 3, 23)
        res = rounds(contenders, n_rounds)
        flops = mlp_flops([2, 128, 128, 2], 10 * sub * 4, 25)
        for name, r in res.items():
            evals = 2 if "fsam" in name else 1
            r["gflops"] = evals * flops / (r["best_ms"] / 1e3) / 1e9
        ratios = {m: paired_ratio(res, f"reference {m}", f"HybridRegressor {m}")
                  for m in ("erm", "fsam") if f"reference {m}" in res}
        if "HybridRegressor fsam" in res:
            ratios["fsam / erm"] = paired_ratio(res, "HybridRegressor fsam", "HybridRegressor erm")
        out[f"step {0.2 / sub:g}"] = {"contenders": res, "ratios": ratios}
    return out


def sweep_section(n_rounds, peak):
    d = ds.make_pendulum(25, 1, 1, random_state=0)
    X, y = d.X_train, d.y_train

    def batched(threads=1, n_jobs=None):
        def make(n):
            est = HybridRegressor(science=models.pendulum_f, method="fsam",
                                  structure=OdeStructure(dt=0.2, n_substeps=4), max_iter=n, n_threads=threads)
            return lambda: HybridRegressorCV(est, rhos=RHOS, seeds=SEEDS, validation_fraction=None,
                                             n_jobs=n_jobs).fit(X, y)
        return per_iteration(make, 2, 8, wall=threads > 1 or n_jobs is not None)

    def single(n):
        return lambda: HybridRegressor(science=models.pendulum_f, method="fsam",
                                       structure=OdeStructure(dt=0.2, n_substeps=4), max_iter=n,
                                       random_state=0).fit(X, y)

    def grid(n):
        est = HybridRegressor(science=models.pendulum_f, method="fsam", structure=OdeStructure(dt=0.2, n_substeps=4),
                              max_iter=n)
        everything = [(np.arange(len(X)), np.arange(len(X)))]
        return lambda: GridSearchCV(est, {"rho": RHOS, "random_state": SEEDS}, cv=everything,
                                    scoring=make_theta_scorer({"omega": 2 / 3}), refit=False,
                                    n_jobs=2).fit(X, y)

    grid(2)()  # start the worker processes once
    res = rounds({"HybridRegressorCV, 1 thread": batched(),
                  "HybridRegressorCV(n_jobs=2), 2 processes": batched(n_jobs=2),
                  "HybridRegressorCV, 2 intra-op threads": batched(threads=2),
                  "GridSearchCV(n_jobs=2), 2 processes": per_iteration(grid, 2, 6, wall=True),
                  "reference fsam, one fit": reference_loop(X, y, 0.2, 0.05, "fsam", 8),
                  "HybridRegressor fsam, one fit": per_iteration(single, 3, 23)}, n_rounds)
    for one in ("reference", "HybridRegressor"):  # 25 sequential fits on one core
        r = res.pop(f"{one} fsam, one fit")
        res[f"25 {one} fits, 1 core"] = {k: 25 * v if k != "rounds_ms" else [25 * t for t in v]
                                          for k, v in r.items()}
    flops = 25 * 2 * mlp_flops([2, 128, 128, 2], 160, 25)
    for name, r in res.items():
        r["cores"] = 2 if "2 " in name else 1
        r["gflops"] = flops / (r["best_ms"] / 1e3) / 1e9
        r["gflops_median"] = flops / (r["median_ms"] / 1e3) / 1e9
        r["peak_percent"] = 100 * r["gflops_median"] / peak[str(r["cores"])]
        r["vs_reference"] = paired_ratio(res, "25 reference fits, 1 core", name)
        r["vs_grid"] = paired_ratio(res, "GridSearchCV(n_jobs=2), 2 processes", name)
    return res


def duffing_section(n_rounds):
    d = ds.make_duffing(100, 1, 1, random_state=0)
    kw = dict(science=models.duffing_f, method="fsam", structure=OdeStructure(dt=d.dt, n_substeps=4))
    res = rounds({
        "HybridRegressor fsam": per_iteration(lambda n: lambda: HybridRegressor(
            max_iter=n, random_state=0, **kw).fit(d.X_train, d.y_train), 2, 6),
        "HybridRegressorCV, 1 thread": per_iteration(lambda n: lambda: HybridRegressorCV(
            HybridRegressor(max_iter=n, **kw), rhos=RHOS, seeds=SEEDS,
            validation_fraction=None).fit(d.X_train, d.y_train), 1, 3)}, max(1, n_rounds - 1))
    return res


def reaction_diffusion_section(n_rounds):
    d = ds.make_reaction_diffusion(100, 1, 1, random_state=0)
    X, y = d.X_train, d.y_train
    kw = dict(science=models.diffusion_f, residual="cnn", structure=OdeStructure(dt=d.dt, n_substeps=1))

    def reference(n_iter=2):
        torch.manual_seed(0)
        est = HybridRegressor(max_iter=1, method="erm", random_state=0, **kw).fit(X[:2], y[:2])
        cnn = est.residual_.train()
        a = nn.Parameter(torch.tensor(0.01))
        b = nn.Parameter(torch.tensor(0.01))
        opt = torch.optim.Adam([a, b, *cnn.parameters()], lr=1e-3)
        x0, yt = torch.as_tensor(X, dtype=torch.float32), torch.as_tensor(y, dtype=torch.float32)
        t = torch.arange(y.shape[1] + 1, dtype=torch.float32) * d.dt
        func = lambda _, v: models.diffusion_f(v, a, b) + cnn(v)  # noqa: E731

        def iteration():
            opt.zero_grad()
            pred = torchdiffeq.odeint(func, x0, t, method="rk4")[1:].transpose(0, 1)
            (pred - yt).pow(2).mean().backward()
            opt.step()

        def run():
            iteration()  # not counted: first calls allocate
            t0 = time.process_time()
            for _ in range(n_iter):
                iteration()
            return (time.process_time() - t0) / n_iter

        return run

    res = rounds({
        "reference erm": reference(),
        "HybridRegressor erm": per_iteration(lambda n: lambda: HybridRegressor(
            method="erm", max_iter=n, random_state=0, **kw).fit(X, y), 1, 3),
        "HybridRegressor fsam": per_iteration(lambda n: lambda: HybridRegressor(
            method="fsam", max_iter=n, random_state=0, **kw).fit(X, y), 1, 2),
        "HybridRegressorCV fsam, 2 members (per member)": per_iteration(
            lambda n: lambda: HybridRegressorCV(HybridRegressor(method="fsam", max_iter=n, **kw),
                                                seeds=[0, 1], validation_fraction=None).fit(X, y),
            1, 2)}, max(1, n_rounds - 2))
    per_member = res["HybridRegressorCV fsam, 2 members (per member)"]
    per_member.update(best_ms=per_member["best_ms"] / 2, median_ms=per_member["median_ms"] / 2,
                      rounds_ms=[t / 2 for t in per_member["rounds_ms"]])
    flops = cnn_flops([2, 16, 16, 2], 32, 4 * y.shape[1], len(X))
    for name, r in res.items():
        r["gflops"] = (2 if "fsam" in name else 1) * flops / (r["best_ms"] / 1e3) / 1e9
    return res


def bound_section(peak: dict) -> dict:
    """The most 25 stacked members can reach: their wide products alone, at the engine's shapes.

    One gradient evaluation of the 25-member pendulum sweep holds, per
    member, 160 stage products forward and 160 backward (25 x 128 by
    128 x 128) and the wide layer's weight gradient (128 x 400 by 400 x 128,
    once per output interval): 97 % of the counted FLOPs.  Timed alone, back
    to back on data in cache, they bound the engine's share of the peak;
    everything else (the thin first and last layers, activations, the
    science function, RK4 arithmetic, the stored stages) is overhead on top.
    The stored stages (two hidden layers, 25 members, 160 stages: 102 MB)
    are written once and read twice: that memory traffic is timed too.
    """
    K, B, H, S, C = 25, 25, 128, 160, 16
    a, w, bias = torch.randn(K, B, H), torch.randn(K, H, H), torch.randn(K, 1, H)
    delta, inputs, acc = torch.randn(K, C * B, H), torch.randn(K, C * B, H), torch.zeros(K, H, H)

    def products():
        for _ in range(S):
            torch.baddbmm(bias, a, w)
        for _ in range(S):
            torch.bmm(a, w)
        for _ in range(S // C):
            acc.baddbmm_(delta.transpose(1, 2), inputs)

    stages, stored = torch.randn(2 * S * K * B * H), torch.empty(2 * S * K * B * H)

    def traffic():
        stored.copy_(stages)
        stored.sum()
        stored.sum()

    products()
    t_products = min(_timed(products) for _ in range(5))
    t_traffic = min(_timed(traffic) for _ in range(5))
    flops = K * mlp_flops([2, 128, 128, 2], S, B)
    return {"gflop_per_evaluation": flops / 1e9, "products_ms": 1e3 * t_products,
            "products_percent": 100 * flops / t_products / 1e9 / peak["1"],
            "target_ms": 1e3 * flops / (0.7 * peak["1"] * 1e9), "traffic_ms": 1e3 * t_traffic}


def profile_section(top=18) -> str:
    """Where one fsam iteration spends its time: single fit and 25 stacked members."""
    from torch.profiler import profile

    d = ds.make_pendulum(25, 1, 1, random_state=0)
    kw = dict(science=models.pendulum_f, method="fsam", structure=OdeStructure(dt=0.2, n_substeps=4))
    fits = {"single fit (K = 1)": lambda n: HybridRegressor(max_iter=n, **kw).fit(d.X_train, d.y_train),
            "HybridRegressorCV, 25 members": lambda n: HybridRegressorCV(
                HybridRegressor(max_iter=n, **kw), rhos=RHOS, seeds=SEEDS,
                validation_fraction=None).fit(d.X_train, d.y_train)}
    lines = ["# Where an fsam iteration's time goes (pendulum, torch.profiler, 1 thread)", "",
             "Self CPU time per iteration (fit of 3 iterations minus fit of 1, profiler overhead "
             "included: a few microseconds per operation), top operations by input shapes.", ""]
    for name, fit in fits.items():
        fit(1)
        spent = []
        for n in (1, 3):
            with profile(record_shapes=True) as prof:
                fit(n)
            spent.append({(e.key, str(e.input_shapes)): (e.self_cpu_time_total, e.count)
                          for e in prof.key_averages(group_by_input_shape=True)})
        rows = sorted(((t - spent[0].get(k, (0, 0))[0]) / 2e3, (c - spent[0].get(k, (0, 0))[1]) // 2, k)
                      for k, (t, c) in spent[1].items())[::-1]
        rows = [r for r in rows if r[1] > 0]  # no more calls per iteration: set-up noise
        total = sum(r[0] for r in rows)
        lines += [f"## {name}: {total:.0f} ms per iteration", "",
                  "| operation | input shapes | ms | calls |", "|---|---|---|---|"]
        lines += [f"| {op} | {shapes} | {t:.1f} | {c} |" for t, c, (op, shapes) in rows[:top]] + [""]
    return "\n".join(lines)


def _hours(ms):
    return ms * PROTOCOL_ITERS / 1e3 / 3600


def targets(r) -> list:
    """(target, measured, met) rows for the issue's targets, from the measurements."""
    pend, sweep = r["pendulum"]["step 0.05"]["ratios"], r["sweep"]
    procs = sweep["HybridRegressorCV(n_jobs=2), 2 processes"]
    one = sweep["HybridRegressorCV, 1 thread"]
    best_batched = max((sweep[k] for k in sweep if k.startswith("HybridRegressorCV")),
                       key=lambda x: x["vs_reference"]["median"])
    rows = [(f"single fit >= 2.5x faster than the reference loop, {m}", _ratio_text(pend[m]),
             pend[m]["median"] >= 2.5) for m in ("erm", "fsam")]
    rows.append(("fsam per iteration <= 2.1x erm", _ratio_text(pend["fsam / erm"]),
                 pend["fsam / erm"]["median"] <= 2.1))
    rows.append(("batched engine, 25 members, >= 70 % of the measured peak on the cores it uses "
                 "(median rounds)",
                 f"1 core: {one['peak_percent']:.0f} %; 2 processes: {procs['peak_percent']:.0f} % "
                 "of the 2-thread peak", max(one["peak_percent"], procs["peak_percent"]) >= 70))
    rows.append(("25-configuration sweep >= 10x faster than 25 sequential reference fits",
                 _ratio_text(best_batched["vs_reference"], digits=1),
                 best_batched["vs_reference"]["median"] >= 10))
    rows.append(("sweep faster than GridSearchCV(n_jobs=2) over single fits",
                 f"{best_batched['vs_grid']['median']:.2f}x", best_batched["vs_grid"]["median"] > 1))
    return rows


def markdown(r) -> str:
    lines = ["# Training speed (benchmarks/speed/bench_speed.py)", "",
             f"Matrix-multiply peak (2048^2 float32): {r['peak_gflops']['1']:.0f} GFLOP/s on 1 "
             f"thread, {r['peak_gflops']['2']:.0f} on 2 (float64: {r['peak_gflops']['1 float64']:.0f} "
             f"on 1). Load average before/after: {r['load'][0]:.2f} / {r['load'][1]:.2f}. "
             "A shared machine whose speed drifts: ratios are medians of same-round ratios.", "",
             "## Targets of issue 4", "", "| target | measured | met |", "|---|---|---|"]
    lines += [f"| {t} | {m} | {'yes' if ok else 'no'} |" for t, m, ok in targets(r)]
    lines.append("")
    for step, sec in r["pendulum"].items():
        res = sec["contenders"]
        lines += [f"## Pendulum, single fit, RK4 {step} (batch 25, MLP 2-128-128-2)", "",
                  "| contender | ms/iteration (best) | median | GFLOP/s (best) | % of 1-thread peak |",
                  "|---|---|---|---|---|"]
        for name, x in res.items():
            lines.append(f"| {name} | {x['best_ms']:.1f} | {x['median_ms']:.1f} | "
                         f"{x['gflops']:.1f} | {100 * x['gflops'] / r['peak_gflops']['1']:.0f} |")
        lines.append("")
        for key, ratio in sec["ratios"].items():
            what = key if "/" in key else f"reference / HybridRegressor, {key}"
            lines.append(f"- {what}: **{_ratio_text(ratio)}**")
        lines.append("")
    lines += ["## 25-configuration fsam sweep (5 rho x 5 seeds), pendulum", "",
              "| contender | ms per iteration of all 25 (best) | median | GFLOP/s (median) | % of peak "
              "on its cores | x faster than 25 reference fits | x faster than GridSearchCV(n_jobs=2) "
              "| 20,000 iterations (h) |", "|---|---|---|---|---|---|---|---|"]
    for name, x in r["sweep"].items():
        lines.append(f"| {name} | {x['best_ms']:.0f} | {x['median_ms']:.0f} | {x['gflops_median']:.1f} | "
                     f"{x['peak_percent']:.0f} | {x['vs_reference']['median']:.1f} | "
                     f"{x['vs_grid']['median']:.2f} | {_hours(x['median_ms']):.1f} |")
    b, one = r["bound"], r["sweep"]["HybridRegressorCV, 1 thread"]
    per_eval = one["median_ms"] / 2  # fsam: two gradient evaluations per iteration
    lines += ["", "### Why the batched engine stays below 70 % of the peak (1 thread, per gradient "
              "evaluation of all 25 members)", "",
              f"- counted network FLOPs: {b['gflop_per_evaluation']:.2f} GFLOP; at 70 % of the "
              f"1-thread peak the whole evaluation would have to take {b['target_ms']:.0f} ms;",
              f"- its wide products alone (25 x 128 by 128 x 128 stage products forward and backward, "
              f"the weight gradient), timed back to back on data in cache: {b['products_ms']:.0f} ms, "
              f"{b['products_percent']:.0f} % of the peak: the bound with zero time for anything else;",
              f"- writing the stored stages once and reading them twice (102 MB): "
              f"{b['traffic_ms']:.0f} ms;",
              f"- measured: {per_eval:.0f} ms (median round), so {per_eval - b['products_ms']:.0f} ms "
              f"go to everything else, against the {b['target_ms'] - b['products_ms']:.0f} ms that 70 % "
              "would leave. Operation by operation: results/speed_profile.md."]
    rd = r["reaction_diffusion"]
    lines += ["", "## Reaction-diffusion at paper size (32 x 32, 100 samples, CNN 16 x 2, 5 outputs, "
              "RK4 step 0.1)", "", "| contender | s/iteration (best) | median | GFLOP/s (best) |",
              "|---|---|---|---|"]
    for name, x in rd.items():
        lines.append(f"| {name} | {x['best_ms'] / 1e3:.2f} | {x['median_ms'] / 1e3:.2f} | "
                     f"{x['gflops']:.1f} |")
    lines.append("- reference / HybridRegressor, erm: **"
                 + _ratio_text(paired_ratio(rd, "reference erm", "HybridRegressor erm")) + "**")
    lines += ["", "## Duffing (100 samples, MLP 2-128-128-2, 10 outputs at dt 0.1, RK4 step 0.025), fsam",
              "", "| contender | ms per iteration (best) | median |", "|---|---|---|"]
    lines += [f"| {name} | {x['best_ms']:.0f} | {x['median_ms']:.0f} |" for name, x in r["duffing"].items()]
    lines += ["", "## Projected wall time of the paper's protocol (20,000 iterations x 25 members, fsam)",
              "", "Median rounds.", "", "| task | how | hours |", "|---|---|---|"]
    for task, how, ms in r["projection"]:
        lines.append(f"| {task} | {how} | {_hours(ms):.1f} |")
    lines += ["", "Where the time goes: results/speed_profile.md."]
    return "\n".join(lines)


def projection(r) -> list:
    """(task, how, ms per iteration of all 25 members) rows of the protocol projection."""
    pend = r["pendulum"]["step 0.05"]["contenders"]
    duff, rd, sweep = r["duffing"], r["reaction_diffusion"], r["sweep"]
    return [
        ("pendulum", "25 reference fits, 1 core", 25 * pend["reference fsam"]["median_ms"]),
        ("pendulum", "25 HybridRegressor fits, 1 core", 25 * pend["HybridRegressor fsam"]["median_ms"]),
        ("pendulum", "HybridRegressorCV, 1 thread", sweep["HybridRegressorCV, 1 thread"]["median_ms"]),
        ("pendulum", "HybridRegressorCV(n_jobs=2), 2 processes",
         sweep["HybridRegressorCV(n_jobs=2), 2 processes"]["median_ms"]),
        ("duffing", "25 HybridRegressor fits, 1 core", 25 * duff["HybridRegressor fsam"]["median_ms"]),
        ("duffing", "HybridRegressorCV, 1 thread", duff["HybridRegressorCV, 1 thread"]["median_ms"]),
        ("reaction-diffusion", "25 HybridRegressor fits, 1 core",
         25 * rd["HybridRegressor fsam"]["median_ms"]),
        ("reaction-diffusion", "HybridRegressorCV (member by member), 1 core",
         25 * rd["HybridRegressorCV fsam, 2 members (per member)"]["median_ms"]),
    ]


def _rewrite_markdown():
    """Regenerate results/speed.md from results/speed.json (after editing the table layout)."""
    import json

    from helpers import RESULTS

    r = json.loads((RESULTS / "speed.json").read_text())
    r["projection"] = projection(r)
    (RESULTS / "speed.json").write_text(json.dumps(r, indent=2))
    machine = r.pop("machine")
    text = markdown(r) + "\n\nMachine: " + ", ".join(f"{k} {v}" for k, v in machine.items())
    (RESULTS / "speed.md").write_text(text + "\n")


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=int, default=5)
    parser.add_argument("--markdown-only", action="store_true",
                        help="rewrite speed.md from speed.json without measuring")
    args = parser.parse_args()
    if args.markdown_only:
        return _rewrite_markdown()
    torch.set_num_threads(1)
    load0 = os.getloadavg()[0]
    r = {"peak_gflops": {"1": matmul_peak(1), "2": matmul_peak(2),
                         "1 float64": matmul_peak(1, dtype=torch.float64)}}
    r["pendulum"] = pendulum_section(args.rounds)
    r["sweep"] = sweep_section(args.rounds, r["peak_gflops"])
    r["bound"] = bound_section(r["peak_gflops"])
    r["duffing"] = duffing_section(args.rounds)
    r["reaction_diffusion"] = reaction_diffusion_section(args.rounds)
    r["projection"] = projection(r)
    r["load"] = [load0, os.getloadavg()[0]]
    path = write_results("speed", r, markdown(r))
    print(path.read_text())
    (path.parent / "speed_profile.md").write_text(profile_section() + "\n")


if __name__ == "__main__":
    main()
