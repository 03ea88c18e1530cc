"""Resolving exact ties of the MAP estimate by a cost on logs.

Occluded regions hold exactly tied structures: a hidden interior filled or
not, a wall's 3-notch log or a 1- and a 2-notch log whose joint nobody saw,
a hidden bottom course with or without a gap. The solver returns an
arbitrary member of the tie; a tie policy says which member to keep by a
cost linear in the structure (:class:`TieCost`):

* "emptiest": the fewest occupied positions plus logs — nothing unseen is
  asserted without need, so hidden walls may keep gaps;
* "fewest": the fewest logs, then the most occupied positions, then the
  largest sum of squared log lengths (a 3- and a 1-notch log rather than
  two 2-notch ones) — the simplest account in pieces, built of the longest
  logs that fit, as walls are built (docs/decisions.md).

Asking the solver for the cheapest member directly (a tiny cost in the
objective it maximises) was measured to make real-evidence solves one to
three orders of magnitude slower — the search must then tell apart
thousands of tied structures (a 6×7×5 cabin: 0.02 s without, 13 s with) —
so ties are resolved after the exact solve instead, by local moves that
never lower the log-probability:

* remove a log (top layers first, so supports go last);
* shorten a log by its first or last notch;
* merge two logs that meet end to end on one line into one of ≤ 3 notches;
* move the joint between two such logs by a notch;
* lengthen a log by a notch at its end or its start, into empty space.

A move is kept when it lowers the cost, the structure stays valid, every
hard constraint still holds and the log-probability does not drop (within
``tolerance``); moves are tried in a fixed order until none applies, so the
result is deterministic. The result is a MAP estimate (same
log-probability) that is locally cheapest: no single move above lowers its
cost without losing probability.

:func:`neighbours` lists every valid structure one move away, these moves and
the reverses that add (a new log, a log split): where
:meth:`~unseeable.solve.StructureSolver.find_better` looks first.
"""

from __future__ import annotations

import functools
import logging
from collections.abc import Callable, Iterable
from dataclasses import dataclass

import numpy as np

from unseeable.domain.grid import EMPTY, Extent, occupancy_code
from unseeable.domain.structure import Log, Structure
from unseeable.errors import InputError

logger = logging.getLogger(__name__)

__all__ = ["TieCost", "TIE_POLICIES", "tie_cost", "resolve_tie", "neighbours", "flat_changes"]

#: Tie policies that resolve a tie by a cost (besides "any": the backend's member).
TIE_POLICIES = ("emptiest", "fewest")


@dataclass(frozen=True)
class TieCost:
    """What a tie policy minimises: ``position`` per occupied position, ``log`` per log,
    and ``square`` times the square of each log's notch count.

    Examples
    --------
    >>> s = Structure(Extent(3, 1, 1), (Log(0, (0, 0), 3),))
    >>> TieCost(position=1, log=1)(s)
    4
    >>> TieCost(position=0, log=0, square=-1)(s)   # one 3-notch log
    -9
    """

    position: int
    log: int
    square: int = 0

    def __call__(self, structure: Structure) -> int:
        return self.of(structure.logs)

    def of(self, logs: Iterable[Log]) -> int:
        """The cost of some logs."""
        return sum(self.per_log(log.notches) for log in logs)

    def per_log(self, notches: int) -> int:
        """The cost of one log of ``notches`` notches."""
        return self.position * notches + self.log + self.square * notches * notches


#: The "emptiest" policy's cost: one per occupied position and one per log.
EMPTIEST = TieCost(position=1, log=1)


def tie_cost(policy: str, extent: Extent) -> TieCost:
    """The cost that tie policy ``policy`` minimises on ``extent`` (module docstring).

    "fewest" is lexicographic: the count of logs first, then the occupied
    positions, then the sum of the squared log lengths (a 3- and a 1-notch log
    before two 2-notch logs: the longest logs that fit). Each weight exceeds
    the most that everything after it can change on ``extent``.
    """
    if policy == "emptiest":
        return EMPTIEST
    if policy == "fewest":
        squares = 9 * extent.positions  # above Σ notches², at most 3 per occupied position
        position = squares + 1
        return TieCost(position=-position, log=position * extent.positions + squares + 1,
                       square=-1)
    raise InputError(f"has no cost; expected one of {list(TIE_POLICIES)}", field="ties",
                     value=policy)


#: A log as the moves handle it: (layer, i, k, notches), ordered as :class:`Log` orders.
_Key = tuple[int, int, int, int]


def _key(log: Log) -> _Key:
    return (log.layer, log.at[0], log.at[1], log.notches)


def _along(key: _Key, notches: int) -> tuple[int, int]:
    """Grid (i, k) that many notches from the log's first along its line (negative: back)."""
    layer, i, k, _ = key
    return (i + notches, k) if layer % 2 == 0 else (i, k + notches)


@functools.lru_cache(maxsize=1 << 16)
def _positions(key: _Key) -> tuple[tuple[int, int, int], ...]:
    """The log's grid positions from notch 0 (as :meth:`Log.positions`)."""
    j, i, k, m = key
    if j % 2 == 0:
        return tuple((i + n, j, k) for n in range(m))
    return tuple((i, j, k + n) for n in range(m))


def _moves(logs: Iterable[_Key]) -> Iterable[tuple[tuple[_Key, ...], tuple[_Key, ...]]]:
    """Moves ``(logs taken out, logs put in)`` of a structure's logs, in a fixed order
    (module docstring)."""
    logs = sorted(logs, key=lambda t: (-t[0], t))  # top layers first
    for log in logs:
        yield (log,), ()
    for log in logs:
        if log[3] > 1:
            # Drop the last notch, or the first (the log then starts one position on).
            yield (log,), ((log[0], log[1], log[2], log[3] - 1),)
            yield (log,), ((log[0], *_along(log, 1), log[3] - 1),)
    starts = {(log[0], log[1], log[2]): log for log in logs}
    # Pairs of logs that meet end to end on one line, in the order of the first.
    pairs = [(log, starts[key]) for log in logs
             if (key := (log[0], *_along(log, log[3]))) in starts]
    for log, nxt in pairs:
        if log[3] + nxt[3] <= 3:
            yield (log, nxt), ((log[0], log[1], log[2], log[3] + nxt[3]),)
    for log, nxt in pairs:
        # Move their joint by a notch either way (same logs and positions: only a cost on
        # lengths can prefer one).
        if log[3] < 3 and nxt[3] > 1:
            yield (log, nxt), ((log[0], log[1], log[2], log[3] + 1),
                               (nxt[0], *_along(nxt, 1), nxt[3] - 1))
        if log[3] > 1 and nxt[3] < 3:
            yield (log, nxt), ((log[0], log[1], log[2], log[3] - 1),
                               (nxt[0], *_along(nxt, -1), nxt[3] + 1))
    for log in logs:
        if log[3] < 3:
            # Add a notch at the end, or before the first.
            yield (log,), ((log[0], log[1], log[2], log[3] + 1),)
            yield (log,), ((log[0], *_along(log, -1), log[3] + 1),)


def _held(key: _Key, occupied) -> bool:
    """Constraints (c)/(d) for one log, ``occupied(q)`` saying what is below it."""
    j = key[0]
    if j == 0:
        return True
    held = 0
    for i, _, k in _positions(key):
        held += occupied((i, j - 1, k))
    return held >= (2 if key[3] == 3 else key[3])


#: Occupancy code of notch n of an m-notch log, by (m, n).
_CODES = {(m, n): occupancy_code(m, n) for m in (1, 2, 3) for n in range(m)}


def _placed(put, freed: set, at: dict, shape: tuple[int, int, int]) -> dict | None:
    """Each position the logs ``put`` in occupy, with its occupancy code; None when one
    runs off the grid or onto a log not among those taken out (``freed`` their places,
    ``at`` the logs by position)."""
    I, J, K = shape
    placed = {}
    for log in put:
        for n, q in enumerate(_positions(log)):
            i, j, k = q
            if not (0 <= i < I and 0 <= j < J and 0 <= k < K) or (q not in freed and q in at):
                return None
            placed[q] = _CODES[log[3], n]
    return placed


def _change(taken: tuple[_Key, ...], put: tuple[_Key, ...], at: dict,
            shape: tuple[int, int, int]) -> tuple[set, dict] | None:
    """A move's positions: those its logs taken out free, and each position its logs put
    in occupy with its code; None when a log put in leaves the grid or lies on another
    log, or a log is left without support (constraints (c)/(d)). ``at``: the logs by
    position."""
    freed = {q for log in taken for q in _positions(log)}
    placed = _placed(put, freed, at, shape)
    if placed is None:
        return None
    # The grammar is local: the logs put in (a move's logs lie on one layer, so what is
    # below them is as before), and those resting on emptied places.
    if not all(_held(log, at.__contains__) for log in put):
        return None
    above = {at[i, j + 1, k] for i, j, k in freed
             if (i, j, k) not in placed and (i, j + 1, k) in at}
    if above:
        def occupied(q):  # under the move
            return q in placed or (q not in freed and q in at)

        if not all(_held(log, occupied) for log in above):
            return None
    return freed, placed


def _changed_codes(freed: set, placed: dict) -> dict:
    """A move's new code at each position it changes (``EMPTY`` where it only frees)."""
    return {q: EMPTY for q in freed if q not in placed} | placed


def flat_changes(changed: dict, extent: Extent) -> tuple[np.ndarray, np.ndarray]:
    """A move's changed positions (position -> code) as flat positions
    ``(i * J + j) * K + k`` and their codes, as ``_Scorer.changes`` takes them."""
    _, J, K = extent.shape
    return (np.array([(i * J + j) * K + k for i, j, k in changed], dtype=np.int64),
            np.array(list(changed.values()), dtype=np.int8))


def neighbours(structure: Structure) -> list[tuple[tuple[Log, ...], tuple[Log, ...], dict]]:
    """Every valid structure one move from ``structure``: the tie search's moves
    (:func:`resolve_tie`) and their reverses that add: a new log in empty space, a
    log split in two or three.

    Returns
    -------
    list of (logs taken out, logs put in, changed positions)
        The changed positions map each grid position the move changes to its new
        occupancy code (``EMPTY`` where a log was taken out). In a fixed order.

    Examples
    --------
    >>> s = Structure(Extent(2, 1, 1), (Log(0, (0, 0), 1),))
    >>> [(len(taken), len(put)) for taken, put, _ in neighbours(s)]
    [(1, 0), (1, 1), (0, 1)]
    """
    I, J, K = structure.extent.shape
    logs = [_key(log) for log in structure.logs]
    at = {q: log for log in logs for q in _positions(log)}
    moves = list(_moves(logs))
    for j in range(J):  # new logs, where something below could hold them
        for i in range(I):
            for k in range(K):
                if (i, j, k) in at:
                    continue
                for m in (1, 2, 3):
                    key = (j, i, k, m)
                    if j == 0 or any((p[0], j - 1, p[2]) in at for p in _positions(key)[:2]):
                        moves.append(((), (key,)))
    for log in logs:  # splits
        cuts = [(c,) for c in range(1, log[3])] + ([(1, 2)] if log[3] == 3 else [])
        for cut in cuts:
            ends = (0, *cut, log[3])
            moves.append(((log,), tuple((log[0], *_along(log, a), b - a)
                                        for a, b in zip(ends, ends[1:]))))
    out = []
    for taken, put in moves:
        change = _change(taken, put, at, (I, J, K))
        if change is None:
            continue
        out.append((tuple(Log(j, (i, k), m) for j, i, k, m in taken),
                    tuple(Log(j, (i, k), m) for j, i, k, m in put), _changed_codes(*change)))
    return out


def resolve_tie(structure: Structure, value: Callable[[np.ndarray], float], *,
                cost: TieCost = EMPTIEST,
                allowed: Callable[[np.ndarray], bool] | None = None,
                tolerance: float = 1e-9, max_moves: int = 100_000) -> Structure:
    """The structure after every move that lowers ``cost`` and keeps its value.

    Parameters
    ----------
    structure : Structure
        A MAP estimate (valid).
    value : callable (I, J, K) occupancy -> float
        The log-probability being maximised.
    cost : TieCost
        What to minimise among tied structures (default: "emptiest"'s; see
        :func:`tie_cost`).
    allowed : callable (I, J, K) occupancy -> bool, optional
        Extra hard constraints a candidate must satisfy (the grammar is
        always kept).
    tolerance : float
        A move may lower the value by at most this (float round-off).
    max_moves : int
        Safety bound on accepted moves (each lowers an integer cost that is
        bounded below, so they end anyway).

    Returns
    -------
    Structure
        Same extent, value within ``tolerance`` of the input's, cost no
        higher.

    Examples
    --------
    >>> from unseeable.domain import Extent
    >>> s = Structure(Extent(3, 1, 1), (Log(0, (0, 0), 3),))
    >>> resolve_tie(s, lambda z: 0.0).logs   # nothing is seen: nothing is kept
    ()
    >>> ends_seen = lambda z: -float(np.count_nonzero(z[[0, 2], 0, 0] == 0))
    >>> s = Structure(Extent(3, 1, 1), (Log(0, (0, 0), 1), Log(0, (2, 0), 1)))
    >>> resolve_tie(s, ends_seen).logs == s.logs   # "emptiest": the gap stays
    True
    >>> resolve_tie(s, ends_seen, cost=tie_cost("fewest", s.extent)).logs
    (Log(layer=0, at=(0, 0), notches=3),)
    """
    extent = structure.extent
    z = np.array(structure.occupancy, dtype=np.int8)
    logs = {_key(log) for log in structure.logs}
    at = {q: log for log in logs for q in _positions(log)}  # position -> the log there
    per_log = [cost.per_log(m) if m else 0 for m in range(4)]
    base = value(z)
    moves = 0
    changed = True
    while changed and moves < max_moves:
        changed = False
        # One pass over the moves of the structure at the pass's start; a move whose
        # logs an earlier move of the pass changed is left for the next pass.
        for taken, put in _moves(list(logs)):
            if any(log not in logs for log in taken) or (
                    sum(per_log[log[3]] for log in put)
                    >= sum(per_log[log[3]] for log in taken)):
                continue
            moved = _change(taken, put, at, extent.shape)
            if moved is None:
                continue
            freed, placed = moved
            trial = z.copy()
            for q in freed:
                trial[q] = EMPTY
            for q, c in placed.items():
                trial[q] = c
            if allowed is not None and not allowed(trial):
                continue
            if value(trial) >= base - tolerance:
                z = trial
                logs.difference_update(taken)
                logs.update(put)
                for q in freed:
                    del at[q]
                for log in put:
                    for q in _positions(log):
                        at[q] = log
                moves += 1
                changed = True
    result = Structure(extent, tuple(Log(j, (i, k), m) for j, i, k, m in logs))
    if moves:
        logger.debug("ties: %d moves (%d -> %d logs)", moves, len(structure.logs),
                     len(result.logs))
    return result
