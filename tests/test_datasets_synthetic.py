"""Tests of the synthetic task generators: shapes, determinism, argument checks and the physics they simulate."""

import numpy as np
import pytest
from scipy.integrate import solve_ivp, simpson
from scipy.ndimage import laplace

from sklearn_hybrid.datasets import (make_duffing, make_pendulum, make_pendulum_images, make_reaction_diffusion,
                                     render_pendulum)

SMALL_RD = dict(n_train=3, n_val=2, n_test=2, grid_size=8)


def _full(data, split="train"):
    """Noise-free trajectory (n, m_x + m_y, ...) of a split, whatever the input length."""
    X, y = data[f"X_{split}"], data[f"y_{split}"]
    X = X[:, None] if X.ndim == y.ndim - 1 else X
    return np.concatenate([X, y], axis=1)


def _pendulum_energy(states, omega):
    omega = np.reshape(omega, (-1,) + (1,) * (states.ndim - 2))
    return states[..., 1] ** 2 / 2 + (2 * np.pi * omega) ** 2 * (1 - np.cos(states[..., 0]))


def _duffing_energy(states, alpha, beta=1.0):
    alpha = np.reshape(alpha, (-1, 1))
    v, w = states[..., 0], states[..., 1]
    return w**2 / 2 + alpha * v**2 / 2 - beta * v**4 / 4


# ------------------------------------------------------------------------------------------------ shapes
@pytest.mark.parametrize("make, kwargs, x_shape, y_shape", [
    (make_pendulum, {}, (25, 2), (25, 10, 2)),
    (make_pendulum, dict(omega=(0.1, 1.0), n_input_steps=10), (25, 10, 2), (25, 10, 2)),
    (make_duffing, dict(n_train=7), (7, 2), (7, 10, 2)),
    (make_duffing, dict(n_train=7, alpha=(0.0, 2.0), n_input_steps=4), (7, 4, 2), (7, 10, 2)),
    (make_reaction_diffusion, SMALL_RD, (3, 2, 8, 8), (3, 5, 2, 8, 8)),
    (make_reaction_diffusion, dict(SMALL_RD, a=(0, .02), b=(0, .02), n_input_steps=5), (3, 5, 2, 8, 8),
     (3, 5, 2, 8, 8)),
    (make_pendulum_images, dict(n_train=4, n_val=2, n_test=3, image_size=16), (4, 10, 16, 16), (4, 10, 16, 16)),
])
def test_shapes_and_bunch_contents(make, kwargs, x_shape, y_shape):
    data = make(random_state=0, **kwargs)
    assert data.X_train.shape == x_shape and data.y_train.shape == y_shape
    sizes = {"train": x_shape[0], "val": kwargs.get("n_val", data.X_val.shape[0]),
             "test": kwargs.get("n_test", data.X_test.shape[0])}
    for split, n in sizes.items():
        assert data[f"X_{split}"].shape == (n,) + x_shape[1:]
        assert data[f"y_{split}"].shape == (n,) + y_shape[1:]
        for name, values in data[f"theta_{split}"].items():
            assert values.shape == (n,) and name in data.theta_true
    n_steps = y_shape[1]
    np.testing.assert_allclose(data.t, data.dt * np.arange(1, n_steps + 1))
    assert data.t_input[-1] == 0 and len(data.t_input) == (x_shape[1] if data.X_train.ndim == data.y_train.ndim
                                                           else 1)
    assert isinstance(data.DESCR, str) and f"X_train: {x_shape}" in data.DESCR
    assert isinstance(data.params, dict)


@pytest.mark.parametrize("make, kwargs", [
    (make_pendulum, dict(omega=(0.1, 1.0), n_input_steps=3)),
    (make_duffing, dict(n_train=5, alpha=(0.0, 2.0))),
    (make_reaction_diffusion, SMALL_RD),
    (make_pendulum_images, dict(n_train=3, n_val=1, n_test=1, image_size=12, noise=0.05)),
])
def test_same_seed_same_arrays(make, kwargs):
    first, second, other = make(random_state=3, **kwargs), make(random_state=3, **kwargs), make(random_state=4,
                                                                                                 **kwargs)
    for key in ("X_train", "y_train", "X_val", "y_val", "X_test", "y_test"):
        np.testing.assert_array_equal(first[key], second[key])
    assert not np.allclose(first.X_train, other.X_train)


def test_noise_is_added_with_requested_scale():
    clean = make_duffing(n_train=200, noise=0.0, random_state=1)
    noisy = make_duffing(n_train=200, noise=0.05, random_state=1)
    residual = noisy.y_train - clean.y_train
    assert abs(residual.std() - 0.05) < 0.003 and abs(residual.mean()) < 0.003


@pytest.mark.parametrize("make, kwargs, match", [
    (make_pendulum, dict(n_train=0), "n_train"),
    (make_pendulum, dict(n_val=2.5), "n_val"),
    (make_pendulum, dict(dt=0.0), "dt"),
    (make_pendulum, dict(n_steps=0), "n_steps"),
    (make_pendulum, dict(n_input_steps=0), "n_input_steps"),
    (make_pendulum, dict(noise=-0.1), "noise"),
    (make_pendulum, dict(omega=0.0), "omega"),
    (make_pendulum, dict(omega=(1.0, 0.5)), "omega range"),
    (make_pendulum, dict(omega=(0.1, 0.5, 0.9)), "omega"),
    (make_pendulum, dict(omega="fast"), "omega"),
    (make_pendulum, dict(gamma=-1.0), "gamma"),
    (make_duffing, dict(beta=0.0), "beta"),
    (make_duffing, dict(alpha=(-1.0, 1.0)), "alpha low"),
    (make_duffing, dict(gamma=float("nan")), "gamma"),
    (make_reaction_diffusion, dict(boundary="dirichlet"), "boundary"),
    (make_reaction_diffusion, dict(grid_size=2), "grid_size"),
    (make_reaction_diffusion, dict(a=-1e-3), "a"),
    (make_pendulum_images, dict(image_size=4), "image_size"),
])
def test_bad_arguments_raise(make, kwargs, match):
    with pytest.raises(ValueError, match=match):
        make(**kwargs)


# ------------------------------------------------------------------------------------------------ pendulum physics
def test_damped_pendulum_energy_decays_and_initial_states_in_range():
    data = make_pendulum(n_train=20, n_input_steps=3, noise=0.0, random_state=0)
    states = _full(data)
    assert np.all(np.abs(states[:, 0]) <= np.pi / 2)  # the first input state is U(-pi/2, pi/2)^2
    energy = _pendulum_energy(states, data.theta_train["omega"])
    assert np.all(np.diff(energy, axis=1) < 0)
    assert np.all(energy[:, -1] < 0.9 * energy[:, 0])


def test_undamped_pendulum_conserves_energy_with_per_sample_omega():
    data = make_pendulum(n_train=30, gamma=0.0, omega=(0.1, 1.0), n_input_steps=10, noise=0.0, random_state=0)
    omega = data.theta_train["omega"]
    assert np.all((omega >= 0.1) & (omega <= 1.0)) and np.ptp(omega) > 0.3
    assert data.theta_true["omega"] == (0.1, 1.0)
    energy = _pendulum_energy(_full(data), omega)
    np.testing.assert_allclose(energy, energy[:, :1] * np.ones_like(energy), rtol=0, atol=1e-6)
    # the energy is conserved only with each sample's own omega
    swapped = _pendulum_energy(_full(data), omega[::-1])
    assert np.ptp(swapped, axis=1).max() > 1e-2


# ------------------------------------------------------------------------------------------------ Duffing physics
@pytest.mark.parametrize("alpha", [1.0, (0.0, 2.0)])
def test_duffing_conserves_energy_and_stays_in_the_well(alpha):
    data = make_duffing(n_train=50, alpha=alpha, n_input_steps=10, noise=0.0, random_state=0)
    alphas, states = data.theta_train["alpha"], _full(data)
    energy = _duffing_energy(states, alphas)
    np.testing.assert_allclose(energy, energy[:, :1] * np.ones_like(energy), rtol=0, atol=1e-7)
    barrier, edge = alphas**2 / 4, np.sqrt(alphas)  # separatrix energy and position for beta = 1
    assert np.all(energy[:, 0] < 0.9 * barrier)
    assert np.all(np.abs(states[..., 0]) < edge[:, None])
    # the cubic term matters: some samples reach a large fraction of the separatrix position
    assert np.max(np.abs(states[..., 0]) / edge[:, None]) > 0.6
    if isinstance(alpha, tuple):
        assert np.all((alphas >= 0.0) & (alphas <= 2.0)) and np.ptp(alphas) > 1.0


def test_damped_duffing_loses_energy():
    data = make_duffing(n_train=20, gamma=0.3, noise=0.0, random_state=0)
    energy = _duffing_energy(_full(data), data.theta_train["alpha"])
    assert np.all(np.diff(energy, axis=1) < 0)


# ------------------------------------------------------------------------------------------------ reaction-diffusion
def test_reaction_diffusion_without_diffusion_follows_the_local_ode():
    k = 5e-3
    data = make_reaction_diffusion(a=0.0, b=0.0, k=k, noise=0.0, random_state=0, **SMALL_RD)

    def local(_t, z):
        u, v = z
        return [u - u**3 - k - v, u - v]

    for sample, row, col in [(0, 0, 0), (1, 3, 5), (2, 7, 7)]:
        start = data.X_train[sample, :, row, col]
        ref = solve_ivp(local, (0, data.t[-1]), start, t_eval=data.t, rtol=1e-11, atol=1e-11).y.T
        np.testing.assert_allclose(data.y_train[sample, :, :, row, col], ref, atol=1e-6)


@pytest.mark.parametrize("boundary, mode", [("periodic", "wrap"), ("neumann", "nearest")])
def test_reaction_diffusion_matches_an_independent_solver(boundary, mode):
    """The stored trajectory solves the stated PDE, rebuilt here with scipy.ndimage's five-point Laplacian."""
    a, b, k, grid = 0.01, 0.02, -0.02, 8
    data = make_reaction_diffusion(a=a, b=b, k=k, boundary=boundary, noise=0.0, random_state=0, **SMALL_RD)
    dx = 2 / grid

    def rhs(_t, z):
        u, v = z.reshape(2, grid, grid)
        du = a * laplace(u, mode=mode) / dx**2 + u - u**3 - k - v
        dv = b * laplace(v, mode=mode) / dx**2 + u - v
        return np.concatenate([du.ravel(), dv.ravel()])

    ref = solve_ivp(rhs, (0, data.t[-1]), data.X_test[0].ravel(), t_eval=data.t, rtol=1e-10, atol=1e-10).y
    np.testing.assert_allclose(data.y_test[0], ref.T.reshape(-1, 2, grid, grid), atol=1e-6)


@pytest.mark.parametrize("boundary", ["periodic", "neumann"])
def test_diffusion_does_not_change_spatial_means(boundary):
    """Diffusion only moves mass: d/dt mean(u) = mean(u - u^3 - k - v) and d/dt mean(v) = mean(u - v).

    Integrating the right-hand sides over a finely sampled trajectory must reproduce the change of the spatial
    means; a Laplacian that created or lost mass (wrong stencil, wrong boundary) would break the balance.
    """
    k = 5e-3
    data = make_reaction_diffusion(a=0.02, b=0.02, k=k, dt=0.005, n_steps=40, noise=0.0, boundary=boundary,
                                   random_state=2, **SMALL_RD)
    fields = _full(data)  # (n, 41, 2, G, G)
    u, v = fields[:, :, 0], fields[:, :, 1]
    t = np.concatenate([[0.0], data.t])
    for mean_field, reaction in [(u, u - u**3 - k - v), (v, u - v)]:
        change = mean_field[:, -1].mean(axis=(1, 2)) - mean_field[:, 0].mean(axis=(1, 2))
        integral = simpson(reaction.mean(axis=(2, 3)), x=t, axis=1)
        np.testing.assert_allclose(change, integral, atol=1e-7)
        assert np.all(np.abs(change) > 1e-3)  # the balance is not trivially zero


def test_reaction_diffusion_varying_coefficients_in_range():
    data = make_reaction_diffusion(a=(0.0, 0.02), b=(0.0, 0.02), n_input_steps=5, random_state=0, **SMALL_RD)
    for split in ("train", "val", "test"):
        for name in ("a", "b"):
            values = data[f"theta_{split}"][name]
            assert np.all((values >= 0.0) & (values <= 0.02))
    assert data.theta_true == {"a": (0.0, 0.02), "b": (0.0, 0.02)}
    assert data.X_train.shape[1] == 5 and np.ptp(data.theta_train["a"]) > 0


# ------------------------------------------------------------------------------------------------ pendulum images
def _centroid_angle(images):
    size = images.shape[-1]
    coords = np.arange(size) + 0.5 - size / 2
    mass = images.sum(axis=(-2, -1))
    row = (images.sum(axis=-1) * coords).sum(axis=-1) / mass
    col = (images.sum(axis=-2) * coords).sum(axis=-1) / mass
    return np.arctan2(col, row)  # angle 0 points down (rows grow downwards)


def test_image_centroid_follows_the_bob_angle():
    data = make_pendulum_images(n_train=6, n_val=2, n_test=2, omega=(0.1, 1.0), random_state=0)
    images = np.concatenate([data.X_train, data.y_train], axis=1).astype(float)
    angles = np.concatenate([data.angles_X_train, data.angles_y_train], axis=1)
    error = np.angle(np.exp(1j * (_centroid_angle(images) - angles)))
    assert np.abs(error).max() < 0.01
    assert data.X_train.dtype == np.float32 and data.X_train.min() >= 0 and data.X_train.max() <= 1
    assert np.all((data.theta_train["omega"] >= 0.1) & (data.theta_train["omega"] <= 1.0))


def test_rendering_is_smooth_in_the_angle():
    base = render_pendulum(np.array([0.3, 2.0]), image_size=32)
    nudged = render_pendulum(np.array([0.3, 2.0]) + 1e-3, image_size=32)
    change = np.abs(nudged.astype(float) - base).max(axis=(1, 2))
    assert np.all(change > 0) and np.all(change < 0.02)
    assert render_pendulum(np.zeros((2, 3)), image_size=16).shape == (2, 3, 16, 16)


def test_image_noise_stays_in_unit_interval():
    data = make_pendulum_images(n_train=2, n_val=1, n_test=1, image_size=12, noise=0.2, random_state=0)
    assert data.X_train.min() >= 0 and data.X_train.max() <= 1 and data.X_train.dtype == np.float32
