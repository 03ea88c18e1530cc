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
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Iterable
from dataclasses import dataclass

import numpy as np

from unseeable.domain.grid import EMPTY, Extent, occupancy_code
from unseeable.domain.structure import Log, Structure
from unseeable.errors import InputError

logger = logging.getLogger(__name__)

__all__ = ["TieCost", "TIE_POLICIES", "tie_cost", "resolve_tie"]

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


def _along(log: Log, notches: int) -> tuple[int, int]:
    """Grid (i, k) that many notches from ``log``'s first along its line (negative: back)."""
    i, k = log.at
    return (i + notches, k) if Extent.axis(log.layer) == 0 else (i, k + notches)


def _moves(structure: Structure) -> list[tuple[tuple[Log, ...], tuple[Log, ...]]]:
    """Moves ``(logs taken out, logs put in)``, in a fixed order (module docstring)."""
    logs = sorted(structure.logs, key=lambda log: (-log.layer, log))  # top layers first
    moves: list[tuple[tuple[Log, ...], tuple[Log, ...]]] = [((log,), ()) for log in logs]
    for log in logs:
        if log.notches > 1:
            # Drop the last notch, or the first (the log then starts one position on).
            moves.append(((log,), (Log(log.layer, log.at, log.notches - 1),)))
            moves.append(((log,), (Log(log.layer, _along(log, 1), log.notches - 1),)))
    starts = {(log.layer, log.at): log for log in logs}
    # Pairs of logs that meet end to end on one line, in the order of the first.
    pairs = [(log, starts[(log.layer, _along(log, log.notches))]) for log in logs
             if (log.layer, _along(log, log.notches)) in starts]
    for log, nxt in pairs:
        if log.notches + nxt.notches <= 3:
            moves.append(((log, nxt), (Log(log.layer, log.at, log.notches + nxt.notches),)))
    for log, nxt in pairs:
        # Move their joint by a notch either way (same logs and positions: only a cost on
        # lengths can prefer one).
        if log.notches < 3 and nxt.notches > 1:
            moves.append(((log, nxt), (Log(log.layer, log.at, log.notches + 1),
                                       Log(nxt.layer, _along(nxt, 1), nxt.notches - 1))))
        if log.notches > 1 and nxt.notches < 3:
            moves.append(((log, nxt), (Log(log.layer, log.at, log.notches - 1),
                                       Log(nxt.layer, _along(nxt, -1), nxt.notches + 1))))
    for log in logs:
        if log.notches < 3:
            # Add a notch at the end, or before the first.
            moves.append(((log,), (Log(log.layer, log.at, log.notches + 1),)))
            moves.append(((log,), (Log(log.layer, _along(log, -1), log.notches + 1),)))
    return moves


def _supported(log: Log, z: np.ndarray) -> bool:
    """Constraints (c)/(d) for one log against occupancy ``z``."""
    if log.layer == 0:
        return True
    held = sum(z[i, j - 1, k] != EMPTY for i, j, k in log.positions())
    return held >= (2 if log.notches == 3 else log.notches)


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
    logs = set(structure.logs)
    at = {q: log for log in logs for q in log.positions()}  # position -> the log there
    base = value(z)
    moves = 0
    changed = True
    while changed and moves < max_moves:
        changed = False
        # One pass over the moves of the structure at the pass's start; a move whose
        # logs an earlier move of the pass changed is left for the next pass.
        for taken, put in _moves(Structure(extent, tuple(logs))):
            if not all(log in logs for log in taken) or cost.of(put) >= cost.of(taken):
                continue
            freed = {q for log in taken for q in log.positions()}
            placed = [q for log in put for q in log.positions()]
            if any(not extent.contains(q) or (q not in freed and q in at) for q in placed):
                continue  # off the grid, or onto another log
            trial = z.copy()
            for q in freed:
                trial[q] = EMPTY
            for log in put:
                for n, q in enumerate(log.positions()):
                    trial[q] = occupancy_code(log.notches, n)
            # The grammar is local: the logs put in, and those resting on emptied places.
            above = {at[i, j + 1, k] for i, j, k in freed
                     if trial[i, j, k] == EMPTY and (i, j + 1, k) in at}
            if not all(_supported(log, trial) for log in (*put, *above)):
                continue
            if allowed is not None and not allowed(trial):
                continue
            if value(trial) >= base - tolerance:
                z = trial
                logs.difference_update(taken)
                logs.update(put)
                for q in freed:
                    del at[q]
                for log in put:
                    for q in log.positions():
                        at[q] = log
                moves += 1
                changed = True
    result = Structure(extent, tuple(logs))
    if moves:
        logger.debug("ties: %d moves (%d -> %d logs)", moves, len(structure.logs),
                     len(result.logs))
    return result
