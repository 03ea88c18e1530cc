"""Geometric visibility of features (DESIGN.md §4, paper "Visibility Estimation").

* :func:`feature_visibility` / :func:`occlusion_fraction`: rays from each
  feature's sample points to the camera centre, blocked by the bounding
  cylinders of a structure's logs (numba kernel in :mod:`.rays`).
* :func:`background_fraction` / :func:`background_context`: the same rays
  continued past each feature: is there wood behind it in the image, and a
  log's silhouette right behind its line (the calibration's context)?
* :func:`initial_visibility`: the paper's first guess from the extent's prism.
* Building blocks: :func:`log_cylinders`, :func:`feature_sample_points`,
  :func:`feature_own_logs`, :func:`blocked_rays`.
"""

from unseeable.visibility.geometry import (
    END_DISC_FRACTION,
    end_normals,
    feature_own_logs,
    feature_sample_points,
    log_cylinders,
    log_id_grid,
)
from unseeable.visibility.initial import (
    MIN_FRONT_ANGLE_DEG,
    SIDE_FACES,
    camera_facing_faces,
    face_features,
    initial_visibility,
)
from unseeable.visibility.occlusion import (
    BACKGROUND_EDGE_OFFSET_MM,
    BACKGROUND_INPUTS,
    DEFAULT_THRESHOLD,
    background_context,
    background_fraction,
    ends_facing_camera,
    feature_visibility,
    occlusion_fraction,
)
from unseeable.visibility.rays import (
    CYLINDER_SHRINK_MM,
    START_OFFSET_MM,
    blocked_rays,
    blocked_rays_reference,
    count_ray_cylinder_hits,
    first_log_beyond,
    rays_beyond,
)

__all__ = [
    "log_cylinders", "log_id_grid", "feature_own_logs", "feature_sample_points", "end_normals",
    "END_DISC_FRACTION", "blocked_rays", "blocked_rays_reference", "count_ray_cylinder_hits",
    "rays_beyond", "first_log_beyond", "background_fraction", "background_context",
    "BACKGROUND_INPUTS", "BACKGROUND_EDGE_OFFSET_MM", "START_OFFSET_MM", "CYLINDER_SHRINK_MM",
    "occlusion_fraction", "feature_visibility",
    "ends_facing_camera", "DEFAULT_THRESHOLD", "initial_visibility", "camera_facing_faces",
    "face_features", "SIDE_FACES", "MIN_FRONT_ANGLE_DEG",
]
