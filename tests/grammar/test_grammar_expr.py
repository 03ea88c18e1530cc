"""The expression layer: folding, negation and evaluation agree with brute force."""

from __future__ import annotations

import itertools

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from unseeable.domain import Extent
from unseeable.errors import InputError
from unseeable.grammar import (
    FALSE,
    TRUE,
    And,
    AtLeast,
    AtMost,
    Choice,
    Const,
    Exactly,
    Iff,
    Implies,
    Not,
    Occ,
    Or,
    evaluate,
    negate,
    occupied,
    scope,
    simplify,
    truth_table,
)

EXTENT = Extent(2, 1, 1)  # two positions; (2, 0, 0) and (0, 1, 0) lie outside
ALL_Z = np.array(list(itertools.product(range(7), repeat=2)), dtype=np.int8).reshape(49, 2, 1, 1)
NAMES = ("a", "b")


def _leaf():
    positions = st.sampled_from([(0, 0, 0), (1, 0, 0), (2, 0, 0), (0, 1, 0), (-1, 0, 0)])
    occ = st.builds(Occ, positions, st.frozensets(st.integers(0, 6)))
    return st.one_of(occ, st.sampled_from([Choice("a"), Choice("b"), TRUE, FALSE]))


def _expressions():
    def extend(children):
        many = st.lists(children, min_size=0, max_size=3)
        return st.one_of(
            st.builds(Not, children),
            st.builds(lambda xs: And(*xs), many),
            st.builds(lambda xs: Or(*xs), many),
            st.builds(Implies, children, children),
            st.builds(Iff, children, children),
            st.builds(AtLeast, st.integers(-1, 4), many),
            st.builds(AtMost, st.integers(-1, 4), many),
            st.builds(Exactly, st.integers(-1, 4), many),
        )
    return st.recursive(_leaf(), extend, max_leaves=8)


def _truth(e):
    """Truth over every occupancy of EXTENT and every choice value: (49, 2, 2) bool."""
    out = np.empty((49, 2, 2), dtype=bool)
    for a, b in itertools.product((False, True), repeat=2):
        out[:, int(a), int(b)] = evaluate(e, ALL_Z, {"a": a, "b": b})
    return out


@settings(max_examples=150, deadline=None)
@given(_expressions())
def test_simplify_and_negate_preserve_meaning(e):
    s = simplify(e, EXTENT)
    assert np.array_equal(_truth(s), _truth(e))
    assert np.array_equal(_truth(negate(s)), ~_truth(e))
    positions, _ = scope(s)
    assert all(EXTENT.contains(q) for q in positions)  # no literal outside the grid survives


@settings(max_examples=60, deadline=None)
@given(_expressions())
def test_truth_table_matches_evaluate(e):
    s = simplify(e, EXTENT)
    positions, names = scope(s)
    positions, names = sorted(positions), sorted(names)
    table = truth_table(s, positions, names)
    truth = _truth(s)
    for z_index in range(49):
        z = ALL_Z[z_index]
        for a, b in itertools.product((0, 1), repeat=2):
            idx = tuple(int(z[q]) for q in positions) + tuple({"a": a, "b": b}[n] for n in names)
            assert table[idx] == truth[z_index, a, b]


def test_positions_outside_the_grid_are_empty():
    assert simplify(Occ((2, 0, 0), {0}), EXTENT) is TRUE
    assert simplify(occupied((0, -1, 0)), EXTENT) is FALSE
    assert simplify(Occ((0, 0, 0), range(7)), EXTENT) is TRUE
    assert simplify(Occ((0, 0, 0), ()), EXTENT) is FALSE


def test_removed_layers_are_empty():
    e = Extent(1, 3, 1)
    assert simplify(occupied((0, 2, 0)), e, removed_from_layer=2) is FALSE
    assert simplify(occupied((0, 1, 0)), e, removed_from_layer=2) == occupied((0, 1, 0))
    z = np.array([1, 1, 1], dtype=np.int8).reshape(1, 3, 1)
    assert not bool(evaluate(occupied((0, 1, 0)), z, removed_from_layer=1))
    assert bool(evaluate(occupied((0, 0, 0)), z, removed_from_layer=1))


def test_operators_build_expressions():
    a, b = Choice("a"), occupied((0, 0, 0))
    assert (a & b) == And(a, b)
    assert (a | b) == Or(a, b)
    assert (~a) == Not(a)
    assert a.implies(b) == Implies(a, b)
    assert And([a, b]) == And(a, b)
    assert hash(Occ((0, 0, 0), {1, 2})) == hash(Occ([0, 0, 0], (2, 1)))


def test_expressions_have_no_truth_value():
    with pytest.raises(TypeError):
        bool(Choice("a"))


def test_bad_leaves_raise_input_error():
    with pytest.raises(InputError, match="0..6"):
        Occ((0, 0, 0), {7})
    with pytest.raises(InputError):
        Occ((0, 0), {1})
    with pytest.raises(InputError):
        Choice("")
    with pytest.raises(InputError, match="choice"):
        evaluate(Choice("x"), np.zeros((1, 1, 1), dtype=np.int8))


def test_constants_fold_in_cardinality():
    xs = [TRUE, Choice("a"), Choice("b")]
    assert simplify(AtLeast(1, xs), EXTENT) is TRUE
    assert simplify(AtMost(0, xs), EXTENT) is FALSE
    assert simplify(Exactly(3, xs), EXTENT) == And(Choice("a"), Choice("b"))
    assert isinstance(simplify(AtLeast(2, [FALSE, FALSE]), EXTENT), Const)
