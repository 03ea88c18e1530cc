"""Edge maps: oriented strength, sampling, the wood colour model."""

import cv2
import numpy as np
import pytest

from unseeable.errors import InputError
from unseeable.vision import edge_maps, woodness_map
from unseeable.vision.edges import (
    as_rgb_image,
    ellipse_rim_strength,
    image_window,
    normal_edge_peaks,
    sample_maps,
    segment_edge_strength,
)
from unseeable.vision.projection import ellipse_points


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
    pts = np.array([[1.0, 2.0], [1.5, 2.0], [1.0, 2.5], [-5.0, 0.0], [np.nan, 1.0],
                    [np.inf, 1.0], [2.0, -np.inf]])
    v = sample_maps(maps, pts)[:, 0]
    assert v[:3] == pytest.approx([11.0, 11.5, 13.5])
    assert not v[3:].any()  # beyond the image, not a number, at infinity: 0


def _reference_bilinear(maps, pts):
    """Plain bilinear interpolation in float64, 0 beyond the image."""
    h, w = maps.shape[:2]
    x, y = pts[:, 0].astype(float), pts[:, 1].astype(float)
    x0, y0 = np.floor(x).astype(int), np.floor(y).astype(int)
    fx, fy = x - x0, y - y0
    out = np.zeros((len(pts), maps.shape[2]))
    for dy, dx, wt in ((0, 0, (1 - fy) * (1 - fx)), (0, 1, (1 - fy) * fx),
                       (1, 0, fy * (1 - fx)), (1, 1, fy * fx)):
        yy, xx = y0 + dy, x0 + dx
        ok = (xx >= 0) & (xx < w) & (yy >= 0) & (yy < h)
        out[ok] += maps[yy[ok], xx[ok]] * wt[ok, None]
    return out


@pytest.mark.parametrize("channels", [1, 2, 3, 5])
def test_sample_maps_is_bilinear_across_the_border(channels):
    rng = np.random.default_rng(channels)
    maps = rng.random((30, 40, channels)).astype(np.float32)
    pts = rng.uniform(-2.0, 42.0, (5000, 2)).astype(np.float32)
    # OpenCV may round the coordinates to 1/32 px (some versions, some channel counts).
    assert sample_maps(maps, pts) == pytest.approx(_reference_bilinear(maps, pts), abs=0.04)
    assert sample_maps(maps, pts.reshape(50, 100, 2)).shape == (50, 100, channels)


def _tensor_maps(seed=0):
    img = np.full((60, 80, 3), 60, np.uint8)
    rng = np.random.default_rng(seed)
    img[20:45, 15:70] = 190
    img = np.clip(img + rng.normal(0, 6, img.shape), 0, 255).astype(np.uint8)
    return edge_maps(img)


def test_normal_edge_peaks_finds_the_step_and_matches_the_profile():
    m = _tensor_maps()
    # Points on row 30, a little left of the step at x = 15, looking along +x.
    pts = np.array([[12.3, 30.0], [13.0, 28.0], [16.5, 33.0]])
    normals = np.tile([[1.0, 0.0]], (3, 1))
    offsets = np.arange(-4.0, 4.0 + 1e-9, 0.25)
    k, peak, left, right, at_zero = normal_edge_peaks(m.tensor, pts, normals, offsets)
    # The same from sampled profiles.
    probe = (pts[:, None, :] + offsets[None, :, None] * normals[:, None, :]).reshape(-1, 2)
    t = _reference_bilinear(m.tensor, probe).reshape(3, len(offsets), 3)
    prof = np.sqrt(np.maximum(t[..., 0], 0.0))  # n = (1, 0): nᵀ S n = Sxx
    assert np.array_equal(k, np.argmax(prof, axis=1))
    rows = np.arange(3)
    assert peak == pytest.approx(prof[rows, k], rel=1e-6)
    assert left == pytest.approx(prof[rows, np.maximum(k - 1, 0)], rel=1e-6)
    assert right == pytest.approx(prof[rows, np.minimum(k + 1, len(offsets) - 1)], rel=1e-6)
    assert at_zero == pytest.approx(prof[:, 16], rel=1e-6)
    # The strongest edge is the step, wherever along the normal the point starts.
    assert pts[:, 0] + offsets[k] == pytest.approx([14.5, 14.5, 14.5], abs=1.0)


def test_ellipse_rim_strength_is_the_mean_energy_across_the_rim():
    m = _tensor_maps(1)
    ell = np.array([[42.0, 32.0, 27.0, 12.5, 0.0],  # the bright block's outline, roughly
                    [42.0, 32.0, 8.0, 5.0, 0.3],  # inside it: flat
                    [42.0, 32.0, 8.0, 5.0, np.nan]])
    got = ellipse_rim_strength(m.tensor, ell, 24)
    pts, nrm = ellipse_points(ell[:2], 24)
    t = _reference_bilinear(m.tensor, pts.reshape(-1, 2)).reshape(2, 24, 3)
    nx, ny = nrm[..., 0], nrm[..., 1]
    ref = np.sqrt(np.maximum(t[..., 0] * nx * nx + 2 * t[..., 1] * nx * ny
                             + t[..., 2] * ny * ny, 0.0)).mean(axis=-1)
    assert got[:2] == pytest.approx(ref, rel=1e-6)
    assert got[0] > 5 * got[1]
    assert np.isnan(got[2])
    assert ellipse_rim_strength(m.tensor, ell[:2].reshape(1, 2, 5), 24).shape == (1, 2)
    with pytest.raises(InputError, match="samples"):
        ellipse_rim_strength(m.tensor, ell, 0)


def test_segment_edge_strength_is_the_segment_detectors_strength():
    from unseeable.vision.detectors import DetectorSettings, score_segments

    m = _tensor_maps(2)
    rng = np.random.default_rng(3)
    on_edges = np.array([[[15.0, 22.0], [15.0, 43.0]],  # the block's left side
                         [[20.0, 21.5], [65.0, 18.5]],  # near its top, a little tilted
                         [[30.0, 30.0], [50.0, 35.0]]])  # inside: no edge
    random = rng.uniform(-5.0, 85.0, (40, 2, 2))
    segments = np.concatenate([on_edges, random, np.zeros((1, 2, 2))])
    st = DetectorSettings()
    got = segment_edge_strength(m.tensor, segments, samples=st.segment_samples,
                                shift=st.segment_shift)
    # (cv2.remap, under score_segments, rounds coordinates to 1/32 px in some OpenCV versions)
    want = score_segments(m, segments, settings=st)[:, 0]
    assert got == pytest.approx(want, rel=0.02, abs=0.01)
    assert got[0] > 5 * got[2] and got[1] > 5 * got[2]
    with pytest.raises(InputError, match="shift"):
        segment_edge_strength(m.tensor, segments, samples=4, shift=-1)


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
    # The caller's Lab image, when it has one, gives the same map; a wrong one is refused.
    lab = cv2.cvtColor(img, cv2.COLOR_RGB2Lab)
    np.testing.assert_array_equal(woodness_map(img, region, lab=lab), w)
    with pytest.raises(InputError, match="lab"):
        woodness_map(img, region, lab=lab[:, :-1])
    with pytest.raises(InputError, match="lab"):
        woodness_map(img, region, lab=lab.astype(np.float32))
    # Scored in a window only: the same map there, learnt on the whole image; 0 elsewhere.
    window = image_window(np.array([[50.0, 30.0], [109.0, 89.0]]), img.shape[:2])
    part = woodness_map(img, region, window=window)
    np.testing.assert_allclose(part[window], w[window], rtol=1e-5, atol=1e-7)
    outside = np.ones(w.shape, bool)
    outside[window] = False
    assert not part[outside].any()
    with pytest.raises(InputError, match="window"):
        woodness_map(img, region, window=(30, 90))


def test_woodness_without_lightness_reads_colour_alone():
    # lightness_weight=0 (benchmarks/woodness.py): the scene in other light, its colour
    # axes the same, gets exactly the same map; with the default weight lightness counts.
    rng = np.random.default_rng(1)
    img = np.empty((120, 160, 3), np.float32)
    img[:] = (190, 175, 150)  # a light oak table
    img[40:80, 60:100] = (150, 95, 55)  # a brown log
    img = np.clip(img + rng.normal(0, 4, img.shape), 0, 255).astype(np.uint8)
    region = np.zeros((120, 160), bool)
    region[30:90, 50:110] = True
    lab = cv2.cvtColor(img, cv2.COLOR_RGB2Lab)
    relit = lab.copy()
    relit[..., 0] = np.clip(relit[..., 0].astype(int) + 40, 0, 255)  # lightness alone
    colour_only = woodness_map(img, region, lab=lab, lightness_weight=0.0)
    np.testing.assert_array_equal(
        woodness_map(img, region, lab=relit, lightness_weight=0.0), colour_only)
    assert colour_only[45:75, 65:95].mean() > 0.9 and colour_only[:20].mean() < 0.1
    assert not np.array_equal(woodness_map(img, region, lab=relit), woodness_map(img, region,
                                                                                 lab=lab))
    for bad in (-0.1, float("nan"), "0.35"):
        with pytest.raises(InputError, match="lightness_weight"):
            woodness_map(img, region, lightness_weight=bad)


def test_image_window_grows_and_clips_the_points_box():
    shape = (48, 64)
    assert image_window(np.array([[10.2, 5.0], [20.0, 7.5]]), shape, margin_px=2) == (
        slice(3, 11), slice(8, 23))
    # Beyond the image: clipped, never empty; a point behind the camera: the whole image.
    assert image_window(np.array([[-90.0, 100.0]]), shape) == (slice(47, 48), slice(0, 1))
    assert image_window(np.array([[1.0, 1.0], [np.inf, 0.0]]), shape) == (
        slice(0, 48), slice(0, 64))
    with pytest.raises(InputError, match="points"):
        image_window(np.zeros((3, 3)), shape)
