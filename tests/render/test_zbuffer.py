"""The z-buffer draws what the renderer's id/depth pass sees, without the renderer."""

import numpy as np
import pytest

from unseeable.camera import Camera
from unseeable.domain import Extent, GridPose, Structure
from unseeable.errors import InputError
from unseeable.render.renderer import render_ground_truth
from unseeable.render.workspace import PendulumArm, default_pose
from unseeable.render.zbuffer import rasterise_ids


def _compare(structure, pose, camera):
    ref_ids, ref_depth = render_ground_truth(structure, pose, camera)
    ids, depth = rasterise_ids(structure, pose, camera)
    assert ids.shape == ref_ids.shape and ids.dtype == np.int32
    assert depth.shape == ref_depth.shape and depth.dtype == np.float32
    drawn = (ids >= 0) | (ref_ids >= 0)
    agree = ids == ref_ids
    same = agree & (ids >= 0)
    return drawn, agree, np.abs(depth[same] - ref_depth[same])


@pytest.mark.parametrize("station", [90.0, 150.0, 210.0])
def test_each_pixel_shows_the_log_the_renderer_sees_there(cabin_structure, station):
    camera = PendulumArm(width=320, height=240).camera(station)
    drawn, agree, depth_error = _compare(cabin_structure, default_pose(cabin_structure.extent),
                                         camera)
    assert drawn.sum() > 1000
    # Only pixels a triangle's edge grazes may differ.
    assert agree[drawn].mean() > 0.999
    assert np.mean(depth_error < 0.05) > 0.999


def test_a_camera_with_distortion_and_skew_is_drawn_as_the_renderer_draws_it(cabin_structure):
    plain = PendulumArm(width=320, height=240).camera(120.0)
    K = plain.K.copy()
    K[1, 1] *= 1.03
    K[0, 1] = 0.5
    camera = Camera(plain.width, plain.height, K, plain.R, plain.t,
                    np.array([-0.12, 0.05, 0.001, -0.001, 0.0]))
    assert camera.has_distortion
    drawn, agree, _ = _compare(cabin_structure, default_pose(cabin_structure.extent), camera)
    assert drawn.sum() > 1000
    assert agree[drawn].mean() > 0.999


def test_nothing_is_drawn_for_no_logs_or_logs_out_of_view(cabin_structure):
    camera = PendulumArm(width=64, height=48).camera(120.0)
    ids, depth = rasterise_ids(Structure(Extent(3, 6, 3), []), GridPose(), camera)
    assert (ids == -1).all() and np.isinf(depth).all()
    far = GridPose(5000.0, 5000.0, 0.0)  # far off the table's image
    ids, depth = rasterise_ids(cabin_structure, far, camera)
    assert (ids == -1).all() and np.isinf(depth).all()


def test_bad_input_is_named(cabin_structure):
    camera = PendulumArm(width=64, height=48).camera(120.0)
    with pytest.raises(InputError, match="pose"):
        rasterise_ids(cabin_structure, (0, 0, 0), camera)
