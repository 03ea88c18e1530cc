"""The paper's initial visibility estimate: the extent's prism seen from the camera.

Before any structure is known, assume the assembly fills the rectangular
prism of its extent; its top face and its camera-facing side faces are
visible, everything else occluded (paper, "Visibility Estimation";
DESIGN.md §4).
"""

from __future__ import annotations

import logging

import numpy as np

from unseeable.camera import Camera
from unseeable.domain import Extent, FeatureKind, GridPose, LogGeometry, feature_index
from unseeable.errors import InputError
from unseeable.visibility.occlusion import ends_facing_camera

__all__ = ["SIDE_FACES", "MIN_FRONT_ANGLE_DEG", "face_features", "camera_facing_faces",
           "initial_visibility"]

log = logging.getLogger(__name__)

#: Side faces of the prism, named by their outward normal in the grid frame.
SIDE_FACES = ("i_min", "i_max", "k_min", "k_max")
#: Below this image angle (degrees) between the two lower front edges, one face is dropped.
MIN_FRONT_ANGLE_DEG = 110.0


def face_features(extent: Extent, face: str) -> np.ndarray:
    """The features that lie on one face of the extent's prism.

    Side faces (``"i_min"``, ``"i_max"``, ``"k_min"``, ``"k_max"``; e.g.
    ``"k_min"`` is the face at the low-k side, outward normal −k):

    * the ``u``, ``v``, ``w`` segments (layers ``0..J+1``) of the layers whose
      logs run *along* the face, on its outer row (``k = 0`` for ``"k_min"``),
      except the ``w`` past the last position, which lies beyond the prism;
    * for the layers whose logs run *into* the face, on its outer row: the log
      end facing out of the face (``end-`` on a ``min`` face, ``end+`` on a
      ``max`` face) and the segment on the overhang that sticks out of the face
      (``u`` on a ``min`` face, ``v`` on a ``max`` face).

    Top face (``"top"``):

    * every segment of layers ``J-1``, ``J`` and ``J+1``: the bottom edges of
      the top layer and the top edges of the two highest layers (the top of
      layer ``J-2`` shows between the top layer's logs);
    * the log ends of the top layer on the prism's outer boundary, facing out.

    Ends inside a row (between two logs of a full prism) belong to no face.

    Parameters
    ----------
    extent : Extent
    face : str
        One of :data:`SIDE_FACES` or ``"top"``.

    Returns
    -------
    (N,) bool
        In :func:`~unseeable.domain.feature_index` order.
    """
    I, J, K = extent.shape
    idx = feature_index(extent)
    kind = idx.kind
    i, j, k = idx.at[:, 0], idx.at[:, 1], idx.at[:, 2]
    along_i = j % 2 == 0  # the layer's logs run along i
    is_seg = kind >= FeatureKind.U
    end_minus = kind == FeatureKind.END_MINUS
    end_plus = kind == FeatureKind.END_PLUS
    if face == "top":
        outer_end = np.where(along_i, (end_minus & (i == 0)) | (end_plus & (i == I - 1)),
                             (end_minus & (k == 0)) | (end_plus & (k == K - 1)))
        return (is_seg & (j >= J - 1)) | (outer_end & (j == J - 1))
    if face not in SIDE_FACES:
        raise InputError(f"unknown face; expected one of {list(SIDE_FACES) + ['top']}",
                         field="face", value=face)
    normal_axis, side = face.split("_")
    coord, last = (i, I - 1) if normal_axis == "i" else (k, K - 1)
    outer = coord == (0 if side == "min" else last)
    # layers whose logs run along the face: along k for an i face, along i for a k face
    runs_along = ~along_i if normal_axis == "i" else along_i
    # the along-face coordinate of the feature: w past the last position leaves the prism
    along_coord, along_last = (k, K - 1) if normal_axis == "i" else (i, I - 1)
    in_prism = ~((kind == FeatureKind.W) & (along_coord == along_last))
    on_row = runs_along & outer & is_seg & in_prism
    if side == "min":
        sticking_out = (end_minus | (kind == FeatureKind.U))
    else:
        sticking_out = (end_plus | (kind == FeatureKind.V))
    into = ~runs_along & outer & sticking_out
    return on_row | into


def _prism_corners(extent: Extent, geometry: LogGeometry) -> np.ndarray:
    """The four base corners of the prism in the grid frame, ``(2, 2, 3)`` by (i side, k side)."""
    g = geometry
    i_range = (-g.l3, (extent.I - 1) * g.l1 + g.l3)
    k_range = (-g.l3, (extent.K - 1) * g.l1 + g.l3)
    corners = np.zeros((2, 2, 3))
    for a in range(2):
        for b in range(2):
            corners[a, b] = (i_range[a], 0.0, k_range[b])
    return corners


def camera_facing_faces(extent: Extent, camera: Camera, pose: GridPose, *,
                        geometry: LogGeometry = LogGeometry()) -> tuple[str, ...]:
    """The side faces of the extent's prism the paper takes as visible.

    The prism's base corners — the grid points ``(0,0,0)``, ``(I-1,0,0)``,
    ``(0,0,K-1)``, ``(I-1,0,K-1)`` pushed out by the log overhang ``l3`` in i
    and k (so the prism bounds the logs and a 1-wide extent still has a
    footprint) and lowered to the table (y = 0) — are projected into the
    image. The bottommost three (largest image y) are the ends of the two
    lower front edges, which meet at the corner between the other two. When
    the image angle between those edges is below :data:`MIN_FRONT_ANGLE_DEG`
    one face is nearly edge-on: the one whose lower edge is narrowest in the
    image (smallest horizontal extent) is dropped.

    When a corner is behind the camera the image construction fails; then a
    face is kept when the camera centre lies on its outer side.

    Returns
    -------
    tuple of str
        One or two names from :data:`SIDE_FACES`.
    """
    corners_grid = _prism_corners(extent, geometry)
    world = pose.grid_to_world(corners_grid.reshape(-1, 3))
    uv = camera.project(world).reshape(2, 2, 2)
    if not np.all(np.isfinite(uv)):
        c = pose.world_to_grid(camera.centre)
        lo, hi = corners_grid[0, 0], corners_grid[1, 1]
        faces = tuple(name for name, outside in (
            ("i_min", c[0] < lo[0]), ("i_max", c[0] > hi[0]),
            ("k_min", c[2] < lo[2]), ("k_max", c[2] > hi[2])) if outside)
        log.debug("a prism corner is behind the camera; faces from the camera side: %s", faces)
        return faces
    # the topmost corner in the image is the one left out; the front corner is its diagonal
    flat = uv.reshape(4, 2)
    top = int(np.argmin(flat[:, 1]))
    ta, tb = divmod(top, 2)
    fa, fb = 1 - ta, 1 - tb
    front = uv[fa, fb]
    # the edge to (ta, fb) runs along i, on the k side fb; the edge to (fa, tb) runs along k
    edge_i = uv[ta, fb] - front
    edge_k = uv[fa, tb] - front
    face_along_i = "k_min" if fb == 0 else "k_max"
    face_along_k = "i_min" if fa == 0 else "i_max"
    norms = np.linalg.norm(edge_i) * np.linalg.norm(edge_k)
    cos = float(np.dot(edge_i, edge_k) / norms) if norms > 0 else 1.0
    angle = float(np.degrees(np.arccos(np.clip(cos, -1.0, 1.0))))
    faces = (face_along_i, face_along_k)
    if angle < MIN_FRONT_ANGLE_DEG:
        narrow = face_along_i if abs(edge_i[0]) < abs(edge_k[0]) else face_along_k
        faces = tuple(f for f in faces if f != narrow)
    log.debug("front edges meet at %.1f deg; visible side faces %s", angle, faces)
    return faces


def initial_visibility(extent: Extent, camera: Camera, pose: GridPose, *,
                       geometry: LogGeometry = LogGeometry()) -> np.ndarray:
    """The paper's initial visibility estimate, before any structure is known.

    Assume the assembly fills the extent's prism. Features on its top face
    and on the camera-facing side faces chosen by :func:`camera_facing_faces`
    are visible (which features lie on a face: :func:`face_features`); all
    others are occluded. Log ends turned away from the camera are occluded
    in any case, as in :func:`~unseeable.visibility.feature_visibility`.

    Parameters
    ----------
    extent : Extent
    camera : Camera
        Calibrated camera (world frame).
    pose : GridPose
    geometry : LogGeometry

    Returns
    -------
    (N,) bool
        True = visible, in :func:`~unseeable.domain.feature_index` order.

    Examples
    --------
    >>> cam = Camera.look_at(eye=[-300, 400, -400], target=[32, 0, 32], width=640,
    ...                      height=480, fov_deg=50)
    >>> faces = camera_facing_faces(Extent(2, 2, 2), cam, GridPose())
    >>> sorted(faces)
    ['i_min', 'k_min']
    """
    if not isinstance(camera, Camera):
        raise InputError("must be a Camera", field="camera", value=camera)
    visible = face_features(extent, "top")
    for face in camera_facing_faces(extent, camera, pose, geometry=geometry):
        visible = visible | face_features(extent, face)
    facing = ends_facing_camera(extent, pose.world_to_grid(camera.centre), geometry=geometry)
    return visible & facing
