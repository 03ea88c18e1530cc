import numpy as np
import pytest

from simulated_view import simulated_observation, station_camera
from unseeable.corpus import load_design
from unseeable.evaluate import count_errors
from unseeable.solve import StructureSolver
from unseeable.visibility import initial_visibility
from unseeable.visibility.loop import estimate_with_visibility


@pytest.mark.parametrize("name, angle, elevation", [
    ("cabin-4x4-hearth", 150, 20), ("tower-roofed-core", 120, 40), ("wall-door", 150, 20)])
def test_automatic_visibility_is_as_good_as_manual(name, angle, elevation):
    truth = load_design(name).structure
    cam, pose = station_camera(truth, angle, elevation_deg=elevation)
    obs, truth_vis = simulated_observation(truth, cam, pose, seed=1)
    solver = StructureSolver(truth.extent, ties="emptiest")
    manual = estimate_with_visibility(obs, truth.extent, solver=solver,
                                      initial_visibility=truth_vis, fixed_visibility=True)
    auto = estimate_with_visibility(obs, truth.extent, solver=solver,
                                    initial_visibility=initial_visibility(truth.extent, cam, pose))
    assert 1 <= auto.iterations <= 12
    assert auto.converged or auto.cycle_length >= 2
    assert np.mean(auto.visibility[0] == truth_vis) > 0.95
    assert count_errors(truth, auto.structure) <= count_errors(truth, manual.structure) + 1


def test_manual_visibility_is_a_single_estimate():
    truth = load_design("cabin-4x4-hearth").structure
    cam, pose = station_camera(truth, 120)
    obs, truth_vis = simulated_observation(truth, cam, pose, seed=2)
    fp = estimate_with_visibility(obs, truth.extent, solver=StructureSolver(truth.extent),
                                  initial_visibility=truth_vis, fixed_visibility=True)
    assert fp.iterations == 1 and fp.converged
    assert np.array_equal(fp.visibility[0], truth_vis)
