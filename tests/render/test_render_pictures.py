"""Pictures of an estimate: coloured by the truth, drawn at a size people can use."""

import numpy as np
import pytest

from unseeable.domain import Extent, GridPose, Log, Structure
from unseeable.errors import InputError
from unseeable.render.pictures import GREEN, RED, estimate_pictures
from unseeable.render.workspace import PendulumArm


@pytest.fixture(scope="module")
def square():
    s = Structure(Extent(3, 2, 3), [Log(0, (0, 0), 3), Log(0, (0, 2), 3), Log(1, (0, 0), 3),
                                    Log(1, (2, 0), 3)])
    return s, GridPose(-64.0, -64.0, 20.0), PendulumArm().camera(120.0)


def _share(picture: np.ndarray, colour) -> float:
    # Shaded and outlined, a log's pixels keep its hue: the dominant channel.
    target = int(np.argmax(colour))
    rgb = picture.astype(int)
    return float(np.mean((rgb[..., target] > rgb.sum(axis=-1) - rgb[..., target])
                         & (rgb.max(axis=-1) < 230)))


def test_each_log_is_green_when_right_and_red_when_wrong(square):
    s, pose, camera = square
    photo = np.full((camera.height, camera.width, 3), 128, np.uint8)
    right = estimate_pictures(photo, s, pose, camera, correct=np.ones(4, bool), crop=False)
    wrong = estimate_pictures(photo, s, pose, camera, correct=np.zeros(4, bool), crop=False)
    for pics in (right, wrong):
        assert pics["overlay"].shape == pics["rendering"].shape == photo.shape
    assert _share(right["rendering"], GREEN) > 0.01 and _share(right["rendering"], RED) == 0
    assert _share(wrong["rendering"], RED) > 0.01 and _share(wrong["rendering"], GREEN) == 0


def test_a_large_photograph_is_drawn_on_shrunk_to_the_pictures_size(square):
    s, pose, camera = square
    photo = np.full((camera.height, camera.width, 3), 128, np.uint8)
    big = camera.scaled(4.0)
    big_photo = np.full((big.height, big.width, 3), 128, np.uint8)
    small = estimate_pictures(photo, s, pose, camera, crop=False)["rendering"]
    drawn = estimate_pictures(big_photo, s, pose, big, crop=False, max_side=640)["rendering"]
    assert drawn.shape == small.shape  # 4 × 640 shrunk to 640 wide: the same camera again
    # The logs land where the small camera draws them.
    on_small, on_drawn = small.min(axis=-1) < 230, drawn.min(axis=-1) < 230
    assert np.mean(on_small != on_drawn) < 0.01


def test_a_tiny_picture_size_is_refused(square):
    s, pose, camera = square
    photo = np.zeros((camera.height, camera.width, 3), np.uint8)
    with pytest.raises(InputError, match="max_side"):
        estimate_pictures(photo, s, pose, camera, max_side=8)
