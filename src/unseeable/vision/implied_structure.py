"""What the detections at a pose imply: the MAP structure, its gain, its silhouette.

The pose choice (:func:`~unseeable.vision.select_pose`) values each candidate
pose by the structure the detections there imply: the MAP structure of the
features the detectors judge (:func:`implied_structure`), its log-probability
gain per judged feature over "no information" (:func:`structure_gain`,
:func:`detection_gain`), and how well its silhouette at the pose covers the
image's wood (:func:`structure_silhouette`, :func:`silhouette_overlap`).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import cv2
import numpy as np

from unseeable.camera import Camera
from unseeable.domain import Evidence, Extent, GridPose, LogGeometry, Structure
from unseeable.errors import InputError
from unseeable.vision.calibration import Calibration
from unseeable.vision.edges import (
    EdgeMaps,
    fill_convex_hull,
    image_window,
    mask_box,
    woodness_map,
)
from unseeable.vision.evidence import FeatureDetection, detect_features
from unseeable.vision.pose.lines import box_mask

if TYPE_CHECKING:  # the solver is imported only when a choice is to be made
    from unseeable.solve import StructureSolver

__all__ = [
    "CHOICE_WORK_LIMIT",
    "detections_at",
    "implied_structure",
    "structure_gain",
    "detection_gain",
    "structure_silhouette",
    "wood_near",
    "silhouette_overlap",
]

#: Deterministic work (CP-SAT's deterministic time, about seconds) for each candidate's MAP
#: solve in :func:`~unseeable.vision.select_pose`. Under a wrong alias of a large extent
#: the detections contradict the grammar and the exact solve takes 10-40 s (the lodge); a
#: solve cut short under-states that candidate's gain, which counts further against a
#: wrong candidate. Against a limit of 2.0, 0.2 chose the same pose on all 160 corpus
#: images and 420 validation and family renders, and took the choice's mean from 0.96 s
#: to 0.62 s and its slowest from 22 s to 6 s on the corpus; there, 50 of 52 solves cut
#: short were wrong candidates', and the right candidate's solve was cut short only on
#: the two lodges seen from 210°, chosen all the same (docs/results.md). 0.1 makes the
#: same choice as 0.2 on the 160 corpus images and 360 validation and family renders
#: (rightness and ambiguity alike), the choice's mean 0.38 -> 0.35 s on two threads.
CHOICE_WORK_LIMIT = 0.1


def detections_at(image: np.ndarray, camera: Camera, extent: Extent, pose: GridPose, *,
                  calibration: Calibration | None, geometry: LogGeometry,
                  maps: EdgeMaps | None, detections: dict | None) -> FeatureDetection:
    """The detections at a candidate pose (unpolished: the search aligned it), kept in
    ``detections`` when given."""
    det = detect_features(image, camera, pose, extent, calibration=calibration,
                          refine=False, geometry=geometry, maps=maps)
    if detections is not None:
        detections[pose] = det
    return det


def implied_structure(det: FeatureDetection, extent: Extent, *, time_limit: float,
                      solver: StructureSolver | None, work_limit: float | None = None
                  ) -> tuple[float, Structure | None]:
    """The MAP structure of the features ``det`` judged (the others at ½), and its
    log-probability gain per judged feature over all-½ (:func:`structure_gain`)."""
    judged = int(det.judged.sum())
    evidence = Evidence(extent, np.where(det.judged, det.p, 0.5))
    if solver is None:
        from unseeable.solve import StructureSolver

        solver = StructureSolver(extent)
    result = solver.solve(evidence, time_limit=time_limit, work_limit=work_limit)
    if result.structure is None:
        return -np.inf, None
    if judged == 0:
        return 0.0, result.structure
    return float((result.log_probability - judged * np.log(0.5)) / judged), result.structure


def structure_silhouette(structure: Structure, pose: GridPose, camera: Camera,
                         shape: tuple[int, int] | None = None, *,
                         geometry: LogGeometry = LogGeometry()) -> np.ndarray:
    """Where ``structure``'s logs, placed at ``pose``, cover the image.

    Each log is drawn as the convex hull of its bounding cylinder's two end
    circles (:func:`~unseeable.visibility.log_cylinders`), 16 points each.

    Parameters
    ----------
    structure : Structure
    pose : GridPose
    camera : Camera
    shape : (int, int), optional
        ``(H, W)`` of the mask; default the camera's image size.
    geometry : LogGeometry

    Returns
    -------
    (H, W) bool

    Examples
    --------
    >>> from unseeable.domain import Extent, Log
    >>> cam = Camera.look_at(eye=[0, 500, -800], target=[0, 0, 0], width=64, height=48,
    ...                      fov_deg=50)
    >>> s = Structure(Extent(2, 1, 1), [Log(layer=0, at=(0, 0), notches=2)])
    >>> mask = structure_silhouette(s, GridPose(0.0, 0.0, 0.0), cam)
    >>> mask.shape, bool(mask.any()), bool(mask.all())
    ((48, 64), True, False)
    """
    from unseeable.visibility import log_cylinders

    if not isinstance(structure, Structure):
        raise InputError("must be a Structure", field="structure",
                         value=type(structure).__name__)
    if not isinstance(pose, GridPose):
        raise InputError("must be a GridPose", field="pose", value=pose)
    if not isinstance(camera, Camera):
        raise InputError("must be a Camera", field="camera", value=type(camera).__name__)
    if shape is None:
        shape = (camera.height, camera.width)
    if (not isinstance(shape, (tuple, list)) or len(shape) != 2
            or not all(isinstance(n, (int, np.integer)) and n > 0 for n in shape)):
        raise InputError("must be two positive whole numbers (H, W)", field="shape",
                         value=shape)
    mask = np.zeros(tuple(int(n) for n in shape), np.uint8)
    axes = log_cylinders(structure, geometry=geometry)
    if not len(axes):
        return mask.astype(bool)
    t = np.linspace(0.0, 2.0 * np.pi, 16, endpoint=False)
    direction = axes[:, 1] - axes[:, 0]
    direction /= np.linalg.norm(direction, axis=1, keepdims=True)
    up = np.array([0.0, 1.0, 0.0])  # logs are horizontal: up is across every one of them
    side = np.cross(direction, up)
    ring = geometry.radius * (np.cos(t)[None, :, None] * up
                              + np.sin(t)[None, :, None] * side[:, None, :])  # (L, 16, 3)
    pts = np.concatenate([axes[:, :1] + ring, axes[:, 1:] + ring], axis=1)  # (L, 32, 3)
    uv = camera.project(pose.grid_to_world(pts.reshape(-1, 3))).reshape(len(axes), -1, 2)
    for log_uv in uv:
        if np.all(np.isfinite(log_uv)):  # a log behind the camera is not drawn
            fill_convex_hull(mask, log_uv)
    return mask.astype(bool)


def wood_near(rgb: np.ndarray, camera: Camera, extent: Extent, poses, geometry: LogGeometry,
              *, band_px: int = 40) -> tuple[np.ndarray, np.ndarray]:
    """The wood-coloured pixels and the region the silhouettes are compared in.

    The region is the union of the extent's boxes at ``poses``, grown by
    ``band_px``; the wood colour model learns the assembly inside the boxes
    and the background outside them (:func:`~unseeable.vision.edges.woodness_map`).
    """
    boxes = np.zeros(rgb.shape[:2], np.uint8)
    for pose in poses:
        box = box_mask(extent, pose, camera, rgb.shape[:2], geometry)
        if box is not None:
            boxes |= box
    region = cv2.dilate(boxes, np.ones((2 * band_px + 1,) * 2, np.uint8)) > 0
    # The wood is compared only inside the region: its colours are scored there only.
    corners = mask_box(region)
    window = image_window(corners, region.shape) if len(corners) else None
    wood = woodness_map(rgb, boxes > 0, window=window) > 0.5
    return wood & region, region


def silhouette_overlap(wood: np.ndarray, region: np.ndarray, structure: Structure,
                       pose: GridPose, camera: Camera, geometry: LogGeometry) -> float:
    """Intersection over union of the structure's silhouette and the wood, in ``region``."""
    sil = structure_silhouette(structure, pose, camera, wood.shape, geometry=geometry) & region
    union = int(np.count_nonzero(wood | sil))
    return float(np.count_nonzero(wood & sil) / union) if union else 0.0


def structure_gain(image: np.ndarray, camera: Camera, extent: Extent, pose: GridPose, *,
                   calibration: Calibration | None = None,
                   geometry: LogGeometry = LogGeometry(), time_limit: float = 5.0,
                   solver: StructureSolver | None = None) -> float:
    """Log-probability gain per judged feature of the best valid structure at ``pose``.

    Every feature the detectors judge at ``pose`` gets its prior ``p_f``, the
    others ½; the MAP structure's log-probability minus that of the
    all-½ evidence, divided by the number judged. Near 0 when the detections
    are uninformative, up to ``log 2`` when a valid structure explains every
    one of them with certainty.

    Parameters
    ----------
    image : (H, W, 3) uint8
    camera : Camera
    extent : Extent
    pose : GridPose
    calibration : Calibration, optional
    geometry : LogGeometry
    time_limit : float
        Seconds for the MAP solve (its best structure so far is used on a timeout).
    solver : StructureSolver, optional
        A solver for ``extent`` to reuse (its model is built once for many calls).

    Returns
    -------
    float
    """
    det = detections_at(image, camera, extent, pose, calibration=calibration,
                        geometry=geometry, maps=None, detections=None)
    gain, _ = implied_structure(det, extent, time_limit=time_limit, solver=solver)
    return gain


def detection_gain(detection: FeatureDetection, *, time_limit: float = 5.0,
                   solver: StructureSolver | None = None) -> float:
    """:func:`structure_gain` of detections already made, as the pose choice values them.

    The MAP solve is cut short as the choice's (:data:`CHOICE_WORK_LIMIT`), so two
    poses' gains compare as two candidates' do in :func:`~unseeable.vision.select_pose`.

    Parameters
    ----------
    detection : FeatureDetection
        From :func:`~unseeable.vision.detect_features` at the pose to value.
    time_limit : float
    solver : StructureSolver, optional
        A solver for the detection's extent to reuse (no constraints: the choice's).

    Returns
    -------
    float
        Log-probability gain per judged feature; ``-inf`` when no valid structure is found.
    """
    gain, _ = implied_structure(detection, detection.evidence.extent, time_limit=time_limit,
                                solver=solver, work_limit=CHOICE_WORK_LIMIT)
    return gain
