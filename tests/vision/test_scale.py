"""Photographs at other scales are judged at the scale the detectors were calibrated at."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from unseeable.camera import Camera
from unseeable.domain import feature_values
from unseeable.errors import InputError
from unseeable.render.workspace import PendulumArm
from unseeable.vision import detect_features, estimate_pose, pose_equivalent
from unseeable.vision.scale import (
    CALIBRATED_MM_PER_PX,
    POSE_FINEST_MM_PER_PX,
    camera_for,
    mm_per_pixel,
    pose_view,
    view_edge_maps,
    working_scale,
    working_view,
)


@pytest.mark.parametrize("station", [90.0, 150.0, 210.0])
def test_the_workspace_cameras_are_used_as_they_are(station):
    camera = PendulumArm().camera(station)
    lo, _, hi = CALIBRATED_MM_PER_PX
    assert lo <= mm_per_pixel(camera) <= hi
    assert working_scale(camera) == 1.0
    image = np.zeros((camera.height, camera.width, 3), np.uint8)
    same, cam = working_view(image, camera)
    assert same is image and cam is camera


@pytest.mark.parametrize("factor", [0.25, 0.5, 2.0, 3.0])
def test_finer_and_coarser_cameras_are_resampled_into_the_calibrated_range(factor):
    camera = PendulumArm().camera(135.0).scaled(factor)
    image = np.zeros((camera.height, camera.width, 3), np.uint8)
    resized, cam = working_view(image, camera)
    assert resized.shape[:2] == (cam.height, cam.width)
    lo, _, hi = CALIBRATED_MM_PER_PX
    if factor >= 0.5:  # a 4x coarser image is enlarged at most twice
        assert lo <= mm_per_pixel(cam) <= hi
    point = np.array([[30.0, 20.0, -40.0]])
    # Pixel centres at whole coordinates, each axis scaled by its exact size ratio.
    ratio = np.array([cam.width / camera.width, cam.height / camera.height])
    assert ratio == pytest.approx(working_scale(camera), rel=0.01)
    np.testing.assert_allclose(cam.project(point), (camera.project(point) + 0.5) * ratio - 0.5,
                               atol=1e-9)
    assert camera_for(resized.shape[:2], camera).K[0, 0] == pytest.approx(cam.K[0, 0])


def test_maps_of_another_size_are_refused_with_the_sizes():
    camera = PendulumArm().camera(135.0)
    with pytest.raises(InputError, match="333x222"):
        camera_for((222, 333), camera)


def test_a_camera_that_does_not_see_the_table_is_left_alone():
    camera = Camera.look_at(eye=[0, 100, -600], target=[0, 300, 0], width=640, height=480,
                            fov_deg=50)
    assert np.isnan(mm_per_pixel(camera))
    assert working_scale(camera) == 1.0


@pytest.fixture(scope="module")
def house_twice_as_fine(rendered_house):
    """The rendered cabin again, by a camera with twice the resolution."""
    from unseeable.render.renderer import render_view
    from unseeable.render.settings import RenderSettings

    s, pose, camera, image = rendered_house
    fine = camera.scaled(2.0)
    fine_image, _, _ = render_view(s, pose, fine, settings=RenderSettings(spp=4), seed=3)
    return s, pose, camera, image, fine, fine_image


@pytest.mark.slow
def test_a_finer_photograph_gives_the_same_pose_and_detections(house_twice_as_fine):
    s, pose, camera, image, fine, fine_image = house_twice_as_fine
    fit = estimate_pose(fine_image, fine, s.extent)
    assert pose_equivalent(fit.pose, pose, s.extent) <= (2.0, 1.0)
    native = detect_features(image, camera, pose, s.extent)
    finer = detect_features(fine_image, fine, pose, s.extent)
    both = native.judged & finer.judged
    assert both.sum() >= 0.9 * native.judged.sum()
    agree = np.mean((native.p[both] > 0.5) == (finer.p[both] > 0.5))
    assert agree >= 0.9
    truth = feature_values(s.extent, s.occupancy) != 0
    right = [np.mean((d.p[both] > 0.5) == truth[both]) for d in (native, finer)]
    assert right[1] >= right[0] - 0.03


def test_the_pose_search_keeps_a_fine_image_and_enlarges_a_coarse_one():
    camera = PendulumArm().camera(135.0)
    fine, coarse = camera.scaled(2.0), camera.scaled(0.5)
    image = np.zeros((fine.height, fine.width, 3), np.uint8)
    kept, cam = pose_view(image, fine)
    assert kept is image and cam is fine
    small = np.zeros((coarse.height, coarse.width, 3), np.uint8)
    enlarged, cam = pose_view(small, coarse)
    assert enlarged.shape[:2] == (cam.height, cam.width) == (camera.height, camera.width)


def test_the_pose_search_shrinks_a_photograph_finer_than_its_floor():
    camera = PendulumArm().camera(135.0)
    huge = camera.scaled(6.0)  # about 0.29 mm per pixel: a 12-megapixel photograph
    assert mm_per_pixel(huge) < POSE_FINEST_MM_PER_PX
    image = np.zeros((huge.height, huge.width, 3), np.uint8)
    shrunk, cam = pose_view(image, huge)
    assert shrunk.shape[:2] == (cam.height, cam.width) and cam.width < huge.width
    assert mm_per_pixel(cam) == pytest.approx(POSE_FINEST_MM_PER_PX, rel=0.01)
    # Edge maps of that view find their camera again (the pose polish is given maps).
    assert camera_for(shrunk.shape[:2], huge).width == cam.width
    just_above = camera.scaled(mm_per_pixel(camera) / (1.05 * POSE_FINEST_MM_PER_PX))
    kept = np.zeros((just_above.height, just_above.width, 3), np.uint8)
    assert pose_view(kept, just_above)[0] is kept


def test_edge_maps_are_reused_at_the_size_each_stage_needs():
    fine = PendulumArm().camera(135.0).scaled(2.0)
    image = np.random.default_rng(0).integers(0, 255, (fine.height, fine.width, 3), np.uint8)
    pose_maps = view_edge_maps(image, fine, pose=True)
    assert pose_maps.shape == (fine.height, fine.width)
    assert view_edge_maps(image, fine, pose=True, maps=pose_maps) is pose_maps
    detector_maps = view_edge_maps(image, fine, maps=pose_maps)
    assert detector_maps.shape == working_view(image, fine)[0].shape[:2]
    assert camera_for(detector_maps.shape, fine).width == detector_maps.shape[1]


@pytest.mark.slow
def test_the_detections_are_drawn_where_the_photograph_shows_the_features(house_twice_as_fine):
    from unseeable.vision import draw_detection, project_features
    from unseeable.vision.detectors import DetectorSettings

    s, pose, _, _, fine, fine_image = house_twice_as_fine
    det = detect_features(fine_image, fine, pose, s.extent)
    picture = draw_detection(fine_image, fine, det)
    assert picture.shape == fine_image.shape
    ends = det.judged & np.isfinite(det.scores.ellipses[:, 0])
    # Each best fit lies within the detector's centre perturbation (in its own pixels) of the
    # feature's projection in the photograph.
    _, work = working_view(fine_image, fine)
    ratio = np.array([work.width / fine.width, work.height / fine.height])
    drawn = (det.scores.ellipses[ends, :2] + 0.5) / ratio - 0.5  # pixel centres at integers
    expected = project_features(s.extent, det.pose, fine).ellipses[ends, :2]
    reach = np.hypot(*(2 * [DetectorSettings().end_shift])) / ratio.min()
    assert np.all(np.linalg.norm(drawn - expected, axis=1) <= reach + 1e-6)
    # And the picture is drawn there: near every judged end's projected rim.
    dimmed = (fine_image.astype(np.float32) * 0.6).astype(np.uint8)
    touched = np.any(picture != dimmed, axis=2).astype(np.uint8)
    touched = cv2.dilate(touched, np.ones((2 * int(np.ceil(reach)) + 1,) * 2, np.uint8)) > 0
    rims = project_features(s.extent, det.pose, fine).rims[ends].reshape(-1, 2)
    col, row = np.round(rims).astype(int).T
    assert touched[row, col].mean() >= 0.95


@pytest.mark.parametrize("stage", ["detectors", "pose"])
def test_an_image_that_is_not_the_cameras_size_is_refused_with_both_sizes(stage):
    from unseeable.domain import Extent, GridPose

    camera = PendulumArm().camera(135.0)
    image = np.zeros((100, 120, 3), np.uint8)
    with pytest.raises(InputError, match="image is 120x100 but the camera expects 640x480"):
        if stage == "detectors":
            detect_features(image, camera, GridPose(), Extent(2, 1, 2))
        else:
            estimate_pose(image, camera, Extent(2, 1, 2))
