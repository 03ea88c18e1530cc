"""Φ, the features g_f, counting and random structures against independent references."""

from __future__ import annotations

import itertools
import math

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
    assert count_valid(extent) == len(valid_occupancies(extent)) == _count_by_layers(extent)


def _count_by_layers(extent: Extent) -> int:
    """The number of valid structures, counted layer by layer from DESIGN.md §2 alone.

    Rules (c)/(d) tie a layer only to the occupancy of the layer below, so the count is a
    sum over that occupancy (a set of columns); given it, each line of a layer is laid
    independently: any 1-, 2- and 3-notch logs or nothing along it, a 1- or 2-notch log
    resting on every notch and a 3-notch log on at least two (on layer 0: all rest). Below
    the top layer a line's ways are told apart by the columns they fill (lines there are
    short); on the top layer only their number matters.
    """
    I, J, K = extent.shape

    def lines(j):  # the columns (i, k) of each line of layer j, in order along its axis
        if j % 2 == 0:
            return [[(i, k) for i in range(I)] for k in range(K)]
        return [[(i, k) for k in range(K)] for i in range(I)]

    def rests(line, below, start, m):
        held = sum(below is None or line[start + n] in below for n in range(m))
        return held >= (2 if m == 3 else m)

    def ways_along(line, below):  # number of ways to lay the line
        ways = [1] * (len(line) + 1)  # ways[a]: ways to lay positions a.. of the line
        for a in range(len(line) - 1, -1, -1):
            ways[a] = ways[a + 1] + sum(ways[a + m] for m in (1, 2, 3)
                                        if a + m <= len(line) and rests(line, below, a, m))
        return ways[0]

    def fills(line, below, a=0):  # filled columns of each way to lay positions a..
        if a >= len(line):
            return [frozenset()]
        out = fills(line, below, a + 1)
        for m in (1, 2, 3):
            if a + m <= len(line) and rests(line, below, a, m):
                out += [rest | set(line[a:a + m]) for rest in fills(line, below, a + m)]
        return out

    below_counts: dict = {None: 1}  # filled columns of the layer below -> number of ways
    for j in range(J - 1):
        counts: dict[frozenset, int] = {}
        for below, ways in below_counts.items():
            layer = {frozenset(): ways}  # filled columns of the lines so far -> ways
            for line in lines(j):
                merged: dict[frozenset, int] = {}
                for cols in fills(line, below):
                    for so_far, n in layer.items():
                        merged[so_far | cols] = merged.get(so_far | cols, 0) + n
                layer = merged
            for cols, n in layer.items():
                counts[cols] = counts.get(cols, 0) + n
        below_counts = counts
    return sum(ways * math.prod(ways_along(line, below) for line in lines(J - 1))
               for below, ways in below_counts.items())


@pytest.mark.parametrize("shape", [(3, 2, 3), (2, 3, 3), (1, 18, 1), (18, 1, 1), (3, 6, 1),
                                   (2, 9, 1), (2, 2, 2), (1, 2, 4)])
def test_count_valid_on_18_positions_is_the_layer_by_layer_count(shape):
    assert count_valid(Extent(*shape)) == _count_by_layers(Extent(*shape))


def test_count_valid_stays_exact_beyond_int64():
    # Extents with far more than 2**63 valid structures: the CRT reconstruction of the
    # counts kept modulo primes must give them exactly.
    for shape in [(2, 30, 2), (3, 20, 2), (60, 1, 1)]:
        extent = Extent(*shape)
        assert count_valid(extent) == _count_by_layers(extent) > 2**63
    assert count_valid(Extent(4, 5, 4)) > 2**63


def test_count_valid_small_cases_by_hand():
    assert count_valid(Extent(1, 1, 1)) == 2  # EMPTY or a 1-notch log
    assert count_valid(Extent(1, 3, 1)) == 4  # a stack of 0..3 logs
    assert count_valid(Extent(1, 18, 1)) == 19
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
