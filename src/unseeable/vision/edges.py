"""Image edge maps shared by the detectors and the pose search.

The colour structure tensor ``S = Σ_c ∇I_c ∇I_cᵀ`` (Di Zenzo) gives, for any
unit direction ``n``, the squared directional derivative summed over colour
channels, ``nᵀ S n = |∇I|² cos²(orientation difference)`` for a grey image:
exactly the paper's oriented edge energy ``E(I) ∘ cos²(O(I) − o)``, but
without quantising the orientation. Strengths are divided by a robust
image-wide contrast so that scores do not depend on exposure or lighting.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass

import cv2
import numpy as np

from unseeable.errors import InputError

__all__ = ["EdgeMaps", "edge_maps", "sample_maps", "as_rgb_image", "fill_convex_hull"]

logger = logging.getLogger(__name__)

#: cv2.remap asserts map sizes below SHRT_MAX; points are laid out in rows of this width.
_REMAP_WIDTH = 4096


def fill_convex_hull(mask: np.ndarray, points: np.ndarray) -> None:
    """Set ``mask`` ``(H, W) uint8`` to 1 inside the convex hull of image ``points`` ``(N, 2)``.

    In place. The points are clipped to ±10⁵ px first: a projection that grazes
    the camera plane lands far off the image, beyond OpenCV's int32 coordinates.

    Examples
    --------
    >>> mask = np.zeros((4, 6), np.uint8)
    >>> fill_convex_hull(mask, np.array([[1.0, 1.0], [4.0, 1.0], [4.0, 2.0], [1.0, 2.0]]))
    >>> int(mask.sum()), int(mask[1:3, 1:5].sum())
    (8, 8)
    >>> fill_convex_hull(mask, np.array([[-1e9, -1e9], [1e9, -1e9], [0.0, 1e9]]))
    >>> bool(mask.all())
    True
    """
    hull = cv2.convexHull(np.round(np.clip(points, -1e5, 1e5)).astype(np.int32))
    cv2.fillConvexPoly(mask, hull, 1)


def as_rgb_image(image: np.ndarray, *, field: str = "image") -> np.ndarray:
    """Check an image array and return it as ``(H, W, 3) uint8``.

    Grey ``(H, W)`` images are repeated over three channels; an alpha channel is dropped.
    """
    img = np.asarray(image)
    if img.ndim == 2:
        img = np.repeat(img[:, :, None], 3, axis=2)
    if img.ndim != 3 or img.shape[2] not in (3, 4) or min(img.shape[:2]) < 8:
        raise InputError("must be an (H, W, 3) image of at least 8x8 pixels", field=field,
                         value=img.shape)
    img = img[:, :, :3]
    if img.dtype != np.uint8:
        if np.issubdtype(img.dtype, np.floating) and img.size and float(np.nanmax(img)) <= 1.0:
            img = img * 255.0
        img = np.clip(np.nan_to_num(img), 0, 255).astype(np.uint8)
    return np.ascontiguousarray(img)


@dataclass(frozen=True, eq=False)
class EdgeMaps:
    """Per-pixel edge information of one image.

    Attributes
    ----------
    tensor : (H, W, 3) float32
        ``Sxx, Sxy, Syy`` of the colour structure tensor, divided by ``contrast²``.
    gradient : (H, W, 2) float32
        Signed gradient ``(gx, gy)`` of the grey image, divided by ``contrast``.
    contrast : float
        The image's robust edge contrast (a high percentile of ``sqrt(trace S)``).
    sigma : float
        Gaussian smoothing (pixels) before differentiation.
    """

    tensor: np.ndarray
    gradient: np.ndarray
    contrast: float
    sigma: float

    @property
    def shape(self) -> tuple[int, int]:
        return self.tensor.shape[:2]

    @property
    def strength(self) -> np.ndarray:
        """``(H, W) float32``: edge strength ``sqrt(trace S)`` (normalised)."""
        return np.sqrt(self.tensor[..., 0] + self.tensor[..., 2])

    def orientation(self) -> tuple[np.ndarray, np.ndarray]:
        """Dominant gradient direction ``(H, W)`` (radians, ``[0, pi)``) and its coherence."""
        sxx, sxy, syy = (self.tensor[..., i] for i in range(3))
        angle = 0.5 * np.arctan2(2 * sxy, sxx - syy)
        tr = sxx + syy
        coherence = np.sqrt((sxx - syy) ** 2 + 4 * sxy**2) / np.maximum(tr, 1e-12)
        return np.mod(angle, np.pi), coherence


def edge_maps(image: np.ndarray, *, sigma: float = 1.0, percentile: float = 99.0) -> EdgeMaps:
    """Structure tensor and gradient of an image, normalised by its edge contrast.

    Parameters
    ----------
    image : (H, W, 3) uint8 or (H, W) uint8
    sigma : float
        Gaussian smoothing in pixels (suppresses JPEG blocking and wood grain).
    percentile : float
        The percentile of edge strength taken as the image's contrast.

    Returns
    -------
    EdgeMaps

    Examples
    --------
    >>> img = np.zeros((32, 32, 3), np.uint8); img[:, 16:] = 200
    >>> m = edge_maps(img)
    >>> bool(m.tensor[16, 15, 0] > 10 * m.tensor[16, 15, 2])  # a vertical edge: d/dx dominates
    True
    """
    img = as_rgb_image(image).astype(np.float32)
    if sigma > 0:
        img = cv2.GaussianBlur(img, (0, 0), sigma)
    gx = cv2.Sobel(img, cv2.CV_32F, 1, 0, ksize=3, scale=1.0 / 8.0)
    gy = cv2.Sobel(img, cv2.CV_32F, 0, 1, ksize=3, scale=1.0 / 8.0)
    sxx = np.sum(gx * gx, axis=2)
    sxy = np.sum(gx * gy, axis=2)
    syy = np.sum(gy * gy, axis=2)
    strength = np.sqrt(sxx + syy)
    contrast = float(np.percentile(strength, percentile))
    contrast = max(contrast, 1e-3)
    grey_gx = gx.mean(axis=2)
    grey_gy = gy.mean(axis=2)
    tensor = np.stack([sxx, sxy, syy], axis=2) / np.float32(contrast**2)
    gradient = np.stack([grey_gx, grey_gy], axis=2) / np.float32(contrast)
    tensor = np.ascontiguousarray(tensor, dtype=np.float32)
    gradient = np.ascontiguousarray(gradient, dtype=np.float32)
    return EdgeMaps(tensor, gradient, contrast, float(sigma))


def sample_maps(maps: np.ndarray, points: np.ndarray) -> np.ndarray:
    """Bilinear samples of a multi-channel float32 image at sub-pixel points.

    Parameters
    ----------
    maps : (H, W, C) float32
    points : (..., 2) float
        ``(x, y)`` pixel coordinates; outside the image (or NaN) samples are 0.

    Returns
    -------
    (..., C) float32
    """
    pts = np.asarray(points, dtype=np.float32)
    shape = pts.shape[:-1]
    flat = pts.reshape(-1, 2)
    m = len(flat)
    channels = maps.shape[2]
    if m == 0:
        return np.zeros((*shape, channels), np.float32)
    rows = -(-m // _REMAP_WIDTH)
    pad = rows * _REMAP_WIDTH - m
    flat = np.nan_to_num(flat, nan=-10.0)
    if pad:
        flat = np.concatenate([flat, np.full((pad, 2), -10.0, np.float32)])
    mx = flat[:, 0].reshape(rows, _REMAP_WIDTH)
    my = flat[:, 1].reshape(rows, _REMAP_WIDTH)
    out = np.empty((rows, _REMAP_WIDTH, channels), np.float32)
    # cv2.remap handles at most 4 channels at once.
    for c0 in range(0, channels, 4):
        part = np.ascontiguousarray(maps[:, :, c0:c0 + 4])
        res = cv2.remap(part, mx, my, interpolation=cv2.INTER_LINEAR,
                        borderMode=cv2.BORDER_CONSTANT, borderValue=0)
        out[:, :, c0:c0 + 4] = res.reshape(rows, _REMAP_WIDTH, -1)
    return out.reshape(-1, channels)[:m].reshape(*shape, channels)


def woodness_map(image: np.ndarray, region: np.ndarray, *, margin_px: int = 12,
                 max_samples: int = 20000, seed: int = 0) -> np.ndarray:
    """How much each pixel looks like the assembly's wood rather than the background.

    A two-class colour model learnt on the image itself: the background
    (table, room) from pixels outside ``region`` dilated by ``margin_px``;
    the wood from the pixels inside ``region`` that the background model
    explains worst. Colours are CIELAB with the lightness down-weighted, so
    that shading and shadows (darker, same hue) stay on their own side.

    Parameters
    ----------
    image : (H, W, 3) uint8
    region : (H, W) bool
        Where the assembly can be (e.g. the convex hull of its projected features).
    margin_px : int
    max_samples : int
        Pixels used to fit each class (random subset).
    seed : int

    Returns
    -------
    (H, W) float32
        In [0, 1]: the posterior of "wood" under equal priors.
    """
    img = as_rgb_image(image)
    lab = cv2.cvtColor(img, cv2.COLOR_RGB2Lab).astype(np.float32)
    lab[..., 0] *= 0.35
    h, w = region.shape
    inside = region.astype(np.uint8)
    grown = cv2.dilate(inside, np.ones((2 * margin_px + 1,) * 2, np.uint8)) > 0
    rng = np.random.default_rng(seed)
    flat = lab.reshape(-1, 3)
    bg_idx = np.flatnonzero(~grown.ravel())
    fg_idx = np.flatnonzero(inside.ravel() > 0)
    if len(bg_idx) < 100 or len(fg_idx) < 100:
        return np.full((h, w), 0.5, np.float32)
    bg = flat[rng.choice(bg_idx, min(max_samples, len(bg_idx)), replace=False)]
    fg = flat[rng.choice(fg_idx, min(max_samples, len(fg_idx)), replace=False)]

    def gaussian(x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        mean = np.median(x, axis=0)
        cov = np.cov((x - mean).T) + np.eye(3) * 4.0
        return mean, cov

    def logpdf(x: np.ndarray, mean: np.ndarray, cov: np.ndarray) -> np.ndarray:
        # Whitened by the Cholesky factor of the inverse covariance, in one OpenCV pass
        # (the whole image is scored: 25x faster than a numpy quadratic form).
        chol = np.linalg.cholesky(np.linalg.inv(cov))
        affine = np.hstack([chol.T, (-chol.T @ mean)[:, None]]).astype(np.float32)
        y = cv2.transform(np.ascontiguousarray(x, np.float32).reshape(-1, 1, 3), affine)
        y = y.reshape(-1, 3)
        return -0.5 * np.einsum("ij,ij->i", y, y) - 0.5 * np.log(np.linalg.det(cov))

    mb, cb = gaussian(bg)
    # Wood: the half of the region's pixels least like the background.
    score_fg = logpdf(fg, mb, cb)
    wood = fg[score_fg <= np.median(score_fg)]
    mw, cw = gaussian(wood)
    ll = logpdf(flat, mw, cw) - logpdf(flat, mb, cb)
    post = 1.0 / (1.0 + np.exp(-np.clip(ll, -30, 30)))
    return post.reshape(h, w).astype(np.float32)
