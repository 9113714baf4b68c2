"""HybridRegressor: the scikit-learn face of hybrid model training."""

from __future__ import annotations

import copy
import numbers
import warnings

import numpy as np
import torch
from sklearn.base import BaseEstimator, RegressorMixin
from sklearn.exceptions import ConvergenceWarning
from sklearn.metrics import r2_score
from sklearn.utils.validation import check_is_fitted, validate_data

from .integrate.kernels import reusing_buffers
from . import encoder as _encoder
from .training.engine import DivergenceError, explain_nonfinite, train
from ._extras import EstimatorExtras, split_holdout
from ._fitting import DTYPES, ode_structure, prepare_fit, store_fit
from .training.memory import check_fit_memory, explained_memory_errors
from .training.verdict import explain_start, judge_training
from ._validation import check_positive, check_target_layout, given_settings, torch_threads
from .methods import method_of
from .structures import structure_of
from .structures.scales import describe_scales

__all__ = ["HybridRegressor"]

class HybridRegressor(EstimatorExtras, RegressorMixin, BaseEstimator):
    """Hybrid model ``science + neural network`` that estimates the science parameters.

    Parameters
    ----------
    science : callable
        The scientist's model, written with torch operations.  Arguments
        without a default are its inputs (the state ``v`` for ``"ode"``, plus
        the input ``u`` when ``n_inputs > 0``; the features ``x`` otherwise);
        arguments with a numeric default are the parameters theta, e.g.
        ``def pendulum_f(v, omega=0.5): ...``.  For ``"ode"`` it returns the
        known part of ``dv/dt``.
    structure : OdeStructure, {"ode", "compose", "additive"} or callable, default="ode"
        How science and network combine (see :mod:`sklearn_hybrid.structures`),
        as an object or by name, as scikit-learn takes ``kernel=RBF()`` or
        ``kernel="rbf"``: ``OdeStructure(dt=0.1, observed=[0])`` carries the
        ODE's options (the time between outputs ``dt``, the integration, the
        observed states, the inputs; see :class:`~sklearn_hybrid.OdeStructure`),
        and ``"ode"`` is the ODE with its defaults (``dt=1.0``, with a warning
        that dt was not given); a callable ``structure(x, f, g) -> y`` gives
        any nested composition.
    residual : str, dict or callable, default="mlp"
        Specification of the network g_phi (see
        :func:`sklearn_hybrid.residual.build_residual`); built inside ``fit``.
        ``"mlp"``: two hidden layers of 64 (ReLU) whose last layer starts at
        zero, so that training starts from the science model alone
        (``{"hidden": (128, 128), "zero_init": False}`` for a wider network
        with a random start).
    method : Method or {"erm", "p-reg", "f-reg", "sam", "asam", "fsam"}, default="fsam"
        Training method, an object of :mod:`sklearn_hybrid.methods` that
        carries its settings, such as ``FisherSAM(rho=0.1)`` (a grid search
        reaches them as ``method__rho``), or a name for the method with its
        defaults (``"fsam"``: ``FisherSAM(rho=0.05, eta=1.0)``).  The SAM
        family perturbs the network parameters only.
    rho, lam, eta : float
        Deprecated: the method's settings belong to the method object
        (``method=FisherSAM(rho=0.1)``, ``ParameterRegularization(lam=1e-2)``);
        given beside a name they still apply, with a ``FutureWarning``.
    perturb : {"residual", "all"}, default="residual"
        Perturb the network only (the paper's method) or every parameter
        (ordinary SAM, the paper's Table 2).
    theta_init : dict, optional
        Initial values overriding the science function's defaults.
    theta_bounds : dict, optional
        ``name -> (low, high)``, enforced by a smooth reparametrisation.
    theta_fixed : list of str or dict, optional
        Parameters kept constant: a list keeps them at their initial value
        (``theta_init`` or the default); a dict ``{"omega": 0.6}`` fixes each
        at its value (as lmfit's ``vary=False`` with a value; a value given
        in both ``theta_init`` and ``theta_fixed`` must agree).
    theta_encoder : str, dict, callable or None, default=None
        Theta that varies from sample to sample: an encoder network reads each
        sample ``X[i]`` and outputs that sample's free parameters, trained
        jointly (see :mod:`sklearn_hybrid.encoder`): ``"mlp"`` (256x2 ReLU
        over the flattened window), ``"cnn"`` (conv 288, 144 with batch norm
        and a dense 256 head, for fields), a dict of options or a factory
        ``factory(in_shape, n_out) -> torch.nn.Module``.  For ``"ode"``, ``X``
        then holds input windows ``(n, m_x, *state_shape)`` and the last state
        of each window is the initial state.  ``theta_bounds`` hold for every
        sample; ``theta_fixed`` parameters stay shared.  The encoder is part
        of theta: ``lr_theta``, no weight decay, perturbed by the SAM family
        only with ``perturb="all"``.
    dt, n_substeps, solver, observed, n_inputs, input_interp
        Deprecated: the ODE's options belong to the structure object,
        ``structure=OdeStructure(dt=0.1, observed=[0])``; given beside
        ``"ode"`` they still apply, with a ``FutureWarning`` (beside an
        ``OdeStructure`` they must agree with it).
    lr : float, default=1e-2
        Initial Adam learning rate, cosine-annealed to 1e-6 over ``max_iter``
        (with early stopping the fit usually ends while it is still high; on
        the pendulum task 1e-2 estimates theta better in 600 iterations than
        1e-3 in 2,000, see ``benchmarks/results/early_stopping.md``).
    lr_theta : float or None, default=None
        Initial learning rate of theta if it should differ from ``lr``.
        theta steps relative to its own size, so the rate means the same in
        any units: Adam moves theta's raw value by at most about its learning
        rate per step, and raw is theta over its starting size (without
        bounds), the softplus-inverse of its distance to a single bound over
        the starting distance, or with two finite bounds the logit of its
        position between them.  Over the cosine schedule raw moves by at most
        ``lr_theta * max_iter / 2`` in all: choose ``lr_theta`` so that this
        exceeds the relative distance theta may have to go (from its default
        to three times it is 2).  ``theta_drift_`` shows a theta that was
        still on its way when the schedule ended.
    max_iter : int, default=1000
        Largest number of optimisation steps (the cosine schedule spans it).
    tol : float or None, default=1e-3
        Early stopping: training stops once, over ``n_iter_no_change``
        iterations, the monitored loss improved by less than ``tol`` times
        the variance of ``y`` (R^2 improved by less than ``tol``) *and* no
        component of theta moved by more than ``tol`` relative to
        ``max(|theta|, 1e-3)``.  The monitored loss is the
        validation loss with ``validation_fraction``, else the training loss
        averaged over the window.  None trains for ``max_iter`` steps.
    n_iter_no_change : int, default=100
        Window of the early-stopping tests, in iterations.
    validation_fraction : float or None, default=None
        Fraction of the samples held out (seeded by ``random_state``) for the
        early-stopping validation loss; they are then not trained on.  None
        monitors the training loss.
    batch_size : int or None, default=None
        Mini-batch size; None trains on the full batch.
    weight_decay : float, default=1e-5
        Slight L2 decay of the network parameters (never of theta).
    dtype : {"float32", "float64"}, default="float32"
        Floating point type of the computation.
    device : {"cpu", "cuda", "cuda:N", "auto"} or torch.device, default="cpu"
        Where fit and predict run: ``"auto"`` takes a CUDA GPU when torch
        finds one, else the CPU; asking for ``"cuda"`` where there is none is
        an error.  The fast RK4 path is CPU-only; on a GPU hybrid ODEs train
        with the plain autograd loop, so a small ODE (a few states, a small
        network) trains faster on the CPU, while fields and images train far
        faster on a GPU (the user guide's page on scaling).
    n_threads : int or None, default=1
        torch threads during fit/predict (small models are fastest on one);
        None keeps torch's setting.
    random_state : int, RandomState or None, default=None
        Seeds network initialisation and mini-batches.  An int gives the same
        fit every time; None draws the seed from numpy's global random state
        (scikit-learn's convention), so repeated fits differ.  torch's global
        generator is never used or advanced.
    verbose : bool or "auto", default="auto"
        Show a progress bar on stderr with the loss, theta, the speed and the
        time left to ``max_iter`` (an early stop comes sooner): ``"auto"`` once
        a fit has run 5 seconds, in a terminal or a notebook (not in logs or
        captured output), so that a short fit prints nothing and a long one
        shows signs of life; True always, from the first iteration; False never.

    Attributes
    ----------
    theta_ : dict
        Estimated parameters (floats, or arrays for vector parameters); with a
        ``theta_encoder``, the mean over the training samples of
        :meth:`predict_theta` (``history_["theta"]`` then holds the mean over
        each iteration's batch).
    residual_ : torch.nn.Module
        The trained network g_phi.
    model_ : HybridModule
        Science part, network and structure together.
    history_ : dict
        ``"loss"`` (per iteration) and ``"theta"`` (name -> values per iteration).
    n_iter_ : int
        Number of optimisation steps taken (``max_iter`` unless stopped early).
    stopped_early_ : bool
        Whether early stopping ended the fit before ``max_iter``.
    theta_drift_ : dict of str to float
        How far each parameter still moved at the end of training: its largest
        relative change ``|theta_end - theta_start| / |theta_end|`` over the
        last iterations in which 10 % of theta's summed learning rate was
        spent (see ``sklearn_hybrid.training.schedule.theta_drift``).  A theta that
        settled moves by much less there than one the cosine schedule froze
        on its way (which moves about 10 % of its whole travel); a change of
        plain iterations would hide that, as the learning rate is close to
        zero over the last 10 % of them.  With a ``theta_encoder``, of the
        per-iteration batch mean.
    theta_std_ : dict
        Noise-only standard error of each parameter (0 for fixed ones), from
        the Gauss-Newton approximation of the data loss in theta with the
        network held fixed (see :meth:`fit_report`): the part of the
        uncertainty that independent noise in ``y`` makes, not what the
        network trades with theta, so no interval is built from it
        (``benchmarks/results/coverage.md``).  Whether the data identify
        theta, with an interval: :func:`~sklearn_hybrid.identifiability.profile_theta`.
    theta_cov_ : ndarray of shape (p, p)
        Covariance of the free parameters, flattened in the order of ``theta_``.
    network_share_ : float or None
        The network's share of the prediction on the training samples,
        ``RMS(hybrid - science alone) / RMS(hybrid)`` (see
        :func:`~sklearn_hybrid.network_share`): how much of the fit the
        science model leaves to the network.  :meth:`fit_report` reads it as a
        first screen.  None where the science alone predicts no ``y`` (a
        composition of your own).
    y_shape_ : tuple
        Per-sample shape of ``y`` in ``fit``, which ``predict`` returns.
    n_features_in_ : int
        Number of features (second axis of ``X``) seen in ``fit``.
    feature_names_in_ : ndarray of str
        Column names of ``X`` in ``fit``, when it was a DataFrame with string names.
    x_shape_ : tuple
        Per-sample shape of ``X`` in ``fit``, which ``predict`` requires.
    device_ : torch.device
        Where the fitted model lives (``device`` resolved).
    n_substeps_ : int or None
        ``"ode"``: the RK4 steps per output interval the fit used
        (``n_substeps`` resolved); None for other structures.

    Notes
    -----
    Units.  Write the science function in your own units: the fit reads the
    scales the data carry and trains in them.  The network (the package's MLP)
    reads each state standardised and writes each rate in units of the rate
    that state is observed to change at (a static model: each input, and the
    science's output it composes with, standardised, each target entry in
    units of its spread); theta steps relative to
    its starting size (so give a start of the right order of magnitude, not
    0, where you can); the gradients are taken in units of ``y``'s variance.
    ``theta_``, the reports and the intervals stay in your units.  What this
    cannot fix: states of very different units weigh in the loss by their
    squared size (standardise ``y`` per component yourself if that matters),
    and parameters that start 10 orders of magnitude off.
    """

    def __init__(self, science=None, *, structure="ode", residual="mlp", method="fsam",
                 rho="deprecated", lam="deprecated", eta="deprecated", perturb="residual", theta_init=None,
                 theta_bounds=None, theta_fixed=None, theta_encoder=None, dt="deprecated",
                 n_substeps="deprecated", solver="deprecated", observed="deprecated", n_inputs="deprecated",
                 input_interp="deprecated", lr=1e-2, lr_theta=None,
                 max_iter=1000, tol=1e-3, n_iter_no_change=100, validation_fraction=None,
                 batch_size=None, weight_decay=1e-5, dtype="float32", device="cpu",
                 n_threads=1, random_state=None, verbose="auto"):
        self.science = science
        self.structure = structure
        self.residual = residual
        self.method = method
        self.rho = rho
        self.lam = lam
        self.eta = eta
        self.perturb = perturb
        self.theta_init = theta_init
        self.theta_bounds = theta_bounds
        self.theta_fixed = theta_fixed
        self.theta_encoder = theta_encoder
        self.dt = dt
        self.n_substeps = n_substeps
        self.solver = solver
        self.observed = observed
        self.n_inputs = n_inputs
        self.input_interp = input_interp
        self.lr = lr
        self.lr_theta = lr_theta
        self.max_iter = max_iter
        self.tol = tol
        self.n_iter_no_change = n_iter_no_change
        self.validation_fraction = validation_fraction
        self.batch_size = batch_size
        self.weight_decay = weight_decay
        self.dtype = dtype
        self.device = device
        self.n_threads = n_threads
        self.random_state = random_state
        self.verbose = verbose

    def __sklearn_tags__(self):
        tags = super().__sklearn_tags__()
        tags.regressor_tags.poor_score = True  # few iterations in checks
        tags.target_tags.multi_output = True
        return tags

    def _check_params(self):
        if self.science is None:
            raise ValueError("HybridRegressor needs a science function: HybridRegressor(science=f).")
        check_positive("lr", self.lr)
        check_positive("lr_theta", self.lr_theta, allow_none=True)
        check_positive("max_iter", self.max_iter, integer=True)
        check_positive("tol", self.tol, allow_none=True)
        check_positive("n_iter_no_change", self.n_iter_no_change, integer=True)
        check_positive("batch_size", self.batch_size, integer=True, allow_none=True)
        check_positive("n_threads", self.n_threads, integer=True, allow_none=True)
        if not (isinstance(self.weight_decay, numbers.Real) and self.weight_decay >= 0):
            raise ValueError(f"weight_decay must be a non-negative number, got {self.weight_decay!r}.")
        if self.perturb not in ("residual", "all"):
            raise ValueError(f"perturb must be 'residual' or 'all', got {self.perturb!r}.")
        if self.dtype not in DTYPES:
            raise ValueError(f"dtype must be one of {list(DTYPES)}, got {self.dtype!r}.")
        return method_of(self.get_params(deep=False))

    def _dt_given(self) -> bool:
        """Whether the ODE's time step was given (in an OdeStructure, or the deprecated flat ``dt``)."""
        return not (isinstance(self.structure, str) and self.structure == "ode"
                    and not given_settings(self.get_params(deep=False), ("dt",), none_unset=("dt",)))

    def _make_structure(self, warn: bool = False):
        """A fresh structure from ``structure`` (and the deprecated flat ODE options; ``warn``: say so)."""
        return structure_of(self.get_params(deep=False), warn=warn)

    def fit(self, X, y, sample_weight=None):
        """Fit theta and the network to data.

        Parameters
        ----------
        X : array-like of shape (n_samples, ...)
            Inputs of the structure (initial states for ``"ode"``).
        y : array-like of shape (n_samples, ...)
            Targets (observed states at the output times for ``"ode"``),
            any per-sample shape; ``predict`` returns the same shape.
        sample_weight : array-like of shape (n_samples,), optional
            Non-negative weight of each sample in the data loss (each
            sample's mean squared error counts in proportion to its weight,
            as :meth:`score` weighs it).

        Returns
        -------
        self : HybridRegressor
            The fitted estimator.  If training diverges, a
            :class:`~sklearn_hybrid.training.engine.DivergenceError` is raised and an
            earlier fit is left untouched.
        """
        setup = prepare_fit(self, X, y, sample_weight)
        with torch_threads(self.n_threads):
            setup.samples_per_pass = check_fit_memory(setup)
        weight = setup.sample_weight
        inputs, y_t, validation = split_holdout(setup, weight, self.validation_fraction)
        weight = validation.pop("train_weight")
        science = setup.model.science
        theta_start = None if setup.model.encoder is not None else {
            name: value for name, value in science.as_dict().items() if science.raw[name].requires_grad}
        initial = copy.deepcopy(setup.model.state_dict())  # for the diagnosis of a start that blows up
        with torch_threads(self.n_threads), reusing_buffers(), explained_memory_errors(setup):
            try:
                history = train(setup.model, setup.method, inputs, y_t, setup.config,
                                torch.Generator().manual_seed(setup.seed), sample_weight=weight,
                                validation=validation.get("data"))
            except DivergenceError as error:  # a lower lr cannot help a model that blows up at its start
                cause = explain_start(setup.model, initial, inputs, y_t, setup.samples_per_pass)
                raise DivergenceError(f"{cause or error}{self._scales_note(setup)}") from error
            # a run that diverged is refused here, before it can replace an earlier fit
            verdict = judge_training(setup.model, history, inputs, y_t, weight, theta_start=theta_start,
                                     batch_size=self.batch_size, chunk=setup.samples_per_pass,
                                     advice=self._training_advice(setup.method))
        store_fit(self, setup, history, (inputs, y_t, weight), verdict=verdict)
        if not verdict.usable:
            warnings.warn(f"The fitted model is not usable: {verdict.summary()}. "
                          f"{self._training_advice(setup.method)}{self._scales_note(setup)} "
                          "fit_report() says so too.",
                          ConvergenceWarning, stacklevel=2)
        return self

    def _scales_note(self, setup) -> str:
        """The data's scales, and a forgotten ``dt``, beside the advice after a training that went bad."""
        note = describe_scales(setup.scales)
        if not self._dt_given() and setup.scales is not None:
            note += (" dt was not given, so one time unit was taken between outputs: if the data were sampled "
                     "at another step, every rate is off by that factor; give structure=OdeStructure(dt=...).")
        return f" {note}" if note else ""

    def _training_advice(self, method):
        """What to change after a training that went bad."""
        rho = f" or rho (rho={method.rho})" if method.perturbs and hasattr(method, "rho") else ""
        return f"Lower lr (lr={self.lr}){rho}, check the data scale, or bound theta with theta_bounds."
    def _structure_X(self, X):
        """What the structure reads of ``X`` (the last state of each window with an encoder)."""
        if self.theta_encoder is None:
            return X
        ode = ode_structure(self)
        if ode is not None and ode.n_inputs:
            raise ValueError("theta_encoder does not support forced ODEs (n_inputs > 0) yet.")
        return _encoder.split_window(ode is not None, X)

    def _inputs(self, X, dtype, device):
        """Model inputs of validated ``X``: the structure's tensors, then the encoder's window."""
        model = self.model_
        inputs = model.structure.tensors(self._structure_X(X), dtype)
        if model.encoder is not None:
            inputs = inputs + (torch.tensor(X, dtype=dtype),)
        return tuple(t.to(device) for t in inputs)
    def _fitted_X(self, X):
        """``X`` validated against the fit: feature count and per-sample shape."""
        check_is_fitted(self)
        shape = tuple(np.shape(X)) if len(self.x_shape_) > 1 else None  # fields, images: "features" misleads
        if shape is not None and shape[1:] != self.x_shape_:
            one = " (a single sample needs its leading axis: X[None])" if shape == self.x_shape_ else ""
            raise ValueError(f"X has per-sample shape {shape[1:]}; this model was fitted on {self.x_shape_}{one}.")
        X = validate_data(self, X, reset=False, allow_nd=True, dtype=np.float64, order="C")
        if X.shape[1:] != self.x_shape_:
            raise ValueError(
                f"X has per-sample shape {X.shape[1:]}; this model was fitted on {self.x_shape_}."
            )
        return X

    def _fitted_dtype(self):
        """The dtype the model was fitted in, whatever ``set_params`` says since."""
        return next(self.model_.science.parameters()).dtype

    def _forward(self, X, use_residual=True, trace=False):
        check_is_fitted(self)
        self._check_structure_unchanged()
        X = self._fitted_X(X)
        model = self.model_
        dtype, device = self._fitted_dtype(), self.device_
        parts = []
        # in chunks decided at fit from its memory: memory then grows with the chunk, not with
        # len(X) (512 image sequences at once may not fit; 512 pendulum states do)
        chunk = self._samples_per_pass
        with torch_threads(self.n_threads), torch.no_grad():
            for start in range(0, max(len(X), 1), chunk):
                inputs = self._inputs(X[start:start + chunk], dtype, device)
                pred, extras = model(*inputs, use_residual=use_residual)
                if not torch.isfinite(pred).all():
                    bad = (~torch.isfinite(pred.reshape(len(pred), -1)).all(dim=1)).nonzero()
                    raise ValueError(
                        f"The prediction is not finite for sample(s) "
                        f"{(bad[:5, 0] + start).tolist()} of X. "
                        + (explain_nonfinite(model, inputs) or
                           "The science function stays finite there: the network or the "
                           "integration blew up (X far outside the training data?).")
                    )
                parts.append(model.trace(inputs, pred, extras) if trace else pred)
        if trace:
            return {k: None if parts[0][k] is None else torch.cat([p[k] for p in parts])
                    for k in parts[0]}
        pred = torch.cat(parts)
        return pred.cpu().numpy().astype(np.float64).reshape(len(X), *self.y_shape_)

    def predict(self, X):
        """Predict targets with the fitted hybrid model.

        Parameters
        ----------
        X : array-like of shape (n_samples, ...)
            Inputs, shaped as in ``fit``.

        Returns
        -------
        ndarray of shape (n_samples, ...)
            Shaped as ``y`` in ``fit``.
        """
        return self._forward(X)

    def predict_theta(self, X) -> dict:
        """Each sample's parameters theta.

        Parameters
        ----------
        X : array-like of shape (n_samples, ...)
            Inputs, shaped as in ``fit`` (windows with a ``theta_encoder``).

        Returns
        -------
        dict of str to ndarray
            ``name -> (n_samples, *shape)``: the encoder's output with a
            ``theta_encoder`` (fixed parameters repeated), ``theta_`` repeated
            for every sample otherwise.
        """
        X = self._fitted_X(X)
        model, n = self.model_, len(X)
        per_sample = {}
        if model.encoder is not None:
            with torch_threads(self.n_threads), torch.no_grad():
                window = torch.tensor(X, dtype=self._fitted_dtype(), device=self.device_)
                theta = model.encoder(window, model.science)
                per_sample = {k: v.cpu().numpy().astype(np.float64) for k, v in theta.items()}
        return {name: per_sample[name] if name in per_sample
                else np.repeat(np.asarray(value, dtype=np.float64)[None], n, axis=0)
                for name, value in self.theta_.items()}

    def predict_science(self, X):
        """Predict with the science part alone (fitted theta, network switched off).

        For ``"ode"`` the science model is integrated without g_phi; for
        ``"additive"`` it is f_theta(x); for ``"compose"`` it is f_theta(x)
        (or A f_theta(x) after ``method="f-reg"``) where that has y's shape.
        With a ``theta_encoder`` each sample uses its own theta (see
        :meth:`predict_theta`).

        Parameters
        ----------
        X : array-like of shape (n_samples, ...)
            Inputs, shaped as in ``fit``.

        Returns
        -------
        ndarray of shape (n_samples, ...)
            Shaped as ``y`` in ``fit``.
        """
        return self._forward(X, use_residual=False)

    def residual_trace(self, X):
        """What the network contributes, and where, along the predictions for ``X``.

        Parameters
        ----------
        X : array-like of shape (n_samples, ...)
            Inputs, shaped as in ``fit``.

        Returns
        -------
        dict of ndarray
            ``"points"``: where g_phi acts (for ``"ode"`` the predicted states at
            time 0 and every output time, stacked; otherwise ``X``);
            ``"inputs"``: the measured inputs at those points (forced ODEs) or
            None; ``"residual"``: the network's contribution there (g_phi(v)
            for ``"ode"`` and ``"additive"``, prediction minus science-only
            prediction for ``"compose"``).
        """
        out = self._forward(X, trace=True)
        return {k: None if v is None else v.cpu().numpy().astype(np.float64) for k, v in out.items()}

    def score(self, X, y, sample_weight=None):
        """R^2 of the prediction over all output values (targets flattened per sample)."""
        pred = self.predict(X)
        n = len(pred)
        y = check_target_layout(y, pred)
        return r2_score(y.reshape(n, -1), pred.reshape(n, -1), sample_weight=sample_weight)
