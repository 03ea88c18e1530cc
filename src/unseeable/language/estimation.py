"""Estimating a structure from photographs and a description together (paper §6).

The description's constraints Ψ join the grammar Φ in the estimator's one exact
solve (``constraints=`` of :func:`unseeable.pipeline.estimate`). *Left* and
*right* are seen from the reference (first) view's camera, which needs the
assembly's pose there: a recorded pose is used as it is; an estimated one is
found first, by the estimator without the description (the pose search does not
depend on it), and the description is compiled at that pose for a second
estimate. Should that estimate settle on a pose elsewhere (its checks of the
pose see the described structure), it is estimated once more at the first pose,
given, so that left and right keep the meaning they were compiled with.

A description no structure on the grid satisfies raises
:class:`~unseeable.language.UnsatisfiableError` naming the sentence.
"""

from __future__ import annotations

import logging
from collections.abc import Sequence
from typing import Any

from unseeable.errors import InputError
from unseeable.language.check import check_satisfiable
from unseeable.language.compile import CompiledDescription, compile_description
from unseeable.language.syntax import Description, parse
from unseeable.language.viewpoint import Viewpoint

__all__ = ["description_constraints", "estimate_with_description", "description_estimator",
           "POSE_MOVED_MM",
           "POSE_MOVED_DEG"]

logger = logging.getLogger(__name__)

#: A second estimate's pose this far from the first (mm or degrees) moved the grid
#: the description was compiled in.
POSE_MOVED_MM = 32.0
POSE_MOVED_DEG = 20.0


def description_constraints(description: Description | str | Sequence[str], view: Any,
                            pose: Any = None) -> CompiledDescription:
    """Ψ of ``description`` for the structure estimated from ``view`` (the reference
    view): compiled on the view's extent, left and right seen from its camera with the
    assembly at ``pose`` (default: the view's recorded pose).

    Raises
    ------
    InputError
        Neither ``pose`` nor a recorded pose, and the description says left or right.
    """
    description = parse(description)
    lateral = any(r.name in ("left_of", "right_of") for r in description.relations)
    viewpoint = None
    if lateral:
        viewpoint = Viewpoint.from_view(view, pose=pose)
    return compile_description(description, view.extent, viewpoint=viewpoint)


def estimate_with_description(observations: Sequence[Any], description: Any,
                              settings: Any = None, *, constraints: Sequence[Any] = (),
                              without: Any = None) -> Any:
    """Estimate from photographs and a description (:func:`unseeable.pipeline.estimate`
    with the description's constraints).

    Parameters
    ----------
    observations : sequence of Observation
        The reference view first.
    description : Description or text
    settings : EstimateSettings, optional
    constraints : sequence of Expr
        Further constraints.
    without : Estimate, optional
        The estimate of the same observations without the description, when the caller
        has it (its pose is the one an estimated pose is compiled at; saves a run).

    Returns
    -------
    Estimate
        Its ``result.choices`` hold the description's selectors
        (:func:`~unseeable.language.chosen_placements`).

    Raises
    ------
    UnsatisfiableError
        No structure on the reference view's grid satisfies the description.
    """
    from unseeable.pipeline import EstimateSettings, Observation, estimate

    settings = EstimateSettings() if settings is None else settings
    observations = tuple(observations)
    if not observations:
        raise InputError("needs at least one observation", field="observations", value=0)
    description = parse(description)
    extra = tuple(constraints)

    def described(obs: tuple, psi: CompiledDescription) -> Any:
        try:
            return estimate(obs, settings, constraints=(*extra, *psi))
        except InputError as err:
            # The pipeline's "no valid structure fits": evidence is soft, so it is the
            # constraints; name the sentence no structure satisfies, when it is one.
            if err.field != "constraints":
                raise
            check_satisfiable(description, psi.extent, viewpoint=psi.viewpoint)
            raise

    reference = observations[0]
    if reference.pose is not None:
        return described(observations, description_constraints(description, reference.view,
                                                                reference.pose))
    first = without if without is not None else estimate(observations, settings,
                                                         constraints=extra)
    if first.pose is None:
        raise InputError("the estimate without the description found no pose",
                         field="observations", value=reference.source)
    psi = description_constraints(description, reference.view, first.pose)
    second = described(observations, psi)
    if second.pose is not None:
        mm, deg = first.pose.distance(second.pose)
        if mm <= POSE_MOVED_MM and deg <= POSE_MOVED_DEG:
            return second
        logger.info("the described estimate moved the pose by %.0f mm, %.0f°; estimated "
                    "again at the pose the description was compiled at", mm, deg)
    fixed = (Observation(reference.view, pose=first.pose, source=reference.source,
                         manual_visibility=reference.manual_visibility), *observations[1:])
    return described(fixed, psi)


def description_estimator(texts: str | Sequence[str]):
    """An ``estimator`` for :func:`unseeable.pipeline.estimate_files` that constrains the
    estimate by the description ``texts`` (parsed now, so that a bad sentence is refused
    before any work) and records the sentences and each entity's chosen placement in the
    estimate (``Estimate.description``)."""
    from dataclasses import replace

    from unseeable.domain.evidence import Evidence
    from unseeable.language.compile import chosen_placements
    from unseeable.pipeline import estimate_evidence

    sentences = [texts] if isinstance(texts, str) else list(texts)
    description = parse(sentences)

    def run(what: Any, settings: Any) -> Any:
        if isinstance(what, Evidence):
            psi = compile_description(description, what.extent)
            try:
                est = estimate_evidence(what, settings, constraints=psi)
            except InputError as err:
                if err.field != "constraints":
                    raise
                check_satisfiable(description, what.extent)
                raise
            if est.structure is None:
                check_satisfiable(description, what.extent)
        else:
            est = estimate_with_description(what, description, settings)
            psi = description_constraints(description, what[0].view, est.pose)
        placed = chosen_placements(description, psi, est.result.choices)
        return replace(est, description={
            "sentences": sentences,
            "placements": {name: p.to_json() for name, p in placed.items()}})
    return run
