"""Shared fixtures of the vision tests: synthetic pictures of assemblies seen by the arm."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).parent))

from drawing import draw_structure  # noqa: E402

from unseeable.domain import Extent, GridPose, Log, LogGeometry, Structure  # noqa: E402
from unseeable.render.workspace import PendulumArm  # noqa: E402


def centred_pose(extent: Extent, yaw_deg: float, geometry: LogGeometry = LogGeometry()):
    """The pose that puts the footprint's centre on the table's centre."""
    centre = np.array([(extent.I - 1) * geometry.l1 / 2, 0.0, (extent.K - 1) * geometry.l1 / 2])
    origin = -(GridPose(0.0, 0.0, yaw_deg).rotation @ centre)
    return GridPose(float(origin[0]), float(origin[2]), yaw_deg)


def house() -> Structure:
    """Four walls, two logs high each way: a small Lincoln Log cabin (extent 3x4x3)."""
    return Structure(Extent(3, 4, 3), [
        Log(0, (0, 0), 3), Log(0, (0, 2), 3), Log(1, (0, 0), 3), Log(1, (2, 0), 3),
        Log(2, (0, 0), 3), Log(2, (0, 2), 3), Log(3, (0, 0), 3), Log(3, (2, 0), 3)])


def scatter() -> Structure:
    """A denser random-looking assembly on a non-square footprint (4x3x3)."""
    from unseeable.training.scenes import random_structure

    return random_structure(Extent(4, 3, 3), density=0.7, seed=0)


@pytest.fixture(scope="session")
def arm_camera():
    return PendulumArm().camera(135.0)


@pytest.fixture(scope="session")
def synthetic_view(arm_camera):
    """(structure, pose, camera, image) of a painted cabin at yaw 23°."""
    s = house()
    pose = centred_pose(s.extent, 23.0)
    image = draw_structure(s, pose, arm_camera, seed=1)
    return s, pose, arm_camera, image


@pytest.fixture(scope="session")
def scatter_view():
    """(structure, pose, camera, image) of a painted 4x3x3 assembly at yaw 17°."""
    s = scatter()
    camera = PendulumArm().camera(120.0)
    pose = centred_pose(s.extent, 17.0)
    return s, pose, camera, draw_structure(s, pose, camera, seed=0)


@pytest.fixture(scope="session")
def rendered_house(arm_camera):
    """(structure, pose, camera, image) of the cabin rendered by Mitsuba (small, quick)."""
    from unseeable.render.renderer import render_view
    from unseeable.render.settings import RenderSettings

    s = house()
    pose = centred_pose(s.extent, -31.0)
    image, _, _ = render_view(s, pose, arm_camera, settings=RenderSettings(spp=4), seed=3)
    return s, pose, arm_camera, image
