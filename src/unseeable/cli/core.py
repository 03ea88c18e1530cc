"""Core commands: ``estimate`` and ``demo``."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import typer
from rich.console import Console

from unseeable.cli import app
from unseeable.cli.options import (
    ADVANCED,
    BACKEND,
    CALIBRATION,
    DELTA_STAR,
    JOINT_COST,
    PHOTOGRAPHS,
    PRIOR,
    READING_SHIFT,
    STACKED_JOINT_COST,
    THREADS,
    TIES,
    TIME_LIMIT,
    UNSUPPORTED_NOTCH_COST,
    flag,
    working,
)

console = Console(highlight=False, soft_wrap=True)


def describe_pose_choice(margin: float | None, ambiguous: bool, rival: dict | None) -> str:
    """How clearly the structure choice picked an estimated pose, for a summary line
    (empty when it had no rival); ``rival`` as :meth:`GridPose.to_json` gives it."""
    if margin is None:
        return ""
    text = f"chosen by a margin of {margin:.3f}"
    if ambiguous and rival is not None:
        text += (f", ambiguous with x={rival['x']:.1f} mm, z={rival['z']:.1f} mm, "
                 f"yaw={rival['yaw_deg']:.2f}°")
    return text


def print_estimate_summary(estimate, *, errors: int | None = None, truth_pose=None,
                           out_path: Path | None = None,
                           pictures=()) -> None:
    """A short human summary of an estimate (what was recovered, seen and unseen); with
    ``errors`` (against a truth) and ``truth_pose``, how far from it it is."""
    r = estimate.result
    if r.structure is None:
        console.print(f"status: {r.status.value} — no structure")
        return
    s = r.structure
    seen = estimate.logs_seen()
    counts = {m: sum(1 for log in s.logs if log.notches == m) for m in (1, 2, 3)}
    console.print(f"estimate: {len(s.logs)} logs on a {s.extent} grid "
                  f"({counts[1]}×1-notch, {counts[2]}×2-notch, {counts[3]}×3-notch), "
                  f"status {r.status.value}, log-probability {r.log_probability:.3f}")
    console.print(f"  seen: {int(seen.sum())} logs with direct evidence; "
                  f"unseen: {int((~seen).sum())} inferred by the grammar")
    view = estimate.views[0]
    report = view.pose_report
    if view.pose is not None:
        p = view.pose
        source = ""
        if report is not None and report.quality is not None:
            choice = describe_pose_choice(report.choice_margin, report.ambiguous,
                                          None if report.rival is None
                                          else report.rival.to_json())
            moved = "moved by the polish on its estimate" if report.moved_by_polish else ""
            source = (f" (from the image, fit quality {report.quality:.2f}"
                      + "".join(f"; {text}" for text in (choice, moved) if text) + ")")
        console.print(f"  pose: x={p.x:.1f} mm, z={p.z:.1f} mm, yaw={p.yaw_deg:.2f}°{source}")
    if view.visible is not None:
        console.print(f"  visibility: {int(view.visible.sum())} features visible, "
                      f"{estimate.iterations} estimates, "
                      + ("fixpoint" if estimate.converged
                         else f"cycle of length {estimate.cycle_length}"
                         if estimate.cycle_length
                         else "not settled (stopped at the cap on estimates or the time "
                              "budget; see --time-limit)"))
    shift = view.presence_shift
    if shift:  # (imported only then: an evidence file's estimate needs no ray casting)
        from unseeable.visibility.loop import PRESENCE_SHIFT_MIN
    if shift and abs(shift) >= PRESENCE_SHIFT_MIN:
        # A shift past the evidence doubt's bar is more likely a grid off the assembly
        # than the photograph's look (pipeline.PRESENCE_SHIFT_DOUBT).
        why = ("the image shows far more than the estimate builds: is the pose off?"
               if view.evidence_doubt
               else "the photograph's look calls presence "
                    f"{'less' if shift > 0 else 'more'} often than the calibration's")
        console.print(f"  detections: log-odds shifted by {shift:+.2f} to agree with the "
                      f"estimate, then estimated again ({why})")
    if view.features_outside_image:
        console.print(f"  outside the image: {view.features_outside_image} of the extent's "
                      f"{len(view.priors)} features (counted as unseen)")
    if len(estimate.views) > 1:
        for n, v in enumerate(estimate.views):
            what = [f"{int(np.count_nonzero(v.visible & (v.priors != 0.5)))} features judged "
                    "and visible"]
            if v.removed_from_layer is not None:
                what.append(f"after the arm removed layers {v.removed_from_layer} and up")
            if v.registration_margin is not None:
                what.append(f"orientation {v.orientation} by {v.registration_margin:.2f} nats")
            if n and v.pose_report is not None and v.pose_report.source == "shared":
                what.append(f"its edges move the shared pose {v.pose_offset[0]:.1f} mm, "
                            f"{v.pose_offset[1]:.2f}°"
                            + (": disagrees" if v.disagrees else ""))
            console.print(f"  view {n + 1} ({v.source}): " + "; ".join(what))
    c = estimate.confidence
    if c is not None:
        tol = "" if c.tolerance is None else f", tolerance δ = {c.tolerance:.3f}"
        why = ""
        if c.confident and not estimate.confident:
            why = ("; it builds nothing where the photograph shows an assembly: is the pose "
                   "off?" if estimate.builds_nothing
                   else "; a view disagrees with the shared pose"
                   if any(v.disagrees for v in estimate.views)
                   else "; a view's orientation was a near tie"
                   if any(v.registration_doubt for v in estimate.views)
                   else "; the pose choice was ambiguous" if view.pose_ambiguous
                   else "; the pose fits poorly" if view.pose_poor
                   else "; the detections show more than the estimate builds: is the pose "
                        "off?" if view.evidence_doubt
                   else "; the extent or the pose is in doubt")
        r = c.readings
        if r is not None and not r.confident:
            why = (f"; it passes δ* but rests on a few seen readings: a shift of {r.shift:g} "
                   "log-odds against them changes it")
        console.print(f"  confident: {'yes' if estimate.confident else 'no'} "
                      f"(δ* = {c.delta_star}{tol}, {c.occluded} occluded features{why})")
    if errors is not None:
        console.print(f"  errors against the truth: {errors}")
    if truth_pose is not None and view.pose is not None:
        from unseeable.vision import pose_equivalent

        mm, deg = pose_equivalent(view.pose, truth_pose, s.extent)
        console.print(f"  pose against the truth: {mm:.1f} mm, {deg:.2f}° off")
    total = estimate.timings.get("total_s")
    if total is not None:
        console.print(f"  time: {total:.2f} s")
    for pic in pictures:
        console.print(f"  picture: {pic}")
    if out_path is not None:
        console.print(f"  wrote {out_path}")


def _check_truth_extent(files: list[Path], truth_path: Path, truth_structure,
                        truth_pose) -> None:
    """An estimate from an evidence file has no pose: its truth is compared grid by grid,
    so a truth of another extent is refused before any work, naming the truth file."""
    from unseeable.domain import Extent
    from unseeable.domain.evidence import EVIDENCE_FORMAT
    from unseeable.errors import InputError
    from unseeable.fileio import read_json

    if len(files) != 1 or truth_pose is not None:
        return
    data = read_json(files[0])
    if not isinstance(data, dict) or data.get("format") != EVIDENCE_FORMAT:
        return
    try:
        extent = Extent.parse(data.get("extent"))
    except InputError:
        return  # the evidence file's own error comes with its estimate
    if truth_structure.extent != extent:
        raise InputError(f"is a {truth_structure.extent} grid, the evidence file's is "
                         f"{extent}: without a pose they are compared grid by grid",
                         file=truth_path, field="extent", value=str(truth_structure.extent))


def no_structure(estimate, settings) -> Exception:
    """The error of an estimate without a structure: the time limit ran out (exit code 3),
    or nothing satisfies the grammar and the constraints (exit code 1)."""
    from unseeable.cli import TimeLimitReached
    from unseeable.errors import SolverError
    from unseeable.solve.result import SolveStatus

    status = estimate.result.status
    if status == SolveStatus.INFEASIBLE:
        return SolverError("no structure satisfies the grammar and the constraints")
    return TimeLimitReached(f"no structure found within the time limit "
                            f"({settings.solver.time_limit:g} s per solve; raise --time-limit "
                            f"or give a smaller extent); solver status {status.value}")


@app.command()
def estimate(
    files: list[Path] = typer.Argument(
        ..., metavar="FILE", show_default=False,
        help="An evidence file, or view files of one assembly (first: reference)."),
    out: Path = typer.Option(..., "--out", metavar="DIR",
                             help="Folder for estimate.json and the pictures."),
    truth: Path = typer.Option(
        None, "--truth", metavar="FILE",
        help="A truth or structure file: count errors, draw truth.png."),
    time_limit: float = TIME_LIMIT,
    force_pose: bool = flag(
        False, "--force-pose/--no-force-pose", rich_help_panel=PHOTOGRAPHS, show_default=False,
        help="Use a refuted pose (not confident)."),
    independent_poses: bool = flag(
        False, "--independent-poses/--shared-pose", rich_help_panel=PHOTOGRAPHS,
        show_default=False, help="Several views: pose each alone, not jointly."),
    calibration: Path | None = CALIBRATION,
    threads: int = THREADS,
    prior: str = PRIOR,
    backend: str = BACKEND,
    delta_star: float = DELTA_STAR,
    reading_shift: float = READING_SHIFT,
    tolerance: bool = flag(True, "--tolerance/--no-tolerance", rich_help_panel=ADVANCED,
                           show_default=False,
                           help="Also find the tolerance δ (default: yes)."),
    ties: str | None = TIES,
    joint_cost: float | None = JOINT_COST,
    stacked_joint_cost: float | None = STACKED_JOINT_COST,
    unsupported_notch_cost: float | None = UNSUPPORTED_NOTCH_COST,
    say: list[str] = typer.Option(
        None, "--say", metavar="SENTENCE", show_default=False,
        help="What you know, e.g. \"window left of and perpendicular to door\" (nouns "
             "wall, window, door; left of, right of, perpendicular to, coplanar to; and): "
             "hard constraints. Repeatable."),
) -> None:
    """Estimate the structure (seen and unseen logs) and how sure the estimate is.

    Writes DIR/estimate.json, overlay.png and estimate.png (truth.png with --truth),
    all or nothing. Exit codes: 0 done, 1 an error (bad input, an output that cannot
    be written), 2 bad usage, 3 no structure found within the time limit.
    """
    from unseeable.fileio import output_folder
    from unseeable.pipeline import (
        EstimateSettings,
        errors_against_truth,
        estimate_files,
        write_estimate,
    )
    from unseeable.render.view import load_reference

    settings = EstimateSettings.from_options(
        prior=prior, backend=backend, time_limit=time_limit, strict=not force_pose,
        threads=threads, independent=independent_poses, calibration=calibration,
        delta_star=delta_star, tolerance=tolerance, ties=ties, joint_cost=joint_cost,
        stacked_joint_cost=stacked_joint_cost, unsupported_notch_cost=unsupported_notch_cost,
        reading_shift=reading_shift)
    if reading_shift == 0:
        settings = settings.replace(reading_shift=None)
    estimator = None
    if say:
        from unseeable.language import description_estimator

        estimator = description_estimator(say)  # a bad sentence is refused before any work
    with output_folder(out) as folder:
        truth_structure, truth_pose = (load_reference(truth) if truth is not None
                                       else (None, None))
        if truth_structure is not None:
            _check_truth_extent(files, truth, truth_structure, truth_pose)
        with working(f"estimating from {', '.join(f.name for f in files)}"):
            est, pictures = estimate_files(files, settings, out_dir=folder.path,
                                           truth=truth_structure, truth_pose=truth_pose,
                                           estimator=estimator)
        if est.structure is None:
            raise no_structure(est, settings)
        errors = (errors_against_truth(est, truth_structure, truth_pose=truth_pose)
                  if truth_structure is not None else None)
        path = write_estimate(est, folder.path)
    print_estimate_summary(est, errors=errors, truth_pose=truth_pose,
                           out_path=folder.final(path),
                           pictures=[folder.final(p) for p in pictures])


def _source_in_place(estimate_path: Path, folder) -> None:
    """Rewrite the view sources an estimate file records inside the temporary folder as
    where they will be once the folder is in place."""
    from unseeable.fileio import read_json, write_json

    data = read_json(estimate_path)
    for view in data.get("views", []):
        if isinstance(view.get("source"), str):
            view["source"] = str(folder.final(view["source"]))
    write_json(estimate_path, data, indent=1)


@app.command()
def demo(
    out: Path = typer.Option(Path("unseeable-demo"), "--out", metavar="DIR",
                             help="Folder for the view, the estimate and the pictures."),
    design: str = typer.Option("cabin-door", "--design", metavar="NAME",
                               help="Corpus design to build on the table (see `unseeable "
                                    "corpus list`)."),
    angle: float = typer.Option(150.0, "--angle", metavar="DEGREES",
                                help="Arm station to photograph from."),
    spp: int = typer.Option(16, "--spp", metavar="N", help="Render samples per pixel."),
    seed: int = typer.Option(0, "--seed", metavar="N", help="Render seed."),
    threads: int = THREADS,
    prior: str = PRIOR,
    backend: str = BACKEND,
) -> None:
    """Build a house in the simulated workspace, photograph it, and estimate it back.

    Writes the view, its truth, the estimate and its pictures into DIR, all or nothing.
    """
    from unseeable.corpus import load_design
    from unseeable.errors import InputError
    from unseeable.fileio import output_folder
    from unseeable.pipeline import EstimateSettings, run_demo
    from unseeable.render.settings import RenderSettings

    # Checked before the render: a bad value must not cost a render.
    settings = EstimateSettings.from_options(prior=prior, backend=backend, threads=threads)
    if not -360.0 <= angle <= 360.0:  # also refuses nan
        raise InputError("must be an angle in degrees from -360 to 360", field="--angle",
                         value=angle)
    if not 0 <= seed < 2**32:
        raise InputError("must be in 0..2**32-1", field="--seed", value=seed)
    RenderSettings(spp=spp)
    load_design(design)
    with output_folder(out) as folder:
        console.print(f"rendering '{design}' from the arm at {angle:g}° and estimating it ...")
        with working("rendering and estimating"):
            result = run_demo(folder.path, settings, design=design, angle=angle, spp=spp,
                              seed=seed)
        _source_in_place(result.files["estimate"], folder)
    est = result.estimate
    console.print(f"truth: {len(result.truth.logs)} logs; {result.pose_note}")
    print_estimate_summary(est, out_path=folder.final(result.files["estimate"]))
    console.print(f"  errors against the truth (paper's metric): {result.errors}")
    for name in ("view", "overlay", "rendering"):
        console.print(f"  {name}: {folder.final(result.files[name])}")
    if (folder.target / "truth.png").is_file():
        console.print(f"  against the truth: {folder.target / 'truth.png'}")
