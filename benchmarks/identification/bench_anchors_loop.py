"""Anchors beside the closed loop: the universal-differential-equation recipe with pysindy, and pysindy alone.

Item 5 of issue "Closed loop, part 3".  On cases of the identification benchmark (``bench_identification.py``;
same systems, data, seeds and function-space scores), the same data through:

(a) **the closed loop**: its stored record (``results/runs/identification/<case>.json``);
(b) **UDE + SINDy** (SciML's "missing physics" recipe): the case's first hybrid fit (the loop's own, stored by
    ``bench_identification.py`` in ``runs/identification/fits/`` and made again the same way where absent), the
    network's output over the states it visited (``residual_trace``), then ``pysindy.STLSQ`` on pysindy's cubic
    ``PolynomialLibrary`` of the states (and the input of a forced system), per equation the network acts on,
    threshold by 5-fold CV with the one-standard-error rule on unit-RMS columns (``bench_sparse_regression``'s
    choice); the terms are added to the science and theta with their coefficients refitted without the network
    on the training trajectories (RK4, 4 substeps, L-BFGS);
(c) **SINDy on the data alone**: derivatives of the noisy training trajectories by pysindy's
    ``SmoothedFiniteDifference``, a library of the science's known terms (the derivative of each equation by each
    parameter at the guesses, as a custom library) beside the cubic polynomials, STLSQ with the same threshold rule.

SBR (pysindy's sparse Bayesian regression) needs jax and numpyro: it is run in place of STLSQ in (b) where it can be
imported, and the page says where it could not.  Systems with declared sensor offsets (batch 8) are left out: the
anchors have no offsets.  Each case is cached in ``results/runs/anchors/<case>.json``.

    python benchmarks/identification/bench_anchors_loop.py --cases van_der_pol_like --noise 0.01
    python benchmarks/identification/bench_anchors_loop.py --batches 15  # every case of batch 15 with a loop record
    python benchmarks/identification/bench_anchors_loop.py --render
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
from helpers import PACKAGE_COMMIT, runs_folder, write_results  # noqa: E402
from identification.protocol import (PROTOCOL, cache_dir, case_name, first_hybrid_fit,  # noqa: E402
                                     make_data, score)
from identification.anchors import (combined_science, polynomial_powers, pysindy_module, refit, sbr,  # noqa: E402
                                    sindy_on_data, sparse_fit, term_labels, theta_error)
from identification.systems import SYSTEMS, simulate  # noqa: E402


RUNS = runs_folder("anchors")


def first_fit(system, noise, seed, data):
    return first_hybrid_fit(system, data, seed, cache_dir(False) / "fits" / f"{case_name(system.name, noise, seed)}.pkl")


def run_case(name, noise, seed=0):
    torch.set_num_threads(1)
    system = SYSTEMS[name]
    data = make_data(system, noise, seed)
    d = len(system.state_names)
    u_train = simulate(system, PROTOCOL["n_train"], seed, stream=0)[1]
    powers = polynomial_powers(d + int(system.forced))
    loop = json.loads((cache_dir(False) / f"{case_name(name, noise, seed)}.json").read_text())
    out = {"system": name, "noise": noise, "seed": seed, "package_commit": PACKAGE_COMMIT,
           "loop": loop_scores(system, loop)}
    start = time.perf_counter()
    hybrid, reused = first_fit(system, noise, seed, data)
    out["first_fit_s"], out["first_fit_reused"] = time.perf_counter() - start, reused
    trace = hybrid.residual_trace(data["X"])
    ps = pysindy_module()
    Z = trace["points"] if trace["inputs"] is None else np.hstack([trace["points"], trace["inputs"]])
    Theta = np.asarray(ps.PolynomialLibrary(degree=3).fit(Z).transform(Z))
    g = trace["residual"].reshape(len(Z), -1)
    theta0 = {k: float(v) for k, v in hybrid.theta_.items()}
    for label in ("stlsq", "sbr"):
        if label == "sbr" and sbr() is None:
            out["ude_sbr"] = {"skipped": "pysindy's SBR needs jax and numpyro, not installed"}
            continue
        start = time.perf_counter()
        xi = np.stack([sparse_fit(Theta, g[:, j], label) for j in range(d)], axis=1)  # features x states
        support = xi != 0
        f = combined_science(system, powers)
        theta, xi_fit, how = refit(system, f, theta0, xi, support, data, u_train)
        scores = score(system, f, {**theta, "_xi": xi_fit}, theta0, data["x_test"], data["u_test"])
        out[f"ude_{label}"] = {**scores, "n_terms": int(support.sum()), "refit": how,
                               "theta_error": theta_error(system, theta), "seconds": time.perf_counter() - start,
                               "terms": term_labels(support, xi_fit, d + int(system.forced), system)}
    start = time.perf_counter()
    out["sindy_data"] = sindy_on_data(system, data, u_train, powers)
    out["sindy_data"]["seconds"] = time.perf_counter() - start
    return out


def cases(names, noises, batches):
    out = []
    for path in sorted(cache_dir(False).glob("*.json")):
        r = json.loads(path.read_text())
        s = SYSTEMS.get(r["system"])
        if r.get("fast") or s is None or s.declared_offsets or s.sensor_offset or "error" in r:
            continue
        if (names and r["system"] not in names) or (noises and r["noise"] not in noises) or \
                (batches and s.batch not in batches):
            continue
        out.append((r["system"], r["noise"], r["seed"]))
    return out


def loop_scores(system, loop: dict) -> dict:
    """The closed loop's scores in its identification record."""
    return {"rel_err": loop.get("rel_err"), "control_err": loop.get("control_err"), "n_added": loop.get("n_added"),
            "theta_error": theta_error(system, loop["science_theta"]), "seconds": loop.get("wall_seconds"),
            "package_commit": loop.get("package_commit")}


ARMS = [("loop", "closed loop"), ("ude_stlsq", "UDE + SINDy (STLSQ)"), ("ude_sbr", "UDE + SINDy (SBR)"),
        ("sindy_data", "SINDy on the data")]


def _summary(effects: list[dict], controls: list[dict]) -> list[str]:
    """One row per recipe: effects within 10 %, median errors, clean controls, median seconds."""
    lines = ["| recipe | effects within 10 % | median rel_err | median theta error | controls with nothing added "
             "| median seconds |", "|---|---|---|---|---|---|"]
    for key, label in ARMS:
        got = [r[key] for r in effects if key in r and "skipped" not in r[key]]
        ctl = [r[key] for r in controls if key in r and "skipped" not in r[key]]
        if not got and not ctl:
            lines.append(f"| {label} | not run | | | | |")
            continue
        hit = sum(g["rel_err"] is not None and g["rel_err"] <= 0.10 for g in got)
        theta = [g["theta_error"] for g in got if g.get("theta_error") is not None]
        secs = [g["seconds"] for g in got + ctl if g.get("seconds") is not None]
        clean = sum((c.get("n_added") if key == "loop" else c.get("n_terms")) == 0 for c in ctl)
        lines.append(f"| {label} | {hit} of {len(got)} | "
                     f"{np.median([g['rel_err'] for g in got]):.3f} | " if got else f"| {label} | | | ")
        lines[-1] += (f"{np.median(theta):.3f} | " if theta else "| ") + f"{clean} of {len(ctl)} | " + \
            (f"{np.median(secs):.1f} |" if secs else "|")
    return lines


def render():
    recs = [json.loads(p.read_text()) for p in sorted(RUNS.glob("*.json"))]
    for r in recs:  # the loop as its record stands now (it may have run again since the anchors did)
        loop = cache_dir(False) / f"{case_name(r['system'], r['noise'], r['seed'])}.json"
        if loop.exists():
            r["loop"] = loop_scores(SYSTEMS[r["system"]], json.loads(loop.read_text()))
    effects = [r for r in recs if not SYSTEMS[r["system"]].is_control]
    controls = [r for r in recs if SYSTEMS[r["system"]].is_control]
    lines = ["# The closed loop beside the UDE recipe with pysindy and pysindy alone", "",
             "`benchmarks/identification/bench_anchors_loop.py` (its docstring gives the recipes). Scores as the "
             "identification "
             "benchmark's: `rel_err = |F - T| / |m|` on noise-free test states, identified when <= 0.10; controls: "
             "terms added and `|F - T| / |T|`. Theta error: mean relative error of the science's parameters (SINDy "
             "on the data has no theta). Seconds: the loop's whole run (its first hybrid fit included); for the "
             "UDE recipes the sparse fit and the refit after that same first fit; SINDy on the data alone. The "
             "loop's columns are its identification records as they stand when this page is made (a case the loop "
             "ran again after its anchors shows the loop's new result beside them; the UDE recipes used the first "
             "hybrid fit stored when they ran).", ""]
    # which of the identification benchmark's cases ran: each needs the loop's first hybrid fit, stored only for
    # the cases run since the fits were kept (batch 15, the controls), made again (minutes each) for the others
    eligible = cases([], [], [])
    by_batch = {}
    for name, noise, _ in eligible:
        by_batch.setdefault(SYSTEMS[name].batch, [0, 0])[0] += 1
    for r in recs:
        by_batch.setdefault(SYSTEMS[r["system"]].batch, [0, 0])[1] += 1
    lines += [f"Cases run: {len(recs)} of the identification benchmark's {len(eligible)} (without declared "
              "offsets): " + ", ".join(f"batch {b} {done} of {n}" for b, (n, done) in sorted(by_batch.items())
                                       if done) + ". Every control ran; of the effects, all of batch 15 (the "
              "several-term and sharp effects) and the few others the time allowed: each needs the loop's first "
              "hybrid fit, made again (minutes) where it was not kept.", ""]
    lines += _summary(effects, controls)
    newest = max(SYSTEMS[r["system"]].batch for r in recs)
    fresh = [r for r in recs if SYSTEMS[r["system"]].batch == newest]
    lines += ["", f"Batch {newest} alone, the freshest (committed before it first ran):", ""]
    lines += _summary([r for r in fresh if not SYSTEMS[r["system"]].is_control],
                      [r for r in fresh if SYSTEMS[r["system"]].is_control])
    lines += ["", "| system | noise | loop | UDE + STLSQ | UDE + SBR | SINDy on data | UDE terms |",
              "|---|---|---|---|---|---|---|"]
    for r in recs:
        key = "control_err" if SYSTEMS[r["system"]].is_control else "rel_err"
        cell = {k: (f"{r[k][key]:.3f}" if k in r and r[k].get(key) is not None else "") for k, _ in ARMS}
        lines.append(f"| {r['system']} | {r['noise']:g} | {cell['loop']} | {cell['ude_stlsq']} | {cell['ude_sbr']} | "
                     f"{cell['sindy_data']} | {'; '.join(r['ude_stlsq'].get('terms', []))[:120]} |")
    return "\n".join(lines) + "\n", {"records": recs}


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--cases", nargs="*", default=[])
    parser.add_argument("--noise", type=float, nargs="*", default=[])
    parser.add_argument("--batches", type=int, nargs="*", default=[])
    parser.add_argument("--render", action="store_true")
    args = parser.parse_args(argv)
    if not args.render:
        for name, noise, seed in cases(args.cases, args.noise, args.batches):
            path = RUNS / f"{case_name(name, noise, seed)}.json"
            if path.exists():
                continue
            out = run_case(name, noise, seed)
            RUNS.mkdir(parents=True, exist_ok=True)
            path.write_text(json.dumps(out, indent=1, default=float) + "\n")
            print(f"{name} {noise}: loop {out['loop']}, ude {out['ude_stlsq'].get('rel_err')}, "
                  f"data {out['sindy_data'].get('rel_err')}", flush=True)
    text, data = render()
    write_results("anchors_loop", data, text)
    print(text)


if __name__ == "__main__":
    main()
