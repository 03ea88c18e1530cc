"""World/grid frames: poses, symbolic orientations, half turns."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from strategies import extents, structures
from unseeable.domain import (
    Extent,
    GridPose,
    LogGeometry,
    half_turn_structure,
    is_valid,
    symbolic_orientations,
)

G = LogGeometry()
poses = st.builds(GridPose, st.floats(-500, 500), st.floats(-500, 500), st.floats(-180, 180))


def _footprint(pose: GridPose, extent: Extent) -> np.ndarray:
    """World corners of the grid footprint, sorted so that equal footprints compare equal."""
    far_i, far_k = (extent.I - 1) * G.l1, (extent.K - 1) * G.l1
    corners = np.array([[0, 0, 0], [far_i, 0, 0], [0, 0, far_k], [far_i, 0, far_k]], float)
    world = np.round(pose.grid_to_world(corners), 6)
    return world[np.lexsort(world.T[::-1])]


@settings(max_examples=50, deadline=None)
@given(poses, extents())
def test_grid_and_world_maps_are_inverse(pose, extent):
    pts = np.random.default_rng(0).normal(0, 200, (10, 3))
    np.testing.assert_allclose(pose.world_to_grid(pose.grid_to_world(pts)), pts, atol=1e-9)
    m = pose.matrix()
    np.testing.assert_allclose(pts @ m[:3, :3].T + m[:3, 3], pose.grid_to_world(pts))


@settings(max_examples=50, deadline=None)
@given(poses, extents(), st.integers(-8, 8), st.integers(-8, 8))
def test_quarter_turns_compose_and_four_are_the_identity(pose, extent, a, b):
    def same(p: GridPose, q: GridPose) -> bool:
        dt, dy = p.distance(q)
        return dt < 1e-6 and dy < 1e-6

    four, e4 = pose.turned(4, extent)
    assert same(four, pose) and e4 == extent
    assert pose.turned(0, extent) == (pose, extent)  # exactly: results are keyed by poses
    once, e1 = pose.turned(a, extent)
    twice, e2 = once.turned(b, e1)
    direct, ed = pose.turned(a + b, extent)
    assert same(twice, direct) and e2 == ed
    # Every symbolic orientation keeps the footprint on the table.
    for _, p, e in symbolic_orientations(pose, extent):
        np.testing.assert_allclose(_footprint(p, e), _footprint(pose, extent), atol=1e-5)


def test_quarter_turn_swaps_i_and_k():
    pose, extent = GridPose(0.0, 0.0, 0.0), Extent(2, 3, 5)
    turned, e = pose.turned(1, extent)
    assert e == Extent(5, 3, 2) and turned.yaw_deg == pytest.approx(90.0)
    assert [o for o, _, _ in symbolic_orientations(pose, extent)] == [0, 2]
    assert len(symbolic_orientations(pose, Extent(3, 1, 3))) == 4


@settings(max_examples=40, deadline=None)
@given(structures())
def test_half_turn_keeps_structures_valid_and_twice_is_identity(structure):
    turned = half_turn_structure(structure)
    assert is_valid(turned) == is_valid(structure)
    assert half_turn_structure(turned) == structure
    assert len(turned.logs) == len(structure.logs)


@settings(max_examples=30, deadline=None)
@given(structures(), poses)
def test_half_turn_describes_the_same_physical_assembly(structure, pose):
    # The half-turned structure at the half-turned pose puts every log in the same place.
    turned_pose, extent = pose.turned(2, structure.extent)
    turned = half_turn_structure(structure)

    def log_centres(s, p):
        out = []
        for log in s.logs:
            pos = np.array(log.positions(), float)
            mid = pos.mean(axis=0)
            out.append(p.grid_to_world(np.array([mid[0] * G.l1, G.layer_height(mid[1]),
                                                 mid[2] * G.l1])))
        arr = np.round(np.array(out).reshape(-1, 3), 5)
        return arr[np.lexsort(arr.T[::-1])] if len(arr) else arr

    np.testing.assert_allclose(log_centres(turned, turned_pose), log_centres(structure, pose),
                               atol=1e-4)
