"""End-to-end estimation: evidence or views in, an :class:`Estimate` out.

This is the orchestration layer the command line calls: it strings the
stages together (pose → evidence → visibility ⇄ structure → confidence) and
writes the estimate file (DESIGN.md §6, ``unseeable/estimate@1``).
"""

from __future__ import annotations

import logging
import time
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from unseeable.domain.evidence import Evidence
from unseeable.domain.features import FeatureKind, feature_index, feature_values
from unseeable.domain.frames import GridPose
from unseeable.domain.grid import Extent
from unseeable.domain.io import structure_to_json
from unseeable.domain.structure import Structure
from unseeable.errors import VisionError, check_seconds, check_whole_number, vision_errors_name
from unseeable.fileio import write_json
from unseeable.parallel import single_blas_thread

if TYPE_CHECKING:  # imported where used: the later stages load lazily
    from unseeable.confidence import Confidence
    from unseeable.solve import SolveResult
    from unseeable.visibility.loop import LineAliases, Observation, VisibilityFixpoint
    from unseeable.vision.evidence import FeatureDetection

__all__ = ["Estimate", "estimate_evidence", "estimate_view", "estimate_file",
           "estimate_to_json", "write_estimate", "write_view_pictures", "ESTIMATE_FORMAT",
           "log_support", "boundary_ends", "run_demo", "DemoResult", "compare_with_truth",
           "errors_against_truth", "structure_prior", "TIE_POLICY", "JOINT_COST",
           "STACKED_JOINT_COST", "UNSUPPORTED_NOTCH_COST"]

logger = logging.getLogger(__name__)

ESTIMATE_FORMAT = "unseeable/estimate@1"
#: Estimates are the member of an exact tie with the fewest logs, then the longest:
#: hidden parts are built as walls are, of whole long logs (see
#: :class:`~unseeable.solve.StructureSolver`, ``ties``; docs/decisions.md).
TIE_POLICY = "fewest"
#: Nats a joint costs under the structure prior (:func:`~unseeable.grammar.joint_prior`):
#: two logs end to end on a line are ``exp(-1)`` as likely a priori as one log across
#: the joint. The soft form of :data:`TIE_POLICY` (docs/decisions.md, "A prior on
#: joints"); 0: the paper's uniform prior. Only joints a camera sees are charged
#: (:func:`~unseeable.grammar.seen_joints`); the tie policy settles the hidden ones.
JOINT_COST = 1.0
#: Nats a joint straight above another on the same wall costs under the structure prior
#: (:func:`~unseeable.grammar.stacked_joint_prior`): builders stagger joints
#: (docs/decisions.md, "Where no camera sees").
STACKED_JOINT_COST = 1.0
#: Nats a notch with nothing below it costs under the structure prior
#: (:func:`~unseeable.grammar.unsupported_notch_prior`): logs rest on every notch they
#: can (docs/decisions.md, "Where no camera sees").
UNSUPPORTED_NOTCH_COST = 1.0
#: An estimate's extent is in doubt when at least this many of the log ends it puts on the
#: extent's boundary, and at least :data:`EDGE_ENDS_ABSENT_SHARE` of those judged, are
#: judged absent (:func:`boundary_ends`): the assembly may go on beyond the extent, or the
#: grid be off it. Read off the corpus and family renders (docs/results.md).
EDGE_ENDS_ABSENT_MIN = 2
EDGE_ENDS_ABSENT_SHARE = 0.25
#: An estimate's evidence is in doubt when the detections' log-odds had to be shifted
#: this far (nats) towards absent to agree with it (the presence shift,
#: :func:`~unseeable.visibility.loop.fit_presence_shift`): the photograph shows much
#: more than any structure the grammar builds on this grid, as when the grid is off the
#: assembly. Set beyond every rightly posed view measured (down to -1.4, seen by other
#: cameras); the wrong poses it catches shift by -1.6 to -4.7 (docs/results.md).
PRESENCE_SHIFT_DOUBT = -1.5
#: The aliases' bar (``PoseSettings.alias_keep`` and ``finals_keep``) when an estimated
#: pose's estimate is in doubt and the pose is searched again (defaults 0.8 and 0.6).
WIDE_ALIAS_KEEP = 0.6


@dataclass(frozen=True, eq=False)
class Estimate:
    """A structure estimate with everything needed to judge and explain it.

    Attributes
    ----------
    result : SolveResult
        The MAP solve that produced the structure.
    priors : (N,) float
        The evidence the kept structure was estimated under (½ = none).
    visible : (N,) bool or None
        Per-feature visibility used (None for bare evidence files).
    confidence : Confidence or None
    pose : GridPose or None
        The pose used (given or estimated), when images were used.
    iterations, converged, cycle_length
        Of the visibility fixpoint (1, True, 0 without one).
    timings : dict
        Seconds per stage.
    extra : dict
        Stage-specific details written to the estimate file (e.g. pose quality).
    """

    result: SolveResult
    priors: np.ndarray
    visible: np.ndarray | None = None
    confidence: Confidence | None = None
    pose: GridPose | None = None
    iterations: int = 1
    converged: bool = True
    cycle_length: int = 0
    timings: dict = field(default_factory=dict)
    extra: dict = field(default_factory=dict)

    @property
    def structure(self) -> Structure:
        return self.result.structure

    @property
    def confident(self) -> bool | None:
        """The δ* test passed (:attr:`confidence`) and, for a pose estimated from the
        image, its choice among the candidates was not a near coin toss
        (``extra["pose_ambiguous"]``), and the log ends it puts on the extent's boundary
        were not seen to be missing (``extra["extent_doubt"]``), and the detections did
        not have to be shifted far towards absent to agree with it
        (``extra["evidence_doubt"]``): an estimate can be sure of its unseen logs only as
        far as it is sure where the grid lies. None without a confidence test."""
        if self.confidence is None:
            return None
        return (bool(self.confidence.confident) and not self.extra.get("pose_ambiguous", False)
                and not self.extra.get("extent_doubt", False)
                and not self.extra.get("evidence_doubt", False))


@dataclass(frozen=True)
class _StructureAtPose:
    """What :func:`estimate_view` estimated at one pose, and whether its extent is in doubt."""

    det: FeatureDetection
    obs: Observation
    fp: VisibilityFixpoint
    priors: np.ndarray
    judged: int
    absent: int
    doubt: bool


def log_support(structure: Structure, priors: np.ndarray) -> np.ndarray:
    """Whether each log of ``structure`` has direct evidence: a judged feature of its own.

    A log is "seen" when one of its end features or the u/v/w segments along its
    notches carries evidence (p ≠ ½); otherwise the grammar inferred it.

    Returns
    -------
    (L,) bool, in ``structure.logs`` order.
    """
    idx = feature_index(structure.extent)
    judged = np.asarray(priors) != 0.5
    seen = np.zeros(len(structure.logs), dtype=bool)
    for n, log in enumerate(structure.logs):
        pos = log.positions()
        kinds, ats = [], []
        kinds.append(FeatureKind.END_MINUS)
        ats.append(pos[0])
        kinds.append(FeatureKind.END_PLUS)
        ats.append(pos[-1])
        for q in pos:
            for kind in (FeatureKind.U, FeatureKind.V):
                kinds.append(kind)
                ats.append(q)
        for q in pos[:-1]:
            kinds.append(FeatureKind.W)
            ats.append(q)
        f = idx.lookup_many(np.array(kinds), np.array(ats))
        seen[n] = bool(judged[f].any())
    return seen


def boundary_ends(structure: Structure, priors: np.ndarray) -> tuple[int, int]:
    """The log ends ``structure`` puts on its extent's boundary that the evidence judged,
    and how many of those it judged absent.

    A log whose first notch is the first position along its axis (or whose
    last is the last) ends at the extent's edge. When the assembly is larger
    than the extent, its logs go on there and the end detectors see a log's
    side rather than its end disc: such ends are judged absent (p < ½), as
    they are when the grid is off the assembly. With the pose estimated, the
    doubt rule of :func:`estimate_view` (:data:`EDGE_ENDS_ABSENT_MIN`,
    :data:`EDGE_ENDS_ABSENT_SHARE`) held for 14 of 54 corpus views given an
    extent one position short each way; with the right extent for 12 of 579
    corpus and family views, 8 of them posed 7 mm or more off (of 27 so posed)
    and 4 posed right (docs/results.md).

    Parameters
    ----------
    structure : Structure
    priors : (N,) float
        Per feature of ``structure.extent`` (½ = not judged).

    Returns
    -------
    judged, absent : int

    Examples
    --------
    >>> from unseeable.domain import Extent, Log
    >>> s = Structure(Extent(2, 1, 1), [Log(layer=0, at=(0, 0), notches=2)])
    >>> p = np.full(len(feature_index(s.extent)), 0.5)
    >>> p[0], p[3] = 0.9, 0.1  # its end at i = 0 judged present, its end at i = 1 absent
    >>> boundary_ends(s, p)
    (2, 1)
    """
    extent = structure.extent
    priors = np.asarray(priors, dtype=float)
    idx = feature_index(extent)
    if priors.shape != (len(idx),):
        from unseeable.errors import InputError

        raise InputError(f"must have one prior per feature of {extent}", field="priors",
                         value=priors.shape)
    along_i = idx.at[:, 1] % 2 == 0  # Extent.axis: even layers run along i
    position = np.where(along_i, idx.at[:, 0], idx.at[:, 2])
    last = np.where(along_i, extent.I, extent.K) - 1
    at_edge = (((idx.kind == FeatureKind.END_MINUS) & (position == 0))
               | ((idx.kind == FeatureKind.END_PLUS) & (position == last)))
    judged = at_edge & feature_values(extent, structure.occupancy) & (priors != 0.5)
    return int(judged.sum()), int((judged & (priors < 0.5)).sum())


def line_aliases(det: FeatureDetection, camera) -> LineAliases:
    """The segment features of a detection that share image lines
    (:func:`~unseeable.vision.projection.collinear_segment_pairs`), with their distances
    from ``camera``'s centre."""
    from unseeable.visibility.loop import LineAliases
    from unseeable.vision.projection import collinear_segment_pairs

    projection = det.scores.projection
    first, second = collinear_segment_pairs(projection, det.judged)
    distance = np.linalg.norm(projection.centres_world - camera.centre, axis=1)
    return LineAliases(first, second, distance)


def structure_prior(extent: Extent, *, joint_cost: float = JOINT_COST,
                    stacked_joint_cost: float = STACKED_JOINT_COST,
                    unsupported_notch_cost: float = UNSUPPORTED_NOTCH_COST):
    """The pipeline's structure prior as the visibility fixpoint takes it.

    A callable from a visibility (one ``(N,) bool`` per view) to the factors of the
    joint prior on the joints that visibility sees
    (:func:`~unseeable.grammar.joint_prior`, :func:`~unseeable.grammar.seen_joints`),
    the stacked-joint prior on every pair
    (:func:`~unseeable.grammar.stacked_joint_prior`) and the unsupported-notch prior
    on every notch above layer 0
    (:func:`~unseeable.grammar.unsupported_notch_prior`); ``()`` when every cost is 0
    (the paper's uniform prior).
    """
    from unseeable.grammar import (
        check_prior_cost,
        joint_prior,
        seen_joints,
        stacked_joint_prior,
        unsupported_notch_prior,
    )

    joint_cost = check_prior_cost(joint_cost, field="joint_cost")
    fixed = (stacked_joint_prior(extent, stacked_joint_cost)
             + unsupported_notch_prior(extent, unsupported_notch_cost))
    if joint_cost == 0 and not fixed:
        return ()

    def prior(visibility):
        return joint_prior(extent, joint_cost, seen=seen_joints(extent, visibility)) + fixed
    return prior


def estimate_evidence(evidence: Evidence, *, backend: str = "cpsat", constraints=(),
                      confidence: bool = True, delta_star: float = 0.2,
                      tolerance: bool = True, time_limit: float = 60.0,
                      workers: int = 1, ties: str = TIE_POLICY,
                      joint_cost: float = JOINT_COST,
                      stacked_joint_cost: float = STACKED_JOINT_COST,
                      unsupported_notch_cost: float = UNSUPPORTED_NOTCH_COST) -> Estimate:
    """MAP structure for bare evidence, with its confidence.

    Features without evidence (p = ½) count as occluded for the confidence test;
    ``ties`` is the tie policy among equally probable structures,
    and ``joint_cost``, ``stacked_joint_cost`` and ``unsupported_notch_cost`` the
    structure prior's costs of a joint, of stacked joints and of a notch with
    nothing below (as for :func:`estimate_view`).

    Examples
    --------
    >>> from unseeable.domain import Extent, Log, Structure, simulate_evidence
    >>> truth = Structure(Extent(2, 1, 2), [Log(0, (0, 0), 2), Log(0, (0, 1), 2)])
    >>> ev = simulate_evidence(truth, accuracy=1.0, occluded_fraction=0.0, seed=0)
    >>> est = estimate_evidence(ev)
    >>> est.structure == truth, est.confident
    (True, True)
    """
    from unseeable.confidence import assess_confidence
    from unseeable.grammar import EvidenceTerm
    from unseeable.solve import StructureSolver

    t0 = time.perf_counter()
    # Bare evidence has no visibility: a feature with a reading (p != ½) counts as seen.
    prior_of = structure_prior(evidence.extent, joint_cost=joint_cost,
                               stacked_joint_cost=stacked_joint_cost,
                               unsupported_notch_cost=unsupported_notch_cost)
    prior = prior_of(evidence.judged) if prior_of else ()
    solver = StructureSolver(evidence.extent, constraints=constraints, backend=backend,
                             workers=workers, ties=ties)
    terms = [EvidenceTerm(evidence), *prior]
    result = solver.solve(terms, time_limit=time_limit)
    timings = {"estimate_s": time.perf_counter() - t0}
    conf = None
    if confidence and result.structure is not None:
        t1 = time.perf_counter()
        conf = assess_confidence(solver, terms, result, ~evidence.judged, delta_star=delta_star,
                                 tolerance=tolerance, time_limit=time_limit)
        timings["confidence_s"] = time.perf_counter() - t1
    timings["total_s"] = time.perf_counter() - t0
    return Estimate(result=result, priors=evidence.p, confidence=conf, timings=timings,
                    extra={"ties": ties, "joint_cost": float(joint_cost),
                           "stacked_joint_cost": float(stacked_joint_cost),
                           "unsupported_notch_cost": float(unsupported_notch_cost)})


def estimate_to_json(estimate: Estimate, *, features: bool = True) -> dict[str, Any]:
    """The estimate file's content (DESIGN.md §6)."""
    r = estimate.result
    data: dict[str, Any] = {
        "format": ESTIMATE_FORMAT,
        "status": r.status.value,
        "structure": None if r.structure is None else structure_to_json(r.structure),
        "log_probability": r.log_probability,
        "bound": r.bound,
        "backend": r.backend,
    }
    if estimate.pose is not None:
        data["pose"] = estimate.pose.to_json()
    if estimate.confidence is not None:
        data.update({
            "confident": estimate.confident,
            "confident_at_pose": estimate.confidence.confident,
            "tolerance": estimate.confidence.tolerance,
            "delta_star": estimate.confidence.delta_star,
            "occluded_features": estimate.confidence.occluded,
        })
    data["iterations"] = estimate.iterations
    data["converged"] = estimate.converged
    data["cycle_length"] = estimate.cycle_length
    data["timings"] = {**estimate.timings, "solver": r.timings}
    if r.choices:
        data["choices"] = r.choices
    if r.structure is not None:
        seen = log_support(r.structure, estimate.priors)
        data["logs_seen"] = seen.tolist()
    data.update(estimate.extra)
    if features and r.structure is not None:
        idx = feature_index(r.structure.extent)
        value = feature_values(r.structure.extent, r.structure.occupancy)
        vis = estimate.visible
        items = []
        for n in range(len(idx)):
            item = {"kind": FeatureKind(int(idx.kind[n])).label, "at": idx.at[n].tolist(),
                    "p": float(estimate.priors[n]), "value": bool(value[n])}
            if vis is not None:
                item["visible"] = bool(vis[n])
            items.append(item)
        data["features"] = items
    return data


def write_estimate(estimate: Estimate, out_dir: str | Path) -> Path:
    """Write ``out_dir/estimate.json`` atomically and return its path."""
    path = Path(out_dir) / "estimate.json"
    write_json(path, estimate_to_json(estimate), indent=1)
    return path


def estimate_file(path: str | Path, data: Any, *, out_dir: str | Path | None = None,
                  backend: str = "cpsat", delta_star: float = 0.2, tolerance: bool = True,
                  time_limit: float = 60.0, truth: Structure | None = None,
                  truth_pose: GridPose | None = None, strict_pose: bool = True,
                  threads: int = 1, ties: str = TIE_POLICY,
                  calibration: str | Path | None = None,
                  joint_cost: float = JOINT_COST,
                  stacked_joint_cost: float = STACKED_JOINT_COST,
                  unsupported_notch_cost: float = UNSUPPORTED_NOTCH_COST
                  ) -> tuple[Estimate, list[Path]]:
    """Estimate from a parsed evidence or view file, told apart by its format tag.

    Returns the estimate and the pictures written to ``out_dir`` (views only;
    coloured against ``truth``, placed at ``truth_pose`` when known, see
    :func:`write_view_pictures`); ``strict_pose``, ``threads``, ``ties``,
    ``joint_cost``, ``stacked_joint_cost`` and ``unsupported_notch_cost`` as
    :func:`estimate_view`.
    ``calibration``: a detector calibration file for a view (default: the shipped
    one), recorded in the estimate's ``extra``; an evidence file holds its priors
    already and takes none.
    """
    from unseeable.domain.evidence import EVIDENCE_FORMAT, evidence_from_json
    from unseeable.errors import InputError

    fmt = data.get("format") if isinstance(data, dict) else None
    if fmt == EVIDENCE_FORMAT:
        if calibration is not None:
            raise InputError("serves views only: an evidence file holds its priors already",
                             file=path, field="calibration", value=str(calibration))
        evidence = evidence_from_json(data, file=path)
        est = estimate_evidence(evidence, backend=backend, delta_star=delta_star,
                                tolerance=tolerance, time_limit=time_limit, ties=ties,
                                joint_cost=joint_cost, stacked_joint_cost=stacked_joint_cost,
                                unsupported_notch_cost=unsupported_notch_cost)
        return est, []
    if fmt == "unseeable/view@1":
        return _estimate_view_file(path, out_dir=out_dir, backend=backend,
                                   delta_star=delta_star, tolerance=tolerance,
                                   time_limit=time_limit, truth=truth,
                                   truth_pose=truth_pose, strict_pose=strict_pose,
                                   threads=threads, ties=ties, calibration=calibration,
                                   joint_cost=joint_cost,
                                   stacked_joint_cost=stacked_joint_cost,
                                   unsupported_notch_cost=unsupported_notch_cost)
    raise InputError(f"must be {EVIDENCE_FORMAT!r} or 'unseeable/view@1'", file=path,
                     field="format", value=fmt)


def _estimate_view_file(path, *, out_dir=None, backend="cpsat", delta_star=0.2,
                        tolerance=True, time_limit=60.0, truth=None, truth_pose=None,
                        strict_pose=True, threads=1, ties=TIE_POLICY, calibration=None,
                        joint_cost=JOINT_COST, stacked_joint_cost=STACKED_JOINT_COST,
                        unsupported_notch_cost=UNSUPPORTED_NOTCH_COST):
    from unseeable.render.view import load_view
    from unseeable.vision.calibration import load_calibration

    # Read before the view and the pose search: a bad file costs nothing.
    cal = load_calibration(calibration) if calibration is not None else None
    view = load_view(path)
    with vision_errors_name(path):  # e.g. a poor pose fit: which view
        est = estimate_view(view, backend=backend, delta_star=delta_star, tolerance=tolerance,
                            time_limit=time_limit, strict_pose=strict_pose, threads=threads,
                            ties=ties, calibration=cal, joint_cost=joint_cost,
                            stacked_joint_cost=stacked_joint_cost,
                            unsupported_notch_cost=unsupported_notch_cost)
    est = replace(est, extra={**est.extra, "calibration": str(calibration)
                              if calibration is not None else "shipped"})
    pictures = []
    if out_dir is not None:
        pictures = write_view_pictures(est, view, out_dir, truth=truth, truth_pose=truth_pose)
    return est, pictures


@single_blas_thread()
def estimate_view(view, *, pose: GridPose | None = None, backend: str = "cpsat",
                  calibration=None, confidence: bool = True, delta_star: float = 0.2,
                  tolerance: bool = True, manual_visibility: np.ndarray | None = None,
                  constraints=(), time_limit: float = 60.0, workers: int = 1,
                  refine_pose: bool = True, use_view_pose: bool = True,
                  strict_pose: bool = True, background: bool = True,
                  presence_shift: bool = True, threads: int = 1,
                  ties: str = TIE_POLICY, lines_once: bool = True,
                  joint_cost: float = JOINT_COST,
                  stacked_joint_cost: float = STACKED_JOINT_COST,
                  unsupported_notch_cost: float = UNSUPPORTED_NOTCH_COST) -> Estimate:
    """Estimate a structure from one photograph: pose → evidence → visibility ⇄ structure
    → confidence.

    Parameters
    ----------
    view : View
        Image, camera, extent; its pose (if recorded) is used unless ``pose`` is given,
        else the pose is estimated from the image.
    pose : GridPose, optional
        A known pose (overrides the view's).
    backend : str
        MAP backend.
    calibration : Calibration, optional
        Detector score → probability maps (the shipped ones by default).
    confidence, delta_star, tolerance
        Run the δ* test, with threshold ``delta_star``, and the tolerance search.
    manual_visibility : (N,) bool, optional
        Use this ("manual", e.g. ground-truth) visibility instead of the fixpoint.
    constraints : sequence of Expr
        Extra hard constraints (e.g. from a description).
    time_limit : float
        Seconds per solve, and the visibility fixpoint's budget: it starts no
        new estimate after this many seconds (``budget_s`` of
        :func:`~unseeable.visibility.estimate_with_visibility`; ``converged``
        is then False).
    refine_pose : bool
        Polish a given pose on the image's edges before detecting features (an
        estimated one is aligned on them already; one moved by the polish on its
        estimate is polished so too).
    use_view_pose : bool
        Use the pose recorded in the view when ``pose`` is not given; False
        estimates it from the image even then.
    strict_pose : bool
        Raise :class:`~unseeable.errors.VisionError` when the pose estimated
        from the image is a poor fit (the issue's "report a failure instead of
        a wrong pose"); False uses it anyway, with its quality in
        ``extra["pose_quality"]`` (a poor fit is right more often than not on
        renders unlike the training ones: docs/results.md).
    background : bool
        Re-weigh the detections by what lies behind each feature under the
        current estimate (wood or table), iterated in the fixpoint with
        visibility, when the calibration has context models (the shipped one
        does). False: the plain calibration throughout.
    presence_shift : bool
        Then shift the log-odds of every detection by the amount that makes them
        agree best with the estimate, and estimate again under them
        (:func:`~unseeable.visibility.loop.fit_presence_shift`): the detectors'
        calibration adapted to the photograph's look. The shift applied is in
        ``extra["presence_shift"]`` (0 when under
        :data:`~unseeable.visibility.loop.PRESENCE_SHIFT_MIN`: no new estimate); the
        priors reported are the shifted ones.
    lines_once : bool
        Count the edge of an image line that several segment features share once
        under each estimate (:class:`~unseeable.visibility.loop.LineAliases`): the
        nearest present one keeps the detection, the others read ½. False: every
        detection counts on its own, as the calibration was fitted.
    threads : int
        Threads for the pose search and the choice among its candidates, when the
        pose is estimated (the estimate is the same for any number; a caller that
        runs images in parallel processes leaves it at 1).
    ties : {"fewest", "emptiest", "any"}
        Which of equally probable structures (hidden parts) to keep: the fewest
        logs, then the longest (:data:`TIE_POLICY`, the default); the fewest positions
        plus logs; or whichever the solver finds, the paper's plain MAP (see
        :class:`~unseeable.solve.StructureSolver`).
    joint_cost : float
        Nats each joint (two logs end to end on a line) costs under the structure
        prior (:func:`~unseeable.grammar.joint_prior`, :data:`JOINT_COST`), applied
        in the visibility fixpoint's last round to the joints its visibility sees
        (:func:`~unseeable.grammar.seen_joints`); 0 (with the two costs below 0):
        the paper's uniform prior. The reported log-probability includes it.
    stacked_joint_cost : float
        Nats a joint straight above another on the same wall (two layers up) costs
        under the structure prior (:func:`~unseeable.grammar.stacked_joint_prior`,
        :data:`STACKED_JOINT_COST`), seen or not, in the same round: builders
        stagger joints, and where a wall is hidden this decides where its joints go.
        0: none (assemblies that stack joints as often as chance would).
    unsupported_notch_cost : float
        Nats each notch above layer 0 with nothing below it costs under the
        structure prior (:func:`~unseeable.grammar.unsupported_notch_prior`,
        :data:`UNSUPPORTED_NOTCH_COST`), in the same round: logs rest on every
        notch they can, and where a course is hidden this fills it under the logs
        above. 0: none.

    Returns
    -------
    Estimate
        With the pose used, and the structure in the view's extent. For an
        estimated pose, ``extra`` holds its fit quality and how clearly the
        structure choice picked it (``pose_choice_margin``, ``pose_ambiguous``:
        an ambiguous choice makes the estimate not confident; ``pose_rival``,
        the best other candidate). For every view, ``extra`` also holds how many
        of the log ends the estimate puts on the extent's boundary were judged
        and judged absent (``edge_ends_judged``, ``edge_ends_absent``;
        :func:`boundary_ends`) and whether that puts the extent or the pose in
        doubt (``extent_doubt``, logged as a warning; the estimate is then not
        confident). Likewise ``evidence_doubt`` when the detections had to be shifted
        by :data:`PRESENCE_SHIFT_DOUBT` or more towards absent to agree with the
        estimate (``presence_shift``): the grid may be off the assembly (only the
        confidence is affected). An estimated pose whose extent is in doubt is
        searched again with the aliases' bar at :data:`WIDE_ALIAS_KEEP`
        (``pose_searched_again``), and that search's pose is used when its estimate is not in doubt
        (``pose_changed_by_second_search``; the pose fields are then its own).
        An estimated pose is then polished far on the edges of its estimate
        and the move judged (:func:`~unseeable.vision.judge_polish`: both gains
        in ``pose_polish_gain``); a better one is used when its estimate is not
        in doubt (``pose_moved_by_polish``).

    Notes
    -----
    An estimated pose fixes the yaw modulo 90° from vanishing directions, and the
    pose fit's edge alignment picks among quarter turns (which change the
    hypothesis: the bottom layer's direction). The remaining half turn describes
    the same physical assembly with the grid numbered from the other corner
    (DESIGN.md §3), so it is not estimated again; the pose is reported with its
    yaw in ``[-90, 90)``.
    """
    from unseeable.confidence import assess_confidence, occluded_features
    from unseeable.solve import StructureSolver, check_tie_policy
    from unseeable.visibility import BACKGROUND_INPUTS, initial_visibility
    from unseeable.visibility.loop import Observation, estimate_with_visibility
    from unseeable.vision import (
        PoseFit,
        PoseSettings,
        detect_features,
        estimate_pose,
        judge_polish,
        select_pose,
    )
    from unseeable.vision.edges import as_rgb_image
    from unseeable.vision.pose_choice import poses_apart
    from unseeable.vision.scale import view_edge_maps

    check_whole_number(threads, field="threads", minimum=1)
    check_seconds(time_limit, field="time_limit")
    check_tie_policy(ties)  # before the pose search, not after it
    t0 = time.perf_counter()
    image = view.image
    camera = view.camera
    extent = view.extent
    prior_of = structure_prior(extent, joint_cost=joint_cost,
                               stacked_joint_cost=stacked_joint_cost,
                               unsupported_notch_cost=unsupported_notch_cost)
    timings: dict[str, float] = {}
    extra: dict[str, Any] = {"ties": ties, "joint_cost": float(joint_cost),
                             "stacked_joint_cost": float(stacked_joint_cost),
                             "unsupported_notch_cost": float(unsupported_notch_cost)}
    given = pose if pose is not None else (view.pose if use_view_pose else None)
    # One image, several poses (the search, the choice, the detections): its edges once.
    rgb = as_rgb_image(image)
    pose_maps = view_edge_maps(rgb, camera, pose=True)
    maps = view_edge_maps(rgb, camera, maps=pose_maps)  # the detectors' (the same in range)
    # The pose choice's detections at its candidates (estimated poses only): those poses are
    # aligned on the image's edges already, as detect_features would polish them.
    detections: dict = {}

    def choose_pose(settings: PoseSettings, strict: bool, *, warn: bool = True) -> PoseFit:
        fit = estimate_pose(image, camera, extent, maps=pose_maps, strict=strict,
                            settings=settings, threads=threads,
                            quality_model=None if calibration is None else calibration.pose_quality)
        if warn and fit.quality < settings.min_quality:
            logger.warning("the pose fit is poor (quality %.2f); used as asked", fit.quality)
        # The grid's near-symmetric translations fit the edges almost as well: the
        # structure the detections imply at each decides (unseeable.vision.pose_choice).
        # Not polished on the implied structure here: the detectors' calibration was fitted
        # with grid-polished poses, and on the corpus the structure polish cost errors
        # (docs/results.md); detect_features polishes the choice on the grid instead.
        return select_pose(image, camera, extent, fit, calibration=calibration,
                           time_limit=time_limit, polish=False, maps=maps,
                           detections=detections, threads=threads)

    def pose_extra(fit: PoseFit) -> dict[str, Any]:
        return {"pose_source": "estimated", "pose_quality": fit.quality,
                "pose_choice_margin": fit.choice_margin, "pose_ambiguous": fit.ambiguous,
                "pose_rival": (None if fit.choice_rival is None
                               else fit.choice_rival.to_json())}

    if given is not None:
        pose_used = given
        extra["pose_source"] = "given"
    else:
        if manual_visibility is not None:
            from unseeable.errors import InputError

            raise InputError("manual visibility needs a known pose (give pose=)",
                             field="manual_visibility", value="given without a pose")
        fit = choose_pose(PoseSettings(), strict_pose)
        timings["pose_s"] = time.perf_counter() - t0
        extra.update(pose_extra(fit))
        # The pose fit separates quarter turns by the edges themselves (its margin over
        # the best quarter-turned hypothesis; layer heights differ by half a log). A half
        # turn re-describes the same physical assembly (DESIGN.md §3), so it is not
        # estimated again: on the corpus the more probable of the two readings was a coin
        # toss (16 images better, 16 worse) at the cost of a detection and a solve
        # (docs/decisions.md, "Symbolic orientation of an estimated pose").
        pose_used = fit.pose
    solver = StructureSolver(extent, constraints=constraints, backend=backend,
                             workers=workers, ties=ties)

    def structure_at(at: GridPose, *, det: FeatureDetection | None = None
                     ) -> _StructureAtPose:
        t1 = time.perf_counter()
        if det is None:
            det = detections.get(at)
        if det is None:
            det = detect_features(image, camera, at, extent, calibration=calibration,
                                  refine=refine_pose and given is not None, maps=maps)
        timings["evidence_s"] = timings.get("evidence_s", 0.0) + time.perf_counter() - t1
        contextual = background and det.has_context
        # With context, the first estimate reads every feature as seen against the table
        # (nothing behind): a fuller estimate, whose rounds then discount what it puts
        # behind. Starting from the plain models' estimate did worse on the corpus
        # (docs/decisions.md, "What lies behind a feature").
        start_priors = (det.priors_given(np.zeros((len(det.p), len(BACKGROUND_INPUTS))))
                        if contextual else det.p)
        obs = Observation(start_priors, camera.centre, det.pose, judged=det.judged,
                          removed_from_layer=view.removed_from_layer,
                          context_priors=det.priors_given if contextual else None,
                          clip=None if det.calibration is None else det.calibration.clip,
                          line_aliases=line_aliases(det, camera) if lines_once else None)
        if manual_visibility is not None:
            start_vis = np.asarray(manual_visibility, dtype=bool)
        else:
            start_vis = initial_visibility(extent, camera, det.pose)
        t2 = time.perf_counter()
        fp = estimate_with_visibility(obs, extent, solver=solver,
                                      initial_visibility=start_vis,
                                      fixed_visibility=manual_visibility is not None,
                                      time_limit=time_limit, budget_s=time_limit,
                                      presence_shift=presence_shift,
                                      structure_prior=prior_of)
        timings["structure_s"] = timings.get("structure_s", 0.0) + time.perf_counter() - t2
        priors = np.where(fp.visibility[0] & obs.judged, fp.priors[0], 0.5)
        judged = absent = 0
        if fp.result.structure is not None:
            judged, absent = boundary_ends(fp.result.structure, priors)
        doubt = absent >= EDGE_ENDS_ABSENT_MIN and absent >= EDGE_ENDS_ABSENT_SHARE * judged
        return _StructureAtPose(det, obs, fp, priors, judged, absent, bool(doubt))

    at = structure_at(pose_used)
    if at.doubt and given is None:
        # Log ends seen missing at the boundary: the grid may be off the assembly by a
        # near-symmetry whose edges scored under the aliases' bar. Searched again with the
        # bar lowered, and kept only if the new estimate is not in doubt (docs/results.md:
        # 2 of the 8 such wrong poses righted on 579 corpus and family views, none lost;
        # about 2 % of photographs pay for it).
        t_again = time.perf_counter()
        wide = PoseSettings(alias_keep=WIDE_ALIAS_KEEP, finals_keep=WIDE_ALIAS_KEEP)
        again = choose_pose(wide, False, warn=False)  # the first search's fit was taken
        extra["pose_searched_again"] = True
        if poses_apart(again.pose, pose_used, extent):
            second = structure_at(again.pose)
            if not second.doubt:
                at = second
                extra.update(pose_extra(again))
                extra["pose_changed_by_second_search"] = True
        timings["pose_again_s"] = time.perf_counter() - t_again
    if given is None and at.fp.result.structure is not None:
        # The search's candidates sit on the grid's edges; the estimate's own edges can hold
        # the pose elsewhere, a depth alias away, or draw it onto other logs' edges: the
        # move is judged as the pose choice judges candidates (docs/results.md).
        t_polish = time.perf_counter()
        shown = at.fp.result.structure  # the logs the image shows (after any removal)
        if view.removed_from_layer is not None:
            shown = shown.removed_from_layer(view.removed_from_layer)
        proposal = judge_polish(image, camera, shown, at.det, calibration=calibration,
                                maps=maps, pose_maps=pose_maps, time_limit=time_limit,
                                refine=refine_pose)
        if proposal is not None:
            extra["pose_polish_gain"] = [proposal.gain_before, proposal.gain_after]
            if proposal.better:
                moved = structure_at(proposal.detection.pose, det=proposal.detection)
                if not moved.doubt:
                    at = moved
                    extra["pose_moved_by_polish"] = True
        timings["pose_polish_s"] = time.perf_counter() - t_polish
    fp, obs, priors = at.fp, at.obs, at.priors
    if fp.result.structure is not None:
        # Only the confidence is doubted: searching an estimated pose in this doubt again,
        # as for extent_doubt, righted none of the wrong poses it caught on the corpora and
        # families and left three views 1-4 errors worse (docs/results.md).
        shift = fp.presence_shift[0] if fp.presence_shift else 0.0
        extra.update({"edge_ends_judged": at.judged, "edge_ends_absent": at.absent,
                      "extent_doubt": at.doubt,
                      "evidence_doubt": bool(shift <= PRESENCE_SHIFT_DOUBT)})
        if fp.presence_shift:
            extra["presence_shift"] = shift
        if at.doubt:
            logger.warning("%d of the %d log ends the estimate puts on the extent's boundary "
                           "look absent: is the extent %s too small, or the pose off?",
                           at.absent, at.judged, extent)
        if extra["evidence_doubt"]:
            logger.warning("the detections had to be shifted by %+.2f towards absent to agree "
                           "with the estimate: the image shows more than it builds; is the "
                           "pose off?", extra["presence_shift"])
    # Features the camera's frame cuts off are not judged: ½ each, as occluded ones are, so
    # the estimate and its confidence already treat them as unseen; the user is told.
    in_image = at.det.scores.projection.in_image
    outside = int(np.count_nonzero(~in_image))
    extra["features_outside_image"] = outside
    if outside:
        logger.warning("%d of the extent's %d features lie outside the image at the pose "
                       "used; they count as unseen (is the whole assembly in view?)",
                       outside, len(in_image))
    conf = None
    if confidence:
        t3 = time.perf_counter()
        occ = occluded_features([obs], fp.visibility, fp.structure.extent)
        conf = assess_confidence(solver, fp.terms, fp.result, occ, delta_star=delta_star,
                                 tolerance=tolerance, time_limit=time_limit)
        timings["confidence_s"] = time.perf_counter() - t3
    timings["total_s"] = time.perf_counter() - t0
    return Estimate(result=fp.result, priors=priors,
                    visible=fp.visibility[0], confidence=conf, pose=at.det.pose,
                    iterations=fp.iterations, converged=fp.converged,
                    cycle_length=fp.cycle_length, timings=timings,
                    extra={**extra, "history": fp.history})


def write_view_pictures(estimate: Estimate, view, out_dir: str | Path, *,
                        truth: Structure | None = None, truth_pose: GridPose | None = None
                        ) -> list[Path]:
    """``overlay.png`` (the photograph with the estimate over it) and ``estimate.png``
    (the estimated structure, green/red against ``truth``, else green seen / orange
    inferred)."""
    from unseeable.render.pictures import estimate_pictures
    from unseeable.render.view import write_image

    s = estimate.structure
    if s is None:
        return []
    correct = None
    if truth is not None:
        correct = compare_with_truth(estimate, truth, truth_pose=truth_pose if truth_pose
                                     is not None else view.pose).estimate_correct
    pics = estimate_pictures(view.image, s, estimate.pose, view.camera, correct=correct,
                             seen=log_support(s, estimate.priors))
    out = Path(out_dir)
    paths = [out / "overlay.png", out / "estimate.png"]
    write_image(paths[0], pics["overlay"])
    write_image(paths[1], pics["rendering"])
    return paths


def compare_with_truth(estimate: Estimate, truth: Structure, *,
                       truth_pose: GridPose | None = None):
    """``estimate`` compared with ``truth`` log by log (a
    :class:`~unseeable.evaluate.Comparison`; None without an estimated structure).

    The logs are compared where they stand: ``truth`` at ``truth_pose`` (a view's
    truth file has it), else where the estimate's own pose puts its grid (a
    structure file for the view's pose). So an estimate whose grid is numbered from
    another side is counted right, and one placed off the truth's grid counts every
    log of both. An estimate without a pose (from an evidence file) is compared grid
    by grid.
    """
    from unseeable.evaluate.metric import compare_structures

    if estimate.structure is None:
        return None
    if estimate.pose is None:
        return compare_structures(truth, estimate.structure)
    return compare_structures(truth, estimate.structure,
                              truth_pose=truth_pose if truth_pose is not None else estimate.pose,
                              estimate_pose=estimate.pose, on_misaligned="count")


def errors_against_truth(estimate: Estimate, truth: Structure, *,
                         truth_pose: GridPose | None = None) -> int | None:
    """The paper's error count of ``estimate`` against ``truth`` (None without a
    structure), the logs compared where they stand (:func:`compare_with_truth`)."""
    comparison = compare_with_truth(estimate, truth, truth_pose=truth_pose)
    return None if comparison is None else comparison.errors


@dataclass(frozen=True, eq=False)
class DemoResult:
    """What :func:`run_demo` made: the estimate, the truth and the files written."""

    estimate: Estimate
    truth: Structure
    errors: int | None
    pose_note: str
    files: dict


def run_demo(out_dir: str | Path, *, design: str = "cabin-door", angle: float = 150.0,
             size: tuple[int, int] = (640, 480), spp: int = 16, seed: int = 0,
             backend: str = "cpsat", threads: int = 1) -> DemoResult:
    """The whole pipeline on a built-in house: render one view, estimate, judge, draw.

    The assembly is a corpus design placed on the simulated table; the arm
    photographs it from ``angle``; the pose is estimated from the image (the
    recorded pose is used, and said so, only when the pose fit is poor); the
    structure, its visibility and its confidence are estimated; pictures and the
    estimate file are written to ``out_dir``. ``threads`` as :func:`estimate_view`.
    """
    from unseeable.corpus import load_design
    from unseeable.domain.io import save_structure
    from unseeable.render.settings import RenderSettings
    from unseeable.render.view import save_truth, save_view
    from unseeable.render.workspace import PendulumArm, Workspace

    # Checked before the render: a bad value must not leave a half-written demo folder.
    check_whole_number(threads, field="threads", minimum=1)
    entry = load_design(design)
    out = Path(out_dir)
    arm = PendulumArm(width=int(size[0]), height=int(size[1]))
    ws = Workspace(entry.structure, pose=entry.pose, arm=arm,
                   settings=RenderSettings(spp=spp), seed=seed)
    t0 = time.perf_counter()
    view = ws.observe(angle)
    render_s = time.perf_counter() - t0
    truth = ws.truth(view)
    view = save_view(view, out / "view.json", image_path=out / "view.png")
    save_truth(truth, out / "view.truth.json")
    save_structure(entry.structure, out / "truth.structure.json")
    try:
        est = estimate_view(view, backend=backend, use_view_pose=False, threads=threads)
        note = "pose estimated from the image"
    except VisionError as err:
        logger.warning("pose estimation failed (%s); using the recorded pose", err)
        est = estimate_view(view, backend=backend)
        note = f"pose estimation failed ({err}); used the recorded pose"
    est = Estimate(**{**est.__dict__, "timings": {**est.timings, "render_s": render_s}})
    errors = errors_against_truth(est, entry.structure, truth_pose=entry.pose)
    files = {"view": out / "view.png", "estimate": write_estimate(est, out)}
    pics = write_view_pictures(est, view, out, truth=entry.structure, truth_pose=entry.pose)
    files.update({"overlay": pics[0], "rendering": pics[1]})
    return DemoResult(est, entry.structure, errors, note, files)
