"""The camera module: projection, rays, look-at, distortion, scaling, the camera file."""

from __future__ import annotations

import json

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from unseeable.camera import Camera, load_camera, save_camera
from unseeable.errors import InputError

finite = st.floats(-500, 500, allow_nan=False)


def _camera(eye=(300.0, 400.0, -700.0), dist=None) -> Camera:
    return Camera.look_at(eye=list(eye), target=[10.0, 20.0, 30.0], width=640, height=480,
                          fov_deg=55.0, dist=dist)


def test_look_at_puts_the_target_in_the_middle_with_up_up():
    cam = _camera()
    np.testing.assert_allclose(cam.project(np.array([[10.0, 20.0, 30.0]]))[0], [320, 240],
                               atol=1e-9)
    np.testing.assert_allclose(cam.centre, [300, 400, -700], atol=1e-9)
    above = cam.project(np.array([[10.0, 120.0, 30.0]]))[0]
    assert above[1] < 240  # world up is image up (y down)
    assert np.linalg.det(cam.R) == pytest.approx(1.0)


def test_camera_axes_follow_opencv():
    cam = Camera.look_at(eye=[0, 0, -1000], target=[0, 0, 0], width=100, height=100, fov_deg=90)
    # OpenCV axes: x right, y down, z forward. Looking along +z with +y up, image right is
    # forward x up = -x in the world.
    right = cam.project(np.array([[100.0, 0.0, 0.0]]))[0]
    down = cam.project(np.array([[0.0, -100.0, 0.0]]))[0]
    assert down[1] > 50
    assert right[0] < 50
    assert cam.depth(np.array([[0.0, 0.0, 0.0]]))[0] == pytest.approx(1000.0)


@settings(max_examples=30, deadline=None)
@given(st.tuples(finite, finite, finite), st.booleans())
def test_pixel_rays_invert_projection(point, distorted):
    cam = _camera(dist=[-0.1, 0.02, 0.001, -0.001, 0.0] if distorted else None)
    p = np.array([point])
    if cam.depth(p)[0] < 50:
        return
    uv = cam.project(p)
    if not cam.in_image(uv).all():
        return
    ray = cam.pixel_rays(uv)[0]
    to_point = (p[0] - cam.centre) / np.linalg.norm(p[0] - cam.centre)
    np.testing.assert_allclose(ray, to_point, atol=1e-5)


@pytest.mark.parametrize("distorted", [False, True])
def test_normalised_coordinates_are_the_camera_frame_point_over_its_depth(distorted):
    cam = _camera(dist=[-0.1, 0.02, 0.001, -0.001, 0.0] if distorted else None)
    p = np.array([[10.0, 20.0, 30.0], [-40.0, 5.0, 60.0]])
    q = cam.world_to_camera(p)
    got = cam.normalised(cam.project(p)[None])  # any leading shape is kept
    assert got.shape == (1, 2, 2)
    np.testing.assert_allclose(got[0], q[:, :2] / q[:, 2:], atol=1e-5)


def test_points_behind_the_camera_project_to_nan():
    cam = _camera()
    behind = cam.centre + (cam.centre - np.array([10.0, 20.0, 30.0]))
    assert np.isnan(cam.project(behind[None])).all()


def test_scaled_camera_scales_pixels():
    cam = _camera()
    half = cam.scaled(0.5)
    p = np.array([[50.0, 10.0, 40.0]])
    # Pixel centres at whole coordinates: pixel 0 of the half image covers pixels 0 and 1.
    np.testing.assert_allclose(half.project(p), (cam.project(p) + 0.5) * 0.5 - 0.5, atol=1e-9)
    assert half.size == (320, 240)


@pytest.mark.parametrize("factor", [0.37, 0.5, 1.6, 3.0])
def test_scaled_camera_sees_a_point_where_cv2_resize_puts_it(factor):
    import cv2

    cam = _camera()
    p = np.array([[50.0, 10.0, 40.0]])
    u, v = cam.project(p)[0]
    # A smooth blob at the point's projection, resized as the vision stage resizes images.
    yy, xx = np.mgrid[0:cam.height, 0:cam.width]
    blob = np.exp(-((xx - u) ** 2 + (yy - v) ** 2) / (2 * 6.0**2)).astype(np.float32)
    small = cam.scaled(factor)
    resized = cv2.resize(blob, small.size, interpolation=cv2.INTER_AREA if factor < 1
                         else cv2.INTER_LINEAR)
    yy, xx = np.mgrid[0:small.height, 0:small.width]
    w = resized / resized.sum()
    centroid = np.array([(w * xx).sum(), (w * yy).sum()])
    np.testing.assert_allclose(centroid, small.project(p)[0], atol=0.03)


def test_camera_file_round_trip(tmp_path):
    cam = _camera(dist=[0.1, 0.0, 0.0, 0.0, 0.0])
    save_camera(cam, tmp_path / "c.json")
    back = load_camera(tmp_path / "c.json")
    for name in ("K", "R", "t", "dist"):
        np.testing.assert_allclose(getattr(back, name), getattr(cam, name))
    assert back.size == cam.size


@pytest.mark.parametrize("change, field", [
    ({"width": 0}, "width"),
    ({"R": [[1, 0, 0], [0, 1, 0], [0, 0, -1]]}, "R"),
    ({"K": [[-5, 0, 1], [0, 5, 1], [0, 0, 1]]}, "K"),
    ({"t": [1, 2]}, "t"),
    ({"dist": [1, 2, 3]}, "dist"),
])
def test_bad_camera_file_names_the_field(tmp_path, change, field):
    from unseeable.camera import camera_to_json

    data = camera_to_json(_camera())
    data.update(change)
    (tmp_path / "c.json").write_text(json.dumps(data))
    with pytest.raises(InputError) as err:
        load_camera(tmp_path / "c.json")
    assert field in str(err.value) and "c.json" in str(err.value)


def test_look_at_rejects_degenerate_views():
    with pytest.raises(InputError):
        Camera.look_at(eye=[0, 100, 0], target=[0, 0, 0], width=10, height=10, fov_deg=50)
    with pytest.raises(InputError):
        Camera.look_at(eye=[0, 0, 0], target=[0, 0, 0], width=10, height=10, fov_deg=50)
    with pytest.raises(InputError):
        Camera.look_at(eye=[0, 0, -1], target=[0, 0, 0], width=10, height=10)
