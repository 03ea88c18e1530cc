"""``unseeable experiment``: the paper's experiments on a rendered corpus."""

from __future__ import annotations

import contextlib
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import typer
from rich.console import Console
from rich.progress import BarColumn, MofNCompleteColumn, TimeElapsedColumn

from unseeable.cli import app
from unseeable.cli.options import (
    BACKEND,
    CALIBRATION,
    JOINT_COST,
    PRIOR,
    SCHEDULER,
    STACKED_JOINT_COST,
    TIES,
    UNSUPPORTED_NOTCH_COST,
    bar_from_first_report,
    flag,
    open_scheduler,
    progress_bar,
)

experiment_app = typer.Typer(help="Rerun the paper's experiments on a rendered corpus.",
                             no_args_is_help=True)
app.add_typer(experiment_app, name="experiment")
console = Console(highlight=False, soft_wrap=True)


def results_folder(corpus: Path, out: Path | None) -> Path:
    """The results folder (default CORPUS/results), checked before any work; it is a cache
    of per-image records that fills as images are evaluated, so it is not staged."""
    from unseeable.fileio import check_output_folder

    return check_output_folder(out or corpus / "results")


def structure_names(only: str | None) -> list[str] | None:
    """The structures an ``--only A,B`` option names (None: every one)."""
    return [n.strip() for n in only.split(",")] if only else None


def evaluation_settings(*, known_pose: bool, time_limit: float = 30.0, **options: Any):
    """The experiment commands' settings: the estimator's flat ``options`` (``prior``,
    ``backend``, …) with ``time_limit`` seconds per solve, and whether poses are known."""
    from unseeable.evaluate.experiments import EvaluationSettings
    from unseeable.pipeline import EstimateSettings

    return EvaluationSettings(
        estimate=EstimateSettings.from_options(time_limit=time_limit, **options),
        known_pose=known_pose)


@contextlib.contextmanager
def experiment_progress(description: str) -> Iterator[Callable[[int, int], None]]:
    """A ``progress(done, total)`` for an experiment's jobs: one bar labelled
    ``description``, shown from the first report on."""
    bar = progress_bar("[progress.description]{task.description}", BarColumn(),
                       MofNCompleteColumn(), TimeElapsedColumn(), transient=False)
    with bar_from_first_report(bar) as update:
        yield lambda done, total: update(completed=done, total=total, description=description)


def _records(corpus: Path, out: Path, *, known_pose: bool, workers: int, only: str | None,
             scheduler: str | None, **options):
    from unseeable.evaluate.experiments import evaluate_corpus

    settings = evaluation_settings(known_pose=known_pose, **options)
    with open_scheduler(scheduler, workers=workers) as executor, \
            experiment_progress("evaluating images") as progress:
        return evaluate_corpus(corpus, out, settings=settings, workers=workers,
                               executor=executor, only=structure_names(only),
                               progress=progress)


_CORPUS = typer.Option(..., "--corpus", help="A corpus folder made by `unseeable corpus build`.")
_OUT = typer.Option(None, "--out", metavar="DIR",
                    help="Results folder (default: CORPUS/results).")
_KNOWN = flag(False, "--known-pose", help="Use the views' recorded poses instead of "
              "estimating them from the images.")
_WORKERS = typer.Option(2, "--workers", help="Images evaluated in parallel.")
_ONLY = typer.Option(None, "--only", help="Comma-separated structure names.")

@experiment_app.command("visibility")
def visibility(corpus: Path = _CORPUS, out: Path = _OUT, known_pose: bool = _KNOWN,
               workers: int = _WORKERS, scheduler: str | None = SCHEDULER,
               only: str = _ONLY, prior: str = PRIOR,
               backend: str = BACKEND, calibration: Path | None = CALIBRATION,
               ties: str | None = TIES, joint_cost: float | None = JOINT_COST,
               stacked_joint_cost: float | None = STACKED_JOINT_COST,
               unsupported_notch_cost: float | None = UNSUPPORTED_NOTCH_COST) -> None:
    """Error histograms: ground-truth ("manual") vs automatic visibility."""
    from unseeable.evaluate.experiments import visibility_experiment

    out = results_folder(corpus, out)
    records = _records(corpus, out, known_pose=known_pose, workers=workers, only=only,
                       scheduler=scheduler, prior=prior, backend=backend,
                       calibration=calibration, ties=ties,
                       joint_cost=joint_cost, stacked_joint_cost=stacked_joint_cost,
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
               workers: int = _WORKERS, scheduler: str | None = SCHEDULER,
               only: str = _ONLY, prior: str = PRIOR,
               backend: str = BACKEND, calibration: Path | None = CALIBRATION,
               ties: str | None = TIES, joint_cost: float | None = JOINT_COST,
               stacked_joint_cost: float | None = STACKED_JOINT_COST,
               unsupported_notch_cost: float | None = UNSUPPORTED_NOTCH_COST) -> None:
    """False positives/negatives of the δ* test (the paper's 0.2) and the distribution of δ."""
    from unseeable.evaluate.experiments import confidence_experiment

    out = results_folder(corpus, out)
    records = _records(corpus, out, known_pose=known_pose, workers=workers, only=only,
                       scheduler=scheduler, prior=prior, backend=backend,
                       calibration=calibration, ties=ties,
                       joint_cost=joint_cost, stacked_joint_cost=stacked_joint_cost,
                       unsupported_notch_cost=unsupported_notch_cost)
    table = confidence_experiment(records, out)
    console.print(f"images: {table['images']}, correct estimates: {table['correct']}, "
                  f"confident: {table['confident']}")
    console.print(f"δ* test (the paper's): false positives (confident, wrong): "
                  f"{table['false_positives']}; "
                  f"false negatives (not confident, right): {table['false_negatives']} "
                  f"({table['false_negatives_exact_ties']} of them exact ties: another "
                  "structure as probable)")
    shipped = table.get("with_readings")
    if shipped is not None and table.get("reading_shift") is not None:
        console.print(f"with the reading test (s* = {table['reading_shift']:g}): "
                      f"false positives {shipped['false_positives']}; false negatives "
                      f"{shipped['false_negatives']}; confident {shipped['confident']}")
    console.print(f"wrote {out / 'confidence.json'} and {out / 'confidence.png'}")


@experiment_app.command("views")
def views(corpus: Path = _CORPUS, out: Path = _OUT, known_pose: bool = _KNOWN,
          workers: int = _WORKERS, scheduler: str | None = SCHEDULER, only: str = _ONLY,
          starts: int | None = typer.Option(
              None, "--starts", help="Starting stations per structure (a seeded choice; "
                                     "default every one)."),
          independent_poses: bool = flag(
              False, "--independent-poses/--shared-pose",
              help="Find each view's pose alone and register it by symbolic orientation, "
                   "instead of one pose in the shared table frame."),
          prior: str = PRIOR, backend: str = BACKEND) -> None:
    """Several views and partial disassembly: errors with 1, 2, … views of each structure,
    and with each disassembly view paired with the full one (PNG + JSON)."""
    from unseeable.evaluate.views import evaluate_views, views_experiment

    out = results_folder(corpus, out)
    settings = evaluation_settings(known_pose=known_pose, prior=prior, backend=backend,
                                   independent=independent_poses)
    with open_scheduler(scheduler, workers=workers) as executor, \
            experiment_progress("structures × starts") as progress:
        records = evaluate_views(corpus, out, settings=settings, workers=workers,
                                 executor=executor, only=structure_names(only),
                                 starts=starts, progress=progress)
    table = views_experiment(records, out)
    console.print(f"jobs: {table['jobs']}" + (f" ({len(table['failed'])} failed)"
                                              if table["failed"] else ""))
    console.print("mean errors by number of views: " + ", ".join(
        f"{n}: {m:.2f} (max {table['max_errors'][n]}, confident and wrong "
        f"{table['confident_wrong'][n]})" for n, m in table["mean_errors"].items()))
    structures = table["errors_all_views_by_structure"]
    console.print(f"all views: {table['structures_within_2_all_views']} of {len(structures)} "
                  "structures within 2 errors")
    d = table["disassembly"]
    if d["pairs"]:
        console.print(f"disassembly pairs: {d['pairs']}; mean errors {d['mean_errors_single']:.2f}"
                      f" alone → {d['mean_errors_pair']:.2f} with the pair; hidden logs right "
                      f"{d['hidden_right_single']} → {d['hidden_right_pair']} of "
                      f"{d['hidden_logs']}")
    console.print(f"wrote {out / 'views.json'} and {out / 'views.png'}")
