"""Core commands: ``estimate`` and ``demo``."""

from __future__ import annotations

from pathlib import Path

import typer
from rich.console import Console

from unseeable.cli import app
from unseeable.cli.options import (
    CALIBRATION,
    JOINT_COST,
    STACKED_JOINT_COST,
    THREADS,
    TIES,
    UNSUPPORTED_NOTCH_COST,
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
    from unseeable.pipeline import log_support
    from unseeable.visibility.loop import PRESENCE_SHIFT_MIN

    r = estimate.result
    if r.structure is None:
        console.print(f"status: {r.status.value} — no structure")
        return
    s = r.structure
    seen = log_support(s, estimate.priors)
    counts = {m: sum(1 for log in s.logs if log.notches == m) for m in (1, 2, 3)}
    console.print(f"estimate: {len(s.logs)} logs on a {s.extent} grid "
                  f"({counts[1]}×1-notch, {counts[2]}×2-notch, {counts[3]}×3-notch), "
                  f"status {r.status.value}, log-probability {r.log_probability:.3f}")
    console.print(f"  seen: {int(seen.sum())} logs with direct evidence; "
                  f"unseen: {int((~seen).sum())} inferred by the grammar")
    if estimate.pose is not None:
        p = estimate.pose
        quality = estimate.extra.get("pose_quality")
        source = ""
        if quality is not None:
            choice = describe_pose_choice(estimate.extra.get("pose_choice_margin"),
                                          bool(estimate.extra.get("pose_ambiguous")),
                                          estimate.extra.get("pose_rival"))
            moved = ("moved by the polish on its estimate"
                     if estimate.extra.get("pose_moved_by_polish") else "")
            source = (f" (from the image, fit quality {quality:.2f}"
                      + "".join(f"; {text}" for text in (choice, moved) if text) + ")")
        console.print(f"  pose: x={p.x:.1f} mm, z={p.z:.1f} mm, yaw={p.yaw_deg:.2f}°{source}")
    if estimate.visible is not None:
        console.print(f"  visibility: {int(estimate.visible.sum())} features visible, "
                      f"{estimate.iterations} estimates, "
                      + ("fixpoint" if estimate.converged
                         else f"cycle of length {estimate.cycle_length}"
                         if estimate.cycle_length
                         else "not settled (stopped at the cap on estimates or the time "
                              "budget; see --time-limit)"))
    shift = estimate.extra.get("presence_shift")
    if shift is not None and abs(shift) >= PRESENCE_SHIFT_MIN:
        # A shift past the evidence doubt's bar is more likely a grid off the assembly
        # than the photograph's look (pipeline.PRESENCE_SHIFT_DOUBT).
        why = ("the image shows far more than the estimate builds: is the pose off?"
               if estimate.extra.get("evidence_doubt")
               else "the photograph's look calls presence "
                    f"{'less' if shift > 0 else 'more'} often than the calibration's")
        console.print(f"  detections: log-odds shifted by {shift:+.2f} to agree with the "
                      f"estimate, then estimated again ({why})")
    outside = estimate.extra.get("features_outside_image")
    if outside:
        console.print(f"  outside the image: {outside} of the extent's {len(estimate.priors)} "
                      "features (counted as unseen)")
    c = estimate.confidence
    if c is not None:
        tol = "" if c.tolerance is None else f", tolerance δ = {c.tolerance:.3f}"
        why = ""
        if c.confident and not estimate.confident:
            why = ("; the pose choice was ambiguous" if estimate.extra.get("pose_ambiguous")
                   else "; the detections show more than the estimate builds: is the pose "
                        "off?" if estimate.extra.get("evidence_doubt")
                   else "; the extent or the pose is in doubt")
        console.print(f"  confident: {'yes' if estimate.confident else 'no'} "
                      f"(δ* = {c.delta_star}{tol}, {c.occluded} occluded features{why})")
    if errors is not None:
        console.print(f"  errors against the truth: {errors}")
    if truth_pose is not None and estimate.pose is not None:
        from unseeable.vision import pose_equivalent

        mm, deg = pose_equivalent(estimate.pose, truth_pose, s.extent)
        console.print(f"  pose against the truth: {mm:.1f} mm, {deg:.2f}° off")
    total = estimate.timings.get("total_s")
    if total is not None:
        console.print(f"  time: {total:.2f} s")
    for pic in pictures:
        console.print(f"  picture: {pic}")
    if out_path is not None:
        console.print(f"  wrote {out_path}")


@app.command()
def estimate(
    file: Path = typer.Argument(..., help="An evidence file (unseeable/evidence@1) or a view "
                                "file (unseeable/view@1)."),
    out: Path = typer.Option(..., "--out", help="Folder for estimate.json and pictures."),
    backend: str = typer.Option("cpsat", help="MAP backend: cpsat, bnb or toulbar2."),
    truth: Path = typer.Option(
        None, help="The truth, to count errors and colour the picture: a structure file "
                   "(numbered as the view's pose numbers the grid) or the view's truth file "
                   "(unseeable/truth@1, with the true pose)."),
    delta_star: float = typer.Option(0.2, help="Tolerance threshold δ* of the confidence test."),
    tolerance: bool = typer.Option(True, help="Also binary-search the estimation tolerance δ."),
    time_limit: float = typer.Option(
        60.0, help="Seconds per solve; the visibility fixpoint starts no new estimate "
                   "after as many seconds."),
    force_pose: bool = typer.Option(
        False, "--force-pose",
        help="For a view without a pose: use the pose estimated from the image even when "
             "its fit is poor (its quality is in estimate.json); otherwise a poor fit is "
             "an error."),
    threads: int = THREADS,
    ties: str = TIES,
    joint_cost: float = JOINT_COST,
    stacked_joint_cost: float = STACKED_JOINT_COST,
    unsupported_notch_cost: float = UNSUPPORTED_NOTCH_COST,
    calibration: Path | None = CALIBRATION,
) -> None:
    """Estimate the structure (seen and unseen logs) and how sure the estimate is."""
    from unseeable.fileio import read_json
    from unseeable.pipeline import errors_against_truth, estimate_file, write_estimate
    from unseeable.render.view import load_reference

    data = read_json(file)
    truth_structure, truth_pose = load_reference(truth) if truth is not None else (None, None)
    est, pictures = estimate_file(file, data, out_dir=out, backend=backend,
                                  delta_star=delta_star, tolerance=tolerance,
                                  time_limit=time_limit, truth=truth_structure,
                                  truth_pose=truth_pose, strict_pose=not force_pose,
                                  threads=threads, ties=ties, calibration=calibration,
                                  joint_cost=joint_cost,
                                  stacked_joint_cost=stacked_joint_cost,
                                  unsupported_notch_cost=unsupported_notch_cost)
    # Counted before estimate.json is written: a truth that cannot be compared (an
    # evidence file's grid of another extent) leaves no estimate behind.
    errors = (errors_against_truth(est, truth_structure, truth_pose=truth_pose)
              if truth_structure is not None else None)
    path = write_estimate(est, out)
    print_estimate_summary(est, errors=errors, truth_pose=truth_pose, out_path=path,
                           pictures=pictures)


@app.command()
def demo(
    out: Path = typer.Option(Path("unseeable-demo"), "--out", help="Folder for the view, "
                             "the estimate and the pictures."),
    design: str = typer.Option("cabin-door", help="Corpus design to build on the table "
                               "(see `unseeable corpus list`)."),
    angle: float = typer.Option(150.0, help="Arm station (degrees) to photograph from."),
    spp: int = typer.Option(16, help="Render samples per pixel."),
    seed: int = typer.Option(0, help="Render seed."),
    threads: int = THREADS,
) -> None:
    """Build a house in the simulated workspace, photograph it, and estimate it back."""
    from unseeable.pipeline import run_demo

    console.print(f"rendering '{design}' from the arm at {angle:g}° and estimating it ...")
    result = run_demo(out, design=design, angle=angle, spp=spp, seed=seed, threads=threads)
    est = result.estimate
    console.print(f"truth: {len(result.truth.logs)} logs; {result.pose_note}")
    print_estimate_summary(est, out_path=result.files["estimate"])
    console.print(f"  errors against the truth (paper's metric): {result.errors}")
    for name in ("view", "overlay", "rendering"):
        console.print(f"  {name}: {result.files[name]}")
