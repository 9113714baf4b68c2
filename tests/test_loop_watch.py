"""The loop's seam for studies of itself (diagnosis/loop/watch.py): it changes nothing unless asked, hands over
the selected model, may stop the loop there, and can give every candidate a second look."""

import numpy as np
import pytest

from sklearn_hybrid import HybridRegressor
from sklearn_hybrid.diagnosis import Candidates, Evidence, ScienceFit, close_the_loop, physics_terms
from sklearn_hybrid.diagnosis.loop import stepwise
from sklearn_hybrid.diagnosis.loop.watch import LoopWatch, current_watch, watching


def decay_f(v, k=0.5):
    """First-order decay of one state (one state or a batch)."""
    return -k * v


def _decay(c: float, n: int = 40, seed: int = 0):
    """40 trajectories of dA/dt = -0.6 A - c A^2 (exact solution), a hybrid fitted for 2 iterations on them, and
    the states with what the hybrid would have learned there."""
    rng = np.random.default_rng(seed)
    dt, n_steps, k = 0.25, 12, 0.6
    x0 = rng.uniform(0.3, 2.0, (n, 1))
    decay = np.exp(-k * dt * np.arange(n_steps + 1))[None, :, None]
    x = k * x0[:, None] * decay / (k + c * x0[:, None] * (1 - decay))
    y = x[:, 1:] + 0.01 * rng.standard_normal(x[:, 1:].shape)
    est = HybridRegressor(science=decay_f, dt=dt, max_iter=2, random_state=0).fit(x0, y)
    states = x.reshape(-1, 1)
    return est, x0, y, states, -k * states - c * states**2


def _select(c: float) -> dict:
    """forward_selection among the polynomials (few candidates: a quick test), judged by the last 3
    trajectories, with a second look on 4 folds of the others."""
    est, x0, y, states, learned = _decay(c)
    splits = [(np.arange(37), np.arange(37, 40))]
    terms = [t for t in physics_terms(["A"], states) if t.kind == "polynomial"]
    return stepwise.forward_selection(decay_f, {"k": 0.5}, ScienceFit(est, x0, y), splits, ["A"], 1,
                                      [states], learned, [0], candidates=Candidates(terms=terms),
                                      evidence=Evidence(second_look=4))


def _second_looks(steps: list) -> list:
    return [s for s in steps if isinstance(s["step"], str) and s["step"].endswith(", second look")
            and s["step"].split(",")[0].isdigit()]


def test_outside_a_watch_nothing_changes():
    assert current_watch() == LoopWatch()
    with watching(LoopWatch(second_look_gate=False)) as watch:
        assert current_watch() is watch
    assert current_watch() == LoopWatch()


def test_without_its_gate_every_candidate_gets_a_second_look():
    gated = _select(0.0)
    assert _second_looks(gated["steps"]) == []  # nothing promising where nothing is missing
    with watching(LoopWatch(second_look_gate=False)):
        open_ = _select(0.0)
    first = [s for s in open_["steps"] if s["step"] == 1 and "failed" not in s]
    looked = _second_looks(open_["steps"])
    assert looked and [s["term"] for s in looked] == [s["term"] for s in first]
    assert open_["added"] == []  # no more accepted: the second look alone holds the line here


def test_the_watch_sees_the_selected_model_and_may_stop_the_loop_there():
    est, x0, y, _, _ = _decay(0.5)
    options = {"evidence": Evidence(second_look=4), "candidates": Candidates(kinds=["polynomial"], max_terms=1)}
    result = close_the_loop(est, x0, y, **options)
    assert [t["term"] for t in result.added] == ["x0^2"]  # the missing -c A^2
    seen = []

    class Stop(Exception):
        pass

    def stop(science, theta, steps):
        seen.append((science, theta, steps))
        raise Stop

    with watching(LoopWatch(on_selection=stop)), pytest.raises(Stop):
        close_the_loop(est, x0, y, **options)
    (science, theta, steps), = seen
    assert [t[1] for t in getattr(science, "terms", [])] == [t["term"] for t in result.added]
    assert theta == pytest.approx(result.science_theta, rel=1e-9)
    assert [(s["step"], s["term"]) for s in steps] == [(s["step"], s["term"]) for s in result.steps]


@pytest.mark.parametrize("bad", [5, "stop"])
def test_a_watch_whose_callback_cannot_be_called_is_refused_at_once(bad):
    # it once failed only after the whole selection, with "'int' object is not callable"
    with pytest.raises(TypeError, match=r"on_selection must be a callable or None, got "):
        LoopWatch(on_selection=bad)


def test_a_watch_whose_gate_is_not_a_bool_is_refused():
    # "no" would have read as True: every candidate still gated
    with pytest.raises(TypeError, match=r"second_look_gate must be True or False"):
        LoopWatch(second_look_gate="no")


@pytest.mark.parametrize("bad", [None, print])
def test_watching_needs_a_watch(bad):
    # None once gave an AttributeError inside the loop, far from the with statement
    with pytest.raises(TypeError, match=r"watching\(\) needs a LoopWatch.*LoopWatch\(\)"):
        with watching(bad):
            pass
    assert current_watch() == LoopWatch()
