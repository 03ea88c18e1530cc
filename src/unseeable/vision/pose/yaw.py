"""Step 1 of the pose search: the yaw modulo 90° from vanishing directions.

Every log edge is a horizontal line along one of the grid's two axes. Each
image line segment (OpenCV's LSD, :func:`line_segments`) is the image of a
horizontal line only for one horizontal direction ψ (its vanishing point must
lie on the segment's line), so each segment votes for ψ
(:func:`segment_directions`). The assembly's two axes are 90° apart: a yaw
scores the product of the votes for it and for it + 90°
(:func:`dominant_yaw`), which ignores clutter with one direction only (a
wooden table's grain); the peaks of either direction alone
(:func:`axis_yaws`) serve views with one axis across the line of sight.
"""

from __future__ import annotations

import cv2
import numpy as np

from unseeable.camera import Camera
from unseeable.errors import VisionError
from unseeable.vision.edges import as_rgb_image

__all__ = [
    "line_segments",
    "horizontal_direction",
    "segment_directions",
    "yaw_gap",
    "dominant_yaw",
    "axis_yaws",
    "concentration",
    "crowd_map",
    "collinear_length",
]


def line_segments(image: np.ndarray, *, min_length: float = 12.0) -> np.ndarray:
    """Straight edge segments of an image (OpenCV's LSD).

    Parameters
    ----------
    image : (H, W, 3) uint8
    min_length : float
        Shorter segments are dropped.

    Returns
    -------
    (L, 2, 2) float
        End points ``(x, y)``.
    """
    img = as_rgb_image(image)
    grey = cv2.cvtColor(img, cv2.COLOR_RGB2GRAY)
    lsd = cv2.createLineSegmentDetector(cv2.LSD_REFINE_STD)
    lines = lsd.detect(grey)[0]
    if lines is None:
        return np.zeros((0, 2, 2))
    seg = lines.reshape(-1, 2, 2).astype(float)
    length = np.linalg.norm(seg[:, 1] - seg[:, 0], axis=1)
    return seg[length >= min_length]


def horizontal_direction(psi_rad: np.ndarray | float) -> np.ndarray:
    """World horizontal direction of angle ψ: ``(cos ψ, 0, -sin ψ)`` (grid i at yaw ψ)."""
    psi = np.asarray(psi_rad, dtype=float)
    return np.stack([np.cos(psi), np.zeros_like(psi), -np.sin(psi)], axis=-1)


def segment_directions(segments: np.ndarray, camera: Camera) -> tuple[np.ndarray, np.ndarray]:
    """The horizontal world direction each image segment would be the image of.

    A horizontal world line of direction ``d(ψ) = (cos ψ, 0, -sin ψ)`` has its
    vanishing point at ``R d(ψ)`` (normalised coordinates); the segment's
    line ``l`` contains it when ``(Rᵀ l) · d(ψ) = 0``.

    Parameters
    ----------
    segments : (L, 2, 2) float
    camera : Camera

    Returns
    -------
    psi_deg : (L,) float
        In ``[0, 180)``; a grid at yaw ψ has its axes at ψ and ψ - 90.
    reliability : (L,) float
        In [0, 1]: near 0 for segments along the horizon, which fit any ψ.
    """
    seg = np.asarray(segments, dtype=float)
    if len(seg) == 0:
        return np.zeros(0), np.zeros(0)

    def directions(points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        norm = camera.normalised(points)
        h = np.concatenate([norm, np.ones(norm.shape[:-1] + (1,))], axis=-1)
        line = np.cross(h[:, 0], h[:, 1])
        line /= np.linalg.norm(line, axis=1, keepdims=True)
        m = line @ camera.R  # Rᵀ l for each row
        return np.degrees(np.arctan2(m[:, 0], m[:, 2])) % 180.0, m

    psi, m = directions(seg)
    reliability = np.hypot(m[:, 0], m[:, 2]) / np.maximum(np.linalg.norm(m, axis=1), 1e-12)
    return psi, reliability


def yaw_gap(a: float, b: float) -> float:
    """Distance in degrees between two yaws modulo 90° (a grid's two axes look alike)."""
    return abs((a - b + 45.0) % 90.0 - 45.0)


def _separated_peaks(grid: np.ndarray, values: np.ndarray, *, count: int,
                     separation_deg: float, where: np.ndarray | None = None) -> list[float]:
    """The ``grid`` yaws of the highest ``values`` (only ``where`` set), each at least
    ``separation_deg`` (modulo 90°) from every higher one kept, at most ``count``."""
    allowed = np.ones(len(values), bool) if where is None else where
    found: list[float] = []
    for b in np.argsort(-np.where(allowed, values, -np.inf)):
        if not allowed[b]:
            break
        y = float(grid[b])
        if all(yaw_gap(y, o) > separation_deg for o in found):
            found.append(y)
            if len(found) == count:
                break
    return found


def _vote_density(psi_deg: np.ndarray, weights: np.ndarray, *, period_deg: float,
                  sigma_deg: float, step: float = 0.1) -> tuple[np.ndarray, np.ndarray]:
    """Direction votes as a circular density: ``(grid, density)``, ``step`` degrees apart."""
    grid = np.arange(0.0, period_deg, step)
    hist = np.bincount(np.round(psi_deg / step).astype(int) % len(grid), weights=weights,
                       minlength=len(grid))
    # Circular Gaussian smoothing via the FFT.
    freq = np.fft.rfftfreq(len(grid), d=step)
    kernel = np.exp(-2 * (np.pi * sigma_deg * freq) ** 2)
    return grid, np.maximum(np.fft.irfft(np.fft.rfft(hist) * kernel, n=len(grid)), 0.0)


def dominant_yaw(psi_deg: np.ndarray, weights: np.ndarray, *, sigma_deg: float = 0.75,
                 peaks: int = 1, separation_deg: float = 4.0) -> tuple:
    """The yaw modulo 90° whose two axis directions both collect strong votes.

    Parameters
    ----------
    psi_deg : (L,) float
        Directions voted for, degrees in [0, 180).
    weights : (L,) float
    sigma_deg : float
        Vote width.
    peaks : int
        With ``peaks > 1``, return the ``peaks`` best yaws (at least
        ``separation_deg`` apart, unrefined) and the best product instead.

    Returns
    -------
    yaw_mod90 : float
        Degrees in [0, 90).
    strength : float
        Geometric mean of the two directions' vote mass near the peak,
        relative to the total vote mass (0 when a direction has no votes).

    Examples
    --------
    >>> psi = np.array([10.0, 10.2, 100.1, 99.9, 45.0, 45.0, 45.0])
    >>> bool(abs(dominant_yaw(psi, np.ones(7))[0] - 10.05) < 0.1)
    True
    """
    psi = np.asarray(psi_deg, dtype=float) % 180.0
    w = np.asarray(weights, dtype=float)
    if len(psi) == 0 or w.sum() <= 0:
        raise VisionError("no straight edges in the image to fix the assembly's yaw")
    grid, smooth = _vote_density(psi, w, period_deg=180.0, sigma_deg=sigma_deg)
    half = len(grid) // 2
    product = smooth[:half] * smooth[half:]
    best = int(np.argmax(product))
    if peaks > 1:
        return (_separated_peaks(grid[:half], product, count=peaks,
                                 separation_deg=separation_deg), float(product[best]))
    # Refine: weighted circular mean of the votes near either direction, folded to 90°.
    folded = psi % 90.0
    centre = grid[best]
    diff = (folded - centre + 45.0) % 90.0 - 45.0
    near = np.abs(diff) < 2.5 * sigma_deg
    if near.any() and w[near].sum() > 0:
        centre = centre + float(np.sum(diff[near] * w[near]) / np.sum(w[near]))
    mass_a = smooth[best] * np.sqrt(2 * np.pi) * sigma_deg
    mass_b = smooth[best + half] * np.sqrt(2 * np.pi) * sigma_deg
    strength = float(np.sqrt(max(mass_a, 0) * max(mass_b, 0)) / max(w.sum(), 1e-12))
    return float(centre % 90.0), strength


def axis_yaws(psi_deg: np.ndarray, weights: np.ndarray, *, sigma_deg: float = 0.75,
              peaks: int = 2, separation_deg: float = 2.0) -> list[float]:
    """Yaws modulo 90° at which *either* axis direction collects a peak of votes.

    :func:`dominant_yaw` wants both of the grid's directions; seen with one
    axis nearly across the line of sight, that axis's edges run along the
    horizon, where a segment fits any direction (its votes are weighed
    out), and the product of the two directions' votes peaks elsewhere.
    The local maxima of the folded sum still mark the other axis.

    Parameters
    ----------
    psi_deg : (L,) float
        Directions voted for, degrees in [0, 180).
    weights : (L,) float
    sigma_deg : float
        Vote width.
    peaks : int
        Yaws returned, strongest first.
    separation_deg : float
        Minimum distance between them (modulo 90°).

    Returns
    -------
    list of float
        Degrees in [0, 90); empty when there are no votes.

    Examples
    --------
    >>> psi = np.array([10.0, 10.2, 9.9, 137.0])
    >>> [round(y, 1) for y in axis_yaws(psi, np.ones(4))]
    [10.0, 47.0]
    """
    psi = np.asarray(psi_deg, dtype=float) % 90.0
    w = np.asarray(weights, dtype=float)
    if len(psi) == 0 or w.sum() <= 0 or peaks <= 0:
        return []
    grid, votes = _vote_density(psi, w, period_deg=90.0, sigma_deg=sigma_deg)
    is_max = (votes >= np.roll(votes, 1)) & (votes > np.roll(votes, -1)) & (votes > 0)
    return _separated_peaks(grid, votes, count=peaks, separation_deg=separation_deg,
                            where=is_max)


def concentration(segments: np.ndarray, psi_deg: np.ndarray, weights: np.ndarray, *,
                  radius_px: float, image_area: float, angle_sigma_deg: float = 1.0,
                  excess: float = 2.0, max_segments: int = 4000) -> np.ndarray:
    """How much each segment's direction crowds near it, beyond that direction's rate over
    the whole image: ``(L,)`` in [0, 1].

    An assembly is compact: its edges (both grid axes, folded modulo 90°) crowd
    within its own image size. A seamed or tiled table's lines, or a room's,
    run the same few directions all over the view, about as densely near any
    segment as anywhere. For each segment, ``local`` is the weight of the
    segments of about its direction (Gaussian in the folded direction,
    ``angle_sigma_deg``) within about ``radius_px`` of its midpoint (Gaussian
    of sigma ``radius_px / 2``, itself included), ``expected`` the same
    direction's weight over the image spread evenly over that Gaussian's area;
    the result is ``1 - excess * expected / local``, clipped: near 1 for an
    edge where its direction crowds, 0 for one of a texture spread over the
    view (up to ``excess`` times as densely near it as over the whole view:
    perspective crowds a table's far lines).

    Parameters
    ----------
    segments : (L, 2, 2) float
        End points (px).
    psi_deg : (L,) float
        Directions voted for (:func:`segment_directions`).
    weights : (L,) float
        The votes' weights.
    radius_px : float
        About the assembly's size in the image.
    image_area : float
        Pixels in the image.
    angle_sigma_deg : float
    excess : float
    max_segments : int
        Beyond this many segments (strongest kept) the others get 0 (memory).
    """
    seg = np.asarray(segments, dtype=float)
    w = np.asarray(weights, dtype=float)
    n = len(seg)
    out = np.zeros(n)
    if n == 0:
        return out
    keep = np.argsort(-w)[:max_segments]
    mid = seg[keep].mean(axis=1)
    folded = np.asarray(psi_deg, dtype=float)[keep] % 90.0
    wk = w[keep]
    dpsi = (folded[:, None] - folded[None, :] + 45.0) % 90.0 - 45.0
    same = np.exp(-0.5 * (dpsi / angle_sigma_deg) ** 2)
    sigma = max(radius_px / 2.0, 1.0)
    d2 = np.sum((mid[:, None, :] - mid[None, :, :]) ** 2, axis=-1)
    near = np.exp(-0.5 * d2 / sigma**2)
    local = (same * near) @ wk
    expected = (same @ wk) * min(2.0 * np.pi * sigma**2 / max(image_area, 1.0), 1.0)
    out[keep] = np.clip(1.0 - excess * expected / np.maximum(local, 1e-12), 0.0, 1.0)
    return out


def crowd_map(segments: np.ndarray, crowd: np.ndarray, shape: tuple[int, int], *,
              radius_px: float) -> np.ndarray:
    """``(H, W) float32`` in [0, 1]: where the segments whose direction crowds lie
    (:func:`concentration` above 0.5), blurred by about the assembly's size
    (Gaussian of sigma ``radius_px / 2``) and scaled to a maximum of 1."""
    out = np.zeros(shape, np.float32)
    for (a, b), c in zip(np.asarray(segments, dtype=float), np.asarray(crowd, dtype=float)):
        if c > 0.5:
            cv2.line(out, (int(round(a[0])), int(round(a[1]))),
                     (int(round(b[0])), int(round(b[1]))), float(c), 2)
    sigma = max(radius_px / 2.0, 1.0)
    out = cv2.GaussianBlur(out, (0, 0), sigma)
    top = float(out.max())
    return out / top if top > 0 else out


def collinear_length(segments: np.ndarray, lengths: np.ndarray, *, tolerance_px: float = 1.5
                     ) -> np.ndarray:
    """``(L,)``: for each segment, the total of ``lengths`` over the segments lying on its
    image line (both end points within ``tolerance_px`` of it), itself included: how
    long a straight edge it belongs to, across gaps (a seam broken by crossings or by
    what stands on it)."""
    seg = np.asarray(segments, dtype=float)
    if len(seg) == 0:
        return np.zeros(0)
    h = np.concatenate([seg, np.ones(seg.shape[:2] + (1,))], axis=-1)
    line = np.cross(h[:, 0], h[:, 1])
    line /= np.maximum(np.hypot(line[:, 0], line[:, 1]), 1e-12)[:, None]
    # (L, L): the farther end point of segment j from the line of segment i.
    dist = np.maximum(np.abs(line @ h[:, 0].T), np.abs(line @ h[:, 1].T))
    return (dist <= tolerance_px).astype(float) @ np.asarray(lengths, dtype=float)
