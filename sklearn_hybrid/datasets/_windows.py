"""Training data from your own recordings: windows of a record and derivative estimates.

:func:`make_windows` cuts a sampled record into the ``X, y`` that
:class:`~sklearn_hybrid.HybridRegressor` fits (initial states, packed with the inputs for a forced
system, and the observed samples that follow each start); :func:`estimate_derivative` supplies
unmeasured velocities for those initial states.
"""

from __future__ import annotations

import numbers

import numpy as np
from sklearn.utils import Bunch

__all__ = ["make_windows", "estimate_derivative"]

# Seven-point central difference (sixth order): f'(t) ~ sum_k w_k f(t + (k - 3) dt) / dt.
_CENTRAL_WEIGHTS = np.array([-1, 9, -45, 0, 45, -9, 1]) / 60.0
DERIVATIVE_METHODS = ("savgol", "central")


def _as_record(name: str, a, n_samples: int | None = None) -> np.ndarray:
    """``a`` as a float (n_samples, n_channels) array; 1-D records become one channel."""
    a = np.asarray(a, dtype=float)
    if a.ndim == 1:
        a = a[:, None]
    if a.ndim != 2:
        raise ValueError(f"{name} must be a 1-D record or a 2-D array (n_samples, n_channels); "
                         f"got shape {a.shape}.")
    if n_samples is not None and len(a) != n_samples:
        raise ValueError(f"{name} has {len(a)} samples but y has {n_samples}; they must be sampled together.")
    return a


def _check_finite(name: str, a: np.ndarray, offset: int = 0) -> None:
    bad = ~np.isfinite(a)
    if bad.any():
        first = int(np.argwhere(bad)[0, 0]) + offset
        raise ValueError(f"{name} contains NaN or infinity ({int(bad.any(axis=1).sum())} samples, the first "
                         f"at sample {first}); cut the record or fill the gaps before windowing.")


def _check_int(name: str, value, minimum: int) -> int:
    if isinstance(value, bool) or not isinstance(value, numbers.Integral) or value < minimum:
        raise ValueError(f"{name} must be an integer >= {minimum}, got {value!r}.")
    return int(value)


def make_windows(y, u=None, *, length: int, stride: int = 1, start: int = 0, stop: int | None = None,
                 states=None) -> Bunch:
    """Cut a recording into initial states ``X`` and target windows ``y`` for a hybrid ODE.

    The window starting at sample ``s`` has the initial state ``states[s]``, the targets
    ``y[s + 1], ..., y[s + length]`` (one per ``dt`` of the estimator) and, for a forced system,
    the inputs ``u[s], ..., u[s + length]`` (from the start to the last target, as
    :func:`~sklearn_hybrid.pack_inputs` wants them). Windows start at ``start``,
    ``start + stride``, ... as long as their last sample lies before ``stop``.

    Parameters
    ----------
    y : array-like of shape (n_samples,) or (n_samples, n_observed)
        The measured (observed) signals, one row per sample.
    u : array-like of shape (n_samples,) or (n_samples, n_inputs), optional
        The inputs, sampled with ``y``. When given, ``X`` is packed with
        :func:`~sklearn_hybrid.pack_inputs` for an estimator with ``n_inputs > 0``.
    length : int
        Targets per window (the estimator's number of steps), at least 1.
    stride : int, default=1
        Samples between consecutive window starts.
    start, stop : int, default=0 and None (the end of the record)
        Only samples ``start <= t < stop`` are used, e.g. to leave a margin for a derivative
        estimate or to keep a test part of the record out of training.
    states : array-like of shape (n_samples,) or (n_samples, n_states), optional
        The full state at every sample (measured or estimated, e.g. ``y`` beside its
        :func:`estimate_derivative`); the rows at the window starts are the initial states.
        Default ``y``: every state is observed.

    Returns
    -------
    Bunch
        ``X`` : ndarray of shape (n_windows, n_states), or (n_windows, n_states + (length + 1) *
        n_inputs) when ``u`` is given; ``y`` : ndarray of shape (n_windows, length, n_observed);
        ``u`` : ndarray of shape (n_windows, length + 1, n_inputs) or None; ``starts`` : ndarray of
        shape (n_windows,), the sample index of each window's initial state.

    Raises
    ------
    ValueError
        For NaN or infinite values in the samples used, records of different lengths, a
        ``length``, ``stride``, ``start`` or ``stop`` out of range, or a record too short for one
        window.

    Examples
    --------
    >>> import numpy as np
    >>> from sklearn_hybrid.datasets import estimate_derivative, make_windows
    >>> t = np.arange(200) * 0.1
    >>> angle, torque = np.sin(t), np.cos(3 * t)
    >>> states = np.column_stack([angle, estimate_derivative(angle, dt=0.1)])
    >>> w = make_windows(angle, torque, length=10, stride=5, states=states)
    >>> w.X.shape, w.y.shape, w.starts[:3]
    ((38, 13), (38, 10, 1), array([ 0,  5, 10]))

    ``w.X`` and ``w.y`` fit ``HybridRegressor(..., dt=0.1, observed=[0], n_inputs=1)``.
    """
    y = _as_record("y", y)
    n = len(y)
    length = _check_int("length", length, 1)
    stride = _check_int("stride", stride, 1)
    start = _check_int("start", start, 0)
    stop = n if stop is None else _check_int("stop", stop, 1)
    if stop > n:
        raise ValueError(f"stop={stop} is beyond the end of the record ({n} samples).")
    if stop - start < length + 1:
        raise ValueError(f"The record is too short for one window: samples [{start}, {stop}) hold "
                         f"{max(stop - start, 0)}, and a window of length={length} needs {length + 1} "
                         "(its initial state and the targets after it).")
    states = y if states is None else _as_record("states", states, n)
    u = None if u is None else _as_record("u", u, n)
    for name, a in (("y", y), ("states", states), ("u", u)):
        if a is not None:
            _check_finite(name, a[start:stop], offset=start)
    starts = np.arange(start, stop - length, stride)
    Y = y[starts[:, None] + np.arange(1, length + 1)]
    if u is None:
        return Bunch(X=states[starts], y=Y, u=None, starts=starts)
    from ..structures import pack_inputs  # imports torch: only for forced systems

    U = u[starts[:, None] + np.arange(length + 1)]
    return Bunch(X=pack_inputs(states[starts], U), y=Y, u=U, starts=starts)


def estimate_derivative(y, dt: float = 1.0, *, method: str = "savgol", window_length: int = 15,
                        polyorder: int = 2) -> np.ndarray:
    """Time derivative of a sampled record, for the unmeasured rates of initial states.

    Parameters
    ----------
    y : array-like of shape (n_samples,) or (n_samples, n_channels)
        The record, sampled every ``dt``; channels are differentiated separately.
    dt : float, default=1.0
        Time between samples, in the time unit of the model.
    method : {"savgol", "central"}, default="savgol"
        ``"savgol"``: derivative of a local polynomial fit (Savitzky-Golay,
        ``scipy.signal.savgol_filter``), which smooths measurement noise; near the ends the
        polynomial of the first / last window is used. ``"central"``: seven-point central
        difference (exact for polynomials up to degree 6, no smoothing: for clean or
        oversampled signals); the three samples at each end use ``numpy.gradient``
        (second order).
    window_length, polyorder : int, default=15 and 2
        Samples per local fit (odd) and the polynomial degree; ``"savgol"`` only.

    Returns
    -------
    ndarray
        The derivative per time unit, with the shape of ``y``.

    Raises
    ------
    ValueError
        For NaN or infinite samples, a non-positive ``dt``, an unknown ``method``, invalid
        ``window_length`` / ``polyorder``, or a record shorter than the method needs (7 samples
        for ``"central"``, ``window_length`` for ``"savgol"``).

    Examples
    --------
    >>> import numpy as np
    >>> from sklearn_hybrid.datasets import estimate_derivative
    >>> t = np.arange(100) * 0.05
    >>> rate = estimate_derivative(np.sin(t), dt=0.05, method="central")
    >>> bool(np.abs(rate - np.cos(t))[3:-3].max() < 1e-8)
    True
    """
    a = np.asarray(y, dtype=float)
    record = _as_record("y", a)
    _check_finite("y", record)
    if isinstance(dt, bool) or not isinstance(dt, numbers.Real) or not np.isfinite(dt) or dt <= 0:
        raise ValueError(f"dt must be a positive number, got {dt!r}.")
    n = len(record)
    if method == "central":
        if n < len(_CENTRAL_WEIGHTS):
            raise ValueError(f"method='central' needs at least 7 samples; the record has {n}.")
        out = np.gradient(record, dt, axis=0, edge_order=2)
        out[3:-3] = sum(w * record[k:n - 6 + k] for k, w in enumerate(_CENTRAL_WEIGHTS)) / dt
    elif method == "savgol":
        from scipy.signal import savgol_filter

        window_length = _check_int("window_length", window_length, 3)
        polyorder = _check_int("polyorder", polyorder, 1)
        if window_length % 2 == 0 or polyorder >= window_length:
            raise ValueError(f"window_length must be odd and larger than polyorder; got window_length="
                             f"{window_length}, polyorder={polyorder}.")
        if n < window_length:
            raise ValueError(f"method='savgol' needs at least window_length={window_length} samples; "
                             f"the record has {n}.")
        out = savgol_filter(record, window_length, polyorder, deriv=1, delta=dt, axis=0)
    else:
        raise ValueError(f"Unknown method {method!r}; choose one of {DERIVATIVE_METHODS}.")
    return out.reshape(a.shape)
