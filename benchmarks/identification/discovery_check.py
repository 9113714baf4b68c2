"""The identification benchmark's cases with the closed loop's discovery on: the page of ``--with-discovery``.

The benchmark runs ``close_the_loop`` as a new user does, discovery off (its default). Discovery (symbolic
regression on what the network learned, and with it the science's terms slowed down, limited or scaled by a
variable, and the harmonic and the plain difference of two angles) joins the default only with a rerun that shows
it does no harm on these cases, and a whole rerun takes hours. ``bench_identification.py --with-discovery --sample K
SEED`` runs a sample of the cases, drawn as ``--sample`` draws them, as the benchmark runs them but with
``candidates=Candidates(discovery=True)``, each cached in ``runs/identification/with_discovery/``; this module
compares each with its stored record (discovery off) and writes ``results/identification_discovery.md``.

Samples declared before they ran: ``--sample 18 7`` (9ab6893); then ``--sample 18 8`` and ``--sample 18 9``, in
that order (17 and 18 cases the first sample does not hold). After the plain difference of two angles joined
discovery beside its harmonic (coupled_pendula's spring had been named ``sin(a2 - a1)``), the cases it can change,
the two with two angle states, at both noise levels: ``--cases coupled_pendula control_coupled_pendula --rerun``.
"""

from __future__ import annotations

import json

import numpy as np

from helpers import RESULTS
from identification.protocol import PROTOCOL, cache_dir, case_name
from identification.systems import SYSTEMS

RUNS = cache_dir(False) / "with_discovery"


def _missed(record: dict) -> list[str]:
    """The science's parameters called identified whose interval misses the truth."""
    out = []
    for k, v in record.get("intervals", {}).items():
        true = record["theta_true"][k]
        low, high = v["interval"]
        if v["verdict"] == "identified" and np.ndim(true) == 0 and not low <= true <= high:
            out.append(f"{k} {record['science_theta'][k]:.4g} for {true:g}")
    return out


def _called(record: dict) -> int:
    return sum(v["verdict"] == "identified" for v in record.get("intervals", {}).values())


def _terms(record: dict) -> str:
    return "; ".join(f"{t['term']} [{t['component']}]" for t in record.get("added", [])) or "nothing"


def _score(record: dict) -> str:
    if "error" in record:
        return "failed: " + record["error"].strip().splitlines()[-1][:80]
    key = "rel_err" if "rel_err" in record else "control_err"
    return f"{key} {record[key]:.3f}"


def render(command: str = "") -> str:
    """Write ``results/identification_discovery.md`` from the runs beside their stored records; return it."""
    runs = [json.loads(p.read_text()) for p in sorted(RUNS.glob("*.json"))]
    pairs = [(r, json.loads((cache_dir(False) / f"{case_name(r['system'], r['noise'], r['seed'])}.json")
                            .read_text())) for r in runs]
    effects = [(r, s) for r, s in pairs if not SYSTEMS[r["system"]].is_control]
    controls = [(r, s) for r, s in pairs if SYSTEMS[r["system"]].is_control]
    within = sum(bool(r.get("identified")) for r, _ in effects)
    within_before = sum(bool(s.get("identified")) for _, s in effects)
    clean = sum(r.get("n_added") == 0 for r, _ in controls)
    clean_before = sum(s.get("n_added") == 0 for _, s in controls)
    missed = [(r["system"], r["noise"], m) for r, _ in pairs for m in _missed(r)]
    missed_before = [(s["system"], s["noise"], m) for _, s in pairs for m in _missed(s)]
    threshold = PROTOCOL["threshold"]
    lines = ["# The identification benchmark with discovery on (a sample)", "", __doc__.split("\n\n")[1]
             .replace("\n", " "), "",
             f"Cases run: {len(pairs)} ({len(effects)} effects, {len(controls)} controls). Effects within "
             f"{threshold:.0%} in function space: {within} of {len(effects)} with discovery, {within_before} in their "
             f"records. Controls with nothing added: {clean} of {len(controls)} with discovery, {clean_before} in "
             f"their records. Parameters called identified whose interval misses the truth: {len(missed)} of "
             f"{sum(_called(r) for r, _ in pairs)} with discovery"
             + (f" ({'; '.join(f'{n} {lv:g}: {m}' for n, lv, m in missed)})" if missed else "")
             + f", {len(missed_before)} of {sum(_called(s) for _, s in pairs)} in their records"
             + (f" ({'; '.join(f'{n} {lv:g}: {m}' for n, lv, m in missed_before)})" if missed_before else "") + ".",
             "", "| system | noise | in the record | with discovery | added in the record | with discovery | "
             "CPU s of the loop (record, with discovery) |", "|---|---|---|---|---|---|---|"]
    for r, s in pairs:
        cpu = f"{s.get('cpu_seconds', float('nan')):.0f}, {r.get('cpu_seconds', float('nan')):.0f}"
        lines.append(f"| {r['system']} | {r['noise']:g} | {_score(s)} | {_score(r)} | {_terms(s)} | {_terms(r)} | "
                     f"{cpu} |")
    machines = sorted({r.get("machine", {}).get("cpu", "?") for r in runs})
    commits = sorted({r.get("package_commit", "?") for r in runs})
    lines += ["", f"Machine: {', '.join(machines)}; package commit {', '.join(commits)}. The first hybrid fit is "
              "the stored one where it is kept (outside git), else made again at this commit, so a difference from "
              "the record can come from the fit as well as from discovery. The CPU seconds are the whole case's "
              "(the first hybrid fit included where the run made it, `first_fit_reused` in each record).",
              "", f"Command: `{command or (runs[0]['command'] if runs else '')}`; then "
              "`python benchmarks/identification/bench_identification.py --with-discovery --render`."]
    text = "\n".join(lines) + "\n"
    (RESULTS / "identification_discovery.md").write_text(text)
    return text
