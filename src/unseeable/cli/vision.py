"""Vision commands: ``unseeable detect``, ``unseeable pose``, ``unseeable calibrate``."""

from __future__ import annotations

from pathlib import Path

import typer

from unseeable.cli import app
from unseeable.cli.core import describe_pose_choice
from unseeable.cli.options import (
    CALIBRATION,
    THREADS,
    bar_from_first_report,
    flag,
    open_scheduler,
    progress_bar,
    working,
)
from unseeable.errors import InputError, check_whole_number, vision_errors_name

__all__ = ["detect_command", "pose_command", "calibrate_command"]


@app.command("detect")
def detect_command(
    view_file: Path = typer.Argument(..., help="View file (unseeable/view@1)."),
    out: Path = typer.Option(..., "--out", metavar="DIR", help="Output folder."),
    features: str = typer.Option(
        "visible", "--features",
        help="Features to judge: 'visible' (the paper's initial visibility estimate: the "
             "top and camera-facing faces of the extent's prism, without removed layers) "
             "or 'all'."),
    calibration: Path | None = CALIBRATION,
    refine: bool = flag(True, "--refine/--no-refine",
                        help="Polish a recorded pose on the image's edges first."),
    threads: int = THREADS,
    force: bool = flag(False, "--force/--no-force",
                       help="Use an estimated pose even where the image shows wood well "
                            "outside the extent's box."),
) -> None:
    """Judge the features of one photograph: DIR/evidence.json and DIR/overlay.png.

    Uses the view's pose when it has one, else finds it as `unseeable estimate` does.
    Only the features the detectors judged appear in evidence.json (the others stay
    at 1/2). Both files are written, or neither.
    """
    from unseeable.domain import save_evidence
    from unseeable.fileio import output_folder
    from unseeable.pipeline import EstimateSettings, Observation, find_pose
    from unseeable.pipeline.files import check_in_image, check_view
    from unseeable.render.view import load_view, write_image
    from unseeable.vision import detect_features, draw_detection

    if features not in ("visible", "all"):
        raise InputError("must be 'visible' or 'all'", field="--features", value=features)
    settings = EstimateSettings.from_options(threads=threads, calibration=calibration,
                                             refine=refine, strict=not force)
    with output_folder(out) as folder:
        view = load_view(view_file)
        check_view(view, file=view_file)
        pose = view.pose
        estimated = pose is None
        if estimated:
            with vision_errors_name(view_file), working("finding the pose"):
                pose = find_pose(Observation.of(view, source=view_file), settings).pose
            check_in_image(view.extent, pose, view.camera, file=view_file,
                           what="the pose estimated from the image puts")
        mask = None
        if features == "visible":
            from unseeable.vision.evidence import initial_mask

            mask = initial_mask(view.extent, view.camera, pose,
                                removed_from_layer=view.removed_from_layer)
        # An estimated pose is aligned on the image's edges already.
        det = detect_features(view.image, view.camera, pose, view.extent, mask=mask,
                              calibration=settings.detection.loaded_calibration(),
                              refine=refine and not estimated)
        save_evidence(det.evidence, folder.path / "evidence.json")
        write_image(folder.path / "overlay.png", draw_detection(view.image, view.camera, det))
    n = int(det.judged.sum())
    present = int((det.p[det.judged] > 0.5).sum())
    source = "estimated" if estimated else "given"
    typer.echo(f"judged {n} features ({present} likely present) with the {source} pose; "
               f"wrote {out / 'evidence.json'} and {out / 'overlay.png'}")


@app.command("pose")
def pose_command(
    view_file: Path = typer.Argument(..., help="View file (unseeable/view@1); its pose, if "
                                               "any, is ignored."),
    out: Path = typer.Option(..., "--out", metavar="DIR", help="Output folder."),
    force: bool = flag(False, "--force/--no-force",
                       help="Write the pose even where the image shows wood well outside "
                            "the extent's box."),
    threads: int = THREADS,
    calibration: Path | None = CALIBRATION,
) -> None:
    """Find the assembly's pose from the image, as `unseeable estimate` does:
    DIR/pose.json and DIR/overlay.png (both, or neither)."""
    from unseeable.fileio import output_folder, write_json
    from unseeable.pipeline import EstimateSettings, Observation, find_pose
    from unseeable.pipeline.files import check_camera, check_extent_size, check_in_image
    from unseeable.render.view import load_view, write_image
    from unseeable.vision import draw_pose

    settings = EstimateSettings.from_options(threads=threads, calibration=calibration,
                                             strict=not force)
    with output_folder(out) as folder:
        view = load_view(view_file)
        check_extent_size(view.extent, file=view_file)
        check_camera(view.camera, file=view_file)  # its recorded pose is not used
        with vision_errors_name(view_file), working("finding the pose"):
            finding = find_pose(Observation.of(view, use_recorded_pose=False,
                                               source=view_file), settings)
        p = finding.pose
        check_in_image(view.extent, p, view.camera, file=view_file,
                       what="the pose estimated from the image puts")
        write_json(folder.path / "pose.json", {**p.to_json(), **finding.report.to_json()})
        write_image(folder.path / "overlay.png",
                    draw_pose(view.image, view.camera, view.extent, p))
    r = finding.report
    choice = describe_pose_choice(r.choice_margin, r.ambiguous,
                                  None if r.rival is None else r.rival.to_json())
    typer.echo(f"pose x={p.x:.1f} mm z={p.z:.1f} mm yaw={p.yaw_deg:.2f} deg "
               f"(quality {r.quality:.2f}{', ' + choice if choice else ''}); "
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
    out: Path = typer.Option(..., "--out", metavar="FILE", help="Calibration file to write."),
    cache: Path | None = typer.Option(
        None, "--cache", help="Render cache folder (default $UNSEEABLE_CACHE or "
                              "~/.cache/unseeable)."),
    start: int = typer.Option(0, "--start", help="Index of the first training scene."),
    members: int = typer.Option(5, "--members",
                                help="Networks per detector model, fitted from different "
                                     "initial weights and averaged."),
    workers: int = typer.Option(2, "--workers",
                                help="Processes judging the scenes and fitting the networks."),
    scheduler: str | None = typer.Option(
        None, "--scheduler", metavar="SPEC", show_default=False,
        help="Judge the scenes on a Dask cluster: tcp://HOST:PORT (a running scheduler) or "
             "local:N (a LocalCluster of N workers started here); the networks are fitted "
             "in --workers local processes. Same calibration."),
    resume: bool = flag(False, "--resume",
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

    from unseeable.fileio import check_output_file, check_output_folder
    from unseeable.training import calibrate, default_cache_dir
    from unseeable.vision.calibration import save_calibration

    check_output_file(out)
    if cache is not None:
        check_output_folder(cache, field="--cache")
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
    with open_scheduler(scheduler, workers=workers) as executor, \
            bar_from_first_report(bar, total=2 * (scenes + walls + tall + looks + halls)
                                  ) as update:
        cal = calibrate(scenes, walls=walls, tall=tall, looks=looks, halls=halls, start=start,
                        cache=folder, workers=workers, executor=executor, members=members,
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
    out: Path = typer.Option(..., "--out", metavar="FILE", help="Calibration file to write."),
) -> None:
    """Average calibrations fitted on different training scenes as one.

    Every detector model of the file written is the ensemble of all the
    files' networks, their logits averaged; the pose-quality model is the
    first file's. The shipped calibration is such a merge (docs/decisions.md).
    """
    from unseeable.fileio import check_output_file
    from unseeable.vision.calibration import (
        load_calibration,
        merge_calibrations,
        save_calibration,
    )

    if len(files) < 2:
        raise InputError("give two or more calibration files", field="FILES",
                         value=[str(f) for f in files])
    check_output_file(out)
    cals = [load_calibration(f) for f in files]
    merged = merge_calibrations(cals, names=[str(f) for f in files])
    save_calibration(merged, out)
    typer.echo(f"merged {len(cals)} calibrations ({merged.info['members']} networks per "
               f"model); wrote {out}")
