"""The grid's near-symmetries: poses whose lines nearly coincide, and when two poses are one.

A half turn leaves the set of grid lines unchanged (:func:`canonical_pose`
reports the yaw in ``[-90, 90)``); on a square footprint so does a quarter
turn after a translation; and a translation along a grid axis can move one
layer's lines onto another's (:func:`pose_aliases`).
"""

from __future__ import annotations

import numpy as np

from unseeable.camera import Camera
from unseeable.domain import Extent, GridPose, LogGeometry, symbolic_orientations
from unseeable.vision.pose.lines import centre_grid

__all__ = ["pose_aliases", "canonical_pose", "pose_equivalent"]


def pose_aliases(pose: GridPose, camera: Camera, extent: Extent, *,
                 layers: tuple[int, ...] = (1, 2),
                 geometry: LogGeometry = LogGeometry()) -> list[GridPose]:
    """Translations of ``pose`` whose grid lines nearly coincide with its own in the image.

    Seen from elevation ``e``, a horizontal line moved a distance ``s``
    across itself, along a direction at angle θ to the horizontal viewing
    direction, has the image it would have raised by ``s tan e / cos θ``
    (the motion keeps it in the plane through the line and the camera).
    Layers are ``l2 / 2`` apart, so a grid translated along one of its axes
    by ``n (l2 / 2) cos θ / tan e`` puts the other axis's lines ``n``
    half-layers up or down, onto lines the grid has too, while the lines
    along the axis itself only slide along themselves. Only the ends, the
    gaps at the notches and the bottom and top layers tell such poses apart.
    (``cos θ`` is kept at 0.7 or more: the alignment that follows finds the
    exact optimum from a few millimetres away.)

    Parameters
    ----------
    pose : GridPose
    camera : Camera
    extent : Extent
    layers : tuple of int
        Half-layer counts ``n``.
    geometry : LogGeometry

    Returns
    -------
    list of GridPose
        ``4 * len(layers)`` poses: ``± n`` along grid ``i``, then along ``k``.

    Examples
    --------
    >>> from unseeable.domain import Extent, GridPose
    >>> cam = Camera.look_at(eye=[0, 500, -600], target=[0, 0, 0], width=160, height=120,
    ...                      fov_deg=40)
    >>> len(pose_aliases(GridPose(-64, -64, 0), cam, Extent(3, 3, 3)))
    8
    """
    centre = pose.grid_to_world(centre_grid(extent, geometry))
    centre[1] = float(geometry.layer_height(extent.J - 1)) / 2.0
    view = centre - camera.centre
    horizontal = np.hypot(view[0], view[2])
    if horizontal < 1e-9 or view[1] >= 0:
        return []  # looking straight down (or up): no such near-symmetry
    tan_e = -view[1] / horizontal
    out = []
    for axis in (0, 2):
        direction = pose.rotation[:, axis]
        cosine = max(abs(direction[0] * view[0] + direction[2] * view[2]) / horizontal, 0.7)
        for n in layers:
            step = n * geometry.radius * cosine / tan_e
            for sign in (-1.0, 1.0):
                move = sign * step * direction
                out.append(GridPose(pose.x + float(move[0]), pose.z + float(move[2]),
                                    pose.yaw_deg))
    return out


def canonical_pose(pose: GridPose, extent: Extent, geometry: LogGeometry) -> GridPose:
    """The pose or its half turn, whichever has its yaw in [-90, 90)."""
    y = (pose.yaw_deg + 180.0) % 360.0 - 180.0
    if -90.0 <= y < 90.0:
        return GridPose(pose.x, pose.z, y)
    turned, _ = pose.turned(2, extent, geometry)
    y2 = (turned.yaw_deg + 180.0) % 360.0 - 180.0
    return GridPose(turned.x, turned.z, y2)


def pose_equivalent(a: GridPose, b: GridPose, extent: Extent, *,
                    geometry: LogGeometry = LogGeometry(),
                    quarter_turns: bool = False) -> tuple[float, float]:
    """Distance (mm, degrees) between ``a`` and the nearest pose numbering ``b``'s grid.

    ``b`` and its half turn describe the same grid lines; with ``quarter_turns``
    so do its quarter turns when the footprint is square (I = K).
    """
    turns = symbolic_orientations(b, extent, geometry)
    if not quarter_turns:
        turns = [t for t in turns if t[0] in (0, 2)]
    return min((a.distance(p) for _, p, _ in turns), key=lambda d: d[0] + d[1])
