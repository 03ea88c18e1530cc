"""Estimates from files, compared with the truth, drawn over their photographs.

A view file is checked before any work (:func:`check_view`): a camera that does
not see the table, focal lengths no detector can work at, or a recorded pose that
puts the assembly outside the photograph are errors naming the file and field;
so is a pose estimated from the photograph that does.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from unseeable.domain.frames import GridPose
from unseeable.domain.structure import Structure
from unseeable.errors import InputError, vision_errors_name
from unseeable.pipeline.core import estimate, estimate_evidence
from unseeable.pipeline.observation import Observation
from unseeable.pipeline.record import Estimate
from unseeable.pipeline.settings import EstimateSettings

__all__ = ["estimate_file", "estimate_files", "write_view_pictures", "compare_with_truth",
           "errors_against_truth", "unseen_positions", "check_camera", "check_in_image",
           "check_view", "check_estimated_poses", "check_extent_size", "VIEW_FORMAT",
           "MAX_ESTIMATE_POSITIONS", "MIN_SHARE_IN_IMAGE", "MM_PER_PIXEL_MAX",
           "MIN_VIEW_SPAN_MM"]

VIEW_FORMAT = "unseeable/view@1"

#: The least share of the extent's features a photograph must hold at the pose: with
#: fewer, the estimate would stand on a corner of the assembly, or on nothing. (An
#: assembly cut in half by the frame keeps about a quarter of its features whole.)
MIN_SHARE_IN_IMAGE = 0.1
#: Largest grid an estimate accepts (positions I*J*K). An estimate's time grows faster than
#: its grid; the worst case is an evidence file with no feature judged, where every
#: structure ties: with the default settings (load 4 on 2 cores, 2026-12-06) 8x8x8 took
#: 1.2 s, 10x10x10 1.9 s, 10x12x10 2.8 s and 12x12x12 44 s. The corpus's largest design is
#: 6x8x6 (288).
MAX_ESTIMATE_POSITIONS = 1500

#: Coarsest image scale accepted (millimetres per pixel at the table under the image
#: centre): a log (19 mm across) 0.4 pixels wide. Focal lengths given in millimetres
#: instead of pixels make hundreds. The detectors were calibrated at 1.35-2.37 mm per
#: pixel (:data:`unseeable.vision.scale.CALIBRATED_MM_PER_PX`) and do poorly far from it,
#: but a small image is no mistake.
MM_PER_PIXEL_MAX = 50.0
#: The image's shorter side must span at least this much of the table (mm): one notch
#: spacing. Finer cameras than that cannot hold a log.
MIN_VIEW_SPAN_MM = 64.0


def check_extent_size(extent, *, file=None, field: str = "extent") -> None:
    """Refuse a grid larger than :data:`MAX_ESTIMATE_POSITIONS`: its estimate would not
    finish in minutes."""
    if extent.positions > MAX_ESTIMATE_POSITIONS:
        raise InputError(f"has {extent.positions} grid positions; an estimate takes up to "
                         f"{MAX_ESTIMATE_POSITIONS} (10x12x10 takes seconds, larger "
                         "grids far longer)", file=file, field=field, value=str(extent))


def check_camera(camera, *, file=None, field: str = "camera") -> None:
    """Check that ``camera`` sees the table at a scale the detectors can work at.

    Raises
    ------
    InputError
        Naming ``file`` and ``field``: no ray of the image meets the table in front
        of the camera (it looks away from it, e.g. up, or its rotation is not
        world-to-camera), or the focal lengths make more than
        :data:`MM_PER_PIXEL_MAX` millimetres per pixel, or the image narrower than
        :data:`MIN_VIEW_SPAN_MM` (focal lengths not in pixels?).
    """
    from unseeable.vision.scale import mm_per_pixel, table_point

    u = np.linspace(0.0, camera.width - 1.0, 17)
    v = np.linspace(0.0, camera.height - 1.0, 13)
    uv = np.stack(np.meshgrid(u, v), axis=-1).reshape(-1, 2)
    with np.errstate(all="ignore"):
        on_table = np.isfinite(table_point(camera, uv, 0.0)).all(axis=1)
    if not on_table.any():
        raise InputError("does not see the table: no ray of its image meets the table "
                         "(y = 0) in front of it (is it looking up, or is R not the "
                         "world-to-camera rotation?)", file=file, field=field)
    mm = mm_per_pixel(camera)
    if not np.isfinite(mm):
        return  # the centre looks above the horizon: no scale to judge
    f = [float(camera.K[0, 0]), float(camera.K[1, 1])]
    if mm > MM_PER_PIXEL_MAX:
        raise InputError(f"the focal lengths make {mm:.3g} mm per pixel at the table: a log "
                         f"would be {19.0 / mm:.2g} pixels across (are fx and fy in "
                         "pixels?)", file=file, field=f"{field}.K", value=f)
    span = min(camera.width, camera.height) * mm
    if span < MIN_VIEW_SPAN_MM:
        raise InputError(f"the focal lengths make the image span {span:.3g} mm of the table, "
                         f"less than one notch spacing ({MIN_VIEW_SPAN_MM:g} mm): no log fits "
                         "in it (are fx and fy in pixels?)", file=file, field=f"{field}.K",
                         value=f)


def check_in_image(extent, pose: GridPose, camera, *, file=None, field: str = "pose",
                   what: str = "puts") -> None:
    """Check that at least :data:`MIN_SHARE_IN_IMAGE` of the extent's features lie inside
    the camera's image with the grid at ``pose``.

    ``what`` starts the message ("puts", or "estimated from the image puts").

    Raises
    ------
    InputError
        Naming ``file`` and ``field`` (with the pose as value), and how many
        features the image holds.
    """
    from unseeable.vision.projection import project_features

    inside = project_features(extent, pose, camera).in_image
    n, total = int(np.count_nonzero(inside)), len(inside)
    if n >= MIN_SHARE_IN_IMAGE * total:
        return
    where = ("the assembly outside the image: none of the extent's "
             f"{total} features is inside it" if n == 0 else
             f"most of the assembly outside the image: {n} of the extent's {total} "
             f"features are inside it, and an estimate needs "
             f"{MIN_SHARE_IN_IMAGE:.0%} at least")
    raise InputError(f"{what} {where} (is the camera or the pose right?)", file=file,
                     field=field, value=[round(pose.x, 1), round(pose.z, 1),
                                         round(pose.yaw_deg, 2)])


def check_view(view, *, file=None) -> None:
    """Check a loaded view before any work: its camera (:func:`check_camera`) and, when it
    records one, its pose (:func:`check_in_image`)."""
    check_extent_size(view.extent, file=file)
    check_camera(view.camera, file=file)
    if view.pose is not None:
        check_in_image(view.extent, view.pose, view.camera, file=file)


def check_estimated_poses(estimate: Estimate, views, paths) -> None:
    """After an estimate: a pose found from a photograph must leave the assembly in it as
    well (:func:`check_in_image`; the poses given are checked before). Every view's pose
    places the reference view's grid, as its overlay draws it."""
    extent = estimate.structure.extent if estimate.structure is not None else views[0].extent
    for view, record, path in zip(views, estimate.views, paths):
        if view.pose is None and record.pose is not None:
            check_in_image(extent, record.pose, view.camera, file=path,
                           what="the pose estimated from the image puts")


def estimate_file(path: str | Path, data: Any, settings: EstimateSettings = EstimateSettings(),
                  *, out_dir: str | Path | None = None, truth: Structure | None = None,
                  truth_pose: GridPose | None = None, constraints=(),
                  estimator: Callable[[Any, EstimateSettings], Estimate] | None = None
                  ) -> tuple[Estimate, list[Path]]:
    """Estimate from a parsed evidence or view file, told apart by its format tag.

    Returns the estimate and the pictures written to ``out_dir`` (views only;
    coloured against ``truth``, placed at ``truth_pose`` when known, see
    :func:`write_view_pictures`). A view's recorded pose is used when it has one.
    ``estimator(evidence or observations, settings)``, when given, makes the estimate
    instead of :func:`estimate_evidence` / :func:`estimate` (e.g. one constrained by a
    description, :func:`unseeable.language.description_estimator`).
    """
    from unseeable.domain.evidence import EVIDENCE_FORMAT, evidence_from_json

    fmt = data.get("format") if isinstance(data, dict) else None
    if fmt == EVIDENCE_FORMAT:
        if settings.detection.calibration is not None:
            raise InputError("serves views only: an evidence file holds its priors already",
                             file=path, field="calibration",
                             value=settings.detection.calibration_label())
        evidence = evidence_from_json(data, file=path)
        check_extent_size(evidence.extent, file=path)
        if estimator is not None:
            return estimator(evidence, settings), []
        return estimate_evidence(evidence, settings, constraints=constraints,
                                 source=path), []
    if fmt == VIEW_FORMAT:
        from unseeable.render.view import load_view

        view = load_view(path)
        check_view(view, file=path)
        observations = [Observation.of(view, source=path)]
        with vision_errors_name(path):  # e.g. a poor pose fit: which view
            est = (estimator(observations, settings) if estimator is not None
                   else estimate(observations, settings, constraints=constraints))
        check_estimated_poses(est, [view], [path])
        pictures = []
        if out_dir is not None:
            pictures = write_view_pictures(est, view, out_dir, truth=truth,
                                           truth_pose=truth_pose)
        return est, pictures
    raise InputError(f"must be {EVIDENCE_FORMAT!r} or {VIEW_FORMAT!r}", file=path,
                     field="format", value=fmt)


def estimate_files(paths, settings: EstimateSettings = EstimateSettings(), *,
                   out_dir: str | Path | None = None, truth: Structure | None = None,
                   truth_pose: GridPose | None = None, constraints=(),
                   estimator: Callable[[Any, EstimateSettings], Estimate] | None = None
                   ) -> tuple[Estimate, list[Path]]:
    """Estimate from one evidence or view file, or from several view files jointly (the
    first is the reference view); ``estimator`` as :func:`estimate_file`'s.

    Returns the estimate and the pictures written to ``out_dir``
    (:func:`write_view_pictures`).
    """
    from unseeable.fileio import read_json
    from unseeable.render.view import load_view

    paths = [Path(p) for p in paths]
    if not paths:
        raise InputError("needs at least one file", field="files", value=[])
    if len(paths) == 1:
        return estimate_file(paths[0], read_json(paths[0]), settings, out_dir=out_dir,
                             truth=truth, truth_pose=truth_pose, constraints=constraints,
                             estimator=estimator)
    views = []
    for path in paths:
        data = read_json(path)
        fmt = data.get("format") if isinstance(data, dict) else None
        if fmt != VIEW_FORMAT:
            raise InputError(f"must be {VIEW_FORMAT!r}: several files are views of one "
                             "assembly", file=path, field="format", value=fmt)
        views.append(load_view(path))
        check_view(views[-1], file=path)
    observations = [Observation.of(v, source=p) for v, p in zip(views, paths)]
    est = (estimator(observations, settings) if estimator is not None
           else estimate(observations, settings, constraints=constraints))
    check_estimated_poses(est, views, paths)
    pictures = []
    if out_dir is not None:
        pictures = write_view_pictures(est, views, out_dir, truth=truth, truth_pose=truth_pose)
    return est, pictures


def unseen_positions(estimate: Estimate) -> np.ndarray | None:
    """``(I, J, K) bool``: the grid positions no view judged a feature of (None without a
    structure); where the estimate builds nothing there, a log may still hide."""
    from unseeable.domain.features import feature_index

    s = estimate.structure
    if s is None:
        return None
    idx = feature_index(s.extent)
    judged = np.zeros(len(idx.kind), dtype=bool)
    for v in estimate.views:  # every view's priors are in the reference view's grid
        judged |= np.asarray(v.priors) != 0.5
    at = np.asarray(idx.at)
    inside = (at < np.array(s.extent.shape)).all(axis=1)  # the top layer's segments: above
    seen = np.zeros(s.extent.shape, dtype=bool)
    i, j, k = at[judged & inside].T
    seen[i, j, k] = True
    return ~seen


def write_view_pictures(estimate: Estimate, views, out_dir: str | Path, *,
                        truth: Structure | None = None, truth_pose: GridPose | None = None
                        ) -> list[Path]:
    """Pictures of an estimate (:mod:`unseeable.render.pictures`), written to ``out_dir``.

    Per view, the photograph with the estimate drawn over it (``overlay.png``, or
    ``overlay_N.png`` for view N of several; a disassembly view's without the
    logs the arm removed): seen logs blue, inferred ones orange, positions no view
    saw hatched grey. Then ``estimate.png``, the estimated structure from the
    reference view's camera in the same colours; and with ``truth``,
    ``truth.png``: the reference photograph with each log green when right and
    red when wrong, and the truth's logs the estimate missed in magenta (the
    truth placed at ``truth_pose`` when known, else at the estimate's pose).

    Returns
    -------
    list of Path
        The overlays, then ``estimate.png``, then ``truth.png`` (with a truth).
    """
    from unseeable.render.pictures import estimate_pictures, truth_picture
    from unseeable.render.view import write_image

    s = estimate.structure
    if s is None:
        return []
    views = list(views) if isinstance(views, (list, tuple)) else [views]
    seen = estimate.logs_seen()
    unknown = unseen_positions(estimate)
    out = Path(out_dir)
    paths = []
    reference = None
    for n, (view, record) in enumerate(zip(views, estimate.views)):
        shown, keep, hidden = s, np.ones(len(s.logs), dtype=bool), unknown
        if record.removed_from_layer is not None:
            keep = np.array([log.layer < record.removed_from_layer for log in s.logs])
            shown = s.removed_from_layer(record.removed_from_layer)
            hidden = unknown.copy()
            hidden[:, record.removed_from_layer:, :] = False
        pics = estimate_pictures(view.image, shown, record.pose, view.camera,
                                 seen=seen[keep], unknown=hidden)
        name = "overlay.png" if len(views) == 1 else f"overlay_{n + 1}.png"
        paths.append(out / name)
        write_image(paths[-1], pics["overlay"])
        if n == 0:
            reference = pics["rendering"] if record.removed_from_layer is None else \
                estimate_pictures(view.image, s, record.pose, view.camera,
                                  seen=seen)["rendering"]
    paths.append(out / "estimate.png")
    write_image(paths[-1], reference)
    if truth is not None:
        view, record = views[0], estimate.views[0]
        placed = truth_pose if truth_pose is not None else view.pose
        comparison = compare_with_truth(estimate, truth, truth_pose=placed)
        paths.append(out / "truth.png")
        write_image(paths[-1], truth_picture(
            view.image, s, record.pose, view.camera, correct=comparison.estimate_correct,
            truth=truth, truth_pose=placed if placed is not None else record.pose,
            truth_correct=comparison.truth_correct))
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
