"""One photograph as the estimator takes it: an :class:`Observation`."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from unseeable.domain.features import feature_index
from unseeable.domain.frames import GridPose
from unseeable.errors import InputError

__all__ = ["Observation"]


@dataclass(frozen=True, eq=False)
class Observation:
    """One photograph and what is known about it before estimating.

    Parameters
    ----------
    view : View
        The image, its calibrated camera, the extent and ``removed_from_layer`` (the
        arm had removed every log on layers ``>= L``).
    pose : GridPose, optional
        The assembly's pose when known; None: found from the image
        (:func:`~unseeable.pipeline.find_pose`).
    source : str, optional
        The file the view came from (for messages and the estimate file).
    manual_visibility : (N,) bool, optional
        Use this visibility (e.g. annotated, or the ground truth's) instead of the
        visibility fixpoint; needs a known pose.

    Examples
    --------
    >>> import numpy as np
    >>> from unseeable.camera import Camera
    >>> from unseeable.domain import Extent
    >>> from unseeable.render.view import View
    >>> cam = Camera.look_at(eye=[0, 500, -800], target=[0, 0, 0], width=4, height=3,
    ...                      fov_deg=50)
    >>> obs = Observation.of(View(np.zeros((3, 4, 3), np.uint8), cam, Extent(2, 2, 2)))
    >>> obs.pose is None, obs.removed_from_layer
    (True, None)
    """

    view: Any
    pose: GridPose | None = None
    source: str | None = None
    manual_visibility: np.ndarray | None = None

    def __post_init__(self) -> None:
        if self.pose is not None and not isinstance(self.pose, GridPose):
            raise InputError("must be a GridPose", field="pose", value=self.pose)
        if self.source is not None:
            object.__setattr__(self, "source", str(self.source))
        if self.manual_visibility is not None:
            vis = np.asarray(self.manual_visibility, dtype=bool)
            n = len(feature_index(self.extent))
            if vis.shape != (n,):
                raise InputError(f"must have one entry per feature ({n})",
                                 field="manual_visibility", value=vis.shape)
            if self.pose is None:
                raise InputError("needs a known pose (give pose=)",
                                 field="manual_visibility", value="given without a pose")
            object.__setattr__(self, "manual_visibility", vis)

    @classmethod
    def of(cls, view, *, use_recorded_pose: bool = True, pose: GridPose | None = None,
           source: str | Path | None = None, manual_visibility=None) -> Observation:
        """An observation of ``view``: its recorded pose is known unless
        ``use_recorded_pose`` is False (then found from the image); ``pose`` overrides
        it."""
        known = pose if pose is not None else (view.pose if use_recorded_pose else None)
        return cls(view, pose=known, source=None if source is None else str(source),
                   manual_visibility=manual_visibility)

    @property
    def extent(self):
        return self.view.extent

    @property
    def camera(self):
        return self.view.camera

    @property
    def removed_from_layer(self) -> int | None:
        return self.view.removed_from_layer
