"""Where "left" and "right" are seen from: the reference view's camera, or the grid's −k side.

*Left of* and *right of* compare positions as a viewer sees them (DESIGN.md §4
"Language": from the reference, first, view). A grid point's **lateral
coordinate** says where it lies across the viewer's field of view, increasing to
the viewer's right; one thing is left of another when every grid point of the
first has a smaller lateral coordinate than every grid point of the second.

* A :class:`Viewpoint` (a camera centre and the assembly's pose on the table)
  gives the *bearing* of each grid point: the horizontal angle, at the camera
  centre, from the camera's viewing direction to the point, in radians, positive
  to the right. Bearings are what a person standing at the camera calls left and
  right: they do not depend on a point's height or the camera's tilt, and two
  points one behind the other are neither left nor right of each other.
* Any function from grid points ``(N, 3)`` (indices ``i, j, k``) to ``(N,)``
  numbers increasing to the right (e.g. image ``x`` coordinates).
* Without a viewpoint (bare evidence has no camera), the viewer stands far away
  on the grid's **−k side**, looking towards +k, upright (+j up). The grid's axes
  are right-handed, so that viewer sees **i increase to the left**: the lateral
  coordinate is ``-i``, and "door left of window" means the door's ``i`` is
  larger than the window's. The corpus's cameras mostly stand on that side, so
  the default agrees with their pictures.

Examples
--------
>>> import numpy as np
>>> lateral_coordinates(None, np.array([[0, 0, 0], [3, 0, 0]])).tolist()
[-0.0, -3.0]
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from unseeable.domain.frames import GridPose
from unseeable.domain.geometry import LogGeometry
from unseeable.domain.grid import Extent
from unseeable.errors import InputError

__all__ = ["Viewpoint", "LateralFunction", "lateral_coordinates", "DEFAULT_VIEWER"]

#: ``f(points (N, 3) grid indices) -> (N,)`` lateral coordinates, increasing to the right.
LateralFunction = Callable[[np.ndarray], np.ndarray]

#: What left and right mean without a viewpoint (module docstring).
DEFAULT_VIEWER = "far away on the grid's -k side, looking towards +k (i increases to the left)"

_UP = np.array([0.0, 1.0, 0.0])


@dataclass(frozen=True, eq=False)
class Viewpoint:
    """A viewer's position relative to the assembly: a camera centre and the grid's pose.

    Parameters
    ----------
    centre : (3,) float
        The camera centre in the world (table) frame, mm.
    pose : GridPose
        The assembly's pose on the table (the grid the description is compiled in).
    forward : (3,) float, optional
        The viewing direction in the world frame (its horizontal part is used);
        default: from the centre towards the middle of the grid's footprint.
    geometry : LogGeometry
        Grid spacing and layer heights.

    Examples
    --------
    >>> import numpy as np
    >>> from unseeable.domain import GridPose
    >>> vp = Viewpoint(np.array([0.0, 500.0, -1000.0]), GridPose(0.0, 0.0, 0.0))
    >>> bearing = vp.lateral(np.array([[0, 0, 0], [4, 0, 0]]))
    >>> bool(bearing[1] < bearing[0])   # seen from -z, larger i lies to the left
    True
    """

    centre: np.ndarray
    pose: GridPose
    forward: np.ndarray | None = None
    geometry: LogGeometry = field(default_factory=LogGeometry)

    def __post_init__(self) -> None:
        centre = np.asarray(self.centre, dtype=float)
        if centre.shape != (3,) or not np.all(np.isfinite(centre)):
            raise InputError("must be 3 finite numbers (mm, world frame)", field="centre",
                             value=getattr(self.centre, "tolist", lambda: self.centre)())
        object.__setattr__(self, "centre", centre)
        if not isinstance(self.pose, GridPose):
            raise InputError("must be a GridPose", field="pose", value=self.pose)
        if self.forward is not None:
            forward = np.asarray(self.forward, dtype=float)
            if forward.shape != (3,) or not np.all(np.isfinite(forward)) \
                    or np.hypot(forward[0], forward[2]) < 1e-9:
                raise InputError("must be 3 finite numbers with a horizontal part",
                                 field="forward", value=forward.tolist())
            object.__setattr__(self, "forward", forward)

    @classmethod
    def from_camera(cls, camera: Any, pose: GridPose, *,
                    geometry: LogGeometry = LogGeometry()) -> Viewpoint:
        """The viewpoint of a calibrated camera (:class:`~unseeable.camera.Camera`): its
        centre, and its optical axis as the viewing direction."""
        R = np.asarray(camera.R, dtype=float)
        forward = R[2]  # the camera's +z axis in the world frame
        if np.hypot(forward[0], forward[2]) < 1e-9:
            forward = None  # looking straight down: towards the grid instead
        return cls(np.asarray(camera.centre, dtype=float), pose, forward, geometry)

    @classmethod
    def from_view(cls, view: Any, *, pose: GridPose | None = None,
                  geometry: LogGeometry = LogGeometry()) -> Viewpoint:
        """The viewpoint of a view (:class:`~unseeable.render.view.View`) at ``pose``
        (default: the view's recorded pose)."""
        pose = pose if pose is not None else getattr(view, "pose", None)
        if pose is None:
            raise InputError("the view has no recorded pose; left and right need the "
                             "assembly's pose (give pose=, e.g. an estimate's)", field="pose",
                             value=None)
        return cls.from_camera(view.camera, pose, geometry=geometry)

    def world_points(self, points: np.ndarray) -> np.ndarray:
        """Grid indices ``(N, 3)`` as world points ``(N, 3)`` (mm)."""
        g = np.asarray(points, dtype=float).reshape(-1, 3)
        grid_mm = np.stack([g[:, 0] * self.geometry.l1, self.geometry.layer_height(g[:, 1]),
                            g[:, 2] * self.geometry.l1], axis=1)
        return self.pose.grid_to_world(grid_mm)

    def lateral(self, points: np.ndarray, extent: Extent | None = None) -> np.ndarray:
        """Bearings of grid points from the camera centre, radians, positive to the right.

        Parameters
        ----------
        points : (N, 3) int or float
            Grid indices ``(i, j, k)``.
        extent : Extent, optional
            Without :attr:`forward`, the bearings are measured from the direction of
            the middle of this extent's footprint (else of the points' mean). Only the
            order of bearings matters, and it is the same from any direction in front
            of the viewer.

        Returns
        -------
        (N,) float
        """
        world = self.world_points(points)
        if self.forward is not None:
            forward = self.forward
        else:
            if extent is not None:
                middle = np.array([[(extent.I - 1) / 2, 0.0, (extent.K - 1) / 2]])
                target = self.world_points(middle)[0]
            else:
                target = world.mean(axis=0) if len(world) else self.centre + [0, 0, 1]
            forward = target - self.centre
        forward = np.array([forward[0], 0.0, forward[2]])
        norm = np.linalg.norm(forward)
        forward = forward / norm if norm > 1e-9 else np.array([0.0, 0.0, 1.0])
        right = np.cross(forward, _UP)
        v = world - self.centre
        return np.arctan2(v @ right, v @ forward)


def lateral_coordinates(viewpoint: Any, points: np.ndarray,
                        extent: Extent | None = None) -> np.ndarray:
    """Lateral coordinates (increasing to the viewer's right) of grid points.

    Parameters
    ----------
    viewpoint : None, Viewpoint, (centre, GridPose) or callable
        None: the default viewer (:data:`DEFAULT_VIEWER`, coordinate ``-i``); a
        callable maps ``(N, 3)`` grid indices to ``(N,)`` coordinates.
    points : (N, 3)
        Grid indices ``(i, j, k)``.
    extent : Extent, optional
        The grid (a :class:`Viewpoint` measures bearings from its middle).

    Returns
    -------
    (N,) float

    Raises
    ------
    InputError
        A viewpoint of another type, or a function that does not return one finite
        number per point.
    """
    pts = np.asarray(points, dtype=float).reshape(-1, 3)
    if viewpoint is None:
        return -pts[:, 0]
    if isinstance(viewpoint, tuple) and len(viewpoint) == 2 \
            and isinstance(viewpoint[1], GridPose):
        viewpoint = Viewpoint(np.asarray(viewpoint[0], dtype=float), viewpoint[1])
    if isinstance(viewpoint, Viewpoint):
        return viewpoint.lateral(pts, extent)
    if callable(viewpoint):
        out = np.asarray(viewpoint(pts), dtype=float)
        if out.shape != (len(pts),) or not np.all(np.isfinite(out)):
            raise InputError("a viewpoint function must return one finite number per grid "
                             "point", field="viewpoint", value=out.shape)
        return out
    raise InputError("must be None, a Viewpoint, (camera centre, GridPose) or a function "
                     "from grid points to lateral coordinates", field="viewpoint",
                     value=type(viewpoint).__name__)
