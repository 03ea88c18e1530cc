"""Ground truth of a rendered view: feature presence and visibility.

Two kinds of feature visibility:

* :func:`feature_truth` asks the project's visibility model
  (:func:`unseeable.visibility.feature_visibility`), the definition every
  stage agrees on (DESIGN.md §4);
* :func:`rendered_visibility` reads visibility off a rendered id map: a
  feature is seen where its sample points land on pixels showing its own
  log. It checks the model against the renderer, and stands in for it when
  the model is not available.
"""

from __future__ import annotations

import logging

import numpy as np

from unseeable.camera import Camera
from unseeable.domain import (
    FeatureKind,
    GridPose,
    LogGeometry,
    Structure,
    feature_axes,
    feature_index,
    feature_values,
    lower_silhouette,
)

__all__ = [
    "feature_owners",
    "feature_samples",
    "rendered_visibility",
    "model_visibility",
    "feature_truth",
    "DEFAULT_THRESHOLD",
]

logger = logging.getLogger(__name__)

#: A feature is occluded when at least this share of its sample points is hidden.
DEFAULT_THRESHOLD = 0.6


def _log_at(structure: Structure) -> np.ndarray:
    """``(I, J, K) int`` index of the log at each grid position (-1: empty)."""
    owner = np.full(structure.extent.shape, -1, dtype=np.int64)
    for n, log in enumerate(structure.logs):
        for q in log.positions():
            owner[q] = n
    return owner


def feature_owners(structure: Structure) -> np.ndarray:
    """The logs each feature belongs to, ``(N, 2) int`` (-1: none), in feature order.

    A log end belongs to the log at its position. A segment of layer ``j``
    at ``q`` is the bottom edge of the log at ``q`` and the top edge of the
    log at ``b(b(q))`` two layers below: column 0 holds the former, column 1
    the latter.
    """
    e = structure.extent
    idx = feature_index(e)
    owner = _log_at(structure)
    at = idx.at
    i, j, k = at[:, 0], at[:, 1], at[:, 2]
    out = np.full((len(idx), 2), -1, dtype=np.int64)
    here = j < e.J
    out[here, 0] = owner[i[here], j[here], k[here]]
    seg = idx.kind >= FeatureKind.U
    below = seg & (j >= 2) & (j - 2 < e.J)
    out[below, 1] = owner[i[below], j[below] - 2, k[below]]
    return out


def feature_samples(structure: Structure, pose: GridPose, camera_centre: np.ndarray, *,
                    geometry: LogGeometry = LogGeometry(), samples: int = 9
                    ) -> tuple[np.ndarray, np.ndarray]:
    """World points at which each feature shows in an image, ``(N, S, 3)``.

    Log ends: the disc's centre and a ring at 0.55 of the radius. Segments:
    points along the lower silhouette line as seen from ``camera_centre``
    (u and v only outside the notch slot, ``|offset| >= l2/2``), moved a
    quarter radius into the owning log so that they project inside its image.
    When only the log two layers below is there, the edge is that log's top:
    its upper silhouette line is sampled instead.

    Returns
    -------
    points : (N, S, 3) float
    facing : (N,) bool
        False for log ends whose disc faces away from the camera.
    """
    g = geometry
    e = structure.extent
    idx = feature_index(e)
    owners = feature_owners(structure)
    axes = pose.grid_to_world(feature_axes(e, g))  # (N, 2, 3)
    c = np.asarray(camera_centre, dtype=float).reshape(3)
    n_feat = len(idx)
    pts = np.zeros((n_feat, samples, 3))
    facing = np.ones(n_feat, dtype=bool)

    ends = idx.kind <= FeatureKind.END_PLUS
    centre = axes[ends, 0]
    normal = axes[ends, 1] - axes[ends, 0]
    normal /= np.linalg.norm(normal, axis=1, keepdims=True)
    facing[ends] = np.sum(normal * (c - centre), axis=1) > 0
    e1 = np.broadcast_to([0.0, 1.0, 0.0], centre.shape)
    e2 = np.cross(normal, e1)
    phi = np.linspace(0.0, 2 * np.pi, samples - 1, endpoint=False)
    ring = 0.55 * g.radius * (np.cos(phi)[None, :, None] * e1[:, None, :]
                              + np.sin(phi)[None, :, None] * e2[:, None, :])
    pts[ends, 0] = centre
    pts[ends, 1:] = centre[:, None, :] + ring

    seg = ~ends
    a, b = axes[seg, 0].copy(), axes[seg, 1].copy()
    kind = idx.kind[seg]
    direction = (b - a) / np.linalg.norm(b - a, axis=1, keepdims=True)
    half = g.l2 / 2
    # u = [q - l3, q]: keep [q - l3, q - l2/2]; v = [q, q + l3]: keep [q + l2/2, q + l3].
    b[kind == FeatureKind.U] -= half * direction[kind == FeatureKind.U]
    a[kind == FeatureKind.V] += half * direction[kind == FeatureKind.V]
    # With no log at q the edge is the top of the log two layers below (axis l2 lower):
    # sample that log's upper silhouette, the lower silhouette seen from the camera
    # mirrored in the log's axis height.
    lower_only = (owners[seg, 0] < 0) & (owners[seg, 1] >= 0)
    a[lower_only, 1] -= g.l2
    b[lower_only, 1] -= g.l2
    eye = np.broadcast_to(c, a.shape).copy()
    eye[lower_only, 1] = 2 * a[lower_only, 1] - c[1]
    sa, sb = _silhouettes(a, b, eye, g.radius)
    sa[lower_only, 1] = 2 * a[lower_only, 1] - sa[lower_only, 1]
    sb[lower_only, 1] = 2 * b[lower_only, 1] - sb[lower_only, 1]
    t = np.linspace(0.1, 0.9, samples)[None, :, None]
    line = sa[:, None, :] + t * (sb - sa)[:, None, :]
    axis_pts = a[:, None, :] + t * (b - a)[:, None, :]
    pts[seg] = line + 0.25 * (axis_pts - line)
    return pts, facing


def _silhouettes(a: np.ndarray, b: np.ndarray, eyes: np.ndarray, radius: float
                 ) -> tuple[np.ndarray, np.ndarray]:
    """:func:`lower_silhouette` with one viewpoint per stretch."""
    sa, sb = np.empty_like(a), np.empty_like(b)
    for eye in np.unique(eyes, axis=0):  # at most two distinct viewpoints
        rows = np.all(eyes == eye, axis=1)
        sa[rows], sb[rows] = lower_silhouette(a[rows], b[rows], eye, radius)
    return sa, sb


def rendered_visibility(structure: Structure, pose: GridPose, camera: Camera, ids: np.ndarray,
                        *, geometry: LogGeometry = LogGeometry(),
                        threshold: float = DEFAULT_THRESHOLD, samples: int = 9
                        ) -> tuple[np.ndarray, np.ndarray]:
    """Feature visibility read off a rendered id map.

    Parameters
    ----------
    structure : Structure
        The logs in the image; ``ids`` index into ``structure.logs``.
    pose : GridPose
    camera : Camera
    ids : (H, W) int
        Log seen at each pixel (-1: none), e.g. from :func:`render_view`.
    threshold : float
        A feature is occluded when at least this share of its points is hidden.
    samples : int
        Sample points per feature.

    Returns
    -------
    visible : (N,) bool
        Present, facing the camera and seen at more than ``1 - threshold`` of
        its points.
    seen : (N,) float
        Share of each feature's points that land on its own log.
    """
    ids = np.asarray(ids)
    pts, facing = feature_samples(structure, pose, camera.centre, geometry=geometry,
                                  samples=samples)
    owners = feature_owners(structure)
    uv = camera.project(pts)  # (N, S, 2)
    finite = np.all(np.isfinite(uv), axis=2)
    px = np.rint(np.where(finite[..., None], uv, -1)).astype(np.int64)
    inside = finite & (px[..., 0] >= 0) & (px[..., 0] < camera.width) \
        & (px[..., 1] >= 0) & (px[..., 1] < camera.height)
    seen_id = np.full(inside.shape, -2, dtype=np.int64)
    seen_id[inside] = ids[px[inside][:, 1], px[inside][:, 0]]
    hit = inside & (owners[:, None, :] >= 0).any(axis=2) & (
        (seen_id == owners[:, None, 0]) | (seen_id == owners[:, None, 1]))
    seen = hit.mean(axis=1)
    present = feature_values(structure.extent, structure.occupancy)
    visible = present & facing & (seen > 1.0 - threshold)
    return visible, seen


def model_visibility(structure: Structure, camera_centre: np.ndarray, pose: GridPose, *,
                     geometry: LogGeometry = LogGeometry(),
                     threshold: float = DEFAULT_THRESHOLD) -> np.ndarray | None:
    """:func:`unseeable.visibility.feature_visibility`, or None when that is not available."""
    try:
        from unseeable.visibility import feature_visibility
    except ImportError:
        return None
    vis = feature_visibility(structure, np.asarray(camera_centre, dtype=float), pose,
                             geometry=geometry, threshold=threshold)
    return np.asarray(vis, dtype=bool)


def feature_truth(structure: Structure, pose: GridPose, camera: Camera, ids: np.ndarray | None,
                  *, geometry: LogGeometry = LogGeometry(),
                  threshold: float = DEFAULT_THRESHOLD) -> tuple[np.ndarray, np.ndarray, str]:
    """Presence and visibility of every feature of a view of ``structure``.

    Visibility comes from the visibility model when it is installed, else
    from the id map (:func:`rendered_visibility`).

    Returns
    -------
    present : (N,) bool
    visible : (N,) bool
    source : {"model", "id_map"}
    """
    present = feature_values(structure.extent, structure.occupancy)
    vis = model_visibility(structure, camera.centre, pose, geometry=geometry, threshold=threshold)
    if vis is not None:
        return present, vis, "model"
    if ids is None:
        raise ValueError("no visibility model installed and no id map given")
    logger.warning("unseeable.visibility.feature_visibility is not available; "
                   "reading visibility off the rendered id map")
    vis, _ = rendered_visibility(structure, pose, camera, ids, geometry=geometry,
                                 threshold=threshold)
    return present, vis, "id_map"
