"""Feature evidence for the estimator: detectors + calibration → :class:`Evidence`."""

from __future__ import annotations

import functools
import logging
from dataclasses import dataclass

import numpy as np

from unseeable.camera import Camera
from unseeable.domain import Evidence, Extent, GridPose, LogGeometry
from unseeable.errors import VisionError
from unseeable.parallel import single_blas_thread
from unseeable.vision.calibration import Calibration, default_calibration
from unseeable.vision.detectors import DetectorSettings, FeatureScores, score_features
from unseeable.vision.edges import EdgeMaps, as_rgb_image, edge_maps
from unseeable.vision.pose import PoseSettings, refine_pose
from unseeable.vision.scale import working_view

__all__ = ["FeatureDetection", "detect_features", "feature_evidence", "initial_mask"]

logger = logging.getLogger(__name__)


@dataclass(frozen=True, eq=False)
class FeatureDetection:
    """What the detectors made of one view.

    Attributes
    ----------
    evidence : Evidence
        p_f for the judged features, ½ for the others.
    p : (N,) float
        Same priors as an array (feature index order).
    judged : (N,) bool
        Features the detectors judged (requested, in the image, large enough).
    pose : GridPose
        The pose the features were projected with (after refinement, if any).
    scores : FeatureScores
        Raw detector statistics and projections.
    calibration : Calibration, optional
        The calibration that made ``p`` (for :meth:`priors_given`).
    """

    evidence: Evidence
    p: np.ndarray
    judged: np.ndarray
    pose: GridPose
    scores: FeatureScores
    calibration: Calibration | None = None

    @property
    def has_context(self) -> bool:
        """Whether :meth:`priors_given` can re-weigh the detections."""
        return self.calibration is not None and self.calibration.has_context

    @single_blas_thread()
    def priors_given(self, behind: np.ndarray) -> np.ndarray:
        """The priors knowing what lies behind each feature (the calibration's context models).

        Parameters
        ----------
        behind : (N, 2) float
            What lies behind each feature: wood, and log edges along it
            (:func:`unseeable.visibility.background_context` under an estimate).

        Returns
        -------
        (N,) float
            ½ where the detectors did not judge.
        """
        if self.calibration is None:
            raise VisionError("this detection does not know its calibration")
        return self._context_priors(behind)

    @functools.cached_property
    def _context_priors(self):
        # The statistics' share of the context models, computed once per detection.
        return self.calibration.context_priors(self.scores)


# The calibration's models are matrix products, whose last bits depend on how many
# threads OpenBLAS splits them over: one thread, as in estimate_view and select_pose,
# so that detections made alone equal the pipeline's on any machine.
@single_blas_thread()
def detect_features(image: np.ndarray, camera: Camera, pose: GridPose, extent: Extent, *,
                    mask: np.ndarray | None = None, calibration: Calibration | None = None,
                    refine: bool = True, geometry: LogGeometry = LogGeometry(),
                    settings: DetectorSettings = DetectorSettings(),
                    maps: EdgeMaps | None = None, threads: int = 1) -> FeatureDetection:
    """Judge the requested features of one photograph.

    Parameters
    ----------
    image : (H, W, 3) uint8
    camera : Camera
    pose : GridPose
        The assembly's pose (estimated by :func:`unseeable.vision.estimate_pose`, or known).
    extent : Extent
    mask : (N,) bool, optional
        Features to judge (e.g. those the visibility stage says are visible); all by default.
    calibration : Calibration, optional
        Score → probability maps; the shipped one by default.
    refine : bool
        First polish ``pose`` on the image's edges (absorbs small camera and placement
        errors; a few tenths of a second).
    geometry : LogGeometry
    settings : DetectorSettings
    maps : EdgeMaps, optional
        Precomputed :func:`~unseeable.vision.edge_maps` of ``image`` (``sigma =
        settings.sigma``), for callers judging one image at several poses.
    threads : int
        Above 1, the ends and the segments are scored side by side
        (:func:`~unseeable.vision.score_features`; the same detections).

    Returns
    -------
    FeatureDetection

    Examples
    --------
    >>> from unseeable.domain import Extent, GridPose
    >>> cam = Camera.look_at(eye=[0, 400, -600], target=[0, 0, 0], width=160, height=120,
    ...                      fov_deg=50)
    >>> det = detect_features(np.zeros((120, 160, 3), np.uint8), cam, GridPose(), Extent(1, 1, 1),
    ...                       refine=False)
    >>> bool(((det.p > 0) & (det.p < 1)).all())
    True
    """
    img, camera = working_view(as_rgb_image(image), camera)
    cal = default_calibration() if calibration is None else calibration
    if maps is None or maps.shape != img.shape[:2]:
        maps = edge_maps(img, sigma=settings.sigma)
    used = pose
    if refine:
        used = refine_pose(maps, camera, extent, pose, geometry=geometry,
                           settings=PoseSettings(sigma=settings.sigma))
    scores = score_features(img, camera, used, extent, mask=mask, geometry=geometry,
                            settings=settings, maps=maps, threads=threads)
    p = cal.probabilities(scores)
    return FeatureDetection(Evidence(extent, p), p, scores.judged.copy(), used, scores, cal)


def feature_evidence(image: np.ndarray, camera: Camera, pose: GridPose, extent: Extent, *,
                     mask: np.ndarray | None = None, calibration: Calibration | None = None,
                     refine: bool = True, geometry: LogGeometry = LogGeometry()) -> Evidence:
    """:class:`Evidence` for the requested features of a photograph (:func:`detect_features`)."""
    return detect_features(image, camera, pose, extent, mask=mask, calibration=calibration,
                           refine=refine, geometry=geometry).evidence


def initial_mask(extent: Extent, camera: Camera, pose: GridPose, *,
                 removed_from_layer: int | None = None,
                 geometry: LogGeometry = LogGeometry()) -> np.ndarray:
    """Features worth judging before any structure is known: the paper's initial visibility.

    The top face and the camera-facing faces of the extent's prism
    (:func:`unseeable.visibility.initial_visibility`). After the arm took
    off every log at layers ``>= removed_from_layer``, the prism is that of
    the remaining layers, and features of the removed layers are left out
    (segment features of the two layers above them remain: they are the
    top edges of the layers below).

    Returns
    -------
    (N,) bool
        In :func:`unseeable.domain.feature_index` order of ``extent``.
    """
    from unseeable.domain import feature_index
    from unseeable.visibility import initial_visibility

    if removed_from_layer is None or removed_from_layer >= extent.J:
        return np.asarray(initial_visibility(extent, camera, pose, geometry=geometry), bool)
    mask = np.zeros(len(feature_index(extent)), dtype=bool)
    if removed_from_layer <= 0:
        return mask
    kept = Extent(extent.I, int(removed_from_layer), extent.K)
    vis = np.asarray(initial_visibility(kept, camera, pose, geometry=geometry), bool)
    small = feature_index(kept)
    mask[feature_index(extent).lookup_many(small.kind, small.at)] = vis
    return mask
