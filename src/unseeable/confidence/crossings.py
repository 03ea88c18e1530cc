"""What the δ* test and the reading test share: one re-solve asking whether a structure
beats the estimate under hypothetical evidence, and the search for the shift at which
the estimate gives way, from one rival's crossing to the next."""

from __future__ import annotations

import logging
from collections.abc import Callable
from typing import Any

from unseeable.confidence.thresholds import CHANGE_EPSILON

__all__ = ["advantage", "rival_with", "walk_crossings"]

logger = logging.getLogger(__name__)


def rival_with(solver, terms, estimate, hypothetical, *, label: str,
               time_limit: float = 60.0) -> tuple[bool, Any]:
    """Whether some structure beats ``estimate`` under ``terms`` plus the ``hypothetical``
    evidence term, and which (a SolveResult; None when none does, or when the re-solve
    was undecided, which counts as a change: an unknown must not make the estimate look
    confident). ``label`` names the shift in the warning an undecided re-solve logs."""
    from unseeable.solve import SolveStatus

    result = solver.find_better([*terms, hypothetical], estimate, margin=CHANGE_EPSILON,
                                time_limit=time_limit)
    if result.status == SolveStatus.FEASIBLE:
        return True, result
    if result.status != SolveStatus.INFEASIBLE:
        logger.warning("%s test ended %s; counted as a change", label, result.status.value)
        return True, None
    return False, None


def advantage(terms, estimate, rival, *, solver=None) -> float:
    """``rival``'s log-probability minus ``estimate``'s under ``terms`` (SolveResults),
    scored by ``solver`` when given (:meth:`~unseeable.solve.StructureSolver.log_probabilities`)
    or by :func:`~unseeable.grammar.log_probability`: the same floats."""
    pairs = [(rival.structure, rival.choices), (estimate.structure, estimate.choices)]
    if solver is not None:
        theirs, ours = solver.log_probabilities(terms, pairs)
    else:
        from unseeable.grammar import log_probability

        theirs, ours = (log_probability(terms, s, c) for s, c in pairs)
    return theirs - ours


def walk_crossings(test: Callable[[float], tuple[bool, Any]],
                   crossing: Callable[[Any, float], float], lo: float, hi: float,
                   rival: Any, *, resolution: float, bisect_when_stalled: bool = False
                   ) -> tuple[float | None, float, float]:
    """The shift at which an estimate gives way, between ``lo`` (it stands) and ``hi``
    (``rival`` beats it).

    Each rival's advantage grows with the shift, so the search tests the shift at which
    the last rival ties with the estimate (``crossing(rival, hi)``, clamped to
    ``[lo, hi]``), takes the rival that beats it there, and so on: finitely many steps
    (the cap of 50 only guards against floating-point cycling). Without a rival (an
    undecided test) it bisects to ``resolution``.

    Parameters
    ----------
    test : callable shift -> (changed, rival)
    crossing : callable (rival, hi) -> shift
    bisect_when_stalled : bool
        Bisect as soon as a crossing lands on ``hi`` (rounding: no progress).

    Returns
    -------
    settled : float or None
        The shift found exactly: a crossing at which nothing beats the estimate, or
        ``lo`` when a crossing falls at or below it. None when the search ended in
        bisection.
    lo, hi : float
        Then the bracket, at most ``resolution`` wide: the estimate stands at ``lo``
        and gives way at ``hi``.
    """
    for _ in range(50):
        if rival is None:
            break
        shift = min(max(crossing(rival, hi), lo), hi)
        if shift <= lo:
            return float(lo), lo, hi
        if bisect_when_stalled and shift >= hi:
            break
        changed, better = test(shift)
        if not changed:
            return float(shift), lo, hi
        hi, rival = shift, better
    while hi - lo > resolution:
        mid = (lo + hi) / 2
        changed, _ = test(mid)
        if changed:
            hi = mid
        else:
            lo = mid
    return None, lo, hi
