"""The vision front end: from a photograph to evidence for the estimator.

* :func:`project_features` — where every feature of an extent appears in an
  image (ellipses of log ends, lower silhouettes of segments).
* :func:`score_features` — detectors focused on each feature's expected
  place and shape (elliptical edge filter; oriented edge energy and the
  longest supported run along a line; whole-log and colour context).
* :class:`Calibration` — detector statistics → p_f, fitted on rendered
  training scenes (:func:`unseeable.training.calibrate`), shipped as
  package data (:func:`default_calibration`, :func:`load_calibration`).
* :func:`detect_features` / :func:`feature_evidence` — all of the above for
  the features the caller asks for, as :class:`~unseeable.domain.Evidence`.
* :func:`estimate_pose` — the assembly's :class:`~unseeable.domain.GridPose`
  from the image; :func:`refine_pose` polishes a pose that is nearly right;
  :func:`align_pose` aligns and scores any pose as the search does its candidates;
  :func:`select_pose` chooses between the pose and its near-symmetric
  aliases by the structure the detections imply there and polishes the
  choice on that structure's own edges (:func:`refine_pose_on_structure`;
  all at once: :func:`estimate_pose_by_structure`).
* :func:`draw_evidence`, :func:`draw_detection`, :func:`draw_pose` — overlays for people.

Any camera may be used: a photograph finer or coarser than the scale the
calibration was fitted at (1.35–2.37 mm per pixel) is resampled for the
detectors, and a coarse one for the pose search (:mod:`unseeable.vision.scale`).
"""

from unseeable.vision.calibration import (
    Calibration,
    default_calibration,
    load_calibration,
    merge_calibrations,
    save_calibration,
)
from unseeable.vision.calibration_fit import fit_calibration
from unseeable.vision.detectors import (
    END_STATS,
    SEGMENT_STATS,
    DetectorSettings,
    FeatureScores,
    score_features,
)
from unseeable.vision.edges import EdgeMaps, as_rgb_image, edge_maps, woodness_map
from unseeable.vision.evidence import FeatureDetection, detect_features, feature_evidence
from unseeable.vision.overlay import (
    draw_detection,
    draw_evidence,
    draw_pose,
    probability_colours,
)
from unseeable.vision.pose import (
    POLISH_REACH_PX,
    PoseFit,
    PoseSettings,
    align_pose,
    estimate_pose,
    pose_equivalent,
    refine_pose,
    refine_pose_on_structure,
    rim_support,
)
from unseeable.vision.pose_choice import (
    PolishProposal,
    detection_gain,
    estimate_pose_by_structure,
    judge_polish,
    poses_apart,
    select_pose,
    structure_gain,
    structure_silhouette,
)
from unseeable.vision.projection import (
    FeatureProjection,
    collinear_segment_pairs,
    fit_ellipses,
    project_features,
    upper_silhouette,
)
from unseeable.vision.scale import view_edge_maps

__all__ = [
    "project_features", "FeatureProjection", "fit_ellipses", "upper_silhouette",
    "collinear_segment_pairs",
    "edge_maps", "EdgeMaps", "woodness_map", "as_rgb_image", "view_edge_maps",
    "score_features", "FeatureScores", "DetectorSettings", "END_STATS", "SEGMENT_STATS",
    "Calibration", "default_calibration", "fit_calibration", "load_calibration",
    "merge_calibrations", "save_calibration",
    "detect_features", "feature_evidence", "FeatureDetection",
    "estimate_pose", "align_pose", "refine_pose", "refine_pose_on_structure", "rim_support",
    "PoseFit",
    "PoseSettings", "POLISH_REACH_PX",
    "pose_equivalent",
    "select_pose", "structure_gain", "detection_gain", "judge_polish", "PolishProposal",
    "estimate_pose_by_structure", "structure_silhouette", "poses_apart",
    "draw_evidence", "draw_detection", "draw_pose", "probability_colours",
]
