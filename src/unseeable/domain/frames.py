"""World and grid frames (DESIGN.md §3): the assembly's pose on the table.

World = table frame: origin on the table at the workspace centre, y up, x and
z on the table, right-handed. Grid frame G: grid point (i, j, k) at
``(i*l1, y_j, k*l1)``. A :class:`GridPose` places G in the world::

    world = Rot_y(yaw) @ G + (x, 0, z)

Symbolic orientations. Image edges fix the yaw only modulo 90°, so each pose
has four *symbolic orientations* ``o = 0..3``: the grid turned by ``o``
quarter turns about the vertical through the footprint's centre, keeping the
same footprint on the table. A quarter turn makes the other horizontal
direction the grid's i (the bottom layer's direction) and swaps I and K; a
half turn keeps the axes and reverses both. A half turn describes the same
physical assembly in another grid (:func:`half_turn_structure`); a quarter
turn is a different hypothesis about the assembly (its bottom layer runs the
other way), so it acts on poses and extents only.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from unseeable.domain.geometry import LogGeometry
from unseeable.domain.grid import Extent
from unseeable.domain.structure import Log, Structure
from unseeable.errors import InputError

__all__ = [
    "GridPose",
    "rot_y",
    "symbolic_orientations",
    "half_turn_structure",
    "lower_silhouette",
]


def rot_y(yaw_rad: float) -> np.ndarray:
    """Right-handed rotation about +y by ``yaw_rad``, ``(3, 3)``."""
    c, s = np.cos(yaw_rad), np.sin(yaw_rad)
    return np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])


@dataclass(frozen=True)
class GridPose:
    """The assembly's pose on the table: 3 degrees of freedom.

    Parameters
    ----------
    x, z : float
        World position (mm) of grid point (0, ·, 0) on the table.
    yaw_deg : float
        Rotation of the grid about the world's vertical axis, in degrees.

    Examples
    --------
    >>> p = GridPose(10.0, 0.0, 90.0)
    >>> np.round(p.grid_to_world(np.array([[1.0, 0.0, 0.0]])), 6).tolist()
    [[10.0, 0.0, -1.0]]
    """

    x: float = 0.0
    z: float = 0.0
    yaw_deg: float = 0.0

    def __post_init__(self) -> None:
        for name in ("x", "z", "yaw_deg"):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, (int, float, np.floating, np.integer)) \
                    or not np.isfinite(v):
                raise InputError("must be a finite number", field=f"pose.{name}", value=v)
            object.__setattr__(self, name, float(v))

    @property
    def yaw(self) -> float:
        """Yaw in radians."""
        return float(np.deg2rad(self.yaw_deg))

    @property
    def rotation(self) -> np.ndarray:
        """``Rot_y(yaw)``, ``(3, 3)``."""
        return rot_y(self.yaw)

    @property
    def translation(self) -> np.ndarray:
        return np.array([self.x, 0.0, self.z])

    def matrix(self) -> np.ndarray:
        """Grid → world as a ``(4, 4)`` homogeneous transform."""
        m = np.eye(4)
        m[:3, :3] = self.rotation
        m[:3, 3] = self.translation
        return m

    def grid_to_world(self, points: np.ndarray) -> np.ndarray:
        """Map ``(..., 3)`` grid-frame points (mm) to the world frame."""
        p = np.asarray(points, dtype=float)
        return p @ self.rotation.T + self.translation

    def world_to_grid(self, points: np.ndarray) -> np.ndarray:
        """Map ``(..., 3)`` world points to the grid frame (mm)."""
        p = np.asarray(points, dtype=float)
        return (p - self.translation) @ self.rotation

    def directions_to_world(self, dirs: np.ndarray) -> np.ndarray:
        return np.asarray(dirs, dtype=float) @ self.rotation.T

    def to_json(self) -> dict:
        return {"x": self.x, "z": self.z, "yaw_deg": self.yaw_deg}

    def turned(self, quarter_turns: int, extent: Extent,
               geometry: LogGeometry = LogGeometry()) -> tuple[GridPose, Extent]:
        """The same footprint described with the grid turned by ``quarter_turns``.

        Returns the pose and extent of symbolic orientation ``quarter_turns``
        (mod 4); no turn (or four) gives this pose itself.
        """
        o = int(quarter_turns) % 4
        if o == 0:
            # This very pose, not one recomputed through its centre with rounding: a caller
            # may key results by the pose.
            return self, extent
        # The footprint's corners in the grid frame (mm), centre of rotation.
        span_i = (extent.I - 1) * geometry.l1
        span_k = (extent.K - 1) * geometry.l1
        centre = self.grid_to_world(np.array([span_i / 2, 0.0, span_k / 2]))
        new_extent = extent if o % 2 == 0 else Extent(extent.K, extent.J, extent.I)
        yaw = self.yaw_deg + 90.0 * o
        yaw = (yaw + 180.0) % 360.0 - 180.0
        half_i = (new_extent.I - 1) * geometry.l1 / 2
        half_k = (new_extent.K - 1) * geometry.l1 / 2
        origin = centre - rot_y(np.deg2rad(yaw)) @ np.array([half_i, 0.0, half_k])
        return GridPose(float(origin[0]), float(origin[2]), float(yaw)), new_extent

    def distance(self, other: GridPose) -> tuple[float, float]:
        """Translation (mm) and yaw (degrees, wrapped to [0, 180]) differences."""
        dt = float(np.hypot(self.x - other.x, self.z - other.z))
        dy = abs((self.yaw_deg - other.yaw_deg + 180.0) % 360.0 - 180.0)
        return dt, dy


def symbolic_orientations(pose: GridPose, extent: Extent,
                          geometry: LogGeometry = LogGeometry(),
                          ) -> list[tuple[int, GridPose, Extent]]:
    """The admissible symbolic orientations of ``pose`` for ``extent``.

    Quarter turns are ruled out when ``I != K`` (the footprint would change
    shape); the caller decides among the rest by the evidence.

    Returns
    -------
    list of (o, pose, extent)
    """
    turns = (0, 1, 2, 3) if extent.I == extent.K else (0, 2)
    return [(o, *pose.turned(o, extent, geometry)) for o in turns]


def half_turn_structure(structure: Structure) -> Structure:
    """The same physical assembly in the grid turned by 180° (see :meth:`GridPose.turned`).

    Position (i, j, k) becomes (I-1-i, j, K-1-k); each log's notch 0 moves to
    its other end. Validity is preserved. Applying it twice is the identity.
    """
    e = structure.extent
    logs = []
    for log in structure.logs:
        last = log.positions()[-1]
        logs.append(Log(layer=log.layer, at=(e.I - 1 - last[0], e.K - 1 - last[2]),
                        notches=log.notches))
    return Structure(e, logs)


def lower_silhouette(start: np.ndarray, stop: np.ndarray, camera_centre: np.ndarray,
                     radius: float) -> tuple[np.ndarray, np.ndarray]:
    """The lower silhouette line of horizontal cylinders as seen from a point.

    For each stretch of log axis ``start[n] → stop[n]`` of a cylinder of
    ``radius``, the generator line where rays from ``camera_centre`` graze the
    cylinder on its lower side (the edge a camera sees between a log and what
    lies below it).

    Parameters
    ----------
    start, stop : (N, 3) float
        Axis end points (any frame, same as ``camera_centre``), y up.
    camera_centre : (3,) float
    radius : float

    Returns
    -------
    start, stop : (N, 3) float
        The silhouette line's end points. Where the camera is inside the
        cylinder's radius the axis is offset straight down.
    """
    a = np.asarray(start, dtype=float)
    b = np.asarray(stop, dtype=float)
    c = np.asarray(camera_centre, dtype=float).reshape(3)
    axis = b - a
    length = np.linalg.norm(axis, axis=1, keepdims=True)
    axis = axis / np.where(length > 0, length, 1.0)
    mid = (a + b) / 2
    d = c - mid
    d_perp = d - np.sum(d * axis, axis=1, keepdims=True) * axis
    dist = np.linalg.norm(d_perp, axis=1, keepdims=True)
    u = d_perp / np.where(dist > 0, dist, 1.0)  # towards the camera, ⊥ axis
    w = np.cross(axis, u)  # ⊥ axis and u
    # tangent point: radius*(cos t * u ± sin t * w), cos t = r/dist
    cos_t = np.clip(radius / np.where(dist > 0, dist, np.inf), 0.0, 1.0)
    sin_t = np.sqrt(1.0 - cos_t**2)
    cand1 = radius * (cos_t * u + sin_t * w)
    cand2 = radius * (cos_t * u - sin_t * w)
    offset = np.where(cand1[:, 1:2] <= cand2[:, 1:2], cand1, cand2)
    inside = (dist[:, 0] <= radius)
    offset[inside] = np.array([0.0, -radius, 0.0])
    return a + offset, b + offset
