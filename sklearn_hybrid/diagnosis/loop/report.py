"""What :func:`~sklearn_hybrid.diagnosis.close_the_loop` reports: metrics per stage, the selection
log, the added terms in words, and the residual nothing explained (numbers and a plot)."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
import torch
from joblib import effective_n_jobs
from joblib.externals.loky import ProcessPoolExecutor
from sklearn.utils import Bunch
from threadpoolctl import threadpool_limits

from ...metrics import network_share, rate_share
from ..evidence import critical_value
from ..sensitivity import root_mean_square, science_sensitivities

__all__ = ["prediction_metrics", "format_table", "residual_profile", "plot_unexplained", "LoopResult"]

KIND_WORDS = {"polynomial": "polynomial", "drag": "drag (v|v|, |v|)", "dry_friction": "dry friction",
              "hinge": "hinge / stop / overflow", "sqrt": "square root (Torricelli)",
              "power": "power law, fitted exponent",
              "exponential": "exponential", "saturation": "saturation (Michaelis-Menten)",
              "periodic": "periodic in an angle (a harmonic)", "norm": "norm of several states (a speed, a distance)",
              "scaled": "its equation times a state or input (a parameter that varies with it)", "user": "user term",
              "offset": "sensor offset", "joint": "terms that enter together",
              "discovered": "discovered by symbolic regression",
              "inhibited": "a science term slowed down or limited by a variable: where it adds -1 times the "
                           "bracket's term to that term's own equation, the term becomes itself over 1 + (|x|/K)^n "
                           "(a factor |x|^n/(K^n + |x|^n)), its parameter still its rate at rest, or itself times "
                           "|x|^n/(K^n + |x|^n) (a factor K^n/(K^n + |x|^n)), its parameter its rate at saturation",
              "modulated": "a science term scaled by a factor of a variable: where it adds 1 times the bracket's "
                           "term to that term's own equation, the term becomes itself times exp(k x), its parameter "
                           "still its rate at x = 0, or itself times |x|^p, its parameter its rate at |x| = 1"}


def format_gain(gain: float) -> str:
    """A relative drop of the validation error as a percentage; powers of ten once it is beyond -9,999 %.

    A candidate whose refit drives some simulations to blow up can multiply the error by 1e20, and
    ``-1823745583607992492752896.0%`` tells less than ``-1.8e+24%``.

    Parameters
    ----------
    gain : float
        Relative drop of the error (0.25 is 25 %; negative when the error grew).

    Returns
    -------
    str
    """
    return f"{gain:.1%}" if not np.isfinite(gain) or abs(gain) < 100 else f"{100 * gain:.2g}%"


def prediction_metrics(y: np.ndarray, y_hybrid: np.ndarray, y_science: np.ndarray) -> dict[str, float]:
    """Test RMSE of the hybrid and of the science part alone, and the network's share of the prediction.

    The share is ``RMS(y_hybrid - y_science) / RMS(y_hybrid)``: how much of the prediction would
    change if the network were switched off.
    """
    def rms(a):
        return float(root_mean_square(a, axis=None))

    return {"rmse": rms(y_hybrid - y), "rmse_science_only": rms(y_science - y),
            "network_share": network_share(y_hybrid, y_science)}


def rate_shares(estimator: Any, X: Any) -> np.ndarray | None:
    """A fitted hybrid ODE's network share of each component of the learned right-hand side along the visited
    points (:func:`~sklearn_hybrid.metrics.rate_share`); None where the shapes do not match."""
    trace = estimator.residual_trace(X)
    args = [trace["points"]] + ([] if trace["inputs"] is None else [trace["inputs"]])
    g = trace["residual"].reshape(len(args[0]), -1)
    f = science_sensitivities(estimator, args, jacobian=False)[0]
    return rate_share(g, f) if f.shape == g.shape else None


def _rhs_share(estimator: Any, X: Any) -> float:
    """The network's largest share of a component of the learned right-hand side (NaN if not defined)."""
    shares = rate_shares(estimator, X)
    return float("nan") if shares is None else float(np.nanmax(shares))


def evaluate(est, X, X_test, y_test, test_scorer, theta_true) -> dict:
    """One table row: test metrics, the network's share, theta (and its error when known)."""
    row: dict[str, Any] = {}
    if test_scorer is not None:
        row.update(test_scorer(est))
    elif X_test is not None:
        y_test = np.asarray(y_test, float).reshape(len(X_test), -1)
        row.update(prediction_metrics(y_test, est.predict(X_test).reshape(len(y_test), -1),
                                      est.predict_science(X_test).reshape(len(y_test), -1)))
    row["network_share_rhs"] = _rhs_share(est, X)
    row["theta"] = {k: (float(v) if np.ndim(v) == 0 else np.asarray(v).tolist()) for k, v in est.theta_.items()}
    if theta_true:
        row["theta_error"] = {k: float(np.max(np.abs(np.asarray(est.theta_[k]) - np.asarray(v))
                                              / np.maximum(np.abs(v), 1e-12)))
                              for k, v in theta_true.items() if k in est.theta_}
    return row


def _one_thread() -> None:
    """Worker set-up: one torch and one BLAS thread, so that idle threads spinning in a worker
    do not take the core the caller's process works on (tiny models gain nothing from more)."""
    torch.set_num_threads(1)
    threadpool_limits(1)


class Scoring:
    """Score models with :func:`evaluate`, here or, with ``n_jobs`` > 1, in worker processes.

    Free runs of long test records are sequential in time and cost per-operation overhead on
    one core; in a worker they overlap with the selection and the refit that go on here.
    ``submit(est)`` returns a function that gives the row when it is needed. Use it as a context
    manager: with workers, this process keeps to one BLAS thread inside it.
    """

    def __init__(self, n_jobs: int | None, *args: Any):
        self.args = args
        n_workers = effective_n_jobs(n_jobs) - 1
        # loky's pool (joblib's) pickles closures such as a recipe's scorer or an augmented science; a
        # pool of its own, not joblib's shared one, which a later joblib.Parallel would find changed
        self.executor = (ProcessPoolExecutor(max_workers=n_workers, initializer=_one_thread)
                         if n_workers > 0 else None)

    def __enter__(self):
        # with workers, the caller too keeps to one BLAS thread: a second one would spin on a worker's core
        self._limits = threadpool_limits(1) if self.executor is not None else None
        return self

    def __exit__(self, *exc):
        if self._limits is not None:
            self._limits.restore_original_limits()
        if self.executor is not None:
            # after an error nobody reads the pending scores: stop the workers instead of waiting
            self.executor.shutdown(wait=True, kill_workers=exc[0] is not None)

    def submit(self, est: Any):
        if self.executor is None:
            row = evaluate(est, *self.args)
            return lambda: row
        return self.executor.submit(evaluate, est, *self.args).result


def residual_profile(remaining: np.ndarray, learned: np.ndarray, values: np.ndarray, variables: Sequence[str],
                     output_names: Sequence[str], components: Sequence[int], n_bins: int = 8) -> dict:
    """How much of what the hybrid learned the final science model still misses, and where.

    Returns ``share`` (per output: RMS of the remainder over RMS of the learned right-hand side)
    and ``profiles`` (per explained output and variable: bin centres and the mean remainder in
    each quantile bin of that variable), which show the shape of a missing effect.
    """
    total = root_mean_square(learned)
    share = root_mean_square(remaining) / np.where(total > 0, total, np.nan)
    profiles = {}
    for j in components:
        for i, name in enumerate(variables):
            x = values[:, i]
            edges = np.unique(np.quantile(x, np.linspace(0, 1, n_bins + 1)))
            if len(edges) < 3:
                continue
            which = np.clip(np.searchsorted(edges, x, side="right") - 1, 0, len(edges) - 2)
            centre = np.array([x[which == b].mean() for b in range(len(edges) - 1)])
            mean = np.array([remaining[which == b, j].mean() for b in range(len(edges) - 1)])
            profiles[(output_names[j], name)] = (centre, mean)
    return {"share": dict(zip(output_names, share.tolist())), "profiles": profiles,
            "components": [output_names[j] for j in components], "_data": (values, remaining, list(variables))}


def plot_unexplained(result: Any, axes: Any = None) -> np.ndarray:
    """Scatter the remaining residual of each explained output against each variable.

    Parameters
    ----------
    result : Bunch
        What :func:`~sklearn_hybrid.diagnosis.close_the_loop` returned.
    axes : array of matplotlib Axes, optional
        ``(n_outputs, n_variables)``; a new figure when None.

    Returns
    -------
    ndarray of matplotlib Axes
    """
    import matplotlib.pyplot as plt  # optional dependency

    info = result.unexplained
    values, remaining, variables = info["_data"]
    outputs = info["components"]
    names = list(info["share"])
    units = result.get("units") or {}
    new_figure = axes is None
    if new_figure:
        _, axes = plt.subplots(len(outputs), len(variables), figsize=(3.5 * len(variables), 3 * len(outputs)),
                               squeeze=False)
    axes = np.asarray(axes, dtype=object).reshape(len(outputs), len(variables))
    for r, out in enumerate(outputs):
        j = names.index(out)
        for c, var in enumerate(variables):
            ax = axes[r, c]
            ax.scatter(values[:, c], remaining[:, j], s=3, alpha=0.3)
            centre, mean = info["profiles"].get((out, var), ([], []))
            ax.plot(centre, mean, "r.-", lw=1.5)
            ax.axhline(0, color="k", lw=0.5)
            ax.set_xlabel(f"{var} [{units[var]}]" if units.get(var) else var)
            if c == 0:
                ax.set_ylabel(f"{out} not explained")
            if c == 0:
                ax.set_title(f"{info['share'][out]:.1%} of what the network learned for {out}", fontsize=9)
    if new_figure:
        fig = axes[0, 0].figure
        fig.suptitle("What the final science model still misses (dots: visited states; red: binned mean)",
                     fontsize=10)
        fig.tight_layout()
    return axes


def _second_look_words(steps: Sequence[dict], min_gain: float) -> str:
    """The report's account of second looks (see ``close_the_loop``'s ``second_look``), if any."""
    looked = [s for s in steps if str(s["step"]).endswith("second look")]
    if not looked:
        return ""
    return (f". Candidates that lowered it by {min_gain * 100:g} % with z above 2 but not past the threshold had a "
            f"second look (rows 'second look'): the same test on folds of the training samples, each predicted by "
            f"a refit on the others, with a threshold of {looked[0]['threshold']:.2f} for their number")


def _joint_words(steps: Sequence[dict]) -> str:
    """The report's account of joint candidates (sets of terms judged together), if any were judged."""
    joint = [s for s in steps if s.get("kind") == "joint" and "threshold" in s]
    if not joint:
        return ""
    return (". Sets of terms that enter together (kind 'joint') are judged as one family per step by Holm's rule, "
            "which holds the family's false-alarm rate at that of one term: the set with the k-th smallest "
            "p-value of m needs Student's t at the tail of z divided by m - k + 1 (thresholds here up to "
            f"{max(s['threshold'] for s in joint):.2f})")


def format_table(rows: list[dict], added: Sequence[dict] = (), steps: Sequence[dict] = (),
                 unexplained: dict | None = None, n_validation: int | None = None, z: float = 3.0,
                 min_gain: float = 0.05, cv: int | None = None, unit: str = "samples", tested: bool = True) -> str:
    """Markdown report: the before/after table, the selection log, the terms added, what is left.

    ``z`` and ``min_gain`` are the evidence thresholds the selection used (stated in the report);
    ``cv`` the number of contiguous blocks when every sample judged by a refit without its block;
    ``unit``: what ``n_validation`` counts ("groups" when samples were judged by groups);
    ``tested``: whether test data (or a test scorer) gave the error columns; without, the report
    says why the table has none.
    """
    skip = ("stage", "science", "added", "theta", "theta_error", "failed")
    metrics = list(dict.fromkeys(k for r in rows for k in r if k not in skip))
    names = list(dict.fromkeys(k for r in rows for k in r["theta"]))
    head = ["stage", *metrics, *names]
    lines = _poor_fit_lines(rows) + ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for r in rows:
        cells = [r["stage"]] + [f"{r.get(m, float('nan')):.4g}" for m in metrics]
        for n in names:
            v = r["theta"].get(n)
            text = "" if v is None else (f"{v:.5g}" if np.ndim(v) == 0 else str(np.round(v, 4).tolist()))
            err = r.get("theta_error", {}).get(n)
            cells.append(text + ("" if err is None else f" (err {err:.1%})"))
        lines.append("| " + " | ".join(cells) + " |")
        if "failed" in r:
            lines.append(f"\nThe {r['stage']} fit failed: {r['failed']}\n")
    if not tested:  # a table without errors reads as if the errors were lost
        lines += ["", "No test data given: the table has no error columns. Pass X_test, y_test (or test_scorer) "
                      "to compare the models' errors before and after."]
    if steps:
        judged = (f"{n_validation} validation {unit}" if cv is None else
                  f"all {n_validation} {unit} in {cv} contiguous blocks, each predicted by a refit on the others")
        if unit == "groups":
            judged += " (a group's samples judged together, by their mean error)"
        lines += ["", f"Selection (science model refitted without the network, mean squared error on "
                      f"{judged}; a term is accepted when it lowers it by at "
                      f"least {min_gain * 100:g} % and by more than "
                      f"{critical_value(z, n_validation or 0):.2f} standard errors, Student's t for the tail "
                      f"of z = {z:g}; a term the later "
                      "ones make dispensable by that test is dropped)" + _second_look_words(steps, min_gain)
                  + _joint_words(steps) + ":", "",
                  "| step | output | term | kind | validation MSE before | after | gain | z | accepted |",
                  "|---|---|---|---|---|---|---|---|---|"]
        bar = critical_value(z, n_validation or 0)
        for s in steps:
            s = {**s, "term": s["term"].replace("|", "\\|")}  # a bar inside a cell would split it
            if "failed" in s:
                lines.append(f"| {s['step']} | {s['output']} | {s['term']} | {s['kind']} | | failed | | | no |")
                continue
            lines.append(f"| {s['step']} | {s['output']} | {s['term']} | {s['kind']} | {s['mse_before']:.4g} | "
                         f"{s['mse_after']:.4g} | {format_gain(s['gain'])} | {s['z']:.1f} | "
                         f"{_verdict_word(s, min_gain, bar)} |")
    lines.append("")
    if added:
        for t in added:
            if t["kind"] == "offset":
                unit = f" {t['unit']}" if t.get("unit") else ""
                lines.append(f"Added a sensor offset: {t['output']} is measured as {t['output']} "
                             f"{t['coef']:+.4g}{unit} (the equations see the reading less it; parameter {t['param']})")
                continue
            shape = ", ".join(f"{k} = {v:.4g}" for k, v in t["shape"].items())
            where = t["output"] if "opposite_output" not in t else (
                f"{t['output']} and, with the opposite sign, to {t['opposite_output']} (a flow, one coefficient)")
            lines.append(f"Added to {where}: {t['coef']:+.4g} * {t['term']}"
                         + (f" with {shape}" if shape else "") + f" ({KIND_WORDS.get(t['kind'], t['kind'])}"
                         + (f", term in {t['unit']}" if t.get("unit") else "") + f"; parameter {t['param']}"
                         + ("; accepted on a second look" if t.get("second_look") else "")
                         + ("; its shape shared by every equation it is added to" if t.get("shape_group")
                            and shape else "")
                         + ("; dimensionally inconsistent in the units given" if t.get("consistent") is False else "")
                         + ")")
    elif _none_moved(steps):
        lines.append("Nothing added, and nothing judged: every candidate's refit stayed exactly where it started, "
                     "at the science refitted alone, a point least squares could not leave (see its parameters "
                     "in the table: one that left its physical range, a rate or a constant across zero, holds it "
                     "there; give theta_bounds). This is no evidence that nothing is missing.")
    else:
        lines.append(_nothing_added(steps, min_gain))
    if unexplained is not None:
        shares = ", ".join(f"{k} {v:.1%}" for k, v in unexplained["share"].items()
                           if k in unexplained["components"])
        lines.append(f"Not explained by the final science model (RMS share of what the hybrid learned): {shares}.")
    return "\n".join(lines)


#: The first hybrid's test error over the final network-free model's beyond which the hybrid is called poor: a
#: hybrid holds the network-free model's terms' worth of freedom in its network, so a well-trained one is not
#: worse by more than its overfitting of the noise.
POOR_FIT_RATIO = 1.5


def _nothing_added(steps: Sequence[dict], min_gain: float) -> str:
    """Why nothing was added: no candidate gained ``min_gain``, or the best that did was too uneven over the
    validation samples to pass (a few samples can carry a large gain, or hide one)."""
    gained = [s for s in steps if "failed" not in s and s["gain"] >= min_gain]
    if not gained:
        return "Nothing added: no candidate improved the held-out error by more than the noise explains."
    best = max(gained, key=lambda s: s["gain"])
    return (f"Nothing added: no candidate passed the evidence test. The largest gain, {best['term']} on "
            f"{best['output']}, lowered the held-out error by {format_gain(best['gain'])} but unevenly over the "
            f"validation samples (z {best['z']:.1f}): these data neither show it nor rule it out.")


def _none_moved(steps: Sequence[dict]) -> bool:
    """Whether every candidate judged ended at exactly the error it started from: the screening refits were
    stuck (an improvement of exactly zero is what no real fit gives), not a verdict on the candidates."""
    judged = [s for s in steps if "failed" not in s]
    return bool(judged) and all(s["mse_after"] == s["mse_before"] for s in judged)


def _poor_fit_lines(rows: list[dict]) -> list[str]:
    """The report's first lines when the first hybrid fit predicts the test data clearly worse than the final
    network-free model: its theta, and the residual the selection read from it, come from a network that
    did not learn what the science misses."""
    first = next((r for r in rows if r["stage"] == "before"), {})
    final = next((r for r in rows if r["stage"] == "science only"), {})
    hybrid, alone = first.get("rmse"), final.get("rmse")
    if hybrid is None or alone is None or not np.isfinite(hybrid) or not alone > 0 \
            or hybrid <= POOR_FIT_RATIO * alone:
        return []
    return [f"POOR HYBRID FIT: the first hybrid's test error (rmse {hybrid:.4g}) is {hybrid / alone:.1f} times "
            f"the final network-free model's ({alone:.4g}). Its network did not learn what the science misses "
            "(too few iterations, a learning rate too high or too low, a network too small), so its theta "
            "('before') is not to be read; the network-free model is the answer, its intervals from its own "
            "refit. A better first fit (est.fit_report() says how it ended) may let the loop find more.", ""]


def _verdict_word(step: dict, min_gain: float, bar: float) -> str:
    """The selection log's last column: a candidate that passed the evidence test but lost to a better one
    of its step is "not chosen", not "no" (which reads as rejected by the data)."""
    if step.get("dropped"):
        return "dropped"
    if step["accepted"]:
        return "yes"
    return "not chosen" if step["gain"] >= min_gain and step["z"] > bar else "no"


class LoopResult(Bunch):
    """What :func:`~sklearn_hybrid.diagnosis.close_the_loop` returns: its fields by name (a Bunch, as
    before), ``print(result)`` for the report with the network-free model's intervals, and
    :meth:`plot` for what the final science model still misses."""

    def __str__(self) -> str:
        intervals = self.get("intervals")
        return self["report"] + ("" if intervals is None else "\n\n" + intervals.report())

    def plot(self, axes: Any = None) -> np.ndarray:
        """The remaining residual against every variable (:func:`plot_unexplained`)."""
        return plot_unexplained(self, axes)
