"""The structures one move away (what find_better looks at before any search) are valid,
are what their changes say, and include every valid structure with one log more; the
scorer's changes are the score differences."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st
from scorer_terms import every_kind_of_term

from grammar.brute import tiny_extents, valid_occupancies
from strategies import structures
from unseeable.domain import Structure, is_valid
from unseeable.grammar import random_structure
from unseeable.solve import StructureSolver
from unseeable.solve.ties import flat_changes, neighbours


@settings(max_examples=40, deadline=None)
@given(extent=tiny_extents(), pick=st.integers(0, 10**6))
def test_every_neighbour_is_valid_and_what_its_changes_say(extent, pick):
    occupancies = valid_occupancies(extent)
    structure = Structure.from_occupancy(extent, occupancies[pick % len(occupancies)])
    seen = set()
    for taken, put, changed in neighbours(structure):
        logs = (set(structure.logs) - set(taken)) | set(put)
        moved = Structure(extent, tuple(sorted(logs)))
        assert is_valid(moved)
        z = structure.occupancy.copy()
        for q, code in changed.items():
            z[q] = code
        assert np.array_equal(z, moved.occupancy)
        assert moved.logs != structure.logs
        seen.add(moved.occupancy.tobytes())
    # Every valid structure with one log more is one move away.
    ours = set(structure.logs)
    for z in occupancies:
        other = Structure.from_occupancy(extent, z)
        if len(other.logs) == len(ours) + 1 and ours <= set(other.logs):
            assert z.tobytes() in seen


@settings(max_examples=20, deadline=None)
@given(structures(max_positions=80), st.integers(0, 2**31 - 1), st.booleans())
def test_the_changes_of_moves_are_the_differences_of_scores(structure, seed, removed):
    from unseeable.solve.api import _Scorer

    extent = structure.extent
    terms, choices = every_kind_of_term(structure, seed, removed)
    score = _Scorer(extent, terms, choices, StructureSolver(extent)._simplify_factor)
    for base in (structure, random_structure(extent, density=0.5, seed=seed)):
        moves = neighbours(base)
        flat = [flat_changes(changed, extent) for _, _, changed in moves]
        gains = score.changes(base.occupancy, flat)
        assert gains.shape == (len(moves),)
        before = score(base.occupancy)
        for (positions, codes), gain in zip(flat, gains):
            trial = base.occupancy.copy()
            trial.ravel()[positions] = codes
            assert abs(gain - (score(trial) - before)) < 1e-9
