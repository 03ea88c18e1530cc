"""``unseeable active``: take views or disassemblies until the estimate is sure; and
``unseeable experiment active``, the paper's protocol on a corpus."""

from __future__ import annotations

from pathlib import Path

import typer

from unseeable.cli import app
from unseeable.cli.experiment import (
    console,
    evaluation_settings,
    experiment_app,
    experiment_progress,
    results_folder,
    structure_names,
)
from unseeable.cli.options import (
    BACKEND,
    CALIBRATION,
    PHOTOGRAPHS,
    PRIOR,
    SCHEDULER,
    THREADS,
    TIME_LIMIT,
    flag,
    open_scheduler,
    working,
)
from unseeable.errors import InputError


def _stations(text: str | None) -> list[float] | None:
    if text is None:
        return None
    try:
        angles = [float(a) for a in text.split(",") if a.strip()]
    except ValueError:
        raise InputError("must be angles in degrees separated by commas", field="--stations",
                         value=text) from None
    if not angles or not all(-360.0 <= a <= 360.0 for a in angles):
        raise InputError("must be angles in degrees from -360 to 360, separated by commas",
                         field="--stations", value=text)
    return angles


def _print_run(run, files: dict, folder) -> None:
    from rich.console import Console
    from rich.table import Table

    table = Table(title=f"Active vision: stopped, {run.stopped}")
    for column in ("step", "action", "logs", "errors", "confident", "δ′ of the action",
                   "re-solves"):
        table.add_column(column)
    for n, step in enumerate(run.steps):
        plan = run.steps[n - 1].plan if n else None
        chosen = plan.candidates[plan.chosen] if plan is not None else None
        delta = ("" if chosen is None else f"{chosen.low:.3f}" if chosen.high - chosen.low
                 < 1e-9 else f"{chosen.low:.3f}–{chosen.high:.3f}")
        s = step.estimate.structure
        table.add_row(str(step.number), "start" if step.action is None else step.action.name,
                      str(len(s.logs)) if s is not None else "-",
                      "" if step.errors is None else str(step.errors),
                      "yes" if step.confident else "no", delta,
                      "" if plan is None else str(plan.solves))
    console = Console()
    console.print(table)
    for what, path in files.items():
        console.print(f"{what}: {folder.final(path)}")


@app.command()
def active(
    views: list[Path] = typer.Argument(
        None, metavar="VIEW", show_default=False,
        help="View files to start from (first: reference); not with --workspace."),
    candidates: list[Path] = typer.Option(
        None, "--candidates", metavar="VIEW", show_default=False,
        help="Candidate view files (their cameras and removed_from_layer plan the choice; "
             "an image is read only once chosen). Repeatable."),
    workspace: Path = typer.Option(
        None, "--workspace", metavar="STRUCTURE", show_default=False,
        help="A structure file: stand it on the simulated table and let the robot take "
             "the views and disassemblies."),
    out: Path = typer.Option(..., "--out", metavar="DIR",
                             help="Folder for estimate.json, active.json and strip.png."),
    max_actions: int = typer.Option(10, "--max-actions", metavar="N",
                                    help="Actions at most."),
    start_angle: float = typer.Option(150.0, "--start-angle", metavar="DEGREES",
                                      help="Workspace: the first photograph's station."),
    stations: str = typer.Option(None, "--stations", metavar="A,B,...", show_default=False,
                                 help="Workspace: the arm's stations (default 90,120,150,"
                                      "180,210)."),
    disassembly: bool = flag(True, "--disassembly/--views-only",
                             help="Workspace: may the arm remove layers (default: yes)."),
    known_pose: bool = flag(False, "--known-pose/--estimate-pose", rich_help_panel=PHOTOGRAPHS,
                            help="Workspace: give the estimator the table's pose (default: "
                                 "found from the first photograph)."),
    spp: int = typer.Option(16, "--spp", metavar="N", help="Workspace: samples per pixel."),
    seed: int = typer.Option(0, "--seed", metavar="N", help="Workspace: render seed."),
    truth: Path = typer.Option(
        None, "--truth", metavar="FILE",
        help="A truth or structure file: count each step's errors and draw the strip "
             "green/red (never used to plan)."),
    time_limit: float = TIME_LIMIT,
    calibration: Path | None = CALIBRATION,
    threads: int = THREADS,
    prior: str = PRIOR,
    backend: str = BACKEND,
) -> None:
    """Estimate, and while not confident take the view or disassembly with the smallest
    δ′ (the least imagined evidence that would change the estimate), until sure.

    Either start from VIEW files and choose among --candidates, or give --workspace to
    run the simulated robot. Writes DIR/estimate.json (the final estimate), active.json
    (every step: candidates with their δ′ bounds, the action chosen, errors, confidence,
    time) and strip.png, all or nothing.
    """
    from unseeable.active import active_from_files, active_in_workspace
    from unseeable.domain.io import load_structure
    from unseeable.fileio import output_folder
    from unseeable.pipeline import EstimateSettings
    from unseeable.render.view import load_reference

    if workspace is not None and (views or candidates):
        raise InputError("give either --workspace or VIEW files with --candidates, not both",
                         field="--workspace", value=str(workspace))
    if workspace is None and not views:
        raise InputError("give VIEW files to start from (or --workspace)", field="VIEW",
                         value=0)
    if workspace is None and not candidates:
        raise InputError("give the candidate views to choose from", field="--candidates",
                         value=0)
    if isinstance(max_actions, int) and max_actions < 0:
        raise InputError("must be >= 0", field="--max-actions", value=max_actions)
    if not -360.0 <= start_angle <= 360.0:
        raise InputError("must be an angle in degrees from -360 to 360", field="--start-angle",
                         value=start_angle)
    angles = _stations(stations)
    settings = EstimateSettings.from_options(prior=prior, backend=backend,
                                             time_limit=time_limit, threads=threads,
                                             calibration=calibration)
    truth_structure, truth_pose = (load_reference(truth) if truth is not None
                                   else (None, None))
    if workspace is not None:
        structure = load_structure(workspace)
    with output_folder(out) as folder:
        if workspace is not None:
            with working(f"the robot at work on {workspace.name}"):
                run, files = active_in_workspace(
                    structure, folder.path, settings, start_angle=start_angle,
                    stations=angles, levels=None if disassembly else (),
                    max_actions=max_actions, spp=spp, seed=seed, known_pose=known_pose,
                    file=workspace)
        else:
            with working(f"active vision from {', '.join(v.name for v in views)}"):
                run, files = active_from_files(views, candidates, folder.path, settings,
                                               max_actions=max_actions,
                                               truth=truth_structure, truth_pose=truth_pose)
    _print_run(run, files, folder)


@experiment_app.command("active")
def experiment_active(
    corpus: Path = typer.Option(..., "--corpus",
                                help="A corpus folder made by `unseeable corpus build`."),
    out: Path = typer.Option(None, "--out", metavar="DIR",
                             help="Results folder (default: CORPUS/results)."),
    known_pose: bool = flag(False, "--known-pose", help="Use the views' recorded poses "
                            "instead of estimating them from the images."),
    workers: int = typer.Option(2, "--workers", help="Images evaluated in parallel."),
    scheduler: str | None = SCHEDULER,
    only: str = typer.Option(None, "--only", help="Comma-separated structure names."),
    starts: int | None = typer.Option(
        None, "--starts", help="Starting stations per structure (a seeded choice; default "
                               "every one)."),
    max_actions: int = typer.Option(5, "--max-actions", metavar="N",
                                    help="Actions at most per process."),
    robot: bool = flag(True, "--robot/--no-robot",
                       help="Also run the simulated robot's closed loop on every structure "
                            "(default: yes)."),
    robot_start: float = typer.Option(150.0, "--robot-start", metavar="DEGREES",
                                      help="The robot's first station."),
    prior: str = PRIOR, backend: str = BACKEND) -> None:
    """Active vision (Figs. active and results): from each starting image, take other
    views, disassemblies, or both by the smallest δ′ until confident; errors at
    termination against the single-view baseline, and the robot's closed loop (PNG + JSON).
    """
    from unseeable.evaluate.active import PROCESSES, active_experiment, evaluate_active

    if isinstance(max_actions, int) and max_actions < 0:
        raise InputError("must be >= 0", field="--max-actions", value=max_actions)
    out = results_folder(corpus, out)
    settings = evaluation_settings(known_pose=known_pose, prior=prior, backend=backend)
    with open_scheduler(scheduler, workers=workers) as executor, \
            experiment_progress("starting images, robot runs") as progress:
        records, robots = evaluate_active(
            corpus, out, settings=settings, workers=workers, executor=executor,
            only=structure_names(only), starts=starts, max_actions=max_actions, robot=robot,
            robot_start=robot_start, progress=progress)
    table = active_experiment(records, robots, out)
    console.print(f"starting images: {table['images']} of {table['structures']} structures"
                  + (f" ({len(table['failed'])} failed)" if table["failed"] else ""))
    console.print("mean errors at termination: " + ", ".join(
        f"{k} {table['mean_errors'][k]:.2f} (max {table['max_errors'][k]}, confident and "
        f"wrong {table['confident_wrong'][k]})" for k in ("baseline", *PROCESSES)))
    console.print("actions per image: " + ", ".join(
        f"{p} {table['actions_per_image'][p]:.2f}" for p in PROCESSES))
    console.print(f"combined: {table['combined_structures_within_2']} of {table['structures']}"
                  " structures within 2 errors from every start")
    r = table.get("robot")
    if r:
        console.print(f"robot: {r['confident']} of {r['structures']} structures confident "
                      f"({r['confident_wrong']} wrong); mean errors {r['mean_errors_start']:.2f}"
                      f" → {r['mean_errors_end']:.2f} in {r['mean_actions']:.2f} actions")
    console.print(f"wrote {out / 'active.json'}, {out / 'active.png'}"
                  + (f" and {out / 'results.png'}" if "results_figure" in table else ""))
