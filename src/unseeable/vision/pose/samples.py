"""Samples of a pose's upper silhouettes and end rims, for aligning them with image edges.

:func:`feature_samples` takes every line and rim the grid could hold (the
pose search, and the polish of a pose on the grid); :func:`structure_samples`
only those an estimated structure shows the camera (the polish on a
structure, and the rim support of the pose choice).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from unseeable.camera import Camera
from unseeable.domain import Extent, GridPose, LogGeometry, Structure
from unseeable.vision.pose.lines import (
    axis_stretches,
    disc_rims,
    end_rims,
    sample_lines,
    upper_lines,
)
from unseeable.vision.pose.settings import POLISH_RIM_WEIGHT
from unseeable.vision.projection import upper_silhouette

__all__ = ["FeatureSamples", "feature_samples", "structure_samples"]


@dataclass(frozen=True, eq=False)
class FeatureSamples:
    """Samples of a pose's upper silhouettes and end rims, in the grid frame.

    Rigid within one alignment: the silhouettes move with the pose only
    through the camera's viewing angle, which hardly changes over a few
    millimetres.
    """

    pts: np.ndarray  # (M, 3)
    tangent: np.ndarray  # (M, 3) unit direction of the line or rim at each sample
    reference: np.ndarray  # (M, 3) a point inside the log or disc (normals point away)
    group: np.ndarray  # (M,) line or rim index
    bias: np.ndarray  # (M,) px: where the image edge sits relative to the silhouette
    n_groups: int
    # (M,) known presence of each sample's line or rim (a structure's); None: judge it
    # from the image's edges
    weight: np.ndarray | None = None
    # (M,) bool: the sample lies on an end disc's rim (else on a silhouette line)
    rim: np.ndarray | None = None


def feature_samples(extent: Extent, pose: GridPose, camera: Camera, geometry: LogGeometry, *,
                    spacing: float, edge_bias_px: float, use_ends: bool = True
                     ) -> FeatureSamples:
    """Samples of every upper silhouette the grid could hold at ``pose`` (and, with
    ``use_ends``, of the end rims facing the camera), about ``spacing`` pixels apart,
    each line or rim judged later by how present it looks (no ``weight``)."""
    lines, _, inside = upper_lines(extent, pose, camera, geometry)
    pts, tangent, lid = sample_lines(lines, camera, spacing)
    ref = inside[lid]
    bias = np.full(len(pts), edge_bias_px)
    n_groups = len(lines)
    if use_ends:
        # The rims of end discs facing the camera: they fix positions along the logs.
        rim, r_tan, r_centre, r_group = end_rims(extent, pose, camera, geometry)
        if len(rim):
            pts = np.concatenate([pts, pose.grid_to_world(rim)])
            tangent = np.concatenate([tangent, pose.directions_to_world(r_tan)])
            ref = np.concatenate([ref, pose.grid_to_world(r_centre)])
            lid = np.concatenate([lid, r_group + n_groups])
            bias = np.concatenate([bias, np.zeros(len(rim))])
            n_groups += int(r_group.max()) + 1
    return FeatureSamples(pose.world_to_grid(pts), tangent @ pose.rotation,
                          pose.world_to_grid(ref), lid, bias, n_groups)


def structure_samples(structure: Structure, pose: GridPose, camera: Camera,
                      geometry: LogGeometry, *, spacing: float, edge_bias_px: float,
                      rim_weight: float = POLISH_RIM_WEIGHT) -> FeatureSamples:
    """Samples of the upper silhouettes and end rims a structure shows the camera.

    Unlike :func:`feature_samples` (every line the grid could hold, each
    judged by how present it looks), only the stretches the structure's logs
    cover and the rims of its log ends facing the camera, each sample kept
    when its ray to the camera passes the structure's other logs (bounding
    cylinders, as in :mod:`unseeable.visibility`). Weights are 1: presence is
    known, except that the rims together weigh ``rim_weight`` times the lines.
    """
    from unseeable.visibility import blocked_rays, log_cylinders, log_id_grid

    extent = structure.extent
    I, J, K = extent.shape
    ids = log_id_grid(structure)
    ii, jj, kk = (a.ravel() for a in np.meshgrid(np.arange(I), np.arange(J), np.arange(K),
                                                  indexing="ij"))
    start, stop, kind = axis_stretches(ii, jj, kk, geometry)
    pi, pj, pk = (np.repeat(a, 3) for a in (ii, jj, kk))
    own = ids[pi, pj, pk]
    # A w stretch runs to the next notch position: covered when the same log is there too.
    even = pj % 2 == 0
    ni, nk = np.where(even, pi + 1, pi), np.where(even, pk, pk + 1)
    inside = (ni < I) & (nk < K)
    after = np.full(len(pi), -2)
    after[inside] = ids[ni[inside], pj[inside], nk[inside]]
    covered = (own >= 0) & ((kind != 2) | (after == own))
    wa, wb = pose.grid_to_world(start[covered]), pose.grid_to_world(stop[covered])
    ua, ub = upper_silhouette(wa, wb, camera.centre, geometry.radius)
    if len(ua):
        pts, tangent, lid = sample_lines(np.stack([ua, ub], axis=1), camera, spacing)
    else:
        pts, tangent, lid = np.zeros((0, 3)), np.zeros((0, 3)), np.zeros(0, int)
    ref = ((wa + wb) / 2.0)[lid]
    owner = own[covered][lid]
    n_line_samples = len(pts)
    bias = np.full(len(pts), edge_bias_px)
    n_groups = int(covered.sum())
    cylinders = log_cylinders(structure, geometry=geometry)
    if len(cylinders):
        axis = cylinders[:, 1] - cylinders[:, 0]
        axis /= np.linalg.norm(axis, axis=1, keepdims=True)
        centre = np.concatenate([cylinders[:, 0], cylinders[:, 1]])
        normal = np.concatenate([-axis, axis])
        log_of = np.tile(np.arange(len(cylinders)), 2)
        rim, r_tan, r_centre, r_group, facing = disc_rims(centre, normal, pose, camera,
                                                          geometry)
        pts = np.concatenate([pts, pose.grid_to_world(rim)])
        tangent = np.concatenate([tangent, pose.directions_to_world(r_tan)])
        ref = np.concatenate([ref, pose.grid_to_world(r_centre)])
        lid = np.concatenate([lid, n_groups + r_group])
        owner = np.concatenate([owner, log_of[facing][r_group]])
        bias = np.concatenate([bias, np.zeros(len(rim))])  # see match_edges
    grid_pts = pose.world_to_grid(pts)
    if len(cylinders) and len(grid_pts):
        camera_grid = pose.world_to_grid(camera.centre[None])[0]
        seen = ~blocked_rays(grid_pts[:, None, :], np.ones((len(grid_pts), 1), bool),
                             camera_grid, cylinders, geometry.radius,
                             exclude=owner[:, None])[:, 0]
    else:
        seen = np.ones(len(grid_pts), bool)
    groups, lid = np.unique(lid[seen], return_inverse=True)
    rim = (np.arange(len(seen)) >= n_line_samples)[seen]
    # The rims outweigh the lines. Lines fix the pose across themselves but a depth
    # shift moves the lines of one layer onto those of the perpendicular logs half a
    # layer away, and on some logs the strongest edge near a top silhouette is the
    # highlight a pixel or two inside it; the rims' closed curves do neither. From the
    # true pose, the polish of the 240 validation renders stays within 2 mm/1° in 236
    # with rims at 4× the lines in total, 234 at 1× (100 of the first 120 with lines
    # alone), 232 with rims alone (docs/results.md); 239 once the rims' edge offsets
    # (RIM_BIAS_PX, RIM_DROP_PX) are taken off.
    n_rim, n_line = int(rim.sum()), int((~rim).sum())
    weight = np.where(rim, rim_weight * n_line / n_rim if n_rim and n_line else 1.0, 1.0)
    return FeatureSamples(grid_pts[seen], tangent[seen] @ pose.rotation,
                          pose.world_to_grid(ref[seen]), lid, bias[seen], len(groups),
                          weight=weight, rim=rim)
