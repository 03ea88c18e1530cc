"""Φ, the features g_f, counting and random structures against independent references."""

from __future__ import annotations

import itertools

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from grammar.brute import tiny_extents, valid_occupancies
from strategies import structures
from unseeable.domain import Extent, Structure, feature_values, is_valid
from unseeable.errors import InputError
from unseeable.grammar import (
    count_line_tilings,
    count_valid,
    evaluate,
    feature_expressions,
    grammar_constraints,
    random_structure,
)


def _domain_valid(extent: Extent, z: np.ndarray) -> bool:
    try:
        return is_valid(Structure.from_occupancy(extent, z))
    except InputError:
        return False


@pytest.mark.parametrize("shape", [(2, 2, 1), (1, 2, 2), (3, 1, 1), (1, 3, 1), (2, 1, 2),
                                   (1, 1, 4)])
def test_grammar_accepts_exactly_the_valid_occupancies(shape):
    extent = Extent(*shape)
    n = extent.positions
    every = np.array(list(itertools.product(range(7), repeat=n)), dtype=np.int8)
    every = every.reshape(-1, *shape)
    accepted = np.ones(len(every), dtype=bool)
    for c in grammar_constraints(extent):
        accepted &= evaluate(c, every)
    expected = np.array([_domain_valid(extent, z) for z in every])
    assert np.array_equal(accepted, expected)
    assert count_valid(extent) == int(expected.sum())


@settings(max_examples=40, deadline=None)
@given(tiny_extents())
def test_count_valid_matches_enumeration(extent):
    assert count_valid(extent) == len(valid_occupancies(extent))


def test_count_valid_is_exact_and_fast_on_18_positions():
    import time

    t0 = time.perf_counter()
    for shape in [(3, 2, 3), (2, 3, 3), (1, 18, 1), (18, 1, 1), (3, 6, 1), (2, 9, 1)]:
        count = count_valid(Extent(*shape))
        assert isinstance(count, int) and count > 0
    assert time.perf_counter() - t0 < 5.0
    # Larger than int64: the CRT reconstruction must stay exact.
    assert count_valid(Extent(4, 5, 4)) > 2**63
    assert count_valid(Extent(40, 1, 1)) == count_line_tilings(40)


def test_count_valid_small_cases_by_hand():
    assert count_valid(Extent(1, 1, 1)) == 2  # EMPTY or a 1-notch log
    assert count_valid(Extent(1, 3, 1)) == 4  # a stack of 0..3 logs
    assert [count_line_tilings(n) for n in range(4)] == [1, 2, 5, 13]


def test_count_valid_refuses_wide_layers():
    with pytest.raises(InputError, match="I\\*K"):
        count_valid(Extent(8, 2, 8))


@settings(max_examples=40, deadline=None)
@given(structures(max_positions=60), st.integers(0, 6))
def test_feature_expressions_are_the_domain_features(structure, removed):
    extent = structure.extent
    z = structure.occupancy
    level = removed if removed < extent.J else None
    exprs = feature_expressions(extent, level)
    got = np.array([bool(evaluate(e, z)) for e in exprs])
    after = z if level is None else structure.removed_from_layer(level).occupancy
    assert np.array_equal(got, feature_values(extent, after))


@settings(max_examples=40, deadline=None)
@given(structures(max_positions=60))
def test_valid_structures_satisfy_the_grammar_expressions(structure):
    assert all(bool(evaluate(c, structure.occupancy)) for c in grammar_constraints(
        structure.extent))


@settings(max_examples=30, deadline=None)
@given(st.tuples(st.integers(1, 6), st.integers(1, 6), st.integers(1, 6)),
       st.floats(0.0, 1.0), st.integers(0, 2**31 - 1))
def test_random_structure_is_valid_and_reproducible(shape, density, seed):
    extent = Extent(*shape)
    s = random_structure(extent, density=density, seed=seed)
    assert is_valid(s)
    assert s == random_structure(extent, density=density, seed=seed)


def test_random_structure_density_controls_fill():
    extent = Extent(6, 5, 6)
    assert len(random_structure(extent, density=0.0, seed=0)) == 0
    sparse = random_structure(extent, density=0.2, seed=0)
    dense = random_structure(extent, density=1.0, seed=0)
    assert (dense.occupancy > 0).sum() > (sparse.occupancy > 0).sum()
    assert (dense.occupancy[:, 0, :] > 0).all()  # layer 0 is packed
    with pytest.raises(InputError):
        random_structure(extent, density=1.5)
