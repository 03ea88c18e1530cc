"""The whole pipeline on a built-in house: :func:`run_demo`."""

from __future__ import annotations

import logging
import time
from dataclasses import dataclass, replace
from pathlib import Path

from unseeable.domain.structure import Structure
from unseeable.errors import VisionError
from unseeable.pipeline.core import estimate
from unseeable.pipeline.files import errors_against_truth, write_view_pictures
from unseeable.pipeline.observation import Observation
from unseeable.pipeline.record import Estimate, write_estimate
from unseeable.pipeline.settings import EstimateSettings

__all__ = ["run_demo", "DemoResult"]

logger = logging.getLogger(__name__)


@dataclass(frozen=True, eq=False)
class DemoResult:
    """What :func:`run_demo` made: the estimate, the truth and the files written."""

    estimate: Estimate
    truth: Structure
    errors: int | None
    pose_note: str
    files: dict


def run_demo(out_dir: str | Path, settings: EstimateSettings = EstimateSettings(), *,
             design: str = "cabin-door", angle: float = 150.0,
             size: tuple[int, int] = (640, 480), spp: int = 16, seed: int = 0
             ) -> DemoResult:
    """The whole pipeline on a built-in house: render one view, estimate, judge, draw.

    The assembly is a corpus design placed on the simulated table; the arm
    photographs it from ``angle``; the pose is found from the image (the
    recorded pose is used, and said so, only when the pose fit is poor); the
    structure, its visibility and its confidence are estimated; pictures and the
    estimate file are written to ``out_dir``.
    """
    from unseeable.corpus import load_design
    from unseeable.domain.io import save_structure
    from unseeable.render.settings import RenderSettings
    from unseeable.render.view import save_truth, save_view
    from unseeable.render.workspace import PendulumArm, Workspace

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
    source = str(out / "view.json")
    try:
        est = estimate([Observation.of(view, use_recorded_pose=False, source=source)],
                       settings)
        note = "pose estimated from the image"
    except VisionError as err:
        logger.warning("pose estimation failed (%s); using the recorded pose", err)
        est = estimate([Observation.of(view, source=source)], settings)
        note = f"pose estimation failed ({err}); used the recorded pose"
    est = replace(est, timings={**est.timings, "render_s": render_s})
    errors = errors_against_truth(est, entry.structure, truth_pose=entry.pose)
    files = {"view": out / "view.png", "estimate": write_estimate(est, out)}
    pics = write_view_pictures(est, view, out, truth=entry.structure, truth_pose=entry.pose)
    files.update({"overlay": pics[0], "rendering": pics[1]})
    return DemoResult(est, entry.structure, errors, note, files)
