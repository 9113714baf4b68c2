"""Update rules of the training methods against hand computations on a tiny model."""

import copy
from dataclasses import dataclass

import numpy as np
import pytest
import torch
from torch import nn

from sklearn_hybrid.training.engine import train
from sklearn_hybrid.training.schedule import THETA_LR_FACTOR, TrainConfig
from sklearn_hybrid.methods import (METHODS, SAM, FisherSAM, Method, asam_perturbation, fsam_perturbation,
                                    make_method, sam_perturbation)
from sklearn_hybrid.science import ScienceModel
from sklearn_hybrid.structures import HybridModule, make_structure


def _grads():
    g = [torch.tensor([[0.3, -1.2], [2.0, 0.1]]), torch.tensor([0.5, -0.4])]
    p = [torch.tensor([[1.0, -2.0], [0.5, 0.0]]), torch.tensor([0.1, 0.2])]
    return p, g


def _flat(ts):
    return torch.cat([t.reshape(-1) for t in ts])


def test_sam_formula():
    _, g = _grads()
    eps = sam_perturbation(g, 0.1)
    flat = _flat(g)
    torch.testing.assert_close(_flat(eps), 0.1 * flat / flat.norm())
    assert torch.isclose(_flat(eps).norm(), torch.tensor(0.1))


def test_asam_formula_weights_scaled_biases_not():
    p, g = _grads()
    eps = asam_perturbation(p, g, 0.5, 0.01, [True, False])
    t = [p[0].abs() + 0.01, torch.ones_like(p[1])]
    norm = _flat([ti * gi for ti, gi in zip(t, g)]).norm()
    expected = [ti * ti * gi * 0.5 / norm for ti, gi in zip(t, g)]
    torch.testing.assert_close(_flat(eps), _flat(expected))


def test_fsam_formula_and_fisher_ball():
    _, g = _grads()
    rho, eta = 0.2, 1.0
    eps = fsam_perturbation(g, rho, eta)
    flat = _flat(g)
    fisher = 1 + eta * flat**2
    expected = rho * (flat / fisher) / torch.sqrt((flat**2 / fisher).sum())
    torch.testing.assert_close(_flat(eps), expected)
    # the perturbation lies on the boundary of the Fisher ball: eps^T F eps = rho^2
    assert torch.isclose((_flat(eps) ** 2 * fisher).sum(), torch.tensor(rho**2))


@pytest.mark.parametrize("rule", ["sam", "asam", "fsam"])
def test_batched_rules_equal_per_member(rule):
    torch.manual_seed(0)
    params = [torch.randn(3, 4, 2), torch.randn(3, 4)]
    grads = [torch.randn(3, 4, 2), torch.randn(3, 4)]
    rho = torch.tensor([0.01, 0.1, 1.0])

    def apply(p, g, r, n):
        if rule == "sam":
            return sam_perturbation(g, r, n_batch_dims=n)
        if rule == "asam":
            return asam_perturbation(p, g, r, 0.01, [True, False], n_batch_dims=n)
        return fsam_perturbation(g, r, 1.0, n_batch_dims=n)

    batched = apply(params, grads, rho, 1)
    for k in range(3):
        single = apply([t[k] for t in params], [t[k] for t in grads], float(rho[k]), 0)
        for b, s in zip(batched, single):
            torch.testing.assert_close(b[k], s)


def _science(x, a=0.7):
    return a * x


def _tiny_model(record):
    """y = a*x + g(x), with a callable structure that records parameters at each call."""
    science = ScienceModel(_science, dtype=torch.float64)
    torch.manual_seed(1)
    residual = nn.Sequential(nn.Linear(1, 3), nn.Tanh(), nn.Linear(3, 1)).double()

    def structure(x, f, g):
        record.append((f.values()["a"].detach().clone(),
                       [p.detach().clone() for p in g.parameters()]))
        return f(x) + g(x)

    s = make_structure(structure)
    s.setup(np.zeros((4, 1)), (1,))
    return HybridModule(science, residual, s)


def _data():
    x = torch.linspace(-1, 1, 8, dtype=torch.float64)[:, None]
    return x, 1.3 * x + torch.sin(3 * x)


@pytest.mark.parametrize("name", ["sam", "asam", "fsam"])
@pytest.mark.parametrize("perturb", ["residual", "all"])
def test_one_sam_step_matches_hand_computation(name, perturb):
    record = []
    model = _tiny_model(record)
    reference = copy.deepcopy(model)
    x, y = _data()
    method = make_method(name, rho=0.3)
    config = TrainConfig(lr=1e-2, max_iter=1, weight_decay=0.0, perturb=perturb)
    train(model, method, (x,), y, config, torch.Generator().manual_seed(0))

    # by hand: gradient at the start, perturbation of phi (and theta for "all")
    theta = [reference.science.raw["a"]]
    phi = list(reference.residual.parameters())
    perturbed = phi + theta if perturb == "all" else phi
    loss = ((reference(x)[0] - y) ** 2).mean()
    var = float(y.var(unbiased=False))  # the gradients are taken in units of the data's spread (run_steps)
    grads = [g / var for g in torch.autograd.grad(loss, perturbed)]
    is_weight = ["weight" in n for n, _ in reference.residual.named_parameters()] + [False]
    eps = method.perturbation(perturbed, list(grads), is_weight[: len(perturbed)])

    start_a, start_phi = record[0]
    pert_a, pert_phi = record[1]
    for p0, p1, e in zip(start_phi, pert_phi, eps):
        torch.testing.assert_close(p1, p0 + e)
    if perturb == "residual":
        assert torch.equal(pert_a, start_a)  # theta untouched by the perturbation
    else:
        assert not torch.equal(pert_a, start_a)

    # gradient of theta and phi at the perturbed point, then one Adam step from the start
    saved = [p.detach().clone() for p in perturbed]
    with torch.no_grad():
        for p, e in zip(perturbed, eps):
            p.add_(e)
    loss_pert = ((reference(x)[0] - y) ** 2).mean()
    all_params = theta + phi
    g_pert = torch.autograd.grad(loss_pert, all_params)
    with torch.no_grad():
        for p, s in zip(perturbed, saved):
            p.copy_(s)
    g_start = torch.autograd.grad(((reference(x)[0] - y) ** 2).mean(), all_params)
    assert any(not torch.allclose(a, b) for a, b in zip(g_pert, g_start))  # the rule matters
    opt = torch.optim.Adam([{"params": theta, "lr": THETA_LR_FACTOR * 1e-2}, {"params": phi}], lr=1e-2)
    for p, g in zip(all_params, g_pert):
        p.grad = g / var
    opt.step()
    for got, want in zip(model.parameters(), reference.parameters()):
        torch.testing.assert_close(got, want, rtol=0, atol=1e-12)


def test_phi_restored_exactly_before_the_step():
    """With a perturbation whose removal by subtraction would round, restore is exact."""
    record = []
    model = _tiny_model(record)
    x, y = _data()

    class HugeSAM(type(make_method("sam"))):
        pass

    method = HugeSAM(rho=1e6)  # eps large: p + eps - eps != p in floating point
    train(model, method, (x,), y, TrainConfig(lr=1e-30, max_iter=2, weight_decay=0.0),
          torch.Generator().manual_seed(0))
    start_phi, third_phi = record[0][1], record[2][1]
    # the third call starts iteration 2: parameters differ from the start only by a 1e-30 Adam step
    for p0, p2 in zip(start_phi, third_phi):
        torch.testing.assert_close(p2, p0, rtol=0, atol=1e-25)


def test_registry_and_errors():
    assert set(METHODS) == {"erm", "p-reg", "f-reg", "sam", "asam", "fsam"}
    with pytest.raises(ValueError, match="Unknown method 'adam'.*'erm'"):
        make_method("adam")
    for bad in (0, -0.1, float("nan"), "big"):
        with pytest.raises(ValueError, match="rho must be a positive number"):
            make_method("sam", rho=bad)
    with pytest.raises(ValueError, match="lam must be a positive"):
        make_method("p-reg", lam=0)
    assert make_method("fsam", eta=2.0).eta == 2.0
    assert make_method("asam").eta == 0.01


def test_penalties():
    record = []
    model = _tiny_model(record)
    p_reg = make_method("p-reg", lam=0.5)
    expected = 0.5 * sum(p.pow(2).sum() for p in model.residual.parameters())
    torch.testing.assert_close(p_reg.penalty(model, None, {}), expected)
    f_reg = make_method("f-reg", lam=0.5)
    with pytest.raises(ValueError, match="f-reg.*user-supplied composition"):
        f_reg.penalty(model, torch.zeros(2, 1), {})


@pytest.mark.parametrize("momentum", [0.1, None])
def test_perturbed_pass_leaves_batchnorm_statistics_alone(momentum):
    """SAM's second pass must not count as a batch, also for a cumulative average (momentum=None)."""
    from sklearn_hybrid.training.engine import _frozen_batchnorm_stats

    torch.manual_seed(0)
    batches = [torch.randn(8, 2) + i for i in range(3)]
    sam, plain = (nn.BatchNorm1d(2, momentum=momentum) for _ in range(2))
    for x in batches:
        sam(x), plain(x)
        with _frozen_batchnorm_stats(sam):
            sam(10 * x + 5)  # the perturbed pass sees other statistics
    assert sam.momentum == momentum
    assert int(sam.num_batches_tracked) == int(plain.num_batches_tracked) == 3
    torch.testing.assert_close(sam.running_mean, plain.running_mean)
    torch.testing.assert_close(sam.running_var, plain.running_var)


def test_a_new_method_registered_once_trains_alike_alone_and_stacked(monkeypatch):
    """A method is called at one site: registered once, it trains a sweep member exactly as a
    single fit, with its own rule (not another method's) and its per-member radius."""
    from dataclasses import dataclass

    from sklearn.base import clone

    from sklearn_hybrid import HybridRegressor, HybridRegressorCV
    from sklearn_hybrid.methods import Method, per_member
    from sklearn_hybrid.models import pendulum_f

    @dataclass
    class SignSAM(Method):  # ascent along sign(g): a rule no built-in method has
        rho: float = 0.05
        name = "sign-sam"
        hyperparameters = ("rho",)
        perturbs = True

        def perturbation(self, params, grads, is_weight, n_batch_dims=0):
            return [per_member(self.rho, g) * torch.sign(g) * 1e-2 for g in grads]

    monkeypatch.setitem(METHODS, "sign-sam", SignSAM)
    rng = np.random.default_rng(0)
    X = rng.uniform(-1, 1, (10, 2))
    y = np.stack([X * np.cos(0.5 * k) for k in range(1, 4)], axis=1)
    base = HybridRegressor(science=pendulum_f, method="sign-sam", dt=0.2, max_iter=6,
                           residual={"hidden": (8,)}, dtype="float64")
    cv = HybridRegressorCV(base, rhos=[0.5, 5.0], seeds=[3], validation_fraction=None).fit(X, y)
    thetas = []
    for params, member in zip(cv.cv_results_["params"], cv.estimators_):
        alone = clone(base).set_params(method=SignSAM(rho=params["rho"]), random_state=params["random_state"]).fit(X, y)
        np.testing.assert_allclose(member.theta_["omega"], alone.theta_["omega"], rtol=1e-12)
        np.testing.assert_allclose(member.history_["loss"], alone.history_["loss"], rtol=1e-12)
        thetas.append(alone.theta_["omega"])
    assert thetas[0] != thetas[1]  # the radius reached each member
    fsam = clone(base).set_params(method=FisherSAM(rho=5.0)).fit(X, y)
    assert fsam.theta_["omega"] != thetas[1]  # not trained with another method's rule


def test_method_given_as_an_object():
    from sklearn.base import clone

    from sklearn_hybrid import HybridRegressor, HybridRegressorCV
    from sklearn_hybrid.methods import FisherSAM
    from sklearn_hybrid.models import pendulum_f

    rng = np.random.default_rng(1)
    X = rng.uniform(-1, 1, (10, 2))
    y = np.stack([X * np.cos(0.5 * k) for k in range(1, 4)], axis=1)
    common = dict(science=pendulum_f, dt=0.2, max_iter=5, residual={"hidden": (8,)}, random_state=0)
    by_object = HybridRegressor(method=FisherSAM(rho=0.2, eta=2.0), **common).fit(X, y)
    with pytest.warns(FutureWarning, match=r"method=FisherSAM\(rho=0.2, eta=2.0\)"):
        by_name = HybridRegressor(method="fsam", rho=0.2, eta=2.0, **common).fit(X, y)  # deprecated, still applies
    assert by_object.theta_ == by_name.theta_
    with pytest.raises(ValueError, match=r"carries its own settings: set rho=0.3 in it"):
        HybridRegressor(method=FisherSAM(rho=0.2), rho=0.3, **common).fit(X, y)  # would be ignored
    assert "FisherSAM(rho=0.2, eta=2.0)" in by_object.fit_report()
    assert clone(by_object).method == FisherSAM(rho=0.2, eta=2.0)
    # a sweep over an object's rho replaces it in a copy, member by member
    cv = HybridRegressorCV(HybridRegressor(method=FisherSAM(rho=0.2), **common), rhos=[0.2, 0.4],
                           validation_fraction=None).fit(X, y)
    assert [m.method.rho for m in cv.estimators_] == [0.2, 0.4]
    assert cv.estimators_[0].theta_ == pytest.approx(
        HybridRegressor(method=FisherSAM(rho=0.2), **common).fit(X, y).theta_)
    with pytest.raises(ValueError, match="FisherSAM.rho must be a positive number"):
        HybridRegressor(method=FisherSAM(rho=-1.0), **common).fit(X, y)
    with pytest.raises(TypeError, match="method must be a name"):
        HybridRegressor(method=3, **common).fit(X, y)


@pytest.mark.parametrize("n_batch_dims", [0, 1])
def test_a_perturbation_that_blows_the_loss_up_is_halved_for_that_step(n_batch_dims):
    """SAM's radius is absolute: where the loss is not finite at the perturbed point (a network moved by rho
    blows a long integration up), the perturbation is halved for that step, member by member, instead of
    handing NaN gradients to theta."""
    from sklearn_hybrid.methods import SAM

    shape = (2, 3) if n_batch_dims else (3,)
    p = torch.nn.Parameter(torch.zeros(shape))
    grads = [torch.ones(shape)]
    seen = []

    def recompute():  # finite only within 0.3 of the origin, per member
        norm = p.detach().reshape(-1, 3).norm(dim=-1) if n_batch_dims else p.detach().norm()
        seen.append(norm.clone())
        loss = torch.where(norm <= 0.3, norm, torch.full_like(norm, float("inf")))
        return loss, [torch.where(torch.isfinite(loss).reshape(*loss.shape, *(1,) * (p.dim() - loss.dim())),
                                  torch.ones_like(p), torch.full_like(p, float("nan")))]

    rho = torch.tensor([1.0, 0.2]) if n_batch_dims else 1.0
    out = SAM(rho=rho).descent([p], [p], grads, [True], recompute, n_batch_dims=n_batch_dims)
    assert torch.isfinite(out[0]).all()
    assert torch.equal(p.detach(), torch.zeros(shape))  # restored exactly after every pass
    expected = torch.tensor([0.25, 0.2]) if n_batch_dims else torch.tensor(0.25)  # 1 -> 0.5 -> 0.25
    torch.testing.assert_close(seen[-1], expected)


@dataclass
class ReachSAM(Method):
    """SAM with its radius called ``reach``: a method and a hyperparameter no module of the package names."""

    reach: float = 0.05
    name = "reach-sam"
    hyperparameters = ("reach",)
    perturbs = True

    def perturbation(self, params, grads, is_weight, n_batch_dims=0):
        return sam_perturbation(grads, self.reach, n_batch_dims=n_batch_dims)


@pytest.fixture
def reach_sam(monkeypatch):
    """ReachSAM in the registry for one test (monkeypatch takes it out again)."""
    monkeypatch.setitem(METHODS, ReachSAM.name, ReachSAM)
    return ReachSAM


def _pendulum_data(seed=0):
    rng = np.random.default_rng(seed)
    X = rng.uniform(-1, 1, (10, 2))
    return X, np.stack([X * np.cos(0.5 * k) for k in range(1, 4)], axis=1)


def _reach_fit(method, **params):
    from sklearn_hybrid import HybridRegressor
    from sklearn_hybrid.models import pendulum_f

    settings = dict(science=pendulum_f, dt=0.2, max_iter=6, residual={"hidden": (8,)}, dtype="float64",
                    random_state=3)
    return HybridRegressor(method=method, **{**settings, **params})


def test_a_new_method_with_its_own_hyperparameter_trains_alone(reach_sam):
    """Registered once, a method with a hyperparameter of its own name trains as an object and by name,
    its radius reaching its rule (the same rule as SAM's, so the same fit as SAM at that rho)."""
    X, y = _pendulum_data()
    alone = _reach_fit(ReachSAM(reach=0.5)).fit(X, y)
    assert alone.theta_ == _reach_fit(SAM(rho=0.5)).fit(X, y).theta_
    assert alone.theta_ != _reach_fit(SAM(rho=0.05)).fit(X, y).theta_  # the radius counts
    by_name = _reach_fit("reach-sam").fit(X, y)  # the method's default radius, rho is not its field
    assert by_name.theta_ == _reach_fit(SAM(rho=0.05)).fit(X, y).theta_
    assert "ReachSAM(reach=0.5)" in alone.fit_report()
    with pytest.raises(ValueError, match="ReachSAM.reach must be a positive number"):
        _reach_fit(ReachSAM(reach=-1.0)).fit(X, y)


def test_a_new_method_with_its_own_hyperparameter_trains_in_a_sweep(reach_sam):
    """Stacked members in two groups (worker processes) each get their own radius, and train as a single
    fit with it does; a HybridRegressorCV over seeds carries the object's radius to every member."""
    from sklearn.base import clone

    from sklearn_hybrid import HybridRegressorCV
    from sklearn_hybrid._fitting import prepare_fit
    from sklearn_hybrid.training.stacked import train_members

    X, y = _pendulum_data()
    radii = [0.5, 5.0]
    setups = [prepare_fit(_reach_fit(ReachSAM(reach=r)), X, y) for r in radii]
    method = setups[0].method.for_members(reach=radii)
    history, _ = train_members([s.model for s in setups], method, setups[0].inputs, setups[0].y,
                               setups[0].config, [s.seed for s in setups], n_jobs=2)
    for k, r in enumerate(radii):
        alone = _reach_fit(ReachSAM(reach=r)).fit(X, y)
        np.testing.assert_allclose(history["loss"][:, k], alone.history_["loss"], rtol=1e-12)
    assert not np.allclose(history["loss"][:, 0], history["loss"][:, 1])
    base = _reach_fit(ReachSAM(reach=5.0))
    cv = HybridRegressorCV(base, seeds=[3, 4], validation_fraction=None).fit(X, y)
    for params, member in zip(cv.cv_results_["params"], cv.estimators_):
        assert member.method == ReachSAM(reach=5.0)
        alone = clone(base).set_params(random_state=params["random_state"]).fit(X, y)
        np.testing.assert_allclose(member.history_["loss"], alone.history_["loss"], rtol=1e-12)


def test_a_new_method_with_its_own_hyperparameter_trains_in_a_profile(reach_sam):
    """The profile of the fit's own objective trains and evaluates members with the fit's method: with the
    same rule as SAM, the same objective as SAM's at that rho."""
    from sklearn_hybrid.identifiability import profile_theta

    X, y = _pendulum_data()
    options = dict(grid={"omega": [0.8, 1.2]}, max_iter=3, refine=False, objective=True)
    mine = profile_theta(_reach_fit(ReachSAM(reach=0.5)).fit(X, y), X, y, **options)
    sam = profile_theta(_reach_fit(SAM(rho=0.5)).fit(X, y), X, y, **options)
    other = profile_theta(_reach_fit(ReachSAM(reach=5.0)).fit(X, y), X, y, **options)
    np.testing.assert_allclose(mine.objective["omega"], sam.objective["omega"], rtol=1e-12)
    assert not np.allclose(mine.objective["omega"], other.objective["omega"])
    assert mine.method == "reach-sam"


def test_no_module_of_the_package_names_the_new_method():
    """What the tests above ran, the package ran without a line about it: neither the method's name nor
    its hyperparameter's is an identifier, keyword or string anywhere in the package."""
    import ast
    from pathlib import Path

    import sklearn_hybrid

    names = {ReachSAM.name, "ReachSAM", *ReachSAM.hyperparameters}
    found = []
    for path in Path(sklearn_hybrid.__file__).parent.rglob("*.py"):
        for node in ast.walk(ast.parse(path.read_text())):
            said = {ast.Name: "id", ast.Attribute: "attr", ast.keyword: "arg", ast.arg: "arg",
                    ast.Constant: "value"}.get(type(node))
            if said and getattr(node, said) in names:
                found.append((path.name, node.lineno))
    assert found == []
    assert ReachSAM.name not in METHODS  # the fixture took it out again


def test_gsam_is_one_class_whose_step_combines_both_gradients():
    """Issue 64: a method whose step combines the gradient at w with the one at w + eps is one class
    (GSAM overrides Method.descent). Its step is SAM's less alpha times the part of the gradient at w
    orthogonal to the one at w + eps, by hand here; at alpha = 0 it is SAM's step."""
    from sklearn_hybrid.methods import GSAM, SAM

    w = torch.nn.Parameter(torch.tensor([1.0, 2.0]))
    theta = torch.nn.Parameter(torch.tensor([0.5]))

    def loss_fn():
        return (w[0] ** 2 + 3 * w[1] ** 2 + theta[0] * w[0]).sum()

    def recompute():
        loss = loss_fn()
        return loss, list(torch.autograd.grad(loss, [theta, w]))

    g = torch.autograd.grad(loss_fn(), [w])
    sam = SAM(rho=0.1).descent([theta, w], [w], list(g), [True], recompute)
    np.testing.assert_allclose(GSAM(rho=0.1, alpha=0.0).descent([theta, w], [w], list(g), [True], recompute)[1],
                               sam[1])
    step = GSAM(rho=0.1, alpha=0.3).descent([theta, w], [w], list(g), [True], recompute)
    h = sam[1]
    orthogonal = g[0] - (g[0] @ h) / (h @ h) * h
    torch.testing.assert_close(step[1], h - 0.3 * orthogonal)
    torch.testing.assert_close(step[0], sam[0])  # theta steps as SAM's
    assert torch.equal(w.detach(), torch.tensor([1.0, 2.0]))  # restored after the perturbed pass


def test_gsam_trains_a_stacked_member_as_a_single_fit():
    """The rule at one site: a sweep member (stacked training) takes the single fit's steps with GSAM."""
    from sklearn.base import clone

    from sklearn_hybrid import HybridRegressorCV
    from sklearn_hybrid.methods import GSAM

    X, y = _pendulum_data()
    base = _reach_fit(GSAM(rho=0.5, alpha=0.5))
    cv = HybridRegressorCV(base, seeds=[3, 4], validation_fraction=None).fit(X, y)
    for params, member in zip(cv.cv_results_["params"], cv.estimators_):
        alone = clone(base).set_params(random_state=params["random_state"]).fit(X, y)
        np.testing.assert_allclose(member.history_["loss"], alone.history_["loss"], rtol=1e-12)
    assert base.fit(X, y).theta_ != _reach_fit(SAM(rho=0.5)).fit(X, y).theta_  # its own rule
