"""Science functions of the tasks against their physics, and every task end to end at tiny size."""

from functools import partial

import numpy as np
import pytest
import torch

from sklearn_hybrid import HybridRegressor
from sklearn_hybrid.datasets import (make_duffing, make_light_tunnel_simulated, make_pendulum,
                                     make_pendulum_images, make_reaction_diffusion,
                                     make_wind_tunnel_simulated)
from sklearn_hybrid.models.causal_chamber import (S_MAX, T_CROSSED, T_PARALLEL, W_WHITE_BALANCE, hexagon_mask,
                                                  model_f3_colour)
from sklearn_hybrid.models import (THETA_BOUNDS, FeedForward, FrameDecoder, ImageEncoder,
                                   PendulumImagesNet, PendulumImagesStructure, UNet,
                                   diffusion_f, duffing_f, laplacian, latent_trajectories,
                                   light_tunnel_f, light_tunnel_unet, make_light_tunnel_f,
                                   pendulum_f, wind_tunnel_f, wind_tunnel_net)
from sklearn_hybrid.science import read_signature

D = torch.float64


# ------------------------------------------------------------------ science functions vs physics
def test_pendulum_f_is_the_undamped_pendulum():
    v = torch.tensor([[0.3, -1.2], [-1.0, 0.5]], dtype=D)
    out = pendulum_f(v, omega=2 / 3)
    v_np = v.numpy()
    expected = np.column_stack([v_np[:, 1], -(2 * np.pi * 2 / 3) ** 2 * np.sin(v_np[:, 0])])
    np.testing.assert_allclose(out.numpy(), expected, rtol=1e-12)


def test_pendulum_f_conserves_the_pendulum_energy():
    # d/dt [v'^2 / 2 - k cos v] = v' v'' + k sin v v' = 0 along f
    v = torch.tensor(np.random.default_rng(0).uniform(-1.5, 1.5, (20, 2)), dtype=D)
    dv = pendulum_f(v, omega=0.4)
    k = (2 * np.pi * 0.4) ** 2
    power = v[:, 1] * dv[:, 1] + k * torch.sin(v[:, 0]) * dv[:, 0]
    assert torch.allclose(power, torch.zeros_like(power), atol=1e-12)


def test_duffing_f_is_the_linear_oscillator():
    v = torch.tensor([[0.5, 0.1], [-0.2, 0.3]], dtype=D)
    np.testing.assert_allclose(duffing_f(v, alpha=1.7).numpy(),
                               np.column_stack([v[:, 1].numpy(), -1.7 * v[:, 0].numpy()]),
                               rtol=1e-12)


def test_default_thetas_are_not_the_truth():
    for f, truth in [(pendulum_f, {"omega": 2 / 3}), (duffing_f, {"alpha": 1.0}),
                     (diffusion_f, {"a": 1e-3, "b": 5e-3}), (wind_tunnel_f, {"r": 0.7})]:
        _, defaults = read_signature(f)
        assert set(defaults) == set(truth)
        for name, value in truth.items():
            assert not np.isclose(defaults[name], value)
    _, defaults = read_signature(light_tunnel_f)
    assert {k: v.shape for k, v in defaults.items()} == {"w": (3,), "t_p": (3,), "t_c": (3,)}
    assert set(THETA_BOUNDS["wind_tunnel_f"]) == {"r"}


@pytest.mark.parametrize("boundary", ["periodic", "neumann"])
def test_laplacian_is_exact_on_a_quadratic_and_matches_the_generator(boundary):
    # the five-point stencil is exact for x^2 + y^2 away from the boundary
    n, dx = 16, 0.1
    grid = np.arange(n) * dx
    field = torch.tensor(grid[:, None] ** 2 + grid[None, :] ** 2, dtype=D)
    lap = laplacian(field, dx, boundary)
    np.testing.assert_allclose(lap[1:-1, 1:-1].numpy(), 4.0, rtol=1e-10)
    # and equals the generator's convention, as seen through its own simulation step
    from sklearn_hybrid.datasets._synthetic import _laplacian

    fields = np.random.default_rng(1).uniform(size=(3, 2, 8, 8))
    np.testing.assert_allclose(laplacian(torch.tensor(fields), 0.25, boundary).numpy(),
                               _laplacian(fields, 0.25, boundary), rtol=1e-12)


def test_laplacian_rejects_unknown_boundary():
    with pytest.raises(ValueError, match="boundary"):
        laplacian(torch.zeros(4, 4), 1.0, "dirichlet")


def test_diffusion_f_uses_the_generator_grid_and_periodic_boundary():
    state = torch.tensor(np.random.default_rng(2).uniform(size=(2, 2, 32, 32)), dtype=D)
    out = diffusion_f(state, a=1e-3, b=5e-3)
    dx = 2.0 / 32
    np.testing.assert_allclose(out[:, 0].numpy(), 1e-3 * laplacian(state[:, 0], dx).numpy())
    np.testing.assert_allclose(out[:, 1].numpy(), 5e-3 * laplacian(state[:, 1], dx).numpy())
    # periodic diffusion conserves mass
    assert torch.allclose(out.sum(dim=(-1, -2)), torch.zeros(2, 2, dtype=D), atol=1e-9)


def test_wind_tunnel_f_closed_form_and_package_sanity_value():
    x = torch.tensor([[[1.0, 0.1, 0.0], [0.05, 0.0, 45.0], [0.5, 0.7, 10.0]]], dtype=D)
    r = 0.75
    out = wind_tunnel_f(x, r=r)
    ell = lambda L: 0.0 if L == 0 else max(L, 0.1)  # noqa: E731
    expected = [S_MAX * (1 - r) * (ell(a) ** 2 - ell(b) ** 2) for a, b, _ in x[0].tolist()]
    np.testing.assert_allclose(out[0].numpy(), expected, rtol=1e-12)
    assert out[0, 0].item() == pytest.approx(18.519, abs=5e-4)  # causalchamber 0.2.8 output
    assert wind_tunnel_f(x[:, :1], r=0.7).item() == pytest.approx(22.223, abs=5e-4)
    # the hatch (third channel) is not part of A1 + C2
    x2 = x.clone()
    x2[..., 2] = 0.0
    assert torch.equal(wind_tunnel_f(x2, r=r), out)


def test_light_tunnel_colour_on_known_inputs():
    f = make_light_tunnel_f(100)
    ref = dict(w=torch.tensor(W_WHITE_BALANCE), t_p=torch.tensor(T_PARALLEL),
               t_c=torch.tensor(T_CROSSED))
    # white light (all LEDs 255 -> x = 1), parallel polarisers: colour = e * w * S.sum(1) * T^p
    white = torch.tensor([[255.0, 255.0, 255.0, 30.0, 30.0]], dtype=D)
    from sklearn_hybrid.models.causal_chamber import EXPOSURE_F3, S_CAMERA

    colour = np.minimum(1, EXPOSURE_F3 * W_WHITE_BALANCE * S_CAMERA.sum(1) * T_PARALLEL)
    image = f(white, **ref)[0].numpy()
    mask = hexagon_mask(100)
    assert mask[50, 50] and not mask[0, 0]
    np.testing.assert_allclose(image[:, 50, 50], colour, rtol=1e-12)  # inside the hexagon
    np.testing.assert_array_equal(image[:, 0, 0], 0.0)  # outside
    np.testing.assert_array_equal(image[:, ~mask], 0.0)
    # crossed polarisers transmit T^c instead of T^p
    crossed = torch.tensor([[255.0, 255.0, 255.0, 0.0, 90.0]], dtype=D)
    np.testing.assert_allclose(f(crossed, **ref)[0, :, 50, 50].numpy(),
                               EXPOSURE_F3 * W_WHITE_BALANCE * S_CAMERA.sum(1) * T_CROSSED,
                               rtol=1e-9)
    # the publisher-protocol inputs agree with the dataset module's numpy F3
    X = np.array([[216, 162, 130, -82.9, -69.2], [10, 19, 4, -117.0, 112.7],
                  [165, 232, 128, 38.3, 169.4]])
    np.testing.assert_allclose(f(torch.tensor(X), **ref)[:, :, 50, 50].numpy(), model_f3_colour(X),
                               rtol=1e-12)
    assert light_tunnel_f(white).shape == (1, 3, 100, 100)


def test_fitted_light_tunnel_estimator_pickles():
    import pickle

    d = make_light_tunnel_simulated(n_samples=6, image_size=8, random_state=0)
    est = HybridRegressor(science=make_light_tunnel_f(8), structure="compose",
                          residual=partial(light_tunnel_unet, channels=(2, 4)), max_iter=1,
                          random_state=0).fit(d.X, d.images)
    again = pickle.loads(pickle.dumps(est))
    np.testing.assert_allclose(again.predict(d.X), est.predict(d.X), rtol=1e-6)


def test_make_light_tunnel_f_checks_the_image_size():
    assert make_light_tunnel_f(24)(torch.zeros(2, 5)).shape == (2, 3, 24, 24)
    with pytest.raises(ValueError, match="image_size"):
        make_light_tunnel_f(3)


# ------------------------------------------------------------------ networks
def test_networks_shapes():
    x, z = torch.rand(4, 20, 3), torch.rand(4, 20)
    net = wind_tunnel_net(((20, 3), (20,)), (20,))
    assert net(x, z).shape == (4, 20)
    assert [m.out_features for m in net.net if hasattr(m, "out_features")] == [40, 40, 20]
    with pytest.raises(ValueError, match="input_scales"):
        FeedForward(((2,),), (1,), input_scales=[1.0, 2.0])
    for size in (24, 25, 100):
        unet = light_tunnel_unet(((5,), (3, size, size)), (3, size, size), channels=(4, 8))
        assert unet(torch.rand(2, 5), torch.rand(2, 3, size, size)).shape == (2, 3, size, size)
    assert UNet(1, 2, (4, 8, 8))(torch.rand(1, 1, 17, 17)).shape == (1, 2, 17, 17)
    assert ImageEncoder(10, 48, 2, (4, 8))(torch.rand(3, 10, 48, 48)).shape == (3, 2)
    dec = FrameDecoder(9, 48, (16,), (8, 4))
    out = dec(torch.rand(5, 9))
    assert out.shape == (5, 48, 48) and out.min() >= 0 and out.max() <= 1


# ------------------------------------------------------------------ tasks end to end
def _fit(X, y, **kw):
    est = HybridRegressor(max_iter=3, random_state=0, method="fsam", **kw).fit(X, y)
    assert est.predict(X).shape == np.shape(y)
    for name, values in est.history_["theta"].items():
        assert np.all(np.isfinite(values)) and len(values) == 3
    return est


def test_pendulum_task_end_to_end():
    d = make_pendulum(6, 2, 2, random_state=0)
    est = _fit(d.X_train, d.y_train, science=pendulum_f, dt=d.dt, n_substeps=2)
    assert est.theta_["omega"] != 0.5  # theta is trained


def test_duffing_task_end_to_end():
    d = make_duffing(6, 2, 2, random_state=0)
    _fit(d.X_train, d.y_train, science=duffing_f, dt=d.dt, n_substeps=1)


def test_reaction_diffusion_task_end_to_end():
    d = make_reaction_diffusion(3, 1, 1, grid_size=8, n_steps=2, random_state=0)
    _fit(d.X_train, d.y_train, science=diffusion_f, dt=d.dt, residual="cnn", n_substeps=1,
         theta_bounds=THETA_BOUNDS["diffusion_f"])


def test_wind_tunnel_task_end_to_end():
    d = make_wind_tunnel_simulated(n_runs=1, n_steps=400, window=20, stride=20, random_state=0)
    y = d.y - d.pressure_ambient
    est = _fit(d.X, y, science=wind_tunnel_f, structure="compose", residual=wind_tunnel_net,
               theta_bounds={"r": (0.0, 1.0)})
    assert 0 < est.theta_["r"] < 1


def test_light_tunnel_task_end_to_end():
    d = make_light_tunnel_simulated(n_samples=8, image_size=16, random_state=0)
    est = _fit(d.X, d.images, science=make_light_tunnel_f(16), structure="compose",
               residual=partial(light_tunnel_unet, channels=(4, 8)), batch_size=4)
    assert est.theta_["w"].shape == (3,)


def test_pendulum_images_task_end_to_end():
    d = make_pendulum_images(4, 1, 1, n_input_steps=3, n_steps=2, image_size=16, random_state=0)
    net = partial(PendulumImagesNet, n_input_frames=3, image_size=16, latent_dim=2,
                  encoder_channels=(4,), encoder_hidden=8, ode_hidden=(8,), fc_hidden=(8,),
                  conv_channels=(4,))
    est = _fit(d.X_train, d.y_train, science=pendulum_f, residual=net,
               structure=PendulumImagesStructure(dt=d.dt, n_steps=2))
    assert latent_trajectories(est, d.X_train).shape == (4, 2, 2)
    with pytest.raises(ValueError, match="PendulumImagesNet expects"):
        est.residual_.check_input(torch.zeros(1, 3, 16, 8))


def test_pendulum_images_structure_validates():
    with pytest.raises(ValueError, match="dt"):
        PendulumImagesStructure(dt=0)
    with pytest.raises(ValueError, match="n_steps"):
        PendulumImagesStructure(n_steps=0)
    with pytest.raises(TypeError, match="PendulumImagesNet"):
        PendulumImagesStructure().states(torch.zeros(1, 10, 48, 48), pendulum_f,
                                         torch.nn.Identity())
