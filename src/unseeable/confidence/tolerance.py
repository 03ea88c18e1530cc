"""How much hypothetical evidence on occluded features would change the estimate.

Shift every occluded feature's prior by δ *away* from its value under the
estimate Ẑ (to ½ − δ where Ẑ has the feature, ½ + δ where it does not). The
*estimation tolerance* is the smallest δ for which the MAP estimate is no
longer Ẑ; the estimate is *confident* when it survives δ* (paper: 0.2).

"Changes" is decided by objective, not by comparing structures: the re-solve
changes the estimate when it finds a structure strictly more probable than Ẑ
under the shifted priors. Occluded regions often hold exactly tied
alternatives, and different solvers return different members of a tie; a tie
is not a change of mind. Every alternative's advantage over Ẑ grows with δ, so
"changes" is monotone in δ and a binary search finds the tolerance.
"""

from __future__ import annotations

import logging
import time
from dataclasses import dataclass

import numpy as np

from unseeable.domain.evidence import Evidence
from unseeable.domain.features import feature_index, feature_values
from unseeable.domain.grid import Extent
from unseeable.domain.structure import Structure
from unseeable.errors import InputError

__all__ = ["DELTA_STAR", "Confidence", "occluded_features", "shifted_term", "estimate_changes",
           "estimation_tolerance", "assess_confidence"]

logger = logging.getLogger(__name__)

#: The paper's tolerance threshold δ*.
DELTA_STAR = 0.2
#: Largest shift tried: priors stay inside (0, 1).
MAX_DELTA = 0.499
#: Objective improvement that counts as a change (log-probability units).
CHANGE_EPSILON = 1e-7


def occluded_features(observations, visibility, extent: Extent) -> np.ndarray:
    """Features of Z that no view saw: not (visible and judged) in any observation.

    A view after partial disassembly (``removed_from_layer = L``) sees a
    feature of Z only on layers below L, where removing logs does not change it.

    Returns
    -------
    (N,) bool
    """
    idx = feature_index(extent)
    seen = np.zeros(len(idx), dtype=bool)
    for obs, vis in zip(observations, visibility):
        looked = vis & obs.judged
        if obs.removed_from_layer is not None:
            looked = looked & (idx.at[:, 1] < obs.removed_from_layer)
        seen |= looked
    return ~seen


def shifted_term(estimate: Structure, occluded: np.ndarray, delta: float):
    """The hypothetical evidence: occluded features at ½ ∓ δ against the estimate."""
    from unseeable.grammar import EvidenceTerm

    if not 0.0 <= delta < 0.5:
        raise InputError("must be in [0, 0.5)", field="delta", value=delta)
    value = feature_values(estimate.extent, estimate.occupancy)
    p = np.where(value, 0.5 - delta, 0.5 + delta)
    return EvidenceTerm(Evidence(estimate.extent, np.where(occluded, p, 0.5)))


def estimate_changes(solver, terms, estimate, occluded: np.ndarray, delta: float, *,
                     time_limit: float = 60.0) -> bool:
    """Whether shifting the occluded priors by ``delta`` changes the MAP estimate.

    Parameters
    ----------
    solver : StructureSolver
        The kept model the estimate came from; asked whether any structure
        beats the estimate under the shift (:meth:`StructureSolver.find_better`,
        the estimate as cut-off and hint).
    terms : sequence of terms
        The objective the estimate maximised.
    estimate : SolveResult
        The estimate Ẑ (with its choices, when constraints have any).
    occluded : (N,) bool
    delta : float

    Returns
    -------
    bool
        True when a strictly more probable structure exists under the shift.
        An undecided test (time limit) counts as a change: an unknown must not
        make the estimate look confident.
    """
    from unseeable.solve import SolveStatus

    shifted = [*terms, shifted_term(estimate.structure, occluded, delta)]
    result = solver.find_better(shifted, estimate, margin=CHANGE_EPSILON, time_limit=time_limit)
    if result.status == SolveStatus.FEASIBLE:
        return True
    if result.status != SolveStatus.INFEASIBLE:
        logger.warning("δ=%.3f test ended %s; counted as a change", delta, result.status.value)
        return True
    return False


@dataclass(frozen=True)
class Confidence:
    """The confidence judgement of one estimate.

    Attributes
    ----------
    confident : bool
        The estimate survives the shift δ*.
    delta_star : float
    tolerance : float or None
        Smallest shift that changes the estimate (to ``resolution``); 0.5
        means no shift below ½ changes it; None when not computed.
    occluded : int
        Number of features whose priors were shifted.
    resolves : int
        Re-solves spent.
    seconds : float
    """

    confident: bool
    delta_star: float
    tolerance: float | None
    occluded: int
    resolves: int
    seconds: float

    def to_json(self) -> dict:
        return {"confident": self.confident, "delta_star": self.delta_star,
                "tolerance": self.tolerance, "occluded_features": self.occluded,
                "resolves": self.resolves, "seconds": self.seconds}


def estimation_tolerance(solver, terms, estimate, occluded: np.ndarray, *,
                         resolution: float = 0.005, known: dict | None = None,
                         time_limit: float = 60.0) -> tuple[float, int]:
    """The estimation tolerance δ by binary search to ``resolution``.

    Parameters
    ----------
    known : dict delta -> bool, optional
        Outcomes already computed (e.g. at δ*), to narrow the bracket.

    Returns
    -------
    tolerance : float
        In (0, 0.5]; 0.5 when even the largest shift leaves the estimate.
    resolves : int
    """
    if not 0 < resolution < 0.5:
        raise InputError("must be in (0, 0.5)", field="resolution", value=resolution)
    known = dict(known or {})
    lo, hi = 0.0, None
    for d, changed in known.items():
        if changed:
            hi = d if hi is None else min(hi, d)
        else:
            lo = max(lo, d)
    resolves = 0
    if hi is None:
        resolves += 1
        if not estimate_changes(solver, terms, estimate, occluded, MAX_DELTA,
                                time_limit=time_limit):
            return 0.5, resolves
        hi = MAX_DELTA
    while hi - lo > resolution:
        mid = (lo + hi) / 2
        resolves += 1
        if estimate_changes(solver, terms, estimate, occluded, mid, time_limit=time_limit):
            hi = mid
        else:
            lo = mid
    return float(hi), resolves


def assess_confidence(solver, terms, estimate, occluded: np.ndarray, *,
                      delta_star: float = DELTA_STAR, tolerance: bool = True,
                      resolution: float = 0.005, time_limit: float = 60.0) -> Confidence:
    """The δ* test (one re-solve) and, optionally, the tolerance by binary search.

    Examples
    --------
    See :func:`unseeable.pipeline.estimate_view`, which calls this after the
    visibility fixpoint.
    """
    if not 0 < delta_star < 0.5:
        raise InputError("must be in (0, 0.5)", field="delta_star", value=delta_star)
    t0 = time.perf_counter()
    occluded = np.asarray(occluded, dtype=bool)
    n_occ = int(occluded.sum())
    if n_occ == 0:
        # Nothing unseen: no hypothetical evidence can exist.
        return Confidence(True, delta_star, 0.5 if tolerance else None, 0, 0,
                          time.perf_counter() - t0)
    changed = estimate_changes(solver, terms, estimate, occluded, delta_star,
                               time_limit=time_limit)
    resolves = 1
    tol = None
    if tolerance:
        tol, extra = estimation_tolerance(solver, terms, estimate, occluded,
                                          resolution=resolution, known={delta_star: changed},
                                          time_limit=time_limit)
        resolves += extra
    return Confidence(not changed, delta_star, tol, n_occ, resolves, time.perf_counter() - t0)
