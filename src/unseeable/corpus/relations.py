"""Proper-subset relations between placed structures, compared physically.

The paper simulates partial disassembly with pairs of corpus structures in a
proper-subset relation: the smaller one is what the arm leaves on the table.
So a relation needs the same placement: two structures are compared through
the world (each log's notches mapped through its structure's pose, DESIGN.md
§3), never by raw grid indices alone; a structure described in a half-turned
grid is the same assembly.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from unseeable.domain import GridPose, LogGeometry, Structure

__all__ = ["physical_logs", "is_proper_subset", "proper_subsets", "truncation_layer"]

#: World coordinates are compared to this many decimals of a millimetre.
_DECIMALS = 2


def physical_logs(structure: Structure, pose: GridPose,
                  geometry: LogGeometry = LogGeometry()) -> frozenset:
    """The structure's logs as placed on the table, comparable between grids.

    Each log is ``(layer, notches, {end notch (x, z), other end notch (x, z)})``
    with world coordinates in mm, rounded to 0.01 mm.

    Returns
    -------
    frozenset of tuple
    """
    if not structure.logs:
        return frozenset()
    ends = np.array([[log.positions()[0], log.positions()[-1]] for log in structure.logs],
                    dtype=float)  # (N, 2, 3) grid indices
    grid = ends * np.array([geometry.l1, 0.0, geometry.l1])
    world = np.round(pose.grid_to_world(grid)[..., [0, 2]], _DECIMALS) + 0.0  # no -0.0
    return frozenset(
        (log.layer, log.notches, frozenset(map(tuple, w.tolist())))
        for log, w in zip(structure.logs, world)
    )


def is_proper_subset(small: Structure, small_pose: GridPose, large: Structure,
                     large_pose: GridPose, geometry: LogGeometry = LogGeometry()) -> bool:
    """Whether every log of ``small`` is a log of ``large`` at the same place, and not vice versa.

    Examples
    --------
    >>> from unseeable.domain import Extent, Log
    >>> a = Structure(Extent(2, 1, 1), [Log(layer=0, at=(0, 0), notches=2)])
    >>> b = Structure(Extent(2, 1, 2), [*a.logs, Log(layer=0, at=(0, 1), notches=2)])
    >>> p = GridPose()
    >>> is_proper_subset(a, p, b, p), is_proper_subset(b, p, a, p)
    (True, False)
    """
    return physical_logs(small, small_pose, geometry) < physical_logs(large, large_pose, geometry)


def proper_subsets(structures: Sequence[Structure], poses: Sequence[GridPose],
                   geometry: LogGeometry = LogGeometry()) -> list[list[int]]:
    """For each structure, the indices of the structures it strictly contains."""
    placed = [physical_logs(s, p, geometry) for s, p in zip(structures, poses)]
    return [[b for b in range(len(placed)) if placed[b] < placed[a]]
            for a in range(len(placed))]


def truncation_layer(small: Structure, large: Structure) -> int | None:
    """``L`` when ``small`` is ``large`` with every log on layers ``>= L`` removed, else None.

    Grids must share their origin; ``small``'s extent may be lower.
    """
    if small.extent.I != large.extent.I or small.extent.K != large.extent.K:
        return None
    top = max((log.layer for log in small.logs), default=-1) + 1
    kept = tuple(log for log in large.logs if log.layer < top)
    if top == 0 or kept != small.logs or len(kept) == len(large.logs):
        return None
    return top
