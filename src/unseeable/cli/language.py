"""``unseeable describe`` and ``unseeable experiment language``: descriptions in English."""

from __future__ import annotations

from pathlib import Path

import typer
from rich.console import Console

from unseeable.cli import app
from unseeable.cli.experiment import (
    evaluation_settings,
    experiment_app,
    experiment_progress,
    structure_names,
)
from unseeable.cli.options import BACKEND, PRIOR

console = Console(highlight=False, soft_wrap=True)


@app.command()
def describe(
    structure: Path = typer.Argument(..., help="A structure file (unseeable/structure@1)."),
    view: Path | None = typer.Option(
        None, "--view", help="A view file (unseeable/view@1) with a pose: left and right as "
                             "its camera sees them (default: seen from the grid's -k side, "
                             "where i grows to the left)."),
) -> None:
    """Print the true sentences of a structure (its doors, windows, walls and how they
    relate), shortest first."""
    from unseeable.domain import load_structure
    from unseeable.errors import InputError
    from unseeable.language import Viewpoint
    from unseeable.language import describe as describe_structure

    s = load_structure(structure)
    viewpoint = None
    if view is not None:
        from unseeable.render.view import load_view

        v = load_view(view)
        if v.extent != s.extent:
            raise InputError(f"the view's extent {v.extent} is not the structure's "
                             f"{s.extent}", file=view, field="extent", value=str(v.extent))
        try:
            viewpoint = Viewpoint.from_view(v)
        except InputError as err:
            raise err.in_file(view) from None
    sentences = describe_structure(s, viewpoint=viewpoint)
    if not sentences:
        console.print("(no door, window or wall)")
    for sentence in sentences:
        console.print(sentence)


@experiment_app.command("language")
def language(
    corpus: Path = typer.Option(..., "--corpus",
                                help="A corpus folder made by `unseeable corpus build`."),
    out: Path | None = typer.Option(None, "--out", help="Results folder (default: "
                                                        "CORPUS/results)."),
    known_pose: bool = typer.Option(False, "--known-pose",
                                    help="Use the views' recorded poses instead of "
                                         "estimating them from the images."),
    workers: int = typer.Option(2, "--workers", help="Images evaluated in parallel."),
    only: str | None = typer.Option(None, "--only", help="Comma-separated structure names."),
    figure: bool = typer.Option(True, "--figure/--no-figure",
                                help="Also draw the four-panel demonstration."),
    time_limit: float = typer.Option(
        30.0, "--time-limit", help="Seconds per solve; the visibility fixpoint starts no new "
                                   "estimate after as many seconds."),
    prior: str = PRIOR,
    backend: str = BACKEND,
) -> None:
    """Errors without and with each image's true description (PNG + JSON), and the
    paper's four-panel demonstration: view 1, view 2, both, view 1 + one sentence."""
    from unseeable.evaluate.language import (
        evaluate_language,
        language_demonstration,
        language_experiment,
    )

    out = out or corpus / "results"
    settings = evaluation_settings(known_pose=known_pose, time_limit=time_limit, prior=prior,
                                   backend=backend)
    with experiment_progress("images × (alone, described)") as progress:
        records = evaluate_language(corpus, out, settings=settings, workers=workers,
                                    only=structure_names(only), progress=progress)
    table = language_experiment(records, out)
    console.print(f"images: {table['evaluated']} of {table['images']} evaluated"
                  + (f" ({len(table['failed'])} failed)" if table["failed"] else "")
                  + f", pose {'known' if known_pose else 'estimated'}")
    console.print(f"mean errors: alone {table['mean_errors_without']:.2f}, with the true "
                  f"description {table['mean_errors_with']:.2f}; exact "
                  f"{table['exact_without']} → {table['exact_with']}; better "
                  f"{table['better']}, same {table['same']}, worse {len(table['worse'])}")
    for w in table["worse"]:
        console.print(f"  worse: {w['name']} view {w['angle']:g}: {w['without']} → {w['with']}")
    console.print(f"time per image: median {table['median_seconds_without']:.1f} s alone, "
                  f"{table['median_seconds_with']:.1f} s described")
    console.print(f"wrote {out / 'language.json'} and {out / 'language.png'}")
    if figure:
        fig = language_demonstration(records, corpus, out, settings=settings.searching_in(out))
        console.print(f"figure: {fig['structure']}, views {fig['view1']:g}° and "
                      f"{fig['view2']:g}°, sentence “{fig['sentence']}”: "
                      + ", ".join(f"{p['title'].split(' ')[0]} {p['errors']}"
                                  for p in fig["panels"]) + " errors")
        console.print(f"wrote {out / 'language-figure.png'} and "
                      f"{out / 'language-figure.json'}")
