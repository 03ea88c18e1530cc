"""What an action would show: the features no current view saw that its camera would.

An :class:`Action` is a hypothetical observation whose camera (and disassembly level)
is known before its photograph exists: a station of the pendulum arm, a partial
disassembly by the removal arm (every log on layers ``>= L`` taken off), or both.
:func:`revealed_features` ray-casts the current estimate, truncated for a
disassembly, from the action's camera, in the estimate's one table frame.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from unseeable.domain.features import feature_index
from unseeable.domain.geometry import LogGeometry
from unseeable.errors import InputError

__all__ = ["Action", "unseen_features", "revealed_features"]


@dataclass(frozen=True, eq=False)
class Action:
    """A photograph that could be taken next.

    Parameters
    ----------
    name : str
        How reports name it (e.g. ``"station 120°"``, ``"station 150°, layers ≥ 2 off"``,
        or the candidate's file).
    camera : Camera
        Its calibrated camera, in the table frame of the estimate's views.
    removed_from_layer : int, optional
        The arm takes every log on layers ``>= L`` off before the photograph (``L >= 1``).
    station : float, optional
        The arm's angle, degrees (workspace actions).
    source : Any, optional
        What executes it: the candidate view file, or None for the workspace.

    Examples
    --------
    >>> from unseeable.render.workspace import PendulumArm
    >>> Action("station 120°", PendulumArm().camera(120.0), station=120.0).removed_from_layer
    """

    name: str
    camera: Any
    removed_from_layer: int | None = None
    station: float | None = None
    source: Any = None

    def __post_init__(self) -> None:
        layer = self.removed_from_layer
        if layer is not None and (isinstance(layer, bool)
                                  or not isinstance(layer, (int, np.integer)) or layer < 1):
            raise InputError("must be a layer number >= 1", field="removed_from_layer",
                             value=layer)

    @property
    def disassembles(self) -> bool:
        return self.removed_from_layer is not None


class _Seen:
    """A view record's judged features, in the form :func:`occluded_features` reads."""

    def __init__(self, record) -> None:
        det = record.detection
        self.judged = (np.asarray(det.judged, dtype=bool) if det is not None
                       else np.asarray(record.priors) != 0.5)
        self.removed_from_layer = record.removed_from_layer


def unseen_features(estimate) -> np.ndarray:
    """Features of the estimate's extent that no view of it saw (visible and judged).

    Parameters
    ----------
    estimate : Estimate
        Made from photographs (its views have visibility).

    Returns
    -------
    (N,) bool
    """
    from unseeable.confidence import occluded_features

    records = [v for v in estimate.views if v.visible is not None]
    if estimate.structure is None or not records:
        raise InputError("needs an estimate made from photographs", field="estimate",
                         value="no structure" if estimate.structure is None else "no views")
    return occluded_features([_Seen(v) for v in records], [v.visible for v in records],
                             estimate.structure.extent)


def revealed_features(estimate, actions: Sequence[Action], *,
                      unseen: np.ndarray | None = None,
                      geometry: LogGeometry = LogGeometry(),
                      threshold: float | None = None) -> np.ndarray:
    """Per action, the features no current view saw that its photograph would show.

    A feature is shown when it lies inside the action's image, is visible from its
    camera against the estimate (with the logs the action removes left out), and,
    for a disassembly to layer ``L``, lies below ``L`` (removing logs changes the
    features on layer ``L`` and above).

    Parameters
    ----------
    estimate : Estimate
        Its structure and reference pose place the grid in the table frame.
    actions : sequence of Action
    unseen : (N,) bool, optional
        :func:`unseen_features` of the estimate, when the caller has it.
    threshold : float, optional
        The occluded share of a feature's rays from which it counts as hidden
        (default: the visibility fixpoint's).

    Returns
    -------
    (A, N) bool
    """
    from unseeable.visibility.occlusion import DEFAULT_THRESHOLD, feature_visibility
    from unseeable.vision.projection import project_features

    structure, pose = estimate.structure, estimate.pose
    if pose is None:
        raise InputError("needs an estimate with a pose (made from photographs)",
                         field="estimate", value="no pose")
    if unseen is None:
        unseen = unseen_features(estimate)
    extent = structure.extent
    layer = feature_index(extent).at[:, 1]
    out = np.zeros((len(actions), len(unseen)), dtype=bool)
    for n, action in enumerate(actions):
        if not isinstance(action, Action):
            raise InputError("must be an Action", field=f"actions[{n}]",
                             value=type(action).__name__)
        cut = action.removed_from_layer
        shown = structure if cut is None else structure.removed_from_layer(cut)
        visible = feature_visibility(shown, action.camera.centre, pose, geometry=geometry,
                                     threshold=DEFAULT_THRESHOLD if threshold is None
                                     else threshold)
        visible &= project_features(extent, pose, action.camera).in_image
        if cut is not None:
            visible &= layer < cut
        out[n] = visible & unseen
    return out
