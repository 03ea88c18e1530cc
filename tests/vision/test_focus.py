"""How out of focus a photograph is, and the pipeline's warning."""

import logging

import cv2
import numpy as np
import pytest

from unseeable.errors import InputError
from unseeable.vision.focus import DEFOCUS_WARN_PX, added_blur, estimate_defocus


def _logs(seed: int = 0) -> np.ndarray:
    """Bright bars (logs) at random places on a mid-grey table, with a little noise."""
    rng = np.random.default_rng(seed)
    img = np.full((240, 320, 3), 90, np.uint8)
    for _ in range(14):
        x, y = rng.integers(10, 280), rng.integers(10, 200)
        w, h = (rng.integers(30, 80), 10) if rng.random() < 0.5 else (10, rng.integers(30, 80))
        img[y:y + h, x:x + w] = (200, 140, 80)
    noise = rng.normal(0, 2, img.shape)
    return np.clip(img + noise, 0, 255).astype(np.uint8)


def test_a_sharp_photograph_is_not_out_of_focus():
    assert estimate_defocus(_logs()) < DEFOCUS_WARN_PX
    assert added_blur(estimate_defocus(_logs())) == 0.0


def test_the_measured_blur_grows_with_the_blur_and_reads_it_back():
    sharp = _logs(1)
    measured = [estimate_defocus(cv2.GaussianBlur(sharp, (0, 0), s)) for s in (1.0, 2.0, 3.0)]
    assert measured == sorted(measured)
    assert measured[1] > DEFOCUS_WARN_PX
    assert added_blur(measured[1]) == pytest.approx(2.0, abs=0.6)
    assert added_blur(measured[2]) == pytest.approx(3.0, abs=0.8)


@pytest.mark.parametrize("image", [np.zeros((10, 10), np.uint8), np.zeros((10, 10, 3))])
def test_only_rgb_photographs_are_measured(image):
    with pytest.raises(InputError, match="image"):
        estimate_defocus(image)


def test_the_estimate_warns_of_a_photograph_out_of_focus(tiny_corpus, caplog):
    from unseeable.pipeline import EstimateSettings, Observation, estimate
    from unseeable.render.view import View, load_view

    view = load_view(tiny_corpus / "wall-door" / "view120.json")
    blurred = View(cv2.GaussianBlur(np.asarray(view.image), (0, 0), 3.0), view.camera,
                   view.extent, pose=view.pose)
    settings = EstimateSettings.from_options(time_limit=10.0)
    with caplog.at_level(logging.WARNING, logger="unseeable.pipeline.posing"):
        estimate([Observation(view, pose=view.pose)], settings)
    assert "out of focus" not in caplog.text
    with caplog.at_level(logging.WARNING, logger="unseeable.pipeline.posing"):
        estimate([Observation(blurred, pose=view.pose, source="blurred.png")], settings)
    assert "blurred.png looks out of focus" in caplog.text
