"""Pictures for people: features drawn at their projections, coloured by p_f; pose grids."""

from __future__ import annotations

from typing import TYPE_CHECKING

import cv2
import numpy as np

from unseeable.camera import Camera
from unseeable.domain import Extent, GridPose, LogGeometry
from unseeable.vision.edges import as_rgb_image
from unseeable.vision.pose import pose_lines
from unseeable.vision.projection import FeatureProjection, ellipse_points, project_features
from unseeable.vision.scale import working_scale

if TYPE_CHECKING:
    from unseeable.vision.evidence import FeatureDetection

__all__ = ["probability_colours", "draw_evidence", "draw_detection", "draw_pose"]

_SHIFT = 4  # fixed-point bits for sub-pixel drawing
_ONE = 1 << _SHIFT


def probability_colours(p: np.ndarray) -> np.ndarray:
    """RGB colours ``(N, 3) uint8`` for probabilities: red (absent) → yellow → green (present)."""
    q = np.clip(np.asarray(p, dtype=float), 0.0, 1.0)
    red = np.clip(2.0 * (1.0 - q), 0.0, 1.0)
    green = np.clip(2.0 * q, 0.0, 1.0)
    return np.round(np.stack([red, green, np.zeros_like(q)], axis=1) * 255).astype(np.uint8)


def _fixed(points: np.ndarray) -> np.ndarray:
    return np.round(np.asarray(points) * _ONE).astype(np.int32)


def draw_evidence(image: np.ndarray, projection: FeatureProjection, p: np.ndarray,
                  judged: np.ndarray, *, ellipses: np.ndarray | None = None,
                  thickness: int = 1, dim: float = 0.6) -> np.ndarray:
    """The image (dimmed) with every judged feature drawn at its projection, coloured by p_f.

    Parameters
    ----------
    image : (H, W, 3) uint8
    projection : FeatureProjection
    p : (N,) float
        Probability that each feature is present.
    judged : (N,) bool
        Features to draw.
    ellipses : (N, 5) float, optional
        Ellipses to draw for ends (e.g. the detectors' best fits); default the projections.
    thickness : int
    dim : float
        Brightness factor of the photograph under the drawing.

    Returns
    -------
    (H, W, 3) uint8
    """
    out = (as_rgb_image(image).astype(np.float32) * dim).astype(np.uint8)
    colours = probability_colours(p)
    ell = projection.ellipses if ellipses is None else np.where(
        np.isfinite(ellipses), ellipses, projection.ellipses)
    is_end = projection.is_end
    # Segments first, ends on top; confident ones last so they stay visible.
    order = np.argsort(np.abs(np.asarray(p) - 0.5))
    for n in order:
        if not judged[n]:
            continue
        colour = tuple(int(c) for c in colours[n])
        if is_end[n]:
            if not np.all(np.isfinite(ell[n])):
                continue
            pts, _ = ellipse_points(ell[n], 48)
            cv2.polylines(out, [_fixed(pts)], True, colour, thickness, cv2.LINE_AA, _SHIFT)
        else:
            seg = projection.segments[n]
            if not np.all(np.isfinite(seg)):
                continue
            a, b = _fixed(seg)
            cv2.line(out, tuple(a.tolist()), tuple(b.tolist()), colour, thickness, cv2.LINE_AA,
                     _SHIFT)
    return out


def draw_detection(image: np.ndarray, camera: Camera, detection: FeatureDetection, *,
                   geometry: LogGeometry = LogGeometry(), thickness: int = 1,
                   dim: float = 0.6) -> np.ndarray:
    """:func:`draw_evidence` of a :func:`~unseeable.vision.detect_features` result, on its image.

    The detectors looked at the photograph at the calibrated scale
    (:func:`~unseeable.vision.scale.working_view`); the features are projected
    again with the photograph's own ``camera``, and the detectors' best-fitting
    ellipses scaled back to it.
    """
    ellipses = detection.scores.ellipses.copy()
    # Back from the working view's pixels (centres at whole coordinates, each axis scaled
    # by its size ratio; see Camera.scaled); semi-axes by the mean ratio, the angle stays.
    work = camera.scaled(working_scale(camera))
    ratio = np.array([work.width / camera.width, work.height / camera.height])
    ellipses[:, :2] = (ellipses[:, :2] + 0.5) / ratio - 0.5
    ellipses[:, 2:4] /= ratio.mean()
    projection = project_features(detection.scores.extent, detection.pose, camera,
                                  geometry=geometry)
    return draw_evidence(image, projection, detection.p, detection.judged, ellipses=ellipses,
                         thickness=thickness, dim=dim)


def draw_pose(image: np.ndarray, camera: Camera, extent: Extent, pose: GridPose, *,
              geometry: LogGeometry = LogGeometry(), dim: float = 0.6) -> np.ndarray:
    """The image (dimmed) with the fitted grid's silhouette lines (i lines red, k lines blue)
    and the grid origin's axes drawn on it."""
    out = (as_rgb_image(image).astype(np.float32) * dim).astype(np.uint8)
    lines, layer_axis = pose_lines(extent, pose, camera, geometry=geometry)
    uv = camera.project(lines)
    for seg, ax in zip(uv, layer_axis):
        if not np.all(np.isfinite(seg)):
            continue
        a, b = _fixed(seg)
        colour = (255, 80, 60) if ax == 0 else (70, 140, 255)
        cv2.line(out, tuple(a.tolist()), tuple(b.tolist()), colour, 1, cv2.LINE_AA, _SHIFT)
    origin = pose.grid_to_world(np.array([[0.0, 0.0, 0.0], [geometry.l1, 0, 0],
                                          [0, 0, geometry.l1]]))
    o = camera.project(origin)
    if np.all(np.isfinite(o)):
        p0, pi, pk = _fixed(o)
        cv2.arrowedLine(out, tuple(p0.tolist()), tuple(pi.tolist()), (255, 255, 0), 2,
                        cv2.LINE_AA, _SHIFT)
        cv2.arrowedLine(out, tuple(p0.tolist()), tuple(pk.tolist()), (0, 255, 255), 2,
                        cv2.LINE_AA, _SHIFT)
    return out
