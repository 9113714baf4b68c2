"""The uncertainty benchmark's protocol, shared with the Laplace study run on its fits.

``bench_uncertainty.py`` fits every system of ``systems.py`` with :data:`SETTINGS` and keeps each repeat in
:data:`RUNS`; ``bench_laplace.py`` fits the same again and scores its intervals with the same row,
:func:`member_row`.
"""

from __future__ import annotations

import numpy as np

from helpers import runs_folder

RUNS = runs_folder("uncertainty")
SETTINGS = {"residual": {"hidden": (32, 32), "zero_init": False}, "max_iter": 300, "n_threads": 1}
#: The hybrid fits of every repeat, each profiled.
HYBRID_METHODS = ("erm", "fsam", "p-reg")


def _interval_of(record, method, label):
    if method.startswith("loop"):  # the loop and its variants; "conditional" (on a term's form) is not identified
        return record["intervals"][label], record["verdicts"][label] == "identified", record["theta"][label]
    if method == "fsam bootstrap":
        return record["bootstrap"][label]["interval"], None, record["theta"][label]
    prof = record["profile"][label]
    return prof["interval"], prof["verdict"] == "identified", record["theta"][label]


def member_row(system, method, label, true, got):
    """One method's intervals of one parameter over the repeats ``got``: coverage, verdicts, error and width.

    Parameters
    ----------
    system : systems.System
        The system the repeats were drawn from.
    method : str
        ``"erm"``, ``"fsam"``, ``"p-reg"`` (profiled), ``"fsam bootstrap"`` or ``"loop"`` and its variants
        (``"loop ..."``: the network-free model's ``science_intervals``); its records' keys are read accordingly.
    label : str
        The parameter.
    true : float
        Its true value.
    got : list of dict
        The method's record of every repeat.

    Returns
    -------
    dict
        The row of ``results/uncertainty.md``.
    """
    intervals, identified, estimates = zip(*(_interval_of(r, method, label) for r in got))
    low, high = np.array([i[0] for i in intervals]), np.array([i[1] for i in intervals])
    est = np.array(estimates)
    covered = (low <= true) & (true <= high)
    rms = float(np.sqrt(np.mean((est - true) ** 2)))
    seconds = [r.get("fit_s", 0) + r.get("profile_s", 0) + (r.get("bootstrap_s", 0) if method == "fsam bootstrap"
                                                               else 0) for r in got]
    row = {"system": system.name, "method": method, "param": label, "true": true, "n": len(got),
           "mean_rel_error": float(np.mean(np.abs(est - true)) / abs(true)), "rms_error": rms,
           "seconds": float(np.mean(seconds)), "coverage_all": float(covered.mean())}
    if identified[0] is None:  # the bootstrap gives an interval, no verdict
        finite = np.isfinite(high - low)
        row.update(verdict_identified=None, coverage_identified=None, miss_identified=None,
                   width_over_rms=float(np.mean((high - low)[finite]) / rms) if finite.any() and rms > 0 else None)
        return row
    ident = np.array(identified)
    if method.startswith("loop"):  # identified only given the form of a chosen term: its interval spans the rivals
        conditional = np.array([r["verdicts"][label] == "conditional" for r in got])
        row.update(verdict_conditional=int(conditional.sum()),
                   coverage_conditional=float(covered[conditional].mean()) if conditional.any() else None)
    row.update(verdict_identified=int(ident.sum()), verdict_not=int((~ident).sum()),
               coverage_identified=float(covered[ident].mean()) if ident.any() else None,
               miss_identified=float((ident & ~covered).mean()),
               width_over_rms=float(np.mean((high - low)[ident]) / rms) if ident.any() and rms > 0 else None,
               expected_not_identified=(label in system.not_identifiable and not method.startswith("loop"))
               or label in system.product_pair)
    return row
