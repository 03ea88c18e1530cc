"""The one rule by which a view's pose is chosen: :func:`find_pose`.

Edges alone fix the assembly's yaw modulo 90° and place the grid up to its
near-symmetric translations; the structure each candidate implies decides among
them (:func:`~unseeable.vision.select_pose`). The chosen pose is then checked
against its own estimate: log ends seen missing on the extent's boundary send the
search round again with a lower bar for aliases, and a polish on the estimate's
own edges may move it (:func:`~unseeable.vision.judge_polish`). Each step keeps a
new pose only when its estimate is not in doubt. ``unseeable pose``, ``unseeable
detect`` and ``unseeable estimate`` all choose their pose here, so they report the
same pose for the same view.
"""

from __future__ import annotations

import logging
import time
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

import unseeable.pipeline.evidence_checks as evidence_checks
from unseeable.domain.frames import GridPose
from unseeable.pipeline.evidence_checks import boundary_ends, line_aliases
from unseeable.pipeline.observation import Observation
from unseeable.pipeline.search_cache import cached_search, search_key
from unseeable.pipeline.settings import EstimateSettings

if TYPE_CHECKING:
    from unseeable.solve import StructureSolver
    from unseeable.visibility.loop import ViewEvidence, VisibilityFixpoint
    from unseeable.vision.evidence import FeatureDetection

__all__ = ["find_pose", "PoseFinding", "PoseReport", "StructureAtPose", "ViewContext",
           "structure_at_pose", "WIDE_ALIAS_KEEP"]

logger = logging.getLogger(__name__)

#: The aliases' bar (``PoseSettings.alias_keep`` and ``finals_keep``) when an estimated
#: pose's estimate is in doubt and the pose is searched again (defaults 0.8 and 0.6).
WIDE_ALIAS_KEEP = 0.6


@dataclass(frozen=True)
class PoseReport:
    """How a view's pose was found, as the estimate file reports it.

    Attributes
    ----------
    source : {"given", "estimated", "shared"}
        Recorded with the view, found from its image, or the reference view's (several
        views in one table frame).
    quality : float or None
        The pose fit's quality in [0, 1] (estimated poses).
    choice_margin : float or None
        How clearly the structure choice picked it among the grid's aliases.
    ambiguous : bool
        That choice was a near coin toss (the estimate is then not confident).
    rival : GridPose or None
        The best other candidate.
    searched_again : bool
        The estimate's extent was in doubt and the pose was searched again.
    changed_by_second_search : bool
        That search's pose was kept.
    polish_gain : (float, float) or None
        The structure choice's gain before and after a polish on the estimate's edges.
    moved_by_polish : bool
        The polished pose was kept.
    """

    source: str
    quality: float | None = None
    choice_margin: float | None = None
    ambiguous: bool = False
    rival: GridPose | None = None
    searched_again: bool = False
    changed_by_second_search: bool = False
    polish_gain: tuple[float, float] | None = None
    moved_by_polish: bool = False

    def to_json(self) -> dict[str, Any]:
        return {"source": self.source, "quality": self.quality,
                "choice_margin": self.choice_margin, "ambiguous": bool(self.ambiguous),
                "rival": None if self.rival is None else self.rival.to_json(),
                "searched_again": self.searched_again,
                "changed_by_second_search": self.changed_by_second_search,
                "polish_gain": None if self.polish_gain is None else list(self.polish_gain),
                "moved_by_polish": self.moved_by_polish}


@dataclass(frozen=True, eq=False)
class StructureAtPose:
    """What was estimated at one pose of a view, and whether its extent is in doubt."""

    detection: FeatureDetection
    evidence: ViewEvidence
    fixpoint: VisibilityFixpoint
    priors: np.ndarray
    edge_ends_judged: int
    edge_ends_absent: int
    extent_doubt: bool


@dataclass(frozen=True, eq=False)
class PoseFinding:
    """A view's pose, how it was found, and the estimate made at it.

    Attributes
    ----------
    pose : GridPose
        The pose the detections were made at (a given pose after its polish on the
        image's edges, when asked for).
    report : PoseReport
    at : StructureAtPose
        The detections and the visibility ⇄ structure fixpoint at :attr:`pose`.
    solver : StructureSolver
        The kept solver (its model serves further solves on the same grid).
    timings : dict
        Seconds per stage.
    """

    pose: GridPose
    report: PoseReport
    at: StructureAtPose
    solver: Any
    timings: dict = field(default_factory=dict)


class ViewContext:
    """One view's image read once: its edge maps, and the detections made at the poses
    the pose choice considered (those poses are aligned on the image already)."""

    def __init__(self, observation: Observation, settings: EstimateSettings) -> None:
        self.observation = observation
        self.settings = settings
        self.view = observation.view
        self.calibration = settings.detection.loaded_calibration()
        self._maps: tuple | None = None
        self.detections: dict = {}
        self.timings: dict[str, float] = {}

    def _edge_maps(self) -> tuple:
        """The pose search's and the detectors' edge maps, made on first use (a view whose
        detections are known needs none)."""
        if self._maps is None:
            from unseeable.vision.edges import as_rgb_image
            from unseeable.vision.focus import DEFOCUS_WARN_PX, added_blur, estimate_defocus
            from unseeable.vision.scale import view_edge_maps

            rgb = as_rgb_image(self.view.image)
            blur = estimate_defocus(rgb)
            if blur > DEFOCUS_WARN_PX:
                logger.warning("%s looks out of focus (edges blurred by about %.1f px more "
                               "than the sharp photographs the detectors were calibrated "
                               "on): expect misread features and a less precise pose",
                               self.observation.source or "the photograph", added_blur(blur))
            pose_maps = view_edge_maps(rgb, self.view.camera, pose=True)
            # The detectors' maps are the pose search's where their ranges agree.
            self._maps = (pose_maps, view_edge_maps(rgb, self.view.camera, maps=pose_maps))
        return self._maps

    @property
    def pose_maps(self):
        return self._edge_maps()[0]

    @property
    def maps(self):
        return self._edge_maps()[1]

    def add_time(self, key: str, seconds: float) -> None:
        self.timings[key] = self.timings.get(key, 0.0) + seconds

    def search(self, pose_settings, strict: bool, *, warn: bool = True):
        """Search the pose on the image's edges and choose among the grid's aliases by
        the structure each implies (read from the active cache of pose searches when
        there, :mod:`~unseeable.pipeline.search_cache`)."""
        v, s = self.view, self.settings
        fit = cached_search(lambda: search_key(v.image, v.camera, v.extent, pose_settings,
                                               strict, s.pose.threads, s.solver.time_limit,
                                               _calibration_identity(s.detection.calibration)),
                            lambda: self._search(pose_settings, strict))
        if warn and fit.quality < pose_settings.min_quality:
            logger.warning("the pose fit is poor (quality %.2f): the estimate will not be "
                           "confident; is the whole assembly in view and the extent %s "
                           "right?", fit.quality, v.extent)
        return fit

    def _search(self, pose_settings, strict: bool):
        from unseeable.vision import estimate_pose, select_pose

        v, s = self.view, self.settings
        threads = s.pose.threads
        cal = self.calibration
        fit = estimate_pose(v.image, v.camera, v.extent, maps=self.pose_maps, strict=strict,
                            settings=pose_settings, threads=threads,
                            quality_model=None if cal is None else cal.pose_quality)
        # Not polished on the implied structure here: the detectors' calibration was
        # fitted with grid-polished poses, and the structure polish cost errors on the
        # corpus (docs/decisions.md); the detections polish the choice on the grid instead.
        return select_pose(v.image, v.camera, v.extent, fit, calibration=cal,
                           time_limit=s.solver.time_limit, polish=False, maps=self.maps,
                           detections=self.detections, threads=threads)

    def view_evidence(self, pose: GridPose, *, given: bool,
                      detection: FeatureDetection | None = None):
        """Detect the features at ``pose``: the detection, the view's evidence for the
        visibility fixpoint, and the visibility to start it from."""
        from unseeable.visibility import BACKGROUND_INPUTS, initial_visibility
        from unseeable.visibility.loop import ViewEvidence
        from unseeable.vision import detect_features

        v, s, obs = self.view, self.settings, self.observation
        t1 = time.perf_counter()
        det = detection if detection is not None else self.detections.get(pose)
        if det is None:
            det = detect_features(v.image, v.camera, pose, v.extent,
                                  calibration=self.calibration,
                                  refine=s.pose.refine and given, maps=self.maps,
                                  threads=s.pose.threads)
        self.add_time("evidence_s", time.perf_counter() - t1)
        contextual = s.detection.background and det.has_context
        # With context, the first estimate reads every feature as seen against the table
        # (nothing behind): a fuller estimate, whose rounds then discount what it puts
        # behind. Starting from the plain models' estimate did worse on the corpus
        # (docs/decisions.md, "What lies behind a feature").
        start_priors = (det.priors_given(np.zeros((len(det.p), len(BACKGROUND_INPUTS))))
                        if contextual else det.p)
        evidence = ViewEvidence(
            start_priors, v.camera.centre, det.pose, judged=det.judged,
            removed_from_layer=v.removed_from_layer,
            context_priors=det.priors_given if contextual else None,
            clip=None if det.calibration is None else det.calibration.clip,
            line_aliases=line_aliases(det, v.camera) if s.detection.lines_once else None,
            threads=s.pose.threads)
        manual = obs.manual_visibility
        start_vis = (manual if manual is not None
                     else initial_visibility(v.extent, v.camera, det.pose))
        return det, evidence, start_vis

    def structure_at(self, pose: GridPose, solver, prior_of, *,
                     given: bool, detection: FeatureDetection | None = None
                     ) -> StructureAtPose:
        """Detect the features at ``pose`` and estimate structure and visibility there."""
        from unseeable.visibility.loop import estimate_with_visibility

        v, s = self.view, self.settings
        det, evidence, start_vis = self.view_evidence(pose, given=given, detection=detection)
        manual = self.observation.manual_visibility
        t2 = time.perf_counter()
        limit = s.solver.time_limit
        fp = estimate_with_visibility(evidence, v.extent, solver=solver,
                                      initial_visibility=start_vis,
                                      fixed_visibility=manual is not None,
                                      time_limit=limit, budget_s=limit,
                                      presence_shift=s.detection.presence_shift,
                                      structure_prior=prior_of)
        self.add_time("structure_s", time.perf_counter() - t2)
        return structure_at_pose(det, evidence, fp)


def _calibration_identity(calibration: Any) -> str:
    """What a cached pose search's key knows of the calibration: the shipped one is part
    of the package (its source digest), a file by its contents, a loaded one by its pickle."""
    import hashlib
    import pickle
    from pathlib import Path

    if calibration is None:
        return "shipped"
    data = (Path(calibration).read_bytes() if isinstance(calibration, str)
            else pickle.dumps(calibration))
    return hashlib.sha256(data).hexdigest()


def structure_at_pose(detection, evidence, fixpoint) -> StructureAtPose:
    """A view's estimate at a pose with the doubt about its extent (log ends the estimate
    puts on the extent's boundary judged absent, :func:`boundary_ends`)."""
    fp = fixpoint
    priors = np.where(fp.visibility[0] & evidence.judged, fp.priors[0], 0.5)
    judged = absent = 0
    if fp.result.structure is not None:
        judged, absent = boundary_ends(fp.result.structure, priors)
    # Read from the module at each use: a study may move the bar.
    doubt = (absent >= evidence_checks.EDGE_ENDS_ABSENT_MIN
             and absent >= evidence_checks.EDGE_ENDS_ABSENT_SHARE * judged)
    return StructureAtPose(detection, evidence, fp, priors, judged, absent, bool(doubt))


def _fit_report(fit) -> dict[str, Any]:
    return {"source": "estimated", "quality": fit.quality, "choice_margin": fit.choice_margin,
            "ambiguous": fit.ambiguous, "rival": fit.choice_rival}


def find_pose(observation: Observation, settings: EstimateSettings = EstimateSettings(), *,
              solver: StructureSolver | None = None, constraints=()) -> PoseFinding:
    """Choose a view's pose, and estimate the structure at it.

    A known pose (``observation.pose``) is used, polished on the image's edges
    when ``settings.pose.refine``. Otherwise the pose is searched on the image's
    edges and chosen among the grid's near-symmetric translations by the structure
    each implies; if the log ends the estimate puts on the extent's boundary look
    absent, the search is repeated with a lower bar for aliases
    (:data:`WIDE_ALIAS_KEEP`); then a polish on the estimate's own edges is judged.
    A new pose is kept only when its estimate is not in doubt.

    Parameters
    ----------
    observation : Observation
    settings : EstimateSettings
    solver : StructureSolver, optional
        A solver on the view's extent to reuse (one is made from the settings).
    constraints : sequence of Expr
        Further hard constraints for the solver made here.

    Returns
    -------
    PoseFinding

    Raises
    ------
    VisionError
        ``settings.pose.strict`` and the image contradicts the extent at the estimated
        pose (:func:`~unseeable.vision.estimate_pose`).
    """
    from unseeable.solve import StructureSolver
    from unseeable.vision import PoseSettings, judge_polish
    from unseeable.vision.pose_choice import poses_apart

    t0 = time.perf_counter()
    context = ViewContext(observation, settings)
    view = observation.view
    extent = view.extent
    prior_of = settings.prior.given_visibility(extent)
    given = observation.pose
    report: dict[str, Any]
    if given is not None:
        pose_used = given
        report = {"source": "given"}
    else:
        fit = context.search(PoseSettings(), settings.pose.strict)
        context.add_time("pose_s", time.perf_counter() - t0)
        report = _fit_report(fit)
        # The fit separates quarter turns by the edges themselves (layer heights differ by
        # half a log). A half turn re-describes the same physical assembly (DESIGN.md §3),
        # so it is not estimated again (docs/decisions.md, "Symbolic orientation of an
        # estimated pose").
        pose_used = fit.pose
    if solver is None:
        solver = StructureSolver(extent, constraints=constraints,
                                 backend=settings.solver.backend,
                                 workers=settings.solver.workers, ties=settings.prior.ties)
    at = context.structure_at(pose_used, solver, prior_of, given=given is not None)
    if at.extent_doubt and given is None:
        # Log ends seen missing at the boundary: the grid may be off the assembly by a
        # near-symmetry whose edges scored under the aliases' bar. Searched again with the
        # bar lowered; kept only if the new estimate is not in doubt (docs/decisions.md).
        t_again = time.perf_counter()
        wide = PoseSettings(alias_keep=WIDE_ALIAS_KEEP, finals_keep=WIDE_ALIAS_KEEP)
        again = context.search(wide, False, warn=False)  # the first search's fit was taken
        report["searched_again"] = True
        if poses_apart(again.pose, pose_used, extent):
            second = context.structure_at(again.pose, solver, prior_of, given=False)
            if not second.extent_doubt:
                at = second
                report.update(_fit_report(again))
                report["changed_by_second_search"] = True
        context.add_time("pose_again_s", time.perf_counter() - t_again)
    if given is None and at.fixpoint.result.structure is not None:
        # The search's candidates sit on the grid's edges; the estimate's own edges can
        # hold the pose elsewhere, a depth alias away, or draw it onto other logs' edges:
        # the move is judged as the pose choice judges candidates.
        t_polish = time.perf_counter()
        shown = at.fixpoint.result.structure  # the logs the image shows (after any removal)
        if view.removed_from_layer is not None:
            shown = shown.removed_from_layer(view.removed_from_layer)
        proposal = judge_polish(view.image, view.camera, shown, at.detection,
                                calibration=context.calibration, maps=context.maps,
                                pose_maps=context.pose_maps,
                                time_limit=settings.solver.time_limit,
                                refine=settings.pose.refine)
        if proposal is not None:
            report["polish_gain"] = (proposal.gain_before, proposal.gain_after)
            if proposal.better:
                moved = context.structure_at(proposal.detection.pose, solver, prior_of,
                                             given=False, detection=proposal.detection)
                if not moved.extent_doubt:
                    at = moved
                    report["moved_by_polish"] = True
        context.add_time("pose_polish_s", time.perf_counter() - t_polish)
    return PoseFinding(at.detection.pose, PoseReport(**report), at, solver,
                       dict(context.timings))
