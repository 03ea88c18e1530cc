"""Choosing between a pose and its aliases by the structure each implies.

:func:`~unseeable.vision.estimate_pose` returns, beside its edge-best pose,
the grid's near-symmetric translations that fit the image's edges almost as
well (:func:`~unseeable.vision.pose.pose_aliases`): moved a centimetre or two
along a grid axis, the lines of one layer land where another layer's lines
would be. Edges alone picked the wrong one of these in one validation view in
ten. What does tell them apart is whether the detections at that pose
make sense *as an assembly*: under the true pose the features the detectors
judge are explained by a valid structure (every log supported, notches
matching); under an alias, floating or unsupported logs would be needed and
the best valid structure disagrees with more of the detections.

The choice maximises ``log(alignment score) + weight · gain + rim_weight ·
rims + silhouette_weight · overlap``, where ``gain`` is the MAP structure's
log-probability gain over "no information" (``p = ½``) per judged feature
and ``rims`` the share of the rims of that structure's visible log ends that
lie on image edges once the candidate is polished on its structure
(:func:`~unseeable.vision.rim_support`).
``weight = 3`` was chosen on the validation renders, where it took the share
of poses within 2 mm and 1° from 79 % (edges alone) to 83 %
(``benchmarks/vision.py``; the best weights lie between 2 and 4). Since the
detectors read profiles (eighteenth session) their priors are sharper and
the gain larger at every candidate; the weight is 1.5 (validation poses
right: 230 of 240 at 1 and 1.5, 229 at 2, 227 at 3, 224 at 6). The rims
were added in the seventh session: a depth alias moves every horizontal line
onto another one, but an end disc's closed rim lands off the image's disc.
``rim_weight = 1`` gained a view in each of two sets of 120 validation
renders (0–119 and 120–239) and lost none; weights of 2–4, or the rims and
gain without the edge score, were better on the first set and worse on the
second (docs/results.md). ``overlap`` (fourteenth session) is the
intersection over union of the implied structure's silhouette at the polished
candidate (:func:`structure_silhouette`) with the image's wood-coloured
pixels near the candidates: a global cue where the others are local. Shadows
read as wood too, so it differs by a few hundredths between the truth and its
aliases — a tie-breaker; ``silhouette_weight = 1`` (set beside the rims'
weight, not tuned) turned two quarter-turn confusions of the 240 validation
renders right and changed no view of the other-camera and other-renderer
families.

The chosen pose is then polished on the edges of its own implied structure
(:func:`~unseeable.vision.pose.refine_pose_on_structure`): the edge fit aligns
every line the grid could hold, each weighted by how present it looks; the
structure says which logs are there and which of their edges the camera
sees. Before that, :func:`pitch_shift` checks the choice against the grid
moved one pitch along each axis, on a common grown grid. With both, and
the other quarter turn's candidates on square footprints, the validation
figures are in docs/results.md. Last, a polish reaching 9 px instead of 3
may move the pose off a depth alias (or onto another log's edges): the move
is kept when the detections there imply a better structure
(:func:`judge_polish`; ``estimate_view`` judges its own polish the same way,
on its fixpoint's estimate).
"""

from __future__ import annotations

import dataclasses
import logging
import queue
from typing import TYPE_CHECKING

import cv2
import numpy as np

from unseeable.camera import Camera
from unseeable.domain import EMPTY, Evidence, Extent, GridPose, LogGeometry, Structure
from unseeable.errors import InputError, check_whole_number
from unseeable.parallel import map_in_stages, single_blas_thread
from unseeable.vision.calibration import Calibration
from unseeable.vision.edges import (
    EdgeMaps,
    as_rgb_image,
    fill_convex_hull,
    image_window,
    mask_box,
    woodness_map,
)
from unseeable.vision.evidence import FeatureDetection, detect_features
from unseeable.vision.pose import (
    PoseFit,
    PoseSettings,
    _box_mask,
    align_pose,
    estimate_pose,
    pose_equivalent,
    refine_pose_on_structure,
    rim_support,
)
from unseeable.vision.scale import view_edge_maps

if TYPE_CHECKING:  # the solver is imported only when a choice is to be made
    from unseeable.solve import StructureSolver

__all__ = ["structure_gain", "detection_gain", "judge_polish", "PolishProposal",
           "select_pose", "pitch_shift", "fills_extent",
           "estimate_pose_by_structure", "structure_silhouette", "POSE_CHOICE_WEIGHT",
           "RIM_WEIGHT", "SILHOUETTE_WEIGHT", "PITCH_MIN_GAIN", "PITCH_EDGE_KEEP",
           "CHOICE_WORK_LIMIT",
           "AMBIGUOUS_CHOICE_MARGIN", "RIVAL_DISTANCE", "WIDE_POLISH_REACH_PX", "POLISH_MOVE",
           "POLISH_MIN_GAIN", "poses_apart"]

logger = logging.getLogger(__name__)

#: Weight of the structure gain against the log of the alignment score (1.5 since the
#: detectors read profiles: their sharper priors make the gain larger everywhere).
POSE_CHOICE_WEIGHT = 1.5

#: Weight of the share of visible log-end rims on image edges (:func:`rim_support`).
RIM_WEIGHT = 1.0

#: Weight of the overlap (IoU) of a candidate's implied structure's silhouette with the
#: image's wood (:func:`structure_silhouette`).
SILHOUETTE_WEIGHT = 1.0

#: Below this lead of the chosen candidate's value over its best rival's, the choice is
#: called ambiguous (:attr:`PoseFit.ambiguous`) and an estimate made at that pose is not
#: confident (:attr:`unseeable.pipeline.Estimate.confident`). Read off, not fitted: on the
#: 160 corpus views (pose estimated) 3 of the 5 wrong choices lie below 0.1 and 3 of the
#: 155 right ones; on the 240 validation renders 6 of 19 wrong and 14 of 221 right; on
#: other cameras and another renderer (measured after) 3 of 7 and 3 of 9 wrong, 5 of 53
#: and 6 of 51 right (docs/results.md).
AMBIGUOUS_CHOICE_MARGIN = 0.1

#: (mm, degrees): candidates nearer than this to the chosen pose are the same pose, not
#: rivals, for :attr:`PoseFit.choice_margin` (the accuracy to which poses count as right).
RIVAL_DISTANCE = (2.0, 1.0)

#: Log-likelihood margin (nats) a pose one grid pitch away needs to replace the choice.
PITCH_MIN_GAIN = 3.0

#: The pitch check's move is kept only when the moved pose, aligned, scores at least this
#: share of the chosen pose's edge alignment. A whole pitch puts lines where lines were,
#: so the edges hardly tell the two apart: the moves not known wrong scored 0.94-1.45 of
#: the pose they left (fifty-first session, corpus, raster-drawn corpus and families). The
#: moves the edges clearly refused (0.60-0.85, raster-drawn corpus) were all wrong, made by
#: detections of logs in a hard cast shadow beside a wall.
PITCH_EDGE_KEEP = 0.9

#: Deterministic work (CP-SAT's deterministic time, about seconds) for each candidate's MAP
#: solve in :func:`select_pose`. Under a wrong alias of a large extent the detections
#: contradict the grammar and the exact solve took 10-40 s (the lodge); a solve cut short
#: under-states that candidate's gain, which counts further against a wrong candidate.
#: 2.0 until the twenty-second session; 0.2 chose the same pose on all 160 corpus images
#: and 420 validation and family renders, and took the choice's mean from 0.96 s to
#: 0.62 s and its slowest from 22 s to 6 s on the corpus. There, 50 of 52 solves cut
#: short were wrong candidates'; the right candidate's solve was cut short only on the
#: two lodges seen from 210°, and chosen all the same (docs/results.md). 0.1 since the
#: twenty-fourth session: the same choice on the 160 corpus images and 360 validation and
#: family renders (rightness and ambiguity alike; the same pose on 80 corpus images timed
#: side by side), the choice's mean 0.38 -> 0.35 s on two threads.
CHOICE_WORK_LIMIT = 0.1

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


def _detections_at(image: np.ndarray, camera: Camera, extent: Extent, pose: GridPose, *,
                   calibration: Calibration | None, geometry: LogGeometry,
                   maps: EdgeMaps | None, detections: dict | None) -> FeatureDetection:
    """The detections at a candidate pose (unpolished: the search aligned it), kept in
    ``detections`` when given."""
    det = detect_features(image, camera, pose, extent, calibration=calibration,
                          refine=False, geometry=geometry, maps=maps)
    if detections is not None:
        detections[pose] = det
    return det


def _structure_of(det: FeatureDetection, extent: Extent, *, time_limit: float,
                  solver: StructureSolver | None, work_limit: float | None = None
                  ) -> tuple[float, Structure | None]:
    """The MAP structure of the features ``det`` judged (the others at ½), and its
    log-probability gain per judged feature over all-½ (:func:`structure_gain`)."""
    judged = int(det.judged.sum())
    evidence = Evidence(extent, np.where(det.judged, det.p, 0.5))
    if solver is None:
        from unseeable.solve import StructureSolver

        solver = StructureSolver(extent)
    result = solver.solve(evidence, time_limit=time_limit, work_limit=work_limit)
    if result.structure is None:
        return -np.inf, None
    if judged == 0:
        return 0.0, result.structure
    return float((result.log_probability - judged * np.log(0.5)) / judged), result.structure


def structure_silhouette(structure: Structure, pose: GridPose, camera: Camera,
                         shape: tuple[int, int] | None = None, *,
                         geometry: LogGeometry = LogGeometry()) -> np.ndarray:
    """Where ``structure``'s logs, placed at ``pose``, cover the image.

    Each log is drawn as the convex hull of its bounding cylinder's two end
    circles (:func:`~unseeable.visibility.log_cylinders`), 16 points each.

    Parameters
    ----------
    structure : Structure
    pose : GridPose
    camera : Camera
    shape : (int, int), optional
        ``(H, W)`` of the mask; default the camera's image size.
    geometry : LogGeometry

    Returns
    -------
    (H, W) bool

    Examples
    --------
    >>> from unseeable.domain import Extent, Log
    >>> cam = Camera.look_at(eye=[0, 500, -800], target=[0, 0, 0], width=64, height=48,
    ...                      fov_deg=50)
    >>> s = Structure(Extent(2, 1, 1), [Log(layer=0, at=(0, 0), notches=2)])
    >>> mask = structure_silhouette(s, GridPose(0.0, 0.0, 0.0), cam)
    >>> mask.shape, bool(mask.any()), bool(mask.all())
    ((48, 64), True, False)
    """
    from unseeable.visibility import log_cylinders

    if not isinstance(structure, Structure):
        raise InputError("must be a Structure", field="structure",
                         value=type(structure).__name__)
    if not isinstance(pose, GridPose):
        raise InputError("must be a GridPose", field="pose", value=pose)
    if not isinstance(camera, Camera):
        raise InputError("must be a Camera", field="camera", value=type(camera).__name__)
    if shape is None:
        shape = (camera.height, camera.width)
    if (not isinstance(shape, (tuple, list)) or len(shape) != 2
            or not all(isinstance(n, (int, np.integer)) and n > 0 for n in shape)):
        raise InputError("must be two positive whole numbers (H, W)", field="shape",
                         value=shape)
    mask = np.zeros(tuple(int(n) for n in shape), np.uint8)
    axes = log_cylinders(structure, geometry=geometry)
    if not len(axes):
        return mask.astype(bool)
    t = np.linspace(0.0, 2.0 * np.pi, 16, endpoint=False)
    direction = axes[:, 1] - axes[:, 0]
    direction /= np.linalg.norm(direction, axis=1, keepdims=True)
    up = np.array([0.0, 1.0, 0.0])  # logs are horizontal: up is across every one of them
    side = np.cross(direction, up)
    ring = geometry.radius * (np.cos(t)[None, :, None] * up
                              + np.sin(t)[None, :, None] * side[:, None, :])  # (L, 16, 3)
    pts = np.concatenate([axes[:, :1] + ring, axes[:, 1:] + ring], axis=1)  # (L, 32, 3)
    uv = camera.project(pose.grid_to_world(pts.reshape(-1, 3))).reshape(len(axes), -1, 2)
    for log_uv in uv:
        if np.all(np.isfinite(log_uv)):  # a log behind the camera is not drawn
            fill_convex_hull(mask, log_uv)
    return mask.astype(bool)


def _wood_near(rgb: np.ndarray, camera: Camera, extent: Extent, poses, geometry: LogGeometry,
               *, band_px: int = 40) -> tuple[np.ndarray, np.ndarray]:
    """The wood-coloured pixels and the region the silhouettes are compared in.

    The region is the union of the extent's boxes at ``poses``, grown by
    ``band_px``; the wood colour model learns the assembly inside the boxes
    and the background outside them (:func:`~unseeable.vision.edges.woodness_map`).
    """
    boxes = np.zeros(rgb.shape[:2], np.uint8)
    for pose in poses:
        box = _box_mask(extent, pose, camera, rgb.shape[:2], geometry)
        if box is not None:
            boxes |= box
    region = cv2.dilate(boxes, np.ones((2 * band_px + 1,) * 2, np.uint8)) > 0
    # The wood is compared only inside the region: its colours are scored there only.
    corners = mask_box(region)
    window = image_window(corners, region.shape) if len(corners) else None
    wood = woodness_map(rgb, boxes > 0, window=window) > 0.5
    return wood & region, region


def _silhouette_overlap(wood: np.ndarray, region: np.ndarray, structure: Structure,
                        pose: GridPose, camera: Camera, geometry: LogGeometry) -> float:
    """Intersection over union of the structure's silhouette and the wood, in ``region``."""
    sil = structure_silhouette(structure, pose, camera, wood.shape, geometry=geometry) & region
    union = int(np.count_nonzero(wood | sil))
    return float(np.count_nonzero(wood & sil) / union) if union else 0.0


def structure_gain(image: np.ndarray, camera: Camera, extent: Extent, pose: GridPose, *,
                   calibration: Calibration | None = None,
                   geometry: LogGeometry = LogGeometry(), time_limit: float = 5.0,
                   solver: StructureSolver | None = None) -> float:
    """Log-probability gain per judged feature of the best valid structure at ``pose``.

    Every feature the detectors judge at ``pose`` gets its prior ``p_f``, the
    others ½; the MAP structure's log-probability minus that of the
    all-½ evidence, divided by the number judged. Near 0 when the detections
    are uninformative, up to ``log 2`` when a valid structure explains every
    one of them with certainty.

    Parameters
    ----------
    image : (H, W, 3) uint8
    camera : Camera
    extent : Extent
    pose : GridPose
    calibration : Calibration, optional
    geometry : LogGeometry
    time_limit : float
        Seconds for the MAP solve (its best structure so far is used on a timeout).
    solver : StructureSolver, optional
        A solver for ``extent`` to reuse (its model is built once for many calls).

    Returns
    -------
    float
    """
    det = _detections_at(image, camera, extent, pose, calibration=calibration,
                         geometry=geometry, maps=None, detections=None)
    gain, _ = _structure_of(det, extent, time_limit=time_limit, solver=solver)
    return gain


def detection_gain(detection: FeatureDetection, *, time_limit: float = 5.0,
                   solver: StructureSolver | None = None) -> float:
    """:func:`structure_gain` of detections already made, as the pose choice values them.

    The MAP solve is cut short as the choice's (:data:`CHOICE_WORK_LIMIT`), so two
    poses' gains compare as two candidates' do in :func:`select_pose`.

    Parameters
    ----------
    detection : FeatureDetection
        From :func:`~unseeable.vision.detect_features` at the pose to value.
    time_limit : float
    solver : StructureSolver, optional
        A solver for the detection's extent to reuse (no constraints: the choice's).

    Returns
    -------
    float
        Log-probability gain per judged feature; ``-inf`` when no valid structure is found.
    """
    gain, _ = _structure_of(detection, detection.evidence.extent, time_limit=time_limit,
                            solver=solver, work_limit=CHOICE_WORK_LIMIT)
    return gain


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
    gain_after, moved_structure = _structure_of(moved, extent, time_limit=time_limit,
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
        wood, region = _wood_near(rgb, camera, extent, [p for p, _ in candidates], geometry)

    made: dict = {} if detections is None else detections

    def detect(candidate: tuple[GridPose, float]) -> FeatureDetection:
        return _detections_at(image, camera, extent, candidate[0], calibration=calibration,
                              geometry=geometry, maps=maps, detections=made)

    def judge(candidate: tuple[GridPose, float], det: FeatureDetection
              ) -> tuple[float, GridPose, Structure | None, float]:
        pose, score = candidate
        try:
            solver = solvers.get_nowait()
        except queue.Empty:
            solver = StructureSolver(extent)
        try:
            gain, structure = _structure_of(det, extent, time_limit=time_limit, solver=solver,
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
                overlap = _silhouette_overlap(wood, region, structure, polished, camera,
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
    margin, rival = _choice_margin(judged, pose, extent, geometry)
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


def _choice_margin(judged: list[tuple[GridPose, float]], chosen: GridPose, extent: Extent,
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


def fills_extent(structure: Structure | None, *, min_positions: int = 2) -> bool:
    """Whether ``structure`` holds logs on all four sides of its extent's footprint.

    Under a grid one pitch off the assembly, the extent's row on one side
    lies beyond it, and a structure estimated there has nothing on that side
    but what the detectors made up (one log position, in the one render of
    the validation sets where the check mattered). A structure with at least
    ``min_positions`` grid positions on every side says the grid is on the
    assembly (or the assembly is larger than the extent, which a shift would
    not mend either).

    Parameters
    ----------
    structure : Structure or None
    min_positions : int
        Grid positions (any layer) each side needs.

    Returns
    -------
    bool

    Examples
    --------
    >>> from unseeable.domain import Extent, Log
    >>> fills_extent(Structure(Extent(2, 1, 1), [Log(layer=0, at=(0, 0), notches=2)]))
    False
    >>> fills_extent(Structure(Extent(2, 1, 1), [Log(layer=0, at=(0, 0), notches=2)]),
    ...              min_positions=1)
    True
    """
    check_whole_number(min_positions, field="min_positions", minimum=0)
    if structure is None:
        return False
    occupied = structure.occupancy != EMPTY
    sides = (occupied[0], occupied[-1], occupied[:, :, 0], occupied[:, :, -1])
    return all(int(np.count_nonzero(side)) >= min_positions for side in sides)


def pitch_shift(image: np.ndarray, camera: Camera, extent: Extent, pose: GridPose, *,
                calibration: Calibration | None = None, geometry: LogGeometry = LogGeometry(),
                time_limit: float = 5.0, solver: StructureSolver | None = None,
                min_gain: float = PITCH_MIN_GAIN, maps: EdgeMaps | None = None
                ) -> tuple[GridPose, Structure | None, float]:
    """The pose, or the pose one grid pitch along an axis when the detections say so.

    A grid moved by a whole pitch (``l1``) puts every line where a line was:
    edges cannot tell the two apart, and the per-feature structure gain of
    :func:`select_pose` prefers a grid partly off the assembly (its features
    are mostly empty, which is easy to judge). Here the poses are compared on
    *the same features*: the detectors judge the extent grown by one
    position on every side, and each placement of the extent in it scores
    the MAP log-probability of its window plus ``log(1 - p_f)`` of every
    judged feature outside it (nothing may lie outside the extent). The
    centre is kept unless a neighbour (one pitch along ``i`` or ``k``) beats
    it by ``min_gain`` nats.

    Parameters
    ----------
    image : (H, W, 3) uint8
    camera : Camera
    extent : Extent
    pose : GridPose
    calibration : Calibration, optional
    geometry : LogGeometry
    time_limit : float
    solver : StructureSolver, optional
        For ``extent``.
    min_gain : float
        Log-likelihood margin a neighbour needs.
    maps : EdgeMaps, optional
        Precomputed edge maps of ``image``.

    Returns
    -------
    pose : GridPose
        ``pose`` or its shift.
    structure : Structure or None
        The MAP structure of the returned pose's window.
    gain : float
        Its log-likelihood margin over the centre (0 when the centre is kept).
    """
    from unseeable.domain import feature_index

    if solver is None:
        from unseeable.solve import StructureSolver

        solver = StructureSolver(extent)
    I, J, K = extent.shape
    grown = Extent(I + 2, J, K + 2)
    corner = pose.grid_to_world(np.array([[-geometry.l1, 0.0, -geometry.l1]]))[0]
    det = detect_features(image, camera, GridPose(float(corner[0]), float(corner[2]),
                                                  pose.yaw_deg),
                          grown, calibration=calibration, refine=False, geometry=geometry,
                          maps=maps)
    outer, inner = feature_index(grown), feature_index(extent)
    absent = np.where(det.judged, np.log(np.clip(1.0 - det.p, 1e-12, 1.0)), np.log(0.5))
    results = {}
    for a, b in ((1, 1), (0, 1), (2, 1), (1, 0), (1, 2)):
        inside = ((outer.at[:, 0] >= a) & (outer.at[:, 0] < a + I)
                  & (outer.at[:, 2] >= b) & (outer.at[:, 2] < b + K))
        at = outer.at[inside] - np.array([a, 0, b])
        target = inner.lookup_many(outer.kind[inside], at)
        priors = np.full(len(inner), 0.5)
        priors[target] = np.where(det.judged[inside], det.p[inside], 0.5)
        outside = float(absent[~inside].sum())
        if (a, b) != (1, 1) and (1, 1) in results:
            # No structure beats every feature's likelier value: a neighbour that cannot
            # reach the margin even so needs no solve (the choice is the same).
            bound = float(np.sum(np.log(np.maximum(priors, 1.0 - priors)))) + outside
            if bound < results[(1, 1)][0] + min_gain:
                continue
        result = solver.solve(Evidence(extent, priors), time_limit=time_limit)
        if result.structure is None:
            continue
        results[(a, b)] = (result.log_probability + outside, result.structure)
    if (1, 1) not in results:
        return pose, None, 0.0
    centre = results[(1, 1)][0]
    (a, b), (value, structure) = max(results.items(), key=lambda kv: kv[1][0])
    if (a, b) == (1, 1) or value < centre + min_gain:
        return pose, results[(1, 1)][1], 0.0
    origin = pose.grid_to_world(np.array([[(a - 1) * geometry.l1, 0.0, (b - 1) * geometry.l1]]))[0]
    logger.debug("pose moved one pitch (%+d, %+d): log-likelihood %+.2f", a - 1, b - 1,
                 value - centre)
    return GridPose(float(origin[0]), float(origin[2]), pose.yaw_deg), structure, value - centre


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
