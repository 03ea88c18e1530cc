"""cpsat, bnb (and toulbar2) find the brute-force optimum on tiny grids."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from grammar.brute import random_priors, scores, tiny_extents, valid_occupancies
from unseeable.domain import Evidence, is_valid
from unseeable.grammar import EvidenceTerm
from unseeable.solve import SolveStatus, StructureSolver, available_backends

BACKENDS = ["cpsat", "bnb"]
TOL = 1e-6


def _random_terms(extent, seed: int, views: int, removal: bool):
    rng = np.random.default_rng(seed)
    terms = []
    for v in range(views):
        layer = int(rng.integers(0, extent.J + 1)) if (removal and v > 0) else None
        terms.append((Evidence(extent, random_priors(extent, rng)), layer))
    return terms


def _check(backend, extent, terms):
    best = scores(terms, valid_occupancies(extent)).max()
    solver = StructureSolver(extent, backend=backend)
    result = solver.solve([EvidenceTerm(e, layer) for e, layer in terms], time_limit=30)
    assert result.status == SolveStatus.OPTIMAL
    assert is_valid(result.structure)
    # Compare objectives, not structures: occluded regions tie exactly.
    assert result.log_probability == pytest.approx(best, abs=TOL)
    assert result.bound >= result.log_probability - 1e-9
    assert result.bound - result.log_probability < 1e-3
    assert scores(terms, result.structure.occupancy[None])[0] == pytest.approx(
        result.log_probability, abs=1e-9)


@pytest.mark.parametrize("backend", BACKENDS)
@settings(max_examples=40, deadline=None)
@given(extent=tiny_extents(), seed=st.integers(0, 2**31 - 1), views=st.integers(1, 3),
       removal=st.booleans())
def test_backends_find_the_brute_force_optimum(backend, extent, seed, views, removal):
    _check(backend, extent, _random_terms(extent, seed, views, removal))


@pytest.mark.skipif("toulbar2" not in available_backends(), reason="pytoulbar2 not installed")
@settings(max_examples=15, deadline=None)
@given(extent=tiny_extents(), seed=st.integers(0, 2**31 - 1), removal=st.booleans())
def test_toulbar2_finds_the_brute_force_optimum(extent, seed, removal):
    _check("toulbar2", extent, _random_terms(extent, seed, 2, removal))


# Shapes where every rule bites: 3-notch logs resting on single logs, long lines,
# tall stacks, both layer orientations.
SHAPES = [(1, 2, 3), (3, 3, 1), (2, 2, 2), (3, 2, 1), (1, 3, 2), (2, 1, 4), (8, 1, 1),
          (1, 8, 1), (1, 2, 4)]


@pytest.mark.parametrize("backend", BACKENDS)
@pytest.mark.parametrize("shape", SHAPES)
def test_backends_on_shapes_where_every_rule_bites(backend, shape):
    from unseeable.domain import Extent

    extent = Extent(*shape)
    for seed in range(6):
        _check(backend, extent, _random_terms(extent, seed, 2, True))


@pytest.mark.parametrize("backend", BACKENDS)
@pytest.mark.parametrize("nearby", [True, False])
@settings(max_examples=30, deadline=None)
@given(extent=tiny_extents(), seed=st.integers(0, 2**31 - 1), pick=st.integers(0, 10**6))
def test_find_better_beats_exactly_the_non_optimal_structures(backend, nearby, extent, seed,
                                                              pick):
    """find_better answers "is anything more probable than this?" as brute force does, with
    its look one move away first and without (the backend's search alone)."""
    terms = _random_terms(extent, seed, 1, False)
    occupancies = valid_occupancies(extent)
    values = scores(terms, occupancies)
    n = pick % len(occupancies)
    from unseeable.domain import Structure

    than = Structure.from_occupancy(extent, occupancies[n])
    solver = StructureSolver(extent, backend=backend)
    result = solver.find_better([EvidenceTerm(e, layer) for e, layer in terms], than,
                                time_limit=30, nearby=nearby)
    if values.max() > values[n] + 1e-5:
        assert result.status == SolveStatus.FEASIBLE
        assert result.log_probability > values[n]
        assert is_valid(result.structure)
    elif values.max() <= values[n] + 1e-7:
        assert result.status == SolveStatus.INFEASIBLE
        assert result.structure is None
