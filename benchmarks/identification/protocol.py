"""The identification benchmark's protocol: a case's data, its scores, its record's name and folder, the loop's
arguments.

Shared by the benchmark (``bench_identification.py``), its checks (``checks.py``) and the anchors beside the
loop (``bench_anchors_loop.py``), so that a case means the same data and the same scores in all three. The
systems are in ``systems.py``.
"""

from __future__ import annotations

import io
import json
import pickle
import zlib
from pathlib import Path

import numpy as np

from helpers import runs_folder
from identification.systems import System, call_science, simulate

from sklearn_hybrid import pack_inputs

NOISE_LEVELS = (0.01, 0.05)
PROTOCOL = {"n_train": 50, "n_test": 20, "estimator": "HybridRegressor(science=f, "
            "structure=OdeStructure(dt=dt, n_inputs=0 or 1), method='erm', theta_init=the system's guesses or None, "
            "random_state=seed), every other setting at its default",
            "noise": "Gaussian, level x the standard deviation of each state over the noise-free training states, "
                     "added to the initial states (X) and to y; inputs are exact",
            "test_states": "every output of the noise-free test trajectories (initial states included)",
            "threshold": 0.10}
FAST = {"n_train": 8, "n_test": 4, "max_iter": 40}


def cache_dir(fast: bool) -> Path:
    """Folder of the cached cases (a separate one for the ``--fast`` smoke protocol)."""
    return runs_folder("identification/fast" if fast else "identification")


def _norm(a: np.ndarray) -> float:
    """sqrt(mean over states of the sum over components of a^2)."""
    return float(np.sqrt(np.mean(np.sum(np.asarray(a) ** 2, axis=1))))


def make_data(system: System, noise: float, seed: int, fast: bool = False) -> dict:
    """Training data (``X``, ``y`` as the estimator takes them) and the noise-free test states and inputs."""
    n_train, n_test = (FAST if fast else PROTOCOL)["n_train"], (FAST if fast else PROTOCOL)["n_test"]
    x, u = simulate(system, n_train, seed, stream=0)
    x_test, u_test = simulate(system, n_test, seed, stream=1)
    d = x.shape[-1]
    sigma = noise * x.reshape(-1, d).std(axis=0)
    eps = np.random.default_rng([zlib.crc32(system.name.encode()), seed, 2]).standard_normal(x.shape)
    noisy = x + eps * sigma + system.offset_vector(d)  # what the sensors read
    X = pack_inputs(noisy[:, 0], u) if system.forced else noisy[:, 0]
    return {"X": X, "y": noisy[:, 1:], "sigma": sigma,
            "x_test": x_test.reshape(-1, d), "u_test": None if u_test is None else u_test.reshape(-1, 1)}


def score(system: System, science, theta: dict, before_theta: dict, x: np.ndarray, u: np.ndarray | None) -> dict:
    """Function-space scores of the final science model ``science(theta)`` on the test states ``x`` (inputs ``u``).

    Where a sensor reads its state plus an offset, every model is evaluated at the readings ``z = x + offset``
    (the states the fitted models simulate); the truth there is the true right-hand side at ``x``, and the
    missing effect is what the science model at the true parameters lacks at ``z``.
    """
    z = x + system.offset_vector(x.shape[1])  # z is x itself where every sensor reads true
    F = call_science(system, science, z, u, theta)
    T = system.truth(x, u)
    B = call_science(system, system.science, z, u, before_theta)
    if system.is_control:
        return {"control_err": _norm(F - T) / _norm(T), "before_control_err": _norm(B - T) / _norm(T)}
    m = (T - call_science(system, system.science, z, u, system.theta_true) if system.sensor_offset
         else system.missing(x, u))
    scale = _norm(m)
    zero = np.zeros(F.shape[1], dtype=bool)
    zero[system.zero_components] = True
    return {"rel_err": _norm(F - T) / scale, "before_err": _norm(B - T) / scale,
            "leak": _norm((F - T)[:, zero]) / scale if zero.any() else None}


# The first fits pickled before the benchmarks were grouped name the science functions' module by its old name.
_MOVED_MODULES = {"_identification_systems": "identification.systems"}


class _Unpickler(pickle.Unpickler):
    def find_class(self, module, name):
        return super().find_class(_MOVED_MODULES.get(module, module), name)


def load_fit(path: Path):
    """A stored first hybrid fit (``runs/identification/fits/<case>.pkl``), from before the grouping too."""
    return _Unpickler(io.BytesIO(Path(path).read_bytes())).load()


def case_name(system: str, noise: float, seed: int) -> str:
    """The stem of a case's cached record (``.json``) and stored first fit (``fits/*.pkl``)."""
    return f"{system}_noise{noise:g}_seed{seed}"


def loop_arguments(system: System) -> dict:
    """close_the_loop's keyword arguments for ``system`` (names, units, declared offsets)."""
    return {"state_names": system.state_names, "input_names": ["u"] if system.forced else None,
            "units": {k: v for k, v in system.units.items() if k != "u" or system.forced},
            "offsets": system.declared_offsets}


def first_hybrid_fit(system: System, data: dict, seed: int = 0, path: Path | None = None):
    """The case's first hybrid fit as the benchmark makes it (erm, the network started at zero on every equation,
    as the loop starts it): loaded from ``path`` where it is stored, else made and stored there. Returns the
    estimator and whether it was loaded."""
    if path is not None and path.exists():
        return load_fit(path), True
    from sklearn_hybrid import HybridRegressor, OdeStructure
    from sklearn_hybrid.diagnosis import MLPOn

    est = HybridRegressor(science=system.science, structure=OdeStructure(dt=system.dt, n_inputs=int(system.forced)),
                          method="erm", theta_init=dict(system.theta_guess) or None, random_state=seed,
                          residual=MLPOn(list(range(len(system.state_names)))))
    est.fit(data["X"], data["y"])
    if path is not None:
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_bytes(pickle.dumps(est))
    return est, False


def load(fast: bool) -> list[dict]:
    """Every cached case of the main (or the fast) protocol."""
    return [json.loads(p.read_text()) for p in sorted(cache_dir(fast).glob("*.json"))]
