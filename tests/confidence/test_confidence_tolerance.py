import numpy as np
import pytest

from grammar.brute import (
    features_from_logs,
    habit_cost,
    log_likelihood_from_logs,
    random_priors,
    valid_occupancies,
)
from simulated_view import simulated_observation, station_camera
from unseeable.confidence import (
    assess_confidence,
    estimation_tolerance,
    occluded_features,
    shifted_term,
)
from unseeable.corpus import load_design
from unseeable.domain import Evidence, Extent, Log, Structure, feature_values
from unseeable.solve import StructureSolver
from unseeable.visibility.loop import estimate_with_visibility


def _estimate(truth, angle, elevation, seed=0):
    cam, pose = station_camera(truth, angle, elevation_deg=elevation)
    obs, truth_vis = simulated_observation(truth, cam, pose, seed=seed)
    solver = StructureSolver(truth.extent, ties="emptiest")
    fp = estimate_with_visibility(obs, truth.extent, solver=solver,
                                  initial_visibility=truth_vis, fixed_visibility=True)
    occ = occluded_features([obs], fp.visibility, truth.extent)
    return solver, fp, occ


@pytest.mark.parametrize("truth", [
    Structure(Extent(3, 1, 3), [Log(0, (0, 0), 3), Log(0, (0, 2), 3)]),
    load_design("wall-door").structure])
def test_fully_visible_simple_structure_is_exact_and_confident(truth):
    solver, fp, occ = _estimate(truth, 150, 40)
    assert fp.structure == truth
    conf = assess_confidence(solver, fp.terms, fp.result, occ)
    assert conf.confident
    assert conf.tolerance >= 0.2


def test_hidden_interior_is_not_confident():
    truth = load_design("cabin-4x4-hearth").structure
    solver, fp, occ = _estimate(truth, 150, 20)
    assert occ.sum() > 0
    conf = assess_confidence(solver, fp.terms, fp.result, occ)
    assert not conf.confident
    assert conf.tolerance < 0.2


@pytest.mark.parametrize("design, angle, elevation, seed", [
    ("wall-door", 150, 40, 0), ("tower-3-L3", 90, 30, 2), ("l-cabin-L3", 120, 30, 1),
    ("cabin-4x4-hearth", 150, 20, 0)])
def test_tolerance_is_where_the_estimate_gives_way(design, angle, elevation, seed):
    # The estimate stands at the tolerance (tied at most) and changes just above it, to a
    # rival whose closed-form crossing lies between the two shifts: the rival differs from
    # the estimate on d occluded features and trails it by -A0 unshifted, so it overtakes
    # at δ = ½·tanh(-A0 / 2d). At tolerance 0 that rival is an exact tie-mate (A0 = 0).
    from unseeable.confidence import estimate_changes
    from unseeable.grammar import log_probability

    solver, fp, occ = _estimate(load_design(design).structure, angle, elevation, seed=seed)
    tol, resolves = estimation_tolerance(solver, fp.terms, fp.result, occ)
    assert 0 <= tol < 0.5 and resolves >= 1
    if tol > 0:
        assert not estimate_changes(solver, fp.terms, fp.result, occ, tol)
    assert estimate_changes(solver, fp.terms, fp.result, occ, tol + 0.002)
    rival = solver.find_better([*fp.terms, shifted_term(fp.structure, occ, tol + 0.002)],
                               fp.result).structure
    ours = feature_values(fp.structure.extent, fp.structure.occupancy)
    d = int(np.sum(occ & (ours != feature_values(rival.extent, rival.occupancy))))
    a0 = log_probability(fp.terms, rival) - log_probability(fp.terms, fp.structure)
    assert d > 0 and a0 <= 1e-9
    assert tol - 1e-6 <= 0.5 * np.tanh(-a0 / (2 * d)) <= tol + 0.002
    # the same from the δ* outcome, as assess_confidence starts
    conf = assess_confidence(solver, fp.terms, fp.result, occ)
    assert conf.tolerance == pytest.approx(tol, abs=1e-9)
    assert conf.confident == (tol >= conf.delta_star)


def _brute_tolerance(extent, terms_score, estimate, occluded):
    """The tolerance by brute force: the smallest crossing ½·tanh(-A0 / 2d) of any valid
    structure that differs from the estimate on d > 0 occluded features, 0.5 when none
    crosses below the largest shift tried. Scores and features are read from the logs."""
    from unseeable.confidence.tolerance import MAX_DELTA

    structures = [Structure.from_occupancy(extent, z) for z in valid_occupancies(extent)]
    present = np.array([features_from_logs(s) for s in structures])
    scores = np.array([terms_score(s) for s in structures])
    d = np.sum(occluded & (present != features_from_logs(estimate)), axis=1)
    a0 = scores - terms_score(estimate)
    assert a0.max() <= 1e-6  # the estimate is a MAP estimate
    crossings = 0.5 * np.tanh(np.maximum(-a0[d > 0], 0.0) / (2 * d[d > 0]))
    best = crossings.min(initial=0.5)
    return best if best < MAX_DELTA else 0.5


@pytest.mark.parametrize("shape", [(3, 1, 1), (2, 2, 1), (1, 2, 3), (2, 2, 2), (4, 2, 1),
                                   (2, 3, 1)])
@pytest.mark.parametrize("backend", ["cpsat", "bnb"])
def test_tolerance_is_the_nearest_brute_force_crossing(shape, backend):
    from unseeable.grammar import EvidenceTerm
    from unseeable.grammar.priors import StructurePrior

    extent = Extent(*shape)
    for case in range(4):
        rng = np.random.default_rng([*shape, case])
        p = random_priors(extent, rng, occluded=0.2)
        occluded = rng.random(len(p)) < 0.4
        p[occluded & (rng.random(len(p)) < 0.7)] = 0.5  # most occluded features not judged
        evidence = Evidence(extent, p)
        terms = [EvidenceTerm(evidence)]
        seen = rng.random(extent.shape) < 0.5
        with_prior = case % 2 == 1
        if with_prior:
            terms += StructurePrior().factors(extent, seen=seen)

        def score(s, p=p, seen=seen, with_prior=with_prior):
            habits = habit_cost(s, joint=1, stacked=1, unsupported=1, seen=seen)
            return log_likelihood_from_logs(p, s) - (habits if with_prior else 0.0)

        solver = StructureSolver(extent, backend=backend)
        estimate = solver.solve(terms)
        expected = _brute_tolerance(extent, score, estimate.structure, occluded)
        tol, _ = estimation_tolerance(solver, terms, estimate, occluded)
        assert tol == pytest.approx(expected, abs=1e-6), f"case {case}"


def _line_of_three(occluded_w: bool):
    """A 3-notch log on a line of 3, every feature seen with prior 0.9 for its value under
    it, except the four log ends inside the line (a joint's ends: occluded, ½) and, when
    ``occluded_w``, the long segments (the joint's edges)."""
    from unseeable.domain import FeatureKind, feature_index
    from unseeable.grammar import EvidenceTerm

    truth = Structure(Extent(3, 1, 1), [Log(0, (0, 0), 3)])
    idx = feature_index(truth.extent)
    value = feature_values(truth.extent, truth.occupancy)
    inner_end = (((idx.kind == FeatureKind.END_PLUS) & (idx.at[:, 0] < 2))
                 | ((idx.kind == FeatureKind.END_MINUS) & (idx.at[:, 0] > 0)))
    occluded = inner_end | ((idx.kind == FeatureKind.W) if occluded_w else False)
    p = np.where(occluded, 0.5, np.where(value, 0.9, 0.1))
    return truth, [EvidenceTerm(Evidence(truth.extent, p))], occluded


def test_a_joint_nothing_seen_tells_apart_has_tolerance_zero():
    # With the joints' edges and ends all occluded, a 3-notch log and a 1- and a 2-notch
    # log (or three 1-notch logs) have the same features wherever anything is seen: exact
    # tie-mates, so the smallest shift changes the estimate.
    truth, terms, occluded = _line_of_three(occluded_w=True)
    solver = StructureSolver(truth.extent)
    estimate = solver.solve(terms)
    tol, _ = estimation_tolerance(solver, terms, estimate, occluded)
    assert tol == 0.0
    assert not assess_confidence(solver, terms, estimate, occluded).confident


def test_a_joint_only_its_long_segments_show_has_tolerance_in_closed_form():
    # The long segments seen (0.9 that the log spans them) and the inner ends occluded:
    # splitting the log at a joint changes 2 occluded ends and breaks the bottom and top
    # edge there (2 seen segments, log 9 each), so the split overtakes at
    # ½·tanh(2·log 9 / (2·2)) = ½·tanh(log 3) = 0.4; three 1-notch logs likewise (4 and 4);
    # every other rival changes more seen features per occluded one.
    truth, terms, occluded = _line_of_three(occluded_w=False)
    solver = StructureSolver(truth.extent)
    estimate = solver.solve(terms)
    assert estimate.structure == truth
    tol, _ = estimation_tolerance(solver, terms, estimate, occluded)
    assert tol == pytest.approx(0.4, abs=1e-6)
    assert assess_confidence(solver, terms, estimate, occluded).confident


def test_tolerance_without_a_better_structure_at_the_largest_shift():
    truth = Structure(Extent(3, 1, 3), [Log(0, (0, 0), 3), Log(0, (0, 2), 3)])
    solver, fp, occ = _estimate(truth, 150, 40)
    assert estimation_tolerance(solver, fp.terms, fp.result, np.zeros_like(occ))[0] == 0.5


def test_shift_points_away_from_the_estimate():
    s = Structure(Extent(2, 1, 1), [Log(0, (0, 0), 2)])
    occ = np.ones(22, bool)
    term = shifted_term(s, occ, 0.2)
    value = feature_values(s.extent, s.occupancy)
    assert np.allclose(term.evidence.p[value], 0.3)
    assert np.allclose(term.evidence.p[~value], 0.7)
    with pytest.raises(ValueError):
        shifted_term(s, occ, 0.6)
