"""One structure from several photographs (paper §5): a joint estimate.

Every view contributes its own evidence terms and its own visibility (ray cast
from its own camera against the one structure, with the logs the arm had removed
left out for a disassembly view), iterated to one joint fixpoint; the confidence
is judged over the features no view saw.

Two registrations:

* **shared table frame** (default; the pendulum arm and the removal arm): the
  cameras are calibrated in one table frame and the assembly does not move, so its
  pose is one. A recorded pose is used; otherwise the reference (first) view's pose
  is found (:func:`~unseeable.pipeline.find_pose`) and every view is detected there,
  each polished on its own image's edges. A view whose polish moves the pose by more
  than :data:`DISAGREE_MM` or :data:`DISAGREE_DEG` disagrees with the shared pose: it is
  flagged, and the estimate is not confident.
* **independent views** (the paper's setting: a hand-held camera, or frames not
  shared): each view's pose is found alone, and each added view is registered
  greedily, trying its admissible symbolic orientations against the joint estimate
  and keeping the most probable; the margin over the runner-up is recorded, and a
  near tie (under :data:`REGISTRATION_TIE`) makes the estimate not confident.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Sequence
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from unseeable.domain.frames import GridPose
from unseeable.errors import InputError
from unseeable.pipeline.evidence_checks import presence_doubt
from unseeable.pipeline.observation import Observation
from unseeable.pipeline.posing import (
    PoseReport,
    StructureAtPose,
    ViewContext,
    find_pose,
    structure_at_pose,
)
from unseeable.pipeline.record import ViewRecord
from unseeable.pipeline.settings import EstimateSettings

__all__ = ["JointFixpoint", "estimate_jointly", "check_views_agree", "DISAGREE_MM",
           "DISAGREE_DEG", "REGISTRATION_TIE"]

logger = logging.getLogger(__name__)

#: A view whose own edges move the shared pose further than this (mm, degrees)
#: disagrees with it: its camera or the assembly's placement is not what the others say.
DISAGREE_MM = 2.0
DISAGREE_DEG = 1.0
#: Nats by which the chosen orientation of an independently posed view must beat the
#: runner-up for the registration to count as sure.
REGISTRATION_TIE = 1.0


@dataclass(frozen=True, eq=False)
class JointFixpoint:
    """What :func:`estimate_jointly` made: the joint fixpoint, a record per view (its
    detection, pose, report and registration), the views' evidence and the kept solver."""

    fixpoint: Any
    views: tuple[ViewRecord, ...]
    evidence: tuple
    solver: Any
    timings: dict


def check_views_agree(observations: Sequence[Observation], *, independent: bool) -> None:
    """Refuse views that cannot be one assembly's: different extents (that no quarter turn
    reconciles, for independent views), or a disassembly level outside the grid."""
    ref = observations[0].extent
    for n, obs in enumerate(observations):
        name = obs.source or f"observations[{n}]"
        e = obs.extent
        same = e == ref or (independent and (e.I, e.J, e.K) == (ref.K, ref.J, ref.I))
        if not same:
            raise InputError(f"must be the reference view's {ref}"
                             + (" (or it turned a quarter)" if independent else ""),
                             file=name, field="extent", value=str(e))
        layer = obs.removed_from_layer
        if layer is not None and not 1 <= layer <= e.J:
            raise InputError(f"must be a layer from 1 to {e.J}", file=name,
                             field="removed_from_layer", value=layer)


def _fixpoint(contexts, evidence, start_vis, extent, solver, settings, prior_of,
              fixed: bool):
    from unseeable.visibility.loop import estimate_with_visibility

    limit = settings.solver.time_limit
    return estimate_with_visibility(list(evidence), extent, solver=solver,
                                    initial_visibility=tuple(start_vis),
                                    fixed_visibility=fixed, time_limit=limit,
                                    budget_s=limit * len(evidence),
                                    presence_shift=settings.detection.presence_shift,
                                    structure_prior=prior_of)


def _pose_offset(a: GridPose, b: GridPose) -> tuple[float, float]:
    mm = float(np.hypot(a.x - b.x, a.z - b.z))
    deg = abs((a.yaw_deg - b.yaw_deg + 180.0) % 360.0 - 180.0)
    return mm, float(deg)


def estimate_jointly(observations: Sequence[Observation], settings: EstimateSettings, *,
                     constraints: Sequence[Any] = (), independent: bool = False,
                     earlier: Sequence[ViewRecord] = ()) -> JointFixpoint:
    """Detect every view and iterate one structure and every view's visibility to a
    fixpoint (the module's two registrations).

    ``earlier``: the records of the first views from an estimate made before (one table
    frame): their pose and detections are taken as they are, and only the views after
    them are detected, at that pose."""
    from unseeable.solve import StructureSolver

    observations = tuple(observations)
    check_views_agree(observations, independent=independent)
    ref = observations[0]
    extent = ref.extent
    fixed = any(o.manual_visibility is not None for o in observations)
    if fixed and not all(o.manual_visibility is not None for o in observations):
        raise InputError("give manual visibility for every view or for none",
                         field="manual_visibility")
    solver = StructureSolver(extent, constraints=constraints, backend=settings.solver.backend,
                             workers=settings.solver.workers, ties=settings.prior.ties)
    prior_of = settings.prior.given_visibility(extent)
    timings: dict[str, float] = {}
    if independent:
        if earlier:
            raise InputError("continues estimates in one table frame only",
                             field="independent", value=True)
        return _independent(observations, settings, solver, prior_of, fixed, timings)
    earlier = tuple(earlier)
    if len(earlier) > len(observations):
        raise InputError("has more records than observations", field="earlier",
                         value=len(earlier))
    t0 = time.perf_counter()
    # The shared pose: a recorded one (the reference's first), else the reference's found.
    known = next((o.pose for o in observations if o.pose is not None), None)
    reports: list[PoseReport | None] = []
    contexts = [ViewContext(o, settings) for o in observations]
    if earlier:
        shared, ref_report, ref_detection = (earlier[0].pose, earlier[0].pose_report,
                                             earlier[0].detection)
    elif known is None:
        finding = find_pose(ref, settings, solver=solver)
        shared, ref_report = finding.pose, finding.report
        ref_detection = finding.at.detection
    else:
        shared, ref_report, ref_detection = known, PoseReport("given"), None
    timings["pose_s"] = time.perf_counter() - t0
    dets, evidence, starts = [], [], []
    for n, context in enumerate(contexts):
        # Every view but an estimated reference is polished on its own image's edges.
        before = earlier[n] if n < len(earlier) else None
        det, ev, start = context.view_evidence(
            shared, given=n > 0 or known is not None,
            detection=before.detection if before is not None
            else ref_detection if n == 0 else None)
        dets.append(det)
        evidence.append(ev)
        starts.append(start)
        reports.append(before.pose_report if before is not None
                       else ref_report if n == 0 else PoseReport("shared"))
    t1 = time.perf_counter()
    fp = _fixpoint(contexts, evidence, starts, extent, solver, settings, prior_of, fixed)
    timings["structure_s"] = time.perf_counter() - t1
    for context in contexts:
        for key, value in context.timings.items():
            timings[key] = timings.get(key, 0.0) + value
    records = []
    for n, (obs, det, ev) in enumerate(zip(observations, dets, evidence)):
        mm, deg = _pose_offset(det.pose, shared)
        disagrees = n > 0 and (mm > DISAGREE_MM or deg > DISAGREE_DEG)
        if disagrees:
            logger.warning("%s: its own edges move the shared pose by %.1f mm, %.2f°: its "
                           "camera or the assembly's placement disagrees with the reference "
                           "view", obs.source or f"view {n + 1}", mm, deg)
        records.append(_record(obs, n, det, ev, fp, reports[n], disagrees=disagrees,
                               offset=(mm, deg)))
    return JointFixpoint(fp, tuple(records), tuple(evidence), solver, timings)


def _record(obs: Observation, n: int, det, ev, fp, report, *, disagrees: bool = False,
            offset=(0.0, 0.0), orientation: int = 0, margin: float | None = None
            ) -> ViewRecord:
    at: StructureAtPose = structure_at_pose(det, ev, _view_of(fp, n))
    shift = fp.presence_shift[n] if fp.presence_shift else 0.0
    in_image = det.scores.projection.in_image
    return ViewRecord(
        source=obs.source, pose=det.pose, pose_report=report, priors=at.priors,
        visible=fp.visibility[n], orientation=orientation,
        removed_from_layer=obs.removed_from_layer, detection=det,
        presence_shift=float(shift), edge_ends_judged=at.edge_ends_judged,
        edge_ends_absent=at.edge_ends_absent,
        extent_doubt=at.extent_doubt and obs.removed_from_layer is None,
        evidence_doubt=presence_doubt(fp, n),
        features_outside_image=int(np.count_nonzero(~in_image)),
        pose_offset=offset, disagrees=disagrees, registration_margin=margin,
        registration_doubt=margin is not None and margin < REGISTRATION_TIE)


def _view_of(fp, n: int):
    """``fp`` as seen by view ``n`` alone (its visibility and priors first)."""
    order = [n, *[m for m in range(len(fp.visibility)) if m != n]]
    return replace(fp, visibility=tuple(fp.visibility[m] for m in order),
                   priors=tuple(fp.priors[m] for m in order))


def _independent(observations, settings, solver, prior_of, fixed, timings) -> JointFixpoint:
    """Each view posed alone, then registered greedily by symbolic orientation."""
    t0 = time.perf_counter()
    ref = observations[0]
    extent = ref.extent
    findings = [find_pose(o, settings, solver=solver) for o in observations]
    timings["pose_s"] = time.perf_counter() - t0
    contexts = [ViewContext(o, settings) for o in observations]
    ref_finding = findings[0]
    chosen = [(ref_finding.at.detection, ref_finding.at.evidence, _start(ref_finding), 0,
               None)]
    fp = ref_finding.at.fixpoint
    t1 = time.perf_counter()
    for n in range(1, len(observations)):
        candidates = []
        for o in range(4):
            pose, turned_extent = findings[n].pose.turned(o, observations[n].extent)
            if turned_extent != extent:
                continue
            det, ev, start = contexts[n].view_evidence(pose, given=False)
            trial = [*chosen, (det, ev, start, o, None)]
            trial_fp = _fixpoint(contexts, [c[1] for c in trial], [c[2] for c in trial],
                                 extent, solver, settings, prior_of, fixed)
            candidates.append((trial_fp.result.log_probability, o, det, ev, start, trial_fp))
        if not candidates:
            raise InputError("no symbolic orientation maps this view's grid onto the "
                             "reference view's", file=observations[n].source,
                             field="extent", value=str(observations[n].extent))
        candidates.sort(key=lambda c: -c[0])
        best = candidates[0]
        margin = best[0] - candidates[1][0] if len(candidates) > 1 else None
        if margin is not None and margin < REGISTRATION_TIE:
            logger.warning("%s: its orientation beats the runner-up by only %.2f nats",
                           observations[n].source or f"view {n + 1}", margin)
        chosen.append((best[2], best[3], best[4], best[1], margin))
        fp = best[5]
    timings["structure_s"] = time.perf_counter() - t1
    records = []
    for n, (det, ev, _, o, margin) in enumerate(chosen):
        records.append(_record(observations[n], n, det, ev, fp, findings[n].report,
                               orientation=o, margin=margin))
    return JointFixpoint(fp, tuple(records), tuple(c[1] for c in chosen), solver, timings)


def _start(finding) -> np.ndarray:
    return finding.at.fixpoint.visibility[0]
