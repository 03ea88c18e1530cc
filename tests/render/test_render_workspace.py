"""The workspace: arm geometry and framing, removal, observations with their truth."""

from __future__ import annotations

import numpy as np
import pytest

from unseeable.domain import Extent, GridPose, LogGeometry, feature_values
from unseeable.errors import InputError
from unseeable.render.settings import RenderSettings, SceneRandomisation
from unseeable.render.workspace import (
    DEFAULT_STATIONS,
    PendulumArm,
    Workspace,
    default_pose,
    jitter_camera,
)

G = LogGeometry()


def test_angle_convention_counter_clockwise_from_plus_x_seen_from_above():
    arm = PendulumArm(radius_mm=1000.0, elevation_deg=None, height_mm=500.0,
                      look_at=(0.0, 0.0, 0.0))
    np.testing.assert_allclose(arm.camera_centre(0.0), [1000.0, 500.0, 0.0], atol=1e-9)
    np.testing.assert_allclose(arm.camera_centre(90.0), [0.0, 500.0, -1000.0], atol=1e-9)
    np.testing.assert_allclose(arm.camera_centre(180.0), [-1000.0, 500.0, 0.0], atol=1e-9)
    # Seen from above (looking down -y), +x to the right, -z up the page: counter-clockwise.
    a, b = arm.camera_centre(10.0), arm.camera_centre(20.0)
    cross_y = a[2] * b[0] - a[0] * b[2]  # y component of a x b
    assert cross_y > 0


def test_every_station_looks_at_the_look_at_point():
    arm = PendulumArm(look_at=(10.0, 20.0, -5.0))
    for angle in DEFAULT_STATIONS:
        cam = arm.camera(angle)
        uv = cam.project(np.array([arm.look_at]))[0]
        np.testing.assert_allclose(uv, [cam.width / 2, cam.height / 2], atol=1e-6)
        assert np.hypot(*(cam.centre - np.array(arm.look_at))[[0, 2]]) == pytest.approx(900.0)


def test_elevation_sets_the_height():
    arm = PendulumArm(elevation_deg=45.0, radius_mm=500.0, look_at=(0.0, 30.0, 0.0))
    assert arm.camera_height_mm == pytest.approx(530.0)


def test_default_arm_frames_an_8x8x8_assembly_at_any_yaw_from_every_station():
    extent = Extent(8, 8, 8)
    lo = np.array([-G.l3, 0.0, -G.l3])
    hi = np.array([7 * G.l1 + G.l3, G.layer_height(7) + G.radius, 7 * G.l1 + G.l3])
    corners = np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1])
                        for z in (lo[2], hi[2])])
    arm = PendulumArm()
    for yaw in (0.0, 20.0, 45.0, 80.0):
        pose = default_pose(extent, G, yaw)
        world = pose.grid_to_world(corners)
        for angle in arm.stations_deg:
            cam = arm.camera(angle)
            assert cam.in_image(cam.project(world), margin=20).all(), (yaw, angle)


def test_default_pose_centres_the_footprint():
    for extent in (Extent(3, 2, 5), Extent(8, 1, 2)):
        pose = default_pose(extent, G, 30.0)
        far = np.array([(extent.I - 1) * G.l1, 0.0, (extent.K - 1) * G.l1])
        mid = pose.grid_to_world(np.array([np.zeros(3), far])).mean(axis=0)
        np.testing.assert_allclose(mid, 0.0, atol=1e-9)


def test_bad_arm_is_an_input_error():
    with pytest.raises(InputError):
        PendulumArm(radius_mm=-1.0)
    with pytest.raises(InputError):
        PendulumArm(elevation_deg=None, height_mm=None)
    with pytest.raises(InputError):
        PendulumArm().camera(float("nan"))


def test_jitter_moves_the_camera_by_about_sigma():
    cam = PendulumArm().camera(150.0)
    rng = np.random.default_rng(0)
    moved = [jitter_camera(cam, rng, position_mm=5.0, rotation_deg=0.5) for _ in range(200)]
    shift = np.array([m.centre - cam.centre for m in moved])
    assert shift.std() == pytest.approx(5.0, rel=0.15)
    assert jitter_camera(cam, rng, position_mm=0.0, rotation_deg=0.0) is cam


@pytest.fixture(scope="module")
def workspace(cabin_structure):
    return Workspace(cabin_structure, arm=PendulumArm(radius_mm=500, width=80, height=60),
                     settings=RenderSettings(spp=2), seed=4)


def test_observe_returns_the_view_and_keeps_its_truth(workspace, cabin_structure):
    view = workspace.observe(120.0)
    truth = workspace.truth(view)
    assert view.image.shape == (60, 80, 3)
    assert view.extent == cabin_structure.extent and view.pose == workspace.pose
    assert view.removed_from_layer is None
    np.testing.assert_array_equal(
        truth.present, feature_values(cabin_structure.extent, cabin_structure.occupancy))
    assert truth.visible[truth.present].any() and not truth.visible[truth.present].all()
    assert set(np.unique(truth.ids)) - {-1} <= set(range(len(cabin_structure.logs)))
    # No randomisation: the view's camera is the camera that took the photograph.
    np.testing.assert_allclose(truth.camera.R, view.camera.R)


def test_observe_after_removal_shows_fewer_logs(workspace, cabin_structure):
    view = workspace.observe(120.0, removed_from_layer=3)
    truth = workspace.truth(view)
    shown = cabin_structure.removed_from_layer(3)
    assert view.removed_from_layer == 3 and truth.shown == shown
    np.testing.assert_array_equal(truth.present, feature_values(shown.extent, shown.occupancy))
    # Removed logs are nowhere in the id map; ids still index the whole assembly.
    gone = [n for n, log in enumerate(cabin_structure.logs) if log.layer >= 3]
    assert not np.isin(truth.ids, gone).any()
    assert truth.ids.max() < len(cabin_structure.logs)


def test_removal_arm_state(cabin_structure):
    ws = Workspace(cabin_structure, arm=PendulumArm(width=40, height=30),
                   settings=RenderSettings(spp=1))
    ws.remove_logs([0, 1])
    ws.remove_from_layer(5)
    top = {n for n, log in enumerate(cabin_structure.logs) if log.layer >= 5}
    assert ws.removed == {0, 1} | top
    assert len(ws.on_table().logs) == len(cabin_structure.logs) - len(ws.removed)
    view = ws.observe(90.0)
    assert view.removed_logs == tuple(sorted(ws.removed))
    ws.restore()
    assert not ws.removed
    with pytest.raises(InputError):
        ws.remove_logs([99])
    with pytest.raises(InputError):
        ws.truth(view.__class__(view.image, view.camera, view.extent))


def test_randomised_workspace_keeps_its_look_and_jitters_the_camera(cabin_structure):
    settings = RenderSettings(spp=1, randomisation=SceneRandomisation())
    ws = Workspace(cabin_structure, GridPose(-60.0, -70.0, 10.0),
                   arm=PendulumArm(width=40, height=30), settings=settings, seed=2)
    a, b = ws.observe(90.0), ws.observe(90.0)
    ta, tb = ws.truth(a), ws.truth(b)
    assert ta.look == tb.look  # one scene, seen twice
    np.testing.assert_allclose(a.camera.R, PendulumArm(width=40, height=30).camera(90.0).R)
    assert not np.allclose(ta.camera.centre, a.camera.centre)
    assert not np.allclose(ta.camera.centre, tb.camera.centre)
