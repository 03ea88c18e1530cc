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


def test_tolerance_is_the_smallest_changing_shift():
    truth = load_design("tower-roofed-core").structure
    solver, fp, occ = _estimate(truth, 150, 25, seed=3)
    tol, resolves = estimation_tolerance(solver, fp.terms, fp.result, occ, resolution=0.01)
    from unseeable.confidence import estimate_changes

    if tol < 0.5:
        assert estimate_changes(solver, fp.terms, fp.result, occ, tol)
        assert not estimate_changes(solver, fp.terms, fp.result, occ, max(0.0, tol - 0.011))
    assert resolves >= 1


def test_shift_points_away_from_the_estimate():
    s = Structure(Extent(2, 1, 1), [Log(0, (0, 0), 2)])
    occ = np.ones(22, bool)
    term = shifted_term(s, occ, 0.2)
    value = feature_values(s.extent, s.occupancy)
    assert np.allclose(term.evidence.p[value], 0.3)
    assert np.allclose(term.evidence.p[~value], 0.7)
    with pytest.raises(ValueError):
        shifted_term(s, occ, 0.6)
