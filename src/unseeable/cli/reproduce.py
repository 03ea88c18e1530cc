"""``unseeable reproduce``: the paper's experiments in one run, as a report."""

from __future__ import annotations

from pathlib import Path

import typer
from rich.console import Console

from unseeable.cli import app
from unseeable.cli.options import SCHEDULER, flag, progress_bar

console = Console(highlight=False, soft_wrap=True)


@app.command()
def reproduce(
    out: Path = typer.Option(..., "--out", metavar="DIR",
                             help="Report folder: report.md, report.html, report.json, "
                                  "figures/ and showcase/, written whole at the end."),
    quick: bool = flag(False, "--quick",
                       help="A small subset in minutes: designs cabin-door and "
                            "cabin-door-L3 at 120°, 150°, 180°, 320x240 at 8 samples per "
                            "pixel, one start per structure, at most 2 actions."),
    corpus: Path = typer.Option(None, "--corpus", metavar="DIR", show_default=False,
                                help="Corpus folder, a cache (default DIR/corpus, "
                                     "DIR/corpus-quick with --quick); one already there "
                                     "must have the run's render settings."),
    workers: int = typer.Option(2, "--workers", help="Local processes running the jobs."),
    scheduler: str | None = SCHEDULER,
    publish: Path = typer.Option(None, "--publish", metavar="FILE", show_default=False,
                                 help="Also write the report as one Markdown file for a "
                                      "repository's docs (e.g. docs/results.md), its "
                                      "figures as JPEGs in images/results/ beside it."),
    report_only: bool = flag(False, "--report-only",
                             help="Run nothing: write the report of the run already in "
                                  "--out again (and --publish it), from its report.json."),
) -> None:
    """Build the corpus and run every experiment of the paper (visibility, confidence,
    several views, active vision and the robot, language), then write a report that sets
    each table and figure beside the paper's number, with the settings, code version,
    machine and each stage's time.

    The corpus and the experiments' records (CORPUS/results, those of the experiment
    commands) are caches: a rerun computes only what is missing.
    """
    from rich.progress import BarColumn, MofNCompleteColumn, TextColumn, TimeElapsedColumn

    from unseeable.errors import InputError
    from unseeable.evaluate import reproduce as module
    from unseeable.report.paper import publish_report

    # Checked before the run, which takes many minutes.
    if publish is not None and (publish.is_dir() or not publish.parent.is_dir()):
        raise InputError("must be a file in an existing folder", field="--publish",
                         value=str(publish))
    if report_only:
        from unseeable.report.paper import write_report

        done = module.load_reproduction(out)
        write_report(done, out)
        console.print(f"wrote {done.files['markdown']} and {done.files['html']}")
        if publish is not None:
            console.print(f"wrote {publish_report(done, publish)}")
        return
    settings = module.QUICK if quick else module.FULL
    bar = progress_bar(TextColumn("{task.description:<34}"), BarColumn(),
                       MofNCompleteColumn(), TimeElapsedColumn(), transient=False)
    tasks: dict[str, int] = {}

    def update(stage: str, done: int, total: int) -> None:
        if not tasks:
            bar.start()
        if stage not in tasks:
            for task in tasks.values():  # a new stage: the others are done
                bar.stop_task(task)
            tasks[stage] = bar.add_task(module.STAGES.get(stage, stage), total=total)
        bar.update(tasks[stage], completed=done, total=total)

    try:
        run = module.reproduce(out, settings=settings, corpus=corpus, workers=workers,
                               scheduler=scheduler, progress=update)
    finally:
        if tasks:
            bar.stop()
    for stage in run.stages:
        console.print(f"{stage.title}: {stage.seconds:.1f} s"
                      + (f" ({stage.note})" if stage.note else ""))
    console.print(f"total: {run.seconds:.1f} s on {run.executor}")
    console.print(f"wrote {run.files['markdown']} and {run.files['html']}")
    if publish is not None:
        console.print(f"wrote {publish_report(run, publish)}")
