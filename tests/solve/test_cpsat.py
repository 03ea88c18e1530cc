"""The CP-SAT adapter writes objectives, hints and cut-offs with numpy; they must be the
very protos CP-SAT's own Python API writes, so that solves (and their tie-breaking and
work-limited answers) do not depend on which way they were built."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from strategies import structures
from unseeable.domain import simulate_evidence
from unseeable.grammar import EvidenceTerm, Factor, compile_objective
from unseeable.grammar.expr import And, Choice, Implies, Occ, Or, evaluate
from unseeable.solve.backend import SCALE
from unseeable.solve.cpsat import CpSatBackend


def _reference_sum(backend: CpSatBackend, objective):
    """``Σ_e round(c_e·SCALE)·[e]`` built term by term with CP-SAT's API."""
    from ortools.sat.python import cp_model

    scaled = np.rint(objective.coefs * SCALE)
    parts = [backend._lin01(e) for e in objective.exprs]
    keep = scaled != 0
    return cp_model.LinearExpr.weighted_sum([p for p, k in zip(parts, keep) if k],
                                            [int(s) for s in scaled[keep]])


@settings(max_examples=15, deadline=None)
@given(structures(max_positions=48), st.integers(0, 2**31 - 1), st.booleans())
def test_objective_hint_and_cutoff_are_cp_sat_s_own(structure, seed, with_choice):
    extent = structure.extent
    # A constraint with a choice puts reified literals and a choice in the model.
    constraints = [Or((Choice("c"), Occ((0, 0, 0), frozenset({0}))))] if with_choice else []
    backend = CpSatBackend(extent, constraints)
    terms = [EvidenceTerm(simulate_evidence(structure, accuracy=0.8, occluded_fraction=0.3,
                                            seed=seed))]
    if extent.J > 1:  # features of a partial disassembly are compound expressions
        terms.append(EvidenceTerm(simulate_evidence(structure.removed_from_layer(1),
                                                    seed=seed + 1), 1))
    objective = compile_objective(extent, terms)
    _, flat = backend._install(objective, structure.occupancy, None)

    reference = backend.model.clone()
    reference.clear_objective()
    reference.clear_hints()
    linear = _reference_sum(backend, objective)
    reference.maximize(linear)
    hinted: dict[int, tuple] = {}  # the placements' variables, a log's at its first position
    for row, value in zip(backend._x, structure.occupancy.ravel()):
        for v, var in enumerate(row):
            if var is not None and (var.index not in hinted or v == value):
                hinted[var.index] = (var, int(v == value))
    for var, value in hinted.values():
        reference.add_hint(var, value)
    assert str(backend.model.model_proto.objective) == str(reference.model_proto.objective)
    assert str(backend.model.model_proto.solution_hint) == \
        str(reference.model_proto.solution_hint)

    ours, theirs = backend.model.clone(), backend.model.clone()
    backend._add_at_least(ours, flat, 12345)
    theirs.add(linear >= 12345)
    last = len(theirs.model_proto.constraints) - 1  # (the proto wrapper takes no -1)
    assert len(ours.model_proto.constraints) == last + 1
    assert str(ours.model_proto.constraints[last]) == str(theirs.model_proto.constraints[last])


@settings(max_examples=10, deadline=None)
@given(structures(max_positions=48), st.integers(0, 2**31 - 1))
def test_the_value_of_a_structure_is_its_objective(structure, seed):
    backend = CpSatBackend(structure.extent, [])
    evidence = simulate_evidence(structure, accuracy=0.7, occluded_fraction=0.2, seed=seed)
    objective = compile_objective(structure.extent, [EvidenceTerm(evidence)])
    scaled, _ = backend._install(objective, None, None)
    expected = sum(int(s) for s, e in zip(scaled, objective.exprs)
                   if evaluate(e, structure.occupancy))
    assert backend._scaled_value(structure.occupancy, None) == expected


@settings(max_examples=10, deadline=None)
@given(structures(max_positions=48), st.integers(0, 2**31 - 1), st.booleans())
def test_a_model_copied_from_a_kept_one_is_the_one_built(structure, seed, with_choice):
    from unseeable.solve import cpsat

    extent = structure.extent
    constraints, factors = [], []
    if with_choice:
        # A compound condition gets a reified literal when the model is built; a factor
        # on the same expression must find it, not add another.
        both = And((Occ((0, 0, 0), frozenset({0})), Occ((0, 0, extent.K - 1), frozenset({0}))))
        constraints = [Or((Choice("c"), Occ((0, 0, 0), frozenset({0})))),
                       Implies(both, Or((Choice("c"), Occ((extent.I - 1, 0, 0),
                                                          frozenset({0})))))]
        factors = [Factor(both, 0.5, -0.5)]
    cpsat._TEMPLATES.clear()
    built = CpSatBackend(extent, constraints)
    copied = CpSatBackend(extent, constraints)
    assert (extent, tuple(constraints)) in cpsat._TEMPLATES
    assert str(built.model.model_proto) == str(copied.model.model_proto)
    terms = [EvidenceTerm(simulate_evidence(structure, seed=seed)), *factors]
    if extent.J > 1:
        terms.append(EvidenceTerm(simulate_evidence(structure.removed_from_layer(1),
                                                    seed=seed + 1), 1))
    objective = compile_objective(extent, terms)
    answers = [b.solve(objective, hint=structure.occupancy) for b in (built, copied)]
    # The objective's reified literals are added alike, and the answers are the same.
    assert str(built.model.model_proto) == str(copied.model.model_proto)
    assert np.array_equal(answers[0].occupancy, answers[1].occupancy)
    assert answers[0].bound == answers[1].bound


def test_the_tie_search_goes_on_only_when_its_probe_found_a_structure():
    """Nothing is seen, so every valid structure ties and the fewest-logs member is the
    empty grid. The search finds it when given the time; a probe that finds nothing (no
    time at all) ends the search without an answer instead of spending the whole budget,
    and the caller keeps its own member of the tie."""
    from unseeable.domain import Evidence, Extent, Log, Structure
    from unseeable.domain.features import feature_index
    from unseeable.solve.api import tie_objective
    from unseeable.solve.backend import SolveStatus
    from unseeable.solve.ties import tie_cost

    extent = Extent(3, 3, 2)
    objective = compile_objective(extent, [EvidenceTerm(
        Evidence(extent, np.full(len(feature_index(extent)), 0.5)))])
    fewest = tie_objective(extent, tie_cost("fewest", extent))
    hint = Structure(extent, (Log(0, (0, 0), 3), Log(0, (0, 1), 3), Log(1, (0, 0), 2),
                              Log(1, (2, 0), 2), Log(2, (0, 0), 3))).occupancy
    backend = CpSatBackend(extent, ())
    for probe in (None, 0.1):
        found = backend.lexicographic(objective, fewest, hint=hint, deterministic_limit=0.5,
                                      probe=probe)
        assert found.status == SolveStatus.OPTIMAL
        assert not found.occupancy.any()
    gave_up = backend.lexicographic(objective, fewest, hint=hint, deterministic_limit=0.5,
                                    probe=0.0)
    assert gave_up.status == SolveStatus.TIMEOUT and gave_up.occupancy is None


@settings(max_examples=10, deadline=None)
@given(structures(max_positions=60), st.integers(0, 2**31 - 1))
def test_a_solve_the_quick_attempt_does_not_settle_is_proven_in_full(structure, seed):
    """The first attempt without inprocessing stops at its work limit; whatever it left
    open, the full solve proves, to the same optimum."""
    import unseeable.solve.cpsat as cpsat
    from unseeable.solve.backend import SolveStatus

    evidence = simulate_evidence(structure, accuracy=0.8, occluded_fraction=0.3, seed=seed)
    objective = compile_objective(structure.extent, [EvidenceTerm(evidence)])
    backend = CpSatBackend(structure.extent, ())
    quick = backend.solve(objective)
    saved = cpsat.EASY_SOLVE_WORK
    cpsat.EASY_SOLVE_WORK = 0.0  # the first attempt settles nothing
    try:
        full = backend.solve(objective)
    finally:
        cpsat.EASY_SOLVE_WORK = saved
    assert quick.status == full.status == SolveStatus.OPTIMAL
    assert quick.bound == full.bound
    values = [backend._value_at(backend._flat_objective(objective)[1],
                                backend._full_hint(r.occupancy, {})) for r in (quick, full)]
    assert values[0] == values[1]


@settings(max_examples=10, deadline=None)
@given(structures(max_positions=60), st.integers(0, 2**31 - 1))
def test_a_hint_is_kept_among_ties_and_warm_starts_only_the_full_solve(structure, seed):
    """The quick first attempt starts cold; of exactly tied optima it keeps the hint (a
    fixpoint's rounds do not wander in a tie), and a hint that is not optimal changes
    nothing it settles. A solve left to the full settings gets the hint."""
    import unseeable.solve.cpsat as cpsat

    backend = CpSatBackend(structure.extent, ())
    # No evidence: every valid structure ties, and the hint is the answer.
    flat = compile_objective(structure.extent, [])
    assert np.array_equal(backend.solve(flat, hint=structure.occupancy).occupancy,
                          structure.occupancy)
    evidence = simulate_evidence(structure, accuracy=0.8, occluded_fraction=0.3, seed=seed)
    objective = compile_objective(structure.extent, [EvidenceTerm(evidence)])
    cold = backend.solve(objective)
    worse = np.zeros_like(structure.occupancy)  # the empty structure, rarely optimal
    hinted = backend.solve(objective, hint=worse)
    assert hinted.bound == cold.bound
    value = [backend._value_at(backend._flat_objective(objective)[1],
                               backend._full_hint(z, {})) for z in (cold.occupancy, worse)]
    if value[1] < value[0]:
        assert np.array_equal(cold.occupancy, hinted.occupancy)
    assert len(backend.model.model_proto.solution_hint.vars) == 0
    saved = cpsat.EASY_SOLVE_WORK
    cpsat.EASY_SOLVE_WORK = 0.0  # the first attempt settles nothing
    try:
        full = backend.solve(objective, hint=structure.occupancy)
    finally:
        cpsat.EASY_SOLVE_WORK = saved
    assert full.bound == cold.bound
    expected = backend._full_hint(structure.occupancy, {})
    assert list(backend.model.model_proto.solution_hint.vars) == expected[0].tolist()


def test_a_tied_hint_that_breaks_the_grammar_is_not_the_answer():
    from unseeable.domain import Extent, Structure, is_valid

    extent = Extent(3, 1, 1)
    broken = np.zeros(extent.shape, np.int8)
    broken[0, 0, 0] = 2  # the first notch of a 2-notch log whose second notch is missing
    backend = CpSatBackend(extent, ())
    result = backend.solve(compile_objective(extent, []), hint=broken)  # every structure ties
    assert not np.array_equal(result.occupancy, broken)
    assert is_valid(Structure.from_occupancy(extent, result.occupancy))
