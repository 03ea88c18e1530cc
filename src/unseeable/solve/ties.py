"""Resolving exact ties of the MAP estimate towards the emptiest structure.

Occluded regions hold exactly tied structures: a hidden interior filled or
not, a wall's 3-notch log or a 1- and a 2-notch log whose joint nobody saw.
The solver returns an arbitrary member of the tie. Asking it for the member
with the fewest positions and logs (a tiny penalty per position and log in
the objective it maximises) was measured to make real-evidence solves one to
three orders of magnitude slower — the search must then tell apart thousands
of tied structures (a 6×7×5 cabin: 0.02 s without, 13 s with) — so ties are
resolved after the exact solve instead, by local moves that never lower the
log-probability:

* remove a log (top layers first, so supports go last);
* shorten a log by its first or last notch;
* merge two logs that meet end to end on one line into one of ≤ 3 notches.

A move is kept when the structure stays valid, every hard constraint still
holds and the log-probability does not drop (within ``tolerance``); moves are
tried in a fixed order until none applies, so the result is deterministic.
The result is a MAP estimate (same log-probability) that is locally
emptiest: no single move above makes it emptier without losing probability.
"""

from __future__ import annotations

import logging
from collections.abc import Callable

import numpy as np

from unseeable.domain.grid import EMPTY, occupancy_code
from unseeable.domain.structure import Log, Structure

logger = logging.getLogger(__name__)

__all__ = ["emptiest_tie"]


def _moves(structure: Structure) -> list[tuple[tuple[Log, ...], tuple[Log, ...]]]:
    """Emptying moves ``(logs taken out, logs put in)``, in a fixed order (module docstring)."""
    logs = sorted(structure.logs, key=lambda log: (-log.layer, log))  # top layers first
    moves: list[tuple[tuple[Log, ...], tuple[Log, ...]]] = [((log,), ()) for log in logs]
    for log in logs:
        if log.notches > 1:
            i, k = log.at
            di, dk = (1, 0) if log.layer % 2 == 0 else (0, 1)
            # Drop the last notch, or the first (the log then starts one position on).
            moves.append(((log,), (Log(log.layer, (i, k), log.notches - 1),)))
            moves.append(((log,), (Log(log.layer, (i + di, k + dk), log.notches - 1),)))
    starts = {(log.layer, log.at): log for log in logs}
    for log in logs:
        i, k = log.at
        di, dk = (1, 0) if log.layer % 2 == 0 else (0, 1)
        nxt = starts.get((log.layer, (i + di * log.notches, k + dk * log.notches)))
        if nxt is not None and log.notches + nxt.notches <= 3:
            moves.append(((log, nxt), (Log(log.layer, log.at, log.notches + nxt.notches),)))
    return moves


def _supported(log: Log, z: np.ndarray) -> bool:
    """Constraints (c)/(d) for one log against occupancy ``z``."""
    if log.layer == 0:
        return True
    held = sum(z[i, j - 1, k] != EMPTY for i, j, k in log.positions())
    return held >= (2 if log.notches == 3 else log.notches)


def emptiest_tie(structure: Structure, value: Callable[[np.ndarray], float], *,
                 allowed: Callable[[np.ndarray], bool] | None = None,
                 tolerance: float = 1e-9, max_moves: int = 100_000) -> Structure:
    """The structure after every emptying move that keeps its value.

    Parameters
    ----------
    structure : Structure
        A MAP estimate (valid).
    value : callable (I, J, K) occupancy -> float
        The log-probability being maximised.
    allowed : callable (I, J, K) occupancy -> bool, optional
        Extra hard constraints a candidate must satisfy (the grammar is
        always kept).
    tolerance : float
        A move may lower the value by at most this (float round-off).
    max_moves : int
        Safety bound on accepted moves (each removes a position or a log, so
        the structure's size bounds them anyway).

    Returns
    -------
    Structure
        Same extent, value within ``tolerance`` of the input's, no more
        occupied positions and no more logs.

    Examples
    --------
    >>> from unseeable.domain import Extent
    >>> s = Structure(Extent(3, 1, 1), (Log(0, (0, 0), 3),))
    >>> emptiest_tie(s, lambda z: 0.0).logs   # nothing is seen: nothing is kept
    ()
    """
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
        for taken, put in _moves(Structure(structure.extent, tuple(logs))):
            if not all(log in logs for log in taken):
                continue
            trial = z.copy()
            for log in taken:
                for q in log.positions():
                    trial[q] = EMPTY
            for log in put:
                for n, q in enumerate(log.positions()):
                    trial[q] = occupancy_code(log.notches, n)
            # The grammar is local: the logs put in, and those resting on emptied places.
            above = {at[i, j + 1, k] for log in taken for i, j, k in log.positions()
                     if trial[i, j, k] == EMPTY and (i, j + 1, k) in at}
            if not all(_supported(log, trial) for log in (*put, *above)):
                continue
            if allowed is not None and not allowed(trial):
                continue
            if value(trial) >= base - tolerance:
                z = trial
                logs.difference_update(taken)
                logs.update(put)
                for log in taken:
                    for q in log.positions():
                        del at[q]
                for log in put:
                    for q in log.positions():
                        at[q] = log
                moves += 1
                changed = True
    result = Structure(structure.extent, tuple(logs))
    if moves:
        logger.debug("ties: %d emptying moves (%d -> %d logs)", moves, len(structure.logs),
                     len(result.logs))
    return result
