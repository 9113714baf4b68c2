"""Two stand-ins that explain an effect only together are replaced by one term of another kind that does as well."""

import numpy as np
import pytest
import torch
from scipy.integrate import solve_ivp

from sklearn_hybrid import HybridRegressor, pack_inputs
from sklearn_hybrid.diagnosis import Evidence, ScienceFit, physics_terms
from sklearn_hybrid.diagnosis.judge import Judge
from sklearn_hybrid.diagnosis.loop.candidates import augment_with, shape_bounds, term_columns
from sklearn_hybrid.diagnosis.loop.collapse import replace_stand_ins
from sklearn_hybrid.diagnosis.loop.placed import PlacedTerm

NAMES = ["T", "u"]


def heated_f(v, u, p=0.8, h=0.25):
    """A heated body losing heat linearly: the science model, which knows of no other loss."""
    return torch.stack([p * u[:, 0] - h * v[:, 0]], dim=-1)


@pytest.fixture(scope="module")
def radiating():
    """30 runs of T' = u - 0.3 T - 0.12 T^2.7 (a loss beyond the library's degrees), 8 judging."""
    rng = np.random.default_rng(0)
    n, dt, n_steps = 30, 0.25, 30
    amps, freqs, x0 = rng.uniform(0.2, 1.5, n), rng.uniform(0.2, 1.0, n), rng.uniform(0.2, 2.5, n)

    def u_of(i, t):
        return amps[i] * (1 + np.sin(freqs[i] * t)) / 2 + 0.2

    t = dt * np.arange(n_steps + 1)
    x = np.stack([solve_ivp(lambda s, T: [u_of(i, s) - 0.3 * T[0] - 0.12 * abs(T[0]) ** 2.7], (0, t[-1]), [x0[i]],
                            t_eval=t, rtol=1e-9, atol=1e-11).y.T for i in range(n)])
    u = np.stack([u_of(i, t) for i in range(n)])[..., None]
    y = x[:, 1:] + 0.01 * rng.standard_normal(x[:, 1:].shape)
    X = pack_inputs(x[:, 0], u)
    est = HybridRegressor(science=heated_f, dt=dt, n_inputs=1, max_iter=2, random_state=0).fit(X, y)
    states, inputs = x.reshape(-1, 1), u.reshape(-1, 1)
    learned = inputs - 0.3 * states - 0.12 * np.abs(states) ** 2.7
    judge = Judge(ScienceFit(est, X, y), [(np.arange(n - 8), np.arange(n - 8, n))])
    return judge, states, inputs, learned


def _fitted(judge, terms, names_shapes, start):
    placed = [PlacedTerm(terms[name], 0, shape, coef, 0.0) for name, shape, coef in names_shapes]
    model = augment_with(heated_f, placed, NAMES, 1, None)
    bounds = shape_bounds(model, placed)
    theta = judge.fit(model, {**start, **{model.terms[k][2]: p.coef for k, p in enumerate(placed)},
                              **{g: placed[k].shape[loc] for k in range(len(placed))
                                 for loc, g in model.shape_names[k].items()}}, bounds)
    added = [p.with_fitted(model, theta, k) for k, p in enumerate(placed)]
    return model, added, theta, judge.errors(model, theta, bounds)


def _replace(radiating, names_shapes):
    judge, states, inputs, learned = radiating
    terms = {t.name: t for t in physics_terms(NAMES, np.hstack([states, inputs]))}
    model, added, theta, errors = _fitted(judge, terms, names_shapes, {"p": 0.8, "h": 0.25})
    columns = term_columns(list(terms.values()), {"T": torch.as_tensor(states[:, 0]),
                                                  "u": torch.as_tensor(inputs[:, 0])})
    steps = []
    out = replace_stand_ins(heated_f, model, added, theta, errors, judge, columns, learned, [states, inputs], NAMES,
                            1, None, steps, lambda s: None, evidence=Evidence())
    return theta, out, steps


def test_a_square_root_and_an_exponential_give_way_to_the_power_law(radiating):
    before, (_, added, theta, _), steps = _replace(radiating, [("sqrt|T|", {}, -0.1), ("exp(k*T)", {"k": 1.0}, -0.05)])
    assert abs(before["h"] - 0.3) > 0.05  # the stand-ins moved the science's own parameter
    assert [t.name for t in added] == ["|T|^p"]
    assert added[0].shape["p"] == pytest.approx(2.7, abs=0.1) and added[0].coef == pytest.approx(-0.12, rel=0.1)
    assert theta["h"] == pytest.approx(0.3, abs=0.02)  # and the replacement puts it back
    assert [s["term"] for s in steps if s["step"] == "replace" and s["accepted"]] == ["|T|^p"]
    assert all(s["kind"] not in ("sqrt", "exponential") for s in steps)  # a term of another kind


def test_a_polynomial_pair_is_left_as_it_is(radiating):
    """T^2 + T^3 is a Taylor reading, not two stand-ins: nothing is tried."""
    _, (_, added, _, _), steps = _replace(radiating, [("T^2", {}, -0.05), ("T^3", {}, -0.05)])
    assert [t.name for t in added] == ["T^2", "T^3"] and steps == []
