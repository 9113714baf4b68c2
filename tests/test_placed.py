"""The selection's candidates (diagnosis/loop/placed.py) refuse what they cannot be built from, at once and in
words: a term that is not a Term, a group without members, another fit's values without the term's parameters."""

import pytest

from sklearn_hybrid.diagnosis import Term
from sklearn_hybrid.diagnosis.loop.placed import PlacedGroup, PlacedTerm, offset_term

X2 = Term("x^2", None, "polynomial")


@pytest.mark.parametrize("term", ["v_dot", 1, None])
def test_a_placed_term_needs_a_term(term):
    # a name in place of the Term once failed only when its .name was read (AttributeError)
    with pytest.raises(TypeError, match=r"PlacedTerm needs a Term .*got "):
        PlacedTerm(term, 1)


@pytest.mark.parametrize("component", ["0", 1.0, None, True])
def test_a_placed_term_needs_an_integer_component(component):
    with pytest.raises(TypeError, match=r"component must be an int .*got "):
        PlacedTerm(X2, component)


def test_valid_placed_terms_and_groups_still_build():
    import numpy as np

    term = PlacedTerm(X2, np.int64(1), {}, 0.5, 0.1)  # a component found by numpy
    offset = PlacedTerm(offset_term("offset(A)"), 0, {}, 0.0, float("nan"), "declared")
    group = PlacedGroup([term, PlacedTerm(X2, 0)])  # a list is kept as a tuple
    assert (term.name, offset.kind, group.name, group.component) == ("x^2", "offset", "x^2", [1, 0])
    assert isinstance(group.members, tuple)


@pytest.mark.parametrize("members", [(), []])
def test_a_group_needs_members(members):
    # an empty group once failed on its .name with IndexError
    with pytest.raises(ValueError, match=r"PlacedGroup needs at least one member"):
        PlacedGroup(members)


def test_a_group_holds_placed_terms_only():
    with pytest.raises(TypeError, match=r"PlacedGroup members must be PlacedTerm.*member 1 is "):
        PlacedGroup((PlacedTerm(X2, 0), X2))


def test_with_values_of_a_term_never_fitted_says_so():
    # it once raised "KeyError: None"
    with pytest.raises(ValueError, match=r"with_values needs a fitted term .*with_fitted"):
        PlacedTerm(X2, 0).with_values({})


def test_with_values_names_the_parameters_it_needs():
    hinge = Term("max(0, x - knot)", None, "hinge", {"knot": ([0.5], (0.0, 1.0))})
    fitted = PlacedTerm(hinge, 0, {"knot": 0.5}, 1.0, param="c_hinge", shape_params={"knot": "knot_1"})
    assert fitted.with_values({"c_hinge": 2.0, "knot_1": 0.25}).shape == {"knot": 0.25}
    with pytest.raises(KeyError, match=r"lacks knot_1 .*needs c_hinge, knot_1"):
        fitted.with_values({"c_hinge": 2.0})
    with pytest.raises(KeyError, match=r"lacks c_hinge, knot_1"):
        fitted.with_values({})
