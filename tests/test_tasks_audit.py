"""The paper's tasks as a user runs them: each defect a user audit found, tested."""

from functools import partial

import numpy as np
import pytest
import torch

from sklearn_hybrid import HybridRegressor
from sklearn_hybrid.datasets import make_pendulum, make_pendulum_images, make_reaction_diffusion
from sklearn_hybrid.models import PendulumImagesNet, PendulumImagesStructure, diffusion_f, pendulum_f


@pytest.fixture(scope="module")
def fields():
    return make_reaction_diffusion(3, 2, 4, grid_size=8, random_state=0)


def _fit_cnn(fields, residual):
    return HybridRegressor(science=diffusion_f, residual=residual, dt=fields.dt, n_substeps=1, max_iter=5,
                           random_state=0).fit(fields.X_train, fields.y_train)


def test_cnn_without_batch_norm_predicts_each_field_on_its_own(fields):
    est = _fit_cnn(fields, {"kind": "cnn", "batch_norm": False})
    together = est.predict(fields.X_test)
    alone = np.stack([est.predict(fields.X_test[i:i + 1])[0] for i in range(len(fields.X_test))])
    np.testing.assert_allclose(alone, together, atol=1e-5)
    assert not any(isinstance(m, torch.nn.BatchNorm2d) for m in est.residual_.modules())


def test_cnn_with_batch_norm_depends_on_the_batch_as_documented(fields):
    # APHYNITY's setting, kept as the default: the README and the ConvNet docstring say so
    est = _fit_cnn(fields, "cnn")
    together = est.predict(fields.X_test)
    assert np.abs(est.predict(fields.X_test[:1])[0] - together[0]).max() > 1e-4


def test_theta_std_of_a_fixed_parameter_is_zero_with_an_encoder():
    def damped(v, omega=0.5, gamma=0.0):
        return torch.stack([v[:, 1], -gamma * v[:, 1] - (2 * torch.pi * omega) ** 2 * torch.sin(v[:, 0])], -1)

    data = make_pendulum(8, 2, 2, omega=(0.1, 1.0), n_input_steps=4, random_state=0)
    est = HybridRegressor(science=damped, theta_encoder="mlp", theta_fixed=["gamma"], dt=data.dt, max_iter=3,
                          random_state=0).fit(data.X_train, data.y_train)
    assert est.theta_std_["gamma"] == 0.0  # was NaN
    assert np.isnan(est.theta_std_["omega"])  # inferred per sample: no shared standard error


def test_a_network_shape_error_with_an_encoder_carries_no_vmap_advice():
    data = make_pendulum_images(6, 2, 3, n_input_steps=3, n_steps=3, image_size=12, random_state=0)
    net = partial(PendulumImagesNet, n_input_frames=3, image_size=16, latent_dim=2, encoder_channels=(4, 8),
                  encoder_hidden=16, ode_hidden=(16, 16), fc_hidden=(16,), conv_channels=(4,))
    est = HybridRegressor(science=pendulum_f, structure=PendulumImagesStructure(dt=data.dt, n_steps=3, n_substeps=1),
                          residual=net, theta_encoder="cnn", max_iter=2, random_state=0)
    with pytest.raises(ValueError, match=r"expects X of shape \(n, 3, 16, 16\)") as info:
        est.fit(data.X_train, data.y_train)
    assert "vmap" not in str(info.value) and ".." not in str(info.value)


def test_a_science_function_vmap_cannot_run_gets_the_vmap_advice():
    def branching(v, omega=0.5):  # Python branching on a tensor's value cannot run under vmap
        sign = 1.0 if omega > 0 else -1.0
        return torch.stack([v[:, 1], -sign * (2 * torch.pi * omega) ** 2 * torch.sin(v[:, 0])], -1)

    data = make_pendulum(6, 2, 2, omega=(0.3, 1.0), n_input_steps=3, random_state=0)
    est = HybridRegressor(science=branching, theta_encoder="mlp", dt=data.dt, max_iter=2, random_state=0)
    with pytest.raises(ValueError, match="torch.func.vmap"):
        est.fit(data.X_train, data.y_train)


@pytest.mark.parametrize("value", [None, "0.5", True])
def test_theta_init_of_the_wrong_type_is_named(value):
    data = make_pendulum(4, 2, 2, random_state=0)
    est = HybridRegressor(science=pendulum_f, theta_init={"omega": value}, dt=data.dt, max_iter=1)
    with pytest.raises(ValueError, match=r"theta_init\['omega'\] must be a number"):
        est.fit(data.X_train, data.y_train)
