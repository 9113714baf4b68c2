"""Laplace intervals of theta with the network integrated out (issue "Is theta identified?", item 3).

An experiment, kept beside the benchmark until it earns a place in the
package.  At the fitted parameters w = (theta, phi), with J the derivative of
every predicted value by w (theta through its bounds' reparametrisation),

    H = J^T S^-1 J + diag(eps for theta, lam for phi),

S the noise variance per state (the residuals' mean square), and theta's
marginal covariance the theta block of H^-1 (the Schur complement: where the
network can take over part of theta, H_pp is nearly singular along it and
theta's variance grows).  lam, the network's prior precision, is what the data
do not fix: it is chosen by the Laplace evidence (MacKay), as laplace-torch's
``optimize_prior_precision(method="marglik")`` does, over a log grid.
"""

from __future__ import annotations

import numpy as np
import torch
from scipy import stats
from torch.func import functional_call, jacrev

from sklearn_hybrid import _fast
from sklearn_hybrid.identifiability._members import fitted_problem, parameter_entries

PRIOR_GRID = np.logspace(-4, 4, 33)
THETA_PRECISION = 1e-8  # theta's prior: flat, only to keep H invertible where the data say nothing


def laplace_theta(estimator, X, y, level=0.95, prior_precision=None):
    """Theta's marginal Laplace intervals of a fitted HybridRegressor.

    Returns ``dict(intervals, std_raw, verdicts, prior_precision, log_evidence)``
    keyed by parameter label; an interval wider than the estimate's magnitude
    on either side is "not identified" (the rule of ``science_intervals``).
    """
    problem = fitted_problem(estimator, X, y)
    model = problem.model
    inputs = tuple(t.to(torch.float64) if torch.is_floating_point(t) else t for t in problem.inputs)
    model = __import__("copy").deepcopy(model).to(torch.float64)
    target = problem.y.to(torch.float64)
    names = [n for n, p in model.named_parameters() if p.requires_grad]
    params = {n: p.detach() for n, p in model.named_parameters() if p.requires_grad}
    science_raw = {f"science.raw.{n}" for n in model.science.names}

    def predict(p):
        return functional_call(model, p, inputs)[0].reshape(len(target), -1)

    with torch.enable_grad(), _fast.disabled():  # the fast RK4's autograd function does not run under jacrev
        pred = predict(params)
        jac = jacrev(predict)(params)
    n, m = target.shape
    d = estimator.y_shape_[-1] if len(estimator.y_shape_) > 1 else 1
    resid = (target - pred.detach()).reshape(n, -1, d)
    noise_var = resid.pow(2).mean(dim=(0, 1))  # per state
    weight = (1.0 / noise_var).repeat(m // d)  # (m,), state varies fastest
    J = torch.cat([jac[k].reshape(n * m, -1) for k in names], dim=1).numpy()
    w = np.tile(weight.numpy(), n)
    G = J.T @ (J * w[:, None])
    sizes = [params[k].numel() for k in names]
    is_theta = np.concatenate([np.full(s, k in science_raw) for k, s in zip(names, sizes)])
    phi = np.concatenate([params[k].reshape(-1).numpy() for k in names])[~is_theta]
    n_phi = int((~is_theta).sum())

    def evidence(lam):
        prior = np.where(is_theta, THETA_PRECISION, lam)
        try:
            chol = np.linalg.cholesky(G + np.diag(prior))
        except np.linalg.LinAlgError:
            return -np.inf, None
        logdet = 2 * np.sum(np.log(np.diag(chol)))
        return 0.5 * n_phi * np.log(lam) - 0.5 * lam * phi @ phi - 0.5 * logdet, chol

    grid = PRIOR_GRID if prior_precision is None else [float(prior_precision)]
    scores = [evidence(lam)[0] for lam in grid]
    lam = float(grid[int(np.argmax(scores))])
    _, chol = evidence(lam)
    theta_cols = np.flatnonzero(is_theta)
    # theta block of H^-1 from solves against the unit columns of theta
    E = np.zeros((len(is_theta), len(theta_cols)))
    E[theta_cols, np.arange(len(theta_cols))] = 1.0
    Z = np.linalg.solve(chol.T, np.linalg.solve(chol, E))
    cov = Z[theta_cols]
    # map raw theta columns to labels (science.raw.<name> in the order of named_parameters)
    science = model.science
    col = 0
    raw_index = {}
    for k, s in zip(names, sizes):
        if k in science_raw:
            for j in range(s):
                raw_index[(k.split(".")[-1], j)] = col
                col += 1
    z = stats.norm.ppf(0.5 + level / 2)
    out = {"intervals": {}, "std_raw": {}, "verdicts": {}, "prior_precision": lam, "log_evidence": max(scores)}
    for name, k, label in parameter_entries(science, None):
        j = raw_index[(name, k)]
        sd = float(np.sqrt(max(cov[j, j], 0.0)))
        raw = science.raw[name].detach().reshape(-1)[k].item()
        transform = science.transforms[name]
        ends = []
        for r in (raw - z * sd, raw, raw + z * sd):
            full = science.raw[name].detach().clone().reshape(-1)
            full[k] = r
            ends.append(float(np.asarray(transform(full.reshape(science.shapes[name]))).reshape(-1)[k]))
        low, value, high = min(ends[0], ends[2]), ends[1], max(ends[0], ends[2])
        identified = np.isfinite(high - low) and max(value - low, high - value) < abs(value)
        out["intervals"][label] = (low, high)
        out["std_raw"][label] = sd
        out["verdicts"][label] = "identified" if identified else "not identified"
    return out
