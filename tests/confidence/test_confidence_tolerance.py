import numpy as np
import pytest

from simulated_view import simulated_observation, station_camera
from unseeable.confidence import (
    assess_confidence,
    estimation_tolerance,
    occluded_features,
    shifted_term,
)
from unseeable.corpus import load_design
from unseeable.domain import Extent, Log, Structure, feature_values
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
    # The estimate stands at the tolerance (tied at most) and changes just above it;
    # with an exact tie-mate on occluded features (the hearth's cabin) that is at 0.
    from unseeable.confidence import estimate_changes

    solver, fp, occ = _estimate(load_design(design).structure, angle, elevation, seed=seed)
    tol, resolves = estimation_tolerance(solver, fp.terms, fp.result, occ)
    assert 0 <= tol < 0.5 and resolves >= 1
    assert (tol == 0) == (design == "cabin-4x4-hearth")
    if tol > 0:
        assert not estimate_changes(solver, fp.terms, fp.result, occ, tol)
    assert estimate_changes(solver, fp.terms, fp.result, occ, tol + 0.002)
    # the same from the δ* outcome, as assess_confidence starts
    conf = assess_confidence(solver, fp.terms, fp.result, occ)
    assert conf.tolerance == pytest.approx(tol, abs=1e-9)
    assert conf.confident == (tol >= conf.delta_star)


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
