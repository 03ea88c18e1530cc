"""The paper's structure error metric (DESIGN.md §5).

On each medial-axis line (a layer and its fixed cross coordinate), logs of
the ground truth and of the estimate that are identical match. The rest form
groups of logs that overlap along the line; a group with r ground-truth and s
estimated logs costs ``min(r, s)`` errors when both are positive, else
``r + s``.

Beyond the paper, each group is told by what went wrong (:class:`ErrorGroup`):
the same notches divided into other logs (``"split"``: the joints misplaced),
notches the truth leaves empty filled (``"extra"``), notches it fills left
empty (``"missing"``), or both (``"mixed"``).

Structures are compared physically: when poses are given, the estimate's logs
are mapped through the world into the truth's grid and snapped to it, so
estimates made under another symbolic orientation or extent compare correctly.
"""

from __future__ import annotations

from collections import defaultdict
from dataclasses import dataclass

import numpy as np

from unseeable.domain.frames import GridPose
from unseeable.domain.geometry import LogGeometry
from unseeable.domain.structure import Extent, Structure
from unseeable.errors import InputError

__all__ = ["Comparison", "ErrorGroup", "compare_structures", "count_errors", "error_histogram",
           "match_features", "snapped_pose", "ERROR_KINDS"]

#: What went wrong in an error group (:class:`ErrorGroup`), in a fixed order.
ERROR_KINDS = ("split", "extra", "missing", "mixed")

# A log on a line: (line key, first notch index along the line, last notch index).
_LineLog = tuple[tuple[int, int, int], int, int]


class _Misaligned(Exception):
    """The estimate's grid does not line up with the truth's."""


def snapped_pose(estimate_pose: GridPose, truth_pose: GridPose, *,
                 geometry: LogGeometry = LogGeometry()) -> GridPose:
    """The pose nearest ``estimate_pose`` whose grid lines up with ``truth_pose``'s: the
    estimate's grid moved onto the truth's by the nearest quarter turn and whole notches.

    What an estimate's structure is, apart from where its pose puts it: a camera whose
    calibration is off makes every pose found for it some millimetres wrong, though the
    logs may all be right.

    Examples
    --------
    >>> truth = GridPose(100.0, -50.0, 30.0)
    >>> est = GridPose(118.0, -41.0, 31.2)  # 20 mm and 1.2° off
    >>> p = snapped_pose(est, truth)
    >>> round(p.x, 6), round(p.z, 6), round(p.yaw_deg, 6)
    (100.0, -50.0, 30.0)
    >>> q = snapped_pose(GridPose(100.0, -50.0, 119.0), truth)  # a quarter turn
    >>> round(q.yaw_deg, 6)
    120.0
    """
    quarter = round((estimate_pose.yaw_deg - truth_pose.yaw_deg) / 90.0)
    origin = truth_pose.world_to_grid(estimate_pose.translation[None])[0]
    notches = np.rint(origin[[0, 2]] / geometry.l1) * geometry.l1
    world = truth_pose.grid_to_world(np.array([[notches[0], 0.0, notches[1]]]))[0]
    return GridPose(float(world[0]), float(world[2]), truth_pose.yaw_deg + 90.0 * quarter)


def _line_logs(structure: Structure, pose: GridPose | None, target: GridPose | None,
               geometry: LogGeometry) -> list[_LineLog]:
    """Each log as (line key (layer, axis, cross), start, stop) in the target grid."""
    out = []
    for log in structure.logs:
        pos = np.array(log.positions(), dtype=float)
        if pose is not None and target is not None:
            mm = pos * np.array([geometry.l1, 1.0, geometry.l1])
            world = pose.grid_to_world(mm)
            grid = target.world_to_grid(world) / np.array([geometry.l1, 1.0, geometry.l1])
            snapped = np.rint(grid).astype(int)
            if np.max(np.abs(grid - snapped)[:, [0, 2]]) > 0.25:
                raise _Misaligned("estimate's grid does not line up with the truth's "
                                  "(poses differ by more than a quarter of a notch)")
            snapped[:, 1] = log.layer
        else:
            snapped = pos.astype(int)
        varies = np.ptp(snapped, axis=0) if len(snapped) > 1 else None
        if varies is None:
            axis = 0 if log.layer % 2 == 0 else 2
        else:
            axis = 0 if varies[0] > 0 else 2
        cross = int(snapped[0, 2 if axis == 0 else 0])
        along = snapped[:, axis]
        out.append(((log.layer, axis, cross), int(along.min()), int(along.max())))
    return out


@dataclass(frozen=True)
class ErrorGroup:
    """Unmatched logs of the truth and the estimate that overlap on one medial-axis line.

    Attributes
    ----------
    line : (int, int, int)
        (layer, axis along which the logs run (0 = i, 2 = k), cross coordinate), in
        the truth's grid.
    start, stop : int
        The first and last notch along the line that the group's logs cover.
    truth_logs, estimate_logs : int
        r and s: the group's logs of the truth and of the estimate.
    errors : int
        ``min(r, s)`` when both are positive, else ``r + s`` (the paper's).
    kind : str
        One of :data:`ERROR_KINDS`: ``"split"`` when both cover the same notches,
        ``"extra"`` when the estimate covers more, ``"missing"`` when it covers fewer,
        ``"mixed"`` otherwise.
    """

    line: tuple[int, int, int]
    start: int
    stop: int
    truth_logs: int
    estimate_logs: int
    errors: int
    kind: str


@dataclass(frozen=True)
class Comparison:
    """Outcome of comparing an estimate with the truth.

    Attributes
    ----------
    errors : int
        The paper's error count.
    truth_correct : (L_truth,) bool
        Whether each ground-truth log (in ``truth.logs`` order) is matched exactly.
    estimate_correct : (L_estimate,) bool
        Whether each estimated log is matched exactly (green in pictures).
    groups : tuple of ErrorGroup
        The groups whose errors make up ``errors``, by line and then along it. When
        the estimate's grid does not line up with the truth's and every log counts,
        one group per log: each truth log missing, each estimated log extra (its line
        in its own grid).
    """

    errors: int
    truth_correct: np.ndarray
    estimate_correct: np.ndarray
    groups: tuple[ErrorGroup, ...] = ()

    def errors_by_kind(self) -> dict[str, int]:
        """Errors summed over the groups of each kind (:data:`ERROR_KINDS`, every kind
        present)."""
        out = dict.fromkeys(ERROR_KINDS, 0)
        for group in self.groups:
            out[group.kind] += group.errors
        return out


def compare_structures(truth: Structure, estimate: Structure, *,
                       truth_pose: GridPose | None = None,
                       estimate_pose: GridPose | None = None,
                       geometry: LogGeometry = LogGeometry(),
                       on_misaligned: str = "raise") -> Comparison:
    """Compare ``estimate`` with ``truth`` log by log (see module docstring).

    ``on_misaligned``: what to do when, with poses, the estimate's grid does not
    line up with the truth's (a wrong pose): ``"raise"`` an :class:`InputError`,
    ``"count"`` every log of both as an error (as the experiments do), or ``"snap"``
    the estimate's grid onto the truth's nearest alignment (:func:`snapped_pose`) and
    compare the logs there: the structure, whatever its pose (for cameras whose
    calibration is off, where no pose lines up).

    Examples
    --------
    >>> from unseeable.domain import Extent, Log
    >>> e = Extent(3, 1, 1)
    >>> truth = Structure(e, [Log(0, (0, 0), 3)])
    >>> est = Structure(e, [Log(0, (0, 0), 1), Log(0, (1, 0), 2)])
    >>> c = compare_structures(truth, est)
    >>> c.errors, c.groups[0].kind
    (1, 'split')
    """
    if on_misaligned not in ("raise", "count", "snap"):
        raise InputError("must be 'raise', 'count' or 'snap'", field="on_misaligned",
                         value=on_misaligned)
    if (truth_pose is None) != (estimate_pose is None):
        raise InputError("give both poses or neither", field="estimate_pose",
                         value=estimate_pose)
    if truth_pose is None and truth.extent != estimate.extent:
        raise InputError(f"extents differ (truth {truth.extent}); give both poses to compare "
                         "physically", field="estimate.extent", value=str(estimate.extent))
    t_logs = _line_logs(truth, truth_pose, truth_pose, geometry)
    try:
        e_logs = _line_logs(estimate, estimate_pose, truth_pose, geometry)
    except _Misaligned as err:
        if on_misaligned == "raise":
            raise InputError(str(err), field="estimate_pose",
                             value=estimate_pose.to_json()) from None
        if on_misaligned == "count":
            # Nothing matches: every truth log is missed and every estimated log extra.
            groups = tuple([ErrorGroup(key, a, b, 1, 0, 1, "missing") for key, a, b in t_logs]
                           + [ErrorGroup(key, a, b, 0, 1, 1, "extra")
                              for key, a, b in _line_logs(estimate, None, None, geometry)])
            return Comparison(len(groups), np.zeros(len(truth.logs), dtype=bool),
                              np.zeros(len(estimate.logs), dtype=bool), groups)
        # "snap": the snapped grid lines up by construction.
        e_logs = _line_logs(estimate, snapped_pose(estimate_pose, truth_pose,
                                                   geometry=geometry), truth_pose, geometry)
    t_ok = np.zeros(len(t_logs), dtype=bool)
    e_ok = np.zeros(len(e_logs), dtype=bool)
    t_index = {log: n for n, log in enumerate(t_logs)}
    for n, log in enumerate(e_logs):
        m = t_index.get(log)
        if m is not None:
            t_ok[m] = True
            e_ok[n] = True
    # Group the unmatched logs of each line by overlap (connected runs of intervals).
    lines: dict[tuple[int, int, int], list[tuple[int, int, int]]] = defaultdict(list)
    for n, (key, a, b) in enumerate(t_logs):
        if not t_ok[n]:
            lines[key].append((a, b, 0))
    for n, (key, a, b) in enumerate(e_logs):
        if not e_ok[n]:
            lines[key].append((a, b, 1))
    groups = []
    for key in sorted(lines):
        items = sorted(lines[key])
        run: list[tuple[int, int, int]] = []
        reach = -1
        for item in items:
            if run and item[0] > reach:
                groups.append(_error_group(key, run))
                run = []
            run.append(item)
            reach = max(reach, item[1])
        groups.append(_error_group(key, run))
    return Comparison(sum(g.errors for g in groups), t_ok, e_ok, tuple(groups))


def _error_group(line: tuple[int, int, int], run: list[tuple[int, int, int]]) -> ErrorGroup:
    """One group from its logs ``(start, stop, 0 = truth / 1 = estimate)``."""
    covered: tuple[set[int], set[int]] = (set(), set())
    for a, b, side in run:
        covered[side].update(range(a, b + 1))
    r = sum(1 for *_, side in run if side == 0)
    s = len(run) - r
    truth, estimate = covered
    kind = ("split" if truth == estimate else "extra" if truth < estimate
            else "missing" if estimate < truth else "mixed")
    return ErrorGroup(line, min(a for a, _, _ in run), max(b for _, b, _ in run), r, s,
                      min(r, s) if r > 0 and s > 0 else r + s, kind)


def match_features(extent: Extent, pose: GridPose, target_extent: Extent, target_pose: GridPose,
                   *, geometry: LogGeometry = LogGeometry(), tol_mm: float = 3.0) -> np.ndarray:
    """Which feature of ``target_extent`` (at ``target_pose``) each feature of ``extent`` is.

    Features are matched physically, by the midpoint of their axis stretch in the
    world (distinct midpoints are ≥ 9 mm apart), so that an estimate numbered under
    another symbolic orientation (a half or quarter turn of the grid) compares with
    the truth feature by feature.

    Returns
    -------
    (N,) int
        Index into ``target_extent``'s features, ``-1`` where none lies within ``tol_mm``.

    Examples
    --------
    >>> from unseeable.domain import Extent, GridPose
    >>> e = Extent(2, 1, 1)
    >>> same = match_features(e, GridPose(), e, GridPose())
    >>> bool((same == np.arange(len(same))).all())
    True
    >>> turned = GridPose(64.0, 0.0, 180.0)  # the same grid, numbered from the other end
    >>> m = match_features(e, turned, e, GridPose())
    >>> m[:4].tolist()  # the four log ends, numbered from the other side
    [3, 2, 1, 0]
    >>> int((m < 0).sum())  # stretches off the grid's far side have no counterpart
    4
    """
    from scipy.spatial import cKDTree

    from unseeable.domain.features import feature_axes

    def midpoints(ext: Extent, p: GridPose) -> np.ndarray:
        return p.grid_to_world(feature_axes(ext, geometry).mean(axis=1))

    dist, idx = cKDTree(midpoints(target_extent, target_pose)).query(midpoints(extent, pose))
    return np.where(dist <= tol_mm, idx, -1)


def count_errors(truth: Structure, estimate: Structure, **kwargs) -> int:
    """The paper's error count between two structures (see :func:`compare_structures`)."""
    return compare_structures(truth, estimate, **kwargs).errors


def error_histogram(errors, *, max_errors: int | None = None) -> np.ndarray:
    """Share of images with at most t errors, for t = 0..max_errors.

    Parameters
    ----------
    errors : (M,) int
        Error count of each image.
    max_errors : int, optional
        Last t (default: the largest count seen).

    Returns
    -------
    (max_errors + 1,) float
        Non-decreasing, ending at 1.0 when ``max_errors`` ≥ the largest count.

    Examples
    --------
    >>> error_histogram([0, 0, 1, 3]).tolist()
    [0.5, 0.75, 0.75, 1.0]
    """
    e = np.asarray(errors, dtype=int).ravel()
    if e.size == 0:
        raise InputError("needs at least one image", field="errors", value=[])
    if np.any(e < 0):
        raise InputError("error counts are non-negative", field="errors", value=int(e.min()))
    top = int(e.max()) if max_errors is None else int(max_errors)
    t = np.arange(top + 1)
    return (e[None, :] <= t[:, None]).mean(axis=1)
