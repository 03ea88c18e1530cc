"""Find the doors and windows of a structure (DESIGN.md §4 "Language").

A door or window lies in a wall's vertical plane and is one position wide
(under support constraints (c)/(d) a wider opening cannot carry its mantel).
With ``a`` the wall's axis (``i`` for a plane of fixed ``k``, logs on even
layers; ``k`` for a plane of fixed ``i``, logs on odd layers) and ``c`` the
opening's position along it:

* *mantel*: on a wall-axis layer ``m``, one 3-notch log from ``c - 1`` to ``c + 1``;
* *opening*: every grid point at ``c`` between the threshold and the mantel EMPTY;
* *posts*: on each wall-axis layer inside the opening, the positions ``c - 1``
  and ``c + 1`` occupied, each the end of its log on the opening's side;
* *door*: the opening reaches layer 0 (its threshold, the opening's bottom,
  is EMPTY at the bottom of the structure);
* *window*: the opening sits on a 3-notch threshold log from ``c - 1`` to
  ``c + 1`` on a wall-axis layer.

Both need at least one post layer. This is the reading used to design and
check the corpus; the language stage encodes the same definition as
constraints.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from unseeable.domain import Structure
from unseeable.domain.grid import EMPTY, FIRST_NOTCH, LAST_NOTCH, occupancy_code

__all__ = ["Opening", "find_openings"]

_FIRST3 = occupancy_code(3, 0)
_MIDDLE3 = occupancy_code(3, 1)
_LAST3 = occupancy_code(3, 2)


@dataclass(frozen=True)
class Opening:
    """A door or window found in a structure.

    Attributes
    ----------
    kind : {"door", "window"}
    along : {"i", "k"}
        Direction of the wall's logs.
    plane : int
        The wall plane's fixed coordinate (``k`` for walls along ``i``).
    at : int
        The opening's position along the wall.
    bottom, top : int
        First and last EMPTY layer of the opening.
    """

    kind: str
    along: str
    plane: int
    at: int
    bottom: int
    top: int

    def to_json(self) -> dict:
        return {"kind": self.kind, "along": self.along, "plane": self.plane, "at": self.at,
                "layers": [self.bottom, self.top]}


def _is_span3(line: np.ndarray, c: int, j: int) -> bool:
    return (line[c - 1, j] == _FIRST3 and line[c, j] == _MIDDLE3
            and line[c + 1, j] == _LAST3)


def find_openings(structure: Structure) -> list[Opening]:
    """Every door and window of ``structure``, in plane order.

    Parameters
    ----------
    structure : Structure

    Returns
    -------
    list of Opening

    Examples
    --------
    >>> from unseeable.corpus.plan import Plan, wall, door
    >>> plan = Plan((3, 4, 1))
    >>> wall(plan, "w", along="i", at=0, span=range(3), layers=range(4))
    >>> door(plan, "w", at=1, mantel=2)
    >>> [o.kind for o in find_openings(plan.build())]
    ['door']
    """
    z = structure.occupancy
    ext = structure.extent
    found: list[Opening] = []
    for along, parity in (("i", 0), ("k", 1)):
        planes = ext.K if along == "i" else ext.I
        for plane in range(planes):
            # line[t, j]: the wall plane with t the position along the wall.
            line = z[:, :, plane] if along == "i" else z[plane, :, :].T
            length = line.shape[0]
            wall_layers = [j for j in range(ext.J) if j % 2 == parity]
            for c in range(1, length - 1):
                for m in wall_layers:
                    if not _is_span3(line, c, m):
                        continue
                    # Walk down from the mantel while the column is empty.
                    j = m - 1
                    while j >= 0 and line[c, j] == EMPTY:
                        j -= 1
                    bottom = j + 1
                    if bottom == m:
                        continue
                    if j < 0:
                        kind = "door"
                    elif j % 2 == parity and _is_span3(line, c, j):
                        kind = "window"
                    else:
                        continue
                    posts = [p for p in wall_layers if bottom <= p < m]
                    if posts and all(LAST_NOTCH[line[c - 1, p]] and FIRST_NOTCH[line[c + 1, p]]
                                      for p in posts):
                        found.append(Opening(kind, along, plane, c, bottom, m - 1))
    return found
