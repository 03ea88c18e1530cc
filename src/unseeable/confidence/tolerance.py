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
"changes" is monotone in δ; each alternative's advantage is known in closed
form, so the tolerance is found exactly, from crossing to crossing.
"""

from __future__ import annotations

import logging
import time
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from unseeable.confidence.crossings import advantage, rival_with, walk_crossings
from unseeable.confidence.thresholds import DELTA_STAR, MAX_DELTA
from unseeable.domain.evidence import Evidence
from unseeable.domain.features import feature_index, feature_values
from unseeable.domain.grid import Extent
from unseeable.domain.structure import Structure
from unseeable.errors import InputError

if TYPE_CHECKING:  # the grammar is imported where it is used
    from unseeable.grammar import EvidenceTerm

__all__ = ["DELTA_STAR", "MAX_DELTA", "Confidence", "occluded_features", "shifted_term",
           "estimate_changes", "rival_under_shift", "crossing_shift", "estimation_tolerance",
           "assess_confidence"]

logger = logging.getLogger(__name__)



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


def shifted_term(estimate: Structure, occluded: np.ndarray, delta: float) -> EvidenceTerm:
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
    return rival_under_shift(solver, terms, estimate, occluded, delta,
                               time_limit=time_limit)[0]


def rival_under_shift(solver, terms, estimate, occluded: np.ndarray, delta: float, *,
                      time_limit: float = 60.0) -> tuple[bool, Any]:
    """Whether shifting the priors of ``occluded`` by ``delta`` changes the estimate, and
    the structure that beats it there (a SolveResult; None when none does, or when the
    test was undecided, which counts as a change)."""
    return rival_with(solver, terms, estimate, shifted_term(estimate.structure, occluded, delta),
                      label=f"δ={delta:.3f}", time_limit=time_limit)


def crossing_shift(terms, estimate, rival, occluded: np.ndarray, *, solver=None) -> float:
    """The shift at which ``rival`` ties with the estimate (it is ahead above it).

    A rival that differs from the estimate on ``d`` occluded features gains
    ``log((½+δ)/(½−δ))`` on each of them against it under the shift ``δ``, so
    its advantage is ``A₀ + d·log((½+δ)/(½−δ))`` with ``A₀ ≤ 0`` its advantage
    unshifted: zero at ``δ = ½·tanh(−A₀ / 2d)``. With the estimate's ``solver``
    the log-probabilities are scored by it (the same floats, faster).
    """
    ours = feature_values(estimate.structure.extent, estimate.structure.occupancy)
    theirs = feature_values(rival.structure.extent, rival.structure.occupancy)
    d = int(np.sum(occluded & (ours != theirs)))
    a0 = advantage(terms, estimate, rival, solver=solver)
    if d == 0 or a0 >= 0:
        return 0.0  # ahead without any shift: the estimate was not the MAP
    return float(0.5 * np.tanh(-a0 / (2 * d)))


@dataclass(frozen=True)
class Confidence:
    """The confidence judgement of one estimate.

    Attributes
    ----------
    confident : bool
        The estimate survives the shift δ*.
    delta_star : float
    tolerance : float or None
        The shift at which the estimate gives way (any larger one changes
        it); 0.5 means no shift below ½ changes it; None when not computed.
    occluded : int
        Number of features whose priors were shifted.
    resolves : int
        Re-solves spent.
    seconds : float
    readings : ReadingTest or None
        The reading test (:func:`~unseeable.confidence.readings.assess_readings`), when
        it was asked for: then ``confident`` requires it too.
    """

    confident: bool
    delta_star: float
    tolerance: float | None
    occluded: int
    resolves: int
    seconds: float
    readings: Any = None

    @property
    def passes_delta_star(self) -> bool:
        """The δ* test alone passed (the paper's test; the reading test is run only then)."""
        return bool(self.confident) or self.readings is not None

    def to_json(self) -> dict:
        out = {"confident": self.confident, "delta_star": self.delta_star,
               "tolerance": self.tolerance, "occluded_features": self.occluded,
               "resolves": self.resolves, "seconds": self.seconds}
        if self.readings is not None:
            out["readings"] = self.readings.to_json()
        return out


def estimation_tolerance(solver, terms, estimate, occluded: np.ndarray, *,
                         resolution: float = 0.005, known: dict | None = None,
                         time_limit: float = 60.0) -> tuple[float, int]:
    """The estimation tolerance δ: the shift at which the estimate gives way.

    Each structure that beats the estimate under some shift does so above one
    crossing shift (its advantage grows with δ in closed form), so the search
    goes from crossing to crossing: test the largest shift, take the crossing
    of the structure that beats the estimate there, test that crossing, and so
    on until nothing beats the estimate at the last crossing — the tolerance,
    exactly, in a few re-solves (the paper's binary search needs ~7 to reach
    0.005). At the tolerance the estimate still stands (tied); any larger
    shift changes it. A first look at a fifth of ``resolution`` catches the
    common case of exact tie-mates on occluded features (tolerance 0).
    Undecided tests (time limit) fall back to the binary search, to
    ``resolution``.

    Parameters
    ----------
    known : dict delta -> bool or (bool, SolveResult or None), optional
        Outcomes already computed (e.g. at δ*): changed or not, with the
        structure that beat the estimate when there is one.

    Returns
    -------
    tolerance : float
        In [0, 0.5]; 0.5 when even the largest shift leaves the estimate, 0
        when the estimate is beaten without a shift (it was not the MAP).
    resolves : int
    """
    if not 0 < resolution < 0.5:
        raise InputError("must be in (0, 0.5)", field="resolution", value=resolution)
    terms = list(terms)
    lo, hi, rival = 0.0, None, None
    for d, outcome in (known or {}).items():
        changed, better = outcome if isinstance(outcome, tuple) else (outcome, None)
        if changed and (hi is None or d < hi):
            hi, rival = d, better
        elif not changed:
            lo = max(lo, d)
    resolves = 0

    def test(delta):
        nonlocal resolves
        resolves += 1
        return rival_under_shift(solver, terms, estimate, occluded, delta,
                                   time_limit=time_limit)

    if hi is None:
        changed, rival = test(MAX_DELTA)
        if not changed:
            return 0.5, resolves
        hi = MAX_DELTA
    if lo == 0.0 and hi > resolution / 5:
        # Most estimates with hidden parts have exact tie-mates there (one member of a
        # tie was kept): the smallest shift already changes them. One look settles it.
        changed, better = test(resolution / 5)
        if changed:
            hi, rival = resolution / 5, better
        else:
            lo = resolution / 5
    settled, lo, hi = walk_crossings(
        test, lambda rival, hi: crossing_shift(terms, estimate, rival, occluded, solver=solver),
        lo, hi,
        rival, resolution=resolution)
    return float(hi if settled is None else settled), resolves


def assess_confidence(solver, terms, estimate, occluded: np.ndarray, *,
                      delta_star: float = DELTA_STAR, tolerance: bool = True,
                      resolution: float = 0.005, time_limit: float = 60.0,
                      reading_shift: float | None = None) -> Confidence:
    """The δ* test (one re-solve) and, optionally, the estimation tolerance.

    With ``reading_shift`` (s*, log-odds; off by default) the estimate must also pass
    the reading test (:func:`~unseeable.confidence.readings.assess_readings`): stay the
    MAP with the unseen features at δ* and every seen feature's reading moved by s*
    against it (at most erased), so that a confident estimate does not rest on a few
    misread features. It is run only when the δ* test passes.

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
        # Nothing unseen: no hypothetical evidence on unseen features can exist.
        changed, tol, resolves = False, 0.5 if tolerance else None, 0
    else:
        changed, better = rival_under_shift(solver, terms, estimate, occluded, delta_star,
                                              time_limit=time_limit)
        resolves = 1
        tol = None
        if tolerance:
            tol, extra = estimation_tolerance(solver, terms, estimate, occluded,
                                              resolution=resolution,
                                              known={delta_star: (changed, better)},
                                              time_limit=time_limit)
            resolves += extra
    if reading_shift is None or changed:
        return Confidence(not changed, delta_star, tol, n_occ, resolves,
                          time.perf_counter() - t0)
    return _with_readings(solver, terms, estimate, occluded, delta_star, tol, resolves,
                          reading_shift, time_limit, t0)


def _with_readings(solver, terms, estimate, occluded, delta_star, tol, resolves,
                   reading_shift, time_limit, t0) -> Confidence:
    """The δ* test passed: its judgement with the reading test's."""
    from unseeable.confidence.readings import assess_readings

    test = assess_readings(solver, terms, estimate, occluded, delta_star=delta_star,
                           shift=reading_shift, time_limit=time_limit)
    if not test.confident:
        logger.info("the estimate survives δ*=%g but not a reading shift of %g: it rests on "
                    "a few of the seen features' readings", delta_star, reading_shift)
    return Confidence(test.confident, delta_star, tol, int(occluded.sum()),
                      resolves + test.resolves, time.perf_counter() - t0, test)
