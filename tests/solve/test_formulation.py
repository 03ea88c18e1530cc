"""The CP-SAT "tight" formulation (disjunctive support, column cuts, stacked joints as
conjunctions of joints) is exact: the same optimum as the plain model of the grammar's
expressions, as bnb and toulbar2, under the shipped structure prior; its decision "does
anything beat this structure?" agrees with solving to optimality; the whole-model hint it
gives CP-SAT is a structure's own assignment."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scorer_terms import every_kind_of_term

from grammar.brute import habit_cost, unsupported_notches
from strategies import structures
from unseeable.domain import Extent, Structure, is_valid, simulate_evidence
from unseeable.grammar import EvidenceTerm, compile_objective, log_probability, random_structure
from unseeable.grammar.expr import Choice, Occ, Or
from unseeable.grammar.priors import StructurePrior
from unseeable.solve import SolveStatus, StructureSolver, available_backends
from unseeable.solve.cpsat import CpSatBackend

TOL = 1e-6


def _shipped_terms(extent: Extent, seed: int, density: float, occluded: float = 0.4):
    """Simulated evidence on a random structure plus the shipped prior, its joint cost on
    the joints the evidence reads (as estimate_structure charges it)."""
    truth = random_structure(extent, density=density, seed=seed)
    evidence = simulate_evidence(truth, accuracy=0.85, occluded_fraction=occluded, seed=seed)
    prior = StructurePrior().given_visibility(extent)
    return [EvidenceTerm(evidence), *prior([evidence.judged])]


def _cpsat_optimum(extent: Extent, terms, formulation: str) -> tuple[float, Structure]:
    backend = CpSatBackend(extent, (), formulation=formulation)
    raw = backend.solve(compile_objective(extent, terms), time_limit=60)
    assert raw.status == SolveStatus.OPTIMAL
    structure = Structure.from_occupancy(extent, raw.occupancy)
    assert is_valid(structure)
    value = log_probability(terms, structure)
    # The proven bound (scaled integers, corrected for rounding) covers the float value.
    assert raw.bound >= value - 1e-6
    assert raw.bound - value < 1e-3
    return value, structure


@pytest.mark.parametrize(("shape", "density"), [
    ((4, 5, 4), 0.8), ((5, 6, 4), 0.8), ((4, 6, 5), 0.5), ((6, 4, 3), 0.9), ((3, 7, 3), 0.8)])
def test_the_tight_model_has_the_plain_model_s_optimum_under_the_shipped_prior(shape, density):
    extent = Extent(*shape)
    for seed in range(4):
        terms = _shipped_terms(extent, seed, density)
        tight, _ = _cpsat_optimum(extent, terms, "tight")
        plain, _ = _cpsat_optimum(extent, terms, "plain")
        assert tight == pytest.approx(plain, abs=TOL), f"seed {seed}"


def test_unsupported_notches_count_exactly_whatever_their_weight():
    # Rewarding an unsupported notch must not let the model call a supported one unsupported.
    from unseeable.grammar import Factor
    from unseeable.grammar.expr import empty, occupied

    extent = Extent(4, 4, 3)
    rng = np.random.default_rng(5)
    for seed in range(3):
        terms = _shipped_terms(extent, seed, 0.8)
        terms += [Factor(occupied(q) & empty((q[0], q[1] - 1, q[2])), float(rng.normal(0, 2)))
                  for q in extent.iter_positions() if q[1] > 0]
        tight, _ = _cpsat_optimum(extent, terms, "tight")
        plain, _ = _cpsat_optimum(extent, terms, "plain")
        assert tight == pytest.approx(plain, abs=TOL), f"seed {seed}"


@settings(max_examples=25, deadline=None)
@given(extent=st.sampled_from([Extent(2, 3, 2), Extent(3, 2, 2), Extent(2, 4, 1),
                               Extent(1, 4, 3), Extent(3, 3, 1)]),
       seed=st.integers(0, 2**31 - 1), density=st.sampled_from([0.5, 0.9]))
def test_cpsat_bnb_and_toulbar2_agree_under_the_shipped_prior(extent, seed, density):
    terms = _shipped_terms(extent, seed, density, occluded=0.5)
    values = {}
    for backend in available_backends():
        result = StructureSolver(extent, backend=backend).solve(terms, time_limit=30)
        assert result.status == SolveStatus.OPTIMAL, backend
        values[backend] = result.log_probability
    assert max(values.values()) - min(values.values()) < TOL, values


@settings(max_examples=10, deadline=None)
@given(extent=st.sampled_from([Extent(2, 3, 2), Extent(3, 3, 2), Extent(2, 4, 2)]),
       seed=st.integers(0, 2**31 - 1))
def test_a_kept_model_re_solved_under_either_sign_keeps_every_optimum(extent, seed):
    # Each solve keeps only the side of a feature's or stacked joint's definition that
    # its weight's sign needs; the evidence read the other way round turns every sign,
    # so each solve here must switch them all, and the decision made after each (on the
    # same half definitions, against a cut-off) must still be exact.
    if "bnb" not in available_backends():
        pytest.skip("bnb is not available")
    terms = _shipped_terms(extent, seed, 0.7, occluded=0.3)
    evidence = terms[0].evidence
    turned = [EvidenceTerm(evidence.with_priors(1.0 - evidence.p)), *terms[1:]]
    kept = StructureSolver(extent)
    for objective in (terms, turned, terms, turned):
        ours = kept.solve(objective, time_limit=30)
        reference = StructureSolver(extent, backend="bnb").solve(objective, time_limit=30)
        assert ours.status == SolveStatus.OPTIMAL
        assert abs(ours.log_probability - reference.log_probability) < TOL
        assert kept.find_better(objective, ours).status == SolveStatus.INFEASIBLE


def test_every_unsupported_notch_is_an_exempt_notch_of_a_three_notch_log():
    # The structure prior's unsupported-notch factor is the exemption literals' sum, with
    # no literal of its own: its value on a structure is the brute-force count.
    extent = Extent(4, 5, 4)
    prior = StructurePrior(joint_cost=0.0, stacked_joint_cost=0.0, unsupported_notch_cost=1.0)
    backend = CpSatBackend(extent, ())
    objective = compile_objective(extent, list(prior.factors(extent)))
    _, flat = backend._install(objective, None, None)
    assert len(flat[0]) > 0
    for seed in range(6):
        structure = random_structure(extent, density=0.9, seed=seed)
        full = backend._full_hint(structure.occupancy, None)
        count = -backend._value_at(flat, full) / 1e6 + objective.constant
        assert count == pytest.approx(unsupported_notches(structure))


@settings(max_examples=15, deadline=None)
@given(structures(max_positions=60), st.integers(0, 2**31 - 1), st.booleans())
def test_the_whole_model_hint_is_the_structure_s_assignment(structure, seed, with_choice):
    extent = structure.extent
    constraints = [Or((Choice("c"), Occ((0, 0, 0), frozenset({0}))))] if with_choice else []
    backend = CpSatBackend(extent, constraints)
    evidence = simulate_evidence(structure, accuracy=0.8, occluded_fraction=0.3, seed=seed)
    terms = [EvidenceTerm(evidence), *StructurePrior().factors(extent)]
    objective = compile_objective(extent, terms)
    _, flat = backend._install(objective, structure.occupancy, None)
    choices = {"c": True} if with_choice else None
    full = backend._full_hint(structure.occupancy, choices)
    # Every variable of the model, each once.
    assert sorted(full[0].tolist()) == list(range(len(backend.model.model_proto.variables)))
    expected = backend._scaled_value(structure.occupancy, choices)
    assert backend._value_at(flat, full) == expected
    # The float objective agrees with the brute-force score of the structure's logs.
    score = log_probability(terms, structure)
    assert score == pytest.approx(evidence.log_probability(structure)
                                  - habit_cost(structure, joint=1, stacked=1, unsupported=1),
                                  abs=1e-9)
    # CP-SAT takes the whole assignment as a feasible solution at once.
    model = backend.model.clone()
    backend._set_hint(model, full)
    from ortools.sat.python import cp_model

    solver = cp_model.CpSolver()
    solver.parameters.num_workers = 1
    solver.parameters.fix_variables_to_their_hinted_value = True
    assert solver.solve(model) == cp_model.OPTIMAL
    assert solver.objective_value == expected


@pytest.mark.parametrize("path", ["all", "neighbourhoods", "lp"])
@pytest.mark.parametrize("shift", [0.0, 0.05, 0.2])
def test_the_decision_agrees_with_solving_to_optimality(shift, path, monkeypatch):
    # Whichever step decides (the LP within its budget, a neighbourhood, the LP to the
    # end), the answer is exact.
    from unseeable.confidence import shifted_term
    from unseeable.solve import cpsat

    if path != "all":  # the first step's budget spent at once: it never decides
        monkeypatch.setattr(cpsat, "IMPROVE_LP_SHARE", 1e-9)
        monkeypatch.setattr(cpsat, "IMPROVE_LP_FLOOR", 1e-9)
    if path == "lp":
        monkeypatch.setattr(cpsat, "NEIGHBOURHOOD_ROUNDS", ())

    extent = Extent(5, 6, 5)
    for seed in range(3):
        terms = _shipped_terms(extent, seed, 0.8)
        solver = StructureSolver(extent)
        estimate = solver.solve(terms)
        occluded = ~terms[0].evidence.judged
        shifted = [*terms, shifted_term(estimate.structure, occluded, shift)] if shift else terms
        base = log_probability(shifted, estimate.structure)
        best = solver.solve(shifted, hint=estimate)
        assert best.status == SolveStatus.OPTIMAL
        # (not one move away first: the backend's own steps are what is tested)
        decision = solver.find_better(shifted, estimate, nearby=False)
        if best.log_probability > base + 1e-5:
            assert decision.status == SolveStatus.FEASIBLE, f"seed {seed}"
            assert base < decision.log_probability <= best.log_probability + 1e-9
            assert is_valid(decision.structure)
        else:
            assert decision.status == SolveStatus.INFEASIBLE, f"seed {seed}"
            assert decision.structure is None


def test_the_decision_holds_with_choices_the_estimate_does_not_give():
    # A choice the hint leaves out: the cut-off comes from CP-SAT with the choice at best.
    extent = Extent(3, 3, 3)
    terms = _shipped_terms(extent, 1, 0.8)
    constraints = [Or((Choice("door"), Occ((1, 0, 1), frozenset({0}))))]
    solver = StructureSolver(extent, constraints=constraints)
    estimate = solver.solve(terms)
    decision = solver.find_better(terms, estimate.structure)
    assert decision.status == SolveStatus.INFEASIBLE
    worse = Structure(extent, [])
    if log_probability(terms, worse) < estimate.log_probability - 1e-5:
        assert solver.find_better(terms, worse).status == SolveStatus.FEASIBLE


def test_an_unknown_formulation_is_refused():
    from unseeable.errors import SolverError

    with pytest.raises(SolverError, match="formulation"):
        CpSatBackend(Extent(2, 2, 2), (), formulation="loose")


def test_both_formulations_keep_their_own_model():
    from unseeable.solve import cpsat

    extent = Extent(3, 4, 3)
    cpsat._TEMPLATES.clear()
    tight = CpSatBackend(extent, ())
    plain = CpSatBackend(extent, (), formulation="plain")
    assert len(cpsat._TEMPLATES) == 2
    again = CpSatBackend(extent, ())
    assert str(again.model.model_proto) == str(tight.model.model_proto)
    assert str(again.model.model_proto) != str(plain.model.model_proto)
    # The plain model has no exemption literals; the tight one has three per 3-notch
    # placement above layer 0.
    assert len(plain._exempt_table) == 0
    assert len(tight._exempt_table) == 3 * sum(
        1 for row in tight._x if row[4] is not None) - 3 * sum(
        1 for n, row in enumerate(tight._x) if row[4] is not None
        and (n // extent.K) % extent.J == 0)
    assert np.all(np.isin(tight._exempt_table[:, 0], np.arange(
        len(tight.model.model_proto.variables))))


@settings(max_examples=20, deadline=None)
@given(structures(max_positions=80), st.integers(0, 2**31 - 1), st.booleans())
def test_the_tie_search_scores_structures_as_log_probability_does(structure, seed, removed):
    # The scores decide which moves keep a tie: they must be log_probability's, bit for bit.
    from unseeable.solve.api import _Scorer

    extent = structure.extent
    terms, choices = every_kind_of_term(structure, seed, removed)
    solver = StructureSolver(extent)
    score = _Scorer(extent, terms, choices, solver._simplify_factor)
    for other in (structure, random_structure(extent, density=0.7, seed=seed)):
        assert score(other.occupancy) == log_probability(terms, other, choices)
        # Under other choices than the scorer was made with (the structures find_better
        # finds bring their own).
        flipped = {"c": not choices["c"]}
        assert score(other.occupancy, flipped) == log_probability(terms, other, flipped)
        # The solver's public scoring, which the confidence tests' crossings use.
        assert solver.log_probabilities(terms, [(other, choices), (other, flipped)]) == [
            log_probability(terms, other, choices), log_probability(terms, other, flipped)]


@settings(max_examples=10, deadline=None)
@given(extent=st.sampled_from([Extent(2, 3, 2), Extent(3, 3, 2), Extent(2, 4, 3)]),
       seed=st.integers(0, 2**31 - 1), ties=st.sampled_from(["any", "fewest"]))
def test_estimates_and_better_structures_report_their_log_probability(extent, seed, ties):
    # What a solve and find_better report is log_probability of what they return, exactly.
    terms = _shipped_terms(extent, seed, 0.7, occluded=0.5)
    solver = StructureSolver(extent, ties=ties)
    result = solver.solve(terms)
    assert result.log_probability == log_probability(terms, result.structure, result.choices)
    # Under shifted evidence something else may beat the estimate: its score too.
    shifted = [*terms, EvidenceTerm(simulate_evidence(
        random_structure(extent, density=0.5, seed=seed + 1), accuracy=0.9,
        occluded_fraction=0.0, seed=seed))]
    better = solver.find_better(shifted, result)
    if better.status == SolveStatus.FEASIBLE:
        assert better.log_probability == log_probability(shifted, better.structure,
                                                         better.choices)
        assert better.log_probability > log_probability(shifted, result.structure)
    else:
        assert better.status == SolveStatus.INFEASIBLE
        assert better.bound == log_probability(shifted, result.structure)


@settings(max_examples=20, deadline=None)
@given(structures(max_positions=80), st.integers(0, 2**31 - 1), st.sampled_from([0, 1, 2]))
def test_the_solver_compiles_the_objective_as_compile_objective_does(structure, seed, levels):
    # Bit for bit: the model's literals follow the expressions' order, and ties with them.
    from unseeable.grammar import Factor
    from unseeable.grammar.expr import empty, occupied

    extent = structure.extent
    rng = np.random.default_rng(seed)
    evidence = simulate_evidence(structure, accuracy=0.8, occluded_fraction=0.3, seed=seed)
    q = (0, 0, 0)
    prior = StructurePrior().given_visibility(extent)([evidence.judged])
    extra = [Factor(occupied(q) | Choice("c"), -0.3), Factor(empty(q), 0.4, -0.1),
             Factor(Occ((0, 0, 0), (1, 2, 4)), float(rng.normal())),  # an end feature's
             Factor(occupied((extent.I, 0, 0)), 0.25)]                 # constant
    layers = [None, 1][:levels]
    terms = [*(EvidenceTerm(evidence, layer) for layer in layers), *prior, *extra]
    solver = StructureSolver(extent)
    for _ in range(2):  # afresh, then from the kept expressions
        ours, theirs = solver._compile(terms), compile_objective(extent, terms)
        assert ours.exprs == theirs.exprs
        assert ours.coefs.tolist() == theirs.coefs.tolist()
        assert ours.constant == theirs.constant


def test_the_decision_refuses_a_structure_outside_the_model():
    # Its value is the cut-off: a structure the grammar or the constraints rule out must
    # not be declared unbeatable.
    from unseeable.domain import Log
    from unseeable.errors import SolverError

    extent = Extent(3, 3, 3)
    terms = _shipped_terms(extent, 2, 0.8)
    floating = Structure(extent, [Log(2, (0, 0), 1)])  # nothing below it
    with pytest.raises(SolverError, match="grammar"):
        StructureSolver(extent).find_better(terms, floating)
    solver = StructureSolver(extent, constraints=[Occ((1, 0, 1), frozenset({0}))])
    occupied_there = Structure(extent, [Log(0, (1, 1), 1)])
    with pytest.raises(SolverError, match="constraint"):
        solver.find_better(terms, occupied_there)
