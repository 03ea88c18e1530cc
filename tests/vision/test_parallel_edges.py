"""Parallel log edges within a segment detector's reach (``parallel_edge_pairs``)."""

from __future__ import annotations

import numpy as np
import pytest

from unseeable.camera import Camera
from unseeable.domain import Extent, GridPose
from unseeable.errors import InputError
from unseeable.vision.projection import parallel_edge_pairs, project_features


@pytest.fixture(scope="module")
def steep():
    """A camera looking steeply down along the grid's i axis onto a small tower."""
    cam = Camera.look_at(eye=[0, 520, -320], target=[0, 40, 0], width=640, height=480,
                         fov_deg=45)
    return project_features(Extent(3, 6, 3), GridPose(-64, 0, -64), cam)


def _line_distance(points, line):
    a, b = line
    u = (b - a) / np.linalg.norm(b - a)
    n = np.array([-u[1], u[0]])
    return np.abs((points - a) @ n)


def test_pairs_lie_beside_within_reach(steep):
    first, second, upper = parallel_edge_pairs(steep, ~steep.is_end, reach_px=4.0)
    assert len(first) > 0
    assert not np.any(first == second)
    for f, g, up in zip(first, second, upper):
        edge = (steep.upper_segments if up else steep.detector_segments)[g]
        stretch = steep.detector_segments[f]
        assert np.all(_line_distance(stretch, edge) < 4.0)
        cos = abs(np.dot(stretch[1] - stretch[0], edge[1] - edge[0])
                  / np.linalg.norm(stretch[1] - stretch[0]) / np.linalg.norm(edge[1] - edge[0]))
        assert cos > np.cos(np.radians(3.0))


def test_only_judged_features_are_explained(steep):
    judged = ~steep.is_end & (np.arange(len(steep)) % 2 == 0)
    first, _, _ = parallel_edge_pairs(steep, judged)
    assert judged[first].all()


def test_a_longer_reach_finds_more(steep):
    near = set(zip(*(a.tolist() for a in parallel_edge_pairs(steep, ~steep.is_end,
                                                             reach_px=2.0))))
    far = set(zip(*(a.tolist() for a in parallel_edge_pairs(steep, ~steep.is_end,
                                                            reach_px=6.0))))
    assert near <= far and len(far) > len(near)


def test_upper_edges_come_from_two_layers_up(steep):
    from unseeable.domain import feature_index

    _, second, upper = parallel_edge_pairs(steep, ~steep.is_end, reach_px=6.0)
    layers = feature_index(steep.extent).at[second[upper], 1]
    assert np.all(layers >= 2)  # no log two layers below layers 0 and 1


def test_rejects_bad_reach_and_mask(steep):
    with pytest.raises(InputError):
        parallel_edge_pairs(steep, ~steep.is_end, reach_px=0.0)
    with pytest.raises(InputError):
        parallel_edge_pairs(steep, np.ones(3, dtype=bool))
