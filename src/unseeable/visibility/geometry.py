"""Where logs and features are, for ray casting (DESIGN.md §4, "Visibility").

Everything here is in the grid frame (mm): grid point ``(i, j, k)`` at
``(i*l1, y_j, k*l1)``. Logs are approximated by their bounding cylinders;
each feature is represented by a few sample points from which rays are cast
to the camera centre.
"""

from __future__ import annotations

import numpy as np

from unseeable.domain import (
    Extent,
    FeatureKind,
    LogGeometry,
    Structure,
    feature_axes,
    feature_index,
    lower_silhouette,
)
from unseeable.domain.grid import SPANS_NEXT
from unseeable.errors import InputError, check_whole_number

__all__ = [
    "log_cylinders",
    "log_id_grid",
    "feature_own_logs",
    "feature_sample_points",
    "end_normals",
    "END_DISC_FRACTION",
]

#: Outer radius of the end-disc sample rings as a fraction of the log radius:
#: the rim of a real log end is chamfered and its ellipse edge is where a
#: detector is least reliable, so the samples stay on the disc's face.
END_DISC_FRACTION = 0.8


def log_cylinders(structure: Structure, *, geometry: LogGeometry = LogGeometry()) -> np.ndarray:
    """Bounding-cylinder axes of the logs of ``structure``.

    Each log's cylinder has radius ``l2 / 2`` and runs the log's full length
    ``(m - 1)*l1 + 2*l3``: from ``l3`` before its first notch to ``l3`` past
    its last, along the layer's axis (i on even layers, k on odd ones), at the
    layer's axis height.

    Parameters
    ----------
    structure : Structure
    geometry : LogGeometry

    Returns
    -------
    (L, 2, 3) float
        Row ``l`` holds the two axis end points (grid frame, mm) of
        ``structure.logs[l]``; the log id is that row index.

    Examples
    --------
    >>> from unseeable.domain import Extent, Log
    >>> s = Structure(Extent(2, 1, 1), [Log(layer=0, at=(0, 0), notches=2)])
    >>> log_cylinders(s)[0].tolist()
    [[-22.0, 9.5, 0.0], [86.0, 9.5, 0.0]]
    """
    g = geometry
    logs = structure.logs
    if not logs:
        return np.zeros((0, 2, 3))
    layer = np.array([log.layer for log in logs])
    at = np.array([log.at for log in logs], dtype=float)  # (L, 2): (i, k) of notch 0
    notches = np.array([log.notches for log in logs])
    first = np.stack([at[:, 0] * g.l1, g.layer_height(layer), at[:, 1] * g.l1], axis=1)
    axis = np.zeros((len(logs), 3))
    axis[layer % 2 == 0, 0] = 1.0
    axis[layer % 2 == 1, 2] = 1.0
    start = first - g.l3 * axis
    stop = first + ((notches - 1) * g.l1 + g.l3)[:, None] * axis
    return np.stack([start, stop], axis=1)


def log_id_grid(structure: Structure) -> np.ndarray:
    """Which log occupies each grid position.

    Returns
    -------
    (I, J, K) int
        Index into ``structure.logs``, ``-1`` where the position is EMPTY.
    """
    ids = np.full(structure.extent.shape, -1, dtype=np.int64)
    for n, log in enumerate(structure.logs):
        for q in log.positions():
            ids[q] = n
    return ids


def feature_own_logs(structure: Structure) -> np.ndarray:
    """The logs a feature belongs to, which never occlude it.

    * a log end at ``q`` (``end-``/``end+``): the log occupying ``q``, if any
      (when that log continues past the end's place, the place is inside it and
      only what lies between it and the camera matters);
    * a ``u`` or ``v`` segment at ``(i, j, k)``: the log at layer ``j`` occupying
      ``q`` and the log at layer ``j - 2`` occupying ``(i, j - 2, k)``, whose top
      edge the segment is (each when present; every notch carries ``l3`` of log
      on both sides, so these logs cover the whole stretch);
    * a ``w`` segment: the same two logs, each only when it continues to
      ``n(q)`` (a log that stops at ``q`` merely ends beside the stretch and may
      well hide it).

    Parameters
    ----------
    structure : Structure

    Returns
    -------
    (N, 2) int
        Log ids (indices into ``structure.logs``), ``-1`` for none, in
        :func:`~unseeable.domain.feature_index` order.
    """
    extent = structure.extent
    I, J, K = extent.shape
    idx = feature_index(extent)
    ids = log_id_grid(structure)
    occ = structure.occupancy
    # Pad two layers below and two above so segment layers -2..J+1 index directly.
    ids_p = np.full((I, J + 4, K), -1, dtype=np.int64)
    ids_p[:, 2:J + 2] = ids
    span_p = np.zeros((I, J + 4, K), dtype=bool)
    span_p[:, 2:J + 2] = SPANS_NEXT[occ]
    i, j, k = idx.at[:, 0], idx.at[:, 1], idx.at[:, 2]
    kind = idx.kind
    own = np.full((len(idx), 2), -1, dtype=np.int64)
    is_end = kind <= FeatureKind.END_PLUS
    own[is_end, 0] = ids_p[i[is_end], j[is_end] + 2, k[is_end]]
    seg = ~is_end
    here = ids_p[i[seg], j[seg] + 2, k[seg]]
    below2 = ids_p[i[seg], j[seg], k[seg]]
    is_w = kind[seg] == FeatureKind.W
    here = np.where(is_w & ~span_p[i[seg], j[seg] + 2, k[seg]], -1, here)
    below2 = np.where(is_w & ~span_p[i[seg], j[seg], k[seg]], -1, below2)
    own[seg, 0] = here
    own[seg, 1] = below2
    return own


def end_normals(extent: Extent, *, geometry: LogGeometry = LogGeometry()) -> np.ndarray:
    """Outward unit normal of every feature's end disc (zeros for segments).

    Returns
    -------
    (N, 3) float
    """
    axes = feature_axes(extent, geometry)
    idx = feature_index(extent)
    normals = np.zeros((len(idx), 3))
    is_end = idx.kind <= FeatureKind.END_PLUS
    d = axes[is_end, 1] - axes[is_end, 0]
    normals[is_end] = d / np.linalg.norm(d, axis=1, keepdims=True)
    return normals


def _disc_pattern(n_end: int) -> np.ndarray:
    """``(n_end, 2)`` offsets in units of the log radius: centre, inner and outer ring."""
    if n_end == 1:
        return np.zeros((1, 2))
    n_inner = (n_end - 1) // 3
    n_outer = n_end - 1 - n_inner
    outer_angle = 2 * np.pi * np.arange(n_outer) / n_outer
    rings = [np.zeros((1, 2)),
             END_DISC_FRACTION * np.stack([np.cos(outer_angle), np.sin(outer_angle)], axis=1)]
    if n_inner:
        # Inner ring half-way out, turned by half a step so no ray lines up with an outer one.
        inner_angle = 2 * np.pi * (np.arange(n_inner) + 0.5) / n_inner
        rings.insert(1, END_DISC_FRACTION / 2
                     * np.stack([np.cos(inner_angle), np.sin(inner_angle)], axis=1))
    return np.concatenate(rings)


def feature_sample_points(
    extent: Extent,
    camera_centre_grid: np.ndarray,
    *,
    geometry: LogGeometry = LogGeometry(),
    n_end: int = 16,
    n_segment: int = 12,
) -> tuple[np.ndarray, np.ndarray]:
    """Sample points of every feature, from which rays go to the camera.

    * Log ends (``end-``, ``end+``): points on the end disc (the plane through
      the disc centre ``q ∓ l3`` normal to the log axis): the centre, a ring at
      ``0.4 r`` (a third of the remaining points) and a ring at ``0.8 r``
      (``r = l2 / 2``).
    * Segments: ``n_segment`` points at the centres of equal pieces of the
      stretch's *lower silhouette line* as seen from the camera
      (:func:`~unseeable.domain.lower_silhouette`), over ``u``:
      ``[q - l3, q - l2/2]``, ``v``: ``[q + l2/2, q + l3]`` (the slot
      ``|offset| < l2/2`` is filled by the crossing log), ``w``:
      ``[q + l3, n(q) - l3]``. Piece centres keep the points off the stretch
      ends, where neighbouring logs touch.

    Parameters
    ----------
    extent : Extent
    camera_centre_grid : (3,) float
        Camera centre in the grid frame (mm), e.g. ``pose.world_to_grid(camera.centre)``.
    geometry : LogGeometry
    n_end, n_segment : int
        Points per log end and per segment (at least 1).

    Returns
    -------
    points : (N, S, 3) float
        ``S = max(n_end, n_segment)``; rows in :func:`~unseeable.domain.feature_index`
        order; unused slots repeat the feature's first point.
    valid : (N, S) bool
        Which slots are samples. A ``w`` stretch of zero or negative length
        (``l1 <= 2*l3``) has none.

    Examples
    --------
    >>> pts, ok = feature_sample_points(Extent(1, 1, 1), np.array([0.0, 500.0, -800.0]))
    >>> pts.shape, int(ok.sum())  # 2 ends * 16 + 3 segments * 3 layers * 12
    ((11, 16, 3), 140)
    """
    for name, value in (("n_end", n_end), ("n_segment", n_segment)):
        check_whole_number(value, field=name, minimum=1)
    c = np.asarray(camera_centre_grid, dtype=float).reshape(-1)
    if c.shape != (3,) or not np.all(np.isfinite(c)):
        raise InputError("must be 3 finite coordinates", field="camera_centre",
                         value=np.asarray(camera_centre_grid).tolist())
    g = geometry
    r = g.radius
    idx = feature_index(extent)
    axes = feature_axes(extent, g)
    n = len(idx)
    S = max(n_end, n_segment)
    points = np.empty((n, S, 3))
    valid = np.zeros((n, S), dtype=bool)

    is_end = idx.kind <= FeatureKind.END_PLUS
    # -- ends: disc in the plane spanned by y and (axis x y) ---------------
    centre = axes[is_end, 0]
    normal = axes[is_end, 1] - centre
    normal /= np.linalg.norm(normal, axis=1, keepdims=True)
    up = np.array([0.0, 1.0, 0.0])
    side = np.cross(normal, up)
    pattern = _disc_pattern(n_end) * r  # (n_end, 2)
    disc = (centre[:, None, :] + pattern[None, :, 0, None] * up
            + pattern[None, :, 1, None] * side[:, None, :])
    points[is_end, :n_end] = disc
    points[is_end, n_end:] = disc[:, :1]
    valid[is_end, :n_end] = True

    # -- segments: the lower silhouette of the part outside the notch slot --
    seg = ~is_end
    start = axes[seg, 0].copy()
    stop = axes[seg, 1].copy()
    direction = stop - start
    length = np.linalg.norm(direction, axis=1, keepdims=True)
    direction /= np.where(length > 0, length, 1.0)
    kind = idx.kind[seg]
    stop[kind == FeatureKind.U] -= r * direction[kind == FeatureKind.U]
    start[kind == FeatureKind.V] += r * direction[kind == FeatureKind.V]
    # w's stretch runs the other way when l1 < 2*l3: no place for a segment.
    usable = np.sum((stop - start) * direction, axis=1) > 0
    lo, hi = lower_silhouette(start, stop, c, r)
    frac = (np.arange(n_segment) + 0.5) / n_segment
    line = lo[:, None, :] + frac[None, :, None] * (hi - lo)[:, None, :]
    points[seg, :n_segment] = line
    points[seg, n_segment:] = line[:, :1]
    seg_valid = np.zeros((int(seg.sum()), S), dtype=bool)
    seg_valid[:, :n_segment] = usable[:, None]
    valid[seg] = seg_valid
    return points, valid
