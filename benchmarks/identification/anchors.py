"""The anchors beside the closed loop, shared by the scripts that run them: UDE + SINDy on a hybrid fit's network
output (the sparse fit, the augmented science, its refit without the network) and SINDy on the data alone.

``bench_anchors_loop.py`` runs them on the identification benchmark's cases, ``discovery/bench_discovery.py`` on
the laws batch; the recipes are described in the former's docstring.
"""

from __future__ import annotations

import numpy as np
import torch

from identification.protocol import score
from identification.sparse_grid import GRID, cv_choice

from sklearn_hybrid.science import read_signature

N_SUBSTEPS = 4


def pysindy_module():
    """pysindy (the [sindy] extra), imported where a case runs rather than at the top: ``--help`` and ``--render``
    need none, and where it is missing the error says how to get it."""
    try:
        import pysindy
    except ImportError as error:
        raise SystemExit("bench_anchors_loop.py needs pysindy to run a case: pip install 'sklearn_hybrid[sindy]' "
                         "(--render needs none)") from error
    return pysindy


def sbr():
    try:
        from pysindy.optimizers import SBR
    except ImportError:
        return None
    return SBR


def polynomial_powers(n_vars: int) -> np.ndarray:
    ps = pysindy_module()
    lib = ps.PolynomialLibrary(degree=3).fit(np.zeros((2, n_vars)))
    return lib.powers_


def monomials(Z: torch.Tensor, powers: np.ndarray) -> torch.Tensor:
    """pysindy's PolynomialLibrary columns, in torch (for the refit's simulation)."""
    p = torch.as_tensor(powers, dtype=Z.dtype)
    return torch.prod(Z[:, None, :] ** p[None], dim=-1)


def sparse_fit(Theta: np.ndarray, r: np.ndarray, optimizer) -> np.ndarray:
    """Coefficients of ``r`` on the columns of ``Theta`` (original units), threshold by CV on unit-RMS columns."""
    scale = np.sqrt(np.mean(Theta**2, axis=0))
    scale[scale == 0] = 1.0
    Xs, rms = Theta / scale, np.sqrt(np.mean(r**2))
    if rms == 0:
        return np.zeros(Theta.shape[1])
    if optimizer == "stlsq":
        ps = pysindy_module()

        def make(t):
            return ps.STLSQ(threshold=t, unbias=True)
        threshold = cv_choice(make, Xs, r, GRID * rms, one_se=True)
        return make(threshold).fit(Xs, r).coef_.ravel() / scale
    # A horseshoe posterior mean is never exactly zero: a term is kept where its central 95 % posterior interval
    # excludes zero (the Bayesian reading of "the data support it"); fewer MCMC draws than pysindy's defaults.
    opt = sbr()(num_warmup=300, num_samples=1000).fit(Xs, r)
    draws = np.asarray(opt.mcmc_.get_samples()["beta"]).reshape(1000, -1)
    low, high = np.quantile(draws, [0.025, 0.975], axis=0)
    coef = opt.coef_.ravel()
    return np.where((low > 0) | (high < 0), coef, 0.0) / scale


def combined_science(system, powers):
    """The science function plus the sparse terms ``Theta(v, u) xi`` (xi: features x states)."""
    science, names = system.science, list(system.theta_true)

    def f(v, *u, **theta):
        base = science(v, *u, **{k: theta[k] for k in names})
        Z = torch.cat([v] + [ui for ui in u], dim=1)
        return base + monomials(Z, powers) @ theta["_xi"]
    f.__name__ = f"{system.science.__name__}_plus_sindy"
    return f


def refit(system, f, theta0: dict, xi0: np.ndarray, support: np.ndarray, data: dict, u: np.ndarray | None):
    """theta and the coefficients on ``support`` by least squares on the training trajectories, no network."""
    X, y = data["X"], torch.as_tensor(data["y"], dtype=torch.float64)
    d = y.shape[-1]
    x0 = torch.as_tensor(np.asarray(X)[:, :d], dtype=torch.float64)
    uu = None if u is None else torch.as_tensor(u, dtype=torch.float64)
    params = {k: torch.tensor(float(v), dtype=torch.float64, requires_grad=True) for k, v in theta0.items()}
    free = torch.tensor(xi0[support], dtype=torch.float64, requires_grad=True)
    mask = torch.as_tensor(support)

    def simulate_all():
        xi = torch.zeros(xi0.shape, dtype=torch.float64).index_put((mask.nonzero(as_tuple=True)), free)
        theta = {**params, "_xi": xi}
        h, x, out = system.dt / N_SUBSTEPS, x0, []
        for step in range(y.shape[1]):
            for s in range(N_SUBSTEPS):
                def rhs(state, frac):
                    if uu is None:
                        return f(state, **theta)
                    ut = uu[:, step] + (uu[:, step + 1] - uu[:, step]) * frac
                    return f(state, ut, **theta)
                a = (s + 0.0) / N_SUBSTEPS
                k1 = rhs(x, a)
                k2 = rhs(x + h / 2 * k1, a + 0.5 / N_SUBSTEPS)
                k3 = rhs(x + h / 2 * k2, a + 0.5 / N_SUBSTEPS)
                k4 = rhs(x + h * k3, a + 1.0 / N_SUBSTEPS)
                x = x + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
            out.append(x)
        return torch.stack(out, dim=1), theta

    def loss():
        pred, _ = simulate_all()
        return torch.mean((pred - y) ** 2)

    start = float(loss().detach())
    if not np.isfinite(start):
        return theta0, xi0, "the start diverged: not refitted"
    opt = torch.optim.LBFGS([*params.values(), free], max_iter=200, line_search_fn="strong_wolfe")

    def closure():
        opt.zero_grad()
        value = loss()
        if torch.isfinite(value):
            value.backward()
        return value
    try:
        opt.step(closure)
    except (RuntimeError, IndexError) as error:  # torch's strong-Wolfe search fails on a non-finite loss
        return theta0, xi0, f"refit failed: {type(error).__name__}: {error}"
    end = float(loss().detach())
    if not np.isfinite(end) or end > start:
        return theta0, xi0, "refit did not lower the loss: kept SINDy's coefficients"
    _, theta = simulate_all()
    return ({k: float(v) for k, v in params.items()}, theta["_xi"].detach().numpy(), "refitted")


def theta_error(system, theta) -> float | None:
    keys = [k for k, v in system.theta_true.items() if np.ndim(v) == 0 and v != 0]
    return float(np.mean([abs(theta[k] - system.theta_true[k]) / abs(system.theta_true[k]) for k in keys])) \
        if keys else None


def term_labels(support, xi, n_vars, system):
    ps = pysindy_module()
    names = ps.PolynomialLibrary(degree=3).fit(np.zeros((2, n_vars))).get_feature_names(
        list(system.state_names) + (["u"] if system.forced else []))
    return [f"{xi[i, j]:+.3g} {names[i]} [{system.state_names[j]}]" for i, j in zip(*np.nonzero(support))]


def sindy_on_data(system, data, u_train, powers) -> dict:
    """STLSQ on [the science's parameter derivatives at the guesses | cubic polynomials] against derivatives of
    the noisy trajectories; scored as a whole model (it has no theta of its own)."""
    d = len(system.state_names)
    states = np.concatenate([np.asarray(data["X"])[:, None, :d], data["y"]], axis=1)
    t = system.dt * np.arange(states.shape[1])
    ps = pysindy_module()
    diff = ps.SmoothedFiniteDifference()
    xdot = np.concatenate([np.asarray(diff(s, t)) for s in states])
    x = states.reshape(-1, d)
    u = None if u_train is None else u_train.reshape(-1, u_train.shape[-1])
    guess = {k: float(v) for k, v in (system.theta_guess or read_signature(system.science)[1]).items()}

    def known(v, *uu):  # d f_j / d theta_k at the guesses, every (k, j) a column
        cols = []
        for k in guess:
            h = 1e-6 * max(abs(guess[k]), 1.0)
            up = system.science(v, *uu, **{**guess, k: guess[k] + h})
            down = system.science(v, *uu, **{**guess, k: guess[k] - h})
            cols.append((up - down) / (2 * h))
        return torch.cat(cols, dim=1)

    def features(v, *uu):
        Z = torch.cat([v, *uu], dim=1)
        return torch.cat([known(v, *uu), monomials(Z, powers)], dim=1)

    args = [torch.as_tensor(x)] + ([] if u is None else [torch.as_tensor(u)])
    with torch.no_grad():
        Theta = features(*args).numpy()
    xi = torch.as_tensor(np.stack([sparse_fit(Theta, xdot[:, j], "stlsq") for j in range(d)], axis=1))

    def model(v, *uu, **_):
        return features(v, *uu) @ xi
    model.__name__ = "sindy_on_data"
    scores = score(system, model, {}, guess, data["x_test"], data["u_test"])
    return {**scores, "n_terms": int((xi != 0).sum())}
