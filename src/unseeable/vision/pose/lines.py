"""Where a pose puts the grid's features in the image.

The axis stretches of every log position of an extent (:func:`axis_stretches`),
their silhouette lines seen from the camera (:func:`grid_lines`,
:func:`upper_lines`), samples along lines (:func:`sample_lines`), the rims of
the end discs facing the camera (:func:`disc_rims`, :func:`end_rims`), the
extent's box in the image (:func:`box_mask`), and the pose of a footprint's
centre (:func:`centre_grid`, :func:`pose_from_centre`, :func:`shifted_pose`).
"""

from __future__ import annotations

import functools

import numpy as np

from unseeable.camera import Camera
from unseeable.domain import (
    Extent,
    FeatureKind,
    GridPose,
    LogGeometry,
    feature_axes,
    feature_index,
    lower_silhouette,
)
from unseeable.vision.edges import fill_convex_hull
from unseeable.vision.projection import upper_silhouette

__all__ = [
    "axis_stretches",
    "grid_lines",
    "upper_lines",
    "pose_lines",
    "sample_lines",
    "centre_grid",
    "pose_from_centre",
    "shifted_pose",
    "disc_rims",
    "end_rims",
    "box_mask",
]


def axis_stretches(i: np.ndarray, j: np.ndarray, k: np.ndarray, geometry: LogGeometry,
                   trim_w: float = 0.0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Grid-frame axis stretches of the u, v, w segments at positions ``(i, j, k)`` (each (P,)).

    Returns ``(start (3P, 3), stop (3P, 3), kind (3P,))`` with kind 0/1/2 for u/v/w; u and v
    keep only the part outside the notch slot.
    """
    g = geometry
    centre = np.stack([i * g.l1, g.layer_height(j), k * g.l1], axis=1).astype(float)
    axis = np.zeros_like(centre)
    even = j % 2 == 0
    axis[even, 0] = 1.0
    axis[~even, 2] = 1.0
    lo = np.array([-g.l3, g.radius, g.l3 + trim_w])
    hi = np.array([-g.radius, g.l3, g.l1 - g.l3 - trim_w])
    start = centre[:, None, :] + lo[None, :, None] * axis[:, None, :]
    stop = centre[:, None, :] + hi[None, :, None] * axis[:, None, :]
    kind = np.broadcast_to(np.arange(3), (len(i), 3))
    return start.reshape(-1, 3), stop.reshape(-1, 3), kind.reshape(-1)


def grid_lines(extent: Extent, pose: GridPose, camera: Camera, *,
               geometry: LogGeometry = LogGeometry(),
               ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Silhouette lines of every log any assembly on the grid could have.

    For every grid position of layers ``0..J-1`` and each of its ``u``,
    ``v``, ``w`` stretches (``w`` past the last notch position left out;
    ``u`` and ``v`` only outside the notch slot, as the detectors do), the
    lower and the upper silhouette seen from the camera: together every
    horizontal edge a log of the grid can make.

    Parameters
    ----------
    extent : Extent
    pose : GridPose
    camera : Camera
    geometry : LogGeometry

    Returns
    -------
    lines : (L, 2, 3) float
        World end points: all lower silhouettes, then the upper ones of the
        same stretches in the same order.
    layer_axis : (L,) int
        0 for lines along grid i (even layers), 1 along grid k.
    upper : (L,) bool
        Upper silhouettes (False: lower silhouettes).
    """
    wa, wb, axis = _world_stretches(extent, pose, geometry)
    la, lb = lower_silhouette(wa, wb, camera.centre, geometry.radius)
    ua, ub = upper_silhouette(wa, wb, camera.centre, geometry.radius)
    lines = np.concatenate([np.stack([la, lb], 1), np.stack([ua, ub], 1)])
    upper = np.repeat([False, True], len(wa))
    return lines, np.tile(axis, 2), upper


def upper_lines(extent: Extent, pose: GridPose, camera: Camera, geometry: LogGeometry
                 ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The upper silhouettes of :func:`grid_lines` ``(L, 2, 3)``, their layer axes ``(L,)``
    and the world midpoints of their logs' axis stretches ``(L, 3)`` (a point inside each
    log, for telling its outside)."""
    wa, wb, axis = _world_stretches(extent, pose, geometry)
    ua, ub = upper_silhouette(wa, wb, camera.centre, geometry.radius)
    return np.stack([ua, ub], 1), axis, (wa + wb) / 2.0


def _world_stretches(extent: Extent, pose: GridPose, geometry: LogGeometry
                     ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The axis stretches of :func:`_grid_stretches` in the world at ``pose`` (start,
    stop ``(L, 3)``) and their layer axes ``(L,)`` (0 along grid i, 1 along grid k)."""
    start, stop, along_k = _grid_stretches(extent, geometry)
    return pose.grid_to_world(start), pose.grid_to_world(stop), along_k.astype(int)


@functools.lru_cache(maxsize=64)
def _grid_stretches(extent: Extent, geometry: LogGeometry
                    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Grid-frame axis stretches of :func:`grid_lines` (start, stop ``(L, 3)``, and
    whether each runs along grid k ``(L,)``): the same for every pose, so made once per
    extent (read-only)."""
    I, J, K = extent.shape
    ii, jj, kk = (a.ravel() for a in np.meshgrid(np.arange(I), np.arange(J), np.arange(K),
                                                  indexing="ij"))
    start, stop, kind = axis_stretches(ii, jj, kk, geometry)
    pi, pj, pk = (np.repeat(a, 3) for a in (ii, jj, kk))
    even = pj % 2 == 0
    last = np.where(even, pi == I - 1, pk == K - 1)
    keep = ~((kind == 2) & last)
    out = (start[keep], stop[keep], ~even[keep])
    for a in out:
        a.setflags(write=False)
    return out


def pose_lines(extent: Extent, pose: GridPose, camera: Camera, *,
               geometry: LogGeometry = LogGeometry()) -> tuple[np.ndarray, np.ndarray]:
    """World end points ``(L, 2, 3)`` and layer axes ``(L,)`` of the extent's silhouette lines.

    See :func:`grid_lines`.
    """
    lines, axis, _ = grid_lines(extent, pose, camera, geometry=geometry)
    return lines, axis


def sample_lines(lines: np.ndarray, camera: Camera, spacing_px: float,
                 max_per_line: int = 64) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Points along world lines, about ``spacing_px`` apart in the image.

    Returns
    -------
    points : (M, 3), tangent : (M, 3) unit world directions, line : (M,) int index
    """
    uv = camera.project(lines)
    length = np.linalg.norm(uv[:, 1] - uv[:, 0], axis=1)
    length = np.nan_to_num(length, nan=0.0)
    counts = np.clip(np.ceil(length / spacing_px).astype(int), 1, max_per_line)
    line_id = np.repeat(np.arange(len(lines)), counts)
    starts = np.concatenate([[0], np.cumsum(counts)[:-1]])
    pos = np.arange(len(line_id)) - np.repeat(starts, counts)
    frac = (pos + 0.5) / np.repeat(counts, counts)
    a = lines[line_id, 0]
    b = lines[line_id, 1]
    pts = a + frac[:, None] * (b - a)
    d = b - a
    tangent = d / np.maximum(np.linalg.norm(d, axis=1, keepdims=True), 1e-12)
    return pts, tangent, line_id


def centre_grid(extent: Extent, geometry: LogGeometry) -> np.ndarray:
    """Grid-frame centre ``(3,)`` of the extent's footprint, at the table."""
    return np.array([(extent.I - 1) * geometry.l1 / 2, 0.0, (extent.K - 1) * geometry.l1 / 2])


def pose_from_centre(centre_xz: np.ndarray, yaw_deg: float, extent: Extent,
                     geometry: LogGeometry) -> GridPose:
    """The pose at ``yaw_deg`` whose footprint centre (:func:`centre_grid`) lies at world
    ``centre_xz`` ``(2,)``."""
    rot = GridPose(0.0, 0.0, yaw_deg).rotation
    origin = np.array([centre_xz[0], 0.0, centre_xz[1]]) - rot @ centre_grid(extent, geometry)
    return GridPose(float(origin[0]), float(origin[2]), float(yaw_deg))


def shifted_pose(pose: GridPose, dx_mm: float, dz_mm: float) -> GridPose:
    """``pose`` moved by ``(dx_mm, dz_mm)`` along its own grid axes."""
    shift = pose.rotation @ np.array([dx_mm, 0.0, dz_mm])
    return GridPose(pose.x + float(shift[0]), pose.z + float(shift[2]), pose.yaw_deg)


def disc_rims(centre: np.ndarray, normal: np.ndarray, pose: GridPose, camera: Camera,
              geometry: LogGeometry, points: int = 16
               ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Rims of the end discs ``(D, 3)`` (grid frame, outward ``normal``) facing the camera.

    Returns
    -------
    rim : (E*R, 3) points, tangent : (E*R, 3) unit rim directions,
    centre : (E*R, 3) the disc centre of each point, group : (E*R,) index among the
    facing discs, facing : (E,) indices of those discs in the input
    """
    cw = pose.grid_to_world(centre)
    facing = np.flatnonzero(
        np.sum((camera.centre - cw) * pose.directions_to_world(normal), axis=1) > 0)
    centre, normal = centre[facing], normal[facing]
    t = np.linspace(0.0, 2 * np.pi, points, endpoint=False)
    e1 = np.array([0.0, 1.0, 0.0])
    along_k = np.abs(normal[:, 2]) > 0.5
    e2 = np.where(along_k[:, None], np.array([1.0, 0.0, 0.0]), np.array([0.0, 0.0, 1.0]))
    cos_t, sin_t = np.cos(t)[None, :, None], np.sin(t)[None, :, None]
    rim = centre[:, None, :] + geometry.radius * (cos_t * e1 + sin_t * e2[:, None, :])
    tangent = -sin_t * e1 + cos_t * e2[:, None, :]
    group = np.repeat(np.arange(len(centre)), points)
    return (rim.reshape(-1, 3), tangent.reshape(-1, 3), np.repeat(centre, points, axis=0),
            group, facing)


def end_rims(extent: Extent, pose: GridPose, camera: Camera, geometry: LogGeometry,
             points: int = 16) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Rims of the extent's end discs facing the camera, in the grid frame.

    Returns
    -------
    rim, tangent, centre, group : as :func:`disc_rims`
    """
    centre, normal = _end_discs(extent, geometry)
    rim, tangent, centre, group, _ = disc_rims(centre, normal, pose, camera, geometry, points)
    return rim, tangent, centre, group


@functools.lru_cache(maxsize=64)
def _end_discs(extent: Extent, geometry: LogGeometry) -> tuple[np.ndarray, np.ndarray]:
    """Grid-frame centres and outward normals ``(E, 3)`` of every end feature's disc: the
    same for every pose, so made once per extent (read-only)."""
    idx = feature_index(extent)
    axes = feature_axes(extent, geometry)
    ends = np.flatnonzero(idx.kind <= FeatureKind.END_PLUS)
    out = (axes[ends, 0], axes[ends, 1] - axes[ends, 0])
    for a in out:
        a.setflags(write=False)
    return out


def _prism_corners(extent: Extent, geometry: LogGeometry) -> np.ndarray:
    """Grid-frame corners ``(8, 3)`` of the box every log of the extent lies in."""
    g = geometry
    I, J, K = extent.shape
    xs = (-g.l3, (I - 1) * g.l1 + g.l3)
    zs = (-g.l3, (K - 1) * g.l1 + g.l3)
    ys = (0.0, float(g.layer_height(J - 1)) + g.radius)
    return np.array([[x, y, z] for x in xs for y in ys for z in zs])


def box_mask(extent: Extent, pose: GridPose, camera: Camera, shape: tuple[int, int],
             geometry: LogGeometry) -> np.ndarray | None:
    """``(H, W) uint8``: the image of the box every log of ``extent`` at ``pose`` lies in
    (None when part of the box is behind the camera)."""
    uv = camera.project(pose.grid_to_world(_prism_corners(extent, geometry)))
    if not np.all(np.isfinite(uv)):
        return None
    mask = np.zeros(shape, np.uint8)
    fill_convex_hull(mask, uv)
    return mask
