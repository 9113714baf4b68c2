"""The closed loop's intervals account for the choice of term: confounding, rival forms, an incomplete model,
and the norm terms (issue 48). Systems here are the tests' own, not the benchmarks'."""

import numpy as np
import pytest
import torch
from scipy.integrate import solve_ivp

from sklearn_hybrid import HybridRegressor
from sklearn_hybrid.diagnosis import Candidates, ZeroResidual, close_the_loop, physics_terms
from sklearn_hybrid.diagnosis import Evidence
from sklearn_hybrid.diagnosis.evidence import group_means
from sklearn_hybrid.diagnosis.loop.caveats import HYBRID_GAIN, UNEXPLAINED_SHARE, left_unexplained, worse_than_hybrid
from sklearn_hybrid.identifiability import ScienceIntervals, science_intervals


def test_norm_terms_pair_states_of_one_unit_only():
    values = np.random.default_rng(0).normal(size=(50, 4))
    names = {t.name for t in physics_terms(["x", "y", "vx", "vy"], values, kinds=["norm"],
                                           units={"x": "m", "y": "m", "vx": "m/s", "vy": "m/s"})}
    assert names == {"|(x, y)|", "|(x, y)|*x", "|(x, y)|*y", "|(vx, vy)|", "|(vx, vy)|*vx", "|(vx, vy)|*vy"}
    assert not physics_terms(["x", "v"], values[:, :2], kinds=["norm"], units={"x": "m", "v": "m/s"})
    assert not physics_terms(["a", "b"], values[:, :2], kinds=["norm"])  # unknown units: no norm
    # concentrations share a unit, but their norm is no physical quantity
    assert not physics_terms(["A", "B"], values[:, :2], kinds=["norm"], units={"A": "mol/l", "B": "mol/l"})
    drag = next(t for t in physics_terms(["vx", "vy"], values[:, :2], kinds=["norm"],
                                         units={"vx": "m/s", "vy": "m/s"}) if t.name == "|(vx, vy)|*vx")
    d = {"vx": torch.tensor([3.0]), "vy": torch.tensor([4.0])}
    assert float(drag(d)) == pytest.approx(15.0)
    assert drag.field == "|(vx, vy)|*(vx, vy)"  # one component of the drag along the speed
    # three velocity components: each pair, and the speed in space with its field
    space = {t.name: t for t in physics_terms(["vx", "vy", "vz"], values[:, :3], kinds=["norm"],
                                              units={"vx": "m/s", "vy": "m/s", "vz": "m/s"})}
    assert len(space) == 4 * 3 + 1 and space["|(vx, vy, vz)|*vz"].field == "|(vx, vy, vz)|*(vx, vy, vz)"
    d["vz"] = torch.tensor([12.0])
    assert float(space["|(vx, vy, vz)|*vz"](d)) == pytest.approx(13.0 * 12.0)


def test_a_vector_fields_terms_are_tried_together_each_on_its_own_equation():
    """|v| vx ranked on g[vx]: the group places it there and |v| vy where that ranks best (not on
    g[vx] again, and not where it ranks second), each with its own coefficient; a term of no field
    makes no group."""
    from sklearn_hybrid.diagnosis.loop.groups import field_groups
    from sklearn_hybrid.diagnosis.loop.placed import PlacedTerm

    terms = {t.name: t for t in physics_terms(["vx", "vy"], np.ones((5, 2)), kinds=["norm", "polynomial"],
                                              units={"vx": "m/s", "vy": "m/s"})}
    on_vx = PlacedTerm(terms["|(vx, vy)|*vx"], 0, {}, -0.3, 0.4)
    scored = [on_vx, PlacedTerm(terms["|(vx, vy)|*vy"], 0, {}, -0.1, 0.3),  # best on g[vx], taken there
              PlacedTerm(terms["|(vx, vy)|*vy"], 1, {}, -0.3, 0.2), PlacedTerm(terms["vx"], 1, {}, 1.0, 0.5),
              PlacedTerm(terms["|(vx, vy)|*vx"], 1, {}, 0.1, 0.01)]
    group, = field_groups([on_vx, scored[3]], scored)
    assert [(m.name, m.component, m.coef) for m in group.members] == [("|(vx, vy)|*vx", 0, -0.3),
                                                                       ("|(vx, vy)|*vy", 1, -0.3)]
    assert group.name == "|(vx, vy)|*(vx, vy)" and group.component == [0, 1] and group.n_parameters() == 2
    assert group.row()["ranked_by"] == "group"
    assert field_groups([scored[3]], scored) == []
    assert field_groups([on_vx], [on_vx]) == []  # its partner taken already: nothing to group


def test_a_parameter_that_trades_with_a_chosen_term_is_conditional():
    """Over 0.5 < x < 3, x / (1 + x) is nearly a multiple of x: the rate a is told from the term's
    coefficient c only through the term's form."""
    rng = np.random.default_rng(1)
    x = rng.uniform(0.5, 3.0, (40, 6))
    y = -0.7 * x + 0.4 * x / (1 + x) + 0.01 * rng.normal(size=x.shape)

    def decay_m(x, a=-0.5, c=0.0):
        return a * x + c * x / (1 + x)

    est = HybridRegressor(science=decay_m, structure="additive", residual=ZeroResidual(), method="erm", lr=5e-2,
                          max_iter=800, tol=None, dtype="float64", random_state=0).fit(x, y)
    plain = science_intervals(est, x, y)
    given = science_intervals(est, x, y, terms={"x/(1 + x)": ["c"]})
    assert plain.verdicts["a"] == "identified" and given.verdicts["a"] == "conditional"
    assert given.verdicts["c"] == "identified"  # the term's own coefficient is not conditional on itself
    assert "trades with x/(1 + x)" in given.conditional["a"]
    assert given.intervals["a"] == plain.intervals["a"]  # no rival form: the interval given the form
    assert "CONDITIONAL on the form of the term added" in given.report()
    assert "given that form alone" in given.report() and "over the forms" not in given.report()
    with pytest.raises(ValueError, match=r"terms names \['c2'\], which are not parameters"):
        science_intervals(est, x, y, terms={"x/(1 + x)": ["c2"]})
    with pytest.raises(TypeError, match="terms must map each chosen term's label to a list"):
        science_intervals(est, x, y, terms={"x/(1 + x)": "c"})
    with pytest.raises(TypeError, match="terms must map"):
        science_intervals(est, x, y, terms=["c"])


def test_widen_and_make_conditional_keep_what_is_not_identified():
    ci = ScienceIntervals(estimate={"k": 1.0, "q": 2.0}, std={"k": 0.1, "q": np.inf},
                          intervals={"k": (0.8, 1.2), "q": (-np.inf, np.inf)},
                          verdicts={"k": "identified", "q": "not identified"}, level=0.95, n_samples=10)
    ci.widen("k", [1.3])
    assert ci.intervals["k"] == (0.8, 1.3) and ci.verdicts["k"] == "identified"
    ci.make_conditional("k", "with x^3 added: 0.6", [0.6])
    ci.make_conditional("q", "with x^3 added: 5")
    assert ci.intervals["k"] == (0.6, 1.3) and ci.verdicts == {"k": "conditional", "q": "not identified"}
    assert ci.conditional == {"k": "with x^3 added: 0.6"}
    assert "[0.6, 1.3] over the forms the data cannot tell apart" in ci.report()
    # conditional by a trade alone, then widened by a rival form that moves it a little: a range over forms now
    ci = ScienceIntervals(estimate={"k": 1.0}, std={"k": 0.1}, intervals={"k": (0.8, 1.2)},
                          verdicts={"k": "identified"}, level=0.95, n_samples=10)
    ci.make_conditional("k", "trades with x^3, R^2 0.95")
    assert "[0.8, 1.2] given that form alone" in ci.report()
    ci.widen("k", [1.25])
    assert "[0.8, 1.25] over the forms the data cannot tell apart" in ci.report()


def test_left_unexplained_names_the_equation_and_the_variable():
    centre = np.linspace(0, 1, 4)
    unexplained = {"share": {"g[x]": 0.02, "g[v]": 0.25}, "components": ["g[x]", "g[v]"],
                   "profiles": {("g[v]", "x"): (centre, np.zeros(4)), ("g[v]", "v"): (centre, centre ** 2)}}
    learned = np.ones((10, 2))
    network = np.full((10, 2), 0.5)  # the network carried half of each equation
    why = left_unexplained(unexplained, network, learned, ["g[x]", "g[v]"])
    assert "25% of what the hybrid learned on g[v]" in why and "varying most with v" in why
    # a remainder small against what the network carried is what it learned of the noise
    small = {**unexplained, "share": {"g[x]": 0.02, "g[v]": 0.12}}
    assert left_unexplained(small, np.ones((10, 2)), learned, ["g[x]", "g[v]"]) is None
    assert UNEXPLAINED_SHARE[0] > 0.02


def test_worse_than_hybrid_asks_for_a_large_and_clear_gain():
    rng = np.random.default_rng(0)
    final = 0.01 * rng.uniform(0.8, 1.2, 20)
    why = worse_than_hybrid(final, 0.3 * final, Evidence())
    assert "30% of the final model's error" in why and "over 20 samples" in why
    assert worse_than_hybrid(final, 0.8 * final, Evidence()) is None  # a clear gain, but small: the network's own fit
    assert HYBRID_GAIN >= 0.5
    scattered = final * np.where(np.arange(20) < 2, 0.01, 1.5)  # two samples better, the others worse
    assert worse_than_hybrid(final, scattered, Evidence()) is None
    codes = np.repeat(np.arange(2), 10)  # two groups: too few to pass Student's t
    np.testing.assert_allclose(group_means(final, codes), [final[:10].mean(), final[10:].mean()])
    assert group_means(final, None) is final
    assert worse_than_hybrid(final, final * rng.uniform(0.2, 0.4, 20), Evidence(), codes) is None


def _decay(seed, missing):
    """Decay with (``missing``) a term no candidate of the test can express (this test's own system)."""
    rng = np.random.default_rng(seed)
    x0 = rng.uniform(0.5, 3.0, (20, 1))
    t = 0.3 * np.arange(11)
    rhs = (lambda _, v: -0.7 * v + 0.1 * np.sin(3 * v)) if missing else (lambda _, v: -0.7 * v)
    states = np.stack([solve_ivp(rhs, (0, t[-1]), x, t_eval=t, rtol=1e-10).y.T for x in x0])
    return x0, states[:, 1:] + 0.005 * rng.standard_normal((20, 10, 1))


def decay_m(v, k=0.3):
    return -k * v


@pytest.mark.parametrize("missing", [True, False])
def test_a_final_model_the_hybrid_fits_far_better_is_incomplete(missing, monkeypatch):
    """A missing sin(3x) that no candidate expresses: nothing is added, the hybrid fits the data far better
    than the refitted science, and its intervals are withheld; with the science complete they stand. (The
    useless candidate's small held-out gain, an open question of its own, is set aside to test this one.)"""
    from sklearn_hybrid.diagnosis.loop import stages

    monkeypatch.setattr(stages, "open_question", lambda steps, min_gain: None)
    X, y = _decay(0, missing)
    useless = Candidates(user_terms={"cos(50 x)": lambda d: torch.cos(50 * d["x"])}, kinds=["user"],
                         max_terms=1)
    res = close_the_loop(HybridRegressor(science=decay_m, dt=0.3, method="erm", max_iter=400, n_threads=1,
                                         random_state=0), X, y, state_names=["x"], candidates=useless, verbose=False)
    if missing:
        assert res.intervals.verdicts["k"] == "not identified"
        assert "the hybrid fits the data with" in res.intervals.incomplete, res.intervals.report()
    else:
        assert res.added == [] and res.intervals.verdicts["k"] == "identified"
        low, high = res.intervals.intervals["k"]
        assert low <= 0.7 <= high


def _population(seed):
    """Logistic growth with a saturating harvest the science lacks (this test's own system)."""
    rng = np.random.default_rng(seed)
    x0 = rng.uniform(0.3, 7.0, (24, 1))
    t = 0.5 * np.arange(13)
    states = np.stack([solve_ivp(lambda _, v: 0.8 * v * (1 - v / 7.0) - 0.5 * v / (0.8 + v), (0, t[-1]), x,
                                 t_eval=t, rtol=1e-10).y.T for x in x0])
    X = states[:, 0] + 0.02 * rng.standard_normal((24, 1))
    y = states[:, 1:] + 0.02 * rng.standard_normal((24, 12, 1))
    return X, y


def logistic_m(v, r=0.5, K=6.0):
    return r * v * (1 - v / K)


def test_the_loop_says_when_theta_rests_on_the_chosen_form():
    """A harvest with a part linear in x, which the growth rate takes: the loop's answer for r is an
    interval that holds the truth, or a verdict that is not a plain 'identified'."""
    X, y = _population(0)
    res = close_the_loop(HybridRegressor(science=logistic_m, dt=0.5, method="erm", max_iter=300, n_threads=1,
                                         random_state=0), X, y, state_names=["x"], units={"x": "t"}, verbose=False)
    truth = {"r": 0.8, "K": 7.0}
    for name, value in truth.items():
        low, high = res.intervals.intervals[name]
        assert res.intervals.verdicts[name] != "identified" or low <= value <= high, (name, res.intervals.report())
    assert all(set(r) == {"model", "theta", "moved"} for r in res.rivals)
    if any(v == "conditional" for v in res.intervals.verdicts.values()):
        assert "CONDITIONAL" in str(res)


def pushed_particle_m(v, fx=0.5, k=0.2):
    """A particle's velocity (vx, vy) under a constant push fx along x with linear drag k."""
    return torch.stack([fx - k * v[:, 0], -k * v[:, 1]], dim=-1)


def test_the_loop_names_a_drag_along_the_speed_that_a_declared_linear_drag_partly_takes():
    """-0.4 |v| (vx, vy) missing where -k v is declared (this test's own system): on either equation alone the
    term explains little while k, held by the other, keeps standing in for part of the drag there; the loop
    adds the field's two terms, each on its own equation, and k comes back."""
    rng = np.random.default_rng(0)
    t = 0.1 * np.arange(26)

    def rhs(_, v):
        return [0.5 - 0.1 * v[0] - 0.4 * np.hypot(*v) * v[0], -0.1 * v[1] - 0.4 * np.hypot(*v) * v[1]]

    x0 = rng.uniform(-2.0, 2.0, (30, 2))
    states = np.stack([solve_ivp(rhs, (0, t[-1]), x, t_eval=t, rtol=1e-10, atol=1e-10).y.T for x in x0])
    X, y = x0, states[:, 1:] + 0.003 * rng.standard_normal((30, 25, 2))
    res = close_the_loop(HybridRegressor(science=pushed_particle_m, dt=0.1, method="erm", max_iter=300, n_threads=1,
                                         random_state=0), X, y, state_names=["vx", "vy"],
                         units={"vx": "m/s", "vy": "m/s"}, candidates=Candidates(kinds=["norm", "polynomial"]),
                         verbose=False)
    assert {(a["term"], a["component"]) for a in res.added} == {("|(vx, vy)|*vx", 0), ("|(vx, vy)|*vy", 1)}, res
    assert all(abs(a["coef"] + 0.4) < 0.04 for a in res.added), res.added
    assert abs(res.science_theta["k"] - 0.1) < 0.02 and abs(res.science_theta["fx"] - 0.5) < 0.02
    assert any(s["term"] == "|(vx, vy)|*(vx, vy)" and s["accepted"] for s in res.steps)


def test_a_parameter_that_a_terms_mirror_would_absorb_is_conditional():
    """Plasma P and tissue T: a transfer P -> T the science lacks, found as +q P on g[T] only. Its mirror
    -q P on g[P] would be absorbed by the elimination rate k (k + q is all the data see), so k is
    conditional; the tissue's loss e, which no mirror resembles, stays identified; a term on every
    uncertain equation already, or an equation left exact, makes no mirror."""
    from sklearn_hybrid.diagnosis.loop.caveats import mirror_trades
    from sklearn_hybrid.diagnosis.loop.placed import PlacedTerm

    def plasma_tissue(v, k=0.5, e=0.2):
        return torch.stack([-k * v[:, 0], -e * v[:, 1] ** 2], dim=-1)

    def fresh():
        return ScienceIntervals(estimate={"k": 0.9, "e": 0.2}, std={"k": 0.01, "e": 0.01},
                                intervals={"k": (0.88, 0.92), "e": (0.18, 0.22)},
                                verdicts={"k": "identified", "e": "identified"}, level=0.95, n_samples=20)

    states = np.random.default_rng(0).uniform(0.1, 2.0, (200, 2))
    terms = {t.name: t for t in physics_terms(["P", "T"], states, kinds=["polynomial"])}
    on_tissue = PlacedTerm(terms["P"], 1, {}, 0.4)
    ci = fresh()
    why = mirror_trades(ci, plasma_tissue, {"k": 0.9, "e": 0.2, "c_P": 0.4}, [on_tissue], [states], ["P", "T"],
                        [0, 1], ["g[P]", "g[T]"])
    assert list(why) == ["k"] and ci.verdicts == {"k": "conditional", "e": "identified"}
    assert "trades with P on g[P] (added on g[T])" in ci.conditional["k"] and "R^2 1.00" in why["k"]
    assert ci.intervals["k"] == (0.88, 0.92)  # how much acts there, the data cannot say: no range to widen to
    on_both = [on_tissue, PlacedTerm(terms["P"], 0, {}, -0.4)]
    for added, components in [(on_both, [0, 1]), ([on_tissue], [1])]:
        ci = fresh()
        assert mirror_trades(ci, plasma_tissue, {"k": 0.9, "e": 0.2}, added, [states], ["P", "T"], components,
                             ["g[P]", "g[T]"]) == {}
        assert ci.verdicts == {"k": "identified", "e": "identified"}


def test_a_vector_fields_component_has_no_mirror():
    """Drag |v| vx on g[vx] is one component of a field whose other component is |v| vy on g[vy]: its own
    form on g[vy] is no partner, so a rotation w (w vy on g[vx], -w vx on g[vy]), which |v| vy on g[vx]
    and |v| vx on g[vy] would nearly express, stays identified."""
    from sklearn_hybrid.diagnosis.loop.caveats import mirror_trades
    from sklearn_hybrid.diagnosis.loop.placed import PlacedTerm

    def rotation(v, w=0.5):
        return torch.stack([w * v[:, 1], -w * v[:, 0]], dim=-1)

    states = np.random.default_rng(0).uniform(-1.0, 1.0, (200, 2))
    terms = {t.name: t for t in physics_terms(["vx", "vy"], states, kinds=["norm"], units={"vx": "m/s", "vy": "m/s"})}
    ci = ScienceIntervals(estimate={"w": 0.5}, std={"w": 0.01}, intervals={"w": (0.48, 0.52)},
                          verdicts={"w": "identified"}, level=0.95, n_samples=20)
    added = [PlacedTerm(terms["|(vx, vy)|*vx"], 0, {}, -0.3), PlacedTerm(terms["|(vx, vy)|*vy"], 1, {}, -0.3)]
    assert mirror_trades(ci, rotation, {"w": 0.5}, added, [states], ["vx", "vy"], [0, 1], ["g[vx]", "g[vy]"]) == {}
    assert ci.verdicts == {"w": "identified"}


def test_rival_forms_are_weighed_beside_rival_additions():
    """Terms the last step left (judged against the final model, so with lower errors) must not crowd out the
    forms that could have stood in place of a chosen term: MAX_RIVALS of each are refitted."""
    from sklearn_hybrid.diagnosis.loop.caveats import MAX_RIVALS, weigh_rivals
    from sklearn_hybrid.diagnosis.loop.placed import PlacedTerm

    def decay(v, a=1.0):
        return torch.stack([-a * v[:, 0], -v[:, 1]], dim=-1)

    class Refit:  # every refit puts a farther outside its interval
        calls = 0

        def fit(self, model, start, bounds):
            Refit.calls += 1
            return {**start, "a": 10.0 * Refit.calls}

    values = np.random.default_rng(0).uniform(0.1, 2.0, (20, 2))
    terms = {t.name: t for t in physics_terms(["x", "y"], values, kinds=["polynomial"])}
    chosen = PlacedTerm(terms["x^2"], 0, {}, 0.1, param="c_x2", shape_params={})
    more = [n for n in terms if n not in ("x^2", "x")][:MAX_RIVALS + 1]
    # each screening fit puts a outside the interval, however far the refits before have widened it
    rivals = [{"role": "add", "cand": PlacedTerm(terms[n], 0, {}, 0.1), "theta": {"a": 100.0}, "mse": 1.0 + i}
              for i, n in enumerate(more)]
    rivals.append({"role": "instead", "of": [(0, "x^2")], "cand": PlacedTerm(terms["x"], 0, {}, 0.1),
                   "theta": {"a": 100.0}, "mse": 10.0})
    ci = ScienceIntervals(estimate={"a": 1.0}, std={"a": 0.01}, intervals={"a": (0.98, 1.02)},
                          verdicts={"a": "identified"}, level=0.95, n_samples=20)
    out = weigh_rivals(ci, rivals, decay, [chosen], {"a": 1.0, "c_x2": 0.1}, Refit(), ["x", "y"], 2, None)
    assert len(more) == MAX_RIVALS + 1 and Refit.calls == MAX_RIVALS + 1  # the fourth addition is not refitted
    assert [r["model"] for r in out][-1] == "with x instead of x^2"
    assert ci.verdicts["a"] == "conditional" and ci.intervals["a"] == (0.98, 40.0)
