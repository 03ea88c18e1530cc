"""Pictures of an estimate: the photograph with the estimate drawn over it, and a
rendering of the estimated structure with each log in its own colour (green
right, red wrong against the truth; or green seen, orange inferred).

Both come from one fast id/depth pass of the renderer
(:func:`~unseeable.render.renderer.render_ground_truth`), so the drawing is
exact: every pixel shows the log that covers it from that camera.
"""

from __future__ import annotations

import numpy as np

from unseeable.camera import Camera
from unseeable.domain import GridPose, Structure
from unseeable.errors import InputError

__all__ = ["GREEN", "RED", "ORANGE", "PICTURE_MAX_SIDE", "shaded_rendering", "overlay_logs",
           "estimate_pictures", "crop_to"]

#: Longest side (pixels) the pictures of an estimate are drawn at (:func:`estimate_pictures`).
PICTURE_MAX_SIDE = 1600

GREEN = (40, 170, 60)
RED = (215, 40, 40)
ORANGE = (245, 150, 30)


def _shading(depth: np.ndarray, camera: Camera) -> np.ndarray:
    """Lambert-like shading ``(H, W)`` in [0.35, 1] from surface normals of a depth map."""
    h, w = depth.shape
    finite = np.isfinite(depth)
    d = np.where(finite, depth, 0.0)
    u, v = np.meshgrid(np.arange(w) + 0.5, np.arange(h) + 0.5)
    kinv = np.linalg.inv(camera.K)
    rays = np.stack([u, v, np.ones_like(u)], axis=-1) @ kinv.T
    pts = rays * d[..., None]
    du = np.gradient(pts, axis=1)
    dv = np.gradient(pts, axis=0)
    n = np.cross(du, dv)
    n /= np.linalg.norm(n, axis=-1, keepdims=True) + 1e-12
    view = -rays / np.linalg.norm(rays, axis=-1, keepdims=True)
    light = view + np.array([0.3, -0.5, 0.0])  # from above-left of the camera
    light /= np.linalg.norm(light, axis=-1, keepdims=True)
    lam = np.abs(np.sum(n * light, axis=-1))
    return np.where(finite, 0.35 + 0.65 * lam, 1.0)


def _boundaries(ids: np.ndarray) -> np.ndarray:
    edge = np.zeros(ids.shape, dtype=bool)
    edge[:, 1:] |= ids[:, 1:] != ids[:, :-1]
    edge[1:, :] |= ids[1:, :] != ids[:-1, :]
    return edge


def shaded_rendering(ids: np.ndarray, depth: np.ndarray, camera: Camera,
                     colours: np.ndarray, *, background=(238, 238, 238)) -> np.ndarray:
    """A flat-coloured, shaded rendering of logs.

    Parameters
    ----------
    ids : (H, W) int
        Log index per pixel (-1 background).
    depth : (H, W) float
        Camera z (mm), ``inf`` where nothing is hit.
    camera : Camera
    colours : (L, 3) uint8
        One colour per log.

    Returns
    -------
    (H, W, 3) uint8
    """
    colours = np.asarray(colours, dtype=float).reshape(-1, 3)
    if ids.max(initial=-1) >= len(colours):
        raise InputError("needs one colour per log", field="colours", value=len(colours))
    img = np.empty((*ids.shape, 3), dtype=float)
    img[:] = background
    on = ids >= 0
    img[on] = colours[ids[on]] * _shading(depth, camera)[on][:, None]
    img[_boundaries(ids) & on] *= 0.45
    return np.clip(img, 0, 255).astype(np.uint8)


def overlay_logs(image: np.ndarray, ids: np.ndarray, colours: np.ndarray, *,
                 alpha: float = 0.5) -> np.ndarray:
    """The photograph with each log's pixels tinted by its colour and outlined."""
    colours = np.asarray(colours, dtype=float).reshape(-1, 3)
    out = np.asarray(image, dtype=float).copy()
    on = ids >= 0
    out[on] = (1 - alpha) * out[on] + alpha * colours[ids[on]]
    edge = _boundaries(ids) & on
    out[edge] = colours[ids[edge]] * 0.6
    return np.clip(out, 0, 255).astype(np.uint8)


def estimate_pictures(image: np.ndarray, structure: Structure, pose: GridPose, camera: Camera,
                      *, correct: np.ndarray | None = None, seen: np.ndarray | None = None,
                      crop: bool = True, min_size: int = 480,
                      max_side: int = PICTURE_MAX_SIDE) -> dict[str, np.ndarray]:
    """The overlay and the rendering of an estimate.

    Parameters
    ----------
    image : (H, W, 3) uint8
        The photograph the estimate came from.
    structure, pose, camera
        The estimate and where it stands.
    correct : (L,) bool, optional
        Per log, right against the truth (green) or wrong (red).
    seen : (L,) bool, optional
        Without ``correct``: per log, with direct evidence (green) or inferred
        by the grammar (orange).
    crop, min_size
        Crop both to the assembly (:func:`crop_to`).
    max_side : int
        A photograph larger than this (its longer side, pixels) is drawn on
        shrunk to it first: the pictures are for people, and drawing them at a
        12-megapixel photograph's size took longer than the estimate.

    Returns
    -------
    dict
        ``"overlay"`` and ``"rendering"``, each ``(H, W, 3) uint8``.
    """
    import cv2

    from unseeable.render.renderer import render_ground_truth

    if max_side < 16:
        raise InputError("must be at least 16 pixels", field="max_side", value=max_side)
    if max(camera.width, camera.height) > max_side:
        camera = camera.scaled(max_side / max(camera.width, camera.height))
        image = cv2.resize(np.asarray(image), (camera.width, camera.height),
                           interpolation=cv2.INTER_AREA)

    n = len(structure.logs)
    if correct is not None:
        colours = np.where(np.asarray(correct, bool)[:, None], GREEN, RED)
    elif seen is not None:
        colours = np.where(np.asarray(seen, bool)[:, None], GREEN, ORANGE)
    else:
        colours = np.tile(GREEN, (n, 1))
    colours = np.asarray(colours, dtype=np.uint8).reshape(n, 3)
    if n == 0:
        blank = np.full((camera.height, camera.width, 3), 238, np.uint8)
        return {"overlay": np.asarray(image).copy(), "rendering": blank}
    ids, depth = render_ground_truth(structure, pose, camera)
    pics = {"overlay": overlay_logs(image, ids, colours),
            "rendering": shaded_rendering(ids, depth, camera, colours)}
    if crop:
        pics = {name: crop_to(pic, ids >= 0, min_size=min_size) for name, pic in pics.items()}
    return pics


def crop_to(image: np.ndarray, mask: np.ndarray, *, margin: float = 0.2,
            min_size: int = 480) -> np.ndarray:
    """Crop ``image`` to the bounding box of ``mask`` plus ``margin`` (a share of the
    box), enlarged (nearest neighbour, whole factors) until its longer side reaches
    ``min_size`` pixels; the whole image when the mask is empty."""
    rows = np.flatnonzero(mask.any(axis=1))
    cols = np.flatnonzero(mask.any(axis=0))
    if len(rows) == 0:
        return image
    h, w = mask.shape
    r0, r1, c0, c1 = rows[0], rows[-1] + 1, cols[0], cols[-1] + 1
    pad = int(margin * max(r1 - r0, c1 - c0))
    r0, r1 = max(0, r0 - pad), min(h, r1 + pad)
    c0, c1 = max(0, c0 - pad), min(w, c1 + pad)
    out = image[r0:r1, c0:c1]
    factor = max(1, int(min_size // max(out.shape[:2])))
    if factor > 1:
        out = np.repeat(np.repeat(out, factor, axis=0), factor, axis=1)
    return out
