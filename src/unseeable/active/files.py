"""An active-vision run written out: ``estimate.json``, ``active.json`` and ``strip.png``.

:func:`active_from_files` (photographs and candidate files) and
:func:`active_in_workspace` (the simulated robot) run the loop and write into a
folder; the command line calls them inside a staged output folder, so a failure
leaves nothing half-written.
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Sequence
from pathlib import Path

import numpy as np

from unseeable.active.run import ActiveRun, ActiveStep, run_active
from unseeable.active.sources import PhotographPool, WorkspaceSource, pool_actions
from unseeable.errors import InputError
from unseeable.fileio import write_json

__all__ = ["write_active", "active_strip", "crop_to_assembly", "active_from_files",
           "active_in_workspace", "ACTIVE_FORMAT", "STRIP_PANEL_WIDTH"]

logger = logging.getLogger(__name__)

ACTIVE_FORMAT = "unseeable/active@1"
#: Width of each picture of the strip (pixels).
STRIP_PANEL_WIDTH = 360


def crop_to_assembly(picture: np.ndarray, image_size: tuple[int, int], extent, pose,
                     camera, *, margin: float = 0.15) -> np.ndarray:
    """``picture`` (of a photograph ``image_size = (W, H)``, maybe rescaled) cropped to
    where ``extent``'s features project at ``pose``, with ``margin`` of the box around."""
    from unseeable.render.pictures import crop_to
    from unseeable.vision.projection import project_features

    proj = project_features(extent, pose, camera)
    points = np.concatenate([proj.ellipses[:, :2], proj.segments.reshape(-1, 2)])
    points = points[np.isfinite(points).all(axis=1)]
    h, w = picture.shape[:2]
    scale = np.array([w / image_size[0], h / image_size[1]])
    points = np.round(points * scale).astype(int)
    inside = (points[:, 0] >= 0) & (points[:, 0] < w) & (points[:, 1] >= 0) & (points[:, 1] < h)
    mask = np.zeros((h, w), dtype=bool)
    mask[points[inside, 1], points[inside, 0]] = True
    return crop_to(picture, mask, margin=margin, min_size=0)


def _panel(image: np.ndarray, width: int, title: str) -> np.ndarray:
    import cv2

    h, w = image.shape[:2]
    scaled = cv2.resize(np.ascontiguousarray(image), (width, max(1, round(h * width / w))),
                        interpolation=cv2.INTER_AREA)
    band = np.full((26, width, 3), 255, np.uint8)
    cv2.putText(band, title[:60], (6, 18), cv2.FONT_HERSHEY_SIMPLEX, 0.45, (0, 0, 0), 1,
                cv2.LINE_AA)
    return np.vstack([band, scaled])


def active_strip(run: ActiveRun, *, truth=None, truth_pose=None,
                 width: int = STRIP_PANEL_WIDTH) -> np.ndarray:
    """One row per step: the photograph it added beside the estimate after it (drawn on
    the reference photograph: green/red against ``truth`` when given, else seen blue and
    inferred orange).

    Returns
    -------
    (H, W, 3) uint8
    """
    from unseeable.pipeline.files import compare_with_truth
    from unseeable.render.pictures import estimate_pictures, truth_picture

    rows = []
    for step in run.steps:
        est = step.estimate
        observations = est.model.observations
        new = observations[-1].view if step.number else observations[0].view
        ref = observations[0].view
        what = "start" if step.action is None else step.action.name
        pose = est.views[-1 if step.number else 0].pose
        left = _panel(crop_to_assembly(new.image, new.camera.size, new.extent, pose,
                                       new.camera), width, f"{step.number}: {what}")
        s = est.structure
        record = est.views[0]
        if s is None:
            picture = np.full_like(ref.image, 255)
        elif truth is not None:
            cmp = compare_with_truth(est, truth, truth_pose=truth_pose)
            picture = truth_picture(ref.image, s, record.pose, ref.camera,
                                    correct=cmp.estimate_correct, truth=truth,
                                    truth_pose=truth_pose if truth_pose is not None
                                    else record.pose,
                                    truth_correct=cmp.truth_correct, legend=False)
        else:
            picture = estimate_pictures(ref.image, s, record.pose, ref.camera,
                                        seen=est.logs_seen(), legend=False)["overlay"]
        verdict = "confident" if step.confident else "not confident"
        errors = "" if step.errors is None else f", {step.errors} errors"
        if s is not None:
            picture = crop_to_assembly(picture, ref.camera.size, s.extent, record.pose,
                                       ref.camera)
        right = _panel(picture, width, f"{len(s.logs) if s else 0} logs{errors}, {verdict}")
        height = max(left.shape[0], right.shape[0])
        row = [np.pad(p, ((0, height - p.shape[0]), (0, 0), (0, 0)), constant_values=255)
               for p in (left, right)]
        rows.append(np.hstack([row[0], np.full((height, 6, 3), 255, np.uint8), row[1]]))
    return np.vstack([np.vstack([r, np.full((6, r.shape[1], 3), 255, np.uint8)])
                      for r in rows])


def write_active(run: ActiveRun, out_dir: str | Path, *, truth=None, truth_pose=None
                 ) -> dict[str, Path]:
    """Write the final estimate, the steps and the picture strip into ``out_dir``."""
    from unseeable.pipeline import write_estimate
    from unseeable.render.view import write_image

    out = Path(out_dir)
    files = {"estimate": write_estimate(run.estimate, out)}
    files["active"] = out / "active.json"
    write_json(files["active"], {**run.to_json(), "format": ACTIVE_FORMAT}, indent=1)
    files["strip"] = out / "strip.png"
    write_image(files["strip"], active_strip(run, truth=truth, truth_pose=truth_pose))
    return files


def active_from_files(views: Sequence[str | Path], candidates: Sequence[str | Path],
                      out_dir: str | Path, settings=None, *, max_actions: int = 10,
                      truth=None, truth_pose=None,
                      on_step: Callable[[ActiveStep], None] | None = None
                      ) -> tuple[ActiveRun, dict[str, Path]]:
    """The loop on photographs: start from ``views``, choose among ``candidates`` (view
    files; each read only once chosen), write into ``out_dir``.

    The pose is the one found from the first view (or its recorded one), shared by every
    photograph: the candidates' cameras must be calibrated in the same table frame.
    """
    from unseeable.pipeline import Observation
    from unseeable.render.view import load_view

    if not views:
        raise InputError("needs at least one photograph to start from", field="VIEW",
                         value=0)
    if not candidates:
        raise InputError("needs at least one candidate view", field="--candidates", value=0)
    start = [load_view(v) for v in views]
    for path, view in zip(views[1:], start[1:]):
        if view.extent != start[0].extent:
            raise InputError(f"must be the first view's {start[0].extent}", file=path,
                             field="extent", value=str(view.extent))
    pool = PhotographPool(pool_actions(candidates, start[0]))
    observations = [Observation.of(v, source=str(p)) for v, p in zip(start, views)]
    run = run_active(observations, pool, settings, max_actions=max_actions, truth=truth,
                     truth_pose=truth_pose, on_step=on_step)
    return run, write_active(run, out_dir, truth=truth, truth_pose=truth_pose)


def active_in_workspace(structure, out_dir: str | Path, settings=None, *, pose=None,
                        start_angle: float = 150.0, stations: Sequence[float] | None = None,
                        levels: Sequence[int] | None = None, max_actions: int = 10,
                        size: tuple[int, int] = (640, 480), spp: int = 16, seed: int = 0,
                        known_pose: bool = False, file: str | Path | None = None,
                        on_step: Callable[[ActiveStep], None] | None = None
                        ) -> tuple[ActiveRun, dict[str, Path]]:
    """The closed loop with the simulated robot: ``structure`` stands on the table at
    ``pose``; the arm photographs it from ``start_angle``; while the estimate is not
    confident, the planner's chosen station and disassembly level are rendered and read
    like any photograph (nothing is read from the truth but the pictures; the truth
    only counts the errors).

    Parameters
    ----------
    stations : sequence of float, optional
        The arm's stations (default: the corpus's, 90°–210°).
    levels : sequence of int, optional
        Disassembly levels (default: every layer above the first).
    file : path, optional
        The structure's file, for messages.
    """
    from unseeable.corpus.build import DEFAULT_ANGLES
    from unseeable.domain.structure import Structure, grammar_violations
    from unseeable.pipeline import Observation
    from unseeable.render.settings import RenderSettings
    from unseeable.render.workspace import PendulumArm, Workspace

    if not isinstance(structure, Structure):
        raise InputError("must be a Structure", field="structure",
                         value=type(structure).__name__)
    broken = grammar_violations(structure)
    if broken:
        raise InputError(f"violates the grammar ({broken[0]})", file=file, field="logs",
                         value=f"{len(broken)} violation{'s' * (len(broken) > 1)}")
    stations = tuple(DEFAULT_ANGLES if stations is None else stations)
    ws = Workspace(structure, pose=pose, arm=PendulumArm(width=int(size[0]),
                                                         height=int(size[1])),
                   settings=RenderSettings(spp=spp), seed=seed)
    source = WorkspaceSource(ws, stations, levels=levels, known_pose=known_pose,
                             taken=[(float(start_angle), None)])
    first = ws.observe(float(start_angle))
    start = [Observation.of(first, use_recorded_pose=known_pose,
                            source=f"station {float(start_angle):g}°")]
    run = run_active(start, source, settings, max_actions=max_actions, truth=structure,
                     truth_pose=ws.pose, on_step=on_step)
    return run, write_active(run, out_dir, truth=structure, truth_pose=ws.pose)
