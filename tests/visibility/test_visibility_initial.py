"""The paper's initial visibility estimate from the extent's prism."""

from __future__ import annotations

import numpy as np
import pytest

from unseeable.camera import Camera
from unseeable.domain import Extent, FeatureKind, GridPose, feature_index
from unseeable.errors import InputError
from unseeable.visibility import (
    SIDE_FACES,
    camera_facing_faces,
    face_features,
    initial_visibility,
)

E = Extent(3, 3, 3)
CENTRE = [64.0, 0.0, 64.0]  # the footprint's centre in the grid frame (pose = identity)


def camera_at(eye, target=CENTRE):
    return Camera.look_at(eye=eye, target=target, width=640, height=480, fov_deg=60)


def feature(kind, at):
    return feature_index(E).lookup(kind, at)


def test_camera_in_front_of_a_corner_sees_both_front_faces_and_top():
    cam = camera_at([-400.0, 450.0, -400.0])  # beyond the (i=0, k=0) corner
    assert set(camera_facing_faces(E, cam, GridPose())) == {"i_min", "k_min"}
    vis = initial_visibility(E, cam, GridPose())
    expected = (face_features(E, "top") | face_features(E, "i_min")
                | face_features(E, "k_min"))
    idx = feature_index(E)
    # ends turned away from the camera stay occluded
    expected &= ~(idx.kind == FeatureKind.END_PLUS)
    np.testing.assert_array_equal(vis, expected)
    assert vis[feature(FeatureKind.U, (1, 0, 0))]  # front row (k = 0), layer 0
    assert vis[feature(FeatureKind.END_MINUS, (1, 1, 0))]  # layer 1 end sticking out at k = 0
    assert vis[feature(FeatureKind.U, (0, 1, 1))]  # side row (i = 0), layer 1
    assert not vis[feature(FeatureKind.W, (1, 0, 1))]  # inside
    assert not vis[feature(FeatureKind.U, (2, 1, 1))]  # back face i = I-1
    assert not vis[feature(FeatureKind.W, (0, 0, 2))]  # back face k = K-1, below the top


def test_head_on_camera_drops_the_edge_on_face():
    cam = camera_at([64.0, 400.0, -900.0])  # straight in front of the k = 0 face
    assert camera_facing_faces(E, cam, GridPose()) == ("k_min",)
    vis = initial_visibility(E, cam, GridPose())
    assert vis[feature(FeatureKind.U, (1, 0, 0))]
    assert not vis[feature(FeatureKind.U, (0, 1, 1))]  # the i = 0 face is dropped
    cam = camera_at([700.0, 350.0, 64.0])  # straight in front of the i = I-1 face
    assert camera_facing_faces(E, cam, GridPose()) == ("i_max",)


def test_faces_follow_the_pose():
    pose = GridPose(150.0, -80.0, 90.0)
    eye_grid = np.array([-400.0, 450.0, -400.0])
    cam = camera_at(pose.grid_to_world(eye_grid), pose.grid_to_world(CENTRE))
    assert set(camera_facing_faces(E, cam, pose)) == {"i_min", "k_min"}
    np.testing.assert_array_equal(initial_visibility(E, cam, pose),
                                  initial_visibility(E, camera_at(eye_grid), GridPose()))


def test_face_membership():
    idx = feature_index(E)
    top = face_features(E, "top")
    assert np.all(idx.at[top & (idx.kind >= FeatureKind.U), 1] >= E.J - 1)
    assert top[feature(FeatureKind.END_PLUS, (2, 2, 1))]  # top layer (even) end at i = I-1
    assert not top[feature(FeatureKind.END_PLUS, (1, 2, 1))]  # inside a row
    k_min = face_features(E, "k_min")
    assert k_min[feature(FeatureKind.W, (1, 2, 0))]
    assert not k_min[feature(FeatureKind.W, (2, 2, 0))]  # beyond the prism
    assert k_min[feature(FeatureKind.END_MINUS, (2, 1, 0))]
    assert not k_min[feature(FeatureKind.END_PLUS, (2, 1, 0))]
    assert not k_min[feature(FeatureKind.V, (2, 1, 0))]
    # every side-face feature sits on that face's outer row
    for face in SIDE_FACES:
        m = face_features(E, face)
        axis = 0 if face.startswith("i") else 2
        row = 0 if face.endswith("min") else E.shape[axis] - 1
        assert m.any() and np.all(idx.at[m, axis] == row)
    with pytest.raises(InputError):
        face_features(E, "front")
