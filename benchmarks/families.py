"""The whole pipeline on held-out scene families: structure errors end to end.

The corpus (``unseeable experiment``) is 32 designed assemblies seen from the
workspace's arm by the renderer the detectors were calibrated on. This
benchmark runs the estimator (:func:`unseeable.pipeline.estimate_view`) as the experiments do
on scenes of the vision benchmark's families (``benchmarks/vision.py``'s
``FAMILIES``), none of which the calibration or any tuning saw:

* ``validation``: random valid structures and walled ones in the validation
  looks, from the workspace's arm;
* ``other-cameras`` / ``other-cameras-1024``: the same looks seen by cameras
  unlike the arm's (radius 650–1200 mm, elevation 28–60°, field of view
  35–60°; 640×480 and 1024×768);
* ``other-renderer``: the validation scenes drawn by the flat-shaded
  rasteriser (``unseeable.render.raster``);
* ``validation-halls``: big cabins with several rooms, doors and windows;
* ``held-out-looks``: the validation scenes (structures, arm, light; fixed seeds
  salted by the family's name) in looks drawn from ranges disjoint from every
  training and calibration look, never tuned on: dark red-brown wood (brightness
  0.3–0.55, redness 0.16–0.3; training 0.75–1.25 and ±0.08), grain and end-grain
  rings at 1.6–2.4 times their contrast (training 0–1), a table of weathered boards
  with open dark seams (``"planks"``, :data:`unseeable.render.textures.MORE_TABLE_KINDS`,
  in no training scene), exposure 1.35–1.7 (training 0.75–1.3) and JPEG quality
  40–74 (training 75–95);
* ``held-out-looks-2``: the same scenes in a second held-out look: pale, cool,
  grainless wood (brightness 1.5–1.8, redness −0.25 to −0.16; no training look is
  paler than 1.4 or cooler than −0.15) on white melamine, exposure 0.45–0.6
  (training 0.65 and up), JPEG quality 40–59 (training 60 and up);
* ``held-out-looks-3``: the same scenes in an evening room lit by tungsten lamps,
  photographed with a daylight white balance and out of focus: a key light at
  1900–2300 K (training 2700 K and up, ``train-wide``; 6500 K elsewhere), the room
  tinted warm (red gain 1.35–1.5, blue 0.5–0.65; training 0.7–1.3), defocus blur of
  2–3 px (training 1.5 px at most), on polished veined marble (``"stone"``, in no
  other family).
* ``defocus-dev``: the validation scenes defocused by 1.5–3 px and nothing else: the
  development family for out-of-focus photographs (looked at, unlike the held-out ones).

For each family it prints, with the pose known (the scene's placement, polished
on the image as the pipeline does) and with the pose estimated from the image:
mean errors (the paper's metric), the share within 12 and exact, the shipped
confidence's false positives (confident, not exact) and negatives (exact, not
confident; the confidence is the δ* test, the reading test and the doubts on
the pose, extent and evidence), wrong poses (more than 2 mm or 1° off,
a half turn being the same pose), refusals, and the mean with perfect
detectors on the visible features (``benchmarks/diagnose.py oracle``): how much of
the error no detector could remove. Renders are cached (the first run renders
them, a few seconds each).

Usage::

    python benchmarks/families.py --family other-cameras --scenes 60 [--workers 2]
    python benchmarks/families.py --family validation other-renderer --known-pose \
        --records records.json
    python benchmarks/families.py --family validation-halls --estimated-pose
    nice -n 10 python benchmarks/families.py --family held-out-looks --scenes 40 --workers 1

(``--known-pose`` and ``--estimated-pose`` run one of the two modes only.)
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np
from rich.progress import Progress

from unseeable.domain.geometry import LogGeometry
from unseeable.errors import UnseeableError
from unseeable.evaluate.metric import count_errors
from unseeable.fileio import write_json
from unseeable.grammar.priors import TIE_POLICY
from unseeable.parallel import run_in_processes
from unseeable.render.view import View
from unseeable.training.scenes import make_scene
from unseeable.visibility.geometry import log_cylinders
from unseeable.vision import pose_equivalent

sys.path.insert(0, str(Path(__file__).resolve().parent))
from corpus_views import run_pipeline  # noqa: E402  (the benchmarks' adapter to the estimator)
from diagnose import oracle_errors  # noqa: E402  (perfect detectors on visible features)

from vision import FAMILIES  # noqa: E402  (the vision benchmark's held-out families)


def assembly_in_frame(scene) -> bool:
    """Whether every log of the scene's structure projects inside its image: the ends of
    each log's bounding cylinder and the points a radius off them across and up."""
    axes = log_cylinders(scene.structure)  # (L, 2, 3), grid frame
    if not len(axes):
        return True
    along = axes[:, 1] - axes[:, 0]
    along /= np.linalg.norm(along, axis=1, keepdims=True)
    across = np.cross(along, [0.0, 1.0, 0.0])
    r = LogGeometry().l2 / 2
    offsets = [np.zeros_like(across), r * across, -r * across,
               np.broadcast_to([0.0, r, 0.0], across.shape),
               np.broadcast_to([0.0, -r, 0.0], across.shape)]
    points = np.concatenate([axes[:, end] + o for end in (0, 1) for o in offsets])
    uv = scene.camera.project(scene.pose.grid_to_world(points))  # NaN behind the camera
    return bool(np.all(scene.camera.in_image(uv)))


def scene_record(task: tuple[str, int, bool, bool, bool]) -> dict:
    """One scene estimated as ``unseeable experiment`` estimates a corpus view."""
    family, n, known_pose, shift, lines_once = task
    scene = make_scene(FAMILIES[family], n)
    view = View(scene.image, scene.camera, scene.extent,
                pose=scene.pose if known_pose else None)
    record = {"family": family, "scene": n, "known_pose": known_pose,
              "logs": len(scene.structure.logs), "in_frame": assembly_in_frame(scene)}
    try:
        est = run_pipeline(view, known_pose=known_pose, presence_shift=shift,
                           lines_once=lines_once)
    except UnseeableError as err:
        return {**record, "failed": str(err)}
    mm, deg = pose_equivalent(est.pose, scene.pose, scene.extent)
    return {**record, "failed": None,
            # A wrong pose whose grid does not line up: every log of both is an error, as
            # in unseeable experiment.
            "errors": count_errors(scene.structure, est.structure, truth_pose=scene.pose,
                                   estimate_pose=est.pose, on_misaligned="count"),
            "confident": bool(est.confident),
            "estimate_logs": len(est.structure.logs) if est.structure is not None else None,
            "presence_shift": est.presence_shift,
            "wrong_pose": bool(mm > 2.0 or deg > 1.0),
            "pose_error_mm": round(float(mm), 2), "pose_error_deg": round(float(deg), 3),
            "seconds": float(est.timings.get("total_s", np.nan))}


def summarise(records: list[dict]) -> str:
    """One line of figures for one family and mode."""
    ok = [r for r in records if r["failed"] is None]
    if not ok:
        return f"every scene refused (first: {records[0]['failed']})"
    e = np.array([r["errors"] for r in ok])
    exact = e == 0
    confident = np.array([r["confident"] for r in ok])
    oracle = np.array([r["oracle"] for r in records])
    worst = sorted(((r["errors"], r["scene"]) for r in ok), reverse=True)[:3]
    return (f"mean {e.mean():.2f} errors (perfect detectors {oracle.mean():.2f}), "
            f"{np.mean(e <= 12):.1%} within 12, {exact.mean():.1%} exact, "
            f"confidence FP {int(np.sum(confident & ~exact))} / FN "
            f"{int(np.sum(~confident & exact))}, "
            f"{sum(r['wrong_pose'] for r in ok)} wrong poses, "
            f"{len(records) - len(ok)} refused "
            f"({sum(r['failed'] is not None and r['in_frame'] for r in records)} with the "
            f"whole assembly in frame), "
            f"median {np.median([r['seconds'] for r in ok]):.2f} s; "
            f"worst scenes (errors, scene): {worst}")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--family", nargs="+", default=["validation"],
                        choices=sorted(FAMILIES), help="scene families")
    parser.add_argument("--scenes", type=int, default=60, help="scenes per family")
    only = parser.add_mutually_exclusive_group()
    only.add_argument("--known-pose", action="store_true",
                      help="only with the pose known (default: known and estimated)")
    only.add_argument("--estimated-pose", action="store_true",
                      help="only with the pose estimated")
    parser.add_argument("--no-presence-shift", action="store_true",
                        help="estimate without the presence shift of the detections "
                             "(the estimator's presence_shift off)")
    parser.add_argument("--no-lines-once", action="store_true",
                        help="count every segment detection on its own, even where several "
                             "features share an image line (the estimator's "
                             "lines_once off)")
    parser.add_argument("--workers", type=int, default=2, help="processes")
    parser.add_argument("--records", type=Path,
                        help="also write every scene's record to this JSON file")
    args = parser.parse_args(argv)
    if args.scenes < 1 or args.workers < 1:
        parser.error("--scenes and --workers must be at least 1")
    modes = [True] if args.known_pose else [False] if args.estimated_pose else [True, False]
    scenes = [(f, n) for f in args.family for n in range(args.scenes)]
    tasks = [(f, n, known, not args.no_presence_shift, not args.no_lines_once)
             for known in modes for f, n in scenes]
    results: dict[tuple[str, bool], list[dict]] = {}
    oracle: dict[tuple[str, int], int] = {}
    with Progress(transient=True) as progress:
        # Every scene rendered (or read) once first, so that no two workers render one;
        # its perfect-detector errors are the same in either mode, so they are taken here.
        bar = progress.add_task("rendering", total=len(scenes))
        for family, n, errors in run_in_processes(scene_oracle, scenes, workers=args.workers):
            oracle[(family, n)] = errors
            progress.advance(bar)
        bar = progress.add_task("estimating", total=len(tasks))
        for record in run_in_processes(scene_record, tasks, workers=args.workers):
            record["oracle"] = oracle[(record["family"], record["scene"])]
            results.setdefault((record["family"], record["known_pose"]), []).append(record)
            progress.advance(bar)
    if args.records is not None:
        write_json(args.records, [r for key in sorted(results) for r in
                                  sorted(results[key], key=lambda r: r["scene"])])
    for known in modes:
        for family in args.family:
            records = sorted(results[(family, known)], key=lambda r: r["scene"])
            mode = "pose known" if known else "pose estimated"
            print(f"{family} ({len(records)} scenes, {mode}): {summarise(records)}")
    return 0


def scene_oracle(item: tuple[str, int]) -> tuple[str, int, int]:
    """One scene rendered (or read from the cache), with its errors under perfect
    detectors on the visible features (``benchmarks/diagnose.py oracle``)."""
    family, n = item
    scene = make_scene(FAMILIES[family], n)
    return family, n, oracle_errors(scene.structure, scene.visible, scene.present > 0, 0.95,
                                    TIE_POLICY)


if __name__ == "__main__":
    raise SystemExit(main())
