"""``structure=`` takes an object, ``OdeStructure(dt=..., observed=...)``, or its name as shorthand, as
scikit-learn takes ``kernel=RBF()`` or ``kernel="rbf"``."""

import inspect

import numpy as np
import pytest
import torch
from sklearn.base import clone
from sklearn.utils.estimator_checks import (check_do_not_raise_errors_in_init_or_set_params,
                                            check_estimator_cloneable, check_estimator_repr,
                                            check_get_params_invariance, check_no_attributes_set_in_init,
                                            check_set_params)

from sklearn_hybrid import HybridRegressor, OdeStructure, pack_inputs
from sklearn_hybrid._fitting import ode_structure
from sklearn_hybrid.datasets import make_pendulum
from sklearn_hybrid.diagnosis import close_the_loop
from sklearn_hybrid.models import pendulum_f
from sklearn_hybrid.structures import ODE_DEFAULTS, ODE_FLAT_SETTINGS

FAST = dict(max_iter=5, residual={"hidden": (8,)}, random_state=0, dtype="float64")


def oscillator(v, u, k=1.0):
    return torch.stack([v[:, 1], -k * v[:, 0] + u[:, 0]], dim=-1)


def _forced(n=8, m=10, dt=0.1):
    rng = np.random.default_rng(0)
    t = np.arange(m + 1) * dt
    u = np.sin(2 * np.pi * rng.uniform(0.5, 1.5, (n, 1)) * t)[:, :, None]
    return pack_inputs(rng.normal(size=(n, 2)), u), rng.normal(size=(n, m, 1))


def test_an_ode_structure_object_fits_as_the_keywords_do():
    X, y = _forced()
    structure = OdeStructure(dt=0.1, n_inputs=1, observed=[0], input_interp="linear")
    by_object = HybridRegressor(science=oscillator, structure=structure, **FAST).fit(X, y)
    by_keywords = HybridRegressor(science=oscillator, dt=0.1, n_inputs=1, observed=[0], input_interp="linear",
                                  **FAST).fit(X, y)
    assert by_object.theta_ == by_keywords.theta_
    np.testing.assert_array_equal(by_object.predict(X), by_keywords.predict(X))
    # the fit set up a copy: the object given is the one stored, untouched
    assert by_object.structure is structure and not hasattr(structure, "n_steps")
    assert structure == OdeStructure(dt=0.1, n_inputs=1, observed=[0], input_interp="linear")
    assert "structure: OdeStructure(dt=0.1, observed=[0], n_inputs=1, input_interp='linear')" in by_object.fit_report()
    assert ode_structure(by_object) == structure == ode_structure(by_keywords)


def test_the_estimators_keywords_defer_to_the_object_or_must_agree_with_it():
    data = make_pendulum(n_train=6, n_val=2, n_test=2, n_steps=4, random_state=0)
    X, y = data.X_train, data.y_train
    structure = OdeStructure(dt=0.2)
    with pytest.warns(FutureWarning, match=r"structure=OdeStructure\(dt=0.2\)"):  # deprecated, still honoured
        agreeing = HybridRegressor(science=pendulum_f, structure=structure, dt=0.2, **FAST).fit(X, y)
    assert agreeing.theta_ == HybridRegressor(science=pendulum_f, structure=structure, **FAST).fit(X, y).theta_
    with pytest.raises(ValueError, match=r"structure=OdeStructure\(dt=0.2\) and dt=0.1 disagree: give dt once"):
        HybridRegressor(science=pendulum_f, structure=structure, dt=0.1, **FAST).fit(X, y)
    # the flat keywords are deprecated: left alone ("deprecated", not given) they defer to the object
    keywords = inspect.signature(HybridRegressor).parameters
    assert {k: keywords[k].default for k in ODE_DEFAULTS if k in keywords} == ODE_FLAT_SETTINGS
    assert ODE_DEFAULTS["dt"] == 1.0
    # by name, flat options still apply (with a FutureWarning) and give the object's fit
    with pytest.warns(FutureWarning, match=r"HybridRegressor\(dt=0.2, n_substeps=2\) is deprecated.*"
                                           r"structure=OdeStructure\(dt=0.2, n_substeps=2\)"):
        flat = HybridRegressor(science=pendulum_f, dt=0.2, n_substeps=2, **FAST).fit(X, y)
    assert flat.theta_ == HybridRegressor(science=pendulum_f, structure=OdeStructure(dt=0.2, n_substeps=2),
                                          **FAST).fit(X, y).theta_


def test_clone_and_params_with_a_structure_object():
    est = HybridRegressor(science=pendulum_f, structure=OdeStructure(dt=0.2, observed=[0]))
    twin = clone(est)
    assert twin.structure == est.structure and twin.structure is not est.structure
    assert est.get_params()["structure"] is est.structure
    assert twin.set_params(structure=OdeStructure(dt=0.1)).structure == OdeStructure(dt=0.1)
    for check in (check_estimator_cloneable, check_get_params_invariance, check_set_params,
                  check_no_attributes_set_in_init, check_estimator_repr,
                  check_do_not_raise_errors_in_init_or_set_params):
        check("HybridRegressor", est)


def test_what_asked_for_structure_ode_asks_the_object():
    """The closed loop's checks read ``observed`` from the object, not the estimator's keyword (None here)."""
    data = make_pendulum(10, 2, 2, dt=0.1, n_steps=5, random_state=0)
    partial = HybridRegressor(science=pendulum_f, structure=OdeStructure(dt=0.1, observed=[0]), method="erm",
                              max_iter=1)
    with pytest.raises(ValueError, match=r"offsets names \['v_dot'\], not measured \(observed=\[0\]\)"):
        close_the_loop(partial, data.X_train, data.y_train[..., :1], state_names=["v", "v_dot"],
                       offsets=["v_dot"])
    assert ode_structure(HybridRegressor(structure="additive")) is None
    assert ode_structure(HybridRegressor(dt=0.3)) == OdeStructure(dt=0.3)
