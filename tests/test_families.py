"""Term families (diagnosis/families/): the registry behind physics_terms, a found formula as a term, and the
discovery family inside the closed loop's selection."""

import math
import pickle
import sys

import numpy as np
import pytest
import torch
from scipy.integrate import solve_ivp

from sklearn_hybrid import HybridRegressor, OdeStructure
from sklearn_hybrid.diagnosis import (TERM_FAMILIES, TERM_KINDS, Candidates, Evidence, ScienceFit, SymbolicDiscovery,
                                      TermContext, physics_terms)
from sklearn_hybrid.diagnosis.families.discovery import monomial_forms
from sklearn_hybrid.diagnosis.families.inhibited import inhibited_terms, linear_parts, other_form
from sklearn_hybrid.diagnosis.families.physics import PHASE_DIFFERENCES
from sklearn_hybrid.diagnosis.terms import Term
from sklearn_hybrid.diagnosis.families.symbolic import form_term
from sklearn_hybrid.diagnosis.loop import stepwise


def test_every_kind_but_the_users_is_one_family_and_a_kind_asks_for_its_family_alone():
    assert set(TERM_FAMILIES) == set(TERM_KINDS) - {"user"}
    values = np.random.default_rng(0).uniform(-1, 2, (30, 3))
    setting = {"units": {"a": "rad", "x": "m", "y": "m"}, "scaled": {1: "x"}}  # an angle, a position in the plane
    everything = physics_terms(["a", "x", "y"], values, **setting)
    for kind in TERM_FAMILIES:
        alone = physics_terms(["a", "x", "y"], values, kinds=[kind], **setting)
        assert alone and {t.kind for t in alone} <= {kind, "dry_friction", "drag"}  # sign(x) is dry friction's
        names = [t.name for t in alone]
        assert names == [t.name for t in everything if t.name in set(names)]  # the library's own order


def test_a_formula_becomes_a_textbook_term_with_named_constants_and_its_coefficient():
    # Operon's writing of 1.3 S I / (0.7 + S) with an intercept and the constants spread over the tree
    found = "(0.001853 + (1.002335 * (((0.108849 * X2) / ((0.825395 * X1) - (-0.579630))) * (9.834289 * X1))))"
    term, coef = form_term(found, ["S", "I"], component=1)
    assert term.name == "I*S/(K1 + S)" and term.kind == "discovered"
    assert term.component is None  # a form of the states: on any equation (the flux S and I share)
    (start,), (low, high) = term.shape["K1"]
    assert start == pytest.approx(0.7022, abs=1e-4) and low < start < high and low > 0  # the sign is kept
    d = {"S": torch.tensor([0.5, 2.0], dtype=torch.float64), "I": torch.tensor([1.0, 0.3], dtype=torch.float64)}
    expected = 1.002335 * 0.108849 * 9.834289 * d["S"] * d["I"] * d["S"] / (0.825395 * d["S"] + 0.579630) / d["S"]
    got = coef * term(d, K1=torch.tensor(start, dtype=torch.float64))
    torch.testing.assert_close(got, expected * d["S"] / d["S"])
    again = pickle.loads(pickle.dumps(term))  # an augmented science with it pickles (joblib.dump of a fit)
    torch.testing.assert_close(again(d, K1=torch.tensor(start, dtype=torch.float64)), got / coef)


def test_a_form_of_the_states_is_placed_on_any_equation_and_one_of_the_science_output_on_its_own():
    """A predation found on the prey's residual also feeds the predator: the ranking places it on both
    equations (a group with a coefficient each), where it stayed on the prey's before."""
    from sklearn_hybrid.diagnosis.loop.candidates import rank_by_residual
    from sklearn_hybrid.diagnosis.loop.groups import candidate_groups

    states = np.random.default_rng(0).uniform(0.2, 2.0, (60, 2))
    flux = states[:, 0] * states[:, 1] / (0.5 + states[:, 0])
    learned = np.column_stack([-1.2 * flux, 0.6 * flux])  # half of what the prey loses feeds the predator
    term, _ = form_term("X1 * X2 / (0.5 + X1)", ["x", "y"], component=0)
    values = {v: torch.as_tensor(states[:, i]) for i, v in enumerate(["x", "y"])}
    col = term(values, **{k: torch.tensor(v[0][0]) for k, v in term.shape.items()}).numpy()
    shape = {k: v[0][0] for k, v in term.shape.items()}
    ranked = rank_by_residual([(term, shape, col)], learned, np.zeros((60, 2, 0)), [0, 1], set())
    assert sorted(c.component for c in ranked) == [0, 1]
    assert sorted(round(c.coef / ranked[0].coef, 3) for c in ranked) in ([-0.5, 1.0], [1.0, -2.0])
    assert len(candidate_groups(ranked)) == 1
    reads_f, _ = form_term("X3 * X1", ["x", "y", "f"], component=1, science="f")
    assert reads_f.component == 1  # the science output of its own equation: placed there only


def test_the_part_a_parameter_of_the_science_provides_is_dropped_from_a_formula():
    x = np.linspace(0.05, 4, 50)[:, None]
    directions = np.column_stack([np.ones(50), -x[:, 0]])  # the science a - b x
    # 1.2 / (1 + x^2) - 0.74 + 0.19 x, as Operon wrote it: the constant and the multiple of x are theta's, and
    # of the forms equal up to a constant the one that vanishes at rest is written: -1.2 x^2 / (1 + x^2)
    found = "(1.064359 / (((((-0.941789) * X1) - (-0.941789)) ** 2) - ((-1.773932) * X1))) + (-0.74 + 0.19 * X1)"
    term, coef = form_term(found, ["x"], 0, values=x, directions=directions)
    assert term.name == "x^2/(K1 + x^2)" and coef == pytest.approx(-1.2, rel=1e-5)
    assert term.shape["K1"][0][0] == pytest.approx(1.0)  # a constant that happens to be 1 is still fitted
    assert form_term("(0.5 - 0.2 * X1)", ["x"], 0, values=x, directions=directions) is None  # nothing left


def test_a_direction_s_rest_share_goes_to_its_parameter():
    """A form that is a science direction times a function finite and non-zero at rest loses the direction's
    multiple at rest (the parameter's); a function that vanishes there, or is not finite there, is kept."""
    import sympy

    from sklearn_hybrid.diagnosis.families.symbolic import rest_share_dropped

    S, I = sympy.symbols("S I")
    assert sympy.simplify(rest_share_dropped(S * I / (I + 0.5), S * I, [S, I]) + 2 * S * I ** 2 / (I + 0.5)) == 0
    assert rest_share_dropped(S ** 2 * I, S * I, [S, I]) == S ** 2 * I  # the function S vanishes at rest
    arrhenius = S * I * sympy.exp(-3 / I)
    assert rest_share_dropped(arrhenius, S * I, [S, I]) == arrhenius  # not finite at rest


def test_a_law_that_modifies_a_science_term_is_offered_in_the_variables():
    """The search reads beta's direction S I (of -beta S I) as one variable and finds an incidence that falls as
    cases rise as that direction over 1 + 8 I^2: written in the states, the law's departure from the science term
    is offered (beta keeps its meaning at low prevalence); a direction no product of the states writes still
    gives no form."""
    rng = np.random.default_rng(0)
    states = rng.uniform(0.05, 1.0, (60, 2))  # S, I
    s, i = states.T
    directions = np.column_stack([-s * i, np.sin(s)])
    assert monomial_forms(directions, states, ["S", "I"]) == [(pytest.approx(-1.0), {"S": 1, "I": 1}), None]
    written = {"dtheta1": (-1.0, {"S": 1, "I": 1})}
    values = np.column_stack([states, directions[:, :1]])
    found = "(X3 / (1 + 8 * X2 * X2)) - X3 + 0.3 * X3"  # the law, less beta's own part (theta's)
    term, coef = form_term(found, ["S", "I", "dtheta1"], 1, values=values, directions=directions[:, :1],
                           theta_parts=["dtheta1"], theta_forms=written)
    # -S I/(1 + 8 I^2) less its value at rest times the direction (-S I): 8 S I^3/(1 + 8 I^2)
    assert term.name == "I^3*S/(I^2 + K1)" and term.shape["K1"][0][0] == pytest.approx(1 / 8)
    assert coef == pytest.approx(1.0)
    assert form_term(found, ["S", "I", "dtheta1"], 1, values=values, directions=directions[:, :1],
                     theta_parts=["dtheta1"]) is None
    with pytest.raises(ValueError, match=r"one name per variable; got shapes \(60, 2\), \(60, 2\) and 1 names"):
        monomial_forms(directions, states, ["S"])


def test_a_form_is_marked_where_it_adds_quantities_of_different_units():
    import sympy

    from sklearn_hybrid.diagnosis.families.symbolic import consistent_units

    x, v, K = sympy.symbols("x v K1")
    units = {"x": "m", "v": "m/s"}
    assert consistent_units(x * v / (K + x), units, {"K1"}) is True  # K1 carries metres
    assert consistent_units(x + v, units, set()) is False
    assert consistent_units(sympy.exp(x), units, set()) is False  # the exponent of a length
    assert consistent_units(sympy.exp(K * x) * v, units, {"K1"}) is True
    assert consistent_units(x + v, {"x": "m"}, set()) is None  # v's unit not given: not known
    term, _ = form_term("(0.3 * (X1 + X2))", ["x", "v"], 0, units=units)
    assert term.consistent is False


def _saturation_context(x_unit=1.0, rate_unit=1.0):
    """The law 1.3 x / (0.7 + x) plus what the science's parameters take, x in units of ``x_unit``, the rate in
    ``rate_unit`` (x in mm where it was in m: x_unit = 1e-3)."""
    x = np.linspace(0.05, 3.0, 200)[:, None]
    learned = 1.3 * x / (0.7 + x) + 0.2 - 0.1 * x
    directions = np.stack([np.ones_like(x), -x], axis=-1)  # (points, outputs, parameters)
    return TermContext(("x",), x / x_unit, n_states=1, learned=learned / rate_unit,
                       directions=directions / rate_unit, components=(0,))


def test_symbolic_discovery_offers_the_law_on_what_the_network_learned():
    context = _saturation_context()
    family = SymbolicDiscovery(operators="add,sub,mul,div", max_rounds=2, random_state=0)
    terms = family.terms(context)
    assert terms and all(t.kind == "discovered" and t.component is None for t in terms)
    assert family.fronts_[0]["add,sub,mul,div"] and family.seconds_ > 0
    # the law, up to what the science's parameters take (here a constant and a multiple of x): one offered
    # form, at its starting constants, with its coefficient and the directions explains the residual exactly
    d = {"x": torch.as_tensor(context.values[:, 0])}
    basis = context.directions[:, 0, :]
    misfits = []
    for t in terms:
        col = t(d, **{k: torch.tensor(v[0][0], dtype=torch.float64) for k, v in t.shape.items()}).numpy()
        A = np.column_stack([col, basis])
        rest = context.learned[:, 0] - A @ np.linalg.lstsq(A, context.learned[:, 0], rcond=None)[0]
        misfits.append(np.sqrt(np.mean(rest ** 2)) / np.std(context.learned[:, 0]))
    best = terms[int(np.argmin(misfits))]
    assert min(misfits) < 1e-4 and "/(K1 + x)" in best.name
    assert next(v[0][0] for k, v in best.shape.items() if k == "K1") == pytest.approx(0.7, rel=1e-3)
    assert not any("dtheta" in t.name for t in terms)  # the directions the search read are theta's


@pytest.mark.parametrize("x_unit, rate_unit", [(1e-3, 1.0), (1.0, 1e2), (1e3, 1e-4)])
def test_symbolic_discovery_finds_the_same_forms_in_any_units(x_unit, rate_unit):
    """The search runs in the data's scales: the same law in millimetres or kilometres, per second or per day,
    gives the same forms, their constants in the units given."""
    family = SymbolicDiscovery(operators="add,sub,mul,div", max_rounds=2, random_state=0)
    reference = {t.name: t for t in family.terms(_saturation_context())}
    scaled = {t.name: t for t in family.terms(_saturation_context(x_unit, rate_unit))}
    assert set(scaled) == set(reference) and any("/(K1 + x)" in name for name in reference)
    law = next(name for name in reference if "/(K1 + x)" in name)
    assert scaled[law].shape["K1"][0][0] * x_unit == pytest.approx(reference[law].shape["K1"][0][0], rel=1e-6)


def test_symbolic_discovery_says_how_to_install_its_engine(monkeypatch):
    monkeypatch.setitem(sys.modules, "pyoperon", None)
    monkeypatch.setitem(sys.modules, "pyoperon.sklearn", None)
    with pytest.raises(ImportError, match="pip install pyoperon"):
        SymbolicDiscovery(max_rounds=1).terms(_saturation_context())


def test_discovery_needs_what_the_network_learned_and_a_valid_setting():
    with pytest.raises(ValueError, match="learned"):
        SymbolicDiscovery().terms(TermContext(("x",), np.ones((3, 1)), n_states=1, components=(0,)))
    with pytest.raises(TypeError, match="discovery"):
        Candidates(discovery="yes").check()
    with pytest.raises(ValueError, match="explained"):
        Candidates(explained=0.0).check()
    with pytest.raises(TypeError, match="flows must be True or False"):
        Candidates(flows="no").check()
    for bad in ({"max_rounds": 0}, {"max_forms": 1.5}, {"operators": ()}, {"operators": ("add,sub", 3)}):
        with pytest.raises(ValueError, match="SymbolicDiscovery"):
            SymbolicDiscovery(**bad).terms(_saturation_context())


def decay_f(v, k=0.5):
    return -k * v


def _hill_decay(rng):
    """dA/dt = -0.3 A - 1.0 A^2 / (0.25 + A^2), observed; a hybrid of ``decay_f`` barely trained on it (only its
    layout is used: the selection reads the exact rates as what the network learned, a quick test of the wiring)
    and a selection on them whose term list holds no Hill function."""
    dt, n_steps, n = 0.3, 12, 30
    x0 = rng.uniform(0.2, 2.5, (n, 1))

    def truth(t, a):
        return -0.3 * a - a ** 2 / (0.25 + a ** 2)
    x = np.stack([solve_ivp(truth, (0, dt * n_steps), s, t_eval=dt * np.arange(n_steps + 1), rtol=1e-10,
                            atol=1e-12).y.T for s in x0])
    y = x[:, 1:] + 0.002 * rng.standard_normal(x[:, 1:].shape)
    est = HybridRegressor(science=decay_f, structure=OdeStructure(dt=dt), max_iter=2, random_state=0).fit(x0, y)
    states = x.reshape(-1, 1)
    terms = [t for t in physics_terms(["A"], states) if t.kind in ("polynomial", "saturation")]

    def select(discovery, network=None, **options):
        return stepwise.forward_selection(decay_f, {"k": 0.5}, ScienceFit(est, x0, y), [(np.arange(24),
                                          np.arange(24, 30))], ["A"], 1, [states], truth(0, states), [0],
                                          candidates=Candidates(terms=terms, discovery=discovery,
                                                                **{"max_terms": 2, **options}),
                                          evidence=Evidence(), network=network)
    return truth, states, select


def test_the_loop_names_a_law_outside_the_term_list_with_discovery_and_only_with_it():
    truth, states, select = _hill_decay(np.random.default_rng(0))
    found = select(SymbolicDiscovery(operators="add,sub,mul,div,square", max_rounds=2, random_state=0))
    assert [t.kind for t in found["added"]] == ["discovered"]
    added = found["added"][0]
    augmented = found["science"]
    rates = augmented(torch.as_tensor(states), **{k: torch.tensor(v) for k, v in found["theta"].items()})
    np.testing.assert_allclose(rates.numpy(), truth(0, states), rtol=0, atol=0.01 * np.abs(truth(0, states)).max())
    assert abs(found["theta"]["k"] - 0.3) < 0.015  # theta right, the law's
    assert "A" in added.name and added.component == 0
    without = select(False)
    assert all(t.kind != "discovered" for t in without["added"])


def test_every_discovered_form_is_judged_in_the_ode_whatever_its_rank():
    """The rankings take one candidate each here (n_candidates=1); each form the discovery family offers is still
    refitted in the ODE at the first step, where it explains most: the samples only propose."""
    truth, states, select = _hill_decay(np.random.default_rng(0))

    class Offers:  # a family offering fixed forms (the family protocol: ``terms(context, log)``)
        def terms(self, context, log=lambda message: None):
            return [Term(f"A^{p}", lambda d, p=p: d["A"] ** p, "discovered", {}) for p in (3, 4, 5)]

    found = select(Offers(), n_candidates=1, max_terms=1)
    first = {s.term for s in found["steps"] if s.step == 1}
    assert {"A^3", "A^4", "A^5"} <= first


def test_the_search_runs_only_where_the_networks_part_lowers_the_held_out_error():
    """The search costs most of a loop with discovery: a network whose part, frozen in the science model,
    does not predict the held-out trajectories better than the science refitted alone learned nothing the data
    can confirm, and no form of it is searched for."""
    truth, states, select = _hill_decay(np.random.default_rng(1))
    searched = []

    class Spy:
        def terms(self, context, log=None):
            searched.append(context.components)
            return []

    def missing(v):  # what decay_f at its start (k = 0.5) lacks: an effect the data see
        return torch.as_tensor(truth(0, v.numpy()) + 0.5 * v.numpy())
    select(Spy(), network=missing)
    assert searched == [(0,)]
    select(Spy(), network=lambda v: 0.3 * torch.sin(40 * v))  # a network that predicts worse than none
    assert searched == [(0,)]
    select(Spy())  # no network given: searched wherever the listed terms leave the residual unexplained
    assert searched == [(0,), (0,)]
    # a network that, off its visited states, runs a held-out trajectory off to infinity gives no verdict either
    # way (it is no evidence of noise): searched (ivlev_predation of the second laws batch lost its search so)
    select(Spy(), network=lambda v: torch.where(v > 2.0, torch.full_like(v, float("inf")), 0.5 * v))
    assert searched == [(0,), (0,), (0,)]


def two_decays_f(v, k1=0.5, k2=0.5):
    return torch.stack([-k1 * v[:, 0], -k2 * v[:, 1]], dim=-1)


def test_the_search_skips_an_equation_whose_part_of_the_network_the_held_out_data_do_not_need():
    """The network carries an effect on A and, on B, wiggles the listed terms cannot explain: the whole network
    lowers the held-out error (through A), but its part on B does not count in that, and B is not searched
    (before, the whole network's verdict sent every unexplained equation to the search)."""
    rng = np.random.default_rng(2)
    dt, n_steps, n = 0.3, 12, 30
    x0 = rng.uniform(0.2, 2.5, (n, 2))

    def truth(t, v):
        a, b = v[..., 0], v[..., 1]
        return np.stack([-0.3 * a - a ** 2 / (0.25 + a ** 2), -0.5 * b], axis=-1)
    x = np.stack([solve_ivp(truth, (0, dt * n_steps), s, t_eval=dt * np.arange(n_steps + 1), rtol=1e-10,
                            atol=1e-12).y.T for s in x0])
    y = x[:, 1:] + 0.002 * rng.standard_normal(x[:, 1:].shape)
    est = HybridRegressor(science=two_decays_f, structure=OdeStructure(dt=dt), max_iter=2, random_state=0).fit(x0, y)
    states = x.reshape(-1, 2)
    wiggle = 0.05 * np.sin(40 * states[:, 1])
    learned = truth(0, states) + np.column_stack([np.zeros(len(states)), wiggle])
    terms = [t for t in physics_terms(["A", "B"], states) if t.kind in ("polynomial", "saturation")]
    searched = []

    class Spy:
        def terms(self, context, log=None):
            searched.append(context.components)
            return []

    def network(v):  # what two_decays_f at its start lacks on A, and the wiggle on B
        v = v.numpy()
        return torch.as_tensor(np.column_stack([truth(0, v)[:, 0] + 0.5 * v[:, 0], 0.05 * np.sin(40 * v[:, 1])]))

    def select(network):
        return stepwise.forward_selection(two_decays_f, {"k1": 0.5, "k2": 0.5}, ScienceFit(est, x0, y),
                                          [(np.arange(24), np.arange(24, 30))], ["A", "B"], 2, [states], learned,
                                          [0, 1], candidates=Candidates(terms=terms, discovery=Spy(), max_terms=1),
                                          evidence=Evidence(), network=network)
    select(None)  # no network: both equations the listed terms leave unexplained are searched
    assert searched == [(0, 1)]
    select(network)
    assert searched == [(0, 1), (0,)]


def sirs_f(v, beta=1.5, gamma=0.4):
    """SIR without the waning of immunity: nothing flows back from R to S."""
    s, i = v[:, 0], v[:, 1]
    inc = beta * s * i
    return torch.stack([-inc, inc - gamma * i, gamma * i], dim=-1)


def test_a_flow_between_two_compartments_is_one_term_with_one_coefficient():
    """Waning immunity moves 0.3 R from R back to S: with the flows the loop adds R once, +c on dS and -c on dR
    (one parameter), where without them it needs a coefficient on each equation."""
    from sklearn_hybrid.diagnosis.loop.stages import flow_pairs

    rng = np.random.default_rng(1)
    dt, n_steps, n = 0.4, 12, 30
    x0 = np.column_stack([rng.uniform(0.4, 0.9, n), rng.uniform(0.05, 0.3, n), rng.uniform(0.0, 0.4, n)])

    def truth(t, v):
        s, i, r = v
        return [-1.5 * s * i + 0.3 * r, 1.5 * s * i - 0.4 * i, 0.4 * i - 0.3 * r]
    x = np.stack([solve_ivp(truth, (0, dt * n_steps), s, t_eval=dt * np.arange(n_steps + 1), rtol=1e-10,
                            atol=1e-12).y.T for s in x0])
    y = x[:, 1:] + 0.002 * rng.standard_normal(x[:, 1:].shape)
    est = HybridRegressor(science=sirs_f, dt=dt, max_iter=2, random_state=0).fit(x0, y)
    states = x.reshape(-1, 3)
    learned = np.array([truth(0, v) for v in states])
    terms = [t for t in physics_terms(["S", "I", "R"], states) if t.kind == "polynomial"]
    pairs = flow_pairs([0, 1, 2], ["S", "I", "R"], {"S": "1", "I": "1", "R": "1"})
    assert (0, 2) in pairs and (2, 0) in pairs
    assert flow_pairs([0, 1], ["x", "v"], {"x": "m", "v": "m/s"}) == []  # a position and a speed exchange nothing

    def select(pairs):
        return stepwise.forward_selection(sirs_f, {"beta": 1.2, "gamma": 0.5}, ScienceFit(est, x0, y),
                                          [(np.arange(24), np.arange(24, 30))], ["S", "I", "R"], 3, [states],
                                          learned, [0, 1, 2], candidates=Candidates(terms=terms),
                                          evidence=Evidence(), flow_pairs=pairs)
    found = select(pairs)
    (flow,) = found["added"]
    assert flow.name == "R" and {flow.component, flow.opposite} == {0, 2} and flow.ranked_by == "flow"
    coef = found["theta"][flow.param]
    assert abs(abs(coef) - 0.3) < 0.01 and np.sign(coef) == (1 if flow.component == 0 else -1)
    assert abs(found["theta"]["beta"] - 1.5) < 0.03 and abs(found["theta"]["gamma"] - 0.4) < 0.01
    record = flow.record()
    assert record["opposite"] == flow.opposite and record["component"] == flow.component
    without = select(())
    assert all(t.opposite is None for t in without["added"]) and len(without["added"]) >= 2


def test_a_flow_is_offered_once_per_pair_and_with_a_yield_as_a_group():
    """Each pair's flow once (its two orientations are one model), on the component it enters; and the same
    term on both components with a coefficient each, for a flux whose yield is not one (2 A -> B at 0.5 A^2:
    -1.0 A^2 on A, +0.5 A^2 on B), even where the term ranks among the best on one equation only."""
    from sklearn_hybrid.diagnosis.loop.groups import flow_candidates, flow_groups
    from sklearn_hybrid.diagnosis.loop.placed import PlacedTerm

    square = Term("A^2", lambda d: d["A"] ** 2, "polynomial")
    scored = [PlacedTerm(square, 0, {}, -1.0, 0.6), PlacedTerm(square, 1, {}, 0.5, 0.3)]
    (flow,) = flow_candidates(scored, [(0, 1), (1, 0)], 4)
    assert (flow.component, flow.opposite, flow.gain) == (1, 0, pytest.approx(0.9))
    (group,) = flow_groups([flow], scored)
    assert [(m.component, m.coef) for m in group.members] == [(1, 0.5), (0, -1.0)] and group.gain == flow.gain

    rng = np.random.default_rng(0)
    dt, n_steps, n = 0.25, 12, 40
    x0 = rng.uniform([0.5, 0.0], [2.0, 0.5], size=(n, 2))

    def truth(t, v):
        return [-0.3 * v[0] - v[0] ** 2, 0.3 * v[0] - 0.9 * v[1] + 0.5 * v[0] ** 2]

    def reaction_f(v, k1=0.4, k2=0.7):
        return torch.stack([-k1 * v[:, 0], k1 * v[:, 0] - k2 * v[:, 1]], dim=-1)
    x = np.stack([solve_ivp(truth, (0, dt * n_steps), s, t_eval=dt * np.arange(n_steps + 1), rtol=1e-8,
                            atol=1e-10).y.T for s in x0])
    y = x[:, 1:] + 0.01 * rng.standard_normal(x[:, 1:].shape)
    est = HybridRegressor(science=reaction_f, structure=OdeStructure(dt=dt), method="erm", max_iter=2,
                          random_state=0).fit(x0, y)
    states = x.reshape(-1, 2)
    learned = np.array([truth(0, v) for v in states])
    terms = [t for t in physics_terms(["A", "B"], states) if t.kind == "polynomial"]
    found = stepwise.forward_selection(reaction_f, {"k1": 0.4, "k2": 0.7}, ScienceFit(est, x0, y),
                                       [(np.arange(n - 12), np.arange(n - 12, n))], ["A", "B"], 2, [states],
                                       learned, [0, 1], candidates=Candidates(terms=terms, n_candidates=1),
                                       evidence=Evidence(second_look=None), flow_pairs=[(0, 1), (1, 0)])
    coefs = {t.key: t.coef for t in found["added"]}
    assert coefs == {(0, "A^2"): pytest.approx(-1.0, rel=0.05), (1, "A^2"): pytest.approx(0.5, rel=0.05)}
    flows = [s for s in found["steps"] if s.ranked_by == "flow"]
    assert flows and all(s.component == [1, 0] for s in flows if s.term == "A^2")  # one orientation


def test_a_term_function_pickled_before_the_families_still_loads():
    """A fitted model saved before the kinds became families names their functions by their old private names."""
    from sklearn_hybrid.diagnosis import terms

    old = pickle.dumps(terms.saturation_term, protocol=0).replace(b"saturation_term", b"_saturation")
    assert pickle.loads(old) is terms.saturation_term


def test_reduced_forms_set_each_constant_to_zero_and_skip_what_leaves_no_variable():
    from sklearn_hybrid.diagnosis.families.symbolic import form_term, reduced_forms

    term, _ = form_term("X2*(X1 + 0.3*X2)/(X1 + 0.7*X2)", ["x", "y"], 0)
    reduced = {r.name: r for r in reduced_forms(term)}
    assert set(reduced) == {"x*y/(K1*y + x)", "(K2*y^2 + x*y)/x"}
    law = reduced["x*y/(K1*y + x)"]
    assert law.shape == {"K1": term.shape["K1"]} and law.kind == "discovered" and law.component is None
    d = {"x": torch.tensor([1.0, 2.0]), "y": torch.tensor([0.5, 1.0])}
    assert torch.allclose(law(d, K1=torch.tensor(0.7)), d["x"] * d["y"] / (d["x"] + 0.7 * d["y"]))
    saturation, _ = form_term("X1/(0.5 + X1)", ["x"], 0)
    assert reduced_forms(saturation) == []  # x/x is a constant: the library's own term
    assert reduced_forms(Term("x^2", lambda d: d["x"] ** 2, "polynomial")) == []  # not a discovered form


def test_a_form_with_a_function_of_numbers_evaluates_and_its_reduced_form_drops_the_number():
    # bug: x exp(-exp(K1 y)) with K1 set to zero left exp(-1), and torch.exp(-1) raised a TypeError that
    # stopped the whole loop (found on a laws batch's Crowley-Martin predation)
    import sympy

    from sklearn_hybrid.diagnosis.families.symbolic import SymbolicForm, form_term, reduced_forms

    d = {"x": torch.tensor([1.0, 2.0]), "y": torch.tensor([0.5, 1.0])}
    x, y = sympy.symbols("x y")
    numbers = SymbolicForm(sympy.srepr(x * sympy.exp(-1) + sympy.sqrt(2) * sympy.log(3) * y), {"x": "x", "y": "y"}, ())
    assert torch.allclose(numbers(d), d["x"] * math.exp(-1) + math.sqrt(2) * math.log(3) * d["y"])
    term, _ = form_term("X2*exp(-exp(-1.5*X2))*log(0.8*X1)", ["x", "y"], 0)
    reduced = {r.name: r for r in reduced_forms(term)}
    form = next(r for name, r in reduced.items() if "exp" not in name)
    assert form.name == "y*log(K2*x)"  # the factor exp(-1) goes to the term's coefficient
    assert torch.allclose(form(d, K2=torch.tensor(0.8)), d["y"] * torch.log(0.8 * d["x"]))


def test_a_form_is_offered_also_with_the_parts_a_parameter_provides():
    """Holling III on the predator's equation, 0.6 x^2 y/(0.64 + x^2) = 0.6 y - 0.384 y/(0.64 + x^2), beside the
    science's -m y: without the part in m's direction the search's form is y/(K + x^2), which on the prey's
    equation lacks the law's y; whole (here with theta's error in m's direction too), it is
    y (K + x^2)/(K + x^2) with two constants, the first of which the loop may drop."""
    rng = np.random.default_rng(0)
    X = rng.uniform(0.2, 2.0, (200, 2))
    directions = -X[:, 1:2]  # -m y's direction
    formula = "0.9*X2 - 0.384*X2/(0.64 + X1**2)"  # 0.6 y of the law, 0.3 y of m's error
    dropped, _ = form_term(formula, ["x", "y"], 1, values=X, directions=directions)
    whole, _ = form_term(formula, ["x", "y"], 1, values=X, directions=directions, keep_parameter_parts=True)
    assert dropped.name == "y/(K1 + x^2)" and whole.name == "y*(K2 + x^2)/(K1 + x^2)", whole.name
    assert whole.shape["K2"][0] == [pytest.approx(0.192 / 0.9)] and whole.shape["K1"][0] == [pytest.approx(0.64)]
    constant, _ = form_term("2.5 + X2/(0.64 + X1**2)", ["x", "y"], 1, values=X, directions=directions,
                            keep_parameter_parts=True)
    assert constant.name == "y/(K1 + x^2)"  # a constant is the library's term, kept or not

    search = SymbolicDiscovery(max_forms=1)
    front = [{"formula": formula, "length": 9, "mse": 1e-4}]
    offered = search._offered(front, ["x", "y"], 1, X, directions, 1.0, {}, np.ones(2))
    assert [t.name for t in offered] == ["y/(K1 + x^2)", "y*(K2 + x^2)/(K1 + x^2)"]


def _inhibited_decay(rng, law=lambda a: -0.8 * a / (1 + (a / 0.5) ** 2), scale=1.0):
    """dA/dt = law(A), by default -0.8 A / (1 + (A/0.5)^2): the science's decay -k A, slowed down as A grows (the
    law keeps k as the rate at rest); the selection reads the exact rates as what the network learned, as in
    ``_hill_decay``. ``scale``: A in other units (its starting values times it)."""
    dt, n_steps, n = 0.3, 12, 30
    x0 = rng.uniform(0.2, 2.5, (n, 1)) * scale

    def truth(t, a):
        return law(a)
    x = np.stack([solve_ivp(truth, (0, dt * n_steps), s, t_eval=dt * np.arange(n_steps + 1), rtol=1e-10,
                            atol=1e-12).y.T for s in x0])
    y = x[:, 1:] + 0.002 * scale * rng.standard_normal(x[:, 1:].shape)
    est = HybridRegressor(science=decay_f, structure=OdeStructure(dt=dt), max_iter=2, random_state=0).fit(x0, y)
    states = x.reshape(-1, 1)
    terms = [t for t in physics_terms(["A"], states) if t.kind in ("polynomial", "saturation")]

    class Nothing:  # a discovery family that offers no form: only the science's inhibited terms are added
        def terms(self, context, log=lambda message: None):
            return []

    def select(discovery):
        return stepwise.forward_selection(decay_f, {"k": 0.5}, ScienceFit(est, x0, y), [(np.arange(24),
                                          np.arange(24, 30))], ["A"], 1, [states], truth(0, states), [0],
                                          candidates=Candidates(terms=terms, discovery=discovery and Nothing(),
                                                                max_terms=2), evidence=Evidence())
    return truth, states, select, ScienceFit(est, x0, y)


@pytest.mark.parametrize("scale", [1.0, 1e-3])
def test_the_loop_names_a_science_term_slowed_down_by_a_state_with_the_science_parameter_kept(scale):
    """Also with A in units a thousand times larger: K's starting grid and bounds follow A's scale."""
    truth, states, select, _ = _inhibited_decay(np.random.default_rng(0),
                                                lambda a: -0.8 * a / (1 + (a / (0.5 * scale)) ** 2), scale)
    found = select(True)
    assert [t.kind for t in found["added"]] == ["inhibited"]
    added, theta = found["added"][0], found["theta"]
    assert added.name == "[k-term of A]*A^2/(K^2 + A^2)"
    shape = {local: theta[name] for local, name in added.shape_params.items()}
    assert abs(theta[added.param] + 1) < 0.02 and abs(shape["K"] / scale - 0.5) < 0.02  # -1: k A / (1 + (A/K)^2)
    assert abs(theta["k"] - 0.8) < 0.02  # the science's k keeps its meaning
    rates = found["science"](torch.as_tensor(states), **{k: torch.tensor(v) for k, v in theta.items()})
    np.testing.assert_allclose(rates.numpy(), truth(0, states), rtol=0, atol=0.01 * np.abs(truth(0, states)).max())
    assert pickle.loads(pickle.dumps(found["science"])).equation == found["science"].equation
    assert all(t.kind != "inhibited" for t in select(False)["added"])


def test_a_parameter_s_part_is_offered_where_the_science_is_linear_in_it_and_once_per_proportional_group():
    def predation_f(v, r=1.0, K=3.0, a=0.8, m=0.4):
        x, y = v[:, 0], v[:, 1]
        return torch.stack([r * x * (1 - x / K) - a * x * y, 0.5 * a * x * y - m * y], dim=-1)

    values = np.random.default_rng(0).uniform(0.2, 2.0, (50, 2))
    theta = {"r": 1.0, "K": 3.0, "a": 0.8, "m": 0.4}
    parts = linear_parts(predation_f, theta, [values])
    assert sorted(parts) == ["a", "m", "r"]  # K is not linear: f(K = 0) is no part of f
    np.testing.assert_allclose(parts["a"][:, 1], 0.4 * values[:, 0] * values[:, 1])
    terms = inhibited_terms(parts, ["x", "y"], values, [0, 1])
    # a's part is proportional on both equations (a flow with a yield): one term, read on x's equation
    assert sorted({t.name.split("]")[0] + "]" for t in terms}) == ["[a-term of x]", "[m-term of y]", "[r-term of x]"]
    # each slowed down or limited by each state, n one or two, or scaled by exp or (both states positive) a power
    assert len(terms) == 3 * 2 * 6
    assert inhibited_terms(parts, ["x", "y"], values, [1]) and not any(
        "r-term" in t.name for t in inhibited_terms(parts, ["x", "y"], values, [1]))
    # a part on one equation is offered on that equation only, one on several (a flow) on any
    assert {t.component for t in terms if "m-term" in t.name} == {1}
    assert {t.component for t in terms if "a-term" in t.name} == {None}


def test_a_science_term_limited_by_a_state_is_named_with_its_rate_at_saturation():
    """dA/dt = -0.8 A * A/(0.5 + A): the science's decay -k A acting only as A saturates; the slowed-down form
    reaches this only as k goes to zero, the limited one at coefficient -1 with k the rate at saturation."""
    truth, states, select, _ = _inhibited_decay(np.random.default_rng(0), lambda a: -0.8 * a * a / (0.5 + a))
    found = select(True)
    assert [t.kind for t in found["added"]] == ["inhibited"]
    added, theta = found["added"][0], found["theta"]
    assert added.name == "[k-term of A]*K/(K + |A|)"
    shape = {local: theta[name] for local, name in added.shape_params.items()}
    assert abs(theta[added.param] + 1) < 0.02 and abs(shape["K"] - 0.5) < 0.02
    assert abs(theta["k"] - 0.8) < 0.02


@pytest.mark.parametrize("law, start, expected", [
    # the slowed-down law -0.8 A / (1 + (A/0.5)^2) reached through the limited form, at its degenerate end
    (lambda a: -0.8 * a / (1 + (a / 0.5) ** 2), {"k": 0.008, "c": 100.0}, {"k": 0.8, "c": -1.0}),
    # a growth back up beside a decay, -0.3 A + 1.2 A^3/(0.25 + A^2): slowed down, k the decay at rest
    (lambda a: -0.3 * a + 1.2 * a ** 3 / (0.25 + a ** 2), {"k": -0.9, "c": -4 / 3}, {"k": 0.3, "c": -4.0})])
def test_an_inhibited_term_is_written_slowed_down_unless_the_limited_form_is_the_law(law, start, expected):
    """The same model in the other form: the science's k at rest (the slowed form), and the coefficient there;
    a rival of the term follows it."""
    from sklearn_hybrid.diagnosis.judge import Judge
    from sklearn_hybrid.diagnosis.loop.candidates import augment_with, shape_bounds
    from sklearn_hybrid.diagnosis.loop.collapse import canonical_inhibited
    from sklearn_hybrid.diagnosis.loop.placed import PlacedTerm

    _, states, _, fit = _inhibited_decay(np.random.default_rng(0), law)
    judge = Judge(fit, [(np.arange(24), np.arange(24, 30))], None)
    parts = linear_parts(decay_f, {"k": 0.5}, [states])
    limited = next(t for t in inhibited_terms(parts, ["A"], states, [0]) if t.name == "[k-term of A]*K^2/(K^2 + A^2)")
    placed = [PlacedTerm(limited, 0, {"K": 0.5}, coef=start["c"])]
    model = augment_with(decay_f, placed, ["A"], 1, None)
    theta = judge.fit(model, {"k": start["k"], model.terms[0][2]: start["c"],
                              **{g: 0.5 for g in model.shape_names[0].values()}}, shape_bounds(model, placed))
    added = [placed[0].with_fitted(model, theta, 0)]
    assert abs(theta["k"] - start["k"]) < 0.05 + 0.1 * abs(start["k"])  # the law in the limited form
    steps = []
    _, kept, fitted, _, renamed = canonical_inhibited(decay_f, model, added, theta, judge.errors(model, theta), judge,
                                                      ["A"], 1, None, steps, lambda m: None, evidence=Evidence(),
                                                      values=states)
    assert [t.name for t in kept] == ["[k-term of A]*A^2/(K^2 + A^2)"]
    assert abs(fitted["k"] - expected["k"]) < 0.01 and abs(kept[0].coef - expected["c"]) < 0.05
    assert abs(kept[0].shape["K"] - 0.5) < 0.01
    assert renamed == {added[0].key: kept[0].key} and steps[-1].accepted


def test_a_limited_reading_needs_its_saturation_among_the_visited_states():
    """A term written limited at the law's coefficient, but with K far beyond every visited |A|: there the factor
    is a power of A, not a saturation, and the term is written slowed down."""
    from sklearn_hybrid.diagnosis.loop.candidates import augment_with
    from sklearn_hybrid.diagnosis.loop.collapse import canonical_inhibited
    from sklearn_hybrid.diagnosis.judge import Judge
    from sklearn_hybrid.diagnosis.loop.placed import PlacedTerm

    _, states, _, fit = _inhibited_decay(np.random.default_rng(0))
    judge = Judge(fit, [(np.arange(24), np.arange(24, 30))], None)
    limited = next(t for t in inhibited_terms(linear_parts(decay_f, {"k": 0.5}, [states]), ["A"], states, [0])
                   if t.name == "[k-term of A]*K^2/(K^2 + A^2)")
    placed = [PlacedTerm(limited, 0, {"K": 30.0}, coef=-0.95)]
    model = augment_with(decay_f, placed, ["A"], 1, None)
    theta = {"k": 20.0, model.terms[0][2]: -0.95, **{g: 30.0 for g in model.shape_names[0].values()}}
    added = [placed[0].with_fitted(model, theta, 0)]
    for values, written in ((states, "[k-term of A]*A^2/(K^2 + A^2)"), (100 * states, limited.name)):
        _, kept, *_ = canonical_inhibited(decay_f, model, added, theta, judge.errors(model, theta), judge, ["A"], 1,
                                          None, [], lambda m: None, evidence=Evidence(min_gain=10.0), values=values)
        assert [t.name for t in kept] == [written]


def test_the_other_form_of_an_inhibited_term_and_a_clear_error_for_any_other_term():
    values = np.random.default_rng(0).uniform(0.2, 2.0, (20, 1))
    slowed = inhibited_terms(linear_parts(decay_f, {"k": 0.5}, [values]), ["A"], values, [0])[0]
    assert other_form(slowed).name == "[k-term of A]*K/(K + |A|)" and other_form(other_form(slowed)).name == slowed.name
    with pytest.raises(ValueError, match="other_form needs a term of inhibited_terms"):
        other_form(physics_terms(["A"], values)[1])


def free_phases_f(v, w1=1.0, w2=1.6):
    return torch.stack([w1 + 0 * v[:, 0], w2 + 0 * v[:, 1]], dim=-1)


def test_the_harmonic_of_a_difference_of_two_angles_is_offered_for_angles_only():
    values = np.random.default_rng(0).uniform(0, 6, (20, 3))
    context = TermContext(("a", "b", "c"), values, {"a": "rad", "b": "deg", "c": "m"}, 3)
    term, linear = PHASE_DIFFERENCES.terms(context)  # a length pairs with nothing
    assert term.name == "sin(0.0174533*b - a + phase)" and term.kind == "periodic"
    assert linear.name == "0.0174533*b - a" and linear.shape == {}
    d = {name: torch.as_tensor(values[:, i]) for i, name in enumerate("abc")}
    expected = np.sin(np.radians(values[:, 1]) - values[:, 0] + 0.3)
    np.testing.assert_allclose(term.func(d, phase=0.3).numpy(), expected, atol=1e-12)
    (without,) = term.reductions  # the coupling without a phase, tried once the term is accepted
    assert without.name == "sin(0.0174533*b - a)" and without.shape == {}
    np.testing.assert_allclose(without.func(d).numpy(), np.sin(np.radians(values[:, 1]) - values[:, 0]), atol=1e-12)
    np.testing.assert_allclose(linear.func(d).numpy(), np.radians(values[:, 1]) - values[:, 0], atol=1e-12)
    assert PHASE_DIFFERENCES.terms(TermContext(("a", "b"), values[:, :2], {"a": "rad"}, 2)) == []


@pytest.mark.parametrize("pull, law", [(np.sin, "sin(q - p)"), (lambda a: a, "q - p")])
def test_two_phases_that_pull_on_each_other_are_named_as_one_coupling_with_discovery_only(pull, law):
    """d theta1/dt = 1 + 0.35 sin(theta2 - theta1), d theta2/dt = 1.6 - 0.35 sin(theta2 - theta1): no harmonic of
    one angle makes the coupling; with discovery the difference's harmonic is a flow between the two phases. And
    where the pull is linear in the difference (a spring between them), the plain difference, not the sine."""
    rng = np.random.default_rng(0)
    dt, n_steps, n = 0.2, 15, 30
    x0 = rng.uniform(0, 6.28, (n, 2))

    def truth(t, v):
        pull_now = 0.35 * pull(v[..., 1] - v[..., 0])
        return np.stack([1.0 + pull_now, 1.6 - pull_now], axis=-1)
    x = np.stack([solve_ivp(truth, (0, dt * n_steps), s, t_eval=dt * np.arange(n_steps + 1), rtol=1e-10,
                            atol=1e-12).y.T for s in x0])
    y = x[:, 1:] + 0.002 * rng.standard_normal(x[:, 1:].shape)
    est = HybridRegressor(science=free_phases_f, structure=OdeStructure(dt=dt), max_iter=2, random_state=0).fit(x0, y)
    states = x.reshape(-1, 2)
    terms = [t for t in physics_terms(["p", "q"], states) if t.kind == "polynomial"]

    class Nothing:
        def terms(self, context, log=lambda message: None):
            return []

    def select(discovery):
        return stepwise.forward_selection(
            free_phases_f, {"w1": 1.0, "w2": 1.0}, ScienceFit(est, x0, y), [(np.arange(24), np.arange(24, 30))],
            ["p", "q"], 2, [states], truth(0, states), [0, 1], flow_pairs=[(0, 1)], units={"p": "rad", "q": "rad"},
            candidates=Candidates(terms=terms, discovery=discovery and Nothing(), max_terms=2), evidence=Evidence())
    found = select(True)
    (added,) = found["added"]
    # a flow, without the phase the coupling lacks (the term offered with it, tried without it once accepted)
    assert added.name == law and {added.component, added.opposite} == {0, 1}
    assert law == "q - p" or any(s.step == "simplify" and s.term == "sin(q - p)" for s in found["steps"])
    theta = found["theta"]
    assert abs(theta["w1"] - 1.0) < 0.01 and abs(theta["w2"] - 1.6) < 0.01
    rates = found["science"](torch.as_tensor(states), **{k: torch.tensor(v) for k, v in theta.items()})
    np.testing.assert_allclose(rates.numpy(), truth(0, states), rtol=0, atol=0.01)
    assert all(t.name not in ("sin(q - p)", "q - p") for t in select(False)["added"])


def test_a_science_term_slowed_down_and_limited_take_one_place_in_the_ranking():
    """The two forms of one inhibited term are one model once theta is refitted: both are screened, in one of the
    ranking's places, so the next model (here the exponential factor) is screened too. A flux's factor comes with
    its placements on the flux's other equations (screened as a group)."""
    from sklearn_hybrid.diagnosis.loop.candidates import first_models
    from sklearn_hybrid.diagnosis.loop.placed import PlacedTerm
    values = np.random.default_rng(0).uniform(0.2, 2.0, (50, 1))
    terms = inhibited_terms({"k": values.copy()}, ["A"], values, [0])
    by_name = {t.name: t for t in terms}
    names = ["[k-term of A]*A^2/(K^2 + A^2)", "[k-term of A]*K^2/(K^2 + A^2)", "[k-term of A]*(|A|^p - 1)",
             "[k-term of A]*(exp(k*A) - 1)"]
    ranked = [PlacedTerm(by_name[n], 0, {}, 0.0, 0.9 - 0.01 * i) for i, n in enumerate(names)]
    assert [t.name for t in first_models(ranked, 2)] == names[:3]
    assert [t.name for t in first_models(ranked, 3)] == names
    # a flux's term (its part proportional on two equations) comes with its placement on the other equation
    flux = inhibited_terms({"k": np.column_stack([-values[:, 0], 0.5 * values[:, 0]])}, ["A"], values, [0, 1])
    power = next(t for t in flux if t.name == "[k-term of A]*(|A|^p - 1)")
    square = next(t for t in flux if t.name == "[k-term of A]*A^2/(K^2 + A^2)")
    ranked = [PlacedTerm(power, 0, {}, 0.0, 0.9), PlacedTerm(square, 0, {}, 0.0, 0.8),
              PlacedTerm(square, 1, {}, 0.0, 0.2), PlacedTerm(power, 1, {}, 0.0, 0.1)]
    assert [(t.name, t.component) for t in first_models(ranked, 1)] == [(power.name, 0), (power.name, 1)]


def test_a_science_term_scaled_by_a_power_of_a_state_is_named_with_its_rate_at_one():
    """dA/dt = -0.3 A^2.5: the science's first-order decay -k A is of order 2.5 (the rate k A times A^1.5); the law
    is the part times |A|^p - 1 at coefficient 1, p 1.5, the science's k kept as the rate at A = 1."""
    truth, states, select, _ = _inhibited_decay(np.random.default_rng(0), lambda a: -0.3 * np.abs(a) ** 2.5)
    found = select(True)
    (added,) = found["added"]
    theta = found["theta"]
    assert added.kind == "modulated" and added.name == "[k-term of A]*(|A|^p - 1)"
    assert abs(theta[added.param] - 1) < 0.02 and abs(theta[added.shape_params["p"]] - 1.5) < 0.02
    assert abs(theta["k"] - 0.3) < 0.01
    rates = found["science"](torch.as_tensor(states), **{k: torch.tensor(v) for k, v in theta.items()})
    np.testing.assert_allclose(rates.numpy(), truth(0, states), rtol=0, atol=0.01 * np.abs(truth(0, states)).max())
    assert pickle.loads(pickle.dumps(found["science"])).equation == found["science"].equation


def test_a_power_of_a_variable_is_offered_only_where_it_keeps_one_sign():
    """|x|^p of a variable that changes sign is no law of it: the science's term is offered scaled by a power of
    the positive state and the input of one sign, not of the state that crosses zero."""
    rng = np.random.default_rng(0)
    values = np.column_stack([rng.uniform(0.1, 2.0, 200), rng.uniform(-1.0, 1.0, 200), rng.uniform(-3.0, -0.5, 200)])
    values[:1, 0] = -1e-3  # a reading dipping below zero does not make a concentration change sign
    part = np.column_stack([values[:, 0], np.zeros(200)])
    names = [t.name for t in inhibited_terms({"k": part}, ["A", "v", "u"], values, [0, 1])]
    assert {n for n in names if "^p" in n} == {"[k-term of A]*(|A|^p - 1)", "[k-term of A]*(|u|^p - 1)"}
    assert "[k-term of A]*(exp(k*v) - 1)" in names


@pytest.mark.parametrize("scale", [1.0, 1e3])
def test_a_science_term_scaled_exponentially_by_a_state_is_named_with_its_rate_at_zero(scale):
    """dA/dt = -0.8 A exp(-A/0.8): the science's decay -k A scaled down as A grows (Aiba's product inhibition has
    this form); the law is the part times exp(k x) - 1 at coefficient 1, k -1/0.8, the science's k kept; the
    same with A in units a thousand times smaller (k's starting grid and bounds follow A's scale)."""
    truth, states, select, _ = _inhibited_decay(np.random.default_rng(0),
                                                lambda a: -0.8 * a * np.exp(-a / (0.8 * scale)), scale)
    found = select(True)
    (added,) = found["added"]
    theta = found["theta"]
    assert added.kind == "modulated" and added.name == "[k-term of A]*(exp(k*A) - 1)"
    assert abs(theta[added.param] - 1) < 0.02 and abs(theta[added.shape_params["k"]] * scale + 1 / 0.8) < 0.02
    assert abs(theta["k"] - 0.8) < 0.02
    rates = found["science"](torch.as_tensor(states), **{k: torch.tensor(v) for k, v in theta.items()})
    np.testing.assert_allclose(rates.numpy(), truth(0, states), rtol=0, atol=0.01 * np.abs(truth(0, states)).max())
    assert pickle.loads(pickle.dumps(found["science"])).equation == found["science"].equation
