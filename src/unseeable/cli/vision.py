"""Vision commands: ``unseeable detect``, ``unseeable pose``, ``unseeable calibrate``."""

from __future__ import annotations

from pathlib import Path

import typer

from unseeable.cli import app
from unseeable.cli.core import describe_pose_choice
from unseeable.cli.options import CALIBRATION, THREADS, bar_from_first_report, progress_bar
from unseeable.errors import InputError, check_whole_number, vision_errors_name

__all__ = ["detect_command", "pose_command", "calibrate_command"]


def _load_calibration(path: Path | None):
    from unseeable.vision.calibration import default_calibration, load_calibration

    return default_calibration() if path is None else load_calibration(path)


@app.command("detect")
def detect_command(
    view_file: Path = typer.Argument(..., help="View file (unseeable/view@1)."),
    out: Path = typer.Option(..., "--out", help="Output folder."),
    features: str = typer.Option(
        "visible", "--features",
        help="Features to judge: 'visible' (the paper's initial visibility estimate: the "
             "top and camera-facing faces of the extent's prism, without removed layers) "
             "or 'all'."),
    calibration: Path | None = CALIBRATION,
    refine: bool = typer.Option(True, "--refine/--no-refine",
                                help="Polish the pose on the image's edges first."),
    threads: int = THREADS,
) -> None:
    """Judge the features of one photograph: DIR/evidence.json and DIR/overlay.png.

    Uses the view's pose when it has one, else estimates it. Only the features
    the detectors judged appear in evidence.json (the others stay at 1/2).
    """
    from unseeable.domain import save_evidence
    from unseeable.render.view import load_view, write_image
    from unseeable.vision import detect_features, draw_detection, estimate_pose_by_structure

    if features not in ("visible", "all"):
        raise InputError("must be 'visible' or 'all'", field="--features", value=features)
    # Used only without a recorded pose, but a bad value is refused either way.
    check_whole_number(threads, field="threads", minimum=1)
    view = load_view(view_file)
    cal = _load_calibration(calibration)
    pose = view.pose
    estimated = pose is None
    if estimated:
        # Polished on the grid by detect_features, as for the calibration's training.
        with vision_errors_name(view_file):
            pose = estimate_pose_by_structure(view.image, view.camera, view.extent,
                                              calibration=cal, polish=False,
                                              threads=threads).pose
    mask = None
    if features == "visible":
        from unseeable.vision.evidence import initial_mask

        mask = initial_mask(view.extent, view.camera, pose,
                            removed_from_layer=view.removed_from_layer)
    det = detect_features(view.image, view.camera, pose, view.extent, mask=mask,
                          calibration=cal, refine=refine)
    out.mkdir(parents=True, exist_ok=True)
    save_evidence(det.evidence, out / "evidence.json")
    write_image(out / "overlay.png", draw_detection(view.image, view.camera, det))
    n = int(det.judged.sum())
    present = int((det.p[det.judged] > 0.5).sum())
    source = "estimated" if estimated else "given"
    typer.echo(f"judged {n} features ({present} likely present) with the {source} pose; "
               f"wrote {out / 'evidence.json'} and {out / 'overlay.png'}")


@app.command("pose")
def pose_command(
    view_file: Path = typer.Argument(..., help="View file (unseeable/view@1); its pose, if "
                                               "any, is ignored."),
    out: Path = typer.Option(..., "--out", help="Output folder."),
    force: bool = typer.Option(False, "--force",
                               help="Write the pose even when the fit is poor."),
    edges_only: bool = typer.Option(
        False, "--edges-only",
        help="Keep the edge-best pose instead of choosing among its near-symmetric "
             "aliases by the structure the detections imply (and polishing the choice "
             "on that structure's edges)."),
    threads: int = THREADS,
    calibration: Path | None = CALIBRATION,
) -> None:
    """Estimate the assembly's pose from the image: DIR/pose.json and DIR/overlay.png."""
    from unseeable.fileio import write_json
    from unseeable.render.view import load_view, write_image
    from unseeable.vision import draw_pose, estimate_pose, estimate_pose_by_structure

    cal = _load_calibration(calibration)
    view = load_view(view_file)
    with vision_errors_name(view_file):
        if edges_only:
            fit = estimate_pose(view.image, view.camera, view.extent, strict=not force,
                                threads=threads, quality_model=cal.pose_quality)
        else:
            fit = estimate_pose_by_structure(view.image, view.camera, view.extent,
                                             calibration=cal, strict=not force,
                                             threads=threads)
    out.mkdir(parents=True, exist_ok=True)
    write_json(out / "pose.json", fit.to_json())
    write_image(out / "overlay.png", draw_pose(view.image, view.camera, view.extent, fit.pose))
    p = fit.pose
    choice = describe_pose_choice(fit.choice_margin, fit.ambiguous,
                                  None if fit.choice_rival is None else fit.choice_rival.to_json())
    typer.echo(f"pose x={p.x:.1f} mm z={p.z:.1f} mm yaw={p.yaw_deg:.2f} deg "
               f"(quality {fit.quality:.2f}{', ' + choice if choice else ''}); "
               f"wrote {out / 'pose.json'}")


@app.command("calibrate")
def calibrate_command(
    scenes: int = typer.Option(600, "--scenes", help="Number of random training scenes."),
    walls: int = typer.Option(150, "--walls",
                              help="Number of walled training scenes (cabins, walls, "
                                   "partitions) added to them."),
    tall: int = typer.Option(400, "--tall",
                             help="Number of tall and large training scenes (towers, screen "
                                  "walls, big cabins) added as well."),
    looks: int = typer.Option(150, "--looks",
                              help="Number of training scenes with hard shadows and plain "
                                   "logs added too."),
    halls: int = typer.Option(0, "--halls",
                              help="Number of big cabins with several rooms, doors and "
                                   "windows added too."),
    out: Path = typer.Option(..., "--out", help="Calibration file to write."),
    cache: Path | None = typer.Option(
        None, "--cache", help="Render cache folder (default $UNSEEABLE_CACHE or "
                              "~/.cache/unseeable)."),
    start: int = typer.Option(0, "--start", help="Index of the first training scene."),
    members: int = typer.Option(5, "--members",
                                help="Networks per detector model, fitted from different "
                                     "initial weights and averaged."),
    workers: int = typer.Option(2, "--workers",
                                help="Processes judging the scenes and fitting the networks."),
    resume: bool = typer.Option(False, "--resume",
                                help="Take up a run with the same options that stopped: "
                                     "its first stage (about half the time) from the "
                                     "checkpoint OUT.stage1, and the scenes it had judged "
                                     "and networks it had fitted from OUT.stage1.scenes. "
                                     "Not after changing the detectors' code."),
) -> None:
    """Refit the detectors' score-to-probability calibration on rendered training scenes.

    Training scenes (random valid structures and random walled ones — cabins,
    walls, partitions, towers, big cabins with several rooms — with random
    poses, lighting, materials and JPEG compression, some with hard shadows
    and plain logs) are rendered once and cached; the benchmark's validation
    scenes and the evaluation corpus are never used. Each detector model is
    an average of --members networks. The first stage's models are kept in
    OUT.stage1, and every scene judged and network fitted in OUT.stage1.scenes,
    until the run is done (see --resume).
    """
    from rich.progress import BarColumn, TextColumn, TimeElapsedColumn

    from unseeable.vision.calibration import save_calibration
    from unseeable.vision.scenes import default_cache_dir
    from unseeable.vision.training import calibrate

    for field, value, minimum in (("--scenes", scenes, 1), ("--start", start, 0),
                                  ("--walls", walls, 0), ("--tall", tall, 0),
                                  ("--looks", looks, 0), ("--halls", halls, 0),
                                  ("--members", members, 1),
                                  ("--workers", workers, 1)):
        check_whole_number(value, field=field, minimum=minimum)
    folder = cache / "vision" if cache is not None else default_cache_dir()
    checkpoint = out.with_name(out.name + ".stage1")
    bar = progress_bar(TextColumn("scenes"), BarColumn(),
                       TextColumn("{task.completed}/{task.total}"), TimeElapsedColumn())
    with bar_from_first_report(bar, total=2 * (scenes + walls + tall + looks + halls)) as update:
        cal = calibrate(scenes, walls=walls, tall=tall, looks=looks, halls=halls, start=start,
                        cache=folder, workers=workers, members=members,
                        checkpoint=checkpoint, resume=resume,
                        progress=lambda done, total: update(completed=done, total=total))
    save_calibration(cal, out)
    acc = ", ".join(f"{g} {cal.info.get(f'{g}_train_accuracy', 0):.3f}"
                    for g in ("end", "short", "long"))
    refused = cal.info.get("pose_refused_scenes", 0)
    refused_text = (f"; {refused} scene(s) the pose estimator refused, left out of the pose "
                    "quality" if refused else "")
    typer.echo(f"calibrated on {scenes} + {walls} walled + {tall} tall + {looks} other-look "
               f"+ {halls} hall scenes "
               f"(training accuracy: {acc}{refused_text}); "
               f"wrote {out}")


@app.command("merge-calibrations")
def merge_calibrations_command(
    files: list[Path] = typer.Argument(..., help="Two or more calibration files "
                                                 "(unseeable/vision-calibration@1)."),
    out: Path = typer.Option(..., "--out", help="Calibration file to write."),
) -> None:
    """Average calibrations fitted on different training scenes as one.

    Every detector model of the file written is the ensemble of all the
    files' networks, their logits averaged; the pose-quality model is the
    first file's. This is how the shipped calibration was made (docs/results.md,
    "Fortieth session").
    """
    from unseeable.vision.calibration import (
        load_calibration,
        merge_calibrations,
        save_calibration,
    )

    if len(files) < 2:
        raise InputError("give two or more calibration files", field="FILES",
                         value=[str(f) for f in files])
    cals = [load_calibration(f) for f in files]
    merged = merge_calibrations(cals, names=[str(f) for f in files])
    save_calibration(merged, out)
    typer.echo(f"merged {len(cals)} calibrations ({merged.info['members']} networks per "
               f"model); wrote {out}")
