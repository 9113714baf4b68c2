"""The closed loop's typed results: each stage's output, and what leaves the loop, read by attribute and as the
dicts the records keep."""

import ast
import inspect
import json
import textwrap

import numpy as np
import pytest

from sklearn_hybrid import HybridRegressor
from sklearn_hybrid.diagnosis import AddedTerm, Candidates, Step, Verdict, close_the_loop, evidence
from sklearn_hybrid.diagnosis.loop import close


def _data(n=300, seed=0):
    rng = np.random.default_rng(seed)
    X = rng.uniform(-1, 1, (n, 2))
    return X, 2.0 * X[:, :1] + 0.5 * X[:, 1:] ** 2 + 0.01 * rng.standard_normal((n, 1))


def test_a_verdict_reads_by_attribute_and_as_the_dict_it_was():
    rng = np.random.default_rng(0)
    before = rng.uniform(0.5, 1.5, 12)
    verdict = evidence(before, 0.5 * before)
    assert isinstance(verdict, Verdict) and verdict.accepted and verdict["accepted"]
    assert dict(verdict) == verdict.as_dict() and set(verdict) == {"mse_before", "mse_after", "gain", "z",
                                                                   "threshold", "accepted"}
    assert verdict.gain == pytest.approx(0.5) and {**verdict}["z"] == verdict.z
    json.dumps(verdict.as_dict())


def test_a_step_lays_out_its_row_as_the_records_held_it():
    row = {"ranked_by": "fit", "component": 1, "term": "v^3", "kind": "polynomial", "gain": 0.8, "shape": {}}
    failed = Step.of(2, row, failed="RuntimeError('diverged')")
    assert failed["gain"] == 0.8 and failed["failed"].startswith("RuntimeError") and "mse_after" not in failed
    judged = Step.of(2, row, verdict=Verdict(1.0, 0.25, 0.75, 9.0, 3.1, True))
    # the held-out gain replaces the ranking's; "accepted" is the selection's choice, not the verdict's yes
    assert judged["gain"] == 0.75 and judged.rank_gain == 0.8 and judged["accepted"] is False
    assert list(judged) == ["step", "ranked_by", "component", "term", "kind", "gain", "shape", "mse_before",
                            "mse_after", "z", "threshold", "accepted"]
    with pytest.raises(KeyError):
        judged["output"]  # named once the loop knows the equations


def test_what_leaves_the_loop_is_typed_and_its_records_are_plain_json():
    X, y = _data()
    est = HybridRegressor(science=lambda x, a=1.0: a * x[:, :1], structure="additive", method="erm", max_iter=150,
                          residual={"kind": "mlp", "hidden": (16, 16), "activation": "tanh"}, random_state=0)
    out = close_the_loop(est, X, y, state_names=["p", "q"], candidates=Candidates(kinds=["polynomial"], max_terms=1),
                         verbose=False)
    assert [type(t) for t in out.added] == [AddedTerm] and all(isinstance(s, Step) for s in out.steps)
    (term,) = out.added
    assert term.term == term["term"] == "q^2" and term.output == "g[0]" and term.coef == pytest.approx(0.5, rel=0.05)
    assert term.param in out.science_theta
    chosen = [s for s in out.steps if s.accepted]
    assert [s.term for s in chosen] == ["q^2"] and chosen[0].verdict.accepted
    records = {"added": [{k: v for k, v in t.as_dict().items() if k != "function"} for t in out.added],
               "steps": [s.as_dict() for s in out.steps]}
    assert json.loads(json.dumps(records, default=float))["added"][0]["param"] == term.param


def test_close_the_loop_is_an_orchestration_of_its_stages():
    """The loop's code (its docstring aside) stays short: each stage is a function of stages.py."""
    tree = ast.parse(textwrap.dedent(inspect.getsource(close.close_the_loop)))
    body = tree.body[0].body[1:]  # without the docstring
    lines = body[-1].end_lineno - body[0].lineno + 1
    assert lines <= 80, f"close_the_loop's code is {lines} lines"
