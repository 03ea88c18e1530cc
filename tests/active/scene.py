"""A cabin that hides a log from the start station, photographed by the rasteriser."""

from __future__ import annotations

from unseeable.domain import Extent, Log, Structure
from unseeable.render.raster import RasterLook, rasterise_view
from unseeable.render.view import View
from unseeable.render.workspace import PendulumArm, default_pose

#: Four-course walls on two sides, and a two-notch log on the floor behind the front wall.
HIDDEN_CABIN = Structure(Extent(3, 4, 3), [
    Log(0, (0, 0), 3), Log(0, (0, 2), 3), Log(1, (0, 0), 3), Log(1, (2, 0), 3),
    Log(2, (0, 0), 3), Log(2, (0, 2), 3), Log(3, (0, 0), 3), Log(3, (2, 0), 3),
    Log(0, (0, 1), 2)])
POSE = default_pose(HIDDEN_CABIN.extent)


def raster_view(angle: float, removed_from_layer: int | None = None, *,
                structure=HIDDEN_CABIN, pose=POSE) -> View:
    camera = PendulumArm().camera(angle)
    shown = structure if removed_from_layer is None else \
        structure.removed_from_layer(removed_from_layer)
    image = rasterise_view(shown, pose, camera, look=RasterLook(), seed=int(angle))
    return View(image, camera, structure.extent, pose=pose,
                removed_from_layer=removed_from_layer)


class RasterWorkspace:
    """The simulated table with the rasteriser in place of the path tracer (what
    WorkspaceSource uses of a Workspace: the structure, the arm, observe)."""

    def __init__(self, structure=HIDDEN_CABIN, pose=POSE) -> None:
        self.structure, self.pose, self.arm = structure, pose, PendulumArm()
        self.observed: list[tuple[float, int | None]] = []

    def observe(self, angle: float, *, removed_from_layer: int | None = None) -> View:
        self.observed.append((angle, removed_from_layer))
        return raster_view(angle, removed_from_layer, structure=self.structure, pose=self.pose)
