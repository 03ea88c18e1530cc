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
