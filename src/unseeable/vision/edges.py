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
import numba
import numpy as np

from unseeable.errors import InputError

__all__ = ["EdgeMaps", "edge_maps", "sample_maps", "normal_edge_peaks", "ellipse_rim_strength",
           "segment_edge_strength", "as_rgb_image", "fill_convex_hull", "image_window", "mask_box",
           "kernel_tensor", "profile_peak", "woodness_map", "WOOD_LIGHTNESS_WEIGHT"]

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


def image_window(points: np.ndarray, shape: tuple[int, int], *,
                 margin_px: int = 0) -> tuple[slice, slice]:
    """Rows and columns of an ``(H, W)`` image around ``points``: their bounding box
    grown by ``margin_px`` on every side and clipped to the image.

    Parameters
    ----------
    points : (N, 2) float
        ``(x, y)`` pixel coordinates. Any that is not finite (behind the camera)
        makes the window the whole image.
    shape : (int, int)
        ``(H, W)``.
    margin_px : int

    Returns
    -------
    (slice, slice)
        ``(rows, cols)``, never empty (a box beyond the image keeps its nearest
        pixel).

    Examples
    --------
    >>> image_window(np.array([[10.2, 5.0], [20.0, 7.5]]), (48, 64), margin_px=2)
    (slice(3, 11, None), slice(8, 23, None))
    >>> image_window(np.array([[np.nan, 0.0]]), (48, 64))
    (slice(0, 48, None), slice(0, 64, None))
    """
    pts = np.asarray(points, dtype=float)
    if pts.ndim != 2 or pts.shape[1] != 2 or len(pts) == 0:
        raise InputError("must be a non-empty (N, 2) array of (x, y)", field="points",
                         value=pts.shape)
    h, w = (int(n) for n in shape)
    if not np.all(np.isfinite(pts)):
        return slice(0, h), slice(0, w)
    lo = np.floor(pts.min(axis=0)) - margin_px
    hi = np.ceil(pts.max(axis=0)) + margin_px + 1
    x0, y0 = (int(np.clip(v, 0, n - 1)) for v, n in zip(lo, (w, h)))
    x1, y1 = (int(np.clip(v, x + 1, n)) for v, x, n in zip(hi, (x0, y0), (w, h)))
    return slice(y0, y1), slice(x0, x1)


def mask_box(mask: np.ndarray) -> np.ndarray:
    """Corners ``(x, y)`` of the bounding box of a mask's set pixels: ``(2, 2)``
    (top left, bottom right), or ``(0, 2)`` when none is set.

    Examples
    --------
    >>> mask = np.zeros((4, 6), bool)
    >>> mask[1:3, 2:5] = True
    >>> mask_box(mask).tolist()
    [[2, 1], [4, 2]]
    >>> mask_box(np.zeros((4, 6), bool)).shape
    (0, 2)
    """
    rows, cols = np.flatnonzero(mask.any(axis=1)), np.flatnonzero(mask.any(axis=0))
    if not len(rows):
        return np.zeros((0, 2), int)
    return np.array([[cols[0], rows[0]], [cols[-1], rows[-1]]])


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
    # One (x, y) map for cv2.remap, padded off the image; NaN -> -10 (off the image: 0).
    # (np.nan_to_num took 0.2 ms a call, most of it on infinities, which are rare here.)
    xy = np.full((rows * _REMAP_WIDTH, 2), -10.0, np.float32)
    np.copyto(xy[:m], flat, where=~np.isnan(flat))
    if np.isinf(xy).any():
        xy = np.nan_to_num(xy)
    xy = xy.reshape(rows, _REMAP_WIDTH, 2)
    out = np.empty((rows, _REMAP_WIDTH, channels), np.float32)
    # cv2.remap handles at most 4 channels at once.
    for c0 in range(0, channels, 4):
        part = np.ascontiguousarray(maps[:, :, c0:c0 + 4])
        res = cv2.remap(part, xy, None, interpolation=cv2.INTER_LINEAR,
                        borderMode=cv2.BORDER_CONSTANT, borderValue=0)
        out[:, :, c0:c0 + 4] = res.reshape(rows, _REMAP_WIDTH, -1)
    return out.reshape(-1, channels)[:m].reshape(*shape, channels)


@numba.njit(cache=True, inline="always")
def _corner(maps: np.ndarray, x: float, y: float) -> tuple[int, int, np.float32, np.float32]:
    """The top-left pixel of ``(x, y)``'s bilinear cell and the fractions; ``sx = -2`` when
    the point is beyond the image's pixels (or NaN)."""
    h, w = maps.shape[0], maps.shape[1]
    if not (x > -1.0 and y > -1.0 and x < w and y < h):  # also false for NaN
        return -2, -2, np.float32(0.0), np.float32(0.0)
    x0 = np.floor(x)
    y0 = np.floor(y)
    return int(x0), int(y0), np.float32(x - x0), np.float32(y - y0)


@numba.njit(cache=True, inline="always")
def _bilinear(v00: np.float32, v01: np.float32, v10: np.float32, v11: np.float32,
              fx: np.float32, fy: np.float32) -> np.float32:
    """A cell's corner values blended at fractions ``(fx, fy)``, in float32 (as cv2.remap)."""
    one = np.float32(1.0)
    return (v00 * (one - fx) + v01 * fx) * (one - fy) + (v10 * (one - fx) + v11 * fx) * fy


@numba.njit(cache=True, inline="always")
def _interpolate(maps: np.ndarray, sx: int, sy: int, fx: np.float32, fy: np.float32,
                 c: int) -> np.float32:
    """Channel ``c`` of the bilinear cell at ``(sx, sy)`` (:func:`_corner`); 0 beyond the image."""
    zero = np.float32(0.0)
    if sx == -2:
        return zero
    h, w = maps.shape[0], maps.shape[1]
    v00 = maps[sy, sx, c] if (sx >= 0 and sy >= 0) else zero
    v01 = maps[sy, sx + 1, c] if (sx + 1 < w and sy >= 0) else zero
    v10 = maps[sy + 1, sx, c] if (sx >= 0 and sy + 1 < h) else zero
    v11 = maps[sy + 1, sx + 1, c] if (sx + 1 < w and sy + 1 < h) else zero
    return _bilinear(v00, v01, v10, v11, fx, fy)


@numba.njit(cache=True, inline="always")
def _energy_across(tensor: np.ndarray, x: float, y: float, nx: float, ny: float) -> float:
    """``sqrt(max(nᵀ S n, 0))`` with the structure tensor ``S`` sampled at ``(x, y)``."""
    sx, sy, fx, fy = _corner(tensor, x, y)
    h, w = tensor.shape[0], tensor.shape[1]
    if sx >= 0 and sy >= 0 and sx + 1 < w and sy + 1 < h:
        # Inside the image (nearly every probe): the four corners read once for the three
        # channels, without _interpolate's bounds checks.
        r0 = tensor[sy, sx]
        r1 = tensor[sy, sx + 1]
        r2 = tensor[sy + 1, sx]
        r3 = tensor[sy + 1, sx + 1]
        sxx = np.float64(_bilinear(r0[0], r1[0], r2[0], r3[0], fx, fy))
        sxy = np.float64(_bilinear(r0[1], r1[1], r2[1], r3[1], fx, fy))
        syy = np.float64(_bilinear(r0[2], r1[2], r2[2], r3[2], fx, fy))
    else:
        sxx = np.float64(_interpolate(tensor, sx, sy, fx, fy, 0))
        sxy = np.float64(_interpolate(tensor, sx, sy, fx, fy, 1))
        syy = np.float64(_interpolate(tensor, sx, sy, fx, fy, 2))
    return np.sqrt(max(sxx * nx * nx + 2 * sxy * nx * ny + syy * ny * ny, 0.0))


def kernel_tensor(tensor: np.ndarray) -> np.ndarray:
    """``tensor`` as the kernels read it: ``(H, W, 3)`` contiguous float32 (checked)."""
    table = np.ascontiguousarray(tensor, dtype=np.float32)
    if table.ndim != 3 or table.shape[2] != 3:
        raise InputError("must have shape (H, W, 3)", field="tensor", value=table.shape)
    return table


def normal_edge_peaks(tensor: np.ndarray, points: np.ndarray, normals: np.ndarray,
                      offsets: np.ndarray) -> tuple[np.ndarray, ...]:
    """The strongest edge along each point's normal, from the structure tensor.

    For each point and offset ``o``, the edge energy across the normal,
    ``sqrt(max(nᵀ S n, 0))`` with ``S`` sampled bilinearly (in float32, 0
    beyond the image) at ``point + o · normal``; one pass, no profile array.

    Parameters
    ----------
    tensor : (H, W, 3) float32
        ``(Sxx, Sxy, Syy)`` (:attr:`EdgeMaps.tensor`).
    points, normals : (M, 2) float
        Finite points; unit normals.
    offsets : (P,) float
        Increasing offsets along the normal (pixels).

    Returns
    -------
    k : (M,) int
        Index of the strongest offset (the first, on a tie).
    peak, left, right : (M,) float
        The energy there and at the offsets either side (the index clipped to the ends).
    at_zero : (M,) float
        The energy at the offset nearest 0.
    """
    pts = np.ascontiguousarray(points, dtype=np.float64).reshape(-1, 2)
    nrm = np.ascontiguousarray(normals, dtype=np.float64).reshape(-1, 2)
    off = np.ascontiguousarray(offsets, dtype=np.float64).reshape(-1)
    if len(pts) != len(nrm) or not len(off):
        raise InputError("need as many normals as points, and offsets",
                         field="normals", value=(pts.shape, nrm.shape, off.shape))
    table = kernel_tensor(tensor)
    return _normal_peaks_kernel(table, pts, nrm, off, int(np.argmin(np.abs(off))))


@numba.njit(cache=True, inline="always")
def profile_peak(tensor, px, py, nx, ny, offsets, zero_index, prof):
    """The strongest energy across the unit normal ``(nx, ny)`` at ``(px, py)`` + each
    offset: ``(k, peak, left, right, at_zero)`` as :func:`normal_edge_peaks` returns them
    for one point (``prof``: scratch of the offsets' length)."""
    n_off = offsets.shape[0]
    for j in range(n_off):
        # float32 probe coordinates, as sample_maps receives them.
        x = np.float64(np.float32(px + offsets[j] * nx))
        y = np.float64(np.float32(py + offsets[j] * ny))
        prof[j] = _energy_across(tensor, x, y, nx, ny)
    kb = 0
    for j in range(1, n_off):
        if prof[j] > prof[kb]:
            kb = j
    return (kb, prof[kb], prof[max(kb - 1, 0)], prof[min(kb + 1, n_off - 1)],
            prof[zero_index])


@numba.njit(cache=True, nogil=True)
def _normal_peaks_kernel(tensor, points, normals, offsets, zero_index):
    m, n_off = points.shape[0], offsets.shape[0]
    k_best = np.zeros(m, np.int64)
    peak = np.zeros(m)
    left = np.zeros(m)
    right = np.zeros(m)
    at_zero = np.zeros(m)
    prof = np.empty(n_off)
    for i in range(m):
        k_best[i], peak[i], left[i], right[i], at_zero[i] = profile_peak(
            tensor, points[i, 0], points[i, 1], normals[i, 0], normals[i, 1], offsets,
            zero_index, prof)
    return k_best, peak, left, right, at_zero


def segment_edge_strength(tensor: np.ndarray, segments: np.ndarray, *, samples: int,
                          shift: int) -> np.ndarray:
    """How strongly an edge runs along each image segment, near where it is expected.

    ``samples`` points evenly spaced along each segment (at the middles of
    equal parts) are moved across it by whole pixels, ``-shift..shift``; at
    the move whose mean energy across the segment (``sqrt(max(nᵀ S n, 0))``,
    ``S`` sampled bilinearly) is largest, each point takes the largest energy
    within a pixel of it (a pixel of wiggle), and the segment the mean of
    those: the ``strength`` of :func:`~unseeable.vision.detectors.score_segments`.

    Parameters
    ----------
    tensor : (H, W, 3) float32
        ``(Sxx, Sxy, Syy)`` (:attr:`EdgeMaps.tensor`).
    segments : (M, 2, 2) float
        Image end points.
    samples, shift : int

    Returns
    -------
    (M,) float
    """
    seg = np.ascontiguousarray(segments, dtype=np.float64)
    if seg.ndim != 3 or seg.shape[1:] != (2, 2):
        raise InputError("must have shape (M, 2, 2)", field="segments", value=seg.shape)
    for name, value in (("samples", samples), ("shift", shift)):
        if not isinstance(value, (int, np.integer)) or value < (1 if name == "samples" else 0):
            raise InputError("must be a whole number (samples at least 1, shift at least 0)",
                             field=name, value=value)
    table = kernel_tensor(tensor)
    return _segment_strength_kernel(table, seg, int(samples), int(shift))


@numba.njit(cache=True, nogil=True)
def _segment_strength_kernel(tensor, segments, samples, shift):
    m = segments.shape[0]
    n_off = 2 * shift + 3  # the moves -shift..shift and a pixel either side
    out = np.zeros(m)
    energy = np.empty((n_off, samples))
    for i in range(m):
        x0, y0 = segments[i, 0, 0], segments[i, 0, 1]
        dx, dy = segments[i, 1, 0] - x0, segments[i, 1, 1] - y0
        length = np.sqrt(dx * dx + dy * dy)
        tx, ty = (dx / length, dy / length) if length > 0 else (dx, dy)
        nx, ny = -ty, tx
        for j in range(n_off):
            off = np.float64(j - shift - 1)
            for k in range(samples):
                s = (k + 0.5) / samples
                x = np.float64(np.float32(x0 + s * dx + off * nx))
                y = np.float64(np.float32(y0 + s * dy + off * ny))
                energy[j, k] = _energy_across(tensor, x, y, nx, ny)
        best, best_mean = 1, -1.0
        for j in range(1, n_off - 1):
            mean = energy[j].mean()
            if mean > best_mean:
                best, best_mean = j, mean
        total = 0.0
        for k in range(samples):
            total += max(energy[best - 1, k], energy[best, k], energy[best + 1, k])
        out[i] = total / samples
    return out


def ellipse_rim_strength(tensor: np.ndarray, ellipses: np.ndarray, samples: int) -> np.ndarray:
    """Mean edge energy across the rims of ellipses, from the structure tensor.

    At ``samples`` points evenly spaced in parameter on each ellipse, the
    energy ``sqrt(max(nᵀ S n, 0))`` across the ellipse's outward normal ``n``
    (``S`` sampled bilinearly), averaged; one pass, no arrays of points.

    Parameters
    ----------
    tensor : (H, W, 3) float32
        ``(Sxx, Sxy, Syy)`` (:attr:`EdgeMaps.tensor`).
    ellipses : (..., 5) float
        ``(cx, cy, a, b, theta)``; a non-finite one scores NaN.
    samples : int

    Returns
    -------
    (...) float
    """
    ell = np.asarray(ellipses, dtype=np.float64)
    if ell.shape[-1:] != (5,):
        raise InputError("must have shape (..., 5)", field="ellipses", value=ell.shape)
    if not isinstance(samples, (int, np.integer)) or samples < 1:
        raise InputError("must be a positive whole number", field="samples", value=samples)
    table = kernel_tensor(tensor)
    t = np.linspace(0.0, 2.0 * np.pi, int(samples), endpoint=False)
    flat = np.ascontiguousarray(ell.reshape(-1, 5))
    return _rim_kernel(table, flat, np.cos(t), np.sin(t)).reshape(ell.shape[:-1])


@numba.njit(cache=True, nogil=True)
def _rim_kernel(tensor, ellipses, cos_t, sin_t):
    out = np.zeros(ellipses.shape[0])
    r = cos_t.shape[0]
    for i in range(ellipses.shape[0]):
        cx, cy, a, b, th = (ellipses[i, 0], ellipses[i, 1], ellipses[i, 2], ellipses[i, 3],
                            ellipses[i, 4])
        if not (np.isfinite(cx) and np.isfinite(cy) and np.isfinite(a) and np.isfinite(b)
                and np.isfinite(th)):
            out[i] = np.nan
            continue
        cth, sth = np.cos(th), np.sin(th)
        total = 0.0
        for j in range(r):
            lx, ly = a * cos_t[j], b * sin_t[j]
            x = np.float64(np.float32(cx + lx * cth - ly * sth))
            y = np.float64(np.float32(cy + lx * sth + ly * cth))
            # Outward normal of (a cos t, b sin t) is along (b cos t, a sin t), turned by theta.
            nx_l, ny_l = b * cos_t[j], a * sin_t[j]
            nx = nx_l * cth - ny_l * sth
            ny = nx_l * sth + ny_l * cth
            norm = np.sqrt(nx * nx + ny * ny)
            if norm > 0:
                nx /= norm
                ny /= norm
            total += _energy_across(tensor, x, y, nx, ny)
        out[i] = total / r
    return out


#: :func:`woodness_map`'s default weight of lightness against colour: what the shipped
#: detector calibration was fitted with.
WOOD_LIGHTNESS_WEIGHT = 0.35


def woodness_map(image: np.ndarray, region: np.ndarray, *, margin_px: int = 12,
                 max_samples: int = 20000, seed: int = 0,
                 lab: np.ndarray | None = None,
                 window: tuple[slice, slice] | None = None,
                 lightness_weight: float = WOOD_LIGHTNESS_WEIGHT) -> np.ndarray:
    """How much each pixel looks like the assembly's wood rather than the background.

    A two-class colour model learnt on the image itself: the background
    (table, room) from pixels outside ``region`` dilated by ``margin_px``;
    the wood from the pixels inside ``region`` that the background model
    explains worst. Colours are CIELAB with the lightness down-weighted
    (``lightness_weight``), so that shading and shadows (darker, same hue)
    stay on their own side.

    Parameters
    ----------
    image : (H, W, 3) uint8
    region : (H, W) bool
        Where the assembly can be (e.g. the convex hull of its projected features).
    margin_px : int
    max_samples : int
        Pixels used to fit each class (random subset).
    seed : int
    lab : (H, W, 3) uint8, optional
        ``cv2.cvtColor(image, cv2.COLOR_RGB2Lab)``, when the caller has it already.
    window : (slice, slice), optional
        Rows and columns (:func:`image_window`) to score: the map is left at 0
        elsewhere. The model is learnt on the whole image all the same, so inside
        the window the map is the one the whole image gives (to float rounding:
        vectorised loops round a few pixels differently). For a caller that reads
        the map near the assembly only (the detectors), the whole image's colour
        conversion and scoring would be wasted.
    lightness_weight : float
        Factor on the lightness (0-255 scale) against the two colour axes; 0
        leaves colour alone. The detectors' calibration was fitted with the
        default. Lower weights keep the logs' pale specular highlights on the
        wood's side (``benchmarks/woodness.py``: 0 separates log pixels from
        the rest far better on every corpus build measured; docs/benchmarks.md),
        but the calibration must be refitted with them.

    Returns
    -------
    (H, W) float32
        In [0, 1]: the posterior of "wood" under equal priors.
    """
    img = as_rgb_image(image)
    if not (isinstance(lightness_weight, (int, float)) and np.isfinite(lightness_weight)
            and lightness_weight >= 0):
        raise InputError("must be a finite number >= 0", field="lightness_weight",
                         value=lightness_weight)
    if lab is not None and (lab.shape != img.shape or lab.dtype != np.uint8):
        raise InputError("must be the (H, W, 3) uint8 Lab image of the image", field="lab",
                         value=(lab.shape, str(lab.dtype)))
    if window is not None and not (isinstance(window, tuple) and len(window) == 2
                                   and all(isinstance(part, slice) for part in window)):
        raise InputError("must be (rows, cols), two slices (see image_window)",
                         field="window", value=window)
    h, w = region.shape
    rows, cols = (slice(0, h), slice(0, w)) if window is None else window
    inside = region.astype(np.uint8)
    grown = cv2.dilate(inside, np.ones((2 * margin_px + 1,) * 2, np.uint8)) > 0
    rng = np.random.default_rng(seed)
    bg_idx = np.flatnonzero(~grown.ravel())
    fg_idx = np.flatnonzero(inside.ravel() > 0)
    if len(bg_idx) < 100 or len(fg_idx) < 100:
        out = np.zeros((h, w), np.float32)
        out[rows, cols] = 0.5
        return out

    def colours(pixels: np.ndarray) -> np.ndarray:
        # Lightness down-weighted; the conversion is per pixel, so converting only the
        # pixels needed gives what converting the whole image would.
        if lab is not None:
            part = lab.reshape(-1, 3)[pixels]
        else:
            part = cv2.cvtColor(img.reshape(-1, 1, 3)[pixels], cv2.COLOR_RGB2Lab)
        part = part.reshape(-1, 3).astype(np.float32)
        part[:, 0] *= lightness_weight
        return part

    bg = colours(rng.choice(bg_idx, min(max_samples, len(bg_idx)), replace=False))
    fg = colours(rng.choice(fg_idx, min(max_samples, len(fg_idx)), replace=False))

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
    scored = (lab[rows, cols] if lab is not None
              else cv2.cvtColor(np.ascontiguousarray(img[rows, cols]), cv2.COLOR_RGB2Lab))
    flat = scored.reshape(-1, 3).astype(np.float32)
    flat[:, 0] *= lightness_weight
    ll = logpdf(flat, mw, cw) - logpdf(flat, mb, cb)
    post = 1.0 / (1.0 + np.exp(-np.clip(ll, -30, 30)))
    out = np.zeros((h, w), np.float32)
    out[rows, cols] = post.reshape(scored.shape[:2])
    return out
