"""Feature visibility from a structure by casting rays to the camera (DESIGN.md §4).

The same function serves both for ground-truth visibility (the true
structure) and inside the visibility ⇄ structure fixpoint (the current
estimate), so it is built on the numba kernel of :mod:`.rays`.
"""

from __future__ import annotations

import functools
import logging

import numpy as np

from unseeable.domain import GridPose, LogGeometry, Structure, feature_axes, feature_index
from unseeable.errors import InputError
from unseeable.visibility.geometry import (
    end_normals,
    feature_own_logs,
    feature_sample_points,
    log_cylinders,
)
from unseeable.visibility.rays import blocked_rays, first_log_beyond, rays_beyond

__all__ = ["occlusion_fraction", "background_fraction", "background_context",
           "BACKGROUND_INPUTS", "BACKGROUND_EDGE_OFFSET_MM", "feature_visibility",
           "ends_facing_camera", "DEFAULT_THRESHOLD"]

log = logging.getLogger(__name__)

#: Share of blocked rays from which a feature counts as occluded (the paper's 60 %).
DEFAULT_THRESHOLD = 0.6
#: Columns of :func:`background_context`.
BACKGROUND_INPUTS = ("behind", "behind_edges")
#: How far (mm) above and below each sample point :func:`background_context` looks for the
#: silhouette of a log behind it: about 2 px at the workspace's scale, the width of a
#: detector's band.
BACKGROUND_EDGE_OFFSET_MM = 3.0


def _camera_centre_grid(camera_centre_world, pose: GridPose) -> np.ndarray:
    c = getattr(camera_centre_world, "centre", camera_centre_world)  # a Camera works too
    c = np.asarray(c, dtype=float).reshape(-1)
    if c.shape != (3,) or not np.all(np.isfinite(c)):
        raise InputError("must be 3 finite world coordinates (mm)", field="camera_centre",
                         value=np.asarray(c).tolist())
    if not isinstance(pose, GridPose):
        raise InputError("must be a GridPose", field="pose", value=pose)
    return pose.world_to_grid(c)


def ends_facing_camera(extent, camera_centre_grid: np.ndarray, *,
                       geometry: LogGeometry = LogGeometry()) -> np.ndarray:
    """Which features are *not* log ends turned away from the camera.

    A log end faces the camera when the camera centre lies strictly on the
    outer side of the end disc's plane. Segments are always True.

    Parameters
    ----------
    extent : Extent
    camera_centre_grid : (3,) float
        Camera centre in the grid frame (mm).

    Returns
    -------
    (N,) bool
    """
    idx = feature_index(extent)
    normals = end_normals(extent, geometry=geometry)
    centres = feature_axes(extent, geometry)[:, 0]
    towards = np.asarray(camera_centre_grid, dtype=float)[None, :] - centres
    facing = np.sum(normals * towards, axis=1) > 0
    is_end = idx.kind <= 1
    return np.where(is_end, facing, True)


def occlusion_fraction(
    structure: Structure,
    camera_centre_world: np.ndarray,
    pose: GridPose,
    *,
    geometry: LogGeometry = LogGeometry(),
    blockers: np.ndarray | None = None,
    n_end: int = 16,
    n_segment: int = 12,
    threads: int = 1,
) -> np.ndarray:
    """Share of each feature's rays to the camera that a log blocks.

    Each feature's sample points (:func:`~unseeable.visibility.feature_sample_points`)
    send a ray to the camera centre; a ray is blocked when it meets the
    bounding cylinder (:func:`~unseeable.visibility.log_cylinders`) of a log
    of ``structure`` other than the feature's own logs
    (:func:`~unseeable.visibility.feature_own_logs`). Every feature of the
    extent gets a value, also where its log is absent: the question is
    whether a detector could see that place.

    Parameters
    ----------
    structure : Structure
        The logs that may occlude (true structure or current estimate).
    camera_centre_world : (3,) float or Camera
        Camera centre in the world frame (mm); a :class:`~unseeable.camera.Camera`
        is accepted for its ``.centre``.
    pose : GridPose
        The assembly's pose on the table.
    geometry : LogGeometry
    blockers : (L,) bool, optional
        Which of ``structure.logs`` may block rays (default: all), e.g. to
        leave out logs the arm has removed while keeping log ids.
    n_end, n_segment : int
        Sample points per log end / segment.
    threads : int
        Above 1, the rays are cast on two threads (:func:`blocked_rays`; the same
        answer).

    Returns
    -------
    (N,) float
        In :func:`~unseeable.domain.feature_index` order, in [0, 1]. A log
        end turned away from the camera gets 1 (its own log is in the way),
        and so does a feature without sample points.

    Examples
    --------
    >>> from unseeable.domain import Extent, Log
    >>> s = Structure(Extent(2, 1, 1), [Log(layer=0, at=(0, 0), notches=2)])
    >>> f = occlusion_fraction(s, np.array([32.0, 1000.0, -600.0]), GridPose())
    >>> f.shape, float(f[6 + 0])  # the u segment at (0, 0, 0): in plain view
    ((22,), 0.0)
    """
    camera, points, valid, cylinders, own = _feature_rays(
        structure, camera_centre_world, pose, geometry=geometry, blockers=blockers,
        n_end=n_end, n_segment=n_segment)
    blocked = blocked_rays(points, valid, camera, cylinders, geometry.radius, exclude=own,
                           threads=threads)
    n_valid = valid.sum(axis=1)
    fraction = np.where(n_valid > 0, blocked.sum(axis=1) / np.maximum(n_valid, 1), 1.0)
    facing = ends_facing_camera(structure.extent, camera, geometry=geometry)
    return np.where(facing, fraction, 1.0)


def background_fraction(
    structure: Structure,
    camera_centre_world: np.ndarray,
    pose: GridPose,
    *,
    geometry: LogGeometry = LogGeometry(),
    blockers: np.ndarray | None = None,
    n_end: int = 16,
    n_segment: int = 12,
) -> np.ndarray:
    """Share of each feature's camera rays that, continued past it, meet a log.

    What a detector sees *behind* a feature: wood (another log of
    ``structure``) or the table. An empty place inside a cabin, seen over
    its near wall, has the far wall's log edges behind it, and the detectors
    judge such places differently from one in front of the table; the
    calibration's context models take this value as an input
    (:mod:`unseeable.vision.calibration`), computed under the true structure
    when training and under the current estimate in the fixpoint.

    Parameters
    ----------
    structure, camera_centre_world, pose, geometry, blockers, n_end, n_segment
        As for :func:`occlusion_fraction` (``blockers``: the logs that count).

    Returns
    -------
    (N,) float
        In :func:`~unseeable.domain.feature_index` order, in [0, 1]; 0 for a
        feature without sample points.

    Examples
    --------
    >>> from unseeable.domain import Extent, Log
    >>> s = Structure(Extent(1, 1, 2), [Log(layer=0, at=(0, 1), notches=1)])
    >>> b = background_fraction(s, np.array([0.0, 100.0, -900.0]), GridPose())
    >>> b[[6, 9]].tolist()  # u segments at (0, 1, 0), far log behind; at (0, 2, 1), none
    [1.0, 0.0]
    """
    camera, points, valid, cylinders, own = _feature_rays(
        structure, camera_centre_world, pose, geometry=geometry, blockers=blockers,
        n_end=n_end, n_segment=n_segment)
    behind = rays_beyond(points, valid, camera, cylinders, geometry.radius, exclude=own)
    return _share(behind, valid)


def background_context(
    structure: Structure,
    camera_centre_world: np.ndarray,
    pose: GridPose,
    *,
    geometry: LogGeometry = LogGeometry(),
    blockers: np.ndarray | None = None,
    n_end: int = 16,
    n_segment: int = 12,
    edge_offset_mm: float = BACKGROUND_EDGE_OFFSET_MM,
    threads: int = 1,
) -> np.ndarray:
    """What a detector sees behind each feature: wood, and log edges right behind its line.

    Column ``behind`` is :func:`background_fraction`. Column ``behind_edges``
    is the share of the feature's sample points whose rays, cast past points
    ``edge_offset_mm`` above and below them, first meet different logs (or
    one a log and the other none): a silhouette of a log behind runs along
    the feature there, and a segment detector finds an edge whether the
    feature is present or not. The feature's own logs are left out as for
    :func:`background_fraction`, so both columns describe the background
    alone; the calibration's context models take them as inputs.

    Parameters
    ----------
    structure, camera_centre_world, pose, geometry, blockers, n_end, n_segment
        As for :func:`background_fraction`.
    edge_offset_mm : float
        Vertical offset of the two rays around each sample point.
    threads : int
        As for :func:`occlusion_fraction`.

    Returns
    -------
    (N, 2) float
        Columns :data:`BACKGROUND_INPUTS`, in :func:`~unseeable.domain.feature_index` order.

    Examples
    --------
    >>> from unseeable.domain import Extent, Log
    >>> s = Structure(Extent(1, 1, 2), [Log(layer=0, at=(0, 1), notches=1)])
    >>> c = background_context(s, np.array([0.0, 300.0, -900.0]), GridPose())
    >>> c[[7, 8]].round(2).tolist()  # u at (0, 1, 1): wood behind; at (0, 2, 0): an edge
    [[1.0, 0.08], [0.0, 0.92]]

    Seen from higher up, the far log's top silhouette lies just below the
    line of the ``u`` segment at ``(0, 2, 0)``: no wood behind the line
    itself, but an edge beside it.
    """
    if not (np.isfinite(edge_offset_mm) and edge_offset_mm > 0):
        raise InputError("must be a positive number of mm", field="edge_offset_mm",
                         value=edge_offset_mm)
    camera, points, valid, cylinders, own = _feature_rays(
        structure, camera_centre_world, pose, geometry=geometry, blockers=blockers,
        n_end=n_end, n_segment=n_segment)
    behind = rays_beyond(points, valid, camera, cylinders, geometry.radius, exclude=own,
                         threads=threads)
    # The grid frame's y is the world's vertical (a pose turns about it).
    lift = np.array([0.0, edge_offset_mm, 0.0])
    above = first_log_beyond(points + lift, valid, camera, cylinders, geometry.radius,
                             exclude=own, threads=threads)
    below = first_log_beyond(points - lift, valid, camera, cylinders, geometry.radius,
                             exclude=own, threads=threads)
    return np.column_stack([_share(behind, valid), _share(above != below, valid)])


def _share(hits: np.ndarray, valid: np.ndarray) -> np.ndarray:
    """Share of each feature's valid samples ``(N, S)`` that are hits; 0 without samples."""
    n_valid = valid.sum(axis=1)
    return np.where(n_valid > 0, (hits & valid).sum(axis=1) / np.maximum(n_valid, 1), 0.0)


@functools.lru_cache(maxsize=8)
def _sample_points(extent, camera: tuple, geometry, n_end: int, n_segment: int
                   ) -> tuple[np.ndarray, np.ndarray]:
    """:func:`feature_sample_points`, read-only, kept: the visibility fixpoint asks for a
    view's visibility and background under one estimate after another."""
    points, valid = feature_sample_points(extent, np.array(camera), geometry=geometry,
                                          n_end=n_end, n_segment=n_segment)
    points.setflags(write=False)
    valid.setflags(write=False)
    return points, valid


def _feature_rays(structure, camera_centre_world, pose, *, geometry, blockers, n_end,
                  n_segment):
    """Camera (grid frame), sample points, the logs' cylinders and each feature's own logs."""
    camera = _camera_centre_grid(camera_centre_world, pose)
    points, valid = _sample_points(structure.extent, tuple(camera.tolist()), geometry,
                                   n_end, n_segment)
    cylinders = log_cylinders(structure, geometry=geometry)
    own = feature_own_logs(structure)
    if blockers is not None:
        mask = np.asarray(blockers)
        if mask.shape != (len(cylinders),) or mask.dtype != bool:
            raise InputError(f"must be a bool mask over the {len(cylinders)} logs",
                             field="blockers", value=mask.shape)
        # Renumber own-log ids into the kept cylinders' numbering.
        keep = np.flatnonzero(mask)
        new_id = np.full(len(cylinders) + 1, -1, dtype=np.int64)
        new_id[keep] = np.arange(len(keep))
        own = new_id[own]  # -1 maps to new_id[-1] == -1
        cylinders = cylinders[keep]
    return camera, points, valid, cylinders, own


def feature_visibility(
    structure: Structure,
    camera_centre_world: np.ndarray,
    pose: GridPose,
    *,
    geometry: LogGeometry = LogGeometry(),
    threshold: float = DEFAULT_THRESHOLD,
    blockers: np.ndarray | None = None,
    n_end: int = 16,
    n_segment: int = 12,
    threads: int = 1,
) -> np.ndarray:
    """Which features the camera can see, given the logs of ``structure``.

    A feature is occluded when at least ``threshold`` of its rays are
    blocked (:func:`occlusion_fraction`); a log end turned away from the
    camera is occluded.

    Parameters
    ----------
    structure, camera_centre_world, pose, geometry, blockers, n_end, n_segment, threads
        As for :func:`occlusion_fraction`.
    threshold : float
        In (0, 1]; the paper's 60 % by default.

    Returns
    -------
    (N,) bool
        True = visible, in :func:`~unseeable.domain.feature_index` order.

    Examples
    --------
    >>> from unseeable.domain import Extent, Log
    >>> s = Structure(Extent(1, 1, 1), [Log(layer=0, at=(0, 0), notches=1)])
    >>> v = feature_visibility(s, np.array([-600.0, 400.0, 0.0]), GridPose())
    >>> v[:2].tolist()  # end- faces the camera, end+ faces away
    [True, False]
    """
    if not (isinstance(threshold, (int, float)) and 0.0 < threshold <= 1.0):
        raise InputError("must be in (0, 1]", field="threshold", value=threshold)
    fraction = occlusion_fraction(structure, camera_centre_world, pose, geometry=geometry,
                                  blockers=blockers, n_end=n_end, n_segment=n_segment,
                                  threads=threads)
    visible = fraction < threshold
    log.debug("visibility: %d of %d features visible (%d logs)", int(visible.sum()),
              len(visible), len(structure.logs))
    return visible
