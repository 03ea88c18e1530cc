"""Brute-force references for tiny extents, independent of the package's grammar code.

Valid structures are enumerated as every way to tile each line with
1-, 2- and 3-notch logs (or nothing), kept when the domain's own
``is_valid`` accepts them. :func:`scores` uses ``Evidence.log_probability``; the readings
below it (features, joints, stacked joints, unsupported notches, the "fewest" order) are
taken from a structure's logs by the definitions in DESIGN.md §2 and the priors'
docstrings, without the package's feature or prior code.
"""

from __future__ import annotations

import itertools
from functools import lru_cache

import numpy as np
from hypothesis import strategies as st

from unseeable.domain import Extent, Structure, is_valid
from unseeable.domain.grid import occupancy_code


def _line_tilings(length: int) -> list[tuple[int, ...]]:
    if length == 0:
        return [()]
    out = []
    for m in (0, 1, 2, 3):
        step = max(m, 1)
        if step > length:
            continue
        head = (0,) if m == 0 else tuple(occupancy_code(m, n) for n in range(m))
        out.extend(head + rest for rest in _line_tilings(length - step))
    return out


def _lines(extent: Extent) -> list[list[tuple[int, int, int]]]:
    I, J, K = extent.shape
    lines = []
    for j in range(J):
        if j % 2 == 0:
            lines += [[(i, j, k) for i in range(I)] for k in range(K)]
        else:
            lines += [[(i, j, k) for k in range(K)] for i in range(I)]
    return lines


@lru_cache(maxsize=64)
def valid_occupancies(extent: Extent) -> np.ndarray:
    """Every valid occupancy of ``extent``: ``(M, I, J, K) int8``."""
    lines = _lines(extent)
    found = []
    for combo in itertools.product(*(_line_tilings(len(line)) for line in lines)):
        z = np.zeros(extent.shape, dtype=np.int8)
        for line, values in zip(lines, combo):
            for q, v in zip(line, values):
                z[q] = v
        if is_valid(Structure.from_occupancy(extent, z)):
            found.append(z)
    out = np.array(found)
    out.setflags(write=False)
    return out


def scores(terms: list, occupancies: np.ndarray) -> np.ndarray:
    """Log-probability of each occupancy under evidence terms (Evidence, removed_from_layer)."""
    total = np.zeros(len(occupancies))
    for evidence, removed in terms:
        for n, z in enumerate(occupancies):
            zz = z.copy()
            if removed is not None:
                zz[:, removed:, :] = 0
            total[n] += evidence.log_probability(zz)
    return total


@st.composite
def tiny_extents(draw, max_positions: int = 8) -> Extent:
    """Extents of at most ``max_positions`` positions (any shape)."""
    while True:
        dims = draw(st.tuples(st.integers(1, 8), st.integers(1, 8), st.integers(1, 8)))
        if int(np.prod(dims)) <= max_positions:
            return Extent(*dims)


def random_priors(extent: Extent, rng: np.random.Generator, occluded: float = 0.4) -> np.ndarray:
    from unseeable.domain import feature_index

    n = len(feature_index(extent))
    p = rng.uniform(0.03, 0.97, n)
    p[rng.random(n) < occluded] = 0.5
    return p


def _notches(log) -> list[tuple[int, int, int]]:
    """Grid positions of a log's notches, from notch 0: along i on even layers, k on odd."""
    i, k = log.at
    if log.layer % 2 == 0:
        return [(i + n, log.layer, k) for n in range(log.notches)]
    return [(i, log.layer, k + n) for n in range(log.notches)]


def _next(q: tuple[int, int, int]) -> tuple[int, int, int]:
    """n(q): the next position along q's layer axis."""
    i, j, k = q
    return (i + 1, j, k) if j % 2 == 0 else (i, j, k + 1)


def features_from_logs(structure: Structure) -> np.ndarray:
    """Every feature's presence ``(N,) bool``, read from the logs by DESIGN.md §2 (e)–(g),
    in the documented order: end-, end+ over (I, J, K); u, v, w over (I, J + 2, K); each
    in C order."""
    I, J, K = structure.extent.shape
    end_minus = np.zeros((I, J, K), bool)
    end_plus = np.zeros((I, J, K), bool)
    occupied = np.zeros((I, J + 2, K), bool)  # the log's own layer
    spans = np.zeros((I, J + 2, K), bool)  # the log continues from here to n(q)
    for log in structure.logs:
        notches = _notches(log)
        end_minus[notches[0]] = True
        end_plus[notches[-1]] = True
        for q in notches:
            occupied[q] = True
        for q in notches[:-1]:
            spans[q] = True
    # Segment features of layer j: the log there or the one two layers below (it touches).
    seg_occ = occupied.copy()
    seg_occ[:, 2:] |= occupied[:, :J]
    seg_span = spans.copy()
    seg_span[:, 2:] |= spans[:, :J]
    return np.concatenate([end_minus.ravel(), end_plus.ravel(), seg_occ.ravel(),
                           seg_occ.ravel(), seg_span.ravel()])


def log_likelihood_from_logs(p: np.ndarray, structure: Structure) -> float:
    """Σ_f log p_f(g_f(Z)) with the features read from the logs."""
    present = features_from_logs(structure)
    return float(np.sum(np.where(present, np.log(p), np.log1p(-p))))


def joints_after(structure: Structure) -> np.ndarray:
    """``(I, J, K) bool``: a joint after q — a log's last notch at q and a log at n(q)."""
    extent = structure.extent
    taken = {q for log in structure.logs for q in _notches(log)}
    out = np.zeros(extent.shape, bool)
    for log in structure.logs:
        last = _notches(log)[-1]
        if _next(last) in taken:
            out[last] = True
    return out


def stacked_joints(structure: Structure) -> int:
    """Joints after (i, j, k) with a joint after (i, j + 2, k) too (same axis, one wall)."""
    joints = joints_after(structure)
    return int(np.sum(joints[:, :-2] & joints[:, 2:]))


def unsupported_notches(structure: Structure) -> int:
    """Occupied positions above layer 0 with the position directly below empty."""
    occ = np.zeros(structure.extent.shape, bool)
    for log in structure.logs:
        for q in _notches(log):
            occ[q] = True
    return int(np.sum(occ[:, 1:] & ~occ[:, :-1]))


def habit_cost(structure: Structure, *, joint: float, stacked: float, unsupported: float,
               seen: np.ndarray | None = None) -> float:
    """The nats the three builder's habits charge ``structure``: ``joint`` per joint after
    a ``seen`` position (every one when None), ``stacked`` per stacked pair, ``unsupported``
    per unsupported notch."""
    joints = joints_after(structure)
    if seen is not None:
        joints &= np.asarray(seen, bool)
    return (joint * int(joints.sum()) + stacked * stacked_joints(structure)
            + unsupported * unsupported_notches(structure))


def fewest_key(structure: Structure) -> tuple[int, int, int]:
    """The "fewest" tie policy's order (solve/ties.py): fewest logs, then the most occupied
    positions, then the largest sum of squared log lengths."""
    logs = structure.logs
    return (len(logs), -sum(log.notches for log in logs),
            -sum(log.notches ** 2 for log in logs))


def all_extents(max_positions: int = 8) -> list[Extent]:
    """Every extent of at most ``max_positions`` positions."""
    return [Extent(i, j, k) for i in range(1, max_positions + 1)
            for j in range(1, max_positions + 1) for k in range(1, max_positions + 1)
            if i * j * k <= max_positions]
