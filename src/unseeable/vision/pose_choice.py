"""Choosing between a pose and its aliases by the structure each implies.

:func:`~unseeable.vision.estimate_pose` returns, beside its edge-best pose,
the grid's near-symmetric translations that fit the image's edges almost as
well (:func:`~unseeable.vision.pose.pose_aliases`): moved a centimetre or two
along a grid axis, the lines of one layer land where another layer's lines
would be. Edges alone pick the wrong one of these in about one validation view
in ten. What does tell them apart is whether the detections at that pose
make sense *as an assembly*: under the true pose the features the detectors
judge are explained by a valid structure (every log supported, notches
matching); under an alias, floating or unsupported logs would be needed and
the best valid structure disagrees with more of the detections.

The choice maximises ``log(alignment score) + weight · gain + rim_weight ·
rims + silhouette_weight · overlap``, where ``gain`` is the MAP structure's
log-probability gain over "no information" (``p = ½``) per judged feature and
``rims`` the share of the rims of that structure's visible log ends that lie
on image edges once the candidate is polished on its structure
(:func:`~unseeable.vision.rim_support`). The detectors read profiles, whose
sharp priors make the gain large at every candidate; ``weight`` is 1.5
(validation poses right, with ``benchmarks/vision.py``: 230 of 240 at 1 and
1.5, 229 at 2, 227 at 3, 224 at 6). The rims tell depth aliases apart: a depth
alias moves every horizontal line onto another one, but an end disc's closed
rim lands off the image's disc. ``rim_weight = 1`` gained a view in each of
two sets of 120 validation renders (0–119 and 120–239) and lost none; weights
of 2–4, or the rims and gain without the edge score, were better on the first
set and worse on the second (docs/results.md). ``overlap`` is the intersection
over union of the implied structure's silhouette at the polished candidate
(:func:`~unseeable.vision.implied_structure.structure_silhouette`) with the
image's wood-coloured pixels near the candidates: a global cue where the
others are local. Shadows read as wood too, so it differs by a few hundredths
between the truth and its aliases — a tie-breaker; ``silhouette_weight = 1``
(set beside the rims' weight, not tuned) turned two quarter-turn confusions of
the 240 validation renders right and changed no view of the other-camera and
other-renderer families.

The chosen pose is then polished on the edges of its own implied structure
(:func:`~unseeable.vision.pose.refine_pose_on_structure`): the edge fit aligns
every line the grid could hold, each weighted by how present it looks; the
structure says which logs are there and which of their edges the camera sees.
Before that, :func:`~unseeable.vision.pitch.pitch_shift` checks the choice
against the grid moved one pitch along each axis, on a common grown grid. With
both, and the other quarter turn's candidates on square footprints, the
validation figures are in docs/results.md. Last, a polish reaching 9 px
instead of 3 may move the pose off a depth alias (or onto another log's
edges): the move is kept when the detections there imply a better structure
(:func:`judge_polish`; ``estimate_view`` judges its own polish the same way,
on its fixpoint's estimate).
"""

from __future__ import annotations

import dataclasses
import logging
import queue
from typing import TYPE_CHECKING

import numpy as np

from unseeable.camera import Camera
from unseeable.domain import Extent, GridPose, LogGeometry, Structure
from unseeable.errors import check_whole_number
from unseeable.parallel import map_in_stages, single_blas_thread
from unseeable.vision.calibration import Calibration
from unseeable.vision.edges import EdgeMaps, as_rgb_image
from unseeable.vision.evidence import FeatureDetection, detect_features
from unseeable.vision.implied_structure import (
    CHOICE_WORK_LIMIT,
    detection_gain,
    detections_at,
    implied_structure,
    silhouette_overlap,
    structure_gain,
    structure_silhouette,
    wood_near,
)
from unseeable.vision.pitch import PITCH_MIN_GAIN, fills_extent, pitch_shift
from unseeable.vision.pose import (
    PoseFit,
    PoseSettings,
    align_pose,
    estimate_pose,
    pose_equivalent,
    refine_pose_on_structure,
    rim_support,
)
from unseeable.vision.pose.fit import AMBIGUOUS_CHOICE_MARGIN
from unseeable.vision.scale import view_edge_maps

if TYPE_CHECKING:  # the solver is imported only when a choice is to be made
    from unseeable.solve import StructureSolver

__all__ = ["structure_gain", "detection_gain", "judge_polish", "PolishProposal",
           "select_pose", "pitch_shift", "fills_extent",
           "estimate_pose_by_structure", "structure_silhouette", "POSE_CHOICE_WEIGHT",
           "RIM_WEIGHT", "SILHOUETTE_WEIGHT", "PITCH_MIN_GAIN", "PITCH_EDGE_KEEP",
           "CHOICE_WORK_LIMIT",
           "AMBIGUOUS_CHOICE_MARGIN", "RIVAL_DISTANCE", "WIDE_POLISH_REACH_PX", "POLISH_MOVE",
           "POLISH_MIN_GAIN", "poses_apart", "lead_over_rival"]

logger = logging.getLogger(__name__)

#: Weight of the structure gain against the log of the alignment score (1.5: the
#: detectors read profiles, whose sharp priors make the gain large everywhere).
POSE_CHOICE_WEIGHT = 1.5

#: Weight of the share of visible log-end rims on image edges (:func:`rim_support`).
RIM_WEIGHT = 1.0

#: Weight of the overlap (IoU) of a candidate's implied structure's silhouette with the
#: image's wood (:func:`~unseeable.vision.implied_structure.structure_silhouette`).
SILHOUETTE_WEIGHT = 1.0

#: (mm, degrees): candidates nearer than this to the chosen pose are the same pose, not
#: rivals, for :attr:`PoseFit.choice_margin` (the accuracy to which poses count as right).
RIVAL_DISTANCE = (2.0, 1.0)

#: The pitch check's move is kept only when the moved pose, aligned, scores at least this
#: share of the chosen pose's edge alignment. A whole pitch puts lines where lines were,
#: so the edges hardly tell the two apart: the moves not known wrong scored 0.94-1.45 of
#: the pose they left (corpus, raster-drawn corpus and families). The moves the edges
#: clearly refused (0.60-0.85, raster-drawn corpus) were all wrong, made by detections of
#: logs in a hard cast shadow beside a wall.
PITCH_EDGE_KEEP = 0.9

#: A chosen pose is polished on its implied structure's edges looking this far (px) at
#: first (:func:`judge_polish`): far enough to leave a depth alias 10 mm off
#: (:func:`~unseeable.vision.refine_pose_on_structure`; its default looks 3 px out).
WIDE_POLISH_REACH_PX = 9.0
#: (mm, degrees): a wide polish that moves the pose to another pose (by more than this in
#: translation or turn; as the choice tells its rivals apart) is judged
#: (:func:`judge_polish`) ...
POLISH_MOVE = RIVAL_DISTANCE
#: ... and kept when the detections there imply a structure whose gain
#: (:func:`detection_gain`) exceeds the pose's by more than this. Read off 580 corpus and
#: family views: every move to a right pose but one gained 0.018 or more, every move away
#: from one at most 0.002 (docs/results.md).
POLISH_MIN_GAIN = 0.01


def poses_apart(a: GridPose, b: GridPose, extent: Extent, *,
                limits: tuple[float, float] = RIVAL_DISTANCE,
                geometry: LogGeometry = LogGeometry()) -> bool:
    """Whether ``a`` and ``b`` are two poses, not one: farther apart than ``limits``
    (mm, degrees) in translation or turn (:func:`~unseeable.vision.pose_equivalent`).

    Examples
    --------
    >>> e = Extent(2, 1, 2)
    >>> poses_apart(GridPose(0.0, 0.0, 0.0), GridPose(1.5, 0.0, 0.5), e)
    False
    >>> poses_apart(GridPose(0.0, 0.0, 0.0), GridPose(0.0, 3.0, 0.0), e)
    True
    """
    return any(d > limit for d, limit in zip(pose_equivalent(a, b, extent, geometry=geometry),
                                              limits))


@dataclasses.dataclass(frozen=True)
class PolishProposal:
    """Where a wide polish on a structure's edges would move a pose (:func:`judge_polish`).

    Attributes
    ----------
    detection : FeatureDetection
        At the moved pose (polished on the grid when asked: its ``pose``).
    structure : Structure or None
        The MAP structure of what ``detection`` judged (the choice's cut-short solve).
    gain_before, gain_after : float
        :func:`detection_gain` at the pose and at the moved pose.
    """

    detection: FeatureDetection
    structure: Structure | None
    gain_before: float
    gain_after: float

    @property
    def better(self) -> bool:
        """The moved pose's structure explains its detections better by
        :data:`POLISH_MIN_GAIN`: the move is to be kept."""
        return self.gain_after > self.gain_before + POLISH_MIN_GAIN


def judge_polish(image: np.ndarray, camera: Camera, structure: Structure,
                 detection: FeatureDetection, *, calibration: Calibration | None = None,
                 geometry: LogGeometry = LogGeometry(), maps: EdgeMaps | None = None,
                 pose_maps: EdgeMaps | None = None, settings: PoseSettings = PoseSettings(),
                 time_limit: float = 5.0, solver: StructureSolver | None = None,
                 refine: bool = True, gain_before: float | None = None,
                 start: GridPose | None = None) -> PolishProposal | None:
    """Polish a pose on its structure's edges, reaching far; judge the move as the choice would.

    The pose search's candidates sit on the grid's edges, every line weighed by
    how present it looks; a structure's own edges can hold the pose elsewhere,
    up to a depth alias 10 mm away (:data:`WIDE_POLISH_REACH_PX`), and can also
    draw it onto other logs' edges. When the polish moves the pose by more than
    :data:`POLISH_MOVE`, the features are detected there and both poses' gains
    compared (:attr:`PolishProposal.better`).

    Parameters
    ----------
    image : (H, W, 3) uint8
    camera : Camera
    structure : Structure
        At ``detection.pose`` (its extent numbers the grid): the logs the image shows.
    detection : FeatureDetection
        The detections at the pose to polish.
    calibration, geometry, maps
        As :func:`~unseeable.vision.detect_features`.
    pose_maps : EdgeMaps, optional
        The polish's edge maps (:func:`~unseeable.vision.scale.view_edge_maps` with
        ``pose=True``); made from ``image`` when not given.
    settings : PoseSettings
        For the polish.
    time_limit : float
    solver : StructureSolver, optional
        For ``structure.extent``, without constraints (the choice's).
    refine : bool
        Polish the moved pose on the grid before detecting, as the detectors'
        calibration poses were.
    gain_before : float, optional
        :func:`detection_gain` of ``detection``, when known.
    start : GridPose, optional
        Where the polish starts, and what the move is measured from (default
        ``detection.pose``; e.g. that pose already polished on ``structure``).

    Returns
    -------
    PolishProposal or None
        None when the polish moves the pose by :data:`POLISH_MOVE` or less.
    """
    extent = structure.extent
    pose = detection.pose if start is None else start
    if pose_maps is None:
        pose_maps = view_edge_maps(as_rgb_image(image), camera, pose=True, sigma=settings.sigma)
    polished = refine_pose_on_structure(pose_maps, camera, structure, pose, geometry=geometry,
                                        settings=settings, reach_px=WIDE_POLISH_REACH_PX)
    if not poses_apart(polished, pose, extent, limits=POLISH_MOVE, geometry=geometry):
        return None
    if solver is None:
        from unseeable.solve import StructureSolver

        solver = StructureSolver(extent)
    moved = detect_features(image, camera, polished, extent, calibration=calibration,
                            refine=refine, geometry=geometry, maps=maps)
    if gain_before is None:
        gain_before = detection_gain(detection, time_limit=time_limit, solver=solver)
    gain_after, moved_structure = implied_structure(moved, extent, time_limit=time_limit,
                                                    solver=solver, work_limit=CHOICE_WORK_LIMIT)
    return PolishProposal(moved, moved_structure, float(gain_before), float(gain_after))


@single_blas_thread()
def select_pose(image: np.ndarray, camera: Camera, extent: Extent, fit: PoseFit, *,
                calibration: Calibration | None = None, weight: float = POSE_CHOICE_WEIGHT,
                geometry: LogGeometry = LogGeometry(), time_limit: float = 5.0,
                polish: bool = True, settings: PoseSettings = PoseSettings(),
                pitch_check: bool = True, pitch_edge_keep: float = PITCH_EDGE_KEEP,
                maps: EdgeMaps | None = None, rim_weight: float = RIM_WEIGHT,
                silhouette_weight: float = SILHOUETTE_WEIGHT,
                detections: dict | None = None, threads: int = 1) -> PoseFit:
    """The candidate of ``fit`` whose edges and implied structure agree best with the image.

    Parameters
    ----------
    image : (H, W, 3) uint8
    camera : Camera
    extent : Extent
    fit : PoseFit
        From :func:`~unseeable.vision.estimate_pose`; its ``candidates`` are compared.
    calibration : Calibration, optional
    weight : float
        Weight of :func:`structure_gain` against the log alignment score.
    geometry : LogGeometry
    time_limit : float
    polish : bool
        Polish each candidate on the edges its implied structure shows
        (:func:`~unseeable.vision.pose.refine_pose_on_structure`) before its
        rims are counted; the chosen one is returned polished, and moved
        where a polish reaching farther finds a better structure
        (:func:`judge_polish`).
    settings : PoseSettings
        For the polish.
    pitch_check : bool
        Move the choice one grid pitch when the detections on a common, larger
        grid say so (:func:`pitch_shift`). Checked only when the choice's
        implied structure leaves a side of the extent (nearly) empty
        (:func:`fills_extent`), as it does one pitch off a tight extent.
    pitch_edge_keep : float
        The pitch check's move is kept only when the moved pose, aligned on the
        edges (:func:`~unseeable.vision.pose.align_pose`), scores at least this
        share of the chosen pose's alignment (0: always kept).
    maps : EdgeMaps, optional
        Precomputed edge maps of ``image`` (``sigma = settings.sigma``).
    rim_weight : float
        Weight of :func:`~unseeable.vision.rim_support` of each candidate's
        implied structure.
    silhouette_weight : float
        Weight of the overlap (intersection over union) of each candidate's
        implied structure's silhouette (:func:`structure_silhouette`, at the
        polished pose) with the image's wood-coloured pixels near the
        candidates.
    detections : dict, optional
        Filled with the feature detections (:func:`~unseeable.vision.detect_features`,
        unpolished) made at each candidate, keyed by its pose: a caller that goes on
        to detect at the chosen pose need not again.
    threads : int
        Threads for the candidates (each its detections, MAP solve and edge checks);
        the choice is the same for any number.

    Returns
    -------
    PoseFit
        ``fit`` with ``pose`` and ``score`` of the chosen candidate, polished,
        and ``choice_margin``, its value's lead over its best rival's (see
        :attr:`PoseFit.ambiguous`); the other fit statistics and the quality
        are those of the edge fit.
    """
    candidates = fit.candidates or ((fit.pose, fit.score),)
    threads = check_whole_number(threads, field="threads", minimum=1)
    if len(candidates) <= 1 and not polish and not pitch_check:
        return fit
    from unseeable.solve import StructureSolver

    # One model per thread for every candidate (only the priors change); a solver is not
    # shared by two threads at once.
    solvers: queue.SimpleQueue = queue.SimpleQueue()
    solvers.put(StructureSolver(extent))
    # One image, several poses: its edges once, as the pose polish and as the detectors see
    # it (the same maps unless the photograph is finer than the calibrated scale).
    rgb = as_rgb_image(image)
    pose_maps = view_edge_maps(rgb, camera, pose=True, sigma=settings.sigma, maps=maps)
    maps = view_edge_maps(rgb, camera, sigma=settings.sigma,
                          maps=pose_maps if maps is None else maps)
    # The overlap only ranks candidates: with one there is nothing to rank.
    use_silhouette = bool(silhouette_weight) and len(candidates) > 1
    if use_silhouette:
        # One colour model for every candidate: the union of their boxes is the assembly's.
        wood, region = wood_near(rgb, camera, extent, [p for p, _ in candidates], geometry)

    made: dict = {} if detections is None else detections

    def detect(candidate: tuple[GridPose, float]) -> FeatureDetection:
        return detections_at(image, camera, extent, candidate[0], calibration=calibration,
                             geometry=geometry, maps=maps, detections=made)

    def judge(candidate: tuple[GridPose, float], det: FeatureDetection
              ) -> tuple[float, GridPose, Structure | None, float]:
        pose, score = candidate
        try:
            solver = solvers.get_nowait()
        except queue.Empty:
            solver = StructureSolver(extent)
        try:
            gain, structure = implied_structure(det, extent, time_limit=time_limit, solver=solver,
                                                work_limit=CHOICE_WORK_LIMIT)
        finally:
            solvers.put(solver)
        polished, rims, overlap = pose, 0.0, 0.0
        if structure is not None:
            if polish:
                polished = refine_pose_on_structure(pose_maps, camera, structure, pose,
                                                    geometry=geometry, settings=settings)
            rims = rim_support(pose_maps, camera, structure, polished, geometry=geometry,
                               settings=settings)
            if use_silhouette:
                overlap = silhouette_overlap(wood, region, structure, polished, camera,
                                             geometry)
        value = float(np.log(max(score, 1e-9)) + weight * gain + rim_weight * rims
                      + silhouette_weight * overlap)
        logger.debug("pose candidate %s: score %.1f, structure gain %.4f, rims %.3f, "
                     "silhouette %.3f -> %.4f", pose, score, gain, rims, overlap, value)
        return value, polished, structure, gain

    best = None
    judged = []
    # Each candidate's detections hold the GIL for much of their time, its solve not: the
    # solves go on as soon as their detections are made, beside the next detections.
    for (pose, score), (value, polished, structure, gain) in zip(
            candidates, map_in_stages(detect, judge, list(candidates), threads=threads)):
        judged.append((pose, value))
        if best is None or value > best[0]:
            best = (value, pose, polished, score, structure, gain)
    solver = solvers.get()
    _, pose, polished, score, structure, gain = best
    margin, rival = lead_over_rival(judged, pose, extent, geometry)
    pitch_moved = False
    if pitch_check and not fills_extent(structure):
        shifted, shifted_structure, _ = pitch_shift(
            image, camera, extent, pose, calibration=calibration, geometry=geometry,
            time_limit=time_limit, solver=solver, maps=maps)
        if shifted != pose and pitch_edge_keep > 0:
            _, kept_score = align_pose(pose_maps, camera, extent, pose, geometry=geometry,
                                       settings=settings)
            _, moved_score = align_pose(pose_maps, camera, extent, shifted, geometry=geometry,
                                        settings=settings)
            if moved_score < pitch_edge_keep * kept_score:
                logger.debug("pitch move refused by the edges: score %.1f -> %.1f",
                             kept_score, moved_score)
                shifted = pose
        if shifted != pose:
            pose, structure, polished = shifted, shifted_structure, shifted
            margin = rival = None  # moved by the pitch check's own, larger margin
            pitch_moved = True
            if polish and structure is not None:
                polished = refine_pose_on_structure(pose_maps, camera, structure, pose,
                                                    geometry=geometry, settings=settings)
    if polish and structure is not None and not pitch_moved:
        # The chosen candidate may sit a depth alias off on the grid's edges: polished far
        # on its structure's, the move kept if the structure there is better.
        proposal = judge_polish(image, camera, structure, made[pose], calibration=calibration,
                                geometry=geometry, maps=maps, pose_maps=pose_maps,
                                settings=settings, time_limit=time_limit, solver=solver,
                                gain_before=gain, start=polished)
        if proposal is not None and proposal.better and proposal.structure is not None:
            logger.debug("pose moved by the wide polish: gain %.4f -> %.4f",
                         proposal.gain_before, proposal.gain_after)
            pose, structure = proposal.detection.pose, proposal.structure
            polished = refine_pose_on_structure(pose_maps, camera, structure, pose,
                                                geometry=geometry, settings=settings)
    logger.debug("pose polished on the implied structure: %s -> %s", pose, polished)
    if margin is not None and margin < AMBIGUOUS_CHOICE_MARGIN:
        logger.info("the pose choice is ambiguous: its best rival is only %.3f "
                    "behind", margin)
    return dataclasses.replace(fit, pose=polished, score=float(score), choice_margin=margin,
                               choice_rival=rival)


def lead_over_rival(judged: list[tuple[GridPose, float]], chosen: GridPose, extent: Extent,
                    geometry: LogGeometry) -> tuple[float | None, GridPose | None]:
    """The chosen candidate's lead over its best rival, and that rival (None, None
    without a finite rival).

    A rival is a candidate more than :data:`RIVAL_DISTANCE` from the chosen
    pose: two alignments of the same pose a millimetre apart are no choice to
    be unsure of.
    """
    best = max(v for p, v in judged if p == chosen)
    rivals = [(v, p) for p, v in judged if np.isfinite(v) and p != chosen
              and poses_apart(p, chosen, extent, geometry=geometry)]
    if not rivals or not np.isfinite(best):
        return None, None
    value, rival = max(rivals, key=lambda r: r[0])
    return float(best - value), rival


def estimate_pose_by_structure(image: np.ndarray, camera: Camera, extent: Extent, *,
                               calibration: Calibration | None = None, strict: bool = True,
                               settings: PoseSettings = PoseSettings(),
                               geometry: LogGeometry = LogGeometry(),
                               weight: float = POSE_CHOICE_WEIGHT,
                               rim_weight: float = RIM_WEIGHT,
                               polish: bool = True, threads: int = 1) -> PoseFit:
    """:func:`~unseeable.vision.estimate_pose`, then :func:`select_pose` among its aliases.

    Parameters and errors as :func:`~unseeable.vision.estimate_pose` (``strict``
    refuses poor edge fits with :class:`~unseeable.errors.VisionError`);
    ``weight``, ``rim_weight``, ``polish`` and ``threads`` as :func:`select_pose`.

    Returns
    -------
    PoseFit
    """
    maps = view_edge_maps(as_rgb_image(image), camera, pose=True, sigma=settings.sigma)
    # The calibration's own pose-quality model judges the fit (the shipped one's if it has
    # none): it was fitted on the poses its detectors choose.
    fit = estimate_pose(image, camera, extent, geometry=geometry, settings=settings,
                        strict=strict, maps=maps, threads=threads,
                        quality_model=None if calibration is None else calibration.pose_quality)
    return select_pose(image, camera, extent, fit, calibration=calibration, weight=weight,
                       rim_weight=rim_weight, geometry=geometry, settings=settings,
                       polish=polish, maps=maps, threads=threads)
