"""What a fit of :class:`~sklearn_hybrid.HybridRegressor` builds and leaves, for the estimator and the package.

:func:`prepare_fit` validates the data and builds the model a fit trains (the stacked sweep, the profiles and the
bootstrap build their members with it); :func:`store_fit` makes an estimator fitted with a trained model: theta, its
standard errors, the network's share, the fitted attributes.  The other functions are what the package's modules
ask of a fitted estimator, as scikit-learn's ``validate_data(estimator, X)`` is a function over an estimator: no
other module calls the estimator's private methods.  Each takes a ``HybridRegressor`` (typed as scikit-learn's base
class: this module is imported by the estimator's).
"""

from __future__ import annotations

import math
import threading
import uuid
import warnings

import numpy as np
import torch
from sklearn.base import BaseEstimator
from sklearn.utils import Bunch, check_random_state
from sklearn.utils.validation import check_is_fitted

from . import encoder as _encoder
from ._device import resolve_device
from ._extras import check_sample_weight
from ._fit_report import flat_predictions, theta_uncertainty
from ._validation import check_dtype_range, check_not_nested, set_feature_info, torch_threads, validate_into_copy
from .metrics import network_share
from .residual import build_residual, is_zero_residual
from .science import ScienceModel
from .structures import ComposeStructure, HybridModule, OdeStructure
from .structures.scales import ode_data_scales, set_network_scales, static_data_scales
from .training.schedule import THETA_LR_FACTOR, TrainConfig, cosine_lr, theta_drift

#: The ``dtype`` parameter's names.
DTYPES = {"float32": torch.float32, "float64": torch.float64}
_SEEDED_INIT = threading.Lock()  # torch's global generator is shared by all threads


def _standard_error_rows(model, n: int, n_iter: int, batch_size, seed: int):
    """Rows of a random subset for the standard errors, or None for all samples.

    They take ``1 + 2 p`` forward passes over their samples (central
    differences in the ``p`` free parameters); a training of ``n_iter``
    iterations of ``batch_size`` samples made about ``n_iter * batch_size``
    passes.  Their cost is kept to a tenth of that, with at least 32 samples.
    """
    p = sum(r.numel() for r in model.science.raw.values() if r.requires_grad)
    passes = n_iter * min(batch_size or n, n)
    m = max(32, int(0.1 * passes / (1 + 2 * p)))
    if m >= n:
        return None
    return torch.as_tensor(np.sort(np.random.default_rng(seed).choice(n, m, replace=False)))


def _network_share(model, inputs, chunk) -> float | None:
    """The network's share of the prediction on ``inputs`` (None where the science alone predicts no ``y``:
    a user's composition, or a science output of another shape)."""
    if is_zero_residual(model.residual):  # no network: nothing to predict twice
        return 0.0
    try:
        hybrid, science = (flat_predictions(model, inputs, chunk, use_residual=flag) for flag in (True, False))
    except ValueError:  # a user-supplied composition has no science-only prediction
        return None
    return network_share(hybrid, science) if hybrid.shape == science.shape else None


def prepare_fit(estimator: BaseEstimator, X, y, sample_weight=None) -> Bunch:
    """Validate ``X, y`` (and ``sample_weight``) and build what a fit of ``estimator`` trains (``estimator`` is
    not changed).

    Returns the Bunch a fit trains from: ``model`` (with the seeded network, in the data's scales as the weights
    count the samples), ``method``, ``inputs``, ``y`` (tensor), ``sample_weight`` (tensor or None), ``config``,
    ``seed`` and the data's shapes.
    """
    method = estimator._check_params()
    if not estimator._dt_given():
        # theta's rates are per time unit: a guessed step scales them all, and nothing in the data shows it
        warnings.warn("dt was not given: the ODE is integrated with dt=1.0, one time unit between consecutive "
                      "outputs of y, and theta's rates are per that unit. Give the time between outputs, e.g. "
                      "HybridRegressor(..., structure=OdeStructure(dt=0.1)) for data sampled every 0.1 s "
                      "(dt=1.0 keeps the output step as the time unit, without this warning).", UserWarning,
                      stacklevel=3)
    y = None if y is None else check_not_nested(y)  # None: validate_data says y is required
    y_shape = () if y is None else y.shape[1:]
    if len(y_shape) > 1:  # scikit-learn validates 2-D targets; predict restores the shape
        y = np.reshape(y, (len(y), math.prod(y_shape)))
    # the estimator changes only in store_fit: a failed refit leaves the earlier fit whole
    # order="C": a reversed view (negative strides) reaches torch as a copy, which torch accepts
    (X, y), features = validate_into_copy(estimator, X, y, allow_nd=True, multi_output=True,
                                          y_numeric=True, dtype=np.float64, order="C")
    y = np.ascontiguousarray(y)  # order= reaches X only
    dtype, device = DTYPES[estimator.dtype], resolve_device(estimator.device)
    check_dtype_range(dtype, X, y)
    weight = check_sample_weight(sample_weight, len(y), dtype)
    try:
        seed = int(check_random_state(estimator.random_state).randint(np.iinfo(np.int32).max))
    except ValueError as error:  # numpy's message names neither the argument nor its value
        raise ValueError(f"random_state must be None, a RandomState or an integer in [0, 2**32 - 1], "
                         f"got {estimator.random_state!r}.") from error
    science = ScienceModel(estimator.science, estimator.theta_init, estimator.theta_bounds,
                           estimator.theta_fixed, dtype=dtype)
    structure = estimator._make_structure(warn=True)  # the fit says once that flat ODE options are deprecated
    X_struct = estimator._structure_X(X)
    structure.setup(X_struct, y_shape)
    with torch_threads(estimator.n_threads):
        inputs = structure.tensors(X_struct, dtype)  # copies: the science never sees the caller's X
        structure_inputs = inputs
        structure.probe(science, inputs)
        # seed init without touching global state; the lock keeps fits in other threads
        # (dask or joblib threading workers) from reseeding the shared generator meanwhile
        with _SEEDED_INIT, torch.random.fork_rng(devices=[]):
            torch.manual_seed(seed)
            in_shapes, out_shape = structure.residual_shapes()
            residual = build_residual(estimator.residual, in_shapes, out_shape, dtype)
            reduction = structure.make_reduction(dtype) if method.needs_reduction else None
            encoder = None
            if estimator.theta_encoder is not None:
                encoder = _encoder.make_theta_encoder(estimator.theta_encoder, science, X.shape[1:], dtype)
                inputs = inputs + (torch.tensor(X, dtype=dtype),)  # the window comes last
    target = torch.tensor(np.asarray(y), dtype=dtype)  # a copy (y may be read-only): read for scales, trained on
    if encoder is None and hasattr(structure, "choose_substeps"):
        with torch_threads(estimator.n_threads):
            structure.choose_substeps(science, inputs[0], target)
    scales = None
    with torch_threads(estimator.n_threads):  # the network trains in the data's scales, whatever the units
        if isinstance(structure, OdeStructure):
            scales = ode_data_scales(structure, science, structure_inputs, target, weight)
        elif isinstance(structure, ComposeStructure) and structure.residual_shapes()[0] is not None:
            scales = static_data_scales(structure, science, structure_inputs, target, weight)
    set_network_scales(residual, scales)
    model = HybridModule(science, residual, structure, reduction, encoder).to(device)
    inputs = tuple(t.to(device) for t in inputs)
    if encoder is not None:
        _encoder.probe_per_sample(model, inputs)
    config = TrainConfig(lr=estimator.lr, lr_theta=estimator.lr_theta, max_iter=estimator.max_iter,
                         batch_size=estimator.batch_size,
                         weight_decay=estimator.weight_decay, perturb=estimator.perturb,
                         verbose=estimator.verbose, tol=estimator.tol,
                         n_iter_no_change=estimator.n_iter_no_change,
                         # an encoder's weights are a network's, not theta's relative raw values
                         theta_lr_factor=1.0 if encoder is not None else THETA_LR_FACTOR)
    setup = Bunch(model=model, method=method, inputs=inputs,
                  y=target.to(device),
                  sample_weight=None if weight is None else weight.to(device),
                  config=config, seed=seed, y_shape=y_shape, x_shape=X.shape[1:],
                  features=features, scales=scales)
    return setup


def store_fit(estimator: BaseEstimator, setup: Bunch, history: dict, data=None, verdict=None) -> None:
    """Make ``estimator`` fitted with the model trained from ``setup`` (from :func:`prepare_fit`).

    With a theta encoder, ``theta_`` is the mean of the per-sample theta
    over the training inputs ``setup.inputs``.  ``data`` is ``(inputs, y,
    sample_weight)`` of the trained samples, for the standard errors of
    theta (default: all samples of ``setup``, unweighted).  ``verdict``
    (see :func:`~sklearn_hybrid.training.verdict.judge_training`) says whether the
    model is usable; ``fit_report`` repeats its reason.
    """
    model = setup.model
    model.eval()
    inputs, y, weight = data or (setup.inputs, setup.y, None)
    with torch_threads(estimator.n_threads):  # two passes without gradients: a free first screen for the report
        share = _network_share(model, inputs, setup.samples_per_pass)
    rows = _standard_error_rows(model, len(y), len(history["loss"]), estimator.batch_size, setup.seed)
    if rows is not None:  # the standard errors' passes over every sample would outweigh a short training
        inputs, y = tuple(t[rows] for t in inputs), y[rows]
        weight = None if weight is None else weight[rows]
    with torch_threads(estimator.n_threads):  # first: an error here must leave an earlier fit whole
        std, cov, _ = theta_uncertainty(model, inputs, y, weight, chunk=setup.samples_per_pass)
    if rows is not None:  # J^T W J grows with the samples: the subset's covariance, scaled to all of them
        scale = len(rows) / len(setup.y if data is None else data[1])
        cov = cov * scale
        std = {k: v * np.sqrt(scale) for k, v in std.items()}
    estimator._standard_error_samples = None if rows is None else (len(rows), len(data[1] if data else setup.y))
    estimator.model_, estimator.residual_ = model, model.residual
    estimator.theta_, estimator.history_ = model.science.as_dict(), history
    if model.encoder is not None:
        with torch_threads(estimator.n_threads), torch.no_grad():
            window = setup.inputs[-1]
            estimator.theta_.update(_encoder.summarize(model.encoder(window, model.science)))
    estimator.theta_std_, estimator.theta_cov_ = std, cov
    estimator.network_share_ = share
    estimator.y_shape_, estimator.x_shape_ = setup.y_shape, setup.x_shape
    estimator.device_ = setup.y.device
    estimator.n_substeps_ = getattr(model.structure, "n_substeps", None)
    estimator._samples_per_pass = setup.samples_per_pass  # what the fit's memory allows, for predict
    estimator.n_iter_ = len(history["loss"])
    estimator.stopped_early_ = estimator.n_iter_ < estimator.max_iter
    config = setup.config
    rates = history["lr_theta"] if "lr_theta" in history else \
        cosine_lr(config.theta_lr, estimator.n_iter_, config)  # a sweep member's history
    estimator.theta_drift_ = theta_drift(history["theta"], rates)
    if history.get("lr_halved_at"):
        warnings.warn(
            f"The training loss spiked at iterations {history['lr_halved_at']}; each time the last "
            "good state was restored and the learning rates halved. A lower lr would train more smoothly.",
            UserWarning, stacklevel=3)
    estimator._not_usable = None if verdict is None or verdict.usable else verdict.summary()
    estimator._fitted_params = estimator.get_params(deep=False)  # what the report and the structure check read
    # which fit this is: a profile records it, and fit_report refuses a profile of another fit
    estimator._fit_token = uuid.uuid4().hex
    set_feature_info(estimator, setup.features)


# What the package's own modules (the profiles, the network-free intervals and refits, the records and plots) ask
# of a fitted estimator.

def fitted_data(estimator: BaseEstimator, X, dtype: torch.dtype | None = None) -> tuple[np.ndarray, tuple]:
    """``X`` validated against the fit, and the fitted model's inputs for it.

    The inputs are tensors on the fit's device, in ``dtype`` (default: the dtype the model was fitted
    in), built without gradients.
    """
    X = estimator._fitted_X(X)
    with torch_threads(estimator.n_threads), torch.no_grad():
        inputs = estimator._inputs(X, dtype or estimator._fitted_dtype(), estimator.device_)
    return X, inputs


def fitted_settings(estimator: BaseEstimator) -> dict:
    """The estimator's parameters as they were at fit (``set_params`` since changes nothing here)."""
    check_is_fitted(estimator)
    # a fit pickled before the parameters at fit were kept: its current ones
    return dict(getattr(estimator, "_fitted_params", None) or estimator.get_params(deep=False))


def ode_structure(estimator: BaseEstimator) -> OdeStructure | None:
    """The ODE structure ``estimator`` fits, not set up (its options from ``structure`` and the
    estimator's keywords), or None for a static structure: what the package's modules ask instead
    of comparing ``estimator.structure`` with ``"ode"``, which an OdeStructure object is not."""
    structure = estimator._make_structure()
    return structure if isinstance(structure, OdeStructure) else None


def structure_X(estimator: BaseEstimator, X: np.ndarray) -> np.ndarray:
    """What the structure reads of validated ``X`` (the last state of each window with a theta encoder)."""
    return estimator._structure_X(X)
