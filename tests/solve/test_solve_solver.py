"""What users of the estimator rely on: truth from good evidence, constraints, hints, statuses."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from grammar.brute import random_priors, scores, valid_occupancies
from strategies import structures
from unseeable.domain import Evidence, Extent, is_valid, simulate_evidence
from unseeable.errors import InputError, SolverError
from unseeable.grammar import (
    FALSE,
    Choice,
    EvidenceTerm,
    Factor,
    Implies,
    Occ,
    Or,
    empty,
    evaluate,
    log_probability,
    occupied,
    random_structure,
)
from unseeable.grammar.priors import StructurePrior
from unseeable.solve import SolveResult, SolveStatus, StructureSolver, estimate_structure
from unseeable.solve.api import available_backends

#: The paper's prior: what the brute-force references and a bare solver maximise.
UNIFORM = StructurePrior.named("uniform")
ALL = ["cpsat", "bnb"] + (["toulbar2"] if "toulbar2" in available_backends() else [])


def _confident(structure, seed=0):
    return simulate_evidence(structure, accuracy=1.0, occluded_fraction=0.0, seed=seed,
                             confidence=(0.8, 0.95))


# Correct readings of every feature give the truth under the paper's uniform prior. The
# builder prior's nat a joint can outweigh two readings at 0.8: on a 4x5x5 structure of
# 42 logs the MAP under it (bnb and CP-SAT alike) drops a joint for 41 logs.
@settings(max_examples=25, deadline=None)
@given(structures(max_positions=125))
def test_confident_correct_evidence_gives_the_truth_cpsat(structure):
    result = estimate_structure(_confident(structure), prior=UNIFORM)
    assert result.status == SolveStatus.OPTIMAL
    assert result.structure == structure


@pytest.mark.parametrize("backend", ALL)
@settings(max_examples=10, deadline=None)
@given(structures(max_positions=27, max_dim=3))
def test_confident_correct_evidence_gives_the_truth(backend, structure):
    result = estimate_structure(_confident(structure), backend=backend, prior=UNIFORM)
    assert result.structure == structure


def _constrained_best(extent, terms, constraints, names=(), factors=()):
    """Brute force: best score over valid occupancies × choice values meeting the constraints."""
    occs = valid_occupancies(extent)
    base = scores(terms, occs)
    best = -math.inf
    for values in itertools.product((False, True), repeat=len(names)):
        choices = dict(zip(names, values))
        ok = np.ones(len(occs), dtype=bool)
        for c in constraints:
            ok &= evaluate(c, occs, choices)
        total = base.copy()
        for f in factors:
            total += np.where(evaluate(f.expr, occs, choices), f.if_true, f.if_false)
        if ok.any():
            best = max(best, float(total[ok].max()))
    return best


@pytest.mark.parametrize("backend", ALL)
@pytest.mark.parametrize("seed", range(4))
def test_forcing_a_position_occupied(backend, seed):
    extent = Extent(2, 2, 2)
    rng = np.random.default_rng(seed)
    ev = Evidence(extent, random_priors(extent, rng))
    q = (int(rng.integers(2)), 1, int(rng.integers(2)))
    cons = [occupied(q)]
    result = estimate_structure(ev, constraints=cons, backend=backend, prior=UNIFORM)
    assert result.status == SolveStatus.OPTIMAL
    assert result.structure.occupancy[q] != 0
    assert result.log_probability == pytest.approx(
        _constrained_best(extent, [(ev, None)], cons), abs=1e-6)


def _placements(extent):
    """"A 2-notch log lies somewhere on layer 1": one choice per placement."""
    names, parts = [], []
    for i in range(extent.I):
        for k in range(extent.K - 1):
            name = f"log@{i},{k}"
            names.append(name)
            parts.append(Implies(Choice(name), Occ((i, 1, k), {2}) & Occ((i, 1, k + 1), {3})))
    return names, [Or(*[Choice(n) for n in names]), *parts]


@pytest.mark.parametrize("backend", ALL)
@pytest.mark.parametrize("seed", range(4))
def test_an_existential_over_choice_placements(backend, seed):
    extent = Extent(2, 2, 3)
    rng = np.random.default_rng(seed)
    ev = Evidence(extent, random_priors(extent, rng))
    names, cons = _placements(extent)
    result = estimate_structure(ev, constraints=cons, backend=backend, prior=UNIFORM)
    assert result.status == SolveStatus.OPTIMAL
    assert set(result.choices) == set(names)
    picked = [n for n in names if result.choices[n]]
    assert picked
    for name in picked:  # the chosen placement really holds a 2-notch log
        i, k = (int(x) for x in name.split("@")[1].split(","))
        assert result.structure.occupancy[i, 1, k] == 2
    assert result.log_probability == pytest.approx(
        _constrained_best(extent, [(ev, None)], cons, names), abs=1e-6)


@pytest.mark.parametrize("backend", ALL)
def test_a_soft_factor_on_a_choice(backend):
    extent = Extent(2, 2, 2)
    rng = np.random.default_rng(7)
    ev = Evidence(extent, random_priors(extent, rng))
    cons = [Implies(Choice("x"), occupied((0, 1, 0)) & occupied((1, 1, 1)))]
    factors = [Factor(Choice("x"), 2.5, -1.0)]
    result = StructureSolver(extent, constraints=cons, backend=backend).solve([ev, *factors])
    best = _constrained_best(extent, [(ev, None)], cons, ["x"], factors)
    assert result.log_probability == pytest.approx(best, abs=1e-6)
    assert result.log_probability == pytest.approx(
        log_probability([ev, *factors], result.structure, result.choices), abs=1e-9)


@pytest.mark.parametrize("backend", ALL)
def test_infeasible_constraints_are_a_status(backend):
    extent = Extent(1, 2, 1)
    for cons in ([FALSE], [occupied((0, 1, 0)), empty((0, 0, 0))]):
        result = estimate_structure(Evidence.uniform(extent), constraints=cons, backend=backend)
        assert result.status == SolveStatus.INFEASIBLE
        assert result.structure is None
        assert result.log_probability == -math.inf and result.bound == -math.inf
        assert result.proven


@pytest.mark.parametrize("backend", ALL)
def test_partial_disassembly_evidence_speaks_for_the_layers_left(backend):
    extent = Extent(3, 3, 3)
    truth = random_structure(extent, density=0.8, seed=3)
    seen = _confident(truth.removed_from_layer(2))
    result = estimate_structure(seen, removed_from_layer=2, backend=backend)
    assert result.structure.removed_from_layer(2) == truth.removed_from_layer(2)
    # The same evidence read as a view of the whole assembly forbids anything on layer 2.
    whole = estimate_structure(seen, backend=backend)
    assert whole.structure == truth.removed_from_layer(2)


@pytest.mark.parametrize("backend", ALL)
@settings(max_examples=8, deadline=None)
@given(st.integers(0, 2**31 - 1))
def test_a_hint_never_changes_the_optimum(backend, seed):
    extent = Extent(3, 3, 2)
    truth = random_structure(extent, density=0.6, seed=seed)
    ev = simulate_evidence(truth, accuracy=0.8, occluded_fraction=0.4, seed=seed)
    solver = StructureSolver(extent, backend=backend)
    plain = solver.solve(ev)
    for hint in (random_structure(extent, density=0.6, seed=seed + 1), truth, plain):
        hinted = solver.solve(ev, hint=hint)
        assert hinted.status == SolveStatus.OPTIMAL
        assert hinted.log_probability == pytest.approx(plain.log_probability, abs=1e-6)


def test_a_kept_model_answers_like_fresh_ones():
    extent = Extent(4, 4, 4)
    solver = StructureSolver(extent, workers=1)
    for n in range(3):
        truth = random_structure(extent, density=0.5, seed=n)
        ev = simulate_evidence(truth, seed=n)
        terms = [ev, EvidenceTerm(simulate_evidence(truth.removed_from_layer(2), seed=n + 9), 2)]
        kept = solver.solve(terms)
        fresh = estimate_structure(terms, prior=UNIFORM)
        assert kept.resolves == n
        assert kept.log_probability == pytest.approx(fresh.log_probability, abs=1e-6)
        assert kept.log_probability == pytest.approx(log_probability(terms, kept.structure),
                                                     abs=1e-12)
        assert set(kept.timings) >= {"build_s", "solve_s"}
        assert kept.wall_s >= kept.timings["solve_s"]
    assert solver.solves == 3


def test_one_worker_is_deterministic():
    extent = Extent(4, 4, 4)
    ev = simulate_evidence(random_structure(extent, density=0.5, seed=5), seed=5)
    a = estimate_structure(ev)
    b = estimate_structure(ev)
    assert a.structure == b.structure


def test_two_workers_agree_with_one():
    extent = Extent(5, 5, 5)
    ev = simulate_evidence(random_structure(extent, density=0.5, seed=2), seed=2)
    one = estimate_structure(ev, workers=1)
    two = estimate_structure(ev, workers=2)
    assert two.status == SolveStatus.OPTIMAL
    assert two.log_probability == pytest.approx(one.log_probability, abs=1e-6)


def test_the_time_limit_is_reported_honestly():
    extent = Extent(4, 4, 4)
    truth = random_structure(extent, density=0.5, seed=0)
    ev = simulate_evidence(truth, accuracy=0.85, occluded_fraction=0.4, seed=0)
    result = estimate_structure(ev, backend="bnb", time_limit=1e-6)
    assert result.status in (SolveStatus.FEASIBLE, SolveStatus.TIMEOUT)
    assert not result.proven
    if result.status == SolveStatus.FEASIBLE:
        assert is_valid(result.structure)
        assert result.bound >= result.log_probability
    big = Extent(8, 10, 8)
    ev = simulate_evidence(random_structure(big, density=0.5, seed=0), seed=0)
    result = estimate_structure(ev, time_limit=1e-3)
    assert result.status in (SolveStatus.FEASIBLE, SolveStatus.TIMEOUT)
    assert (result.structure is None) == (result.status == SolveStatus.TIMEOUT)


def test_a_work_budget_stops_the_search_at_the_same_place_on_any_machine():
    # The pose choice solves under a budget of deterministic work: a good structure soon,
    # the same one however loaded the machine, and never one that breaks the grammar.
    big = Extent(8, 10, 8)
    truth = random_structure(big, density=0.5, seed=3)
    ev = simulate_evidence(truth, accuracy=0.8, occluded_fraction=0.3, seed=3)
    solver = StructureSolver(big)
    # A fifth of what the proof of this instance's optimum takes (0.03 on 2026-12-06).
    runs = [solver.solve(ev, work_limit=0.006) for _ in range(2)]
    assert runs[0].structure == runs[1].structure
    for result in runs:
        assert result.status in (SolveStatus.FEASIBLE, SolveStatus.TIMEOUT)
        if result.structure is not None:
            assert is_valid(result.structure)
            assert result.bound >= result.log_probability
    exact = solver.solve(ev)
    assert exact.status == SolveStatus.OPTIMAL
    assert runs[0].structure is None or runs[0].log_probability <= exact.log_probability
    with pytest.raises(InputError, match="work_limit"):
        solver.solve(ev, work_limit=0)


def test_results_are_values():
    extent = Extent(2, 2, 2)
    result = estimate_structure(Evidence.uniform(extent))
    assert isinstance(result, SolveResult)
    assert result.status.value == "optimal" and SolveStatus("optimal") is SolveStatus.OPTIMAL
    assert result.log_probability == pytest.approx(Evidence.uniform(extent).log_probability(
        result.structure.occupancy))
    assert result.gap == pytest.approx(0.0, abs=1e-6)
    assert result.choices == {}


def test_user_errors():
    extent = Extent(2, 2, 2)
    ev = Evidence.uniform(extent)
    with pytest.raises(InputError, match="simplex"):
        estimate_structure(ev, backend="simplex")
    with pytest.raises(InputError, match="time_limit"):
        estimate_structure(ev, time_limit=0)
    with pytest.raises(InputError, match="workers"):
        StructureSolver(extent, workers=0)
    with pytest.raises(InputError, match="extent"):
        StructureSolver(Extent(2, 2, 3)).solve(ev)
    with pytest.raises(InputError, match="hint"):
        StructureSolver(extent).solve(ev, hint=random_structure(Extent(3, 2, 2), seed=0))
    with pytest.raises(InputError):
        estimate_structure([])


def test_a_missing_optional_solver_says_how_to_install(monkeypatch):
    import sys

    monkeypatch.setitem(sys.modules, "pytoulbar2", None)  # import now fails
    with pytest.raises(SolverError, match="pip install pytoulbar2"):
        StructureSolver(Extent(2, 2, 2), backend="toulbar2")
    assert "toulbar2" not in available_backends()


def test_scores_match_the_brute_force_helper():
    # The brute-force helper and the package agree on what a score is.
    extent = Extent(2, 2, 1)
    ev = Evidence(extent, random_priors(extent, np.random.default_rng(0)))
    occs = valid_occupancies(extent)
    s = scores([(ev, 1)], occs)
    for z, v in zip(occs, s):
        assert log_probability([(ev, 1)], z) == pytest.approx(v, abs=1e-12)


@pytest.mark.parametrize("backend", ALL)
def test_emptiest_ties_pick_the_emptiest_of_tied_structures(backend):
    extent = Extent(3, 3, 2)
    uniform = Evidence.uniform(extent)  # every valid structure ties
    result = StructureSolver(extent, backend=backend, ties="emptiest").solve(uniform)
    assert len(result.structure) == 0
    assert result.log_probability == pytest.approx(uniform.log_probability(
        result.structure.occupancy), abs=1e-12)
    with pytest.raises(InputError, match="ties"):
        StructureSolver(extent, ties="fullest")
    with pytest.raises(InputError, match="ties"):
        StructureSolver(extent, ties="local")  # a solve's option, not a solver's


@pytest.mark.parametrize("backend", ALL)
@pytest.mark.parametrize("ties", ["emptiest", "fewest"])
@settings(max_examples=10, deadline=None)
@given(st.integers(0, 2**31 - 1))
def test_tie_policies_keep_the_optimum_and_never_cost_more(backend, ties, seed):
    """A policy's member is still a MAP estimate, at no more than the backend's member's
    cost: no more positions plus logs ("emptiest"), no more logs ("fewest")."""
    from unseeable.solve.ties import tie_cost

    extent = Extent(3, 3, 3)
    truth = random_structure(extent, density=0.7, seed=seed % 1000)
    ev = simulate_evidence(truth, accuracy=0.85, occluded_fraction=0.5, seed=seed)
    plain = StructureSolver(extent, backend=backend)
    exact = plain.solve(ev)
    assert plain.solve(ev, ties="local").structure == exact.structure  # "any": no moves
    solver = StructureSolver(extent, backend=backend, ties=ties)
    result = solver.solve(ev)
    assert result.status == SolveStatus.OPTIMAL and is_valid(result.structure)
    assert result.log_probability == pytest.approx(exact.log_probability, abs=1e-6)
    assert ev.log_probability(result.structure.occupancy) == pytest.approx(
        result.log_probability, abs=1e-9)
    cost = tie_cost(ties, extent)
    assert cost(result.structure) <= cost(exact.structure)
    if ties == "fewest":
        assert len(result.structure) <= len(exact.structure)
    assert solver.resolve_tie(ev, result).structure == result.structure


@settings(max_examples=10, deadline=None)
@given(st.integers(0, 2**31 - 1))
def test_a_tie_policy_per_solve_and_the_emptiest_member_of_a_given_estimate(seed):
    """What the visibility fixpoint relies on to search a tie once, at the end."""
    extent = Extent(3, 3, 3)
    truth = random_structure(extent, density=0.7, seed=seed % 1000)
    ev = simulate_evidence(truth, accuracy=0.85, occluded_fraction=0.5, seed=seed)
    plain = StructureSolver(extent)  # ties="any"
    full = StructureSolver(extent, ties="emptiest").solve(ev)
    assert plain.solve(ev, ties="emptiest").structure == full.structure
    local = plain.solve(ev, ties="local")
    assert local.log_probability == pytest.approx(full.log_probability, abs=1e-6)
    later = StructureSolver(extent, ties="emptiest").resolve_tie(ev, local)
    assert later.log_probability == pytest.approx(full.log_probability, abs=1e-6)
    size = lambda z: len(z) + int((z.occupancy != 0).sum())  # noqa: E731
    assert size(later.structure) <= size(local.structure)
    assert StructureSolver(extent, ties="emptiest").resolve_tie(ev, later).structure \
        == later.structure
    assert plain.resolve_tie(ev, local) is local  # policy "any": as it is
    with pytest.raises(InputError, match="ties"):
        plain.solve(ev, ties="fullest")


def test_emptiest_ties_remove_shorten_and_merge_unseen_logs():
    from unseeable.domain import Log, Structure
    from unseeable.solve.ties import resolve_tie

    extent = Extent(3, 2, 1)
    # Layer 0: a 1-notch and a 2-notch log end to end; layer 1 holds a 1-notch log on top.
    s = Structure(extent, (Log(0, (0, 0), 1), Log(0, (1, 0), 2), Log(1, (1, 0), 1)))
    # Only layer 0 is seen (all three positions occupied): the top log goes, the two merge.
    merged = resolve_tie(s, lambda z: -float((z[:, 0, 0] == 0).sum()))
    assert merged.logs == (Log(0, (0, 0), 3),)
    # Every occupied position is seen: only the merge keeps the value.
    kept = resolve_tie(s, lambda z: float((z != 0).sum()))
    assert kept.logs == (Log(0, (0, 0), 3), Log(1, (1, 0), 1))


def test_fewest_ties_build_a_hidden_course_of_whole_long_logs():
    # The pipeline's policy: a course seen only at its two ends, held by a 1-notch log at
    # each, becomes one 3-notch log (a lengthening, then a merge); "emptiest" keeps the gap.
    from unseeable.domain import Log, Structure
    from unseeable.solve.ties import TieCost, resolve_tie, tie_cost

    extent = Extent(3, 1, 1)
    s = Structure(extent, (Log(0, (0, 0), 1), Log(0, (2, 0), 1)))
    ends_seen = lambda z: -float(int(z[0, 0, 0] == 0) + int(z[2, 0, 0] == 0))  # noqa: E731
    fewest = tie_cost("fewest", extent)
    assert resolve_tie(s, ends_seen, cost=fewest).logs == (Log(0, (0, 0), 3),)
    assert resolve_tie(s, ends_seen).logs == s.logs
    # fewer logs first, whatever the positions; then the longer
    assert fewest.log > extent.shape[0] * extent.shape[1] * extent.shape[2]
    assert fewest(Structure(extent, (Log(0, (0, 0), 3),))) \
        < fewest(Structure(extent, (Log(0, (0, 0), 2),))) \
        < fewest(Structure(extent, (Log(0, (0, 0), 1), Log(0, (1, 0), 1))))
    assert TieCost(position=1, log=1)(s) == 4
    with pytest.raises(InputError, match="ties"):
        tie_cost("any", extent)


def test_fewest_ties_put_the_longest_log_first_where_a_joint_is_unseen():
    # A course of 4 positions, all seen occupied, its joint not: two logs either way, on
    # the same positions. "fewest" keeps a 3-notch and a 1-notch log, not two 2-notch
    # ones (the joint moved a notch), and its cost says so.
    from unseeable.domain import Log, Structure
    from unseeable.solve.ties import resolve_tie, tie_cost

    extent = Extent(4, 1, 1)
    halves = Structure(extent, (Log(0, (0, 0), 2), Log(0, (2, 0), 2)))
    all_seen = lambda z: -float((z[:, 0, 0] == 0).sum())  # noqa: E731
    fewest = tie_cost("fewest", extent)
    out = resolve_tie(halves, all_seen, cost=fewest)
    assert out.logs == (Log(0, (0, 0), 3), Log(0, (3, 0), 1))
    assert fewest(out) < fewest(halves)
    # The lengths come last: fewer logs first, then more positions.
    assert fewest(Structure(extent, (Log(0, (0, 0), 1),))) < fewest(out)
    assert fewest(Structure(extent, (Log(0, (0, 0), 1), Log(0, (3, 0), 1)))) > fewest(halves)


def test_fewest_ties_lengthen_only_into_empty_space_on_the_grid():
    from unseeable.domain import Log, Structure
    from unseeable.solve.ties import resolve_tie, tie_cost

    extent = Extent(3, 2, 1)
    # A 2-notch log at the line's end cannot grow off the grid, nor onto its neighbour.
    s = Structure(extent, (Log(0, (0, 0), 1), Log(0, (1, 0), 2)))
    both = lambda z: -float(int(z[0, 0, 0] == 0) + int(z[2, 0, 0] == 0))  # noqa: E731
    assert resolve_tie(s, both, cost=tie_cost("fewest", extent)).logs == (Log(0, (0, 0), 3),)
    # A log on layer 1 (along k) grows only as far as the logs below hold it: with one
    # below it stays; with two, it grows to 3 notches (two of them held, rule (d)).
    extent = Extent(1, 2, 3)
    seen = lambda z: -float(int(z[0, 1, 0] == 0) + int(z[0, 0, 1] == 0))  # noqa: E731
    for below, grown in (((0,), Log(1, (0, 0), 1)), ((0, 1), Log(1, (0, 0), 3))):
        s = Structure(extent, (*(Log(0, (0, k), 1) for k in below), Log(1, (0, 0), 1)))
        out = resolve_tie(s, seen, cost=tie_cost("fewest", extent))
        assert is_valid(out) and grown in out.logs
