"""device="cpu" | "cuda" | "auto": resolved at fit, carried to prediction, a clear error without CUDA."""

import numpy as np
import pytest
import torch

from sklearn_hybrid import HybridRegressor, HybridRegressorCV
from sklearn_hybrid._device import resolve_device
from sklearn_hybrid.models import pendulum_f

FAST = dict(max_iter=3, residual={"hidden": (8,)}, random_state=0, dt=0.2)


@pytest.fixture
def data():
    rng = np.random.default_rng(0)
    return rng.uniform(-1, 1, (6, 2)), rng.uniform(-1, 1, (6, 5, 2))


@pytest.fixture
def no_cuda(monkeypatch):
    monkeypatch.setattr(torch.cuda, "is_available", lambda: False)


def test_cpu_by_name_object_and_auto_without_gpu(data, no_cuda):
    default = HybridRegressor(science=pendulum_f, **FAST).fit(*data)
    assert default.device_ == torch.device("cpu")
    for device in ("cpu", torch.device("cpu"), "auto"):
        est = HybridRegressor(science=pendulum_f, device=device, **FAST).fit(*data)
        assert est.device_ == torch.device("cpu")
        assert est.theta_ == default.theta_
        np.testing.assert_array_equal(est.predict(data[0]), default.predict(data[0]))


@pytest.mark.parametrize("device", ["cuda", "cuda:1"])
def test_cuda_asked_for_and_absent(data, no_cuda, device):
    with pytest.raises(ValueError, match=f"device='{device}' asks for a CUDA GPU, but torch finds none"):
        HybridRegressor(science=pendulum_f, device=device, **FAST).fit(*data)
    with pytest.raises(ValueError, match="asks for a CUDA GPU"):
        HybridRegressorCV(HybridRegressor(science=pendulum_f, method="erm", device=device,
                                          **FAST), seeds=[0, 1]).fit(*data)


@pytest.mark.parametrize("device", ["gpu", "mps", 3.5])
def test_unknown_device(device):
    with pytest.raises(ValueError, match="device must be 'cpu', 'cuda', 'cuda:N' or 'auto'"):
        resolve_device(device)


def test_auto_takes_a_gpu_when_torch_sees_one(monkeypatch):
    monkeypatch.setattr(torch.cuda, "is_available", lambda: True)
    assert resolve_device("auto") == torch.device("cuda")


def test_fast_path_is_cpu_only():
    from sklearn_hybrid.integrate import fast as fast_rk4
    from sklearn_hybrid.residual import MLP

    mlp = MLP(((2,),), (2,))
    assert fast_rk4.supports(mlp, (2,), "rk4")
    meta = MLP(((2,),), (2,)).to("meta")  # a module off the CPU, without needing a GPU
    assert not fast_rk4.supports(meta, (2,), "rk4")
