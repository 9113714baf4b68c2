"""Residual diagnosis: what does the network of a fitted hybrid model contribute, in named terms?

:class:`ResidualDiagnosis` evaluates the network's contribution where it acts (for a hybrid ODE,
``g_phi`` at the predicted states; for a composition, prediction minus science-only prediction),
builds a :class:`~sklearn_hybrid.diagnosis.CandidateLibrary` over the named states and inputs, and
explains every residual component with a :class:`~sklearn_hybrid.diagnosis.SparseTermRegression`.

The network often also compensates a bias of the science parameters (e.g. a slightly wrong
frequency). Such a correction is, to first order, ``sum_k (df/dtheta_k) dtheta_k``; so the
sensitivities of the science output to each free parameter join the candidates as terms named
``df/d<name>`` (not those of ``theta_fixed``: a fixed parameter cannot absorb a shift, so what it would
express, such as a damping held at zero, is a term to name), and library terms the science function already contains (within its parameters'
span) are left out. A selected ``df/d<name>`` term says "shift theta by its coefficient", not
"add a term".

A network also fits noise, and sparse regression on what it learned finds terms there too, each
stable under the bootstrap. Given ``y``, every new term must pass the test that
:func:`~sklearn_hybrid.diagnosis.close_the_loop` applies: the science model with the term,
refitted without the network, predicts held-out samples better by more than the noise explains. Exact equations (an ODE component whose science output depends on no
parameter, such as ``d angle/dt = velocity``) are left alone, as there.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Mapping, Sequence
from numbers import Real
from typing import Any

import numpy as np
from sklearn.base import BaseEstimator, clone
from sklearn.utils import check_random_state
from sklearn.utils.validation import check_is_fitted

from ..._fitting import ode_structure
from ..._validation import check_positive

from ..judge import judge_terms
from ..evidence import Evidence, held_out_splits
from .library import CandidateLibrary
from ..sensitivity import exact_components, root_mean_square, science_sensitivities, state_labels
from .regression import SparseTermRegression

__all__ = ["ResidualDiagnosis"]

_CONTAINED_R2 = 0.99  # a library term this well explained by the parameter sensitivities is redundant
_SENS = "df/d"


class ResidualDiagnosis(BaseEstimator):
    """Explain the network part of a fitted hybrid model by sparse regression on named terms.

    Parameters
    ----------
    state_names : list of str, optional
        Names of the state components (``"ode"``) or of the feature columns (static structures);
        default ``x0, x1, ...``.
    input_names : list of str, optional
        Names of the measured inputs of a forced ODE; default ``u0, u1, ...``.
    units : dict of str to str, optional
        Units of the variables, shown in the equations.
    library : CandidateLibrary, optional
        Candidate terms (cloned); default polynomials up to degree 3 without a constant.
    regression : SparseTermRegression, optional
        The sparse regression (cloned per component); default EBIC with 50 bootstrap resamples.
    components : list of int, optional
        Residual components to explain; default every component whose residual is at least
        ``min_residual`` of the total (science + network) there.
    min_residual : float, default=0.01
        Components whose residual RMS is below this fraction of the total RMS are skipped: the
        science model already explains them.
    exact : "auto", list of str or int, or None, default="auto"
        ODE components whose science equation is exact, never explained by default (as in
        :func:`~sklearn_hybrid.diagnosis.close_the_loop`): ``"auto"`` takes those whose science
        output depends on no free parameter at the visited states; ``None``: none.
    validation_fraction, z, min_gain : float
        Deprecated: set them in ``evidence`` (``Evidence(z=4.0)``), as for ``close_the_loop``.
    science_terms : bool, default=True
        Add the science output's sensitivities ``df/d<name>`` to the free parameters (not those of the
        estimator's ``theta_fixed``) as candidates (see module).
    max_points : int, default=20000
        Subsample the visited points to at most this many (seeded by ``random_state``).
    random_state : int, RandomState or None, default=None
        Seeds the subsampling and the bootstrap.
    evidence : Evidence, optional
        With ``y`` given to :meth:`fit`, the test each new term must pass
        (:class:`~sklearn_hybrid.diagnosis.Evidence`, the closed loop's own): the last
        ``validation_fraction`` of the samples judge, and a term must lower their error by
        ``min_gain`` and by more than ``z`` standard errors. Default ``Evidence()``.

    Attributes
    ----------
    variable_names_ : list of str
        States then inputs, the variables of the library.
    points_ : ndarray of shape (n_points, n_variables)
        Where the residual was evaluated.
    residual_ : ndarray of shape (n_points, n_components)
        The network's contribution there.
    science_ : ndarray of shape (n_points, n_components) or None
        The science output there (None where it has another shape than the residual).
    output_names_ : list of str
        ``g[<state>]`` per component.
    components_ : list of int
        Components that were explained.
    exact_ : list of int
        Exact components (see ``exact``).
    residual_share_ : ndarray of shape (n_components,)
        RMS of the residual over RMS of science + residual, per component (NaN when unknown).
    regressions_ : dict of int to SparseTermRegression
        The fitted regression of each explained component.
    terms_ : list of dict
        Every selected term: ``component``, ``output``, ``term``, ``coef``, ``explained``,
        ``inclusion``, ``unit`` and ``kind`` (``"term"`` for a new term, ``"theta"`` for a
        parameter sensitivity); with ``y``, a new term's ``evidence`` (its held-out verdict) and
        ``kept`` (whether it passed).
    theta_shift_ : dict of str to float
        Parameter corrections read off the selected sensitivity terms.
    """

    def __init__(self, state_names: Sequence[str] | None = None, input_names: Sequence[str] | None = None,
                 units: Mapping[str, str] | None = None, library: CandidateLibrary | None = None,
                 regression: SparseTermRegression | None = None, components: Sequence[int] | None = None,
                 min_residual: float = 0.01, exact: Any = "auto", validation_fraction: Any = "deprecated",
                 z: Any = "deprecated", min_gain: Any = "deprecated", science_terms: bool = True,
                 max_points: int = 20000, random_state: Any = None, evidence: Evidence | None = None) -> None:
        self.state_names = state_names
        self.input_names = input_names
        self.units = units
        self.library = library
        self.regression = regression
        self.components = components
        self.min_residual = min_residual
        self.exact = exact
        self.validation_fraction = validation_fraction
        self.z = z
        self.min_gain = min_gain
        self.science_terms = science_terms
        self.max_points = max_points
        self.random_state = random_state
        self.evidence = evidence

    # ------------------------------------------------------------------ fitting
    def fit(self, estimator: Any, X: Any, y: Any = None) -> "ResidualDiagnosis":
        """Evaluate the residual of ``estimator`` along ``X`` and explain it.

        Parameters
        ----------
        estimator : fitted HybridRegressor
            With structure ``"ode"``, ``"additive"`` or ``"compose"``.
        X : array-like
            Inputs, shaped as in the estimator's ``fit`` (typically its training data).
        y : array-like, optional
            The targets of ``X``: every new term is then judged on held-out samples, and only
            those that pass are in :attr:`new_terms_`. Without ``y`` the terms are not judged
            (a warning says so when any is selected): a network also fits noise.

        Returns
        -------
        self : ResidualDiagnosis
        """
        check_is_fitted(estimator, "model_")
        share = self.min_residual
        if isinstance(share, bool) or not (isinstance(share, Real) and 0 <= share < 1):
            raise ValueError(f"min_residual must be in [0, 1), got {self.min_residual!r}.")
        check_positive("max_points", self.max_points, integer=True)
        test = self._check_y(estimator, X, y) if y is not None else None
        trace = estimator.residual_trace(X)
        points = trace["points"].reshape(len(trace["points"]), -1)
        inputs = trace["inputs"]
        residual = trace["residual"].reshape(len(points), -1)
        rng = check_random_state(self.random_state)
        if len(points) > self.max_points:  # the regression needs thousands of points, not millions
            keep = np.sort(rng.choice(len(points), self.max_points, replace=False))
            points, residual = points[keep], residual[keep]
            inputs = None if inputs is None else inputs[keep]
        states = state_labels(self.state_names, points.shape[1], "x", "state_names")
        names = list(states)
        Z, args = points, [points.reshape(len(points), *trace["points"].shape[1:])]
        if inputs is not None:
            names += state_labels(self.input_names, inputs.shape[1], "u", "input_names")
            Z, args = np.hstack([points, inputs]), args + [inputs]
        if len(set(names)) != len(names):
            raise ValueError(f"State and input names must be unique, got {names}.")
        self.variable_names_, self.points_, self.residual_ = names, Z, residual
        ode = ode_structure(estimator) is not None
        self.output_names_ = [f"g[{s}]" for s in states] if ode and residual.shape[1] == len(states) else \
            [f"g[{j}]" for j in range(residual.shape[1])]

        f, jac, pnames = science_sensitivities(estimator, args)
        same_shape = f.shape == residual.shape
        self.science_ = f if same_shape else None
        total = root_mean_square(f + residual) if same_shape else np.full(residual.shape[1], np.nan)
        self.residual_share_ = root_mean_square(residual) / np.where(total > 0, total, np.nan)
        self.exact_ = self._exact(estimator, jac, pnames, states) if ode and same_shape else []
        if self.components is None:
            chosen = [j for j in range(residual.shape[1]) if j not in self.exact_
                      and not (self.residual_share_[j] < self.min_residual) and np.any(residual[:, j] != 0)]
        else:
            if np.ndim(self.components) != 1:
                raise ValueError(f"components must be a list of residual component indices, got {self.components!r}.")
            chosen = [int(j) for j in self.components]
            bad = [j for j in chosen if not 0 <= j < residual.shape[1]]
            if bad:
                raise ValueError(f"components {bad} out of range for {residual.shape[1]} residual components.")
        self.components_ = chosen

        library = clone(self.library) if self.library is not None else CandidateLibrary(degree=3, include_bias=False)
        if self.units is not None and library.units is None:
            library.set_params(units=dict(self.units))
        library.fit(Z, feature_names=names)
        Theta = library.transform(Z)
        lib_names, lib_units = list(library.term_names_), library.term_units_
        self.library_ = library
        template = self.regression if self.regression is not None else SparseTermRegression(n_bootstrap=50)
        fixed = set(estimator.theta_fixed or ())
        self.regressions_, self.terms_, self._columns = {}, [], {}
        for j in chosen:
            S = jac[:, j, :] if (self.science_terms and same_shape) else np.zeros((len(Z), 0))
            # a parameter held fixed (theta_fixed) cannot absorb a shift: its sensitivity is no candidate, else
            # an effect it would express (a damping fixed at zero) is read as its correction and never named
            live = [k for k in range(S.shape[1]) if pnames[k].split("[")[0] not in fixed
                    and np.max(np.abs(S[:, k])) > 1e-12 * max(1.0, np.max(np.abs(f)))]
            S, snames = S[:, live], [f"{_SENS}{pnames[k]}" for k in live]
            keep = [i for i in range(Theta.shape[1]) if not self._contained(Theta[:, i], S)]
            seed = rng.randint(np.iinfo(np.int32).max)
            while True:  # rerun without library terms the science parameters can stand in for
                Xj = np.hstack([Theta[:, keep], S])
                tnames = [lib_names[i] for i in keep] + snames
                tunits = None if lib_units is None else [lib_units[i] for i in keep] + [""] * len(snames)
                reg = clone(template)
                if "random_state" in reg.get_params() and reg.random_state is None:
                    reg.set_params(random_state=seed)
                reg.fit(Xj, residual[:, j], tnames, term_units=tunits, output_names=[self.output_names_[j]])
                redundant = self._replaceable(Xj, residual[:, j], reg.support_[0], len(keep),
                                              getattr(reg, "min_explained", 0.01))
                if not redundant:
                    break
                keep = [i for n, i in enumerate(keep) if n not in redundant]
            self.regressions_[j], self._columns[j] = reg, Xj
            for i in np.flatnonzero(reg.support_[0]):
                name = str(reg.term_names_[i])
                self.terms_.append({
                    "component": j, "output": self.output_names_[j], "term": name,
                    "coef": float(reg.coef_[0, i]), "explained": float(reg.explained_fraction_[0, i]),
                    "inclusion": float(reg.inclusion_frequency_[0, i]),
                    "unit": "" if tunits is None else tunits[i],
                    "kind": "theta" if name.startswith(_SENS) else "term"})
        self.theta_shift_ = self._theta_shift()
        self._judge(estimator, X, y, names, len(states), test)
        return self

    def _judge(self, estimator, X, y, variables, n_states, test: Evidence | None) -> None:
        """Hold the new terms to the held-out test (strongest first), or warn that they were not."""
        new = sorted((t for t in self.terms_ if t["kind"] == "term"), key=lambda t: -t["explained"])
        if not new:
            return
        if y is None or self.science_ is None:
            why = ("without y" if y is None else
                   "as the science output is not shaped like the residual, so no term can be added to it")
            warnings.warn(f"The {len(new)} new term(s) were not judged on held-out data ({why}): a network also "
                          "fits noise. Pass y to keep only the terms that held-out samples support.",
                          UserWarning, stacklevel=3)
            return
        library = {term.name: term for term in self.library_.terms_}  # each name's Term, added as it is
        placed = [{**t, "term": library[t["term"]]} for t in new]
        verdicts = judge_terms(estimator, X, y, placed, variables, n_states,
                               validation_fraction=test.validation_fraction, z=test.z, min_gain=test.min_gain)
        for t, verdict in zip(new, verdicts):
            t["evidence"], t["kept"] = verdict, verdict["accepted"]

    def _check_y(self, estimator, X, y) -> Evidence:
        """The judge's options and ``y``'s layout, before anything is computed: the judge runs last."""
        test = self._evidence()
        if getattr(estimator, "theta_encoder", None) is not None:
            raise ValueError("ResidualDiagnosis cannot judge terms of a model with a theta_encoder: its network-free "
                             "refits hold one theta shared by every sample. Fit it without y to read the terms.")
        shape, fitted = np.shape(y), tuple(getattr(estimator, "y_shape_", ()))
        if shape[:1] != np.shape(X)[:1]:
            raise ValueError(f"y has {shape[0] if shape else 0} samples and X {len(X)}: give the targets of X.")
        if shape[1:] != fitted and shape[1:] != (math.prod(fitted),):
            raise ValueError(f"y has per-sample shape {shape[1:]}; the estimator was fitted on y of per-sample "
                             f"shape {fitted}. Give the targets of X in the layout of the fit.")
        held_out_splits(len(y), test.validation_fraction)  # enough samples to judge a term
        return test

    def _evidence(self) -> Evidence:
        """The held-out test: ``evidence``, or the deprecated flat settings (with a FutureWarning)."""
        flat = {k: getattr(self, k) for k in ("validation_fraction", "z", "min_gain")
                if not (isinstance(getattr(self, k), str) and getattr(self, k) == "deprecated")}
        if flat and self.evidence is not None:
            raise ValueError(f"ResidualDiagnosis got both evidence and {sorted(flat)}: set them in evidence only, "
                             f"e.g. Evidence({', '.join(f'{k}={v!r}' for k, v in flat.items())}).")
        if flat:
            warnings.warn(f"ResidualDiagnosis({', '.join(f'{k}=...' for k in flat)}) is deprecated and will be "
                          f"removed: pass evidence=Evidence({', '.join(f'{k}={v!r}' for k, v in flat.items())}), "
                          "as close_the_loop takes it.", FutureWarning, stacklevel=4)  # from fit
        if self.evidence is not None and not isinstance(self.evidence, Evidence):
            raise TypeError(f"evidence must be an Evidence object such as Evidence(z=4.0), got "
                            f"{type(self.evidence).__name__}.")
        test = self.evidence if self.evidence is not None else Evidence(**flat)
        test.check()
        if test.cv is not None or test.groups is not None:
            raise ValueError("ResidualDiagnosis judges its terms on the last validation_fraction of the samples: "
                             "Evidence(cv=...) and groups are the closed loop's (close_the_loop(evidence=...)).")
        return test

    def _exact(self, estimator, jac, pnames, states) -> list[int]:
        """The exact components: named in ``exact``, or (``"auto"``) those whose science output
        depends on no free parameter at the visited points."""
        if self.exact is None:
            return []
        if isinstance(self.exact, str) and self.exact == "auto":  # close_the_loop's rule, at the visited points
            return exact_components(jac, pnames, set(estimator.theta_fixed or ())) or []
        items = [self.exact] if isinstance(self.exact, (str, int)) else list(self.exact)
        out = []
        for item in items:
            j = states.index(item) if isinstance(item, str) and item in states else item
            if isinstance(j, bool) or not isinstance(j, (int, np.integer)) or not 0 <= j < len(states):
                raise ValueError(f"exact entry {item!r} is neither a state name of {states} nor an index below "
                                 f"{len(states)}; give 'auto', None or a list of them.")
            out.append(int(j))
        return out

    @staticmethod
    def _replaceable(X: np.ndarray, r: np.ndarray, support: np.ndarray, n_library: int, tol: float) -> set[int]:
        """Selected library columns that the sensitivity columns (the last ones) can replace.

        A term whose removal, with every parameter sensitivity allowed in its place, costs less
        than ``tol`` of ``sum(r^2)`` is a parameter correction in disguise (e.g. ``v`` standing
        in for a frequency error multiplying ``sin(v)``).
        """
        if X.shape[1] == n_library:
            return set()
        sens = list(range(n_library, X.shape[1]))

        def rss(cols):
            A = X[:, cols]
            return float(np.sum((r - A @ np.linalg.lstsq(A, r, rcond=None)[0]) ** 2)) if cols else float(r @ r)

        chosen = list(np.flatnonzero(support))
        base = rss(chosen)
        out = set()
        for i in (c for c in chosen if c < n_library):
            others = [c for c in chosen if c != i and c < n_library] + sens
            if rss(others) - base < tol * float(r @ r):
                out.add(int(i))
        return out

    @staticmethod
    def _contained(column: np.ndarray, S: np.ndarray) -> bool:
        """Whether ``column`` lies (to R^2 > 0.999) in the span of the sensitivities ``S``."""
        if S.shape[1] == 0 or not np.any(column):
            return not np.any(column)
        coef = np.linalg.lstsq(S, column, rcond=None)[0]
        return 1 - np.sum((column - S @ coef) ** 2) / np.sum(column**2) > _CONTAINED_R2

    def _theta_shift(self) -> dict[str, float]:
        """Per parameter, the correction of the component where that sensitivity explains most."""
        best: dict[str, tuple[float, float]] = {}
        for t in self.terms_:
            if t["kind"] == "theta":
                name = t["term"][len(_SENS):]
                if name not in best or t["explained"] > best[name][1]:
                    best[name] = (t["coef"], t["explained"])
        return {name: coef for name, (coef, _) in best.items()}

    # ------------------------------------------------------------------ reporting
    @property
    def new_terms_(self) -> list[dict]:
        """The selected terms that the science model lacks (``kind == "term"``), held-out evidence
        permitting (``kept``, where ``fit`` was given ``y``)."""
        check_is_fitted(self, "terms_")
        return [t for t in self.terms_ if t["kind"] == "term" and t.get("kept", True)]

    def equations(self, precision: int = 3) -> list[str]:
        """Readable equations of the explained components, e.g. ``"g[v_dot] = -0.5 v_dot"``."""
        check_is_fitted(self, "terms_")
        return [line for j in self.components_ for line in self.regressions_[j].equations(precision)]

    def summary(self) -> str:
        """Text report: residual share per component, selected terms, stability, explained fraction."""
        check_is_fitted(self, "terms_")
        lines = [f"Residual diagnosis over {len(self.points_)} points; variables {self.variable_names_}"]
        for j, name in enumerate(self.output_names_):
            share = self.residual_share_[j]
            status = ("explained below" if j in self.components_ else "exact, left alone" if j in self.exact_
                      else "skipped (science explains it)")
            lines.append(f"{name}: residual RMS {root_mean_square(self.residual_[:, j]):.4g}"
                         + ("" if np.isnan(share) else f" = {share:.1%} of science + network") + f", {status}")
        for j in self.components_:
            lines.append(self.regressions_[j].summary())
        for t in self.terms_:
            if "evidence" in t:
                e = t["evidence"]
                lines.append(f"{t['term']} on {t['output']}: " + (f"refit failed ({e['failed']})" if "failed" in e else
                             f"held-out gain {e['gain']:.1%}, z {e['z']:.2f} against {e['threshold']:.2f}")
                             + (": kept" if t["kept"] else ": not supported by held-out data, left out"))
        if self.theta_shift_:
            lines.append("Parameter corrections the network carries: "
                         + ", ".join(f"{k} {v:+.4g}" for k, v in self.theta_shift_.items()))
        lines.append("Equations: " + "; ".join(self.equations()))
        return "\n".join(lines)

    def plot(self, axes: Any = None) -> np.ndarray:
        """Residual against each selected term (partial residual: the other terms removed).

        Parameters
        ----------
        axes : array of matplotlib Axes, optional
            One per selected term; a new figure when None.

        Returns
        -------
        axes : ndarray of matplotlib Axes
        """
        check_is_fitted(self, "terms_")
        import matplotlib.pyplot as plt  # optional dependency, imported when plotting

        terms = self.terms_
        if not terms:
            raise ValueError("No term was selected; there is nothing to plot.")
        if axes is None:
            _, axes = plt.subplots(1, len(terms), figsize=(4 * len(terms), 3.5), squeeze=False)
        axes = np.atleast_1d(np.asarray(axes, dtype=object)).ravel()
        if axes.size != len(terms):
            raise ValueError(f"axes has {axes.size} Axes but {len(terms)} terms were selected.")
        for ax, t in zip(axes, terms):
            j, reg = t["component"], self.regressions_[t["component"]]
            col = list(reg.term_names_).index(t["term"])
            x = self._columns[j][:, col]
            partial = self.residual_[:, j] - self._columns[j] @ reg.coef_[0] + t["coef"] * x
            order = np.argsort(x)
            ax.scatter(x, partial, s=3, alpha=0.4)
            ax.plot(x[order], t["coef"] * x[order], "r-", lw=1.5, label=f"{t['coef']:.4g} {t['term']}")
            ax.set_xlabel(t["term"] + (f" [{t['unit']}]" if t["unit"] and t["unit"] != "1" else ""))
            ax.set_ylabel(f"{t['output']} (partial residual)")
            ax.set_title(f"explains {t['explained']:.1%}, inclusion {t['inclusion']:.2f}")
            ax.legend(fontsize=8)
        return axes
