"""Choosing between a pose and its aliases by the structure each implies.

:func:`~unseeable.vision.estimate_pose` returns, beside its edge-best pose,
the grid's near-symmetric translations that fit the image's edges almost as
well (:func:`~unseeable.vision.pose.pose_aliases`): moved a centimetre or two
along a grid axis, the lines of one layer land where another layer's lines
would be. Edges alone picked the wrong one of these in one validation view in
ten. What does tell them apart is whether the detections at that pose
make sense *as an assembly*: under the true pose the features the detectors
judge are explained by a valid structure (every log supported, notches
matching); under an alias, floating or unsupported logs would be needed and
the best valid structure disagrees with more of the detections.

The choice maximises ``log(alignment score) + weight · gain``, where ``gain``
is the MAP structure's log-probability gain over "no information"
(``p = ½``) per judged feature. ``weight = 3`` was chosen on the
validation renders, where it took the share of poses within 2 mm and 1°
from 79 % (edges alone) to 83 % (``benchmarks/vision.py``); the best
weights lie between 2 and 4 (docs/results.md).

The chosen pose is then polished on the edges of its own implied structure
(:func:`~unseeable.vision.pose.refine_pose_on_structure`): the edge fit aligns
every line the grid could hold, each weighted by how present it looks; the
structure says which logs are there and which of their edges the camera
sees.
"""

from __future__ import annotations

import dataclasses
import logging
from typing import TYPE_CHECKING

import numpy as np

from unseeable.camera import Camera
from unseeable.domain import Evidence, Extent, GridPose, LogGeometry, Structure
from unseeable.vision.calibration import Calibration
from unseeable.vision.evidence import detect_features
from unseeable.vision.pose import (
    PoseFit,
    PoseSettings,
    estimate_pose,
    refine_pose_on_structure,
)

if TYPE_CHECKING:  # the solver is imported only when a choice is to be made
    from unseeable.solve import StructureSolver

__all__ = ["structure_gain", "select_pose", "estimate_pose_by_structure", "POSE_CHOICE_WEIGHT"]

logger = logging.getLogger(__name__)

#: Weight of the structure gain against the log of the alignment score.
POSE_CHOICE_WEIGHT = 3.0


def _implied_structure(image: np.ndarray, camera: Camera, extent: Extent, pose: GridPose, *,
                       calibration: Calibration | None, geometry: LogGeometry,
                       time_limit: float, solver: StructureSolver | None
                       ) -> tuple[float, Structure | None]:
    """:func:`structure_gain` and the MAP structure it is the gain of."""
    det = detect_features(image, camera, pose, extent, calibration=calibration,
                          refine=False, geometry=geometry)
    judged = int(det.judged.sum())
    evidence = Evidence(extent, np.where(det.judged, det.p, 0.5))
    if solver is None:
        from unseeable.solve import StructureSolver

        solver = StructureSolver(extent)
    result = solver.solve(evidence, time_limit=time_limit)
    if result.structure is None:
        return -np.inf, None
    if judged == 0:
        return 0.0, result.structure
    return float((result.log_probability - judged * np.log(0.5)) / judged), result.structure


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
    gain, _ = _implied_structure(image, camera, extent, pose, calibration=calibration,
                                 geometry=geometry, time_limit=time_limit, solver=solver)
    return gain


def select_pose(image: np.ndarray, camera: Camera, extent: Extent, fit: PoseFit, *,
                calibration: Calibration | None = None, weight: float = POSE_CHOICE_WEIGHT,
                geometry: LogGeometry = LogGeometry(), time_limit: float = 5.0,
                polish: bool = True, settings: PoseSettings = PoseSettings()) -> PoseFit:
    """The candidate of ``fit`` whose edges and implied structure agree best with the image.

    Parameters
    ----------
    image : (H, W, 3) uint8
    camera : Camera
    extent : Extent
    fit : PoseFit
        From :func:`~unseeable.vision.estimate_pose`; its ``candidates`` are compared.
    calibration : Calibration, optional
    weight : float
        Weight of :func:`structure_gain` against the log alignment score.
    geometry : LogGeometry
    time_limit : float
    polish : bool
        Polish the chosen pose on the edges its implied structure shows
        (:func:`~unseeable.vision.pose.refine_pose_on_structure`).
    settings : PoseSettings
        For the polish.

    Returns
    -------
    PoseFit
        ``fit`` with ``pose`` and ``score`` of the chosen candidate, polished;
        the other fit statistics and the quality are those of the edge fit.
    """
    candidates = fit.candidates or ((fit.pose, fit.score),)
    if len(candidates) <= 1 and not polish:
        return fit
    from unseeable.solve import StructureSolver

    solver = StructureSolver(extent)  # one model for every candidate: only the priors change
    best = None
    for pose, score in candidates:
        gain, structure = _implied_structure(image, camera, extent, pose,
                                             calibration=calibration, geometry=geometry,
                                             time_limit=time_limit, solver=solver)
        value = float(np.log(max(score, 1e-9)) + weight * gain)
        logger.debug("pose candidate %s: score %.1f, structure gain %.4f -> %.4f",
                     pose, score, gain, value)
        if best is None or value > best[0]:
            best = (value, pose, score, structure)
    _, pose, score, structure = best
    if polish and structure is not None:
        polished = refine_pose_on_structure(image, camera, structure, pose,
                                            geometry=geometry, settings=settings)
        logger.debug("pose polished on the implied structure: %s -> %s", pose, polished)
        pose = polished
    return dataclasses.replace(fit, pose=pose, score=float(score))


def estimate_pose_by_structure(image: np.ndarray, camera: Camera, extent: Extent, *,
                               calibration: Calibration | None = None, strict: bool = True,
                               settings: PoseSettings = PoseSettings(),
                               geometry: LogGeometry = LogGeometry(),
                               weight: float = POSE_CHOICE_WEIGHT) -> PoseFit:
    """:func:`~unseeable.vision.estimate_pose`, then :func:`select_pose` among its aliases.

    Parameters and errors as :func:`~unseeable.vision.estimate_pose` (``strict``
    refuses poor edge fits with :class:`~unseeable.errors.VisionError`).

    Returns
    -------
    PoseFit
    """
    fit = estimate_pose(image, camera, extent, geometry=geometry, settings=settings,
                        strict=strict)
    return select_pose(image, camera, extent, fit, calibration=calibration, weight=weight,
                       geometry=geometry, settings=settings)
