"""The image scale the detectors were calibrated at, and resampling a photograph to it.

The detectors' filters, the pose search's sampling and the calibration's
score statistics are in pixels. The calibration's training scenes were
rendered at 1.35–2.37 mm per pixel (at the table, under the image centre;
median 1.70): 640×480 images from the workspace's arm. A photograph from
another camera, resolution or distance can be much finer (a 1024×768 view
from the same arm: ~1.0 mm/px) or coarser; measured on such renders, the
detectors at 0.7–0.9 mm/px were right on 72–85 % of visible features where
the same images resampled to 1.70 mm/px gave 88–93 % (docs/benchmarks.md).
So the detectors resample an image outside the calibrated range to its
median (:func:`working_view`); the pose search and polish only enlarge a
coarse image and keep a fine one (:func:`pose_view`: finer pixels place the
grid more precisely). Poses and probabilities do not depend on the image
scale, so nothing else changes for the caller.

Examples
--------
>>> from unseeable.camera import Camera
>>> cam = Camera.look_at(eye=[0, 600, -700], target=[0, 0, 0], width=1280, height=960,
...                      fov_deg=50)
>>> round(mm_per_pixel(cam), 2), round(working_scale(cam), 2)
(0.65, 0.38)
>>> image, small = working_view(np.zeros((960, 1280, 3), np.uint8), cam)
>>> image.shape, (small.width, small.height)
((367, 489, 3), (489, 367))
"""

from __future__ import annotations

import logging

import cv2
import numpy as np

from unseeable.camera import Camera
from unseeable.errors import InputError
from unseeable.vision.edges import EdgeMaps, edge_maps

__all__ = ["CALIBRATED_MM_PER_PX", "POSE_FINEST_MM_PER_PX", "mm_per_pixel", "working_scale",
           "working_view", "pose_view", "view_edge_maps", "camera_for", "table_point"]

logger = logging.getLogger(__name__)

#: Smallest, median and largest millimetres per pixel of the calibration's training
#: scenes (``unseeable.training.scenes``: TRAIN, TRAIN_WALLS, TRAIN_TALL; 40 of each).
CALIBRATED_MM_PER_PX = (1.35, 1.70, 2.37)

#: A coarse image is enlarged at most this much (interpolation adds no detail).
MAX_UPSAMPLE = 2.0
#: The pose search keeps a fine image as it is down to this many millimetres per pixel
#: and shrinks a finer one to it: an 11-megapixel photograph from the arm (0.29 mm/px)
#: took 7 s to pose at its own size, 3.4 s of it its edge maps; the finest cameras the
#: pose search was measured on give 0.6 mm/px (docs/benchmarks.md).
POSE_FINEST_MM_PER_PX = 0.5

#: Height (mm) of the table-parallel plane the scale is measured on: about a bottom
#: log's axis.
_SCALE_HEIGHT_MM = 20.0


def table_point(camera: Camera, uv: np.ndarray, height: float) -> np.ndarray:
    """World points on the horizontal plane ``y = height`` seen at pixels ``(N, 2)``.

    Rows whose ray does not meet the plane in front of the camera are NaN.
    """
    rays = camera.pixel_rays(uv)
    c = camera.centre
    with np.errstate(divide="ignore", invalid="ignore"):
        s = (height - c[1]) / rays[:, 1]
    pts = c + s[:, None] * rays
    pts[~(s > 0)] = np.nan
    return pts


def mm_per_pixel(camera: Camera) -> float:
    """Millimetres per pixel at the table point seen at the image centre (NaN: none seen)."""
    centre = table_point(camera, np.array([[camera.width / 2.0, camera.height / 2.0]]),
                         _SCALE_HEIGHT_MM)
    if not np.all(np.isfinite(centre)):
        return float("nan")
    return float(camera.depth(centre)[0]) / float(camera.K[0, 0])


def working_scale(camera: Camera, *, shrink: bool = True,
                  finest_mm: float | None = None) -> float:
    """The resize factor that brings the camera's image into the calibrated scale range.

    1 inside :data:`CALIBRATED_MM_PER_PX` (and when the camera does not see
    the table at its image centre); else the factor that gives the range's
    median, enlarging at most :data:`MAX_UPSAMPLE` times. With ``shrink=False``
    a finer image is kept as it is (the pose search and polish: finer pixels
    place the grid more precisely, see :func:`pose_view`), unless it is finer
    than ``finest_mm`` millimetres per pixel: then it is shrunk to that.
    """
    mm = mm_per_pixel(camera)
    lo, mid, hi = CALIBRATED_MM_PER_PX
    if not np.isfinite(mm) or lo <= mm <= hi:
        return 1.0
    if mm < lo and not shrink:
        return 1.0 if finest_mm is None or mm >= finest_mm else float(mm / finest_mm)
    return float(min(mm / mid, MAX_UPSAMPLE))


def working_view(image: np.ndarray, camera: Camera, *, shrink: bool = True,
                 finest_mm: float | None = None) -> tuple[np.ndarray, Camera]:
    """``image`` and ``camera`` resampled to the calibrated scale (unchanged when within it).

    What the detectors look at.

    Parameters
    ----------
    image : (H, W, C) array
        Matching ``camera``'s size.
    camera : Camera
    shrink : bool
        Also shrink an image finer than the range (else only enlarge a coarser one).
    finest_mm : float, optional
        With ``shrink=False``: still shrink an image finer than this (mm per pixel)
        to this scale.

    Returns
    -------
    image : (H', W', C) array
    camera : Camera
        The same camera for the resized image (:meth:`Camera.scaled`).

    Raises
    ------
    InputError
        When the image is not the camera's size.
    """
    height, width = np.shape(image)[:2]
    if (height, width) != (camera.height, camera.width):
        raise InputError(f"image is {width}x{height} but the camera expects "
                         f"{camera.width}x{camera.height}", field="image", value=[width, height])
    factor = working_scale(camera, shrink=shrink, finest_mm=finest_mm)
    if factor == 1.0:
        return image, camera
    scaled = camera.scaled(factor)
    interpolation = cv2.INTER_AREA if factor < 1.0 else cv2.INTER_LINEAR
    resized = cv2.resize(np.ascontiguousarray(image), (scaled.width, scaled.height),
                         interpolation=interpolation)
    logger.debug("image resampled %dx%d -> %dx%d (%.2f mm/px -> calibrated scale)",
                 camera.width, camera.height, scaled.width, scaled.height, mm_per_pixel(camera))
    return resized, scaled


def pose_view(image: np.ndarray, camera: Camera) -> tuple[np.ndarray, Camera]:
    """What the pose search and polish look at: a coarse image enlarged, a fine one kept
    (down to :data:`POSE_FINEST_MM_PER_PX`).

    The search's sampling and its alignment are in pixels too, but a finer
    image places the grid more precisely: on 60 renders by 1024x768 cameras
    (0.6-1.7 mm/px), poses found and polished at the camera's own scale were
    within 2 mm and 1° in 50, at the calibrated scale in 45 (docs/benchmarks.md).
    """
    return working_view(image, camera, shrink=False, finest_mm=POSE_FINEST_MM_PER_PX)


def view_edge_maps(image: np.ndarray, camera: Camera, *, pose: bool = False,
                   sigma: float = 1.0, maps: EdgeMaps | None = None) -> EdgeMaps:
    """Edge maps of what the detectors (``pose=True``: the pose search) look at.

    ``maps`` is returned as it is when it already has that view's size, so
    that one image's maps are computed once for several calls.
    """
    view, _ = pose_view(image, camera) if pose else working_view(image, camera)
    if maps is not None and maps.shape == view.shape[:2]:
        return maps
    return edge_maps(view, sigma=sigma)


def camera_for(shape: tuple[int, int], camera: Camera) -> Camera:
    """``camera``, or the same camera scaled, for an image (or edge maps) of ``shape`` (H, W).

    Edge maps computed on :func:`working_view`'s image go with the native camera
    this way.

    Raises
    ------
    InputError
        When ``shape`` is neither the camera's size nor its working view's.
    """
    height, width = int(shape[0]), int(shape[1])
    if (height, width) == (camera.height, camera.width):
        return camera
    for shrink in (True, False):
        scaled = camera.scaled(working_scale(
            camera, shrink=shrink, finest_mm=None if shrink else POSE_FINEST_MM_PER_PX))
        if (height, width) == (scaled.height, scaled.width):
            return scaled
    raise InputError(f"image is {width}x{height} but the camera expects "
                     f"{camera.width}x{camera.height}", field="image", value=[width, height])
