"""Test setup: point the dataset loaders at the project's shared measured data when present."""

import os
from pathlib import Path

import pytest
import torch

# scikit-learn's array-API check (numpy inputs with dispatch on) runs only when scipy's array-API
# mode is on, which must be decided before scipy is imported.
os.environ.setdefault("SCIPY_ARRAY_API", "1")

# The suite runs in pytest-xdist workers (setup.cfg). Each worker trains small models, which gain
# nothing from a second intra-op thread but lose the core another worker needs: give each worker its
# share of the cores, at least one, instead of torch's default of every core per worker.
if os.environ.get("PYTEST_XDIST_WORKER_COUNT"):
    torch.set_num_threads(max(1, (os.cpu_count() or 1) // int(os.environ["PYTEST_XDIST_WORKER_COUNT"])))

# The measured files live beside the repository (never inside it): <repo>/../shared/data.
SHARED_DATA = Path(__file__).resolve().parents[1].parent / "shared" / "data"


@pytest.fixture(scope="session", autouse=True)
def _data_home_env():
    """Set SKLEARN_HYBRID_DATA to the shared data folder unless the caller set it."""
    if SHARED_DATA.is_dir() and not os.environ.get("SKLEARN_HYBRID_DATA"):
        with pytest.MonkeyPatch.context() as mp:
            mp.setenv("SKLEARN_HYBRID_DATA", str(SHARED_DATA))
            yield
    else:
        yield


@pytest.fixture(scope="session")
def shared_data() -> Path:
    """The shared measured-data folder; tests using it skip only where it does not exist."""
    if not SHARED_DATA.is_dir():
        pytest.skip(f"shared data folder {SHARED_DATA} not present")
    return SHARED_DATA
