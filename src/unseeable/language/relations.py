"""What the nouns and relations mean on the grid: the reference semantics.

* A *window* entity stands at one of :func:`~unseeable.grammar.shapes.placements` of its
  kind; a *door* entity at one whose opening is at least :data:`DOOR_MIN_LAYERS` layers
  high, as every window's is. The shape predicate also admits an opening of two layers
  under a mantel on layer 2 (along ``i``): one log's height at the foot of a wall, which
  nobody calls a door, and which the estimator would otherwise take for "the door" where
  the images leave a taller doorway unclear. A *wall* entity stands at a **minimal
  wall** (2 positions wide, 2 layers high): every wall contains one, and each relation
  that holds for a wall holds for every piece of it (the same plane; a piece of a
  wall left of a door is left of the door), so "some wall satisfies the description"
  and "some minimal wall does" are the same statement, with far fewer placements to
  choose from.
* *perpendicular to*: the two planes differ in direction (a wall along ``i``, a
  plane of fixed ``k``, against one along ``k``); *coplanar to*: the same plane
  (direction and fixed coordinate).
* *left of*: every grid point of the subject's rectangle lies left of every grid
  point of the object's, by their lateral coordinates
  (:mod:`~unseeable.language.viewpoint`); *right of* the mirror image. Lateral
  coordinates closer than :data:`LATERAL_TOLERANCE` (relative) are equal: one
  point behind the other is neither left nor right of it.

:func:`compile_description <unseeable.language.compile_description>` states these
as solver constraints; this module checks them directly, for
:func:`~unseeable.language.describe` and for tests.

Examples
--------
>>> from unseeable.domain import Extent
>>> from unseeable.grammar.shapes import Placement
>>> ranks = lateral_ranks(Extent(5, 3, 5), None)   # seen from -k: i grows to the left
>>> door, window = Placement("door", "i", 0, 3, 0, 1), Placement("window", "k", 0, 1, 2, 2)
>>> relation_holds("left_of", door, window, ranks), relation_holds("perpendicular_to",
...                                                                 door, window, ranks)
(True, True)
"""

from __future__ import annotations

from functools import lru_cache
from typing import Any

import numpy as np

from unseeable.domain.grid import Extent
from unseeable.errors import InputError
from unseeable.grammar.shapes import WALL_MIN_HEIGHT, WALL_MIN_WIDTH, Placement, placements
from unseeable.language.syntax import RELATIONS
from unseeable.language.viewpoint import lateral_coordinates

__all__ = ["LATERAL_TOLERANCE", "DOOR_MIN_LAYERS", "entity_placements", "lateral_ranks",
           "rectangle_points", "lateral_span", "relation_holds"]

#: Fewest layers of a door's opening (a window's opening has at least three by its shape).
DOOR_MIN_LAYERS = 3
#: Lateral coordinates within this share of their largest magnitude (at least this much
#: absolutely) count as equal.
LATERAL_TOLERANCE = 1e-9


@lru_cache(maxsize=256)
def entity_placements(kind: str, extent: Extent) -> tuple[Placement, ...]:
    """Where an entity of ``kind`` may stand on ``extent`` (doors: at least
    :data:`DOOR_MIN_LAYERS` layers high; walls: the minimal ones).

    Examples
    --------
    >>> from unseeable.domain import Extent
    >>> len(entity_placements("wall", Extent(3, 2, 1)))   # positions 0-1 and 1-2
    2
    """
    ps = placements(extent, kind)
    if kind == "door":
        ps = tuple(p for p in ps if p.top - p.bottom + 1 >= DOOR_MIN_LAYERS)
    if kind == "wall":
        ps = tuple(p for p in ps if p.width == WALL_MIN_WIDTH
                   and p.top - p.bottom + 1 == WALL_MIN_HEIGHT)
    return ps


def rectangle_points(placement: Placement) -> np.ndarray:
    """The grid points ``(N, 3)`` of a placement's rectangle (a wall's points, an opening's)."""
    return np.array([placement.point(t, j) for j in placement.layers
                     for t in placement.positions], dtype=np.intp).reshape(-1, 3)


def lateral_ranks(extent: Extent, viewpoint: Any) -> np.ndarray:
    """Each grid point's lateral coordinate as a rank: equal coordinates (within
    :data:`LATERAL_TOLERANCE`) share a rank, and ranks grow to the viewer's right.

    Parameters
    ----------
    extent : Extent
    viewpoint : None, Viewpoint, (centre, GridPose) or callable
        See :func:`~unseeable.language.viewpoint.lateral_coordinates`.

    Returns
    -------
    (I, J, K) int
    """
    I, J, K = extent.shape
    grid = np.stack(np.meshgrid(np.arange(I), np.arange(J), np.arange(K), indexing="ij"),
                    axis=-1).reshape(-1, 3)
    x = lateral_coordinates(viewpoint, grid, extent)
    order = np.argsort(x, kind="stable")
    sorted_x = x[order]
    tol = LATERAL_TOLERANCE * max(1.0, float(np.max(np.abs(x))) if len(x) else 1.0)
    # A new rank wherever the sorted coordinates step by more than the tolerance.
    steps = np.concatenate([[0], (np.diff(sorted_x) > tol).astype(np.intp)])
    ranks = np.empty(len(x), dtype=np.intp)
    ranks[order] = np.cumsum(steps)
    return ranks.reshape(I, J, K)


def lateral_span(placement: Placement, ranks: np.ndarray) -> tuple[int, int]:
    """The lowest and highest lateral rank of a placement's rectangle."""
    q = rectangle_points(placement)
    r = ranks[q[:, 0], q[:, 1], q[:, 2]]
    return int(r.min()), int(r.max())


def relation_holds(name: str, a: Placement, b: Placement, ranks: np.ndarray) -> bool:
    """Whether placement ``a`` stands in relation ``name`` to placement ``b``.

    Parameters
    ----------
    name : {"left_of", "right_of", "perpendicular_to", "coplanar_to"}
    a, b : Placement
    ranks : (I, J, K) int
        :func:`lateral_ranks` of the grid.
    """
    if name == "perpendicular_to":
        return a.along != b.along
    if name == "coplanar_to":
        return a.along == b.along and a.plane == b.plane
    if name == "left_of":
        return lateral_span(a, ranks)[1] < lateral_span(b, ranks)[0]
    if name == "right_of":
        return lateral_span(b, ranks)[1] < lateral_span(a, ranks)[0]
    raise InputError(f"must be one of {', '.join(RELATIONS)}", field="relation", value=name)
