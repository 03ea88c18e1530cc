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
        assert pics["overlay"].shape == photo.shape
        # The rendering's legend is a band above it, off the logs.
        assert pics["rendering"].shape[1:] == photo.shape[1:]
        assert pics["rendering"].shape[0] > photo.shape[0]
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


def _near(picture: np.ndarray, colour, tol: float = 0.04) -> np.ndarray:
    """Pixels of ``colour``'s hue whatever their shading (chromaticity within ``tol``)."""
    rgb = picture.astype(float)
    chroma = rgb / np.maximum(rgb.sum(axis=-1, keepdims=True), 1.0)
    target = np.asarray(colour, float) / sum(colour)
    return (np.abs(chroma - target).max(axis=-1) < tol) & (rgb.sum(axis=-1) > 60)


def test_seen_and_inferred_logs_have_their_own_colours_and_neither_is_green(square):
    from unseeable.render.pictures import INFERRED, SEEN

    s, pose, camera = square
    photo = np.full((camera.height, camera.width, 3), 128, np.uint8)
    pics = estimate_pictures(photo, s, pose, camera, seen=np.array([True, True, False, False]),
                             crop=False, legend=False)
    for name in ("overlay", "rendering"):
        assert _near(pics[name], SEEN).sum() > 50 and _near(pics[name], INFERRED).sum() > 50
        assert _near(pics[name], GREEN).sum() == 0 and _near(pics[name], RED).sum() == 0
    all_seen = estimate_pictures(photo, s, pose, camera, seen=np.ones(4, bool), crop=False,
                                 legend=False)["rendering"]
    assert _near(all_seen, INFERRED).sum() == 0


def test_the_overlay_keeps_the_photograph_and_shows_it_through_the_logs(square):
    s, pose, camera = square
    rng = np.random.default_rng(0)
    photo = rng.integers(0, 256, (camera.height, camera.width, 3), dtype=np.uint8)
    pics = estimate_pictures(photo, s, pose, camera, legend=False)  # crop=True: rendering only
    overlay = pics["overlay"]
    assert overlay.shape == photo.shape
    assert pics["rendering"].shape != photo.shape  # the rendering is cropped to the assembly
    from unseeable.render.renderer import render_ground_truth

    ids, _ = render_ground_truth(s, pose, camera)
    inside = ids >= 0
    inside[1:] &= ids[:-1] == ids[1:]
    inside[:-1] &= ids[1:] == ids[:-1]  # away from the outlines
    # Semi-transparent: the photograph's texture still shows under the logs.
    drawn = overlay[inside].astype(float)
    under = photo[inside].astype(float)
    assert np.corrcoef(drawn[:, 0], under[:, 0])[0, 1] > 0.5
    assert np.array_equal(overlay[ids < 0], photo[ids < 0])  # untouched elsewhere


def test_a_legend_says_what_the_colours_mean_where_it_hides_the_least():
    from unseeable.render.pictures import SEEN, LegendEntry, draw_legend

    image = np.full((240, 320, 3), 100, np.uint8)
    avoid = np.zeros((240, 320), bool)
    avoid[:120, :] = True  # the top half is taken
    drawn = draw_legend(image, [LegendEntry(SEEN, "seen: 3 logs")], title="estimate",
                        avoid=avoid)
    assert drawn.shape == image.shape
    changed = np.any(drawn != image, axis=-1)
    assert changed[120:].sum() > 0 and changed[:120].sum() == 0
    assert _near(drawn, SEEN).sum() > 10  # its swatch


def test_the_truth_picture_marks_right_wrong_and_missed_logs(square):
    from unseeable.render.pictures import MAGENTA, truth_picture

    s, pose, camera = square
    photo = np.full((camera.height, camera.width, 3), 128, np.uint8)
    estimate = Structure(s.extent, s.logs[:3])  # the truth's last log is missing
    truth = s
    picture = truth_picture(photo, estimate, pose, camera,
                            correct=np.array([True, True, False]), truth=truth,
                            truth_correct=np.array([True, True, False, False]))
    assert picture.shape == photo.shape
    for colour in (GREEN, RED, MAGENTA):
        assert _near(picture, colour).sum() > 30, colour


def test_unseen_positions_left_empty_are_hatched_grey(square):
    from unseeable.render.pictures import UNKNOWN

    s, pose, camera = square
    photo = np.full((camera.height, camera.width, 3), 40, np.uint8)
    unknown = np.zeros(s.extent.shape, bool)
    unknown[1, 0, 1] = True  # the middle of the floor: empty in the estimate
    with_unknown = estimate_pictures(photo, s, pose, camera, unknown=unknown, crop=False,
                                     legend=False)["overlay"]
    without = estimate_pictures(photo, s, pose, camera, crop=False, legend=False)["overlay"]
    grey = (np.abs(with_unknown.astype(int) - np.array(UNKNOWN) * 0.65 - 40 * 0.35) < 12) \
        .all(axis=-1)
    assert grey.sum() > 20 and (with_unknown != without).any(axis=-1).sum() > grey.sum()
    # An occupied position is not unknown however it is flagged.
    occupied = np.zeros(s.extent.shape, bool)
    occupied[0, 0, 0] = True
    same = estimate_pictures(photo, s, pose, camera, unknown=occupied, crop=False,
                             legend=False)["overlay"]
    assert np.array_equal(same, without)


def test_a_hidden_inferred_log_is_outlined_through_the_logs_in_front(square):
    from unseeable.render.pictures import INFERRED
    from unseeable.render.renderer import render_ground_truth

    s, pose, camera = square
    photo = np.full((camera.height, camera.width, 3), 128, np.uint8)
    ids, _ = render_ground_truth(s, pose, camera)
    seen_area = [(ids == n).sum() for n in range(len(s.logs))]
    hidden = int(np.argmin(seen_area))  # the log the camera sees least of
    seen = np.ones(len(s.logs), bool)
    seen[hidden] = False
    overlay = estimate_pictures(photo, s, pose, camera, seen=seen, crop=False,
                                legend=False)["overlay"]
    alone, _ = render_ground_truth(Structure(s.extent, [s.logs[hidden]]), pose, camera)
    behind = (alone >= 0) & (ids >= 0) & (ids != hidden)
    assert behind.any()
    assert _near(overlay, INFERRED)[behind].sum() > 10
