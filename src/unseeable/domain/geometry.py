"""Log dimensions (DESIGN.md §3): the three lengths every geometric computation uses."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from unseeable.errors import InputError

__all__ = ["LogGeometry"]


@dataclass(frozen=True)
class LogGeometry:
    """The paper's l1, l2, l3 in millimetres.

    Parameters
    ----------
    l1 : float
        Notch spacing (distance between grid points along a layer).
    l2 : float
        Log diameter.
    l3 : float
        Distance from a log end to its nearest notch centre.

    Notes
    -----
    Notch slots are ``l2`` wide and ``l2 / 4`` deep, top and bottom, so layer
    ``j``'s axis sits at ``y_j = l2/2 + j*l2/2`` and logs two layers apart touch.

    Examples
    --------
    >>> g = LogGeometry()
    >>> g.log_length(3)
    172.0
    >>> float(g.layer_height(2))
    28.5
    """

    l1: float = 64.0
    l2: float = 19.0
    l3: float = 22.0

    def __post_init__(self) -> None:
        for name in ("l1", "l2", "l3"):
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and np.isfinite(value) and value > 0):
                raise InputError("must be a positive finite length in mm", field=name, value=value)
        if self.l3 < self.l2 / 2:
            raise InputError("l3 must be at least l2/2 (the notch must fit on the log)",
                             field="l3", value=self.l3)
        if self.l1 < self.l2:
            raise InputError("l1 must be at least l2 (notches cannot overlap)",
                             field="l1", value=self.l1)

    @property
    def radius(self) -> float:
        """Log radius, ``l2 / 2``."""
        return self.l2 / 2.0

    @property
    def notch_depth(self) -> float:
        """Depth of each notch slot, ``l2 / 4``."""
        return self.l2 / 4.0

    @property
    def layer_step(self) -> float:
        """Vertical distance between consecutive layers' axes, ``l2 / 2``."""
        return self.l2 / 2.0

    def layer_height(self, j: int | np.ndarray) -> float | np.ndarray:
        """Height above the table of layer ``j``'s log axes: ``l2/2 + j*l2/2``."""
        return self.l2 / 2.0 + np.asarray(j, dtype=float) * self.l2 / 2.0

    def log_length(self, notches: int) -> float:
        """Length of an ``notches``-notch log: ``(m-1)*l1 + 2*l3``."""
        return (notches - 1) * self.l1 + 2.0 * self.l3
