"""The flat-shaded rasteriser: a second renderer that draws the same geometry another way."""

from __future__ import annotations

import numpy as np
import pytest

from unseeable.domain import Extent, GridPose, Log, LogGeometry, Structure
from unseeable.errors import InputError
from unseeable.render.raster import RasterLook, random_raster_look, rasterise_view
from unseeable.render.workspace import PendulumArm

LOOK = RasterLook(noise=0.0, blur_px=0.0, wood=(0.6, 0.4, 0.2), table=(0.2, 0.5, 0.2))


def _cabin() -> Structure:
    return Structure(Extent(3, 4, 3), [
        Log(0, (0, 0), 3), Log(0, (0, 2), 3), Log(1, (0, 0), 3), Log(1, (2, 0), 3),
        Log(2, (0, 0), 3), Log(2, (0, 2), 3), Log(3, (0, 0), 3), Log(3, (2, 0), 3)])


def _pose(extent: Extent, yaw: float, g: LogGeometry = LogGeometry()) -> GridPose:
    centre = np.array([(extent.I - 1) * g.l1 / 2, 0.0, (extent.K - 1) * g.l1 / 2])
    origin = -(GridPose(0.0, 0.0, yaw).rotation @ centre)
    return GridPose(float(origin[0]), float(origin[2]), yaw)


def test_logs_are_drawn_where_the_camera_sees_them_and_the_table_elsewhere():
    g = LogGeometry()
    s = _cabin()
    pose = _pose(s.extent, 20.0)
    camera = PendulumArm().camera(135.0)
    image = rasterise_view(s, pose, camera, look=LOOK).astype(float)
    table = np.array(LOOK.table) * 255
    # The axis of the top layer's first log (along k at i = 0), at its middle notch: wood.
    top = pose.grid_to_world(np.array([[0.0, g.layer_height(3), g.l1]]))
    u, v = np.round(camera.project(top)[0]).astype(int)
    assert np.abs(image[v, u] - table).max() > 40
    assert image[v, u, 0] > image[v, u, 2]  # wood is red-brown
    # A table corner far from the assembly: exactly the table's colour (or its shadow).
    corner = image[5, 5]
    assert np.allclose(corner, table, atol=1) or np.allclose(corner, table * LOOK.ambient, atol=1)


def test_the_light_casts_shadows_away_from_itself():
    s = Structure(Extent(1, 1, 1), [Log(0, (0, 0), 1)])
    camera = PendulumArm().camera(135.0)
    low_light = RasterLook(**{**LOOK.__dict__, "light_elevation_deg": 30.0})
    image = rasterise_view(s, GridPose(), camera, look=low_light)
    shadow = np.all(np.abs(image.astype(float) - np.array(LOOK.table) * 255 * LOOK.ambient) <= 1,
                    axis=2)
    assert shadow.sum() > 20


def test_same_seed_same_image_and_the_look_changes_it():
    s = _cabin()
    pose = _pose(s.extent, 0.0)
    camera = PendulumArm().camera(90.0)
    a = rasterise_view(s, pose, camera, seed=4)
    assert np.array_equal(a, rasterise_view(s, pose, camera, seed=4))
    assert not np.array_equal(a, rasterise_view(s, pose, camera, seed=5))
    other = random_raster_look(np.random.default_rng(1))
    assert not np.array_equal(a, rasterise_view(s, pose, camera, seed=4, look=other))


def test_bad_supersampling_is_refused():
    with pytest.raises(InputError, match="supersample"):
        rasterise_view(_cabin(), GridPose(), PendulumArm().camera(90.0), supersample=0)


@pytest.mark.parametrize("station, yaw", [(120.0, 17.0), (200.0, 5.0)])
def test_the_pose_is_found_on_a_rasterised_photograph(station, yaw):
    # The vision stage was tuned on path-traced renders only: another renderer's look
    # (flat shading, hard shadows, plain colours, no texture) must not move the pose.
    from unseeable.training.scenes import random_structure
    from unseeable.vision import estimate_pose, pose_equivalent

    s = random_structure(Extent(4, 3, 3), density=0.7, seed=0)
    pose = _pose(s.extent, yaw)
    camera = PendulumArm().camera(station)
    look = RasterLook(wood=(0.7, 0.45, 0.25), table=(0.55, 0.55, 0.52), light_azimuth_deg=-40.0,
                      noise=0.01, blur_px=0.6)
    image = rasterise_view(s, pose, camera, look=look, seed=3)
    fit = estimate_pose(image, camera, s.extent)
    err = pose_equivalent(fit.pose, pose, s.extent)
    assert err[0] <= 2.0 and err[1] <= 1.0
