"""View and truth files: round trips, relative paths, clear errors."""

from __future__ import annotations

import json

import numpy as np
import pytest

from unseeable.camera import Camera, save_camera
from unseeable.domain import Extent, GridPose, Log, Structure, feature_index
from unseeable.errors import InputError
from unseeable.render.view import (
    View,
    ViewTruth,
    load_truth,
    load_view,
    save_truth,
    save_view,
    write_image,
)


@pytest.fixture
def camera() -> Camera:
    return Camera.look_at(eye=[0, 500, -800], target=[0, 0, 0], width=8, height=6, fov_deg=50)


@pytest.fixture
def image() -> np.ndarray:
    return np.random.default_rng(0).integers(0, 256, (6, 8, 3), dtype=np.uint8)


def test_view_round_trips_with_relative_image_path(tmp_path, camera, image):
    view = View(image, camera, Extent(2, 3, 4), GridPose(1.0, 2.0, 30.0), removed_from_layer=2)
    saved = save_view(view, tmp_path / "sub" / "v.json")
    data = json.loads((tmp_path / "sub" / "v.json").read_text())
    assert data["format"] == "unseeable/view@1" and data["image"] == "v.png"
    assert data["pose"] == {"x": 1.0, "z": 2.0, "yaw_deg": 30.0}
    back = load_view(tmp_path / "sub" / "v.json")
    assert not back.loaded  # the pixels wait until needed
    np.testing.assert_array_equal(back.image, image)
    assert back.extent == Extent(2, 3, 4) and back.pose == view.pose
    assert back.removed_from_layer == 2 and back.removed_logs is None
    np.testing.assert_allclose(back.camera.K, camera.K)
    assert saved.image_path == tmp_path / "sub" / "v.png"


def test_view_file_may_name_a_camera_file_and_omit_the_pose(tmp_path, camera, image):
    save_camera(camera, tmp_path / "cams" / "cam.json")
    write_image(tmp_path / "img" / "a.png", image)
    (tmp_path / "v.json").write_text(json.dumps({
        "format": "unseeable/view@1", "image": "img/a.png", "camera": "cams/cam.json",
        "extent": [1, 1, 1]}))
    view = load_view(tmp_path / "v.json")
    assert view.pose is None and view.removed_from_layer is None
    np.testing.assert_array_equal(view.image, image)


def _write(tmp_path, **changes):
    data = {"format": "unseeable/view@1", "image": "a.png",
            "camera": json.loads(json.dumps(changes.pop("camera_json"))), "extent": [1, 1, 1]}
    data.update(changes)
    path = tmp_path / "v.json"
    path.write_text(json.dumps(data))
    return path


def test_missing_image_names_file_field_and_value(tmp_path, camera):
    from unseeable.camera import camera_to_json

    path = _write(tmp_path, camera_json=camera_to_json(camera))
    with pytest.raises(InputError) as err:
        load_view(path)
    assert str(path) in str(err.value) and "image" in str(err.value) and "a.png" in str(err.value)


def test_image_of_the_wrong_size_is_rejected(tmp_path, camera):
    from unseeable.camera import camera_to_json

    write_image(tmp_path / "a.png", np.zeros((7, 8, 3), np.uint8))
    path = _write(tmp_path, camera_json=camera_to_json(camera))
    with pytest.raises(InputError, match="8x7 but the camera's image is 8x6"):
        load_view(path)


@pytest.mark.parametrize("bad", [
    {"camera_json": {"format": "unseeable/camera@1", "width": 8}},
    {"camera_json": "missing.json"},
    {"camera_json": 3},
])
def test_bad_camera_is_rejected(tmp_path, bad):
    write_image(tmp_path / "a.png", np.zeros((6, 8, 3), np.uint8))
    path = _write(tmp_path, **bad)
    with pytest.raises(InputError, match="camera"):
        load_view(path)


def test_bad_fields_are_rejected(tmp_path, camera):
    from unseeable.camera import camera_to_json

    write_image(tmp_path / "a.png", np.zeros((6, 8, 3), np.uint8))
    cam = camera_to_json(camera)
    for change, field in (({"extent": [0, 1, 1]}, "extent"),
                          ({"pose": {"x": 1}}, "pose.z"),
                          ({"removed_from_layer": -1}, "removed_from_layer"),
                          ({"format": "unseeable/view@2"}, "format")):
        with pytest.raises(InputError, match=field.replace(".", r"\.")):
            load_view(_write(tmp_path, camera_json=cam, **change))


def test_view_rejects_image_of_other_size(camera):
    with pytest.raises(InputError):
        View(np.zeros((6, 9, 3), np.uint8), camera, Extent(1, 1, 1))
    with pytest.raises(InputError):
        View(np.zeros((6, 8), np.uint8), camera, Extent(1, 1, 1))


def test_truth_round_trips(tmp_path, camera):
    s = Structure(Extent(2, 2, 1), [Log(0, (0, 0), 2), Log(1, (1, 0), 1)])
    n = len(feature_index(s.extent))
    rng = np.random.default_rng(1)
    ids = rng.integers(-1, 2, (6, 8)).astype(np.int32)
    depth = rng.random((6, 8)).astype(np.float32)
    depth[0, 0] = np.inf
    truth = ViewTruth(s, GridPose(3.0, 4.0, 5.0), camera, rng.random(n) < 0.5,
                      rng.random(n) < 0.5, ids, depth, removed_from_layer=1,
                      removed_logs=(1,), look={"exposure": 1.0})
    save_truth(truth, tmp_path / "v.truth.json")
    assert (tmp_path / "v.ids.npz").exists()
    data = json.loads((tmp_path / "v.truth.json").read_text())
    assert data["format"] == "unseeable/truth@1" and data["ids"] == "v.ids.npz"
    assert set(data["features"][0]) == {"kind", "at", "present", "visible"}
    back = load_truth(tmp_path / "v.truth.json")
    assert back.structure == s and back.pose == truth.pose
    np.testing.assert_array_equal(back.present, truth.present)
    np.testing.assert_array_equal(back.visible, truth.visible)
    np.testing.assert_array_equal(back.ids, ids)
    np.testing.assert_array_equal(back.depth, depth)
    assert back.removed_from_layer == 1 and back.removed_logs == (1,)
    assert back.shown == s.with_logs([s.logs[0]])


def test_truth_rejects_wrong_feature_count(camera):
    s = Structure(Extent(1, 1, 1), [Log(0, (0, 0), 1)])
    with pytest.raises(InputError):
        ViewTruth(s, GridPose(), camera, np.zeros(3, bool), np.zeros(3, bool))
