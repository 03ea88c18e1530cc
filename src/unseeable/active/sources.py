"""Where actions come from and how they are executed: the simulated robot, or a pool of
photographs.

An :class:`ActionSource` lists the actions available now and executes the one the
planner chose, returning its :class:`~unseeable.pipeline.Observation`. One planner
serves both:

* :class:`WorkspaceSource`: the structure stands on the simulated table; the actions
  are the pendulum arm's stations and the removal arm's disassembly levels; the chosen
  one is rendered (the arm's removal: the truncated structure, from the chosen station)
  and read like any photograph. Disassembly cannot be undone: once layers ``>= L`` are
  off the table, every later photograph shows at most layers below ``L``.
* :class:`PhotographPool`: candidate view files whose camera and
  ``removed_from_layer`` are read to plan; a candidate's image is read only once it is
  chosen (the paper's evaluation, and a robot with recorded stations).
"""

from __future__ import annotations

import logging
from collections.abc import Sequence
from pathlib import Path
from typing import Any, Protocol

from unseeable.active.actions import Action
from unseeable.errors import InputError

__all__ = ["ActionSource", "WorkspaceSource", "PhotographPool", "pool_actions"]

logger = logging.getLogger(__name__)


class ActionSource(Protocol):
    """The actions available and how to take one."""

    def available(self) -> list[Action]:
        """The actions that can be taken now (those taken already left out)."""

    def take(self, action: Action) -> Any:
        """Execute ``action``: its photograph as an Observation."""


def _station_name(angle: float, layer: int | None) -> str:
    name = f"station {angle:g}°"
    return name if layer is None else f"{name}, layers ≥ {layer} off"


class WorkspaceSource:
    """The simulated robot: photographs from the arm's stations, after removals.

    Parameters
    ----------
    workspace : Workspace
        The structure on the table, its arm and renderer.
    stations : sequence of float
        The arm's stations (degrees).
    levels : sequence of int, optional
        Disassembly levels the removal arm may use (default: every layer from 1 to the
        extent's top; ``L`` removes every log on layers ``>= L``). Empty: views only.
    known_pose : bool
        Give the estimator the table's recorded pose (else it keeps the pose it found
        from the first photograph: the closed loop reads nothing from the truth but the
        pictures).
    taken : sequence of (float, int or None)
        Station and level of the photographs taken before (the starting view).
    """

    def __init__(self, workspace, stations: Sequence[float], *,
                 levels: Sequence[int] | None = None, known_pose: bool = False,
                 taken: Sequence[tuple[float, int | None]] = ()) -> None:
        top = workspace.structure.extent.J
        self.workspace = workspace
        self.stations = tuple(float(a) for a in stations)
        if not self.stations:
            raise InputError("needs at least one station", field="stations", value=[])
        if levels is None:
            levels = range(1, top)
        self.levels = tuple(int(n) for n in levels)
        bad = [n for n in self.levels if not 1 <= n < top]
        if bad:
            raise InputError(f"disassembly levels must lie in 1..{top - 1}", field="levels",
                             value=bad)
        self.known_pose = bool(known_pose)
        self.taken: list[tuple[float, int | None]] = [(float(a), lv) for a, lv in taken]
        #: The lowest level removed so far (None: the whole assembly stands).
        self.removed: int | None = None
        self.photographs: list[Any] = []

    def available(self) -> list[Action]:
        arm = self.workspace.arm
        levels: list[int | None] = [None] if self.removed is None else []
        levels += [n for n in self.levels if self.removed is None or n <= self.removed]
        actions = []
        for layer in levels:
            for angle in self.stations:
                if any(abs(angle - a) < 1e-6 and layer == lv for a, lv in self.taken):
                    continue
                actions.append(Action(_station_name(angle, layer), arm.camera(angle),
                                      removed_from_layer=layer, station=angle))
        return actions

    def take(self, action: Action) -> Any:
        from unseeable.pipeline.observation import Observation

        if action.station is None:
            raise InputError("is not a station of the arm", field="action", value=action.name)
        layer = action.removed_from_layer
        if self.removed is not None and (layer is None or layer > self.removed):
            raise InputError(f"layers >= {self.removed} are off the table already",
                             field="action", value=action.name)
        view = self.workspace.observe(action.station, removed_from_layer=layer)
        if layer is not None:
            self.removed = layer if self.removed is None else min(self.removed, layer)
        self.taken.append((action.station, layer))
        self.photographs.append(view)
        return Observation.of(view, use_recorded_pose=self.known_pose, source=action.name)


def pool_actions(paths: Sequence[str | Path], reference) -> list[Action]:
    """Actions for candidate view files (camera and ``removed_from_layer`` read; images
    not), checked against the reference view: the same extent (one table frame), a
    disassembly level inside it."""
    from unseeable.render.view import load_view

    actions = []
    for path in paths:
        view = load_view(path)
        if view.extent != reference.extent:
            raise InputError(f"must be the reference view's {reference.extent} (candidates "
                             "share its table frame)", file=path, field="extent",
                             value=str(view.extent))
        layer = view.removed_from_layer
        if layer is not None and not 1 <= layer <= view.extent.J:
            raise InputError(f"must be a layer from 1 to {view.extent.J}", file=path,
                             field="removed_from_layer", value=layer)
        if layer == view.extent.J:
            layer = None  # removing nothing: a plain view
        actions.append(Action(str(path), view.camera, removed_from_layer=layer,
                              source=view))
    return actions


class PhotographPool:
    """Candidate photographs: planned from their cameras, read once chosen.

    Parameters
    ----------
    actions : sequence of Action
        One per candidate, each with its :class:`~unseeable.render.view.View` as
        ``source`` (:func:`pool_actions` makes them from files).
    known_pose : bool
        Use each candidate's recorded pose (else the estimate's shared one).
    """

    def __init__(self, actions: Sequence[Action], *, known_pose: bool = False) -> None:
        self.actions = list(actions)
        self.known_pose = bool(known_pose)
        self.used: list[Action] = []
        for n, a in enumerate(self.actions):
            if a.source is None:
                raise InputError("needs its view as source", field=f"actions[{n}]",
                                 value=a.name)

    def available(self) -> list[Action]:
        return [a for a in self.actions if all(a is not b for b in self.used)]

    def take(self, action: Action) -> Any:
        from unseeable.pipeline.observation import Observation

        if all(action is not a for a in self.actions):
            raise InputError("is not a candidate of this pool", field="action",
                             value=action.name)
        self.used.append(action)
        logger.info("reading %s", action.name)
        return Observation.of(action.source, use_recorded_pose=self.known_pose,
                              source=action.name)
