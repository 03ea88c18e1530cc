"""How far the readings of *seen* features may be wrong before the estimate changes.

The δ* test (:mod:`unseeable.confidence.tolerance`) asks whether hypothetical
evidence on the features no view saw could change the estimate Ẑ. A calibrated
detector is still wrong now and then on the features it sees: a reading of 0.96
is wrong one time in 25. An estimate that rests on one or two such readings can
pass the δ* test and still be wrong.

The *reading test* perturbs the seen features' priors too, in the same form: on
top of the δ* shift of the unseen features, every seen feature's log-odds is moved
by ``s`` away from Ẑ (towards "absent" where Ẑ has the feature, towards "present"
where it does not), but by no more than its views' reading for Ẑ
(:func:`seen_support`): a reading may be erased, never reversed, and a reading
against Ẑ is left as it is. A rival that differs from Ẑ on seen features gains the
sum of their moves over it, so the test asks: does Ẑ stay the MAP when any of the
views' readings might be worth up to ``s`` less? The *reading tolerance* is the
largest ``s`` for which it does; the estimate passes when that is at least ``s*``
(:data:`READING_SHIFT`).

s* = 2 was chosen on the development families alone (``validation``,
``seamed-tables-dev``, ``defocus-dev``, 40 scenes each, pose known; 2026-12-06,
``benchmarks/confidence_readings.py``): the smallest shift of the grid 0.5, 0.75,
1, 1.25, 1.5, 2, 2.5, 3 with no confident wrong estimate there (10 without the
test), at 28 false negatives of 65 exact estimates (14 without it). An unshifted
calibration is no reason for a smaller s*: on those families the readings are
as right as they claim (e.g. 0.84 measured for 0.855 claimed); the confident wrong
estimates are the few whose rival differs from them on one to three seen
features, each misread as often as its calibrated probability allows.

As for the δ* shift, a rival's advantage grows with ``s`` (piecewise linearly, each
move up to its cap), so the tolerance is found from crossing to crossing.

The structure prior's charge on a joint a camera sees (:func:`~unseeable.grammar.joint_prior`,
1 nat) is a belief about a seen feature, not a reading of it, and the test treats it as
it treats a reading (:func:`reading_test_terms`): where it favours the estimate (a joint
the estimate does not show) it may be erased; where it is against the estimate (a joint
the estimate shows) it stays. Without that, a confident estimate could rest on one
misread end plus the prior's dislike of the joint it would show (held-out-looks-2 scene
43: two 1-notch logs estimated as one 2-notch log, the gap's end read absent at 0.10).
Erasing the charges against the estimate too would also let a rival *merge* two logs the
estimate shows as joined, making other estimates look surer (held-out-looks scene 24,
pose estimated, confident with one error); erased only, the change can withdraw
confidence, never add it (docs/decisions.md).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from unseeable.confidence.crossings import advantage, rival_with, walk_crossings
from unseeable.confidence.thresholds import MAX_DELTA
from unseeable.domain.evidence import Evidence
from unseeable.domain.features import feature_values
from unseeable.domain.structure import Structure
from unseeable.errors import InputError

__all__ = ["READING_SHIFT", "MAX_READING_SHIFT", "ReadingTest", "reading_shift_term",
           "seen_support", "reading_test_terms",
           "rival_under_reading_shift", "reading_tolerance", "assess_readings"]

#: The reading shift s* (log-odds) an estimate must survive (chosen on the development
#: families, 2026-12-06).
READING_SHIFT = 2.0
#: Largest reading shift tried (log-odds).
MAX_READING_SHIFT = 8.0


def reading_test_terms(terms, estimate: Structure) -> list:
    """The terms the reading test weighs: ``terms`` without the structure prior's joint
    charges that favour ``estimate`` (joints it does not show), as a reading for it may
    be erased; the charges against it (joints it shows) are kept.

    Parameters
    ----------
    terms : iterable of Term
        The objective's terms.
    estimate : Structure

    Returns
    -------
    list of Term

    Examples
    --------
    >>> from unseeable.domain import Extent, Log, Structure
    >>> from unseeable.grammar import joint_prior
    >>> prior = joint_prior(Extent(3, 1, 1), 1.0)          # joints after notch 0 and 1
    >>> split = Structure(Extent(3, 1, 1), [Log(0, (0, 0), 1), Log(0, (1, 0), 2)])
    >>> len(reading_test_terms(prior, split))             # the joint it shows stays
    1
    >>> len(reading_test_terms(prior, Structure(Extent(3, 1, 1), [Log(0, (0, 0), 3)])))
    0
    """
    from unseeable.grammar.expr import evaluate
    from unseeable.grammar.objective import is_joint_factor

    z = estimate.occupancy
    return [t for t in terms
            if not (is_joint_factor(t) and not evaluate(t.expr, z, {}))]


def reading_shift_term(estimate: Structure, occluded: np.ndarray, delta: float,
                       shift: float, weights: np.ndarray | None = None,
                       caps: np.ndarray | None = None):
    """The hypothetical evidence of the reading test, as one evidence term.

    Parameters
    ----------
    estimate : Structure
    occluded : (N,) bool
        Features no view saw: prior ½ ∓ ``delta`` against the estimate.
    delta : float
        In [0, ½).
    shift : float
        Log-odds (>= 0) by which every seen feature is moved against the estimate.
    weights : (N,) float, optional
        Per-feature scale of the shift (>= 0; 1 everywhere by default): feature ``f``
        moves by ``shift * weights[f]``.
    caps : (N,) float, optional
        Per-feature largest move (>= 0; none by default): feature ``f`` moves by
        ``min(shift * weights[f], caps[f])`` (e.g. its reading's own log-odds for the
        estimate: a reading may be erased, not reversed).

    Returns
    -------
    EvidenceTerm
    """
    from unseeable.grammar import EvidenceTerm

    if not 0.0 <= delta < 0.5:
        raise InputError("must be in [0, 0.5)", field="delta", value=delta)
    if not 0.0 <= shift <= MAX_READING_SHIFT:
        raise InputError(f"must be in [0, {MAX_READING_SHIFT}]", field="shift", value=shift)
    value = feature_values(estimate.extent, estimate.occupancy)
    against_unseen = np.where(value, 0.5 - delta, 0.5 + delta)
    moves = _moves(shift, len(value), weights, caps)
    q = 1.0 / (1.0 + np.exp(np.minimum(moves, 30.0)))  # sigmoid(-move)
    against_seen = np.where(value, q, 1.0 - q)
    occluded = np.asarray(occluded, dtype=bool)
    return EvidenceTerm(Evidence(estimate.extent, np.where(occluded, against_unseen,
                                                           against_seen)))


def seen_support(estimate: Structure, terms, occluded: np.ndarray) -> np.ndarray:
    """Each seen feature's reading for the estimate: the log-odds its views' evidence
    gives the estimate's value of it (summed over the views), 0 where that is against
    the estimate or the feature unseen.

    A view after partial disassembly (``removed_from_layer = L``) speaks of the
    estimate's features only on layers below ``L``.

    Returns
    -------
    (N,) float
        >= 0; the caps of the reading test's "erase, never reverse" form.
    """
    from unseeable.domain.features import feature_index
    from unseeable.grammar import EvidenceTerm

    extent = estimate.extent
    value = feature_values(extent, estimate.occupancy)
    layer = feature_index(extent).at[:, 1]
    net = np.zeros(len(value))
    for t in terms:
        if not isinstance(t, EvidenceTerm):
            continue
        p = np.clip(np.asarray(t.evidence.p, dtype=float), 1e-12, 1 - 1e-12)
        logit = np.log(p / (1 - p))
        if t.removed_from_layer is not None:
            logit = np.where(layer < t.removed_from_layer, logit, 0.0)
        net += logit
    support = np.where(value, net, -net)
    return np.where(np.asarray(occluded, dtype=bool), 0.0, np.maximum(support, 0.0))


def _moves(shift: float, n: int, weights: np.ndarray | None,
           caps: np.ndarray | None) -> np.ndarray:
    """Each feature's log-odds move against the estimate at ``shift``."""
    w = np.ones(n) if weights is None else np.asarray(weights, dtype=float)
    moves = shift * w
    if caps is not None:
        moves = np.minimum(moves, np.maximum(np.asarray(caps, dtype=float), 0.0))
    return moves


def rival_under_reading_shift(solver, terms, estimate, occluded: np.ndarray, delta: float,
                              shift: float, *, weights: np.ndarray | None = None,
                              caps: np.ndarray | None = None, time_limit: float = 60.0):
    """Whether some structure beats the estimate under the reading test's shifts, and
    which (a SolveResult; None when none does or the test was undecided, which counts as
    a change)."""
    return rival_with(solver, terms, estimate,
                      reading_shift_term(estimate.structure, occluded, delta, shift, weights,
                                         caps),
                      label=f"reading shift {shift:.3f}", time_limit=time_limit)


def _crossing(terms, estimate, rival, occluded: np.ndarray, delta: float,
              weights: np.ndarray | None, caps: np.ndarray | None, largest: float,
              solver=None) -> float:
    """The reading shift at which ``rival`` ties with the estimate (ahead above it).

    The rival's advantage is ``A + Σ_f move_f(s)`` over the seen features where it
    differs from the estimate, with ``A`` its advantage at δ alone; each move grows with
    ``s`` (linearly, up to its cap), so the crossing is found by bisection on ``s``.
    """
    ours = feature_values(estimate.structure.extent, estimate.structure.occupancy)
    theirs = feature_values(rival.structure.extent, rival.structure.occupancy)
    differ = ours != theirs
    d_unseen = int(np.sum(occluded & differ))
    a0 = advantage(terms, estimate, rival, solver=solver)
    a = a0 + d_unseen * float(np.log((0.5 + delta) / (0.5 - delta)))
    if a >= 0:
        return 0.0
    where = ~occluded & differ
    if not where.any():
        return float(largest)

    def gain(s: float) -> float:
        return float(np.sum(_moves(s, len(ours), weights, caps)[where]))

    if gain(largest) + a < 0:
        return float(largest)
    lo, hi = 0.0, float(largest)
    for _ in range(60):
        mid = (lo + hi) / 2
        if gain(mid) + a < 0:
            lo = mid
        else:
            hi = mid
    return hi


def reading_tolerance(solver, terms, estimate, occluded: np.ndarray, *, delta: float,
                      weights: np.ndarray | None = None, caps: np.ndarray | None = None,
                      largest: float = MAX_READING_SHIFT,
                      resolution: float = 0.01, time_limit: float = 60.0
                      ) -> tuple[float, int]:
    """The largest reading shift the estimate survives, with the unseen features shifted
    by ``delta``.

    Returns
    -------
    tolerance : float
        In [0, :data:`MAX_READING_SHIFT`] (log-odds); 0 when the estimate already gives
        way at ``delta`` alone.
    resolves : int
    """
    terms = reading_test_terms(terms, estimate.structure)
    occluded = np.asarray(occluded, dtype=bool)
    resolves = 0

    def test(shift):
        nonlocal resolves
        resolves += 1
        return rival_under_reading_shift(solver, terms, estimate, occluded, delta, shift,
                                         weights=weights, caps=caps, time_limit=time_limit)

    hi = float(largest)
    changed, rival = test(hi)
    if not changed:
        return hi, resolves

    def crossing(rival, hi: float) -> float:
        return _crossing(terms, estimate, rival, occluded, delta, weights, caps, hi, solver)

    # A crossing's bisection can land on ``hi`` by rounding: no closed-form progress.
    settled, lo, _ = walk_crossings(test, crossing, 0.0, hi, rival, resolution=resolution,
                                    bisect_when_stalled=True)
    return float(lo if settled is None else settled), resolves


@dataclass(frozen=True)
class ReadingTest:
    """The reading test's judgement of one estimate.

    Attributes
    ----------
    confident : bool
        The estimate survives the reading shift ``shift`` on top of δ*.
    shift : float
        s*, log-odds.
    delta : float
        The unseen features' shift it was combined with (δ*).
    tolerance : float or None
        The largest reading shift survived (None when not computed).
    resolves : int
    """

    confident: bool
    shift: float
    delta: float
    tolerance: float | None
    resolves: int

    def to_json(self) -> dict:
        return {"confident": self.confident, "shift": self.shift, "delta": self.delta,
                "tolerance": self.tolerance, "resolves": self.resolves}


def assess_readings(solver, terms, estimate, occluded: np.ndarray, *,
                    delta_star: float = 0.2, shift: float = READING_SHIFT,
                    erase: bool = True, tolerance: bool = False,
                    time_limit: float = 60.0) -> ReadingTest:
    """The reading test: does the estimate stay the MAP with the unseen features shifted
    by ``delta_star`` and every seen feature's log-odds by ``shift``, both against it?

    Parameters
    ----------
    solver, terms, estimate
        As for :func:`~unseeable.confidence.assess_confidence` (the kept solver, the
        objective's terms, the SolveResult).
    occluded : (N,) bool
        Features no view saw (:func:`~unseeable.confidence.occluded_features`).
    delta_star : float
    shift : float
        s*, log-odds in [0, :data:`MAX_READING_SHIFT`].
    erase : bool
        Move each seen feature at most by its reading's log-odds for the estimate
        (:func:`seen_support`): a reading may be erased, never reversed. False: every
        seen feature moves by ``shift``.
    tolerance : bool
        Also find the reading tolerance.

    Examples
    --------
    >>> import numpy as np
    >>> from unseeable.domain import Evidence, Extent, Log, Structure, feature_values
    >>> from unseeable.grammar import EvidenceTerm
    >>> from unseeable.solve import StructureSolver
    >>> truth = Structure(Extent(2, 1, 1), [Log(0, (0, 0), 2)])
    >>> value = feature_values(truth.extent, truth.occupancy)
    >>> terms = [EvidenceTerm(Evidence(truth.extent, np.where(value, 0.98, 0.02)))]
    >>> solver = StructureSolver(truth.extent)
    >>> est = solver.solve(terms)
    >>> assess_readings(solver, terms, est, np.zeros(len(value), bool)).confident
    True
    """
    if not 0 <= delta_star <= MAX_DELTA:
        raise InputError(f"must be in [0, {MAX_DELTA}]", field="delta_star", value=delta_star)
    occluded = np.asarray(occluded, dtype=bool)
    terms = reading_test_terms(terms, estimate.structure)
    caps = seen_support(estimate.structure, terms, occluded) if erase else None
    changed, _ = rival_under_reading_shift(solver, terms, estimate, occluded, delta_star,
                                           shift, caps=caps, time_limit=time_limit)
    resolves = 1
    tol = None
    if tolerance:
        tol, extra = reading_tolerance(solver, terms, estimate, occluded, delta=delta_star,
                                       caps=caps, time_limit=time_limit)
        resolves += extra
    return ReadingTest(not changed, float(shift), float(delta_star), tol, resolves)
