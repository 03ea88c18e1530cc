"""Visibility ⇄ structure to a fixpoint (paper §3, DESIGN.md §4).

Start from a visibility guess, estimate the structure with occluded features
at ½, recompute every feature's visibility against the estimate's bounding
cylinders, and repeat until the visibility no longer changes. When the
iteration enters a cycle instead, the cycle's highest-probability structure
is kept.

When an observation can re-weigh its detections by what lies *behind* each
feature (``ViewEvidence.context_priors``, the calibration's context models),
the fixpoint under its own priors is followed by rounds under the priors the
last estimate implies, each a visibility fixpoint of its own.

The loop works on *observations*: one per view, each with the detector
priors for every feature, which features the detector could judge at all
(inside the image), the camera centre and the pose that places the shared grid
in that view's world. One view is the paper's setting; several views, or a
view after partial disassembly, are the same loop over one joint estimate.
"""

from __future__ import annotations

import functools
import logging
import math
import time
from collections import OrderedDict
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace

import numpy as np

from unseeable.domain.evidence import Evidence
from unseeable.domain.frames import GridPose
from unseeable.domain.geometry import LogGeometry
from unseeable.domain.grid import Extent
from unseeable.domain.structure import Structure
from unseeable.errors import InputError, check_seconds
from unseeable.visibility.occlusion import (
    DEFAULT_THRESHOLD,
    background_context,
    feature_visibility,
)

__all__ = ["ViewEvidence", "LineAliases", "VisibilityFixpoint", "estimate_with_visibility",
           "observation_terms", "fit_presence_shift", "PRESENCE_SHIFT_WEIGHT", "PRESENCE_SHIFT_MIN",
           "PRESENCE_SHIFT_BOUND", "PRESENCE_SHIFT_KEEP"]

logger = logging.getLogger(__name__)

#: Weight of the Gaussian prior on a view's presence shift (nats per squared unit of
#: log-odds: a standard deviation of about 0.7): weak beside the hundreds of judged
#: features of a view, strong enough to hold the shift near 0 on a few dozen.
PRESENCE_SHIFT_WEIGHT = 1.0
#: Shifts smaller than this (log-odds) are not worth a further fixpoint.
PRESENCE_SHIFT_MIN = 0.1
#: The largest presence shift applied, either way (log-odds: the odds of every reading
#: scaled by at most e^1.5, about 4.5); a fitted shift beyond it is applied at the bound
#: (the best shift within it: the fit's objective is concave). Adapting to a photograph's
#: look never needed more: on every rightly posed view of both corpora and the held-out
#: families the fitted shift stayed above -1.40 (620 views; ``pipeline``'s evidence
#: doubt, ``PRESENCE_SHIFT_DOUBT``, is set at -1.5, docs/decisions.md). A shift beyond it
#: says that the detections and every structure the grammar builds on the grid disagree
#: more than a look explains: a grid off the assembly, or detectors failing on one kind
#: of feature, whose fault a shift of every reading would spread to all the others.
PRESENCE_SHIFT_BOUND = 1.5
#: Share of a view's clearly seen present features (present in the estimate before the
#: shift, with a reading whose log-odds are at least :data:`PRESENCE_SHIFT_BOUND`, which
#: no applied shift turns to absent) that the shifted estimate must keep present. A
#: shift that adapts to a look moves the readings at the margin and leaves the clear
#: ones where they were (30 corpus views at their poses, the readings biased by ±1.5 or
#: ±3 nats, all of them or one kind: at most 1.6 % dropped; the same views with the grid
#: 32 mm off the assembly: up to 57 %, 2026-12-06). One that makes the estimate drop most
#: of what the detectors see clearly contradicts them rather than adapting them, and is
#: refused: the estimate under the unshifted readings is kept
#: (:attr:`VisibilityFixpoint.presence_refused`).
PRESENCE_SHIFT_KEEP = 0.5
#: Structures whose visibility and priors a view keeps (a fixpoint visits a handful).
_ANSWERS_KEPT = 8


def fit_presence_shift(priors: np.ndarray, present: np.ndarray, *,
                       weight: float = PRESENCE_SHIFT_WEIGHT) -> float:
    """The shift ``b`` of the priors' log-odds under which they best agree with an estimate.

    Maximises ``Σ log Bernoulli(present_f; σ(logit p_f + b)) - weight · b²``
    (concave: the root of its slope, bracketed). The detectors' calibration was fitted on
    rendered training scenes; a photograph in another look (another renderer,
    lighting, table) can make them call presence too rarely or too often
    throughout. The structure the grammar reconciles from the same detections
    shows by how much, and the priors shifted by ``b`` are then re-solved
    (:func:`estimate_with_visibility`, ``presence_shift``). It is the classic
    adjustment of a classifier to new prior odds (Saerens et al., 2002), with
    the estimate for labels.

    Parameters
    ----------
    priors : (M,) float
        Priors in (0, 1) of the judged, visible features.
    present : (M,) bool
        The estimate's value of each.
    weight : float
        Weight of the prior ``b ~ N(0, 1 / (2 weight))``; > 0.

    Returns
    -------
    float

    Examples
    --------
    >>> p = np.array([0.3, 0.3, 0.3, 0.3])
    >>> round(fit_presence_shift(p, np.array([True, True, True, False]), weight=1e-9), 3)
    1.946
    >>> fit_presence_shift(p, np.array([True, True, True, False])) < 1.946
    True
    """
    p = np.asarray(priors, dtype=float)
    y = np.asarray(present, dtype=float)
    if p.ndim != 1 or p.shape != y.shape:
        raise InputError(f"priors and present must be (M,) arrays of one length, got "
                         f"{p.shape} and {y.shape}", field="present", value=y.shape)
    if not np.all((p > 0) & (p < 1)):
        raise InputError("priors must lie in (0, 1)", field="priors",
                         value=float(p.min()) if p.size else None)
    if not weight > 0:
        raise InputError("must be > 0", field="weight", value=weight)
    if y.size == 0:
        return 0.0
    from scipy.special import expit, logit

    z = logit(p)
    target = float(y.sum())

    def slope(b: float) -> float:  # minus the objective's derivative: increasing in b
        return float(np.sum(expit(z + b))) - target + 2.0 * weight * b

    # |Σ σ - Σ y| <= M, so the root lies within M / (2 weight) of 0.
    reach = y.size / (2.0 * weight) + 1.0
    return _brentq(slope, -reach, reach, xtol=1e-10)


def _brentq(f: Callable[[float], float], xa: float, xb: float, *, xtol: float,
            rtol: float = 4 * np.finfo(float).eps, maxiter: int = 100) -> float:
    """A root of ``f`` bracketed by ``xa`` and ``xb``: SciPy's ``brentq`` (Brent 1973, as
    in scipy/optimize/Zeros/brentq.c), step for step and so to the last bit, without
    importing ``scipy.optimize`` (a third of a second of every command that estimates
    from a photograph)."""
    xpre, xcur = float(xa), float(xb)
    fpre, fcur = f(xpre), f(xcur)
    if fpre == 0:
        return xpre
    if fcur == 0:
        return xcur
    if math.copysign(1.0, fpre) == math.copysign(1.0, fcur):
        raise ValueError("f(a) and f(b) must have different signs")
    xblk = fblk = spre = scur = 0.0
    for _ in range(maxiter):
        if fpre != 0 and fcur != 0 and math.copysign(1.0, fpre) != math.copysign(1.0, fcur):
            xblk, fblk = xpre, fpre
            spre = scur = xcur - xpre
        if abs(fblk) < abs(fcur):
            xpre, xcur, xblk = xcur, xblk, xcur
            fpre, fcur, fblk = fcur, fblk, fcur
        delta = (xtol + rtol * abs(xcur)) / 2
        sbis = (xblk - xcur) / 2
        if fcur == 0 or abs(sbis) < delta:
            return xcur
        if abs(spre) > delta and abs(fcur) < abs(fpre):
            if xpre == xblk:  # interpolate
                stry = -fcur * (xcur - xpre) / (fcur - fpre)
            else:  # extrapolate
                dpre = (fpre - fcur) / (xpre - xcur)
                dblk = (fblk - fcur) / (xblk - xcur)
                stry = -fcur * (fblk * dblk - fpre * dpre) / (dblk * dpre * (fblk - fpre))
            if 2 * abs(stry) < min(abs(spre), 3 * abs(sbis) - delta):  # a good short step
                spre, scur = scur, stry
            else:
                spre = scur = sbis
        else:
            spre = scur = sbis
        xpre, fpre = xcur, fcur
        xcur += scur if abs(scur) > delta else (delta if sbis > 0 else -delta)
        fcur = f(xcur)
    raise ValueError(f"no convergence in {maxiter} iterations")


def _shift_log_odds(p: np.ndarray, shift: float, judged: np.ndarray,
                    clip: tuple[float, float] | None) -> np.ndarray:
    """``p`` with the log-odds of the judged features moved by ``shift``, kept within
    ``clip`` (the calibration's: no single detector may veto), else within the range of
    the judged priors; the others as they are."""
    from scipy.special import expit, logit

    if clip is None:
        clip = (float(p[judged].min()), float(p[judged].max())) if judged.any() else (0.5, 0.5)
    # A judged feature at exactly ½ was counted out (LineAliases): it stays out.
    return np.where(judged & (p != 0.5), np.clip(expit(logit(p) + shift), *clip), p)


@dataclass(frozen=True, eq=False)
class LineAliases:
    """Segment features that one image line holds together, so that one edge answers
    every detector on it (e.g. a log two layers up and a pitch along a depth axis seen
    from above): under a structure the edge counts once.

    Parameters
    ----------
    first, second : (M,) int
        Feature indices: ``second[m]`` lies on ``first[m]``'s image line
        (:func:`~unseeable.vision.projection.collinear_segment_pairs`).
    distance : (N,) float
        Each feature's distance from the camera (mm): of several present features on
        a line the nearest keeps the evidence.
    """

    first: np.ndarray
    second: np.ndarray
    distance: np.ndarray

    def __post_init__(self) -> None:
        first = np.asarray(self.first, dtype=np.intp).reshape(-1)
        second = np.asarray(self.second, dtype=np.intp).reshape(-1)
        distance = np.asarray(self.distance, dtype=float)
        if first.shape != second.shape:
            raise InputError("first and second must have one shape", field="second",
                             value=second.shape)
        if distance.ndim != 1:
            raise InputError("must be one distance per feature, shape (N,)", field="distance",
                             value=distance.shape)
        for name, index in (("first", first), ("second", second)):
            bad = index[(index < 0) | (index >= len(distance))]
            if bad.size:
                raise InputError(f"feature indices must lie in [0, {len(distance)})",
                                 field=name, value=int(bad[0]))
        object.__setattr__(self, "first", first)
        object.__setattr__(self, "second", second)
        object.__setattr__(self, "distance", distance)

    def count_once(self, priors: np.ndarray, present: np.ndarray,
                   visible: np.ndarray) -> np.ndarray:
        """``priors`` with ½ for every visible feature whose line's edge another feature
        explains under a structure: one present and visible on its line that is nearer,
        or, for a feature the structure leaves absent, any present and visible one.

        Parameters
        ----------
        priors : (N,) float
        present, visible : (N,) bool
            Under the structure.

        Returns
        -------
        (N,) float
        """
        f, a = self.first, self.second
        held = visible[a] & present[a] & (~present[f] | (self.distance[a] < self.distance[f]))
        out = np.zeros(len(priors), dtype=bool)
        out[f[held]] = True
        return np.where(out & visible, 0.5, priors)


@dataclass(frozen=True, eq=False)
class ViewEvidence:
    """What one view contributes to the joint estimate.

    Parameters
    ----------
    priors : (N,) float
        Detector prior for every feature of the extent (½ where not judged).
    camera_centre : (3,) float
        The camera centre in this view's world frame (mm).
    pose : GridPose
        Places the shared grid in this view's world frame.
    judged : (N,) bool, optional
        Features the detectors could judge at all (e.g. inside the image);
        default: every feature whose prior is not ½.
    removed_from_layer : int, optional
        The view shows the assembly after the arm removed every log on layers
        ``>= L``: its features are evaluated against the estimate with those
        logs removed, and only the remaining logs block rays.
    context_priors : callable, optional
        ``behind (N, 2) -> priors (N,)``: the detector priors re-weighed by
        what lies behind each feature under the current estimate
        (:func:`~unseeable.visibility.background_context`: wood, and log
        edges along the feature; e.g. ``FeatureDetection.priors_given``). ``priors`` serve the first
        estimate; None: the priors do not depend on the estimate.
    clip : (float, float), optional
        The range the detector priors are confined to (the calibration's clip),
        which a shift of their log-odds keeps to (``presence_shift`` of
        :func:`estimate_with_visibility`); None: the range of the judged priors.
    line_aliases : LineAliases, optional
        Segment features sharing an image line: under an estimate, an edge counts
        once per line (:meth:`LineAliases.count_once`); None: every detection counts.
    threads : int
        Threads to cast the visibility's and the background's rays on (the same
        answer for any number).
    """

    priors: np.ndarray
    camera_centre: np.ndarray
    pose: GridPose
    judged: np.ndarray | None = None
    removed_from_layer: int | None = None
    context_priors: Callable[[np.ndarray], np.ndarray] | None = None
    clip: tuple[float, float] | None = None
    line_aliases: LineAliases | None = None
    threads: int = 1

    def __post_init__(self) -> None:
        p = np.asarray(self.priors, dtype=float)
        if p.ndim != 1 or not np.all((p > 0) & (p < 1)):
            raise InputError("priors must be an (N,) array in (0, 1)", field="priors",
                             value=p.shape)
        judged = (p != 0.5) if self.judged is None else np.asarray(self.judged, dtype=bool)
        if judged.shape != p.shape:
            raise InputError(f"judged must have shape {p.shape}", field="judged",
                             value=judged.shape)
        centre = np.asarray(self.camera_centre, dtype=float).reshape(3)
        if self.line_aliases is not None and self.line_aliases.distance.shape != p.shape:
            raise InputError(f"line_aliases must cover the {len(p)} features",
                             field="line_aliases", value=self.line_aliases.distance.shape)
        if self.clip is not None:
            try:
                lo, hi = (float(c) for c in self.clip)
                valid = 0 < lo <= hi < 1
            except (TypeError, ValueError):
                valid = False
            if not valid:
                raise InputError("must be (low, high) with 0 < low <= high < 1", field="clip",
                                 value=self.clip)
            object.__setattr__(self, "clip", (lo, hi))
        object.__setattr__(self, "priors", p)
        object.__setattr__(self, "judged", judged)
        object.__setattr__(self, "camera_centre", centre)
        # The fixpoint asks for the same structure's visibility and priors again and again
        # (each round's last estimate, the tie policy's member, the next round's start):
        # answers kept per structure, the last few.
        object.__setattr__(self, "_answers", OrderedDict())

    def _kept(self, what: str, structure: Structure, compute: Callable[[], np.ndarray],
              *args) -> np.ndarray:
        """``compute()``, kept for this structure and ``args`` (a copy is returned)."""
        key = (what, structure.extent, structure.occupancy.tobytes(), *args)
        answers = self._answers
        hit = answers.get(key)
        if hit is None:
            hit = answers[key] = np.asarray(compute())
            if len(answers) > _ANSWERS_KEPT:
                answers.popitem(last=False)
        return hit.copy()

    def evidence(self, extent: Extent, visible: np.ndarray,
                 priors: np.ndarray | None = None) -> Evidence:
        """Evidence with the detector priors (``priors``, default the observation's own)
        on visible, judged features and ½ elsewhere."""
        p = self.priors if priors is None else priors
        return Evidence(extent, np.where(visible & self.judged, p, 0.5))

    def _seen(self, structure: Structure) -> Structure:
        if self.removed_from_layer is not None:
            return structure.removed_from_layer(self.removed_from_layer)
        return structure

    def visibility(self, structure: Structure, *, geometry: LogGeometry,
                   threshold: float) -> np.ndarray:
        """Visibility of every feature in this view given an estimate of the structure."""
        return self._kept("visibility", structure, lambda: feature_visibility(
            self._seen(structure), self.camera_centre, self.pose, geometry=geometry,
            threshold=threshold, threads=self.threads), geometry, threshold)

    def priors_under(self, structure: Structure, *, geometry: LogGeometry,
                     threshold: float = DEFAULT_THRESHOLD,
                     visible: np.ndarray | None = None) -> np.ndarray:
        """The detector priors given an estimate of the structure: what lies behind each
        feature in this view (``context_priors``), and which edges its features on a
        shared image line explain (``line_aliases``, under the structure's own
        visibility: ``visible`` when the caller has it, else computed at
        ``threshold``); without either, the observation's own priors."""
        if self.context_priors is None and self.line_aliases is None:
            return self.priors
        if visible is None:
            return self._kept("priors", structure, lambda: self._priors_under(
                structure, geometry, threshold, None), geometry, threshold)
        return self._priors_under(structure, geometry, threshold, visible)

    def _priors_under(self, structure: Structure, geometry: LogGeometry, threshold: float,
                      visible: np.ndarray | None) -> np.ndarray:
        p = self.priors
        seen = self._seen(structure)
        if self.context_priors is not None:
            behind = background_context(seen, self.camera_centre, self.pose, geometry=geometry,
                                        threads=self.threads)
            p = np.asarray(self.context_priors(behind), dtype=float)
            if p.shape != self.priors.shape or not np.all((p > 0) & (p < 1)):
                raise InputError(f"context_priors must return a {self.priors.shape} array "
                                 "in (0, 1)", field="context_priors", value=p.shape)
        if self.line_aliases is not None:
            from unseeable.domain.features import feature_values

            present = feature_values(seen.extent, seen.occupancy).astype(bool)
            if visible is None:
                visible = self.visibility(structure, geometry=geometry, threshold=threshold)
            p = self.line_aliases.count_once(p, present, visible & self.judged)
        return p

    def log_probability_of(self, structure: Structure, *, shift: float = 0.0,
                           geometry: LogGeometry = LogGeometry(),
                           threshold: float = DEFAULT_THRESHOLD) -> float:
        """A structure's log-probability in this view under the visibility and the priors
        it implies itself.

        What a settled fixpoint of :func:`estimate_with_visibility` maximises
        locally: the visible, judged features weigh with the priors the structure
        implies (:meth:`priors_under`, their log-odds moved by ``shift`` as a
        presence shift moves them), every other feature with ½. Unlike a solve's
        log-probability it does not depend on the estimate made before, so
        hypotheses that hide different features compare in one currency; e.g.
        whether a wrong estimate is the evidence's fault (it outscores the truth)
        or the search's (``benchmarks/diagnose.py blame``).

        Parameters
        ----------
        structure : Structure
            In the observation's extent.
        shift : float
            Added to the log-odds of the judged priors (kept within ``clip``).
        geometry : LogGeometry
        threshold : float
            As :func:`estimate_with_visibility`'s.

        Returns
        -------
        float
            ``Σ_f log p_f(g_f(Z))`` over every feature of the extent, in nats.
        """
        visible = self.visibility(structure, geometry=geometry, threshold=threshold)
        p = self.priors_under(structure, geometry=geometry, visible=visible)
        if shift:
            p = _shift_log_odds(p, shift, self.judged, self.clip)
        return self.evidence(structure.extent, visible, p).log_probability(self._seen(structure))


def observation_terms(observations, visibility, extent: Extent, priors=None) -> list:
    """Objective terms of several observations under per-view visibility masks (and
    per-view priors, default each observation's own)."""
    from unseeable.grammar import EvidenceTerm

    if priors is None:
        priors = [None] * len(observations)
    return [EvidenceTerm(obs.evidence(extent, vis, p), obs.removed_from_layer)
            for obs, vis, p in zip(observations, visibility, priors)]


@dataclass(frozen=True, eq=False)
class VisibilityFixpoint:
    """Outcome of :func:`estimate_with_visibility`.

    Attributes
    ----------
    result : SolveResult
        The solve that produced the kept structure.
    visibility : tuple of (N,) bool
        Per view, the visibility under which the kept structure was estimated.
    priors : tuple of (N,) float
        Per view, the detector priors of that estimate (they differ from the
        observation's own when it has ``context_priors``).
    final : bool
        False for a round that only seeds the next (ties left to the local
        moves, or stopped within the round slack); what
        :func:`estimate_with_visibility` returns is always final.
    terms : list
        The objective terms of that solve (used by the confidence test).
    iterations : int
        Number of structure estimates made.
    converged : bool
        True for a fixpoint, False when a cycle was detected or the cap reached.
    cycle_length : int
        Length of the detected cycle (0 for a fixpoint).
    history : list of dict
        Per iteration: log-probability, visible features, changed features, seconds.
    presence_shift : tuple of float
        Per view, the shift of the priors' log-odds the estimate was made under
        (``presence_shift`` of :func:`estimate_with_visibility`: the one fitted to
        the estimate before, within :data:`PRESENCE_SHIFT_BOUND`; 0 where none was
        worth a further fixpoint or where it was refused; empty without).
    presence_fitted : tuple of float
        Per view, the shift fitted to the estimate before, unbounded, applied or not
        (empty without ``presence_shift``).
    presence_refused : tuple of bool
        Per view, whether the estimate under the shifts kept present fewer than
        :data:`PRESENCE_SHIFT_KEEP` of the features the view sees clearly; if any
        did, no view is shifted and the estimate is the one before. Empty without
        ``presence_shift``.
    """

    result: object
    visibility: tuple
    terms: list
    iterations: int
    converged: bool
    cycle_length: int
    history: list = field(default_factory=list)
    priors: tuple = ()
    final: bool = True
    presence_shift: tuple = ()
    presence_fitted: tuple = ()
    presence_refused: tuple = ()

    @property
    def structure(self) -> Structure:
        return self.result.structure


def estimate_with_visibility(observations, extent: Extent, *, solver,
                             initial_visibility=None, geometry: LogGeometry = LogGeometry(),
                             threshold: float = DEFAULT_THRESHOLD, max_iterations: int = 12,
                             fixed_visibility: bool = False,
                             time_limit: float = 60.0,
                             defer_ties: bool = True,
                             context_rounds: int = 2,
                             round_slack: float = 0.02,
                             budget_s: float | None = None,
                             presence_shift: bool = False,
                             structure_prior: Sequence | Callable = ()
                             ) -> VisibilityFixpoint:
    """Estimate structure and visibility together, to a fixpoint.

    Parameters
    ----------
    observations : ViewEvidence or sequence of ViewEvidence
    extent : Extent
    solver : StructureSolver
        A kept model for ``extent`` (re-solved once per iteration, warm-started).
    initial_visibility : (N,) bool or sequence of them, optional
        Starting visibility per view (default: every judged feature visible).
    threshold : float
        Share of blocked rays that makes a feature occluded (paper: 0.6).
    max_iterations : int
        Cap on estimates per visibility fixpoint; the paper saw fixpoints or
        2-cycles within 3–4.
    fixed_visibility : bool
        Keep ``initial_visibility`` (e.g. ground-truth, "manual" visibility):
        one estimate per round instead of a fixpoint.
    defer_ties : bool
        With a solver whose tie policy resolves ties by a cost ("emptiest",
        "fewest"): iterate with the cheap local tie moves only and search for
        the policy's member of the tie once visibility has settled (then
        check that it settles for that member too, iterating on with the full
        policy if not), or for the estimate kept from a cycle. The search is
        most of a solve's time on a large extent (docs/decisions.md).
    context_rounds : int
        For observations with ``context_priors``: after the fixpoint under
        their own priors, up to this many further fixpoints, each under the
        priors the previous estimate implies (what lies behind each feature),
        starting from its visibility; they stop early when the priors repeat.
        0: the observations' own priors only.
    round_slack : float
        A round that may not be the last stops once an estimate changes the
        visibility of at most this share of the features it was made under
        (the next round starts from there and iterates on): on the largest
        cabins the first round's last few estimates, each changing a handful
        of features, were most of the time (docs/decisions.md). 0: every round
        to its fixpoint.
    budget_s : float, optional
        Wall-clock seconds after which no further estimate is started: the
        fixpoint stops as at ``max_iterations`` (the more probable of its last
        two estimates, ``converged`` False) and no further round begins. A
        solve already running keeps its own ``time_limit``. On evidence the
        grammar cannot reconcile (a photograph taken by another camera than
        the one the view names) every solve runs to its time limit and the
        rounds took minutes; on sound evidence the budget is never reached.
        None: no budget.
    presence_shift : bool
        After the rounds, estimate again under each view's priors shifted to
        agree with the estimate (:func:`fit_presence_shift`), each shift within
        :data:`PRESENCE_SHIFT_BOUND`; when the shifted estimate drops most of the
        features a view sees clearly (:data:`PRESENCE_SHIFT_KEEP`) the estimate
        stays as it was and ``presence_refused`` says so.
    structure_prior : sequence of Factor, or callable
        A prior over structures (e.g. :func:`~unseeable.grammar.joint_prior`), in
        a last round: a fixpoint under the final priors with the prior's factors
        added, from the estimate before. A callable is given each estimate's
        visibility (a tuple of ``(N,) bool``, one per view) and returns the
        factors for it (the pipeline's prior charges only joints seen,
        :func:`~unseeable.grammar.seen_joints`). The rounds before only find the
        visibility and the priors, and solve faster without it (a joint prior
        made each solve about 2.5 times slower). The result is a fixpoint of the
        whole objective; its ``terms`` include the prior. Empty: none (the
        paper's uniform prior).

    Returns
    -------
    VisibilityFixpoint
        Of the last round; ``iterations`` and ``history`` cover every round.
    """
    if isinstance(context_rounds, bool) or not isinstance(context_rounds, int) \
            or context_rounds < 0:
        raise InputError("must be a whole number >= 0", field="context_rounds",
                         value=context_rounds)
    if not 0.0 <= round_slack < 1.0:
        raise InputError("must be in [0, 1)", field="round_slack", value=round_slack)
    deadline = (None if budget_s is None
                else time.perf_counter() + check_seconds(budget_s, field="budget_s"))
    obs = [observations] if isinstance(observations, ViewEvidence) else list(observations)
    if not obs:
        raise InputError("needs at least one observation", field="observations", value=[])
    if callable(structure_prior):
        prior_of = structure_prior
    elif structure_prior:
        factors = tuple(structure_prior)
        prior_of = lambda visibility: factors  # noqa: E731 (the same under any visibility)
    else:
        prior_of = None
    if initial_visibility is None:
        vis = tuple(o.judged.copy() for o in obs)
    elif isinstance(initial_visibility, np.ndarray) and initial_visibility.ndim == 1:
        vis = (np.asarray(initial_visibility, dtype=bool),)
    else:
        vis = tuple(np.asarray(v, dtype=bool) for v in initial_visibility)
    if len(vis) != len(obs):
        raise InputError(f"needs one visibility mask per observation ({len(obs)})",
                         field="initial_visibility", value=len(vis))
    if not any(o.context_priors is not None or o.line_aliases is not None for o in obs):
        context_rounds = 0  # the priors do not depend on the estimate
    priors = tuple(o.priors for o in obs)
    history: list = []
    hint = None
    fixpoint = functools.partial(_visibility_fixpoint, obs, extent=extent, solver=solver,
                                 geometry=geometry, threshold=threshold,
                                 max_iterations=max_iterations, fixed=fixed_visibility,
                                 time_limit=time_limit, defer_ties=defer_ties,
                                 deadline=deadline)
    def implied(fp):
        return tuple(o.priors_under(fp.structure, geometry=geometry, threshold=threshold)
                     for o in obs)

    def same(a, b):
        return all(np.array_equal(x, y) for x, y in zip(a, b))

    for round_ in range(context_rounds + 1):
        last = round_ == context_rounds
        # A round that may not be the last leaves ties to the cheap local moves: the
        # search for the tie policy's member is a third of the time on a cabin, and
        # only the kept estimate needs it.
        fp = fixpoint(priors, vis, hint=hint, settle_ties=last,
                      slack=0.0 if last else round_slack)
        steps = list(fp.history)
        if not last:
            new_priors = implied(fp)
            if same(priors, new_priors) and not fp.final:
                # The last round, it seems: its estimate becomes the tie policy's member
                # of its tie, visibility must settle for that member (else iterate on), and
                # the priors it implies must still be the round's (else the rounds go on).
                settled = solver.resolve_tie(fp.terms, fp.result)
                before = fp.structure
                fp = replace(fp, result=settled, final=True)
                if not fixed_visibility:  # (a round stopped within its slack is unsettled)
                    new_vis = tuple(o.visibility(settled.structure, geometry=geometry,
                                                 threshold=threshold) for o in obs)
                    if not same(new_vis, fp.visibility):
                        fp = fixpoint(priors, new_vis, hint=settled, settle_ties=True)
                        steps += fp.history
                if fp.structure != before:
                    new_priors = implied(fp)
        for step in steps:
            step["round"] = round_
        history += steps
        if last or same(priors, new_priors):
            break
        if deadline is not None and time.perf_counter() >= deadline:
            logger.warning("time budget of %.0f s spent: no further context round", budget_s)
            break
        logger.debug("context round %d: %d priors re-weighed", round_ + 1,
                     sum(int(np.sum(a != b)) for a, b in zip(priors, new_priors)))
        priors, vis, hint = new_priors, fp.visibility, fp.result
    if presence_shift and fp.structure is not None:
        # A round with the prior follows: it settles the tie; this one leaves it to the
        # cheap local moves, as the context rounds do.
        fp = _presence_shift_round(obs, fp, extent, fixpoint, history, deadline,
                                   settle_ties=prior_of is None)
    if prior_of is not None and fp.structure is not None:
        with_prior = _further_round(fixpoint, fp.priors, fp, history, extra_terms=prior_of)
        fp = replace(with_prior, presence_shift=fp.presence_shift,
                     presence_fitted=fp.presence_fitted, presence_refused=fp.presence_refused)
    return replace(fp, iterations=len(history), history=history)


def _further_round(fixpoint, priors, fp: VisibilityFixpoint, history: list, *,
                   settle_ties: bool = True, **kwargs) -> VisibilityFixpoint:
    """A fixpoint under ``priors`` from ``fp``'s visibility and estimate, its steps
    appended to ``history`` as the next round; its tie settled on the tie policy's member
    unless ``settle_ties`` is False (``kwargs``: ``fixpoint``'s, e.g. ``extra_terms``)."""
    last_round = max((step.get("round", 0) for step in history), default=0)
    further = fixpoint(priors, fp.visibility, hint=fp.result, settle_ties=settle_ties,
                       slack=0.0, **kwargs)
    for step in further.history:
        step["round"] = last_round + 1
    history += further.history
    return further


def _presence_shift_round(obs, fp: VisibilityFixpoint, extent: Extent, fixpoint, history,
                          deadline, *, settle_ties: bool = True) -> VisibilityFixpoint:
    """The fixpoint under each view's priors shifted to agree with ``fp``'s estimate
    (``presence_shift`` of :func:`estimate_with_visibility`), each shift within
    :data:`PRESENCE_SHIFT_BOUND`; ``fp`` with shifts of 0 when none is worth a further
    fixpoint (or the time budget is spent), and when the shifted estimate drops most of
    a view's clearly seen features (:data:`PRESENCE_SHIFT_KEEP`). Appends the new
    round's steps to ``history``."""
    from unseeable.domain.features import feature_values

    fitted, clear = [], []
    for o, p, vis in zip(obs, fp.priors, fp.visibility):
        # A counted-out detection (½, LineAliases) is no reading: it neither informs the
        # shift nor moves with it.
        seen = vis & o.judged & (p != 0.5)
        present = feature_values(extent, o._seen(fp.structure).occupancy).astype(bool)
        fitted.append(fit_presence_shift(p[seen], present[seen]))
        clear.append(_clearly_present(p, seen, present))
    fitted_t = tuple(fitted)
    # The objective is concave in each view's shift, so the bound's edge is its best
    # shift within the bound.
    applied = tuple(float(np.clip(b, -PRESENCE_SHIFT_BOUND, PRESENCE_SHIFT_BOUND))
                    for b in fitted_t)

    def shifts(values) -> str:
        return ", ".join(f"{b:+.2f}" for b in values)

    unshifted = replace(fp, presence_shift=(0.0,) * len(obs), presence_fitted=fitted_t,
                        presence_refused=(False,) * len(obs))
    if max(abs(b) for b in applied) < PRESENCE_SHIFT_MIN:
        return unshifted
    if deadline is not None and time.perf_counter() >= deadline:
        logger.warning("time budget spent: the detections' presence shift (%s) is not "
                       "applied", shifts(applied))
        return unshifted
    if applied != fitted_t:
        logger.warning("the detections would need a presence shift of %s to agree with the "
                       "estimate; a look explains at most ±%.1f: shifted by %s",
                       shifts(fitted_t), PRESENCE_SHIFT_BOUND, shifts(applied))
    else:
        logger.debug("presence shift of the priors' log-odds: %s", shifts(applied))
    priors = tuple(_shift_log_odds(p, b, o.judged, o.clip)
                   for o, p, b in zip(obs, fp.priors, applied))
    shifted = _further_round(fixpoint, priors, fp, history, settle_ties=settle_ties)
    dropped = []
    for o, features in zip(obs, clear):
        after = feature_values(extent, o._seen(shifted.structure).occupancy)[features]
        dropped.append(bool(np.count_nonzero(after) < PRESENCE_SHIFT_KEEP * len(features)))
    if any(dropped):
        logger.warning("under the presence shift (%s) the estimate drops most of the present "
                       "features the detections see clearly: the estimate before it is kept",
                       shifts(applied))
        return replace(unshifted, presence_refused=tuple(dropped))
    return replace(shifted, presence_shift=applied, presence_fitted=fitted_t,
                   presence_refused=(False,) * len(obs))


def _clearly_present(priors: np.ndarray, seen: np.ndarray, present: np.ndarray) -> np.ndarray:
    """Indices of the features an estimate has present whose reading says present under
    every shift the bound allows: seen, with log-odds of at least
    :data:`PRESENCE_SHIFT_BOUND`."""
    from scipy.special import logit

    z = np.where(seen, logit(np.clip(priors, 1e-12, 1 - 1e-12)), -np.inf)
    return np.flatnonzero(seen & present & (z >= PRESENCE_SHIFT_BOUND))


def _visibility_fixpoint(obs, priors, vis, *, extent, solver, hint, geometry, threshold,
                         max_iterations, fixed, time_limit, defer_ties,
                         settle_ties=True, slack=0.0, deadline=None,
                         extra_terms=None) -> VisibilityFixpoint:
    """Visibility ⇄ structure to a fixpoint (or cycle) under fixed detector priors.

    ``settle_ties=False`` (with a deferring solver): never search for the tie
    policy's member of a tie; the result is then not ``final``.
    ``slack`` > 0: stop once an estimate changes at most that share of the visible
    features (not a fixpoint: ``converged`` False and not ``final``, the last
    estimate kept). ``deadline`` (a ``time.perf_counter()`` value): start no estimate
    after it, stopping as at ``max_iterations``. ``extra_terms``: a callable giving the
    factors added to a solve's objective (a structure prior) from the visibility the solve
    is made under; None: none."""
    from unseeable.solve import SolveStatus

    seen: dict[bytes, int] = {}
    runs: list[tuple] = []  # (result, visibility, terms)
    history = []
    converged, cycle_length, near = False, 0, False
    deferred = defer_ties and getattr(solver, "ties", "any") != "any"
    unsettled = deferred and not settle_ties

    def visibility_of(result):
        new = tuple(o.visibility(result.structure, geometry=geometry, threshold=threshold)
                    for o in obs)
        return new, b"".join(np.packbits(v).tobytes() for v in new)

    for iteration in range(max_iterations):
        t0 = time.perf_counter()
        key = b"".join(np.packbits(v).tobytes() for v in vis)
        seen[key] = iteration
        terms = observation_terms(obs, vis, extent, priors)
        if extra_terms is not None:
            terms += list(extra_terms(vis))
        result = solver.solve(terms, hint=hint, time_limit=time_limit,
                              ties="local" if deferred else None)
        if result.structure is None:
            raise InputError(f"no valid structure fits (solver status {result.status.value})",
                             field="constraints", value=result.status.value)
        if result.status != SolveStatus.OPTIMAL:
            logger.warning("iteration %d: solver stopped at %s", iteration, result.status.value)
        new_vis, new_key = (None, key) if fixed else visibility_of(result)
        if deferred and new_key == key and not unsettled:
            # Settled under the cheap tie moves: the estimate becomes the tie policy's
            # member, and visibility must settle for that one too (else iterate on, fully).
            deferred = False
            settled = solver.resolve_tie(terms, result)
            if settled.structure != result.structure and not fixed:
                new_vis, new_key = visibility_of(settled)
            result = settled
        runs.append((result, vis, terms))
        hint = result
        history.append(_step(result, vis, new_vis, t0))
        if new_key == key:
            converged = True
            break
        if slack and history[-1]["changed"] <= slack * history[-1]["visible"]:
            start, near = len(runs) - 1, True  # near enough for a round that seeds the next
            break
        if new_key in seen:
            start = seen[new_key]
            cycle_length = len(runs) - start
            logger.info("visibility cycle of length %d after %d estimates", cycle_length,
                        len(runs))
            break
        vis = new_vis
        if deadline is not None and time.perf_counter() >= deadline:
            start = max(0, len(runs) - 2)
            logger.warning("visibility did not settle before the time budget ran out "
                           "(%d estimates)", len(runs))
            break
    else:
        start = max(0, len(runs) - 2)
        logger.warning("visibility did not settle in %d estimates", max_iterations)
    if converged:
        chosen = runs[-1]
    else:
        # In a cycle (or at the cap): the highest-probability structure among the last runs.
        chosen = max(runs[start:], key=lambda r: r[0].log_probability)
    result, vis_used, terms_used = chosen
    if deferred and not unsettled:
        result = solver.resolve_tie(terms_used, result)
    return VisibilityFixpoint(result=result, visibility=vis_used, terms=terms_used,
                              iterations=len(runs), converged=converged,
                              cycle_length=cycle_length, history=history, priors=priors,
                              final=not (unsettled or near))


def _step(result, vis, new_vis, t0) -> dict:
    changed = None
    if new_vis is not None:
        changed = int(sum(int(np.sum(a != b)) for a, b in zip(vis, new_vis)))
    return {
        "log_probability": result.log_probability,
        "status": result.status.value,
        "visible": int(sum(int(v.sum()) for v in vis)),
        "changed": changed,
        "logs": len(result.structure),
        "seconds": time.perf_counter() - t0,
    }
