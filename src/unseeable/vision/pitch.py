"""The pitch check: whether the grid sits one pitch off the assembly (:func:`pitch_shift`).

A grid moved by a whole pitch puts every line where a line was; the
detections on a grid grown by one position on every side tell the two
apart. The pose choice (:func:`~unseeable.vision.select_pose`) runs the check
when its choice's implied structure leaves a side of the extent (nearly)
empty (:func:`fills_extent`).
"""

from __future__ import annotations

import logging
from typing import TYPE_CHECKING

import numpy as np

from unseeable.camera import Camera
from unseeable.domain import EMPTY, Evidence, Extent, GridPose, LogGeometry, Structure
from unseeable.errors import check_whole_number
from unseeable.vision.calibration import Calibration
from unseeable.vision.edges import EdgeMaps
from unseeable.vision.evidence import detect_features

if TYPE_CHECKING:  # the solver is imported only when a check is to be made
    from unseeable.solve import StructureSolver

__all__ = ["PITCH_MIN_GAIN", "fills_extent", "pitch_shift"]

logger = logging.getLogger(__name__)

#: Log-likelihood margin (nats) a pose one grid pitch away needs to replace the choice.
PITCH_MIN_GAIN = 3.0


def fills_extent(structure: Structure | None, *, min_positions: int = 2) -> bool:
    """Whether ``structure`` holds logs on all four sides of its extent's footprint.

    Under a grid one pitch off the assembly, the extent's row on one side
    lies beyond it, and a structure estimated there has nothing on that side
    but what the detectors made up (one log position, in the one render of
    the validation sets where the check mattered). A structure with at least
    ``min_positions`` grid positions on every side says the grid is on the
    assembly (or the assembly is larger than the extent, which a shift would
    not mend either).

    Parameters
    ----------
    structure : Structure or None
    min_positions : int
        Grid positions (any layer) each side needs.

    Returns
    -------
    bool

    Examples
    --------
    >>> from unseeable.domain import Extent, Log
    >>> fills_extent(Structure(Extent(2, 1, 1), [Log(layer=0, at=(0, 0), notches=2)]))
    False
    >>> fills_extent(Structure(Extent(2, 1, 1), [Log(layer=0, at=(0, 0), notches=2)]),
    ...              min_positions=1)
    True
    """
    check_whole_number(min_positions, field="min_positions", minimum=0)
    if structure is None:
        return False
    occupied = structure.occupancy != EMPTY
    sides = (occupied[0], occupied[-1], occupied[:, :, 0], occupied[:, :, -1])
    return all(int(np.count_nonzero(side)) >= min_positions for side in sides)


def pitch_shift(image: np.ndarray, camera: Camera, extent: Extent, pose: GridPose, *,
                calibration: Calibration | None = None, geometry: LogGeometry = LogGeometry(),
                time_limit: float = 5.0, solver: StructureSolver | None = None,
                min_gain: float = PITCH_MIN_GAIN, maps: EdgeMaps | None = None
                ) -> tuple[GridPose, Structure | None, float]:
    """The pose, or the pose one grid pitch along an axis when the detections say so.

    A grid moved by a whole pitch (``l1``) puts every line where a line was:
    edges cannot tell the two apart, and the per-feature structure gain of
    :func:`~unseeable.vision.select_pose` prefers a grid partly off the assembly (its features
    are mostly empty, which is easy to judge). Here the poses are compared on
    *the same features*: the detectors judge the extent grown by one
    position on every side, and each placement of the extent in it scores
    the MAP log-probability of its window plus ``log(1 - p_f)`` of every
    judged feature outside it (nothing may lie outside the extent). The
    centre is kept unless a neighbour (one pitch along ``i`` or ``k``) beats
    it by ``min_gain`` nats.

    Parameters
    ----------
    image : (H, W, 3) uint8
    camera : Camera
    extent : Extent
    pose : GridPose
    calibration : Calibration, optional
    geometry : LogGeometry
    time_limit : float
    solver : StructureSolver, optional
        For ``extent``.
    min_gain : float
        Log-likelihood margin a neighbour needs.
    maps : EdgeMaps, optional
        Precomputed edge maps of ``image``.

    Returns
    -------
    pose : GridPose
        ``pose`` or its shift.
    structure : Structure or None
        The MAP structure of the returned pose's window.
    gain : float
        Its log-likelihood margin over the centre (0 when the centre is kept).
    """
    from unseeable.domain import feature_index

    if solver is None:
        from unseeable.solve import StructureSolver

        solver = StructureSolver(extent)
    I, J, K = extent.shape
    grown = Extent(I + 2, J, K + 2)
    corner = pose.grid_to_world(np.array([[-geometry.l1, 0.0, -geometry.l1]]))[0]
    det = detect_features(image, camera, GridPose(float(corner[0]), float(corner[2]),
                                                  pose.yaw_deg),
                          grown, calibration=calibration, refine=False, geometry=geometry,
                          maps=maps)
    outer, inner = feature_index(grown), feature_index(extent)
    absent = np.where(det.judged, np.log(np.clip(1.0 - det.p, 1e-12, 1.0)), np.log(0.5))
    results = {}
    for a, b in ((1, 1), (0, 1), (2, 1), (1, 0), (1, 2)):
        inside = ((outer.at[:, 0] >= a) & (outer.at[:, 0] < a + I)
                  & (outer.at[:, 2] >= b) & (outer.at[:, 2] < b + K))
        at = outer.at[inside] - np.array([a, 0, b])
        target = inner.lookup_many(outer.kind[inside], at)
        priors = np.full(len(inner), 0.5)
        priors[target] = np.where(det.judged[inside], det.p[inside], 0.5)
        outside = float(absent[~inside].sum())
        if (a, b) != (1, 1) and (1, 1) in results:
            # No structure beats every feature's likelier value: a neighbour that cannot
            # reach the margin even so needs no solve (the choice is the same).
            bound = float(np.sum(np.log(np.maximum(priors, 1.0 - priors)))) + outside
            if bound < results[(1, 1)][0] + min_gain:
                continue
        result = solver.solve(Evidence(extent, priors), time_limit=time_limit)
        if result.structure is None:
            continue
        results[(a, b)] = (result.log_probability + outside, result.structure)
    if (1, 1) not in results:
        return pose, None, 0.0
    centre = results[(1, 1)][0]
    (a, b), (value, structure) = max(results.items(), key=lambda kv: kv[1][0])
    if (a, b) == (1, 1) or value < centre + min_gain:
        return pose, results[(1, 1)][1], 0.0
    origin = pose.grid_to_world(np.array([[(a - 1) * geometry.l1, 0.0, (b - 1) * geometry.l1]]))[0]
    logger.debug("pose moved one pitch (%+d, %+d): log-likelihood %+.2f", a - 1, b - 1,
                 value - centre)
    return GridPose(float(origin[0]), float(origin[2]), pose.yaw_deg), structure, value - centre
