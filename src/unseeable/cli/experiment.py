"""``unseeable experiment``: the paper's experiments on a rendered corpus."""

from __future__ import annotations

from pathlib import Path

import typer
from rich.console import Console
from rich.progress import BarColumn, MofNCompleteColumn, TimeElapsedColumn

from unseeable.cli import app
from unseeable.cli.options import (
    CALIBRATION,
    JOINT_COST,
    STACKED_JOINT_COST,
    TIES,
    UNSUPPORTED_NOTCH_COST,
    bar_from_first_report,
    progress_bar,
)

experiment_app = typer.Typer(help="Rerun the paper's experiments on a rendered corpus.",
                             no_args_is_help=True)
app.add_typer(experiment_app, name="experiment")
console = Console(highlight=False, soft_wrap=True)


def _records(corpus: Path, out: Path, *, known_pose: bool, backend: str, workers: int,
             only: str | None, tolerance: bool, background: bool, ties: str,
             calibration: Path | None, presence_shift: bool = True,
             lines_once: bool = True, joint_cost: float, stacked_joint_cost: float,
             unsupported_notch_cost: float):
    from unseeable.evaluate.experiments import EvaluationSettings, evaluate_corpus

    settings = EvaluationSettings(backend=backend, known_pose=known_pose, tolerance=tolerance,
                                  background=background, ties=ties,
                                  presence_shift=presence_shift, lines_once=lines_once,
                                  joint_cost=joint_cost,
                                  stacked_joint_cost=stacked_joint_cost,
                                  unsupported_notch_cost=unsupported_notch_cost,
                                  calibration=None if calibration is None else str(calibration))
    names = [n.strip() for n in only.split(",")] if only else None
    bar = progress_bar("[progress.description]{task.description}", BarColumn(),
                       MofNCompleteColumn(), TimeElapsedColumn(), transient=False)
    with bar_from_first_report(bar) as update:
        return evaluate_corpus(
            corpus, out, settings=settings, workers=workers, only=names,
            progress=lambda done, total: update(completed=done, total=total,
                                                description="evaluating images"))


_CORPUS = typer.Option(..., "--corpus", help="A corpus folder made by `unseeable corpus build`.")
_OUT = typer.Option(None, "--out", help="Results folder (default: CORPUS/results).")
_KNOWN = typer.Option(False, "--known-pose", help="Use the views' recorded poses instead of "
                      "estimating them from the images.")
_WORKERS = typer.Option(2, "--workers", help="Images evaluated in parallel.")
_ONLY = typer.Option(None, "--only", help="Comma-separated structure names.")
_BACKEND = typer.Option("cpsat", "--backend", help="MAP backend.")
_BACKGROUND = typer.Option(True, "--background/--no-background",
                           help="Re-weigh detections by what lies behind each feature under "
                                "the estimate (the calibration's context models).")
_SHIFT = typer.Option(True, "--presence-shift/--no-presence-shift",
                      help="Estimate again under the detections shifted to agree with the "
                           "estimate (the calibration adapted to each photograph's look).")
_LINES = typer.Option(True, "--lines-once/--no-lines-once",
                      help="Count an edge that several segment features share on one image "
                           "line once under each estimate (else once per feature).")


@experiment_app.command("visibility")
def visibility(corpus: Path = _CORPUS, out: Path = _OUT, known_pose: bool = _KNOWN,
               workers: int = _WORKERS, only: str = _ONLY, backend: str = _BACKEND,
               background: bool = _BACKGROUND, ties: str = TIES,
               calibration: Path | None = CALIBRATION,
               presence_shift: bool = _SHIFT, lines_once: bool = _LINES,
               joint_cost: float = JOINT_COST,
               stacked_joint_cost: float = STACKED_JOINT_COST,
               unsupported_notch_cost: float = UNSUPPORTED_NOTCH_COST) -> None:
    """Error histograms: ground-truth ("manual") vs automatic visibility."""
    from unseeable.evaluate.experiments import visibility_experiment

    out = out or corpus / "results"
    records = _records(corpus, out, known_pose=known_pose, backend=backend, workers=workers,
                       only=only, tolerance=True, background=background, ties=ties,
                       calibration=calibration, presence_shift=presence_shift,
                       lines_once=lines_once, joint_cost=joint_cost,
                       stacked_joint_cost=stacked_joint_cost,
                       unsupported_notch_cost=unsupported_notch_cost)
    table = visibility_experiment(records, out)
    console.print(f"images: {table['evaluated']} of {table['images']} evaluated"
                  + (f" ({len(table['failed'])} failed)" if table["failed"] else ""))
    console.print(f"mean errors: manual {table['mean_errors_manual']:.2f}, "
                  f"automatic {table['mean_errors_automatic']:.2f}; "
                  f"max automatic {table['max_errors_automatic']}; "
                  f"exact: manual {table['exact_manual']:.0%}, "
                  f"automatic {table['exact_automatic']:.0%}")
    kinds = table["errors_by_kind"]["automatic"]
    console.print("automatic's errors by kind: "
                  + ", ".join(f"{kind} {count}" for kind, count in kinds.items())
                  + " (split: the same notches in other logs; extra / missing: notches "
                  "filled / left empty against the truth)")
    console.print(f"fixpoint: {table['mean_iterations']:.2f} estimates on average, "
                  f"{table['cycles']} cycles; visibility agreement with the truth "
                  f"{table['mean_visibility_agreement']:.1%}")
    console.print(f"time per image: median {table['median_seconds']:.2f} s")
    console.print(f"wrote {out / 'visibility.json'} and {out / 'visibility.png'}")


@experiment_app.command("confidence")
def confidence(corpus: Path = _CORPUS, out: Path = _OUT, known_pose: bool = _KNOWN,
               workers: int = _WORKERS, only: str = _ONLY, backend: str = _BACKEND,
               background: bool = _BACKGROUND, ties: str = TIES,
               calibration: Path | None = CALIBRATION,
               presence_shift: bool = _SHIFT, lines_once: bool = _LINES,
               joint_cost: float = JOINT_COST,
               stacked_joint_cost: float = STACKED_JOINT_COST,
               unsupported_notch_cost: float = UNSUPPORTED_NOTCH_COST) -> None:
    """False positives/negatives of the δ* = 0.2 test and the distribution of δ."""
    from unseeable.evaluate.experiments import confidence_experiment

    out = out or corpus / "results"
    records = _records(corpus, out, known_pose=known_pose, backend=backend, workers=workers,
                       only=only, tolerance=True, background=background, ties=ties,
                       calibration=calibration, presence_shift=presence_shift,
                       lines_once=lines_once, joint_cost=joint_cost,
                       stacked_joint_cost=stacked_joint_cost,
                       unsupported_notch_cost=unsupported_notch_cost)
    table = confidence_experiment(records, out)
    console.print(f"images: {table['images']}, correct estimates: {table['correct']}, "
                  f"confident: {table['confident']}")
    console.print(f"false positives (confident, wrong): {table['false_positives']}; "
                  f"false negatives (not confident, right): {table['false_negatives']} "
                  f"({table['false_negatives_exact_ties']} of them exact ties: another "
                  "structure as probable)")
    console.print(f"wrote {out / 'confidence.json'} and {out / 'confidence.png'}")
