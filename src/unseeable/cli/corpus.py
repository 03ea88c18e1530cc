"""Commands of the evaluation corpus: ``unseeable corpus list`` and ``unseeable corpus build``."""

from __future__ import annotations

from pathlib import Path

import typer

from unseeable.cli import app
from unseeable.cli.options import (
    SCHEDULER,
    bar_from_first_report,
    flag,
    open_scheduler,
    parse_angles,
    parse_size,
    progress_bar,
)

__all__ = ["corpus_app"]

corpus_app = typer.Typer(help="The evaluation corpus: 32 designed structures and their views.",
                         no_args_is_help=True)
app.add_typer(corpus_app, name="corpus")


@corpus_app.command("list")
def list_command() -> None:
    """List the designed structures: name, extent, logs, subset relations, description."""
    from unseeable.corpus import list_designs

    for e in list_designs():
        related = f" ⊂ {', '.join(e.subset_of)}" if e.subset_of else ""
        typer.echo(f"{e.name:22s} {str(e.structure.extent):8s} {len(e.structure):4d} logs  "
                   f"yaw {e.pose.yaw_deg:6.1f}°  {e.description}{related}")


@corpus_app.command("build")
def build_command(
    out: Path = typer.Option(..., "--out", metavar="DIR",
                             help="Corpus folder (created; reused as a cache)."),
    angles: str = typer.Option("90,120,150,180,210", "--angles",
                               help="Arm stations in degrees, comma separated."),
    size: str = typer.Option("640x480", "--size", help="Image size WIDTHxHEIGHT."),
    spp: int = typer.Option(24, "--spp", help="Samples per pixel."),
    seed: int = typer.Option(0, "--seed", help="Root seed (same seed, same images)."),
    only: str | None = typer.Option(None, "--only",
                                    help="Build only these designs (comma separated names)."),
    workers: int = typer.Option(1, "--workers", help="Render in this many processes."),
    scheduler: str | None = SCHEDULER,
    randomise: bool = flag(False, "--randomise",
                           help="Randomise each structure's lights, wood and table, "
                                        "and jitter each view's camera."),
) -> None:
    """Render 5 views of each designed structure, with ground truth, into a corpus folder.

    Writes DIR/<name>/view<angle>.png|json|truth.json|ids.npz and DIR/corpus.json.
    Views already rendered with the same settings are skipped, so an interrupted
    build resumes where it stopped.
    """
    from rich.progress import BarColumn, TextColumn, TimeElapsedColumn

    from unseeable.corpus.build import build_corpus, plan_views
    from unseeable.fileio import check_output_folder
    from unseeable.render.settings import RenderSettings

    # The folder is a cache that fills view by view (each view written whole), so that an
    # interrupted build resumes: it is checked first, not staged.
    check_output_folder(out)
    names = [n.strip() for n in only.split(",") if n.strip()] if only else None
    options = dict(angles=parse_angles(angles), size=parse_size(size),
                   settings=RenderSettings(spp=spp), seed=seed, only=names,
                   randomise=randomise)
    total = len(plan_views(out, **options))
    progress = progress_bar(TextColumn("[bold]corpus[/] {task.description}"), BarColumn(),
                            TextColumn("{task.completed}/{task.total}"), TimeElapsedColumn())
    with open_scheduler(scheduler, workers=workers) as executor, \
            bar_from_first_report(progress, total=total) as update:

        def advance(item, rendered: bool) -> None:
            what = "rendered" if rendered else "cached"
            update(advance=1, description=f"{item.name} at {item.angle:g}° ({what})")

        report = build_corpus(out, workers=workers, executor=executor, progress=advance,
                              **options)
    seconds = sum(d.seconds for d in report.rendered)
    typer.echo(f"{len(report.rendered)} views rendered ({seconds:.1f} s of rendering), "
               f"{len(report.skipped)} already there, in {report.seconds:.1f} s")
    typer.echo(f"{report.entries} structures complete, listed in {report.manifest}")
