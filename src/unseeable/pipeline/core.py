"""The estimator: observations (or bare evidence) in, an :class:`Estimate` out.

``estimate(observations, settings, constraints)`` is the core: for each photograph
the pose is found (:func:`find_pose`), the features are detected there, structure
and visibility are iterated to a fixpoint, and the confidence is judged over the
features no view saw. :func:`estimate_view` and :func:`estimate_evidence` are
the one-photograph and bare-evidence forms.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Sequence
from typing import Any

import numpy as np

from unseeable.domain.evidence import Evidence
from unseeable.domain.frames import GridPose
from unseeable.errors import InputError
from unseeable.parallel import single_blas_thread
from unseeable.pipeline.evidence_checks import presence_doubt
from unseeable.pipeline.observation import Observation
from unseeable.pipeline.posing import find_pose
from unseeable.pipeline.record import Estimate, EstimateModel, ViewRecord
from unseeable.pipeline.settings import EstimateSettings

__all__ = ["estimate", "estimate_view", "estimate_evidence", "extend_estimate"]

logger = logging.getLogger(__name__)


def _check_settings(settings: Any) -> EstimateSettings:
    if not isinstance(settings, EstimateSettings):
        raise InputError("must be an EstimateSettings", field="settings",
                         value=type(settings).__name__)
    return settings


@single_blas_thread()
def estimate(observations: Sequence[Observation],
             settings: EstimateSettings = EstimateSettings(), *,
             constraints: Sequence[Any] = ()) -> Estimate:
    """Estimate a structure from photographs: pose → evidence → visibility ⇄ structure
    → confidence.

    Parameters
    ----------
    observations : sequence of Observation
        The photographs, full or after the arm removed layers; the first is the
        reference view, whose grid the structure is numbered in. Several views make one
        joint estimate (:mod:`~unseeable.pipeline.joint`: one table frame, or
        independent views registered by symbolic orientation, ``settings.pose``).
    settings : EstimateSettings
        Every setting (the shipped estimator by default).
    constraints : sequence of Expr
        Further hard constraints on the structure (e.g. from a description).

    Returns
    -------
    Estimate
        The structure in the reference view's extent, one :class:`ViewRecord` per
        photograph (its pose and how it was found, visibility, detections, doubts),
        the confidence and what is needed to continue.

    Raises
    ------
    VisionError
        A pose estimated from an image fits poorly and ``settings.pose.strict``.
    InputError
        Bad observations or settings.

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

    settings = _check_settings(settings)
    observations = tuple(observations)
    if not observations:
        raise InputError("needs at least one observation", field="observations", value=0)
    for n, obs in enumerate(observations):
        if not isinstance(obs, Observation):
            raise InputError("must be an Observation", field=f"observations[{n}]",
                             value=type(obs).__name__)
    if len(observations) > 1:
        return _estimate_jointly(observations, settings, constraints)
    t0 = time.perf_counter()
    obs = observations[0]
    finding = find_pose(obs, settings, constraints=constraints)
    at = finding.at
    fp = at.fixpoint
    timings = dict(finding.timings)
    shift = fp.presence_shift[0] if fp.presence_shift else 0.0
    evidence_doubt = False
    if fp.result.structure is not None:
        # Only the confidence is doubted: searching an estimated pose in this doubt again,
        # as for the extent's doubt, righted none of the wrong poses it caught on the
        # corpora and families and left three views 1-4 errors worse (docs/decisions.md).
        evidence_doubt = presence_doubt(fp, 0)
        if at.extent_doubt:
            logger.warning("%d of the %d log ends the estimate puts on the extent's boundary "
                           "look absent: is the extent %s too small, or the pose off?",
                           at.edge_ends_absent, at.edge_ends_judged, obs.extent)
        if evidence_doubt:
            fitted = fp.presence_fitted[0] if fp.presence_fitted else shift
            logger.warning("the detections would need a shift of %+.2f in log-odds to agree "
                           "with the estimate%s: they and every structure on this grid "
                           "disagree more than a look explains; is the pose off?", fitted,
                           " (refused: it dropped what they see clearly)"
                           if fp.presence_refused and fp.presence_refused[0] else "")
    # Features the camera's frame cuts off are not judged: ½ each, as occluded ones are, so
    # the estimate and its confidence already treat them as unseen; the user is told.
    in_image = at.detection.scores.projection.in_image
    outside = int(np.count_nonzero(~in_image))
    if outside:
        logger.warning("%d of the extent's %d features lie outside the image at the pose "
                       "used; they count as unseen (is the whole assembly in view?)",
                       outside, len(in_image))
    record = ViewRecord(
        source=obs.source, pose=finding.pose, pose_report=finding.report, priors=at.priors,
        visible=fp.visibility[0], removed_from_layer=obs.removed_from_layer,
        detection=at.detection, presence_shift=float(shift),
        edge_ends_judged=at.edge_ends_judged, edge_ends_absent=at.edge_ends_absent,
        extent_doubt=at.extent_doubt if fp.result.structure is not None else False,
        evidence_doubt=evidence_doubt, features_outside_image=outside)
    conf = None
    if settings.confidence.enabled:
        t3 = time.perf_counter()
        occ = occluded_features([at.evidence], fp.visibility, fp.structure.extent)
        conf = assess_confidence(finding.solver, fp.terms, fp.result, occ,
                                 delta_star=settings.confidence.delta_star,
                                 tolerance=settings.confidence.tolerance,
                                 reading_shift=settings.confidence.reading_shift,
                                 time_limit=settings.solver.time_limit)
        timings["confidence_s"] = time.perf_counter() - t3
    timings["total_s"] = time.perf_counter() - t0
    model = EstimateModel(observations, finding.solver, fp.terms, tuple(constraints))
    return Estimate(result=fp.result, views=(record,), confidence=conf, settings=settings,
                    iterations=fp.iterations, converged=fp.converged,
                    cycle_length=fp.cycle_length, history=fp.history, timings=timings,
                    model=model)


def extend_estimate(previous: Estimate, observations: Sequence[Observation] = (), *,
                    constraints: Sequence[Any] = ()) -> Estimate:
    """``previous`` with more photographs or more constraints: one joint estimate, in which
    the photographs it was made from keep their pose and detections (only the new ones
    are detected, at its pose; one table frame), under its settings.

    Parameters
    ----------
    previous : Estimate
        From photographs (its ``model`` holds them).
    observations : sequence of Observation
        Further photographs.
    constraints : sequence of Expr
        Further hard constraints (those ``previous`` was made under are kept).
    """
    model = previous.model
    if model is None or not model.observations:
        raise InputError("continues estimates made from photographs", field="previous",
                         value="bare evidence")
    for n, obs in enumerate(observations):
        if not isinstance(obs, Observation):
            raise InputError("must be an Observation", field=f"observations[{n}]",
                             value=type(obs).__name__)
    return _estimate_jointly((*model.observations, *observations), previous.settings,
                             (*model.constraints, *constraints), earlier=previous.views)


def _estimate_jointly(observations, settings: EstimateSettings, constraints, *,
                      earlier=()) -> Estimate:
    """:func:`estimate` for several photographs (``earlier``: as
    :func:`~unseeable.pipeline.joint.estimate_jointly`'s)."""
    from unseeable.confidence import assess_confidence, occluded_features
    from unseeable.pipeline.joint import estimate_jointly

    t0 = time.perf_counter()
    joint = estimate_jointly(observations, settings, constraints=constraints,
                             independent=settings.pose.independent, earlier=earlier)
    fp = joint.fixpoint
    timings = dict(joint.timings)
    for v in joint.views:
        if v.features_outside_image:
            logger.warning("%s: %d of the extent's features lie outside the image; they "
                           "count as unseen there", v.source or "a view",
                           v.features_outside_image)
    conf = None
    if settings.confidence.enabled:
        t3 = time.perf_counter()
        occ = occluded_features(list(joint.evidence), fp.visibility, fp.structure.extent)
        conf = assess_confidence(joint.solver, fp.terms, fp.result, occ,
                                 delta_star=settings.confidence.delta_star,
                                 tolerance=settings.confidence.tolerance,
                                 reading_shift=settings.confidence.reading_shift,
                                 time_limit=settings.solver.time_limit)
        timings["confidence_s"] = time.perf_counter() - t3
    timings["total_s"] = time.perf_counter() - t0
    model = EstimateModel(tuple(observations), joint.solver, fp.terms, tuple(constraints))
    return Estimate(result=fp.result, views=joint.views, confidence=conf, settings=settings,
                    iterations=fp.iterations, converged=fp.converged,
                    cycle_length=fp.cycle_length, history=fp.history, timings=timings,
                    model=model)


def estimate_view(view, settings: EstimateSettings = EstimateSettings(), *,
                  pose: GridPose | None = None, use_recorded_pose: bool = True,
                  source: Any = None, manual_visibility: np.ndarray | None = None,
                  constraints: Sequence[Any] = ()) -> Estimate:
    """Estimate a structure from one photograph (:func:`estimate` with one observation).

    Parameters
    ----------
    view : View
        Image, camera, extent; its recorded pose (if any) is used unless
        ``use_recorded_pose`` is False, else the pose is found from the image.
    settings : EstimateSettings
    pose : GridPose, optional
        A known pose (overrides the view's).
    source : str, optional
        The view's file, recorded in the estimate.
    manual_visibility : (N,) bool, optional
        Use this visibility instead of the fixpoint (needs a known pose).
    constraints : sequence of Expr

    Examples
    --------
    >>> from unseeable.corpus import load_design
    >>> from unseeable.render.workspace import PendulumArm, Workspace
    >>> entry = load_design("cabin-4x4")
    >>> ws = Workspace(entry.structure, pose=entry.pose, arm=PendulumArm(width=320,
    ...                height=240), raster=True)  # doctest: +SKIP
    >>> est = estimate_view(ws.observe(150.0))  # doctest: +SKIP
    """
    obs = Observation.of(view, use_recorded_pose=use_recorded_pose, pose=pose, source=source,
                         manual_visibility=manual_visibility)
    return estimate([obs], settings, constraints=constraints)


def estimate_evidence(evidence: Evidence, settings: EstimateSettings = EstimateSettings(), *,
                      constraints: Sequence[Any] = (), source: Any = None) -> Estimate:
    """MAP structure for bare evidence (an evidence file's priors), with its confidence.

    Features without evidence (p = ½) count as unseen for the confidence test and
    for the structure prior's joints.

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

    settings = _check_settings(settings)
    t0 = time.perf_counter()
    prior_of = settings.prior.given_visibility(evidence.extent)
    # Bare evidence has no visibility: a feature with a reading (p != ½) counts as seen.
    prior = prior_of(evidence.judged) if prior_of else ()
    solver = StructureSolver(evidence.extent, constraints=constraints,
                             backend=settings.solver.backend,
                             workers=settings.solver.workers, ties=settings.prior.ties)
    terms = [EvidenceTerm(evidence), *prior]
    result = solver.solve(terms, time_limit=settings.solver.time_limit)
    timings = {"estimate_s": time.perf_counter() - t0}
    conf = None
    if settings.confidence.enabled and result.structure is not None:
        t1 = time.perf_counter()
        conf = assess_confidence(solver, terms, result, ~evidence.judged,
                                 delta_star=settings.confidence.delta_star,
                                 tolerance=settings.confidence.tolerance,
                                 reading_shift=settings.confidence.reading_shift,
                                 time_limit=settings.solver.time_limit)
        timings["confidence_s"] = time.perf_counter() - t1
    timings["total_s"] = time.perf_counter() - t0
    record = ViewRecord(source=None if source is None else str(source), pose=None,
                        pose_report=None, priors=evidence.p)
    return Estimate(result=result, views=(record,), confidence=conf, settings=settings,
                    timings=timings,
                    model=EstimateModel((), solver, terms, tuple(constraints)))
