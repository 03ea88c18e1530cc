"""Which log each pixel shows: a z-buffer over the logs' CAD triangles.

The pictures of an estimate (:mod:`unseeable.render.pictures`) need, per pixel,
the log that covers it from the photograph's camera and how far away it is —
the id/depth pass of :func:`~unseeable.render.renderer.render_ground_truth`,
without the rest of a path tracer. Casting Mitsuba's rays for it meant loading
Mitsuba, choosing its variant and building a scene, about a second of every
``unseeable estimate`` (docs/benchmarks.md). This module draws the same
triangles (each log's mesh placed by :func:`~unseeable.render.cad.placed_logs`; the
renderer draws the same surfaces) into a depth buffer with numba,
sampling each pixel at its centre as the ray caster does; a camera with
distortion, skew or unequal focal lengths is drawn through the same plain
pinhole proxy and resampled, so the two agree but for pixels a triangle's edge
grazes (tests/render/test_zbuffer.py).

The ground truth of rendered views (feature visibility, the corpus's records)
still comes from the renderer itself: it is what the photographs show.

Examples
--------
>>> from unseeable.camera import Camera
>>> from unseeable.domain import Extent, GridPose, Log, Structure
>>> three = Structure(Extent(3, 1, 1), [Log(layer=0, at=(0, 0), notches=3)])
>>> camera = Camera.look_at(eye=[60, 250, -350], target=[64, 10, 0], width=80, height=60,
...                         fov_deg=45)
>>> ids, depth = rasterise_ids(three, GridPose(), camera)
>>> ids.shape, ids.dtype.name, sorted(set(ids.ravel().tolist()))
((60, 80), 'int32', [-1, 0])
>>> bool(np.isinf(depth[ids < 0]).all() and np.isfinite(depth[ids == 0]).all())
True
"""

from __future__ import annotations

import numba
import numpy as np

from unseeable.camera import Camera
from unseeable.domain import GridPose, LogGeometry, Structure

__all__ = ["rasterise_ids"]

#: Triangles with a corner nearer the camera than this (mm, along its axis) are not
#: drawn: no log stands at the lens.
_NEAR_MM = 1e-3


@numba.njit(cache=True, nogil=True)
def _zbuffer_kernel(xy: np.ndarray, z: np.ndarray, owner: np.ndarray, height: int,
                    width: int) -> tuple[np.ndarray, np.ndarray]:
    """Nearest triangle at every pixel centre (whole coordinates): its owner and depth.

    ``xy`` ``(T, 3, 2)`` projected corners, ``z`` ``(T, 3)`` their depths along the
    camera axis (all beyond :data:`_NEAR_MM`); the depth at a pixel is interpolated as
    ``1/z`` is, linearly in the image (perspective-correct)."""
    ids = np.full((height, width), -1, np.int32)
    depth = np.full((height, width), np.inf, np.float64)
    for t in range(xy.shape[0]):
        x0, y0 = xy[t, 0, 0], xy[t, 0, 1]
        x1, y1 = xy[t, 1, 0], xy[t, 1, 1]
        x2, y2 = xy[t, 2, 0], xy[t, 2, 1]
        area = (x1 - x0) * (y2 - y0) - (x2 - x0) * (y1 - y0)
        if abs(area) < 1e-12:
            continue
        lo_x = max(int(np.ceil(min(x0, x1, x2))), 0)
        hi_x = min(int(np.floor(max(x0, x1, x2))), width - 1)
        lo_y = max(int(np.ceil(min(y0, y1, y2))), 0)
        hi_y = min(int(np.floor(max(y0, y1, y2))), height - 1)
        if lo_x > hi_x or lo_y > hi_y:
            continue
        inv = 1.0 / area
        iz0, iz1, iz2 = 1.0 / z[t, 0], 1.0 / z[t, 1], 1.0 / z[t, 2]
        # A pixel on an edge two triangles share belongs to both: the nearer one wins.
        slack = -1e-9
        for py in range(lo_y, hi_y + 1):
            for px in range(lo_x, hi_x + 1):
                b0 = ((x1 - px) * (y2 - py) - (x2 - px) * (y1 - py)) * inv
                b1 = ((x2 - px) * (y0 - py) - (x0 - px) * (y2 - py)) * inv
                b2 = 1.0 - b0 - b1
                if b0 < slack or b1 < slack or b2 < slack:
                    continue
                d = 1.0 / (b0 * iz0 + b1 * iz1 + b2 * iz2)
                if d < depth[py, px]:
                    depth[py, px] = d
                    ids[py, px] = owner[t]
    return ids, depth


def rasterise_ids(structure: Structure, pose: GridPose, camera: Camera, *,
                  geometry: LogGeometry = LogGeometry(), segments: int | None = None
                  ) -> tuple[np.ndarray, np.ndarray]:
    """The log seen at each pixel and its depth, from the logs' CAD triangles.

    Parameters
    ----------
    structure : Structure
    pose : GridPose
        Where the assembly stands (world = table frame).
    camera : Camera
        Any camera; one with distortion, skew or unequal focal lengths is drawn
        through a plain pinhole and resampled (nearest pixel), as the renderer does.
    geometry : LogGeometry
    segments : int, optional
        Facets around a log (default the renderer's,
        :data:`~unseeable.render.cad.DEFAULT_SEGMENTS`).

    Returns
    -------
    ids : (H, W) int32
        Index into ``structure.logs`` of the log each pixel centre sees, -1 where none
        (the table and beyond are not drawn).
    depth : (H, W) float32
        Its depth along the camera's axis (mm); ``inf`` where no log is seen.
    """
    from unseeable.render.cad import DEFAULT_SEGMENTS, placed_logs
    from unseeable.render.renderer import check_scene_inputs, pinhole_proxy, truth_from_proxy

    check_scene_inputs(structure, pose, camera)
    proxy, maps = pinhole_proxy(camera)
    verts, faces, owner = placed_logs(
        structure, pose, geometry=geometry,
        segments=DEFAULT_SEGMENTS if segments is None else int(segments))
    cam_pts = verts[faces].reshape(-1, 3) @ proxy.R.T + proxy.t
    z = cam_pts[:, 2].reshape(-1, 3)
    keep = (z > _NEAR_MM).all(axis=1)
    with np.errstate(divide="ignore", invalid="ignore"):
        uvw = cam_pts @ proxy.K.T
        xy = (uvw[:, :2] / uvw[:, 2:3]).reshape(-1, 3, 2)
    ids, depth = _zbuffer_kernel(np.ascontiguousarray(xy[keep]), np.ascontiguousarray(z[keep]),
                                 np.ascontiguousarray(owner[keep]), proxy.height, proxy.width)
    return truth_from_proxy(ids, depth.astype(np.float32), maps)
