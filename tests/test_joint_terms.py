"""Terms that explain an effect only together (joint candidates, judged with Holm's correction), dry friction as
sign(v), and power laws with a fitted exponent."""

import numpy as np
import pytest
import torch
from scipy.integrate import solve_ivp
from scipy.stats import norm

from sklearn_hybrid import HybridRegressor
from sklearn_hybrid.diagnosis import Candidates, Evidence, ScienceFit, Term, physics_terms
from sklearn_hybrid.diagnosis.loop import second_look, stepwise
from sklearn_hybrid.diagnosis.loop.candidates import term_columns
from sklearn_hybrid.diagnosis.evidence import critical_value, evidence, holm
from sklearn_hybrid.diagnosis import Verdict
from sklearn_hybrid.diagnosis.loop.joint import joint_candidates
from sklearn_hybrid.diagnosis.loop.placed import PlacedGroup, PlacedTerm
from sklearn_hybrid.diagnosis.loop.report import format_table

NAMES = ["x", "v"]


def oscillator_f(s, omega=1.0):
    """An undamped oscillator: the science model, which knows of no damping or driving."""
    return torch.stack([s[:, 1], -omega**2 * s[:, 0]], dim=-1)


def spring_f(s, k=1.0, c=0.1):
    """A spring with linear damping: the science model, which knows of no other friction."""
    return torch.stack([s[:, 1], -k * s[:, 0] - c * s[:, 1]], dim=-1)


def _trajectories(rhs, x0, dt, n_steps, noise, rng):
    t = dt * np.arange(n_steps + 1)
    x = np.stack([solve_ivp(rhs, (0, t[-1]), s, t_eval=t, rtol=1e-8, atol=1e-10).y.T for s in x0])
    return x, x[:, 1:] + noise * rng.standard_normal(x[:, 1:].shape)


def _select(science, theta, rhs, x0, dt, n_steps, n_validation, extra=None, seed=0, second_look=None) -> dict:
    """forward_selection on trajectories of ``rhs`` from ``x0`` (noise 0.01), the last ``n_validation`` judging;
    what the hybrid learned is the truth (plus ``extra``, a spurious part, at the visited states)."""
    rng = np.random.default_rng(seed)
    x, y = _trajectories(rhs, x0, dt, n_steps, 0.01, rng)
    est = HybridRegressor(science=science, dt=dt, max_iter=2, random_state=0).fit(x0, y)
    states = x.reshape(-1, 2)
    learned = np.stack([rhs(0, s) for s in states])
    if extra is not None:
        learned = learned + extra(states)
    n = len(x0)
    splits = [(np.arange(n - n_validation), np.arange(n - n_validation, n))]
    return stepwise.forward_selection(science, theta, ScienceFit(est, x0, y), splits, NAMES, 2, [states], learned,
                                      [1], candidates=Candidates(terms=physics_terms(NAMES, states)),
                                      evidence=Evidence(second_look=second_look))


def limit_cycle(mu, omega=1.3):
    """x'' = -omega^2 x + mu (1 - x^2) x': a van der Pol oscillator of its own (not the benchmark's)."""
    def rhs(t, s):
        return [s[1], -omega**2 * s[0] + mu * (1 - s[0] ** 2) * s[1]]
    return rhs


def _cycle_starts(n, seed=0):
    rng = np.random.default_rng(seed + 100)
    return np.column_stack([rng.uniform(-2.5, 2.5, n), rng.uniform(-2.5, 2.5, n)])


# ------------------------------------------------------------------------------------------- Holm's rule

def test_holm_with_one_candidate_is_the_single_test():
    verdict = evidence(np.full(12, 1.0), np.full(12, 0.5) * np.exp(0.05 * np.sin(np.arange(12))))
    assert holm([verdict], 12)[0]["threshold"] == pytest.approx(critical_value(3.0, 12))
    assert holm([verdict], 12)[0]["accepted"] == verdict["accepted"]


def test_holm_holds_the_family_rate_of_one_test():
    """Families of 8 useless candidates, each judged on 12 samples: each alone passes about once in 740
    (z = 3), so judged one by one about 8 of 740 families would accept one; Holm's rule holds it at 1 in 740."""
    rng = np.random.default_rng(0)
    n_families, m, n = 4000, 8, 12
    plain = corrected = 0
    for _ in range(n_families):
        before = np.exp(rng.standard_normal((m, n)))
        after = before * np.exp(0.3 * rng.standard_normal((m, n)))  # no real gain: noise around the same error
        verdicts = [evidence(b, a, min_gain=-np.inf) for b, a in zip(before, after)]
        plain += any(v["accepted"] for v in verdicts)
        corrected += any(v["accepted"] for v in holm(verdicts, n, min_gain=-np.inf))
    alpha = norm.sf(3.0)
    assert plain > 3 * alpha * n_families  # the comparisons multiply
    assert corrected <= 2 * alpha * n_families + 3  # about 5 expected; Poisson room, not a loosened rule


def test_holm_steps_down_and_still_asks_for_the_gain():
    def judged(z, gain):
        return Verdict(mse_before=1.0, mse_after=1.0 - gain, gain=gain, z=z, threshold=None, accepted=False)

    strong, weak, small = judged(12.0, 0.9), judged(4.0, 0.5), judged(12.0, 0.01)
    out = holm([weak, strong, small, judged(0.0, 0.0)], 12)
    # weak passes one test (3.85) but not its level, third of four; small is significant but gains too little
    assert weak["z"] > critical_value(3.0, 12) and [v["accepted"] for v in out] == [False, True, False, False]
    assert out[1]["threshold"] > out[0]["threshold"]  # the smallest p-value meets the strictest level
    assert holm([strong], 12, m=5)[0]["threshold"] > holm([strong], 12)[0]["threshold"]  # failed refits count


# ------------------------------------------------------------------------------------------- joint candidates

def test_joint_candidates_propose_the_pair_that_only_together_explains_a_limit_cycle():
    rhs = limit_cycle(0.5)
    x, _ = _trajectories(rhs, _cycle_starts(20), 0.2, 30, 0.0, np.random.default_rng(0))
    states = x.reshape(-1, 2)
    remaining = np.zeros_like(states)
    remaining[:, 1] = 0.5 * (1 - states[:, 0] ** 2) * states[:, 1]
    jac = states[:, None, :1] * np.array([0.0, 1.0])[None, :, None]  # omega's sensitivity acts like x on x'
    columns = term_columns(physics_terms(NAMES, states), {k: torch.as_tensor(states[:, i]) for k, i in
                                                          (("x", 0), ("v", 1))})
    cands = joint_candidates(columns, remaining, jac, [1], set())
    assert cands[0].name in ("v + x^2*v", "x^2*v + v") and cands[0].kind == "joint"
    assert cands[0].gain > 0.99 and cands[0].component == 1 and cands[0].n_parameters() == 2
    coefs = {e.name: e.coef for e in cands[0].entries()}
    assert coefs["v"] == pytest.approx(0.5, rel=1e-3) and coefs["x^2*v"] == pytest.approx(-0.5, rel=1e-3)
    # a term already in the model is not proposed again
    assert not [c for c in joint_candidates(columns, remaining, jac, [1], {(1, "v")})
                if "v" in c.name.split(" + ")]
    # a residual one term explains is left to the single terms: no set with it is worth its refit
    remaining[:, 1] = -0.4 * states[:, 1] ** 3
    assert not [c for c in joint_candidates(columns, remaining, jac, [1], set()) if "v^3" in c.name]


def test_a_limit_cycle_is_named_as_the_pair_that_only_together_passes():
    sel = _select(oscillator_f, {"omega": 1.0}, limit_cycle(0.5), _cycle_starts(30), 0.2, 30, 8)
    assert sorted(t.name for t in sel["added"]) == ["v", "x^2*v"]
    coef = {t.name: t.coef for t in sel["added"]}
    assert coef["v"] == pytest.approx(0.5, rel=0.05) and coef["x^2*v"] == pytest.approx(-0.5, rel=0.05)
    assert sel["theta"]["omega"] == pytest.approx(1.3, rel=0.02)
    first = [s for s in sel["steps"] if s["step"] == 1]
    assert not [s for s in first if s["kind"] != "joint" and s["accepted"]]  # no single term passed
    pair = [s for s in first if s["accepted"]]
    assert len(pair) == 1 and pair[0]["kind"] == "joint" and pair[0]["threshold"] > critical_value(3.0, 8)
    report = format_table([], [{**t.record(), "output": "g[v]"} for t in sel["added"]],
                          [{**s, "output": "g[v]"} for s in sel["steps"]], None, 8)
    assert "| joint |" in report and "Holm's rule" in report


def test_joint_candidates_add_nothing_to_a_control():
    """Nothing is missing, but the network learned a trace of a limit cycle (a network's residual is never
    zero): the pair it suggests is judged on the data, Holm-corrected, and does not enter."""
    def trace(states):
        out = np.zeros_like(states)
        out[:, 1] = 0.05 * (1 - states[:, 0] ** 2) * states[:, 1]
        return out

    sel = _select(oscillator_f, {"omega": 1.0}, limit_cycle(0.0), _cycle_starts(30), 0.2, 30, 8, extra=trace,
                  second_look=4)
    assert sel["added"] == []
    judged = [s for s in sel["steps"] if s["kind"] == "joint" and isinstance(s["step"], int)]
    assert "v + x^2*v" in {s["term"] for s in judged} or "x^2*v + v" in {s["term"] for s in judged}
    assert all(s["threshold"] >= critical_value(3.0, 8) for s in judged)


def test_of_the_best_a_single_term_of_another_kind_beats_two_stand_ins():
    """Two stand-ins that explain an effect only together lose to one term that does as well."""
    def tried(cand, mse):
        return second_look.Screened(cand, {}, {"accepted": True, "mse_after": mse}, None, None, 0)

    pair = PlacedGroup((PlacedTerm(Term("sqrt|T|", None, "sqrt"), 0), PlacedTerm(Term("exp(k*T)", None, "exponential"),
                                                                                  0, {"k": 1.0})), joint=True)
    power = PlacedTerm(Term("|T|^p", None, "power"), 0, {"p": 1.0})
    assert pair.name == "sqrt|T| + exp(k*T)" and pair.n_parameters() == 3 and power.n_parameters() == 2
    assert second_look.simplest_of_the_best([tried(pair, 1.00), tried(power, 1.03)], 0.05).cand is power
    # a pair clearly better than every single stays
    assert second_look.simplest_of_the_best([tried(pair, 1.00), tried(power, 1.5)], 0.05).cand is pair


# ------------------------------------------------------------------------------------------- sign and power laws

def test_sign_and_power_terms_are_offered_where_they_mean_something():
    values = np.column_stack([np.linspace(-1, 1, 30), np.linspace(0.1, 2, 30)])
    names = {t.name: t for t in physics_terms(["v", "h"], values)}
    assert names["sign(v)"].kind == "dry_friction" and "sign(h)" not in names  # a level never changes sign
    assert {"|v|^p", "v|v|^(p-1)", "|h|^p"} <= set(names) and "h|h|^(p-1)" not in names
    d = {"v": torch.tensor([-4.0, 0.0, 9.0]), "h": torch.tensor([1.0, 1.0, 1.0])}
    np.testing.assert_allclose(names["v|v|^(p-1)"](d, p=torch.tensor(1.5)).numpy(), [-8.0, 0.0, 27.0], rtol=1e-6)
    np.testing.assert_allclose(names["|v|^p"](d, p=torch.tensor(0.5)).numpy(), [2.0, 1e-6, 3.0], rtol=1e-5)
    assert not [t for t in physics_terms(["v"], values[:, :1], kinds=["polynomial"]) if t.kind == "power"]


def _damped(extra):
    """x'' = -2 x - 0.2 x' + extra(x'), from starts of amplitude 1.5 to 2.5: dry friction never sticks here."""
    def rhs(t, s):
        return [s[1], -2.0 * s[0] - 0.2 * s[1] + extra(s[1])]
    rng = np.random.default_rng(7)
    amp, phase = rng.uniform(1.5, 2.5, 30), rng.uniform(0, 2 * np.pi, 30)
    return rhs, np.column_stack([amp * np.cos(phase), amp * np.sqrt(2.0) * np.sin(phase)])


def test_coulomb_friction_is_named_as_sign_within_ten_percent():
    rhs, x0 = _damped(lambda v: -0.3 * np.sign(v))
    sel = _select(spring_f, {"k": 1.0, "c": 0.1}, rhs, x0, 0.1, 30, 8)
    assert [t.kind for t in sel["added"]] == ["dry_friction"]
    term = sel["added"][0].record()
    v = np.linspace(-3, 3, 601)
    found = term["coef"] * (np.sign(v) if term["term"] == "sign(v)" else np.tanh(v / term["shape"]["w"]))
    # in function space, the friction force with the linear damping refitted beside it
    truth, model = -0.3 * np.sign(v) - 0.2 * v, found - sel["theta"]["c"] * v
    assert np.sqrt(np.mean((model - truth) ** 2)) / np.sqrt(np.mean(truth ** 2)) < 0.1
    assert abs(term["coef"] + 0.3) < 0.03


def test_a_power_law_is_named_with_its_exponent():
    rhs, x0 = _damped(lambda v: -0.6 * v * np.abs(v) ** 0.5)
    sel = _select(spring_f, {"k": 1.0, "c": 0.1}, rhs, x0, 0.1, 30, 8)
    assert [t.name for t in sel["added"]] == ["v|v|^(p-1)"]
    term = sel["added"][0].record()
    assert term["shape"]["p"] == pytest.approx(1.5, abs=0.1)
    v = np.linspace(-3, 3, 601)
    truth = -0.6 * v * np.abs(v) ** 0.5 - 0.2 * v
    model = term["coef"] * v * np.abs(v) ** (term["shape"]["p"] - 1) - sel["theta"]["c"] * v
    assert np.sqrt(np.mean((model - truth) ** 2)) / np.sqrt(np.mean(truth ** 2)) < 0.1
