"""Edge maps: oriented strength, sampling, the wood colour model."""

import numpy as np
import pytest

from unseeable.errors import InputError
from unseeable.vision import edge_maps, woodness_map
from unseeable.vision.edges import as_rgb_image, sample_maps


def test_strength_is_across_the_edge():
    img = np.full((40, 40, 3), 40, np.uint8)
    img[:, 20:] = 200
    m = edge_maps(img)
    sxx, sxy, syy = m.tensor[20, 19]
    assert sxx > 50 * abs(syy) and sxx > 0
    # The strongest column is at the step.
    assert np.argmax(m.strength[20]) in (19, 20)
    assert m.gradient[20, 19, 0] > 0  # brighter to the right


def test_contrast_normalisation_makes_strength_exposure_free():
    img = np.full((40, 40, 3), 40, np.uint8)
    img[:, 20:] = 120
    a = edge_maps(img)
    b = edge_maps((img.astype(float) * 2).astype(np.uint8))
    assert a.strength.max() == pytest.approx(b.strength.max(), rel=1e-3)


def test_sample_maps_is_bilinear_and_zero_outside():
    maps = np.arange(20, dtype=np.float32).reshape(4, 5, 1)
    pts = np.array([[1.0, 2.0], [1.5, 2.0], [1.0, 2.5], [-5.0, 0.0], [np.nan, 1.0]])
    v = sample_maps(maps, pts)[:, 0]
    assert v[:3] == pytest.approx([11.0, 11.5, 13.5])
    assert v[3] == 0 and v[4] == 0


def test_bad_images_are_input_errors():
    with pytest.raises(InputError):
        as_rgb_image(np.zeros((3, 3, 3), np.uint8))
    with pytest.raises(InputError):
        as_rgb_image(np.zeros((20, 20, 2), np.uint8))
    assert as_rgb_image(np.zeros((20, 20), np.uint8)).shape == (20, 20, 3)


def test_woodness_separates_wood_from_table():
    rng = np.random.default_rng(0)
    img = np.empty((120, 160, 3), np.float32)
    img[:] = (110, 110, 115)  # grey table
    img[40:80, 60:100] = (150, 95, 55)  # a brown log
    img += rng.normal(0, 4, img.shape)
    img = np.clip(img, 0, 255).astype(np.uint8)
    region = np.zeros((120, 160), bool)
    region[30:90, 50:110] = True
    w = woodness_map(img, region)
    assert w[45:75, 65:95].mean() > 0.9
    assert w[:20].mean() < 0.1
